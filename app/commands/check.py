"""``brdf-studio check``: the statistical validation report of a sampler (exit status 1 when anything fails).

For each outgoing angle (and, for the adaptive sampler, each ``n_max``): chi-square p-values on the sphere and
on the disk (1e6 samples by default, alpha = 0.01 Sidak-corrected over every test of the run), the integral of
the pdf, the per-trial acceptance and the leaf-bound violations (adaptive), and the relative standard deviation
of the weight ``f cos / pdf``. ``--all`` runs every model x applicable sampler x theta in {0, 30, 60, 80, 89}
x n_max in {1.3, 2, 3}.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from app.commands import _args
from app.commands._args import add_list, azimuth, name, number, seed, whole
from app.commands.eval import add_brdf_arguments, brdf_from_args
from core.brdf import LUMINANCE, all_models
from core.budget import check_memory, largest_within, round_down
from core.errors import ParameterError
from core.geometry import degrees_to_dir
from core.sampling import applicable_samplers, make_sampler
from core.sampling.base import check_sampler_options, current_sampler_name

THETAS = (0.0, 30.0, 60.0, 80.0, 89.0)
N_MAXES = (1.3, 2.0, 3.0)
BYTES_PER_SAMPLE = 200
"""Peak memory of one chi-square test per sample drawn (directions, pdfs, BRDF values and the histogram's
indices at once), an upper bound of what ``python bench/budgets.py`` measures."""
MAX_SAMPLES = 10**12


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "check", help="validate a sampler: chi-square tests, pdf integral, acceptance, weights"
    )
    add_brdf_arguments(p)
    p.add_argument(
        "--sampler",
        type=name,
        default="adaptive_exact",
        metavar="S",
        help="sampling strategy (default adaptive_exact)",
    )
    add_list(
        p, "--n-max", item=number(1.0, 1000.0, lo_open=True), metavar="X", help="adaptive n_max, (1, 1000]"
    )
    add_list(p, "--theta", item=_args.theta, metavar="DEG", help="outgoing angles in degrees, [0, 90]")
    p.add_argument("--phi", type=azimuth, default=17.0, metavar="DEG", help="outgoing azimuth (default 17)")
    p.add_argument(
        "--samples", type=whole(1, MAX_SAMPLES), default=1_000_000, metavar="N", help="samples per test (1e6)"
    )
    p.add_argument("--all", action="store_true", help="every model x sampler x theta x n_max")
    p.add_argument("--seed", type=seed, default=1, help="random seed (default 1)")
    return ["check"]


def validate(sampler, theta: float, phi: float, n: int, n_tests: int, seed: int) -> dict:
    """One row of the report."""
    # imported here: scipy.stats costs every other command's start 0.7 s
    from core.chi2 import chi2_test, integrate_pdf, sampler_functions

    wo = degrees_to_dir(theta, phi)
    sample, pdf = sampler_functions(sampler, wo)
    row: dict = {"theta": theta}
    ok = True
    for domain in ("sphere", "disk"):
        res = chi2_test(sample, pdf, n, domain=domain, seed=seed, n_tests=n_tests)
        row[f"p_{domain}"] = res.p_value
        if not res.passed:
            ok = False
            row.setdefault("reasons", []).append(f"{domain}: {res.reason}")
    row["integral"] = integrate_pdf(pdf, (32, 32), 1e-7)
    if abs(row["integral"] - 1.0) > 1e-3:
        ok = False
        row.setdefault("reasons", []).append(f"pdf integrates to {row['integral']:.6f}")
    batch = sampler.sample(wo, min(n, 100_000), seed + 1)
    wi, p = batch.wi, batch.pdf
    f = batch.f @ LUMINANCE
    w = np.where(p > 0, f * np.maximum(wi[:, 2], 0.0) / np.where(p > 0, p, 1.0), 0.0)
    row["weight_rel_std"] = float(np.std(w) / np.mean(w)) if np.mean(w) > 0 else float("nan")
    if hasattr(sampler, "acceptance"):
        row["acceptance"] = float(sampler.acceptance(wo)[0])
        row["violations"] = int(sampler.bound_violations)
        if row["violations"]:
            ok = False
            row.setdefault("reasons", []).append(f"{row['violations']} leaf-bound violations")
        n_max = getattr(sampler, "n_max", None)
        # a BRDF that is 0 for every wi at this wo has nothing to accept: the sampler draws the cosine density
        # (checked by the chi-square tests above), and its acceptance is not a guarantee's measure
        nothing = hasattr(sampler, "normalizer") and float(sampler.normalizer(wo)[0]) == 0.0
        if n_max and row["acceptance"] < 1.0 / n_max and theta < 90.0 and not nothing:
            ok = False
            row.setdefault("reasons", []).append(f"acceptance {row['acceptance']:.3f} < 1/n_max")
    row["passed"] = ok
    return row


def _fmt(row: dict) -> str:
    acc = f"{row['acceptance']:.3f}" if "acceptance" in row else "  -  "
    vio = f"{row['violations']}" if "violations" in row else "-"
    text = (
        f"  theta={row['theta']:5.1f}  p_sphere={row['p_sphere']:.3g}  p_disk={row['p_disk']:.3g}  "
        f"int_pdf={row['integral']:.6f}  acceptance={acc}  violations={vio}  "
        f"weight_rel_std={row['weight_rel_std']:.2e}  {'PASS' if row['passed'] else 'FAIL'}"
    )
    for r in row.get("reasons", []):
        text += f"\n      {r}"
    return text


def run(args: argparse.Namespace) -> int:
    thetas = list(args.theta or THETAS)
    n_maxes = args.n_max or (list(N_MAXES) if args.all else [2.0])
    check_memory(
        args.samples * BYTES_PER_SAMPLE,
        f"a chi-square test of {args.samples:.3g} samples",
        f"use --samples {round_down(largest_within(BYTES_PER_SAMPLE))} or fewer",
    )
    if args.all:
        jobs = [(m.bind(), s) for m in all_models() for s in applicable_samplers(m.bind())]
    else:
        brdf = brdf_from_args(args)
        args.sampler = current_sampler_name(args.sampler)
        # unknown sampler, or an option it does not take: a clear error before any work
        check_sampler_options(args.sampler, {"n_max": n_maxes[0]} if args.sampler == "adaptive_exact" else {})
        if args.n_max and args.sampler != "adaptive_exact":
            raise ParameterError(
                f"--n-max is an option of the 'adaptive_exact' sampler, not of '{args.sampler}'"
            )
        jobs = [(brdf, args.sampler)]
    runs = [(b, s, x) for b, s in jobs for x in (n_maxes if s == "adaptive_exact" else [None])]
    n_tests = 2 * len(runs) * len(thetas)
    failures = 0
    t0 = time.perf_counter()
    for brdf, strategy, n_max in runs:
        options = {"n_max": n_max} if n_max is not None else {}
        try:
            sampler = make_sampler(strategy, brdf, **options)
        except ParameterError as exc:
            print(f"{brdf.name} / {strategy}: skipped ({exc})")
            continue
        label = f"{brdf.name} / {strategy}" + (f" (n_max={n_max:g})" if n_max is not None else "")
        print(label, flush=True)
        for theta in thetas:
            row = validate(sampler, theta, args.phi, args.samples, n_tests, args.seed)
            failures += not row["passed"]
            print(_fmt(row), flush=True)
    print(
        f"{n_tests} chi-square tests, alpha=0.01 Sidak-corrected; "
        f"{'all passed' if failures == 0 else f'{failures} rows FAILED'} ({time.perf_counter() - t0:.0f} s)"
    )
    return 0 if failures == 0 else 1
