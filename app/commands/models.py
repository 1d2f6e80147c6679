"""``brdf-studio models``: the model library with parameters, defaults, bounds and traits.

``brdf-studio models [M ...]`` describes only the models named, registered names or model files (``.brdf``,
``.py``): ``brdf-studio models --json my.brdf`` shows what the file declares, as the other commands read it,
with the file's path, its SHA-256 and the notices of its load.
"""

from __future__ import annotations

import argparse
import json

from app.commands.eval import model_from_arg
from core.brdf import Model, Traits, all_models


def add_parser(sub: argparse._SubParsersAction) -> list[str]:
    p = sub.add_parser("models", help="list every BRDF model with its parameters and traits")
    p.add_argument(
        "models",
        nargs="*",
        metavar="M",
        help="describe only these: model names or model files (.brdf, .py); default every built-in model",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    return ["models"]


def describe(model: Model) -> dict:
    out = {
        "name": model.name,
        "label": model.label,
        "citation": model.citation,
        "traits": [t.name.lower() for t in Traits if t in model.traits and t.name],
        "analytic_sampler": model.sample is not None,
        "measured": model.measured,
        "parameters": [
            {
                "name": p.name,
                "label": p.label or p.name,
                "kind": p.kind,
                "default": model.defaults()[p.name],
                "min": p.lo,
                "max": p.hi,
                "unit": p.unit,
                "log_scale": p.log,
            }
            for p in model.params
        ],
        "notes": model.notes,
    }
    if model.source is not None:
        out["file"] = {
            "path": model.source.path,
            "sha256": model.source.digest,
            "notices": list(model.source.findings),
        }
    return out


def run(args: argparse.Namespace) -> int:
    chosen = [model_from_arg(m, args.command) for m in args.models] if args.models else all_models()
    models = [describe(m) for m in chosen]
    if args.json:
        print(json.dumps(models, indent=2))
        return 0
    for m in models:
        traits = ", ".join(m["traits"]) or "none"
        sampler = "analytic sampler" if m["analytic_sampler"] else "no analytic sampler"
        print(f"{m['name']:<20} {m['label']}  [{traits}; {sampler}]")
        for p in m["parameters"]:
            d = p["default"]
            dtext = ", ".join(f"{x:g}" for x in d) if isinstance(d, tuple | list) else f"{d:g}"
            rng = "true/false" if p["kind"] == "bool" else f"[{p['min']:g}, {p['max']:g}]"
            log = " log" if p["log_scale"] else ""
            unit = f" {p['unit']}" if p["unit"] else ""
            print(f"    {p['name']:<10} = {dtext:<18} {rng}{unit}{log}  {p['label']}")
    return 0
