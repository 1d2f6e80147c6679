"""Resource budgets: what a request will need, checked before the work starts.

A request whose memory estimate exceeds what the machine can give is refused with one line naming the need,
the machine's memory and the option that lowers it (``needs 21.8 TiB; this machine has 23.4 GiB available;
use --samples 1e7 or fewer``), instead of failing half-way with ``MemoryError``. Estimates are upper bounds
per unit of work (bytes per sample, per pixel, per candidate) measured with ``python bench/budgets.py``;
where a request can be streamed in bounded chunks (``brdf-studio sample``), it is, and only the chunk counts.
"""

from __future__ import annotations

import math
import os

from core.errors import BrdfStudioError

MEMORY_FRACTION = 0.8
"""A request may use at most this fraction of the memory available when it starts (the rest is the
interpreter, the libraries, the page cache other processes rely on)."""


class BudgetError(BrdfStudioError):
    """A request needs more memory, disk or time than it may have."""


def format_bytes(n: float) -> str:
    """``23.4 GiB``, ``512 B``: binary units, three significant digits."""
    units = ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB", "ZiB", "YiB")
    if not math.isfinite(n):
        return "an unbounded amount"
    k = 0
    while abs(n) >= 1024.0 and k < len(units) - 1:
        n /= 1024.0
        k += 1
    return f"{n:.0f} {units[k]}" if k == 0 else f"{n:.3g} {units[k]}"


_BINARY = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30, "t": 1 << 40}


def parse_bytes(text: str, name: str) -> int:
    """A size as a user writes it: bytes (``4e9``) or binary units (``512M``, ``4G``, ``4GiB``); raises
    :class:`BudgetError` naming ``name`` for anything else (a budget silently ignored would be measured)."""
    t = text.strip().lower().removesuffix("ib").removesuffix("b")
    unit = t[-1:] if t[-1:] in _BINARY else ""
    try:
        value = float(t[: len(t) - len(unit)]) * _BINARY[unit]
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0:
        raise BudgetError(f"{name}={text!r}: expected a size in bytes, e.g. 4e9, 512M or 4G")
    return int(value)


def available_memory() -> int:
    """Bytes of memory this process can still use: ``MemAvailable`` of ``/proc/meminfo`` (Linux), capped by a
    cgroup limit if one is set; ``BRDF_STUDIO_MEMORY`` (bytes) overrides both (tests, shared machines)."""
    override = os.environ.get("BRDF_STUDIO_MEMORY")
    if override:
        return parse_bytes(override, "BRDF_STUDIO_MEMORY")
    avail = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except OSError:
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_AVPHYS_PAGES")
        except (ValueError, OSError, AttributeError):
            avail = 8 << 30  # unknown platform: assume a modest machine
    for limit_file in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = open(limit_file, encoding="ascii").read().strip()  # noqa: SIM115
        except OSError:
            continue
        if text.isdigit() and int(text) < avail:
            avail = int(text)
    return int(avail)


def check_memory(need: float, what: str, hint: str) -> None:
    """Refuse (:class:`BudgetError`) when ``need`` bytes exceed :data:`MEMORY_FRACTION` of the available
    memory: ``"<what> needs 21.8 TiB; this machine has 23.4 GiB available; <hint>"``."""
    have = available_memory()
    if not need <= MEMORY_FRACTION * have:
        raise BudgetError(
            f"{what} needs {format_bytes(need)}; this machine has {format_bytes(have)} available; {hint}"
        )


def largest_within(bytes_per_unit: float, fixed: float = 0.0) -> int:
    """The largest count of units whose estimate ``fixed + count * bytes_per_unit`` fits the budget (>= 0)."""
    room = MEMORY_FRACTION * available_memory() - fixed
    return max(0, int(room // bytes_per_unit)) if bytes_per_unit > 0 else 0


def round_down(n: int) -> str:
    """``n`` rounded down to one significant digit, written the way a user types it (``3e7``, ``500``)."""
    if n < 10:
        return str(max(0, n))
    exp = int(math.floor(math.log10(n)))
    lead = n // 10**exp
    return f"{lead}e{exp}" if exp >= 4 else str(lead * 10**exp)
