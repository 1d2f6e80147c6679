"""``bench/render.py``: the Cornell comparison labels Mitsuba's records with the sample counts it renders."""

from __future__ import annotations

import pytest

from tests.bench._load import bench_module


@pytest.fixture(scope="module")
def bench():
    yield from bench_module("render")


def test_ldsampler_counts_are_the_square_powers_of_two_it_renders(bench):
    """Mitsuba's ``ldsampler`` rounds a sample count up to 4, 16, 64, ...: the records say what was rendered
    (they said what was asked: 1, 2 and 4 were three records of one 4-spp image), other samplers take the
    count as asked."""
    asked = [1, 2, 4, 8, 16, 32, 64, 128, 1024, 2048]
    assert [bench._mitsuba_spp("ldsampler", s) for s in asked] == [4, 4, 4, 16, 16, 64, 64, 256, 1024, 4096]
    assert [bench._mitsuba_spp(None, s) for s in asked] == asked
    assert [bench._mitsuba_spp("independent", s) for s in asked] == asked
