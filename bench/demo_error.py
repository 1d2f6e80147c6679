"""Where a strategy's error on the demo scene comes from: by first-hit material, by path length, fireflies.

Every strategy renders the bundled demo scene at equal spp (one thread, CPU seconds measured), once with the
scene's path length and once with ``max_depth=1`` (direct light only: the camera ray's vertex, its light
sample and its BRDF sample hitting a light or the sky). The random numbers of a path are keyed by
``(seed, pass, path, bounce, role)`` and the samplers' draws by ``(seed, pass, wavefront, bounce, material,
slice)``, so the direct-only image is exactly the first bounce's share of the full image (checked: full -
direct >= 0), and ``full - direct`` is the indirect light (two or more bounces) of the same paths. Against
references rendered the same two ways (``analytic``, another seed, ``--ref-spp``), the squared error splits
exactly into direct + indirect + 2 x their covariance.

Each pixel is assigned to the material all its 16 jittered camera rays hit first (``sky`` for rays that
escape, ``edge`` when they hit more than one class), and the error is summed per class. The
references' own noise (per-pixel variance of their passes' means, divided by the number of passes: an upper
bound, since the pixel and light samples are stratified across passes) is subtracted from each MSE
("corrected"). Fireflies: the share of the MSE in the 0.1 % of pixels with the largest squared error.

Equal time is computed, not run: a strategy's MSE at equal CPU time is ``MSE x seconds`` (MSE falls as 1/spp
for an unbiased estimator), so ``ratio = sqrt(MSE_s t_s / (MSE_uniform t_uniform))`` is the RMSE ratio an
equal-time run would show (``bench/render.py``), component by component.

Prints tables; writes ``demo_error.csv`` (one row per strategy, component and class) under ``--out``.

    .venv/bin/python bench/demo_error.py [--size 256] [--spp 64] [--ref-spp 2048] [--seed 1] [--save]
        [--strategies uniform,cosine,analytic,adaptive_warp] [--option LABEL=S:k=v,p_area=P,mis=balance] [--ris 0]
        [--scene FILE]

Findings on the demo: docs/renderer.md, "Where the demo's remaining error comes from".
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from app.commands.render import demo_scene_path
from core.scene import load_scene, scene_digest
from renderer.render import prepare
from renderer.world import NO_MATERIAL

REF_SEED = 987_654
FIREFLY_SHARE = 0.001


def render_stats(scene, sampler: str, size: int, spp: int, seed: int, max_depth: int | None,  # type: ignore[no-untyped-def]
                 p_area: float | None = None, **kw):  # fmt: skip
    """Mean image ``(h, w, 3)``, per-pixel variance of that mean (from its passes' means), CPU seconds of the
    passes (preparation excluded), the job's material names and the first-hit classes. ``p_area``: next-event
    estimation picks the area lights with this probability and the sky with the rest (default: equal shares;
    the demo has no point lights)."""
    job = prepare(scene, sampler=sampler, width=size, height=size, seed=seed, max_depth=max_depth, threads=1,
                  warm_up_sweep=True, **kw)  # fmt: skip
    if p_area is not None:
        t = job.tracer
        assert t.p_point == 0.0 and not t.ris, "p_area: for a scene of area lights and a sky, without RIS"
        t.p_area, t.p_env = float(p_area), 1.0 - float(p_area)
    tracer = job.tracer
    n_pix = size * size
    total = np.zeros((n_pix, 3))
    total2 = np.zeros((n_pix, 3))
    done = passes = 0
    cpu = 0.0
    tracer.render_pass(1 << 20, 1)  # first-call costs outside the clock (a pass index never used below)
    while done < spp:
        batch = min(job.batch, spp - done)
        t0 = time.process_time()
        job.world.refresh_samplers()
        rad = tracer.render_pass(passes, batch, first_sample=done)
        cpu += time.process_time() - t0
        total += rad * batch
        total2 += (rad * rad) * batch  # pass means weighted by their size
        done += batch
        passes += 1
    mean = total / done
    # the spread of the passes' means (of job.batch samples each) over the number of passes, unbiased
    var_mean = np.maximum(total2 / done - mean * mean, 0.0) * job.batch / max(1, done - job.batch)
    names = [rt.name if rt is not None else "light" for rt in job.world.materials_by_index]
    classes = first_hit_classes(job, size)
    job.world.accel.close()
    return mean.reshape(size, size, 3), var_mean.reshape(size, size, 3), cpu, names, classes


def first_hit_classes(job, size: int, rays: int = 16) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Per pixel: the material index most of its ``rays`` jittered camera rays hit first; -2 for the sky,
    -3 for an edge (rays that hit more than one class), NO_MATERIAL for an emitter."""
    w = job.world
    n_pix = size * size
    pix = np.repeat(np.arange(n_pix), rays)
    rng = np.random.default_rng(5)
    o, d = job.tracer.camera.rays(pix, rng.random((len(pix), 2)))
    hits = w.accel.intersect(o, d)
    cls = np.where(hits.prim >= 0, w.tri_material[np.maximum(hits.prim, 0)], -2).reshape(n_pix, rays)
    out = np.empty(n_pix, dtype=np.int64)
    for p in range(n_pix):
        vals, counts = np.unique(cls[p], return_counts=True)
        k = int(np.argmax(counts))
        out[p] = vals[k] if counts[k] == rays else -3
    return out.reshape(size, size)


def reference(scene, size: int, spp: int, max_depth: int | None, out: Path, **kw):  # type: ignore[no-untyped-def]
    """Cached analytic reference (mean, variance of the mean)."""
    key = scene_digest(scene, size, spp, max_depth, REF_SEED, kw)[:10]
    path = out / f"demo_error_ref_{size}_{spp}spp_d{max_depth}_{key}.npz"
    if path.is_file():
        z = np.load(path)
        return z["mean"], z["var"]
    t0 = time.perf_counter()
    mean, var, cpu, _, _ = render_stats(scene, "analytic", size, spp, REF_SEED, max_depth, **kw)
    np.savez_compressed(path, mean=mean, var=var)
    print(f"reference max_depth={max_depth}: {spp} spp, {cpu:.0f} s CPU, {time.perf_counter() - t0:.0f} s "
          f"-> {path}", file=sys.stderr)  # fmt: skip
    return mean, var


def split(
    err2: np.ndarray, refvar: np.ndarray, classes: np.ndarray, names: dict[int, str]
) -> dict[str, tuple]:
    """Per class: (share of the image's squared error, corrected MSE over the whole image's pixel count)."""
    n = err2.shape[0] * err2.shape[1] * 3
    out = {}
    for c in sorted(np.unique(classes)):
        m = classes == c
        out[names[int(c)]] = (float(err2[m].sum()), float(refvar[m].sum()), int(m.sum()))
    out["all"] = (float(err2.sum()), float(refvar.sum()), int(classes.size))
    return {k: (raw / n, max(raw - rv, 0.0) / n, px) for k, (raw, rv, px) in out.items()}


def fireflies(err2: np.ndarray, share: float = FIREFLY_SHARE) -> float:
    """Share of the squared error in the ``share`` of pixels with the largest squared error."""
    per_px = err2.sum(axis=2).ravel()
    k = max(1, int(round(share * per_px.size)))
    return float(np.sort(per_px)[-k:].sum() / max(per_px.sum(), 1e-300))


def firefly_classes(
    err2: np.ndarray, classes: np.ndarray, names: dict[int, str], share: float = FIREFLY_SHARE
) -> str:
    """The first-hit classes of the ``share`` of pixels with the largest squared error, with their share of
    the image's squared error."""
    per_px = err2.sum(axis=2).ravel()
    k = max(1, int(round(share * per_px.size)))
    top = np.argsort(per_px)[-k:]
    cls = classes.ravel()[top]
    total = max(per_px.sum(), 1e-300)
    parts = sorted(((per_px[top][cls == c].sum() / total, int(c)) for c in np.unique(cls)), reverse=True)
    return ", ".join(f"{names[c][:14]} {v:.2f}" for v, c in parts)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", help="another scene file (default: the bundled demo)")
    ap.add_argument("--size", type=int, default=256, help="image width and height (default 256)")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel of each strategy (default 64)")
    ap.add_argument("--ref-spp", type=int, default=2048, help="samples per pixel of the references")
    ap.add_argument("--strategies", default="uniform,cosine,analytic,adaptive_warp")
    ap.add_argument("--ris", type=int, default=0, help="RIS candidates for the sky (every strategy)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--option", action="append", default=[], metavar="LABEL=S:k=v,...",
        help="an extra row: strategy S with sampler options (or ris=M, p_area=P, mis=balance), labelled LABEL (repeatable)",
    )  # fmt: skip
    ap.add_argument(
        "--save", action="store_true", help="also write each strategy's images (demo_error_S.npz)"
    )
    ap.add_argument("--out", default="results/bench")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scene = load_scene(args.scene or demo_scene_path())
    full_depth = scene.render.max_depth
    ref_full, var_full = reference(scene, args.size, args.ref_spp, full_depth, out)
    ref_dir, var_dir = reference(scene, args.size, args.ref_spp, 1, out)
    # the indirect light's noise, taking the direct and indirect light of a path as uncorrelated (their errors'
    # covariance is measured below: small)
    var_ind = np.maximum(var_full - var_dir, 0.0)

    runs: list[tuple[str, str, dict, int]] = [(s, s, {}, args.ris) for s in args.strategies.split(",")]
    for item in args.option:
        label, _, rest = item.partition("=")
        strat, _, kv = rest.partition(":")
        opts: dict = {}
        ris = args.ris
        for pair in filter(None, kv.split(",")):
            k, _, v = pair.partition("=")
            if k == "ris":
                ris = int(v)
                continue
            if k == "p_area":
                opts["@p_area"] = float(v)
                continue
            if k == "mis":
                opts["@mis"] = v
                continue
            try:
                opts[k] = int(v) if v.lstrip("-").isdigit() else float(v)
            except ValueError:
                opts[k] = v
        runs.append((label, strat, opts, ris))

    rows: list[dict] = []
    summary: dict[str, dict] = {}
    for label, strat, opts, ris in runs:
        p_area = opts.pop("@p_area", None)
        run_scene = scene
        if "@mis" in opts:  # the MIS heuristic of this row ("power" or "balance")
            run_scene = scene.model_copy(deep=True)
            run_scene.render.mis = opts.pop("@mis")
        options = {**scene.render.sampler_options, **opts}
        kw = {"sampler_options": options, "ris_candidates": ris, "p_area": p_area}
        img, _, cpu, names, classes = render_stats(
            run_scene, strat, args.size, args.spp, args.seed, full_depth, **kw
        )
        dimg, _, cpu_d, _, _ = render_stats(run_scene, strat, args.size, args.spp, args.seed, 1, **kw)
        neg = float(np.minimum(img - dimg, 0.0).min())
        cls_names = {i: n for i, n in enumerate(names)} | {-2: "sky", -3: "edge", NO_MATERIAL: "light"}
        e_full, e_dir = img - ref_full, dimg - ref_dir
        e_ind = e_full - e_dir
        parts = {
            "full": split(e_full**2, var_full, classes, cls_names),
            "direct": split(e_dir**2, var_dir, classes, cls_names),
            "indirect": split(e_ind**2, var_ind, classes, cls_names),
        }
        cov = float(np.mean(e_dir * e_ind))
        where = {c: firefly_classes(e**2, classes, cls_names) for c, e in
                 (("full", e_full), ("direct", e_dir), ("indirect", e_ind))}  # fmt: skip
        if args.save:
            np.savez_compressed(out / f"demo_error_{label}.npz", full=img, direct=dimg, classes=classes)
        summary[label] = {"cpu": cpu, "cpu_direct": cpu_d, "parts": parts, "cov": cov, "neg": neg,
                          "where": where, "fire": {"full": fireflies(e_full**2), "direct": fireflies(e_dir**2),
                                   "indirect": fireflies(e_ind**2)}}  # fmt: skip
        print(f"  {label}: {args.spp} spp, {cpu:.1f} s CPU (direct only {cpu_d:.1f} s), "
              f"RMSE {np.sqrt(parts['full']['all'][0]):.4g}, min(full - direct) {neg:.2g}", file=sys.stderr)  # fmt: skip
        for comp, table in parts.items():
            for cls, (raw, corr, px) in table.items():
                rows.append({"strategy": label, "sampler": strat, "ris": ris, "spp": args.spp, "cpu_s": cpu,
                             "component": comp, "class": cls, "pixels": px, "mse_raw": raw, "mse": corr,
                             "fireflies": summary[label]["fire"][comp] if cls == "all" else ""})  # fmt: skip

    base = summary.get("uniform")
    print(f"\ndemo {args.size}x{args.size}, {args.spp} spp each, one thread; references {args.ref_spp} spp "
          f"(analytic, seed {REF_SEED}); MSE corrected for the references' noise")  # fmt: skip
    print(f"{'strategy':<16}{'CPU s':>7}{'MSE full':>10}{'direct':>10}{'indirect':>10}{'2cov':>10}"
          f"{'fire full':>10}{'fire dir':>9}{'fire ind':>9}{'eq-t ratio':>11}{'dir':>7}{'ind':>7}")  # fmt: skip
    for label, s in summary.items():
        p = s["parts"]
        mf, md, mi = p["full"]["all"][1], p["direct"]["all"][1], p["indirect"]["all"][1]

        def ratio(comp: str, s=s) -> str:
            if base is None:
                return "-"
            mu = base["parts"][comp]["all"][1]
            return (
                f"{np.sqrt(s['parts'][comp]['all'][1] * s['cpu'] / (mu * base['cpu'])):.3f}"
                if mu > 0
                else "-"
            )

        print(f"{label:<16}{s['cpu']:>7.1f}{mf:>10.3g}{md:>10.3g}{mi:>10.3g}{2 * s['cov']:>10.2g}"
              f"{s['fire']['full']:>10.2f}{s['fire']['direct']:>9.2f}{s['fire']['indirect']:>9.2f}"
              f"{ratio('full'):>11}{ratio('direct'):>7}{ratio('indirect'):>7}")  # fmt: skip
    print(f"\nfireflies (the {FIREFLY_SHARE:.1%} of pixels with the largest squared error): their first-hit "
          "classes and share of the image's squared error")  # fmt: skip
    for label, s in summary.items():
        for comp, txt in s["where"].items():
            print(f"  {label:<16}{comp:<9}{txt}")
    classes_all = list(dict.fromkeys(r["class"] for r in rows if r["class"] != "all"))
    for comp in ("full", "direct", "indirect"):
        print(f"\n{comp}: corrected MSE x 1e4 by first-hit class (pixels), equal-time ratio to uniform in ()")
        print(f"{'class':<40}" + "".join(f"{lab[:14]:>16}" for lab in summary))
        for cls in classes_all:
            cells = []
            for s in summary.values():
                _, corr, px = s["parts"][comp].get(cls, (0.0, 0.0, 0))
                r = ""
                if base is not None and cls in base["parts"][comp] and base["parts"][comp][cls][1] > 0:
                    r = f"({np.sqrt(corr * s['cpu'] / (base['parts'][comp][cls][1] * base['cpu'])):.2f})"
                cells.append(f"{corr * 1e4:>9.3f}{r:>7}")
            px = next(s["parts"][comp][cls][2] for s in summary.values() if cls in s["parts"][comp])
            print(f"{(cls[:30] + f' ({px})'):<40}" + "".join(f"{c:>16}" for c in cells))
    keys = list(rows[0])
    with open(out / "demo_error.csv", "w") as fh:
        fh.write(",".join(keys) + "\n")
        for r in rows:
            fh.write(",".join(v if isinstance(v, str) else f"{v:.6g}" for v in (r[k] for k in keys)) + "\n")
    print(f"\nwrote {out / 'demo_error.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
