"""Fitting analytic models to measured materials (core.fit): noise-free recovery within the issue's 2 %, the
residual, and the measurements a fit compares against.

A material written from a model with known parameters is exact at its own nodes (MERL cell centres, RGL
sample-grid nodes), so the fit of the same model from other starting points must find the parameters; the
observed errors are ~1e-8 (bench/fit.py), the asserted bound is the issue's 2 %.
"""

from __future__ import annotations

import numpy as np
import pytest

from core.brdf import make_brdf
from core.errors import ParameterError
from core.fit import fit, measurements, parameter_errors
from core.measured import load_measured, write_measured
from core.rgl.export import ExportOptions, tabulate
from core.rgl.material import RGLBRDF

SMALL = ExportOptions(n_theta_i=10, n_phi_quadrant=5, vndf=(32, 32), samples=(16, 16), ndf=(32, 32))


def test_recovers_an_isotropic_model_from_a_merl_file(tmp_path):
    truth = {"n": 60.0, "ks": (0.3, 0.3, 0.3), "kd": (0.5, 0.3, 0.2)}
    write_measured(tmp_path / "phong.binary", make_brdf("phong", truth))
    result = fit(load_measured(tmp_path / "phong.binary"), "phong", "log", starts=1)
    errors = parameter_errors(result.params, truth)
    assert max(errors.values()) < 0.02, errors
    assert result.residual < 1e-6 and result.points > 100_000


@pytest.mark.parametrize("metric", ["log", "cbrt"])
def test_recovers_an_anisotropic_model_from_an_rgl_file(metric):
    truth = {"sx": 0.08, "sy": 0.3, "ks": (0.2, 0.2, 0.2), "kd": (0.4, 0.4, 0.3)}
    source = RGLBRDF(tabulate(make_brdf("ward", truth), SMALL))
    result = fit(source, "ward", metric, starts=2, seed=3)
    errors = parameter_errors(result.params, truth)
    assert max(errors.values()) < 0.02, errors
    assert result.residual < 1e-5


def test_a_wrong_model_leaves_a_residual():
    source = RGLBRDF(tabulate(make_brdf("ggx", {"alpha": 0.1}), SMALL))
    exact = fit(source, "ggx", starts=1, fixed={"eta": (0.2, 0.924, 1.102), "k": (3.912, 2.452, 2.142)})
    wrong = fit(source, "phong", starts=1)
    assert wrong.residual > 100 * max(exact.residual, 1e-9)
    assert wrong.relative_error > 0.01 > exact.relative_error


def test_measurements_cover_the_pairs_with_positive_weights():
    m = measurements(make_brdf("lambert"))
    assert np.all(m.wi[:, 2] > 0.0) and np.all(m.wo[:, 2] > 0.0) and np.all(m.weight > 0.0)
    # the weights approximate the measure of pairs of directions of the upper hemisphere, (2 pi)^2, halved:
    # phi_d in [0, pi) holds each pair once, its swap (wi <-> wo) being phi_d + pi
    assert m.weight.sum() == pytest.approx(0.5 * (2 * np.pi) ** 2, rel=0.05)


def test_bad_requests_are_parameter_errors():
    src = make_brdf("lambert")
    with pytest.raises(ParameterError, match="metric"):
        fit(src, "phong", "square")  # type: ignore[arg-type]
    with pytest.raises(ParameterError, match="no free parameter"):
        fit(src, "lambert", fixed={"kd": 0.5})
