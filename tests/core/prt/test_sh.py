"""Tests of spectral_materials.core.prt.sh (real orthonormal spherical harmonics)."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest
import scipy.special
from numpy.polynomial import legendre
from scipy.spatial.transform import Rotation

from spectral_materials.core.prt import sh

# --------------------------------------------------------------------------- helpers


def random_unit(n: int, seed: int = 0) -> np.ndarray:
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def random_rotation(seed: int) -> np.ndarray:
    return Rotation.random(random_state=seed).as_matrix()


def complex_sh(l: int, m: int, d: np.ndarray) -> np.ndarray:
    """scipy's complex Y_l^m (Condon–Shortley phase included) at unit vectors d."""
    polar = np.arctan2(np.hypot(d[..., 0], d[..., 1]), d[..., 2])  # accurate near the poles
    azimuth = np.arctan2(d[..., 1], d[..., 0])
    if hasattr(scipy.special, "sph_harm_y"):  # scipy >= 1.15
        return scipy.special.sph_harm_y(l, m, polar, azimuth)
    return scipy.special.sph_harm(m, l, azimuth, polar)


def real_sh_from_scipy(bands: int, d: np.ndarray) -> np.ndarray:
    """The standard complex → real relation, removing the Condon–Shortley phase."""
    out = np.empty(d.shape[:-1] + (bands * bands,))
    for l in range(bands):
        for m in range(-l, l + 1):
            y = complex_sh(l, abs(m), d)
            sign = (-1.0) ** abs(m)
            if m > 0:
                out[..., l * l + l + m] = math.sqrt(2.0) * sign * y.real
            elif m < 0:
                out[..., l * l + l + m] = math.sqrt(2.0) * sign * y.imag
            else:
                out[..., l * l + l] = y.real
    return out


def exact_real_sh(bands: int, d: np.ndarray) -> np.ndarray:
    """Reference by exact rational arithmetic (no trig): P̄_l^m = d^m P_l / dz^m."""
    out = np.empty(bands * bands)
    x, y, z = (Fraction(float(c)) for c in d)
    for l in range(bands):
        # P_l(t) = 2^-l Σ_k (-1)^k C(l, k) C(2l - 2k, l) t^(l - 2k)
        poly = {l - 2 * k: Fraction((-1) ** k * math.comb(l, k) * math.comb(2 * l - 2 * k, l),
                                    2**l) for k in range(l // 2 + 1)}
        re, im = Fraction(1), Fraction(0)
        for m in range(l + 1):
            if m > 0:
                poly = {p - 1: c * p for p, c in poly.items() if p > 0}
                re, im = x * re - y * im, x * im + y * re
            value = sum(c * z**p for p, c in poly.items())
            norm = math.sqrt((2 * l + 1) / (4 * math.pi)
                             * math.factorial(l - m) / math.factorial(l + m))
            if m == 0:
                out[l * l + l] = norm * float(value)
            else:
                out[l * l + l + m] = math.sqrt(2.0) * norm * float(value * re)
                out[l * l + l - m] = math.sqrt(2.0) * norm * float(value * im)
    return out


def hemisphere_rule(n: int, z_min: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre in z ∈ [z_min, 1] × uniform φ: exact for polynomials on that cap."""
    t, wt = legendre.leggauss(n)
    z = z_min + (t + 1.0) * (1.0 - z_min) / 2.0
    wz = wt * (1.0 - z_min) / 2.0
    phi = (np.arange(2 * n) + 0.5) * (math.pi / n)
    r = np.sqrt(1.0 - z * z)
    dirs = np.stack(np.broadcast_arrays(r[:, None] * np.cos(phi), r[:, None] * np.sin(phi),
                                        z[:, None]), axis=-1).reshape(-1, 3)
    return dirs, np.repeat(wz * (math.pi / n), 2 * n)


def frame_with_z(axis: np.ndarray) -> np.ndarray:
    """A rotation R with R @ e_z = axis."""
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    y = np.cross(axis, x)
    return np.stack([x, y, axis], axis=1)


def zonal_profile(zonal: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """Σ_l z_l Y_l0 at polar angle γ."""
    l = np.arange(len(zonal))
    return legendre.legval(np.cos(gamma), zonal * np.sqrt((2 * l + 1) / (4 * math.pi)))


# --------------------------------------------------------------------------- counts and validation


def test_sh_count_and_indices():
    assert sh.sh_count() == 25 == sh.sh_count(sh.DEFAULT_BANDS)
    assert [sh.sh_count(b) for b in (1, 2, 3, 8, 32)] == [1, 4, 9, 64, 1024]
    assert sh.sh_count(np.int64(4)) == 16
    l, m = sh.sh_indices(3)
    assert l.tolist() == [0, 1, 1, 1, 2, 2, 2, 2, 2]
    assert m.tolist() == [0, -1, 0, 1, -2, -1, 0, 1, 2]
    assert np.array_equal(l * l + l + m, np.arange(9))


@pytest.mark.parametrize("bad", [0, -1, 33, 100, 2.0, True, "5", None])
def test_bands_out_of_range(bad):
    with pytest.raises(ValueError, match="bands"):
        sh.sh_count(bad)
    with pytest.raises(ValueError, match="bands"):
        sh.sh_basis([0.0, 0.0, 1.0], bad)


def test_invalid_directions():
    d = random_unit(10)
    d[3, 1] = np.nan
    d[7, 0] = np.inf
    with pytest.raises(ValueError, match=r"2 non-finite"):
        sh.sh_basis(d)
    z = random_unit(6).reshape(2, 3, 3)
    z[0, 1] = 0.0
    z[1, 2] = 0.0
    z[1, 0] = -0.0
    with pytest.raises(ValueError, match=r"3 zero vector"):
        sh.sh_basis(z)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        sh.sh_basis(np.ones((4, 2)))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3\)"):
        sh.sh_basis(1.0)


# --------------------------------------------------------------------------- basis values


def test_known_values():
    near_pole = np.array([[1e-9, -2e-9, 1.0], [3e-12, 1e-12, -1.0]])
    near_pole /= np.linalg.norm(near_pole, axis=1, keepdims=True)
    d = np.concatenate([random_unit(50, seed=1), near_pole])
    x, y, z = d.T
    b = sh.sh_basis(d, 3)
    c0 = 1.0 / (2.0 * math.sqrt(math.pi))
    c1 = math.sqrt(3.0 / (4.0 * math.pi))
    c2 = 0.5 * math.sqrt(15.0 / math.pi)
    expected = np.stack([
        np.full_like(x, c0),
        c1 * y, c1 * z, c1 * x,
        c2 * x * y, c2 * y * z, 0.25 * math.sqrt(5.0 / math.pi) * (3 * z * z - 1),
        c2 * x * z, 0.5 * c2 * (x * x - y * y),
    ], axis=-1)
    np.testing.assert_allclose(b, expected, rtol=0, atol=1e-15)
    assert sh.sh_basis([0.3, -2.0, 0.1], 1)[0] == pytest.approx(0.28209479177387814, abs=1e-16)


@pytest.mark.parametrize("bands", [1, 5, 8, 32])
def test_matches_scipy_complex_to_real(bands):
    d = random_unit(300, seed=bands)
    # poles, equator and axes; scipy's trigonometric evaluation loses digits close to
    # the poles (1e-9 relative at sin θ = 2e-4; 0 for m = ±1 at sin θ = 2e-9), so the
    # near-pole check is test_near_pole_exact
    extra = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1, 0], [-1, 0, 0],
                      [0.6, 0.8, 0.0]], dtype=float)
    extra /= np.linalg.norm(extra, axis=1, keepdims=True)
    d = np.concatenate([d, extra])
    err = np.abs(sh.sh_basis(d, bands) - real_sh_from_scipy(bands, d)).max()
    assert err < (1e-14 if bands <= 8 else 2e-13)


@pytest.mark.parametrize("direction", [[1e-9, -2e-9, 1.0], [1e-4, -2e-4, 1.0],
                                       [3e-12, 1e-12, -1.0], [0.3, -0.4, 0.5]])
def test_near_pole_exact(direction):
    d = np.asarray(direction) / np.linalg.norm(direction)
    got = sh.sh_basis(d, 10)
    ref = exact_real_sh(10, d)
    np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-15)


def test_poles_exact():
    bands = 32
    l = np.arange(bands)
    for sign in (1.0, -1.0):
        b = sh.sh_basis([0.0, 0.0, 5.0 * sign], bands)
        expected = np.zeros(bands * bands)
        expected[l * l + l] = sign**l * np.sqrt((2 * l + 1) / (4 * math.pi))
        np.testing.assert_allclose(b, expected, rtol=1e-13, atol=1e-15)
    # no trig at the poles: exactly zero for m != 0
    b = sh.sh_basis([0.0, 0.0, 1.0], bands)
    mask = np.ones(bands * bands, bool)
    mask[l * l + l] = False
    assert np.all(b[mask] == 0.0)


def test_normalises_any_length():
    d = random_unit(20, seed=2)
    scales = np.array([1e-200, 1e-8, 1.0, 7.5, 1e200])[np.arange(20) % 5, None]
    np.testing.assert_allclose(sh.sh_basis(d * scales, 8), sh.sh_basis(d, 8),
                               rtol=0, atol=1e-14)


def test_shapes_nd_and_empty():
    d = random_unit(24, seed=3).reshape(2, 3, 4, 3)
    b = sh.sh_basis(d)
    assert b.shape == (2, 3, 4, 25)
    np.testing.assert_array_equal(b.reshape(-1, 25), sh.sh_basis(d.reshape(-1, 3)))
    assert sh.sh_basis(d[0, 0, 0], 4).shape == (16,)
    assert sh.sh_basis(np.empty((0, 3)), 6).shape == (0, 36)
    assert sh.sh_basis(np.empty((2, 0, 3))).shape == (2, 0, 25)
    assert sh.evaluate(np.ones(25), np.empty((0, 3))).shape == (0,)
    dirs, w = sh.sphere_quadrature(4)
    assert sh.project(np.empty((dirs.shape[0], 0)), sh.sh_basis(dirs, 2), w).shape == (0, 4)


# --------------------------------------------------------------------------- quadrature, projection


@pytest.mark.parametrize("bands", [8, 32])
def test_orthonormal_by_quadrature(bands):
    dirs, w = sh.sphere_quadrature(bands)
    assert dirs.shape == (2 * bands * bands, 3) and w.shape == (2 * bands * bands,)
    assert w.sum() == pytest.approx(4 * math.pi, rel=1e-14)
    assert np.all(w > 0)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=1), 1.0, rtol=0, atol=1e-15)
    b = sh.sh_basis(dirs, bands)
    gram = b.T @ (b * w[:, None])
    assert np.abs(gram - np.eye(bands * bands)).max() < 1e-12


def test_quadrature_order_is_tight():
    # n nodes are exact to degree 2n - 1: n = bands suffices, n = bands - 1 does not
    bands = 6
    dirs, w = sh.sphere_quadrature(bands - 1)
    b = sh.sh_basis(dirs, bands)
    assert np.abs(b.T @ (b * w[:, None]) - np.eye(bands * bands)).max() > 1e-3
    with pytest.raises(ValueError, match="quadrature order"):
        sh.sphere_quadrature(0)
    with pytest.raises(ValueError, match="quadrature order"):
        sh.sphere_quadrature(2.5)


def test_project_roundtrip_with_channels():
    bands = 8
    rng = np.random.default_rng(4)
    coeffs = rng.normal(size=(3, bands * bands))  # e.g. 3 spectral coefficients

    def f(d):
        return sh.evaluate(coeffs, d)  # (Q, 3)

    got = sh.project_function(f, bands, n=bands)
    np.testing.assert_allclose(got, coeffs, rtol=0, atol=1e-12)
    got_default = sh.project_function(lambda d: sh.evaluate(coeffs[0], d), bands)
    np.testing.assert_allclose(got_default, coeffs[0], rtol=0, atol=1e-12)
    # fewer bands: the low bands of the same function
    np.testing.assert_allclose(sh.project_function(f, 3, n=bands), coeffs[:, :9],
                               rtol=0, atol=1e-12)


def test_project_errors():
    dirs, w = sh.sphere_quadrature(3)
    b = sh.sh_basis(dirs, 2)
    with pytest.raises(ValueError, match="values must have shape"):
        sh.project(np.ones(5), b, w)
    with pytest.raises(ValueError, match="weights must have shape"):
        sh.project(np.ones(len(w)), b, w[:-1])
    with pytest.raises(ValueError, match="basis must have shape"):
        sh.project(np.ones(len(w)), b[:, 0], w)
    v = np.ones(len(w))
    v[2] = np.nan
    with pytest.raises(ValueError, match="1 non-finite"):
        sh.project(v, b, w)
    with pytest.raises(ValueError, match="bands²"):
        sh.evaluate(np.ones(5), dirs)


# --------------------------------------------------------------------------- zonal kernels


def test_clamped_cosine_closed_forms():
    z = sh.clamped_cosine_zonal(8)
    expected = [math.sqrt(math.pi) / 2, math.sqrt(math.pi / 3), math.sqrt(5 * math.pi) / 8, 0.0,
                -math.sqrt(math.pi) / 16, 0.0, math.sqrt(13 * math.pi) / 128, 0.0]
    np.testing.assert_allclose(z, expected, rtol=1e-15, atol=1e-17)
    assert sh.clamped_cosine_zonal().shape == (5,)


def test_clamped_cosine_vs_numerical_projection():
    # max(cos θ, 0) is a polynomial on the upper hemisphere: a hemisphere rule is exact
    bands = 32
    dirs, w = hemisphere_rule(40)
    coeffs = sh.project(dirs[:, 2], sh.sh_basis(dirs, bands), w)
    l, m = sh.sh_indices(bands)
    np.testing.assert_allclose(coeffs[m == 0], sh.clamped_cosine_zonal(bands),
                               rtol=0, atol=5e-14)
    assert np.abs(coeffs[m != 0]).max() < 5e-14
    # and a plain (kinked-integrand) sphere rule converges to it
    coarse = sh.project_function(lambda d: np.maximum(d[:, 2], 0.0), 8, n=200)
    np.testing.assert_allclose(coarse[sh.sh_indices(8)[1] == 0], sh.clamped_cosine_zonal(8),
                               atol=1e-4)


@pytest.mark.parametrize("half_angle", [0.01, 0.4, math.pi / 2, 2.5])
def test_cap_zonal_vs_numerical_projection(half_angle):
    bands = 16
    dirs, w = hemisphere_rule(30, z_min=math.cos(half_angle))
    coeffs = sh.project(np.ones(len(w)), sh.sh_basis(dirs, bands), w)
    l, m = sh.sh_indices(bands)
    np.testing.assert_allclose(coeffs[m == 0], sh.cap_zonal(bands, half_angle),
                               rtol=0, atol=5e-14)


def test_cap_zonal_limits_and_errors():
    full = sh.cap_zonal(6, math.pi)
    np.testing.assert_allclose(full, [math.sqrt(4 * math.pi), 0, 0, 0, 0, 0], atol=1e-15)
    assert np.all(sh.cap_zonal(6, 0.0) == 0.0)
    with pytest.raises(ValueError, match="half_angle"):
        sh.cap_zonal(4, -0.1)
    with pytest.raises(ValueError, match="half_angle"):
        sh.cap_zonal(4, 4.0)


def test_zonal_to_sh_matches_projection_of_rotated_zonal():
    bands = 8
    rng = np.random.default_rng(5)
    zonal = rng.normal(size=bands)
    axis = np.array([0.3, -0.5, 0.8])
    a = axis / np.linalg.norm(axis)

    def f(d):
        return zonal_profile(zonal, np.arccos(np.clip(d @ a, -1, 1)))

    np.testing.assert_allclose(sh.zonal_to_sh(zonal, axis), sh.project_function(f, bands, n=8),
                               rtol=0, atol=1e-13)
    # along +z the result is the zonal coefficients themselves
    c = sh.zonal_to_sh(zonal, [0, 0, 2.0])
    l, m = sh.sh_indices(bands)
    np.testing.assert_allclose(c[m == 0], zonal, rtol=1e-14)
    assert np.all(c[m != 0] == 0.0)
    # broadcasting: several axes, one kernel
    axes = random_unit(6, seed=6).reshape(2, 3, 3)
    assert sh.zonal_to_sh(zonal, axes).shape == (2, 3, 64)
    with pytest.raises(ValueError, match="zero vector"):
        sh.zonal_to_sh(zonal, [0, 0, 0])


def test_convolve_zonal_is_funk_hecke():
    bands = 6
    rng = np.random.default_rng(7)
    coeffs = rng.normal(size=bands * bands)
    kernel = rng.normal(size=bands)
    dirs, w = sh.sphere_quadrature(bands + 1)
    f_values = sh.evaluate(coeffs, dirs)
    normals = random_unit(5, seed=8)
    # g(n) = ∫ f(ω) k(n·ω) dω, integrand of degree ≤ 2(bands − 1): exact
    brute = np.array([np.sum(w * f_values * zonal_profile(kernel, np.arccos(np.clip(dirs @ n,
                                                                                    -1, 1))))
                      for n in normals])
    got = sh.evaluate(sh.convolve_zonal(coeffs, kernel), normals)
    np.testing.assert_allclose(got, brute, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="zonal has 5 bands"):
        sh.convolve_zonal(coeffs, kernel[:5])
    with pytest.raises(ValueError, match="bands²"):
        sh.convolve_zonal(coeffs[:-1], kernel)


def test_irradiance_from_clamped_cosine():
    bands = 5
    cos_zonal = sh.clamped_cosine_zonal(bands)
    # constant radiance 1 → irradiance π everywhere
    ones = sh.project_function(lambda d: np.ones(len(d)), bands)
    normals = random_unit(7, seed=9)
    np.testing.assert_allclose(sh.evaluate(sh.convolve_zonal(ones, cos_zonal), normals), math.pi,
                               rtol=1e-14)
    # band-limited environment: exact irradiance by hemisphere quadrature about each normal
    rng = np.random.default_rng(10)
    env = rng.normal(size=(2, bands * bands))  # two spectral channels
    irr = sh.convolve_zonal(env, cos_zonal)
    local, w = hemisphere_rule(12)
    for n in normals:
        world = local @ frame_with_z(n).T
        brute = (w * local[:, 2]) @ sh.evaluate(env, world)
        np.testing.assert_allclose(sh.evaluate(irr, n), brute, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- rotation


def test_rotation_identity_and_band_one():
    np.testing.assert_array_equal(sh.rotation_matrix_sh(np.eye(3), 8), np.eye(64))
    r = random_rotation(11)
    m = sh.rotation_matrix_sh(r, 2)
    np.testing.assert_allclose(m[1:4, 1:4], r[np.ix_([1, 2, 0], [1, 2, 0])], rtol=0, atol=0)
    assert sh.rotation_matrix_sh(r, 1).tolist() == [[1.0]]


@pytest.mark.parametrize("bands", [8, 32])
def test_rotation_convention_basis_identity(bands):
    d = random_unit(200, seed=12)
    for seed in (13, 14, 15):
        r = random_rotation(seed)
        m = sh.rotation_matrix_sh(r, bands)
        err = np.abs(sh.sh_basis(d @ r.T, bands) - sh.sh_basis(d, bands) @ m.T).max()
        assert err < (1e-13 if bands <= 8 else 2e-12)


def test_rotation_vs_brute_force_reprojection():
    bands = 8
    dirs, w = sh.sphere_quadrature(bands)
    for seed in (16, 17, 18):
        r = random_rotation(seed)
        # M_ij = ∫ Y_i(R d) Y_j(d) dd, exact for this quadrature
        brute = sh.sh_basis(dirs @ r.T, bands).T @ (sh.sh_basis(dirs, bands) * w[:, None])
        assert np.abs(sh.rotation_matrix_sh(r, bands) - brute).max() < 1e-13


@pytest.mark.parametrize("bands", [8, 32])
def test_rotation_group_properties(bands):
    size = bands * bands
    l, _ = sh.sh_indices(bands)
    for seed in (19, 20, 21):
        r1, r2 = random_rotation(seed), random_rotation(seed + 100)
        m1 = sh.rotation_matrix_sh(r1, bands)
        m2 = sh.rotation_matrix_sh(r2, bands)
        tol = 1e-13 if bands <= 8 else 5e-12
        assert np.abs(sh.rotation_matrix_sh(r1 @ r2, bands) - m1 @ m2).max() < tol
        assert np.abs(m1.T @ m1 - np.eye(size)).max() < tol
        assert np.abs(sh.rotation_matrix_sh(r1.T, bands) - m1.T).max() < tol
        # block diagonal, each block a proper rotation
        assert np.all(m1[l[:, None] != l[None, :]] == 0.0)
        for band in range(bands):
            block = m1[band * band:(band + 1) ** 2, band * band:(band + 1) ** 2]
            assert np.linalg.det(block) == pytest.approx(1.0, abs=1e-10)
        assert np.linalg.det(m1) == pytest.approx(1.0, abs=1e-9)


def test_rotation_about_z_and_improper():
    bands = 6
    l, m = sh.sh_indices(bands)
    angle = 0.7
    rz = Rotation.from_euler("z", angle).as_matrix()
    mz = sh.rotation_matrix_sh(rz, bands)
    # rotating about z keeps m = 0 and mixes (m, −m) by cos/sin(m·angle)
    np.testing.assert_allclose(np.diag(mz), np.where(m == 0, 1.0, np.cos(m * angle)), atol=1e-14)
    # inversion acts as (−1)^l; a mirror still satisfies the basis identity
    np.testing.assert_allclose(sh.rotation_matrix_sh(-np.eye(3), bands), np.diag((-1.0) ** l),
                               atol=1e-15)
    mirror = random_rotation(22) @ np.diag([1.0, -1.0, 1.0])
    d = random_unit(50, seed=23)
    mm = sh.rotation_matrix_sh(mirror, bands)
    np.testing.assert_allclose(sh.sh_basis(d @ mirror.T, bands), sh.sh_basis(d, bands) @ mm.T,
                               atol=1e-13)


def test_rotate_moves_a_zonal_lobe_to_its_axis():
    bands = 8
    zonal = sh.clamped_cosine_zonal(bands)
    at_z = sh.zonal_to_sh(zonal, [0, 0, 1])
    axis = np.array([-0.2, 0.9, 0.4])
    r = frame_with_z(axis)
    np.testing.assert_allclose(sh.rotate(at_z, r), sh.zonal_to_sh(zonal, axis), atol=1e-14)
    stacked = np.stack([at_z, 2 * at_z])
    assert sh.rotate(stacked, r).shape == (2, 64)


def test_rotation_errors():
    with pytest.raises(ValueError, match="shape \\(3, 3\\)"):
        sh.rotation_matrix_sh(np.eye(4), 3)
    with pytest.raises(ValueError, match="not orthogonal"):
        sh.rotation_matrix_sh(np.diag([1.0, 1.0, 1.1]), 3)
    bad = np.eye(3)
    bad[0, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        sh.rotation_matrix_sh(bad, 3)
    with pytest.raises(ValueError, match="bands"):
        sh.rotation_matrix_sh(np.eye(3), 33)


# --------------------------------------------------------------------------- windowing


def test_window_values():
    np.testing.assert_array_equal(sh.window(4, "none"), np.ones(4))
    np.testing.assert_allclose(sh.window(4, "hanning"),
                               [1.0, (1 + math.cos(math.pi / 4)) / 2, 0.5,
                                (1 + math.cos(3 * math.pi / 4)) / 2], rtol=1e-15)
    np.testing.assert_allclose(sh.window(3, "lanczos", width=2.0),
                               [1.0, math.sin(math.pi / 2) / (math.pi / 2), 0.0], atol=1e-16)
    np.testing.assert_allclose(sh.window(4, "cesaro"), [1.0, 0.6, 0.3, 0.1], rtol=1e-15)
    np.testing.assert_allclose(sh.window(5, "cesaro", width=3), [1.0, 0.5, 1 / 6, 0.0, 0.0],
                               rtol=1e-15)
    for kind in ("hanning", "lanczos", "cesaro"):
        w = sh.window(8, kind)
        assert w[0] == 1.0 and np.all(np.diff(w) < 0) and np.all(w > 0)
    assert sh.window().shape == (5,)


def test_window_errors():
    with pytest.raises(ValueError, match="window kind"):
        sh.window(5, "hann")
    for width in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="width"):
            sh.window(5, "hanning", width=width)
    with pytest.raises(ValueError, match="width must be >= 1"):
        sh.window(5, "cesaro", width=0.5)
    with pytest.raises(ValueError, match="per-band"):
        sh.apply_window(np.ones(25), np.ones(4))


@pytest.mark.parametrize("bands", [3, 5, 8, 16])
def test_window_suppresses_sun_ringing(bands):
    sun_radius = math.radians(0.27)
    sun_dir = np.array([0.4, 0.3, 0.866])
    coeffs = sh.zonal_to_sh(sh.cap_zonal(bands, sun_radius), sun_dir)
    dirs, _ = sh.sphere_quadrature(120)

    def min_over_peak(c):
        values = sh.evaluate(c, dirs)
        peak = sh.evaluate(c, sun_dir)
        return values.min() / peak

    plain = min_over_peak(coeffs)
    assert plain < -0.1  # Gibbs: a sun makes > 10 % negative radiance
    hann = min_over_peak(sh.apply_window(coeffs, sh.window(bands, "hanning")))
    lanczos = min_over_peak(sh.apply_window(coeffs, sh.window(bands, "lanczos")))
    cesaro = min_over_peak(sh.apply_window(coeffs, sh.window(bands, "cesaro")))
    # Hanning / Lanczos shrink the negative lobe but do not remove it
    assert plain / 3 < hann < 0 and plain / 2 < lanczos < 0
    # the (C, 2) window has a non-negative kernel: no negative radiance
    assert cesaro >= -1e-3
    assert cesaro >= -1e-12
