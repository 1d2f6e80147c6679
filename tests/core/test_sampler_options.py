"""Every strategy declares its options (``SamplerOption``), and ``make_sampler`` holds every caller to them:
unknown keys, wrong types and out-of-range values are errors naming the option and its range (issue 18)."""

from __future__ import annotations

import math
import warnings
from dataclasses import fields

import pytest

from core.brdf import make_brdf
from core.budget import BudgetError
from core.errors import FormerSamplerName, ParameterError
from core.sampling import make_sampler, sampler_names
from core.sampling.adaptive.records import TableOptions
from core.sampling.base import check_sampler_options, current_sampler, sampler_option_set

BAD_VALUES = [float("nan"), float("inf"), -1e308, 1e308, "x", None, [], {}, 2.5]


def bad_values_for(option) -> list:  # type: ignore[no-untyped-def]
    if option.kind == "choice":
        return ["nope", 1, None, True]
    if option.kind == "bool":
        return ["x", 2, 0.5, None, [], "2"]
    if option.kind == "cache":
        return [5, 0.5, None, [], ""]
    values = [
        v for v in BAD_VALUES if not (option.kind == "float" and v == 2.5 and option.lo <= 2.5 <= option.hi)
    ]
    values += [option.hi * 2 + 1, option.lo - 1]
    if option.lo_open:
        values.append(option.lo)
    if option.kind == "int":
        values.append(option.lo + 0.5)
    return values


@pytest.mark.parametrize("name", sampler_names())
def test_every_declared_option_refuses_bad_values_naming_itself_and_its_range(name):
    for option in sampler_option_set(name).values():
        for value in bad_values_for(option):
            with pytest.raises(ParameterError) as info:
                check_sampler_options(name, {option.name: value})
            text = str(info.value)
            assert f"'{option.name}'" in text and option.range_text() in text, (option, value, text)


@pytest.mark.parametrize("name", sampler_names())
def test_unknown_options_are_refused_with_the_list_of_known_ones(name):
    with pytest.raises(ParameterError) as info:
        check_sampler_options(name, {"theta_step": 1.0})
    declared = sampler_option_set(name)
    assert "theta_step" in str(info.value)
    assert ("takes no options" in str(info.value)) == (not declared)
    for known in declared:
        assert known in str(info.value)


def test_basic_strategies_take_no_options():
    brdf = make_brdf("phong")
    for name in ("uniform", "cosine", "analytic"):
        assert sampler_option_set(name) == {}
        with pytest.raises(ParameterError, match=f"the sampler '{name}' takes no options, got 'n_max'"):
            make_sampler(name, brdf, n_max=0.5)


def test_values_are_normalized():
    out = check_sampler_options(
        "adaptive_exact",
        {"n_max": "3", "rounds": "4", "threads": "true", "progressive": 0, "cache": "/tmp/x"},
    )
    assert out == {"n_max": 3.0, "rounds": 4, "threads": True, "progressive": False, "cache": "/tmp/x"}
    assert isinstance(out["rounds"], int) and math.isclose(out["n_max"], 3.0)


def test_adaptive_declaration_matches_its_table_options():
    """Every TableOptions field a user may set is declared, and nothing else (the bounds follow the mode)."""
    table = {f.name for f in fields(TableOptions)} - {"bounds"}
    for name in ("adaptive_exact", "adaptive_warp"):
        declared = set(sampler_option_set(name))
        assert declared - table == {"cache", "threads", "progressive"}
        assert table <= declared


def test_declared_extremes_are_accepted_by_the_strategies():
    """The declared ranges are the strategies' own: their ends build (on tiny settings) without a complaint."""
    brdf = make_brdf("lambert")
    tiny = {"n_theta_o": 1, "n_theta": 2, "n_phi": 2, "substeps": 1}
    make_sampler("uniform_cdf", brdf, **tiny, tol=0.0, defensive=0.5)
    make_sampler("compress_cdf", brdf, **tiny, tol=0.5, defensive=1e-9)
    small = {"n_theta_o": 1, "n_phi_o": 1, "n_theta_p": 2, "n_phi_p": 2, "terms_j": 1, "terms_k": 1}
    make_sampler("factored", brdf, **small, reparam=True, defensive=0.5)
    for n_max in (1.0 + 1e-9, 1000.0):
        assert make_sampler("adaptive_exact", brdf, n_max=n_max, cache=False).n_max == n_max


def test_tables_beyond_the_memory_are_refused_before_they_are_built(monkeypatch):
    monkeypatch.setenv("BRDF_STUDIO_MEMORY", str(1 << 20))  # a 1 MiB machine
    with pytest.raises(BudgetError, match=r"needs [\d.]+ MiB; this machine has 1 MiB available"):
        make_sampler("uniform_cdf", make_brdf("phong"))
    with pytest.raises(BudgetError, match="factored"):
        make_sampler("factored", make_brdf("phong"))


def test_the_former_name_adaptive_is_the_exact_sampler_with_a_notice_naming_adaptive_exact():
    brdf = make_brdf("phong")
    with pytest.warns(FormerSamplerName, match="'adaptive' is a former name of the sampler 'adaptive_exact'"):
        sampler = make_sampler("adaptive", brdf, n_max=3.0, cache=False)
    assert sampler.name == "adaptive_exact" and sampler.mode == "exact" and sampler.n_max == 3.0
    with pytest.warns(
        FormerSamplerName, match="with mode='warp' is a former name of the sampler 'adaptive_warp'"
    ):
        warp = make_sampler("adaptive", brdf, mode="warp", cache=False)
    assert warp.name == "adaptive_warp" and warp.mode == "warp"
    with pytest.warns(FormerSamplerName, match="'adaptive_exact'"):
        assert current_sampler("adaptive", {"mode": "exact", "n_max": 2}) == ("adaptive_exact", {"n_max": 2})
    with pytest.warns(FormerSamplerName, match="the sampler 'adaptive_warp' takes no mode='warp'"):
        assert make_sampler("adaptive_warp", brdf, mode="warp", cache=False).mode == "warp"
    with pytest.raises(
        ParameterError, match="option 'mode' of the sampler 'adaptive' must be one of exact, warp"
    ):
        current_sampler("adaptive", {"mode": "fast"})
    with pytest.raises(ParameterError, match="'adaptive_exact'"):
        current_sampler("adaptive_warp", {"mode": "exact"})


def test_the_current_names_give_no_notice_and_take_no_mode():
    brdf = make_brdf("phong")
    assert "adaptive" not in sampler_names() and {"adaptive_exact", "adaptive_warp"} <= set(sampler_names())
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        assert make_sampler("adaptive_exact", brdf, cache=False).mode == "exact"
        assert make_sampler("adaptive_warp", brdf, cache=False).mode == "warp"
        assert current_sampler("cosine", {}) == ("cosine", {})
    with pytest.raises(ParameterError, match="the sampler 'adaptive_exact' has no option 'mode'"):
        make_sampler("adaptive_exact", brdf, mode="exact")
