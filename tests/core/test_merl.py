"""MERL .binary reader, writer and measured BRDF.

Reference values here are computed independently of core.merl: direction pairs are built from chosen
half/difference angles with explicit rotation matrices, and the file layout is checked byte by byte.

Tolerances:
- write -> read round trip: bit-exact (the stored float64 values are copied, never converted).
- lookups at cell centres: 1e-12 relative for the nearest cell (the table holds ``f / scale``, the lookup
  multiplies back: a few ulps); 1e-9 for the trilinear lookup, whose neighbour weights at a centre come from
  angles recomputed from the directions (``acos`` near 1 turns 1e-16 into ~1e-14 rad, 1e-12 of a cell).
- lookups between centres, for a test lobe that depends on theta_h only: the nearest-cell lookup is within
  ``max|f'| * (cell width in theta_h)`` of the truth (mean value theorem); the trilinear lookup interpolates
  linearly in the index coordinate ``u`` (with ``theta_h = ((u + 1/2)/90)^2 pi/2``), so it is within
  ``max|d^2 f/du^2| / 8`` (the linear-interpolation error bound). Both derivative maxima are taken on a fine
  grid of the analytic formula, with a 10% margin for the grid.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from core.brdf import make_brdf
from core.errors import FileFormatError
from core.kernels import eval_batch, eval_into
from core.merl import (
    FILE_BYTES,
    MERL_BLOCK,
    N_CELLS,
    SCALES,
    MeasuredBRDF,
    MerlTable,
    cell_centre_pairs,
    eval_merl,
    eval_merl_rows,
    measured_brdf,
    read_merl,
    tabulate,
    write_merl,
)
from core.sampling import make_sampler

LOBE_N = 50.0
LOBE_RGB = np.array([0.48, 0.24, 0.12])
LOBE_KD = 0.1

HALF_LOBE = make_brdf(
    "blinn",
    {"n": LOBE_N, "ks": tuple((LOBE_N + 2.0) / (8.0 * math.pi) * LOBE_RGB), "kd": tuple(LOBE_KD * LOBE_RGB)},
)
"""A smooth test lobe depending on theta_h only: ``(kd/pi + (n+2)/(8 pi) cos^n theta_h) * rgb`` (Blinn's
model, whose specular coefficient bounds the tint to ``rgb <= 8 pi / (n + 2)``)."""


def lobe_value(theta_h: np.ndarray) -> np.ndarray:
    """The test lobe's luminance-free value (before the RGB tint) as a function of theta_h."""
    return LOBE_KD / np.pi + (LOBE_N + 2.0) / (8.0 * np.pi) * np.cos(theta_h) ** LOBE_N


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def pair_from_angles(theta_h, phi_h, theta_d, phi_d) -> tuple[np.ndarray, np.ndarray]:
    """``(wi, wo)`` with the given Rusinkiewicz angles: ``wi = Rz(phi_h) Ry(theta_h) d``, ``wo`` its mirror
    about ``h = Rz(phi_h) Ry(theta_h) z``."""
    d = np.array(
        [math.sin(theta_d) * math.cos(phi_d), math.sin(theta_d) * math.sin(phi_d), math.cos(theta_d)]
    )
    r = rot_z(phi_h) @ rot_y(theta_h)
    wi = r @ d
    h = r @ np.array([0.0, 0.0, 1.0])
    wo = 2.0 * (wi @ h) * h - wi
    return wi, wo


def centre_angles(ih: int, jd: int, kp: int) -> tuple[float, float, float]:
    return ((ih + 0.5) / 90.0) ** 2 * np.pi / 2, (jd + 0.5) / 90.0 * np.pi / 2, (kp + 0.5) / 180.0 * np.pi


@pytest.fixture(scope="module")
def lobe_file(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("merl") / "lobe.binary"
    write_merl(path, HALF_LOBE)
    return str(path)


def test_round_trip_is_bit_exact(tmp_path, rng):
    raw = rng.normal(size=(3, 90, 90, 180)) * 100.0
    raw[:, 3, 4, 5] = -1.0  # a missing cell survives too
    path = tmp_path / "t.binary"
    write_merl(path, raw)
    assert path.stat().st_size == FILE_BYTES
    back = read_merl(path)
    assert np.array_equal(back.raw, raw)
    again = tmp_path / "u.binary"
    write_merl(again, back)
    assert path.read_bytes() == again.read_bytes()


def test_file_layout_header_and_planes(tmp_path):
    raw = np.zeros((3, 90, 90, 180))
    raw[0, 7, 11, 13] = 1.5
    raw[1, 89, 0, 179] = 2.5
    raw[2, 0, 89, 0] = 3.5
    path = tmp_path / "t.binary"
    write_merl(path, raw)
    data = path.read_bytes()
    assert np.frombuffer(data[:12], dtype="<i4").tolist() == [90, 90, 180]
    body = np.frombuffer(data[12:], dtype="<f8")
    n = 90 * 90 * 180
    assert body[0 * n + 13 + 180 * (11 + 90 * 7)] == 1.5  # index = phi_d + 180 (theta_d + 90 theta_h)
    assert body[1 * n + 179 + 180 * (0 + 90 * 89)] == 2.5
    assert body[2 * n + 0 + 180 * (89 + 90 * 0)] == 3.5
    assert np.count_nonzero(body) == 3


@pytest.mark.parametrize("interpolate", [True, False])
def test_single_cell_is_found_from_its_angles(rng, interpolate):
    """A table that is zero except one cell: the lookup at that cell's centre, for any phi_h and either
    orientation of the pair (reciprocity folds phi_d by pi), returns the cell's scaled value."""
    for _ in range(4):
        ih, jd, kp = int(rng.integers(0, 60)), int(rng.integers(0, 30)), int(rng.integers(0, 180))
        raw = np.zeros((3, 90, 90, 180))
        raw[:, ih, jd, kp] = [3.0, 5.0, 7.0]
        brdf = MeasuredBRDF(MerlTable(raw), interpolate=interpolate)
        wi, wo = pair_from_angles(
            *centre_angles(ih, jd, kp)[:1], rng.uniform(0, 2 * np.pi), *centre_angles(ih, jd, kp)[1:]
        )
        assert wi[2] > 0 and wo[2] > 0
        expected = np.array([3.0, 5.0, 7.0]) * SCALES
        rtol = 1e-9 if interpolate else 1e-12
        np.testing.assert_allclose(brdf.eval(wo, wi)[0], expected, rtol=rtol)
        np.testing.assert_allclose(brdf.eval(wi, wo)[0], expected, rtol=rtol)


@pytest.mark.parametrize("interpolate", [True, False])
def test_exact_at_cell_centres(lobe_file, rng, interpolate):
    brdf = measured_brdf(lobe_file, interpolate=interpolate)
    source = HALF_LOBE
    wis, wos = [], []
    while len(wis) < 400:
        ih, jd, kp = rng.integers(0, 90), rng.integers(0, 90), rng.integers(0, 180)
        wi, wo = pair_from_angles(
            *centre_angles(ih, jd, kp)[:1], rng.uniform(0, 2 * np.pi), *centre_angles(ih, jd, kp)[1:]
        )
        if wi[2] > 0 and wo[2] > 0:
            wis.append(wi)
            wos.append(wo)
    wi, wo = np.array(wis), np.array(wos)
    np.testing.assert_allclose(brdf.eval(wo, wi), source.eval(wo, wi), rtol=1e-9 if interpolate else 1e-12)


def _random_pairs(rng, n, min_cos=0.1):
    """Uniform pairs on the hemisphere with both cosines above ``min_cos``: every cell centre within one
    cell of such a pair is above the horizon (a cell spans < 0.07 rad in the three angles together), so
    the table there holds plain centre values."""
    out = []
    while sum(len(o[0]) for o in out) < n:
        u = rng.random((n, 4))
        wi = np.stack(
            [
                np.sqrt(1 - u[:, 0] ** 2) * np.cos(2 * np.pi * u[:, 1]),
                np.sqrt(1 - u[:, 0] ** 2) * np.sin(2 * np.pi * u[:, 1]),
                u[:, 0],
            ],
            1,
        )
        wo = np.stack(
            [
                np.sqrt(1 - u[:, 2] ** 2) * np.cos(2 * np.pi * u[:, 3]),
                np.sqrt(1 - u[:, 2] ** 2) * np.sin(2 * np.pi * u[:, 3]),
                u[:, 2],
            ],
            1,
        )
        ok = (wi[:, 2] > min_cos) & (wo[:, 2] > min_cos)
        out.append((wi[ok], wo[ok]))
    wi = np.concatenate([o[0] for o in out])[:n]
    wo = np.concatenate([o[1] for o in out])[:n]
    return wi, wo


def test_nearest_lookup_error_within_cell_resolution(lobe_file, rng):
    brdf = measured_brdf(lobe_file, interpolate=False)
    wi, wo = _random_pairs(rng, 20_000)
    h = wi + wo
    theta_h = np.arccos(np.clip(h[:, 2] / np.linalg.norm(h, axis=1), -1, 1))
    fine = np.linspace(0.0, np.pi / 2, 200_001)
    slope = np.abs(np.gradient(lobe_value(fine), fine))
    lipschitz = 1.1 * slope.max()
    i = np.floor(np.sqrt(theta_h / (np.pi / 2)) * 90).astype(int)
    width = ((i + 2) ** 2 - (i + 1) ** 2) / 8100 * np.pi / 2  # the next cell's (wider) width: rounding-safe
    bound = lipschitz * width
    err = np.abs(brdf.eval(wo, wi) - lobe_value(theta_h)[:, None] * LOBE_RGB)
    assert np.all(err <= bound[:, None] * LOBE_RGB), f"worst excess {np.max(err - bound[:, None])}"
    # The bound is not vacuous: the lookup does differ from the lobe, and by a fair share of the bound.
    assert err.max() > 0.1 * (bound[:, None] * LOBE_RGB).max()


def test_trilinear_lookup_error_within_second_derivative_bound(lobe_file, rng):
    brdf = measured_brdf(lobe_file)
    wi, wo = _random_pairs(rng, 20_000)
    h = wi + wo
    theta_h = np.arccos(np.clip(h[:, 2] / np.linalg.norm(h, axis=1), -1, 1))
    u = np.linspace(-0.5, 89.5, 900_001)
    g = lobe_value(((u + 0.5) / 90.0) ** 2 * np.pi / 2)
    du = u[1] - u[0]
    g2 = np.abs(np.diff(g, 2)) / du**2
    bound = 1.1 * g2.max() / 8.0
    err = np.abs(brdf.eval(wo, wi) - lobe_value(theta_h)[:, None] * LOBE_RGB)
    assert np.all(err <= bound * LOBE_RGB + 1e-12)
    nearest = measured_brdf(lobe_file, interpolate=False)
    err_nearest = np.abs(nearest.eval(wo, wi) - lobe_value(theta_h)[:, None] * LOBE_RGB)
    assert err.mean() < 0.2 * err_nearest.mean()  # second order beats first order by far


def test_measured_is_reciprocal_isotropic_and_finite(lobe_file, rng):
    brdf = measured_brdf(lobe_file)
    wi, wo = _random_pairs(rng, 5000, min_cos=0.0)
    a = brdf.eval(wo, wi)
    assert np.all(np.isfinite(a)) and np.all(a >= 0)
    np.testing.assert_allclose(brdf.eval(wi, wo), a, rtol=1e-9, atol=1e-14)
    rot = rot_z(1.234)
    np.testing.assert_allclose(brdf.eval(wo @ rot.T, wi @ rot.T), a, rtol=1e-9, atol=1e-14)
    below = wi * np.array([1.0, 1.0, -1.0])
    assert np.all(brdf.eval(wo, below) == 0.0) and np.all(brdf.eval(below, wo) == 0.0)


def test_measured_plugs_into_batch_drivers_and_samplers(lobe_file, rng):
    brdf = measured_brdf(lobe_file)
    wi, wo = _random_pairs(rng, 1000)
    serial = brdf.eval(wo, wi)
    parallel = eval_batch(
        brdf.model, np.ascontiguousarray(wi), np.ascontiguousarray(wo), brdf.params, threads=True
    )
    assert np.array_equal(serial, parallel)
    sampler = make_sampler("cosine", brdf)
    drawn = sampler.sample(np.array([0.0, 0.0, 1.0]), 100, seed=1)
    assert np.all(np.isfinite(drawn.f)) and np.all(drawn.pdf > 0)
    np.testing.assert_array_equal(drawn.f, brdf.eval(np.array([0.0, 0.0, 1.0]), drawn.wi))
    assert brdf.key() != measured_brdf(lobe_file, interpolate=False).key()


def test_retabulating_a_measured_brdf_reproduces_its_table(lobe_file):
    """Exporting a measured BRDF evaluates it at the cell centres, where the lookup is exact: the valid
    cells come back to within rounding."""
    table = read_merl(lobe_file)
    again = tabulate(measured_brdf(lobe_file, interpolate=False))
    ih, jd, kp = np.meshgrid(np.arange(90), np.arange(90), np.arange(180), indexing="ij")
    wi, wo = cell_centre_pairs(ih.ravel(), jd.ravel(), kp.ravel())
    valid = ((wi[:, 2] > 0) & (wo[:, 2] > 0)).reshape(90, 90, 180)
    assert valid.mean() > 0.5
    np.testing.assert_allclose(again.raw[:, valid], table.raw[:, valid], rtol=1e-12)


def test_lambert_export_is_constant_everywhere_above_the_horizon(tmp_path, rng):
    kd = np.array([0.2, 0.5, 0.8])
    path = tmp_path / "l.binary"
    write_merl(path, make_brdf("lambert", {"kd": tuple(kd)}))
    table = read_merl(path)
    assert 0.0 < table.missing_fraction < 0.5  # cells with no direction pair above the horizon
    wi, wo = _random_pairs(rng, 5000, min_cos=0.0)
    f = measured_brdf(path).eval(wo, wi)
    inside = np.all(np.isclose(f, kd / np.pi, rtol=1e-12), axis=1)
    assert inside.mean() > 0.999  # a pair in a cell without valid sub-samples (extreme grazing) reads 0


# ------------------------------------------------------------------------------------------ bad files


def _write_bytes(path, header=(90, 90, 180), values=None, count=3 * N_CELLS, extra=b""):
    values = np.zeros(count) if values is None else values
    path.write_bytes(np.array(header, dtype="<i4").tobytes() + np.asarray(values, "<f8").tobytes() + extra)
    return path


def test_missing_file(tmp_path):
    with pytest.raises(FileFormatError, match="does not exist"):
        read_merl(tmp_path / "nope.binary")


def test_directory_is_not_a_file(tmp_path):
    with pytest.raises(FileFormatError, match="not a regular file"):
        read_merl(tmp_path)


def test_truncated_header(tmp_path):
    p = tmp_path / "h.binary"
    p.write_bytes(b"\x5a\x00\x00\x00")
    with pytest.raises(FileFormatError, match=r"truncated: 4 bytes, too short for the 12-byte header"):
        read_merl(p)


def test_truncated_data(tmp_path):
    p = _write_bytes(tmp_path / "t.binary", count=N_CELLS)
    with pytest.raises(FileFormatError, match=rf"truncated: {12 + 8 * N_CELLS} bytes, expected {FILE_BYTES}"):
        read_merl(p)


def test_wrong_header_dimensions(tmp_path):
    p = _write_bytes(tmp_path / "d.binary", header=(90, 90, 360))
    with pytest.raises(FileFormatError, match=r"dimensions 90 x 90 x 360 .* expected 90 x 90 x 180"):
        read_merl(p)


def test_trailing_bytes(tmp_path):
    p = _write_bytes(tmp_path / "x.binary", extra=b"\0" * 8)
    with pytest.raises(FileFormatError, match="wrong size.*8 bytes of unexpected trailing data"):
        read_merl(p)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values(tmp_path, bad):
    values = np.ones(3 * N_CELLS)
    values[12345] = bad
    p = _write_bytes(tmp_path / "n.binary", values=values)
    with pytest.raises(FileFormatError, match=r"1 non-finite values \(NaN or Inf\)"):
        read_merl(p)


def test_nan_filled(tmp_path):
    p = _write_bytes(tmp_path / "n.binary", values=np.full(3 * N_CELLS, np.nan))
    with pytest.raises(FileFormatError, match=rf"{3 * N_CELLS} non-finite values"):
        read_merl(p)


def test_all_negative(tmp_path):
    values = np.ones(3 * N_CELLS)
    values[N_CELLS : 2 * N_CELLS] = -1.0
    p = _write_bytes(tmp_path / "neg.binary", values=values)
    with pytest.raises(FileFormatError, match="no valid data in channel G"):
        read_merl(p)


def test_writer_refuses_bad_tables(tmp_path):
    with pytest.raises(FileFormatError, match="3 x 1458000 values"):
        write_merl(tmp_path / "a.binary", np.zeros(10))
    with pytest.raises(FileFormatError, match="NaN or Inf"):
        write_merl(tmp_path / "a.binary", np.full((3, 90, 90, 180), np.nan))
    assert not (tmp_path / "a.binary").exists()


def test_table_values_scale_and_zero_missing():
    raw = np.ones((3, 90, 90, 180))
    raw[:, 0, 0, 0] = -1.0
    t = MerlTable(raw)
    v = t.values()
    assert np.all(v[:, 0, 0, 0] == 0.0)
    np.testing.assert_array_equal(v[:, 1, 0, 0], SCALES)


def test_the_lookup_angles_are_the_rusinkiewicz_angles_at_hard_pairs():
    """The interpolating reader's own angles (no library arc tangent, ``h`` not normalized) against
    :func:`half_diff_angles` (``phi_d`` folded into ``[0, pi]``, reciprocity) at random pairs, grazing ones a
    hair above the horizon, ``h`` along the normal (``wi = wo``, normal incidence) and mirror pairs."""
    from numba import njit

    from core.merl import _lookup_angles, half_diff_angles

    @njit
    def both(wi, wo):
        out = np.empty((wi.shape[0], 6))
        for k in range(wi.shape[0]):
            a = (wi[k, 0], wi[k, 1], wi[k, 2])
            b = (wo[k, 0], wo[k, 1], wo[k, 2])
            out[k, 0], out[k, 1], out[k, 2] = _lookup_angles(a, b)
            out[k, 3], out[k, 4], out[k, 5] = half_diff_angles(a, b)
        return out

    rng = np.random.default_rng(17)

    def upper(n, z_max=1.0):
        z = rng.uniform(0.0, z_max, n)
        phi = rng.uniform(0.0, 2.0 * math.pi, n)
        s = np.sqrt(1.0 - z * z)
        return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)

    wi = np.concatenate([upper(4000), upper(1000, 1e-6), [[0.0, 0.0, 1.0]], upper(500)])
    wo = np.concatenate([upper(4000), upper(1000, 1e-6), [[0.0, 0.0, 1.0]], wi[-500:] * [-1.0, -1.0, 1.0]])
    wi[-501 - 200 : -501] = wo[-501 - 200 : -501]  # wi = wo: h along wo
    got = both(np.ascontiguousarray(wi), np.ascontiguousarray(wo))
    assert np.all(np.isfinite(got))
    ref_phi = np.where(got[:, 5] < 0.0, got[:, 5] + math.pi, got[:, 5])
    np.testing.assert_allclose(got[:, 0], got[:, 3], atol=1e-12)
    np.testing.assert_allclose(got[:, 1], got[:, 4], atol=1e-12)
    # phi_d is undefined where theta_d = 0 (wi = h): compare it where the difference direction is defined
    defined = got[:, 4] > 1e-6
    d_phi = np.abs(got[defined, 2] - ref_phi[defined])
    assert np.all(np.minimum(d_phi, math.pi - d_phi) < 1e-9)


@njit(cache=False)
def _per_row(wi, wo, p, out):
    for i in range(wi.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = eval_merl(
            (wi[i, 0], wi[i, 1], wi[i, 2]), (wo[i, 0], wo[i, 1], wo[i, 2]), p
        )


def _any_pairs(rng, n):
    """Pairs over the whole sphere (a quarter below the horizon on either side), some grazing."""
    d = rng.normal(size=(2, n, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    d[:, :, 2] = np.abs(d[:, :, 2]) * np.where(rng.random((2, n)) < 0.75, 1.0, -1.0)
    d[0, :50, 2] = 1e-12  # grazing light
    d[0, :50] /= np.linalg.norm(d[0, :50], axis=-1, keepdims=True)
    return np.ascontiguousarray(d[0]), np.ascontiguousarray(d[1])


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_batched_lookups_are_the_per_row_lookups_to_the_bit(lobe_file, rng, dtype):
    """``eval_merl_rows`` (blocks of ``MERL_BLOCK`` rows: cells, reads, sums) and ``eval_into`` on a measured
    table give ``eval_merl``'s values exactly, 0 below the horizon and for a table of the wrong size, and leave
    the rows a mask skips as they were (float64 tables, and the renderer's float32 copies)."""
    brdf = measured_brdf(lobe_file)
    p = np.ascontiguousarray(brdf.params.astype(dtype))
    n = 3 * MERL_BLOCK + 37
    wi, wo = _any_pairs(rng, n)
    want = np.empty((n, 3))
    _per_row(wi, wo, p, want)
    assert np.all(want[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] == 0.0) and np.any(want > 0.0)
    cells, fractions = np.empty((MERL_BLOCK, 3), dtype=np.int64), np.empty((MERL_BLOCK, 3))
    keep = rng.random(n) < 0.6
    for mask in (np.zeros(0, dtype=np.bool_), keep):
        got = np.full((n, 3), 7.0)
        eval_merl_rows(wi, wo, p, mask, got, cells, fractions)
        rows = np.ones(n, dtype=bool) if len(mask) == 0 else mask
        np.testing.assert_array_equal(got[rows], want[rows])
        assert np.all(got[~rows] == 7.0)
    if dtype is np.float64:
        got = np.full((n, 3), 7.0)
        eval_into(brdf.model.id, wi, wo, p, got, keep)
        np.testing.assert_array_equal(got[keep], want[keep])
        assert np.all(got[~keep] == 7.0)
    wrong = np.ones(30, dtype=dtype)
    got = np.full((n, 3), 7.0)
    eval_merl_rows(wi, wo, wrong, np.zeros(0, dtype=np.bool_), got, cells, fractions)
    assert np.all(got == 0.0)


@pytest.mark.usefixtures("private_tables")
def test_the_rejection_free_draws_of_a_measured_table_carry_its_values(lobe_file, rng):
    """The rejection-free mode evaluates a measured table apart from its draws and densities (in blocks):
    every draw's ``f`` and every density's ``f`` are the BRDF's own values at those directions, bit for bit,
    and the rows a mask skips are left alone."""
    brdf = measured_brdf(lobe_file)
    sampler = make_sampler("adaptive_warp", brdf)
    n = 500
    wo = np.ascontiguousarray(_any_pairs(rng, n)[1])
    wo[:, 2] = np.abs(wo[:, 2]) + 0.05
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    drawn = sampler.sample_each(wo, seed=3)
    np.testing.assert_array_equal(drawn.f, brdf.eval(wo, drawn.wi))
    wi = np.ascontiguousarray(_any_pairs(rng, n)[0])
    mask = rng.random(n) < 0.5
    f, pdf = np.full((n, 3), 7.0), np.full(n, 7.0)
    sampler.eval_pdf_where(wo, wi, mask, f, pdf)
    np.testing.assert_array_equal(f[mask], brdf.eval(wo[mask], wi[mask]))
    assert np.all(f[~mask] == 7.0) and np.all(pdf[~mask] == 7.0)
    np.testing.assert_array_equal(pdf[mask], sampler.pdf(wo[mask], wi[mask]))
