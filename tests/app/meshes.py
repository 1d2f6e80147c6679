"""Small mesh files written for the app tests."""

from __future__ import annotations

from pathlib import Path

CUBE_V = [(x, y, z) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
CUBE_F = [
    (1, 3, 4, 2), (5, 6, 8, 7), (1, 2, 6, 5), (3, 7, 8, 4), (1, 5, 7, 3), (2, 4, 8, 6),
]  # fmt: skip


def write_obj(path: Path, groups: dict[str, tuple[float, float, float]]) -> Path:
    """An OBJ with one unit cube per group, each shifted by its offset."""
    lines = []
    base = 0
    for name, (dx, dy, dz) in groups.items():
        lines.append(f"o {name}")
        lines += [f"v {x + dx} {y + dy} {z + dz}" for x, y, z in CUBE_V]
        for quad in CUBE_F:
            a, b, c, d = (base + i for i in quad)
            lines += [f"f {a} {b} {c}", f"f {a} {c} {d}"]
        base += len(CUBE_V)
    path.write_text("\n".join(lines) + "\n")
    return path
