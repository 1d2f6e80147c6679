"""``brdf-studio demo``: a readable summary of the model library on the bundled demo materials.

For each demo material (``resources/materials/materials.json``): the directional albedo at 0, 30, 60 and 80
degrees with its stated error, and the reciprocity, energy and non-negativity checks of ``core.analysis``.
"""

from __future__ import annotations

import argparse
import time

from app.commands._args import add_list
from core.analysis import albedo_table, energy_report, nonnegativity_report, reciprocity_report
from core.brdf import BRDF, all_models, make_brdf
from core.errors import BrdfStudioError

THETAS_DEG = (0.0, 30.0, 60.0, 80.0)


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser(
        "demo",
        help="summary of the model library on the bundled demo materials",
        description="Albedo tables and physical checks for every bundled demo material.",
    )
    add_list(p, "--material", split=False, metavar="NAME", help="only these materials (a list)")
    return ["demo"]


def _material_brdf(entry: dict) -> BRDF:
    if "measured" in entry:
        from core.merl import measured_brdf

        return measured_brdf(entry["measured"])
    return make_brdf(entry["model"], entry.get("params", {}))


def _describe(brdf: BRDF) -> str:
    if brdf.model.measured:
        return f"{brdf.model.label}, {getattr(brdf, 'path', '')}"
    values = ", ".join(
        f"{k}={'/'.join(f'{x:g}' for x in v) if isinstance(v, tuple) else f'{v:g}'}"
        for k, v in brdf.values.items()
    )
    return f"{brdf.model.label}: {values}"


def run(args: argparse.Namespace) -> int:
    from resources.materials import demo_materials

    start = time.perf_counter()
    materials = demo_materials()
    if args.material:
        known = {m["name"] for m in materials}
        for name in args.material:
            if name not in known:
                raise BrdfStudioError(f"unknown demo material '{name}'; known: {', '.join(sorted(known))}")
        materials = [m for m in materials if m["name"] in args.material]
    models = all_models()
    print("BRDF Studio: the model library on the bundled demo materials")
    print(f"{len(models)} registered models: {', '.join(m.name for m in models)}")
    for entry in materials:
        print()
        try:
            brdf = _material_brdf(entry)
        except BrdfStudioError as exc:  # a model still missing from the library: say so and go on
            print(f"== {entry['name']}: skipped ({exc})")
            continue
        print(f"== {entry['name']}  ({_describe(brdf)})")
        print(f"   {'theta':>5}  {'albedo R':>9} {'G':>9} {'B':>9}  {'± error':>8}")
        for r in albedo_table(brdf, THETAS_DEG):
            note = "" if r.converged else "  (budget spent)"
            print(
                f"   {r.theta_deg:5.0f}  {r.value[0]:9.5f} {r.value[1]:9.5f} {r.value[2]:9.5f}  "
                f"{max(r.error):8.1e}{note}"
            )
        print(f"   {reciprocity_report(brdf).summary()}")
        energy = energy_report(brdf)
        declared = "declared" if brdf.model.energy_conserving else "not declared"
        print(f"   {energy.summary()} [{declared} energy-conserving]")
        print(f"   {nonnegativity_report(brdf).summary()}")
    print()
    print(
        f"done in {time.perf_counter() - start:.1f} s (albedo: adaptive Gauss-Kronrod, see docs/analysis.md)"
    )
    return 0
