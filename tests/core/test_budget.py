"""The memory budget's override: ``BRDF_STUDIO_MEMORY`` in the forms a user writes, and a clear error for
anything else (an override silently ignored would leave the measured budget in force)."""

from __future__ import annotations

import pytest

from core.budget import BudgetError, available_memory, parse_bytes


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("4294967296", 4 << 30),
        ("4e9", 4_000_000_000),
        ("512M", 512 << 20),
        ("4G", 4 << 30),
        ("4GiB", 4 << 30),
        ("4gb", 4 << 30),
        (" 1.5T ", int(1.5 * (1 << 40))),
        ("64k", 64 << 10),
        ("0", 0),
    ],
)
def test_sizes_in_bytes_or_binary_units(text: str, expected: int) -> None:
    assert parse_bytes(text, "X") == expected


@pytest.mark.parametrize("text", ["lots", "", "G", "-1G", "nan", "inf", "4Q", "1e400"])
def test_anything_else_is_refused_by_name(text: str) -> None:
    with pytest.raises(BudgetError, match=r"X=.*: expected a size in bytes, e.g. 4e9, 512M or 4G"):
        parse_bytes(text, "X")


def test_the_override_sets_the_budget_or_names_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", "3G")
    assert available_memory() == 3 << 30
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", "three gigs")
    with pytest.raises(BudgetError, match="BRDF_STUDIO_MEMORY='three gigs'"):
        available_memory()
