"""Fixtures of the core tests."""

from __future__ import annotations

import pytest

from core.sampling.adaptive import clear_memory_cache


@pytest.fixture
def private_tables(tmp_path, monkeypatch):
    """The adaptive sampler's tables in a folder of this test only, and none in memory before or after: a test
    sees its own builds (and cache hits), never another test's."""
    monkeypatch.setenv("BRDF_STUDIO_CACHE", str(tmp_path / "cache"))
    clear_memory_cache()
    yield
    clear_memory_cache()


@pytest.fixture
def bundled_merl_brdf():
    """The measured BRDF of the synthetic MERL file shipped in ``resources/materials`` (it must be there)."""
    from importlib import resources

    from core.merl import measured_brdf

    return measured_brdf(str(resources.files("resources.materials") / "red_plastic_ct.binary"))
