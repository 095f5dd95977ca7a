"""Tests of spectral_materials.core.brdf.params (BRDF parameterisations and axis lookups)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_materials.core.brdf import params
from spectral_materials.core.brdf.params import (
    PARAMETERIZATIONS,
    Axis,
    axis_lookup,
    from_spherical,
    get_parameterization,
    spherical,
)

NAMES = ["io", "io_iso", "hd", "hd_iso", "gs", "ea"]
Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------- helpers


def random_hemisphere(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.abs(v[:, 2])
    return v


def random_pairs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return random_hemisphere(rng, n), random_hemisphere(rng, n)


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def dirs(theta, phi) -> np.ndarray:
    return from_spherical(np.asarray(theta, float), np.asarray(phi, float))


def special_pairs() -> tuple[np.ndarray, np.ndarray]:
    """Degenerate and boundary configurations, all at or above the horizon."""
    wi, wo = [], []

    def add(a, b):
        wi.append(unit(a))
        wo.append(unit(b))

    add(Z, Z)  # poles
    for a in (1e-9, 0.3, 1.0, math.pi / 2 - 1e-9, math.pi / 2):
        for p in (0.0, 0.7, math.pi, 5.0):
            d = dirs(a, p)
            add(d, d * [-1, -1, 1])  # mirror about n: h == n
            add(d, dirs(a, p + math.pi + 1e-9))  # h ≈ n
            add(d, d)  # wi == wo
            add(d, Z)
            add(Z, d)
    for g in (math.pi / 2, math.pi / 2 - 1e-9):  # grazing, both
        for p, q in ((0.0, 0.0), (0.0, 1.0), (0.3, 2.0), (1.0, math.pi), (0.0, math.pi / 2)):
            add(dirs(g, p), dirs(g, q))
            add(dirs(g, p), dirs(0.4, q))
    for b in (0.0, 0.5, math.pi / 2, 2.0, math.pi, 4.0):  # wi ≈ −wo horizontal
        d = np.array([math.cos(b), math.sin(b), 0.0])
        add(d, -d)
        add(d, -d + [0, 0, 1e-9])
        add(d + [0, 0, 1e-9], -d + [0, 0, 1e-12])
        add(d + [0, 0, 1e-17], -d)
    for a in (0.0, 0.2, 1.0, math.pi / 2):  # grazing retro-reflection: h = ±t
        add([math.cos(a), math.sin(a), 0], [math.cos(a), -math.sin(a), 0])
        add([-math.cos(a), math.sin(a), 0], [-math.cos(a), -math.sin(a), 0])
        add([math.cos(a), math.sin(a), 1e-9], [math.cos(a), -math.sin(a), 1e-9])
    add([1, 0, 0], [1, 0, 0])
    add([-1, 0, 0], [-1, 0, 0])
    return np.array(wi), np.array(wo)


def same_directions(p, wi, wo, wi2, wo2, atol):
    """Equal directions; for isotropic parameterisations equal up to a rotation about z."""
    if p.isotropic:

        def inv(a, b):
            return np.stack(
                [
                    a[:, 2],
                    b[:, 2],
                    a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1],
                    a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
                ],
                axis=-1,
            )

        np.testing.assert_allclose(inv(wi2, wo2), inv(wi, wo), rtol=0, atol=atol)
    else:
        np.testing.assert_allclose(wi2, wi, rtol=0, atol=atol)
        np.testing.assert_allclose(wo2, wo, rtol=0, atol=atol)


def random_coords(p, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    cols = []
    for ax in p.axes:
        cols.append(rng.uniform(ax.lo, ax.hi, size=n))
    uniform = np.stack(cols, axis=-1)
    picked = np.stack(
        [
            ax.centres(r)[rng.integers(0, r, size=n)]
            for ax, r in zip(p.axes, p.default_resolution, strict=True)
        ],
        axis=-1,
    )
    return np.concatenate([uniform, picked])


# --------------------------------------------------------------------------- registry


def test_registry_contents():
    assert list(PARAMETERIZATIONS) == NAMES
    for name, p in PARAMETERIZATIONS.items():
        assert p.name == name
        assert len(p.axes) == len(p.default_resolution) == p.ndim
        flat = sorted(p.split[0] + p.split[1])
        assert flat == list(range(p.ndim)), name
        assert p.split[0] and p.split[1]
    assert PARAMETERIZATIONS["io"].default_resolution == (90, 180, 90, 180)
    assert PARAMETERIZATIONS["io_iso"].default_resolution == (90, 180, 90)
    assert PARAMETERIZATIONS["hd"].default_resolution == (90, 45, 90, 45)
    assert PARAMETERIZATIONS["hd"].axes[0].warp == "sqrt"
    assert PARAMETERIZATIONS["hd_iso"].default_resolution == (90, 90, 180)
    assert PARAMETERIZATIONS["gs"].default_resolution == (32, 32, 32, 32)
    assert PARAMETERIZATIONS["ea"].default_resolution == (90, 90, 180, 180)


def test_get_parameterization():
    assert get_parameterization("io", False).name == "io"
    assert get_parameterization("io", True).name == "io_iso"
    assert get_parameterization("hd", False).name == "hd"
    assert get_parameterization("hd", True).name == "hd_iso"
    assert get_parameterization("gs", True).name == "gs"
    assert get_parameterization("ea", True).name == "ea"
    assert get_parameterization("hd_iso", False).name == "hd_iso"
    with pytest.raises(ValueError, match="io_iso"):
        get_parameterization("merl", False)


def test_grid_layout():
    p = PARAMETERIZATIONS["hd_iso"]
    g = p.grid((3, 4, 5))
    assert g.shape == (60, 3)
    table = g.reshape(3, 4, 5, 3)
    np.testing.assert_allclose(table[:, 0, 0, 0], p.axes[0].centres(3))
    np.testing.assert_allclose(table[0, :, 0, 1], p.axes[1].centres(4))
    np.testing.assert_allclose(table[0, 0, :, 2], p.axes[2].centres(5))
    with pytest.raises(ValueError):
        p.grid((3, 4))


# --------------------------------------------------------------------------- spherical


def test_spherical_poles_and_rounding():
    v = np.array([[0, 0, 1], [0, 0, -1], [0, 0, 1 + 1e-15], [-0.0, -0.0, 1], [1, 0, 0], [0, -1, 0]])
    with np.errstate(all="raise"):
        th, ph = spherical(v)
    np.testing.assert_allclose(th, [0, math.pi, 0, 0, math.pi / 2, math.pi / 2], atol=1e-15)
    np.testing.assert_allclose(ph, [0, 0, 0, 0, 0, 3 * math.pi / 2], atol=1e-15)
    assert np.all((ph >= 0) & (ph < 2 * math.pi))
    # tiny negative y must wrap to [0, 2π), never to 2π itself
    _, ph = spherical(np.array([1.0, -1e-300, 0.0]))
    assert 0 <= ph < 2 * math.pi


def test_spherical_round_trip():
    rng = np.random.default_rng(1)
    v = unit(rng.normal(size=(1000, 3)))
    th, ph = spherical(v)
    np.testing.assert_allclose(from_spherical(th, ph), v, atol=1e-14)


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("name", NAMES)
def test_coords_round_trip(name):
    """coords → (wi, wo) → coords on random valid coordinates."""
    p = PARAMETERIZATIONS[name]
    c = random_coords(p, 5000, seed=2)
    wi, wo, valid = p.inverse(c)
    assert valid.sum() > 1000
    c, wi, wo = c[valid], wi[valid], wo[valid]
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(wo, axis=1), 1, atol=1e-12)
    c2 = p.forward(wi, wo)
    # the directions always agree
    wi2, wo2, valid2 = p.inverse(c2)
    assert valid2.all()
    np.testing.assert_allclose(wi2, wi, atol=1e-9)
    np.testing.assert_allclose(wo2, wo, atol=1e-9)
    # the coordinates agree where they are defined (azimuths away from the poles)
    polar = [k for k, ax in enumerate(p.axes) if ax.name.startswith("theta")]
    defined = np.all(c[:, polar] > 1e-4, axis=1) if polar else np.ones(len(c), bool)
    assert defined.mean() > 0.9
    for k, ax in enumerate(p.axes):
        a, b = c[defined, k], c2[defined, k]
        if ax.periodic:
            diff = np.angle(np.exp(1j * (b - a)))
            np.testing.assert_allclose(diff, 0, atol=1e-8, err_msg=ax.name)
            assert np.all((b >= ax.lo) & (b < ax.hi))
        else:
            np.testing.assert_allclose(b, a, atol=1e-8, err_msg=ax.name)


@pytest.mark.parametrize("name", NAMES)
def test_directions_round_trip(name):
    """(wi, wo) → coords → (wi, wo) on random hemisphere pairs."""
    p = PARAMETERIZATIONS[name]
    wi, wo = random_pairs(20000, seed=3)
    c = p.forward(wi, wo)
    wi2, wo2, valid = p.inverse(c)
    assert valid.all()
    same_directions(p, wi, wo, wi2, wo2, atol=1e-7)
    for k, ax in enumerate(p.axes):
        if ax.periodic:
            assert np.all((c[:, k] >= ax.lo) & (c[:, k] < ax.hi))
        else:
            assert np.all((c[:, k] >= ax.lo) & (c[:, k] <= ax.hi))


@pytest.mark.parametrize("name", NAMES)
def test_degenerate_configurations_are_finite(name):
    p = PARAMETERIZATIONS[name]
    wi, wo = special_pairs()
    rwi, rwo = random_pairs(100_000, seed=4)
    for a, b in ((wi, wo), (rwi, rwo)):
        with np.errstate(all="raise"):
            c = p.forward(a, b)
            wi2, wo2, valid = p.inverse(c)
        assert np.isfinite(c).all()
        assert np.isfinite(wi2).all() and np.isfinite(wo2).all()
        assert valid.all()
        same_directions(p, a, b, wi2, wo2, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_inverse_of_bad_coords_is_finite(name):
    p = PARAMETERIZATIONS[name]
    rng = np.random.default_rng(5)
    c = rng.uniform(-10, 10, size=(1000, p.ndim))
    c[0] = np.nan
    c[1, 0] = np.inf
    c[2, -1] = -np.inf
    with np.errstate(all="raise"):
        wi, wo, valid = p.inverse(c)
    assert np.isfinite(wi).all() and np.isfinite(wo).all()
    assert not valid[:3].any()
    tol = p.horizon_tolerance
    assert np.all(wi[valid][:, 2] >= -tol) and np.all(wo[valid][:, 2] >= -tol)


def test_shapes():
    p = PARAMETERIZATIONS["hd"]
    wi, wo = random_pairs(10, seed=6)
    assert p.forward(wi.reshape(2, 5, 3), wo.reshape(2, 5, 3)).shape == (2, 5, 4)
    assert p.forward(Z, Z).shape == (4,)
    assert p.forward(Z, wo).shape == (10, 4)  # broadcast
    a, b, v = p.inverse(np.zeros((2, 5, 4)))
    assert a.shape == b.shape == (2, 5, 3) and v.shape == (2, 5)
    with pytest.raises(ValueError):
        p.forward(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(ValueError):
        p.inverse(np.zeros((3, 3)))


# --------------------------------------------------------------------------- known values


def test_known_values_poles():
    hd = PARAMETERIZATIONS["hd"].forward(Z, Z)
    np.testing.assert_allclose(hd[[0, 2]], 0, atol=1e-15)
    np.testing.assert_allclose(PARAMETERIZATIONS["gs"].forward(Z, Z), 0, atol=1e-15)
    np.testing.assert_allclose(PARAMETERIZATIONS["io"].forward(Z, Z), 0, atol=1e-15)
    np.testing.assert_allclose(PARAMETERIZATIONS["hd_iso"].forward(Z, Z)[:2], 0, atol=1e-15)


@pytest.mark.parametrize("a", [0.0, 0.2, 0.9, math.pi / 2 - 1e-9, math.pi / 2])
def test_known_values_mirror(a):
    wi = np.array([math.sin(a), 0, math.cos(a)])
    wo = np.array([-math.sin(a), 0, math.cos(a)])
    th, ph, td, pd = PARAMETERIZATIONS["hd"].forward(wi, wo)
    assert th == pytest.approx(0, abs=1e-12)
    assert td == pytest.approx(a, abs=1e-12)
    assert pd == pytest.approx(0, abs=1e-12)
    th, td, pd = PARAMETERIZATIONS["hd_iso"].forward(wi, wo)
    assert (th, td) == pytest.approx((0, a), abs=1e-12)
    gs = PARAMETERIZATIONS["gs"].forward(wi, wo)
    np.testing.assert_allclose(gs, [0, 0, math.sin(a), 0], atol=1e-12)


def test_known_values_hd_specular_and_opposite():
    a = 0.6
    d = np.array([0.0, math.sin(a), math.cos(a)])
    th, ph, td, pd = PARAMETERIZATIONS["hd"].forward(d, d)
    assert (th, ph, td) == pytest.approx((a, math.pi / 2, 0), abs=1e-12)
    # wi == −wo: h undefined → n, θd = π/2
    c = PARAMETERIZATIONS["hd"].forward([1, 0, 0], [-1, 0, 0])
    np.testing.assert_allclose(c, [0, 0, math.pi / 2, 0], atol=1e-15)
    np.testing.assert_allclose(
        PARAMETERIZATIONS["gs"].forward([1, 0, 0], [-1, 0, 0]), [0, 0, 1, 0], atol=1e-15
    )
    # Rusinkiewicz: rotating both directions about n changes only φh
    wi, wo = dirs(0.5, 0.3), dirs(1.1, 2.0)
    c1 = PARAMETERIZATIONS["hd"].forward(wi, wo)
    c2 = PARAMETERIZATIONS["hd"].forward(dirs(0.5, 1.3), dirs(1.1, 3.0))
    np.testing.assert_allclose(c2[[0, 2, 3]], c1[[0, 2, 3]], atol=1e-12)
    assert c2[1] - c1[1] == pytest.approx(1.0, abs=1e-12)


def test_known_values_io():
    wi, wo = dirs(0.3, math.pi / 2), dirs(1.2, math.pi / 4)
    np.testing.assert_allclose(
        PARAMETERIZATIONS["io"].forward(wi, wo), [0.3, math.pi / 2, 1.2, math.pi / 4], atol=1e-14
    )
    np.testing.assert_allclose(
        PARAMETERIZATIONS["ea"].forward(wi, wo), [0.3, 1.2, math.pi / 2, math.pi / 4], atol=1e-14
    )
    np.testing.assert_allclose(
        PARAMETERIZATIONS["io_iso"].forward(wi, wo), [0.3, 7 * math.pi / 4, 1.2], atol=1e-14
    )
    wi2, wo2, valid = PARAMETERIZATIONS["io_iso"].inverse([0.3, 7 * math.pi / 4, 1.2])
    assert valid
    np.testing.assert_allclose(wi2, dirs(0.3, 0.0), atol=1e-15)
    np.testing.assert_allclose(wo2, dirs(1.2, 7 * math.pi / 4), atol=1e-15)


def test_known_values_gs():
    a = 0.7
    d = np.array([math.sin(a), 0, math.cos(a)])
    np.testing.assert_allclose(
        PARAMETERIZATIONS["gs"].forward(d, d), [math.sin(a), 0, 0, 0], atol=1e-15
    )
    # grazing retro-reflection: h = t exactly, frame guarded (t' = −n, s' = s)
    b = 0.4
    wi = np.array([math.cos(b), math.sin(b), 0.0])
    wo = np.array([math.cos(b), -math.sin(b), 0.0])
    with np.errstate(all="raise"):
        c = PARAMETERIZATIONS["gs"].forward(wi, wo)
        wi2, wo2, valid = PARAMETERIZATIONS["gs"].inverse(c)
    np.testing.assert_allclose(c, [1, 0, 0, math.sin(b)], atol=1e-15)
    assert valid
    np.testing.assert_allclose(wi2, wi, atol=1e-15)
    np.testing.assert_allclose(wo2, wo, atol=1e-15)
    # t' ⟂ h and wi·h = dz ≥ 0 for random pairs
    rwi, rwo = random_pairs(1000, seed=7)
    c = PARAMETERIZATIONS["gs"].forward(rwi, rwo)
    assert np.all(c[:, 0] ** 2 + c[:, 1] ** 2 <= 1 + 1e-12)
    assert np.all(c[:, 2] ** 2 + c[:, 3] ** 2 <= 1 + 1e-12)


def test_validity():
    io = PARAMETERIZATIONS["io"]
    _, _, v = io.inverse([[0.5, 0, 0.5, 0], [1.7, 0, 0.5, 0], [0.5, 0, -0.1, 0], [0.5, 9, 0.5, -3]])
    assert v.tolist() == [True, False, False, True]
    hd = PARAMETERIZATIONS["hd"]
    _, _, v = hd.inverse(
        [[0.2, 0, 0.2, 0], [1.5, 0, 1.5, 0], [1.5, 0, 0.05, 1.0], [0.2, 0, 1.7, 0]]
    )
    assert v.tolist() == [True, False, True, False]
    gs = PARAMETERIZATIONS["gs"]
    _, _, v = gs.inverse([[0, 0, 0, 0], [0.9, 0.9, 0, 0], [0, 0, 0.8, 0.8], [0.9, 0, -0.9, 0]])
    assert v.tolist() == [True, False, False, False]


# --------------------------------------------------------------------------- Axis


@pytest.mark.parametrize("warp", ["linear", "sqrt"])
@pytest.mark.parametrize("periodic", [False, True])
def test_axis_unit_round_trip(warp, periodic):
    ax = Axis("a", -0.5, 2.5, periodic=periodic, warp=warp)
    u = np.linspace(0, 1, 101)[:-1]
    v = ax.from_unit(u)
    np.testing.assert_allclose(ax.to_unit(v), u, atol=1e-14)
    rng = np.random.default_rng(8)
    v = rng.uniform(ax.lo, ax.hi, 100)
    np.testing.assert_allclose(ax.from_unit(ax.to_unit(v)), v, atol=1e-13)
    np.testing.assert_allclose(ax.centres(4), ax.from_unit((np.arange(4) + 0.5) / 4))


def test_axis_wrap_and_clamp():
    phi = Axis("phi", 0, 2 * math.pi, periodic=True)
    assert phi.to_unit(2 * math.pi + 0.1) == pytest.approx(phi.to_unit(0.1))
    assert phi.to_unit(-0.1) == pytest.approx(phi.to_unit(2 * math.pi - 0.1))
    u = phi.to_unit(np.array([-1e-20, 2 * math.pi, -4 * math.pi]))
    assert np.all((u >= 0) & (u < 1))
    th = Axis("theta_h", 0, math.pi / 2, periodic=False, warp="sqrt")
    np.testing.assert_allclose(th.to_unit([-1.0, 3.0]), [0, 1])
    assert th.to_unit(math.pi / 8) == pytest.approx(0.5)
    assert th.centres(90)[0] == pytest.approx((0.5 / 90) ** 2 * math.pi / 2)
    with pytest.raises(ValueError):
        Axis("bad", 1, 0, periodic=False)
    with pytest.raises(ValueError):
        Axis("bad", 0, 1, periodic=False, warp="log")
    with pytest.raises(ValueError):
        th.centres(0)


def interp(table, lookup):
    i0, i1, w = lookup
    return (1 - w) * table[i0] + w * table[i1]


def test_axis_lookup_periodic_wrap():
    phi = Axis("phi", 0, 2 * math.pi, periodic=True)
    n = 180
    step = 2 * math.pi / n
    i0, i1, w = axis_lookup(phi, n, np.array([2 * math.pi - 1e-9, 0.0, 2 * math.pi - step / 2]))
    assert i0.dtype == np.int64 and i1.dtype == np.int64 and w.dtype == np.float64
    assert i0.tolist() == [n - 1, n - 1, n - 1]
    assert i1.tolist() == [0, 0, 0]
    np.testing.assert_allclose(w, [0.5, 0.5, 0.0], atol=1e-7)
    # exact at the centres, negative and >2π values wrap
    c = phi.centres(n)
    for k in (0, 7, 179):
        i0, i1, w = axis_lookup(phi, n, np.array([c[k] - 2 * math.pi, c[k] + 4 * math.pi]))
        assert np.all(((i0 == k) & (w < 1e-9)) | ((i1 == k) & (w > 1 - 1e-9)))
    # a sinusoid is reproduced, including across the seam
    v = np.random.default_rng(9).uniform(-7, 14, 1000)
    np.testing.assert_allclose(interp(np.cos(c), axis_lookup(phi, n, v)), np.cos(v), atol=2e-4)


def test_axis_lookup_edges():
    ax = Axis("theta", 0, math.pi / 2, periodic=False)
    n = 10
    c = ax.centres(n)
    table = 3 * c + 1  # a linear function of the value
    v = np.concatenate([[0.0, c[0] / 2, math.pi / 2, c[-1]], np.linspace(0, math.pi / 2, 57)])
    lin = axis_lookup(ax, n, v, edge="linear")
    np.testing.assert_allclose(interp(table, lin), 3 * v + 1, atol=1e-12)
    assert lin[2][0] == pytest.approx(-0.5) and lin[2][2] == pytest.approx(1.5)
    assert lin[0][0] == 0 and lin[1][2] == n - 1
    clamp = axis_lookup(ax, n, v, edge="clamp")
    expect = np.clip(3 * v + 1, table[0], table[-1])
    np.testing.assert_allclose(interp(table, clamp), expect, atol=1e-12)
    assert np.all((clamp[2] >= 0) & (clamp[2] <= 1))
    # out of range values are clamped into [lo, hi] first
    out = axis_lookup(ax, n, np.array([-1.0, 5.0, np.nan]))
    ref = axis_lookup(ax, n, np.array([0.0, math.pi / 2, 0.0]))
    for a, b in zip(out, ref, strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError):
        axis_lookup(ax, n, v, edge="wrap")


def test_axis_lookup_sqrt_warp_is_linear_in_u():
    ax = Axis("theta_h", 0, math.pi / 2, periodic=False, warp="sqrt")
    n = 90
    table = ax.to_unit(ax.centres(n))
    v = np.random.default_rng(10).uniform(0, math.pi / 2, 500)
    np.testing.assert_allclose(interp(table, axis_lookup(ax, n, v)), ax.to_unit(v), atol=1e-12)


@pytest.mark.parametrize("periodic", [False, True])
def test_axis_lookup_single_cell(periodic):
    ax = Axis("a", 0, 1, periodic=periodic)
    values = np.array([[0.0, 0.3], [1.0, 7.0]])
    i0, i1, w = axis_lookup(ax, 1, values)
    assert i0.shape == values.shape
    assert not i0.any() and not i1.any() and not w.any()
    assert i0.dtype == np.int64 and w.dtype == np.float64
    with pytest.raises(ValueError):
        axis_lookup(ax, 0, values)


def test_module_constants():
    assert params.HALF_VECTOR_EPS > 0 and params.VALID_EPS > 0
    assert PARAMETERIZATIONS["gs"].horizon_tolerance == params.GS_HORIZON_EPS
    assert PARAMETERIZATIONS["hd"].horizon_tolerance == params.VALID_EPS


@pytest.mark.parametrize("name", sorted(PARAMETERIZATIONS))
def test_view_axes_depend_on_the_view_alone(name):
    """``view_axes`` are exactly the coordinates that do not move when only wi moves."""
    rng = np.random.default_rng(31)
    param = get_parameterization(name)
    wo = rng.normal(size=(400, 3))
    wo[:, 2] = np.abs(wo[:, 2]) + 0.05
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)

    def upper(n):
        v = rng.normal(size=(n, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    a = param.forward(upper(400), wo)
    b = param.forward(upper(400), wo)
    moved = [k for k in range(param.ndim) if not np.array_equal(a[:, k], b[:, k])]
    assert sorted(set(range(param.ndim)) - set(moved)) == list(param.view_axes)


def test_theta_resolution_by_hand():
    """The "θ cells" setting: 90° of θ gets that many cells, every axis at least 2."""
    from spectral_materials.core.brdf.params import get_parameterization

    io = get_parameterization("io", False)                 # 90 × 180 × 90 × 180
    assert io.theta_resolution(32) == (32, 64, 32, 64)
    assert io.theta_resolution(90) == io.default_resolution
    assert io.theta_resolution(1) == (2, 2, 2, 2)
    assert get_parameterization("hd", False).theta_resolution(64) == (64, 32, 64, 32)
