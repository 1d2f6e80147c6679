"""The code's shape against the codebase targets: positional parameter reads, compiled functions' argument
counts, module sizes and the sampling toolkit's single search and guide builder.

    .venv/bin/python bench/code_shape.py [--out results/bench] [--max-args 12] [--max-lines 600]

Reads the sources as text and syntax trees (nothing is imported or run): every ``p[<digit>]`` read in
``core/models/``; every function decorated with ``njit``, ``kernel`` or another numba decorator in ``core/``
and ``renderer/``, with its argument count; every module of ``core/``, ``renderer/`` and ``app/`` with its
line count; the definitions of ``find_interval`` and of guide-table builders (functions named for a guide
that do not call the one builder, ``fill_guide``). Prints a table and writes ``code_shape.csv``; exits 1 when a
target is missed.
"""

from __future__ import annotations

import argparse
import ast
import csv
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("core", "renderer", "app")
COMPILED = re.compile(r"\b(njit|jit|kernel|vectorize|guvectorize|cfunc)\b")
POSITIONAL = re.compile(r"\bp\[\d")


def sources(*packages: str) -> list[Path]:
    return sorted(f for p in packages for f in (ROOT / p).rglob("*.py") if "__pycache__" not in f.parts)


def compiled_functions(files: list[Path]) -> list[tuple[str, str, int]]:
    """``(module, function, arguments)`` of every function with a numba decorator."""
    out = []
    for f in files:
        tree = ast.parse(f.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and any(
                COMPILED.search(ast.unparse(d)) for d in node.decorator_list
            ):
                args = node.args
                count = len(args.posonlyargs) + len(args.args) + len(args.kwonlyargs)
                out.append((str(f.relative_to(ROOT)), node.name, count))
    return out


def definitions(files: list[Path], pattern: re.Pattern[str]) -> list[str]:
    out = []
    for f in files:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and pattern.fullmatch(node.name):
                out.append(f"{f.relative_to(ROOT)}:{node.name}")
    return out


def guide_builders(files: list[Path], builder: str = "fill_guide") -> list[str]:
    """Functions named for a guide that write a table of their own: not ``builder``'s callers (directly or
    through another such function), and not readers (no array store)."""
    found: dict[str, tuple[str, set[str], bool]] = {}
    for f in files:
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and "guide" in node.name:
                calls = {
                    ast.unparse(c.func).split(".")[-1] for c in ast.walk(node) if isinstance(c, ast.Call)
                }
                stores = any(
                    isinstance(t, ast.Subscript) and isinstance(t.ctx, ast.Store) for t in ast.walk(node)
                )
                found[node.name] = (str(f.relative_to(ROOT)), calls, stores)
    users = {builder}
    while True:
        more = {name for name, (_, calls, _) in found.items() if calls & users} - users
        if not more:
            break
        users |= more
    return [
        f"{path}:{name}"
        for name, (path, _, stores) in found.items()
        if name == builder or (stores and name not in users)
    ]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    ap.add_argument("--max-args", type=int, default=12)
    ap.add_argument("--max-lines", type=int, default=600)
    a = ap.parse_args(argv)

    models = sources("core/models")
    positional = sum(len(POSITIONAL.findall(f.read_text(encoding="utf-8"))) for f in models)
    kernels = compiled_functions(sources("core", "renderer"))
    widest = max(kernels, key=lambda k: k[2])
    over_args = [k for k in kernels if k[2] > a.max_args]
    sizes = [
        (str(f.relative_to(ROOT)), len(f.read_text(encoding="utf-8").splitlines()))
        for f in sources(*PACKAGES)
    ]
    largest = max(sizes, key=lambda s: s[1])
    over_lines = [s for s in sizes if s[1] > a.max_lines]
    everything = sources(*PACKAGES)
    searches = definitions(everything, re.compile(r"find_interval"))
    guides = guide_builders(everything)

    rows = [
        ("positional parameter reads in core/models", positional, "0", positional == 0),
        (f"compiled functions over {a.max_args} arguments", len(over_args), "0", not over_args),
        ("most arguments of a compiled function", f"{widest[2]} ({widest[0]}: {widest[1]})", f"<= {a.max_args}",
         widest[2] <= a.max_args),
        (f"modules over {a.max_lines} lines", len(over_lines), "0", not over_lines),
        ("largest module", f"{largest[1]} ({largest[0]})", f"<= {a.max_lines}", largest[1] <= a.max_lines),
        ("definitions of find_interval", f"{len(searches)} ({', '.join(searches)})", "1", len(searches) == 1),
        ("guide-table builders", f"{len(guides)} ({', '.join(guides)})", "1", len(guides) == 1),
    ]  # fmt: skip
    width = max(len(r[0]) for r in rows)
    print(f"{'measure':<{width}}  value  (target)  met")
    for name, value, target, met in rows:
        print(f"{name:<{width}}  {value}  ({target})  {'yes' if met else 'NO'}")
    for path, name, count in sorted(over_args, key=lambda k: -k[2]):
        print(f"  over: {path}: {name} ({count} arguments)")
    for path, lines in sorted(over_lines, key=lambda s: -s[1]):
        print(f"  over: {path} ({lines} lines)")
    a.out.mkdir(parents=True, exist_ok=True)
    with open(a.out / "code_shape.csv", "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["measure", "value", "target", "met"])
        w.writerows(rows)
    print(f"wrote {a.out / 'code_shape.csv'}")
    return 0 if all(r[3] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
