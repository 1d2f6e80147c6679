"""Spectral RGL ``.bsdf`` files read as linear sRGB (``core/rgl/spectral.py``): the colour of a few reflectance
spectra against Mitsuba 3's own conversion in its RGB variants, and the cost of reading a spectral file.

    .venv/bin/python bench/rgl_spectral.py [--out results/bench]

* colours: ours (``spectrum @ rgb_weights``) and Mitsuba 3's ``mi.spectrum_list_to_srgb(..., d65=True)``
  (``scalar_rgb``; what Mitsuba does with a reflectance spectrum in a scene in an RGB variant — its
  ``measured`` plugin refuses spectral files there), sampled like the RGL database (360-1000 nm, 161 values);
* reading: a spectral file shaped like the database's (isotropic and anisotropic, 161 wavelengths) written
  from a Phong and a Ward export, the seconds of ``read_bsdf`` against the same file in RGB (median of 3,
  after one untimed read), and the file sizes.

Prints two tables, writes ``rgl_spectral.csv``.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from core.brdf import make_brdf  # noqa: E402
from core.rgl.export import tabulate  # noqa: E402
from core.rgl.material import read_bsdf, write_bsdf  # noqa: E402
from core.rgl.spectral import rgb_weights  # noqa: E402
from core.rgl.tensor_file import write_tensor_file  # noqa: E402

WAVELENGTHS = np.linspace(360.0, 1000.0, 161)
SPECTRA = {
    "flat 1": lambda wl: np.ones_like(wl),
    "flat 0.18": lambda wl: np.full_like(wl, 0.18),
    "reddish ramp": lambda wl: 0.15 + 0.7 / (1.0 + np.exp(-(wl - 590.0) / 25.0)),
    "greenish bump": lambda wl: 0.1 + 0.6 * np.exp(-0.5 * ((wl - 540.0) / 40.0) ** 2),
    "bluish ramp": lambda wl: 0.1 + 0.7 / (1.0 + np.exp((wl - 480.0) / 20.0)),
}
MODELS = {"phong": {"n": 100.0}, "ward": {"sx": 0.05, "sy": 0.25}}


def _spectral_copy(table, path: Path) -> None:
    fields = {k: v for k, v in table.fields().items() if k != "rgb"}
    grey = table.rgb[:, :, :1].astype(np.float64)
    spectrum = SPECTRA["reddish ramp"](WAVELENGTHS)
    fields["wavelengths"] = WAVELENGTHS.astype(np.float32)
    fields["spectra"] = (grey * spectrum[None, None, :, None, None]).astype(np.float32)
    write_tensor_file(path, fields)


def _seconds(path: Path) -> float:
    read_bsdf(path)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        read_bsdf(path)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/bench")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    rows = []
    print("| spectrum | ours (R, G, B) | Mitsuba 3 (R, G, B) | max abs. difference |")
    print("|---|---|---|---|")
    for name, spectrum in SPECTRA.items():
        values = spectrum(WAVELENGTHS)
        ours = values @ rgb_weights(WAVELENGTHS)
        theirs = np.array(mi.spectrum_list_to_srgb(list(WAVELENGTHS), list(values), False, True), dtype=float)
        diff = float(np.max(np.abs(ours - theirs)))
        print(
            f"| {name} | {ours[0]:.4f}, {ours[1]:.4f}, {ours[2]:.4f} | {theirs[0]:.4f}, {theirs[1]:.4f}, "
            f"{theirs[2]:.4f} | {diff:.1e} |"
        )
        rows.append(
            {"kind": "colour", "case": name, "ours": list(ours), "mitsuba": list(theirs), "diff": diff}
        )
    print()
    print("| model | slices | sample grid | spectral MB | RGB MB | read spectral s | read RGB s |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, params in MODELS.items():
            table = tabulate(make_brdf(name, params))
            rgb_path, spec_path = Path(tmp) / f"{name}.bsdf", Path(tmp) / f"{name}_spec.bsdf"
            write_bsdf(rgb_path, table)
            _spectral_copy(table, spec_path)
            t_spec, t_rgb = _seconds(spec_path), _seconds(rgb_path)
            mb_spec, mb_rgb = spec_path.stat().st_size / 1e6, rgb_path.stat().st_size / 1e6
            p, t, _, h, w = table.rgb.shape
            print(
                f"| {name} | {p}x{t} | {h}x{w} | {mb_spec:.1f} | {mb_rgb:.2f} | {t_spec:.3f} | {t_rgb:.3f} |"
            )
            rows.append(
                {
                    "kind": "read",
                    "case": name,
                    "spectral_mb": mb_spec,
                    "rgb_mb": mb_rgb,
                    "read_spectral_s": t_spec,
                    "read_rgb_s": t_rgb,
                }
            )
    keys = sorted({k for r in rows for k in r})
    with open(out / "rgl_spectral.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    print(f"\nwrote {out / 'rgl_spectral.csv'}")


if __name__ == "__main__":
    main()
