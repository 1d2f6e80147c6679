"""Poulin-Fournier (1990) cylinders: reference values from a brute-force discretization of the cross-section
with explicit ray casting against the cylinders (independent of the kernel's interval geometry), a value
written out by hand, the flat limits (h -> 0, d large), grazing directions and anisotropy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.brdf import get_model
from core.geometry import degrees_to_dir

MODEL = get_model("poulin_fournier")


def _local_brdf(nrm, wi, wo, n, ks, kd):
    """Lambert + Lewis-normalized Phong for normals ``nrm (k, 3)``."""
    ni, no = nrm @ wi, nrm @ wo
    cos_a = 2.0 * ni * no - wi @ wo
    return kd / math.pi + ks * (n + 2) / (2 * math.pi) * np.maximum(cos_a, 0.0) ** n


def _unblocked(py, pz, qy, qz, d, h, own):
    """True where the 2D ray q + t (py, pz), t > 0, misses every cylinder (circles of radius 1 centred at
    (j d, h - 1)); ``own`` marks the cylinder a cap point lies on (its own circle is skipped: the point faces
    the ray, and a convex arc cannot block itself)."""
    ok = np.ones(qy.shape, dtype=bool)
    for j in range(-3, 4):
        cy, cz = j * d, h - 1.0
        if own is not None and j == 0:
            continue
        ry, rz = qy - cy, qz - cz
        b = ry * py + rz * pz
        c = ry * ry + rz * rz - 1.0
        disc = b * b - c
        t_far = -b + np.sqrt(np.maximum(disc, 0.0))
        ok &= ~((disc > 0.0) & (t_far > 1e-12))
    return ok


def _escapes_groove(py, pz, qy, qz, h):
    """True where the ray from a point of the groove wall (circle of radius 1 centred at (0, 1 - h), cut into
    the plane z = 0) leaves the circle above the plane, i.e. is not stopped by the groove's other wall."""
    ry, rz = qy, qz - (1.0 - h)
    b = ry * py + rz * pz
    c = ry * ry + rz * rz - 1.0
    t_far = -b + np.sqrt(np.maximum(b * b - c, 0.0))
    return qz + t_far * pz >= -1e-12


def _brute(wi, wo, d, h, n, ks, kd, count=400_000, grooves=False):
    """f = 1/(d cos_i cos_o) sum over one period of f_loc (N.wi)+ (N.wo)+ V_i V_o ds (midpoint rule)."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    beta_m = math.acos(1.0 - h)
    w = math.sqrt(h * (2.0 - h))
    # cap of the cylinder at y = 0
    beta = -beta_m + (np.arange(count) + 0.5) * (2 * beta_m / count)
    cap = np.stack([np.zeros_like(beta), np.sin(beta), np.cos(beta)], axis=-1)
    qy, qz = np.sin(beta), h - 1.0 + np.cos(beta)
    if grooves:  # the wall point whose inward normal has angle beta: centre minus normal
        qy, qz = -np.sin(beta), (1.0 - h) - np.cos(beta)
    ds_cap = 2 * beta_m / count
    # flat part between the caps at y = 0 and y = d
    y = w + (np.arange(count) + 0.5) * ((d - 2 * w) / count)
    ds_flat = (d - 2 * w) / count
    total = 0.0
    for nrm, py_pts, pz_pts, ds, own in (
        (cap, qy, qz, ds_cap, True),
        (np.tile([0.0, 0.0, 1.0], (count, 1)), y, np.zeros_like(y), ds_flat, None),
    ):
        ni, no = nrm @ wi, nrm @ wo
        vis = (ni > 0) & (no > 0)
        for v in (wi, wo):
            a = math.hypot(v[1], v[2])
            if not grooves:
                vis &= _unblocked(v[1] / a, v[2] / a, py_pts, pz_pts, d, h, own)
            elif own:  # nothing rises above the plane: only a groove's own wall can block
                vis &= _escapes_groove(v[1] / a, v[2] / a, py_pts, pz_pts, h)
        total += np.sum(np.where(vis, _local_brdf(nrm, wi, wo, n, ks, kd) * ni * no, 0.0)) * ds
    return total / (d * wi[2] * wo[2])


def _f(values, wi, wo):
    return MODEL.bind(values).eval(np.asarray(wo), np.asarray(wi))[0, 0]


@pytest.mark.parametrize(
    ("values", "wi_deg", "wo_deg"),
    [
        # tall cylinders, strong shadowing and masking across the cylinders, glossy
        ({"d": 2.5, "h": 0.6, "n": 20.0, "ks": 0.7, "kd": 0.3}, (60.0, 90.0), (50.0, 250.0)),
        # half cylinders touching, light along one side, view from the other, partly along the axis
        ({"d": 2.0, "h": 1.0, "n": 5.0, "ks": 0.5, "kd": 0.5}, (70.0, 100.0), (40.0, 300.0)),
        # back-scattering: light and view on the same side of the cylinders, both partly shadowed/masked
        ({"d": 2.2, "h": 0.8, "n": 50.0, "ks": 0.6, "kd": 0.4}, (65.0, 80.0), (72.0, 95.0)),
        # grooves: deep, light and view across them on opposite sides, and on the same side
        ({"d": 2.5, "h": 0.7, "n": 30.0, "ks": 0.6, "kd": 0.4, "grooves": True}, (60.0, 90.0), (45.0, 260.0)),
        ({"d": 2.0, "h": 1.0, "n": 8.0, "ks": 0.5, "kd": 0.5, "grooves": True}, (75.0, 80.0), (50.0, 120.0)),
        # the seed's setting, light near grazing across the cylinders (shadowing by the low caps)
        ({}, (85.0, 90.0), (30.0, 275.0)),
    ],
)
def test_matches_brute_force_ray_casting(values, wi_deg, wo_deg):
    full = MODEL.resolve(values)
    wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
    expected = _brute(
        wi, wo, full["d"], full["h"], full["n"], full["ks"][0], full["kd"][0], grooves=bool(full["grooves"])
    )
    np.testing.assert_allclose(_f(values, wi, wo), expected, rtol=2e-4)


def test_reference_value_written_out():
    # Normal light and view, kd = 1, ks = 0, h = 0.5, d = 3: nothing is shadowed; N.wi = N.wo = cos(beta).
    # beta_m = acos(0.5) = pi/3 = 1.0471976, w = sqrt(0.75) = 0.8660254;
    # int_cap cos^2 = beta_m + sin(2 beta_m)/2 = 1.0471976 + 0.4330127 = 1.4802103; flat d - 2w = 1.2679492;
    # f = (1/pi) (1.4802103 + 1.2679492) / 3 = 0.9160532 / pi = 0.2915888.
    got = _f({"kd": 1.0, "ks": 0.0, "h": 0.5, "d": 3.0}, degrees_to_dir(0.0), degrees_to_dir(0.0))
    np.testing.assert_allclose(got, 0.2915888, rtol=1e-6)


def _flat(wi, wo, n, ks, kd):
    cos_a = 2 * wi[2] * wo[2] - wi @ wo
    return kd / math.pi + ks * (n + 2) / (2 * math.pi) * max(cos_a, 0.0) ** n


@pytest.mark.parametrize("values", [{"h": 1e-4}, {"d": 100.0, "h": 0.3, "ks": 0.0, "kd": 0.5}])
def test_flat_limits(values):
    # h -> 0: the caps flatten (normals within 0.8 degrees) and the model tends to the plane's Lambert + Phong.
    # d large: the caps cover 2w/d = 1.4 % of the width; the diffuse part differs from the plane's by about
    # that fraction. (The specular part does not: tilted cap normals still catch highlights the plane has not.)
    full = MODEL.resolve(values)
    tol = 2e-3 if values.get("d", 2.0) < 50 else 3e-2
    for wi_deg, wo_deg in (
        ((30.0, 0.0), (30.0, 180.0)),
        ((50.0, 40.0), (20.0, 250.0)),
        ((70.0, 90.0), (10.0, 0.0)),
    ):
        wi, wo = degrees_to_dir(*wi_deg), degrees_to_dir(*wo_deg)
        expected = _flat(wi, wo, full["n"], full["ks"][0], full["kd"][0])
        np.testing.assert_allclose(_f(values, wi, wo), expected, rtol=tol, atol=1e-9)


def test_grazing_directions_are_finite_and_bounded():
    brdf = MODEL.bind({"h": 1.0, "d": 2.0, "n": 1e4})
    for theta in (89.0, 89.9, 89.999, 89.99999):
        for phi in (0.0, 45.0, 90.0, 270.0):
            for theta_o, phi_o in ((theta, phi + 180.0), (30.0, 90.0), (theta, phi)):
                f = brdf.eval(degrees_to_dir(theta_o, phi_o), degrees_to_dir(theta, phi))[0]
                assert np.all(np.isfinite(f)) and np.all(f >= 0.0)
    # The diffuse part stays bounded at grazing incidence: the lit part of the caps shrinks with cos(theta_i).
    matte = MODEL.bind({"h": 1.0, "d": 2.0, "ks": 0.0, "kd": 1.0})
    vals = [
        matte.eval(degrees_to_dir(20.0, 270.0), degrees_to_dir(t, 90.0))[0, 0] for t in (80.0, 89.9, 89.99999)
    ]
    assert max(vals) < 1.0


def test_anisotropic_highlight_stretches_across_the_cylinders():
    # Light at 40 degrees across the cylinders (phi = 90): tilting the view out of the mirror direction across
    # the cylinders (phi_o = 270, theta_o changed) keeps a highlight from the cap normals, along the axis not.
    brdf = MODEL.bind({"h": 1.0, "d": 2.0, "n": 200.0, "kd": 0.0, "ks": 1.0})
    wi = degrees_to_dir(40.0, 90.0)
    across = brdf.eval(degrees_to_dir(60.0, 270.0), wi)[0, 0]
    along = brdf.eval(degrees_to_dir(40.0, 270.0 + 20.0), wi)[0, 0]
    assert across > 100.0 * along
    rotated = brdf.eval(degrees_to_dir(60.0, 0.0), degrees_to_dir(40.0, 180.0))[0, 0]
    assert not np.isclose(across, rotated, rtol=1e-3)


@pytest.mark.slow
def test_matches_brute_force_on_random_settings(rng):
    for i in range(16):
        values = {
            "d": float(np.exp(rng.uniform(np.log(2.0), np.log(8.0)))),
            "h": float(np.exp(rng.uniform(np.log(0.01), 0.0))),
            "n": float(np.exp(rng.uniform(0.0, np.log(1e4)))),
            "ks": 0.7,
            "kd": 0.3,
            "grooves": bool(i % 2),
        }
        wi = degrees_to_dir(rng.uniform(0.0, 89.0), rng.uniform(0.0, 360.0))
        wo = degrees_to_dir(rng.uniform(0.0, 89.0), rng.uniform(0.0, 360.0))
        if i % 3 == 0:  # near the mirror direction, where the Phong lobe matters
            wo = np.array([-wi[0], -wi[1], wi[2]]) + rng.normal(scale=0.05, size=3)
            wo[2] = abs(wo[2])
            wo /= np.linalg.norm(wo)
        expected = _brute(
            wi,
            wo,
            values["d"],
            values["h"],
            values["n"],
            0.7,
            0.3,
            count=1_000_000,
            grooves=values["grooves"],
        )
        np.testing.assert_allclose(_f(values, wi, wo), expected, rtol=1e-4, err_msg=str(values))
