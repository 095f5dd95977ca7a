"""Tests for the analytic BRDF models (spectral_materials.core.brdf.models)."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.models import (
    MODELS,
    AshikhminShirley,
    CookTorranceGGX,
    Lambert,
    OrenNayar,
    WardAnisotropic,
    fresnel_conductor,
    make_model,
)
from spectral_materials.core.colour import spectra

WL1 = np.array([550.0])
WL81 = spectra.WAVELENGTHS_REFERENCE


def direction(theta_deg: float, phi_deg: float = 0.0) -> np.ndarray:
    """One unit vector (1, 3) from polar/azimuth angles in degrees."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]])


def random_directions(rng: np.random.Generator, n: int, upper: bool = False) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if upper:
        v[:, 2] = np.abs(v[:, 2])
    return v


def all_models() -> list[models.BRDFModel]:
    """One instance of every model, with anisotropic and spectral parameters."""
    patch = spectra.colorchecker_spectrum(7)
    return [
        Lambert(albedo=patch),
        OrenNayar(albedo=patch, sigma=0.4),
        AshikhminShirley(nu=20.0, nv=300.0, diffuse=patch, specular=0.1),
        WardAnisotropic(alpha_x=0.15, alpha_y=0.4, diffuse=patch, specular=0.2),
        CookTorranceGGX(alpha_x=0.2, alpha_y=0.5, ior_n=(WL81, np.linspace(0.2, 1.3, 81)),
                        ior_k=(WL81, np.linspace(3.5, 2.0, 81)), diffuse=0.1),
    ]


MODEL_IDS = ["lambert", "oren_nayar", "ashikhmin_shirley", "ward", "ggx"]


# --------------------------------------------------------------------------- quadrature

def hemisphere_grid(n_theta: int = 180, n_phi: int = 720) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint rule in (θ, φ): directions (K, 3) and weights cos θ sin θ dθ dφ."""
    t = (np.arange(n_theta) + 0.5) * (np.pi / 2 / n_theta)
    p = (np.arange(n_phi) + 0.5) * (2 * np.pi / n_phi)
    tt, pp = np.meshgrid(t, p, indexing="ij")
    wo = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    weights = np.cos(tt) * np.sin(tt) * (np.pi / 2 / n_theta) * (2 * np.pi / n_phi)
    return wo.reshape(-1, 3), weights.ravel()


GRID = hemisphere_grid()


def directional_albedo(model, theta_i_deg: float, phi_i_deg: float = 0.0) -> float:
    """∫ f(wi, wo) cos θo dωo at 550 nm."""
    wo, weights = GRID
    wi = np.repeat(direction(theta_i_deg, phi_i_deg), len(wo), axis=0)
    return float(model(wi, wo, WL1)[:, 0] @ weights)


ANGLES = [0.0, 30.0, 60.0, 75.0, 85.0]


# --------------------------------------------------------------------------- reciprocity

@pytest.mark.parametrize("model", all_models(), ids=MODEL_IDS)
def test_reciprocity(model):
    rng = np.random.default_rng(1)
    wi = random_directions(rng, 2000)
    wo = random_directions(rng, 2000)
    wi[:1000, 2] = np.abs(wi[:1000, 2])  # half the pairs both above the horizon
    wo[:1000, 2] = np.abs(wo[:1000, 2])
    assert model.reciprocal
    forward = model(wi, wo, WL81)
    np.testing.assert_allclose(forward, model(wo, wi, WL81), rtol=1e-13, atol=0)
    assert forward.shape == (2000, 81) and forward.dtype == np.float64
    assert np.all(forward >= 0) and np.isfinite(forward).all()


@pytest.mark.parametrize("model", all_models(), ids=MODEL_IDS)
def test_zero_below_and_on_horizon(model):
    rng = np.random.default_rng(2)
    up = random_directions(rng, 50, upper=True)
    down = up * np.array([1.0, 1.0, -1.0])
    phi = rng.uniform(0, 2 * np.pi, 50)
    horizon = np.column_stack([np.cos(phi), np.sin(phi), np.zeros(50)])
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        for wi, wo in [(down, up), (up, down), (horizon, up), (up, horizon),
                       (horizon, horizon), (down, down)]:
            assert np.array_equal(model(wi, wo, WL81), np.zeros((50, 81)))
        assert np.array_equal(model(np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]]),
                                    WL1), [[0.0]])


# --------------------------------------------------------------------------- energy

@pytest.mark.parametrize("model", [
    Lambert(1.0),
    OrenNayar(1.0, sigma=0.0),
    OrenNayar(1.0, sigma=0.5),
    OrenNayar(1.0, sigma=1.0),
    OrenNayar(1.0, sigma=10.0),
    AshikhminShirley(0.0, 0.0, diffuse=0.0, specular=1.0),
    AshikhminShirley(10.0, 10.0, diffuse=0.0, specular=1.0),
    AshikhminShirley(100.0, 100.0, diffuse=0.0, specular=1.0),
    AshikhminShirley(10.0, 100.0, diffuse=0.0, specular=1.0),
    AshikhminShirley(100.0, 100.0, diffuse=1.0, specular=0.05),
    AshikhminShirley(10.0, 10.0, diffuse=1.0, specular=0.0),
    WardAnisotropic(0.1, 0.1, diffuse=0.0, specular=1.0),
    WardAnisotropic(0.3, 0.3, diffuse=0.5, specular=0.5),
    WardAnisotropic(1.0, 1.0, diffuse=0.0, specular=1.0),
    WardAnisotropic(1.0, 0.1, diffuse=0.0, specular=1.0),
    WardAnisotropic(5.0, 5.0, diffuse=0.0, specular=1.0),
    CookTorranceGGX(0.1, 0.1, ior_n=1e-3, ior_k=100.0),
    CookTorranceGGX(0.3, 0.3, ior_n=0.05, ior_k=4.0),
    CookTorranceGGX(1.0, 1.0, ior_n=1e-3, ior_k=100.0),
    CookTorranceGGX(0.15, 0.6, ior_n=1e-3, ior_k=100.0),
    CookTorranceGGX(0.3, 0.3, ior_n=1.5, ior_k=0.0, diffuse=0.5),
], ids=repr)
def test_directional_albedo_at_most_one(model):
    params = model.describe()
    anisotropic = any(params.get(a) != params.get(b)
                      for a, b in (("nu", "nv"), ("alpha_x", "alpha_y")))
    for theta in ANGLES:
        for phi in (0.0, 90.0) if anisotropic else (0.0,):
            albedo = directional_albedo(model, theta, phi)
            assert 0.0 < albedo <= 1.0 + 2e-3, (theta, phi, albedo)


def test_lambert_albedo_is_exact():
    for theta in ANGLES:
        assert directional_albedo(Lambert(0.6), theta) == pytest.approx(0.6, rel=2e-4)


def test_ggx_albedo_alpha_one_closed_form():
    # α = 1 makes D = 1/π; at normal incidence G2 = 2 cos θo / (1 + cos θo), so the
    # albedo is ∫₀¹ μ / (1 + μ) dμ = 1 − ln 2 (times F ≈ 1 for k = 100).
    albedo = directional_albedo(CookTorranceGGX(1.0, 1.0, ior_n=1e-3, ior_k=100.0), 0.0)
    assert albedo == pytest.approx(1.0 - np.log(2.0), rel=1e-3)


def test_ward_albedo_holds_up_to_89_degrees_and_breaks_at_the_horizon():
    ward = WardAnisotropic(0.7, 0.7, diffuse=0.0, specular=1.0)
    assert directional_albedo(ward, 89.0) < 1.0
    assert directional_albedo(ward, 89.9) > 1.0  # documented limit of Ward's normalisation


def test_oren_nayar_albedo_excess_is_small():
    # Documented: the qualitative model overshoots by <= 1.5 % at grazing for σ ≈ 0.2.
    model = OrenNayar(1.0, sigma=0.2)
    values = [directional_albedo(model, theta) for theta in (60.0, 80.0, 89.0)]
    assert max(values) > 1.0
    assert max(values) < 1.016


# --------------------------------------------------------------------------- reference values

@pytest.mark.parametrize("wavelengths", [WL1, WL81], ids=["L1", "L81"])
def test_lambert_exact(wavelengths):
    rng = np.random.default_rng(3)
    wi, wo = random_directions(rng, 100, True), random_directions(rng, 100, True)
    albedo = spectra.colorchecker(3, wavelengths)
    value = Lambert(spectra.colorchecker_spectrum(3))(wi, wo, wavelengths)
    assert value.shape == (100, wavelengths.size)
    np.testing.assert_allclose(value, np.broadcast_to(albedo / np.pi, value.shape), rtol=1e-15)
    np.testing.assert_array_equal(Lambert(0.5)(wi, wo, wavelengths), 0.5 / np.pi)


def test_oren_nayar_sigma_zero_is_lambert():
    rng = np.random.default_rng(4)
    wi, wo = random_directions(rng, 500), random_directions(rng, 500)
    patch = spectra.colorchecker_spectrum(12)
    np.testing.assert_array_equal(OrenNayar(patch, sigma=0.0)(wi, wo, WL81),
                                  Lambert(patch)(wi, wo, WL81))


def test_oren_nayar_hand_computed():
    # σ = 0.5: A = 1 − 0.5·0.25/0.58, B = 0.45·0.25/0.34; θi = 60°, θo = 30°, same azimuth:
    # sin α tan β = sin 60° tan 30° = 1/2.
    a = 1.0 - 0.125 / 0.58
    b = 0.1125 / 0.34
    model = OrenNayar(0.7, sigma=0.5)
    same = model(direction(60.0, 40.0), direction(30.0, 40.0), WL1)
    assert same[0, 0] == pytest.approx(0.7 / np.pi * (a + 0.5 * b), rel=1e-14)
    assert 0.7 / np.pi * (a + 0.5 * b) == pytest.approx(0.7 / np.pi * 0.949923935091277, rel=1e-12)
    # Azimuth difference 60°: cos = 1/2. Opposite (180°) or perpendicular: A only.
    sixty = model(direction(60.0, 10.0), direction(30.0, 70.0), WL1)
    assert sixty[0, 0] == pytest.approx(0.7 / np.pi * (a + 0.25 * b), rel=1e-14)
    for phi_o in (130.0, 220.0):
        value = model(direction(60.0, 40.0), direction(30.0, phi_o), WL1)
        assert value[0, 0] == pytest.approx(0.7 / np.pi * a, rel=1e-14)
    # At the pole the azimuth is undefined and the term vanishes.
    pole = model(direction(0.0), direction(70.0, 123.0), WL1)
    assert pole[0, 0] == pytest.approx(0.7 / np.pi * a, rel=1e-14)


def test_ashikhmin_shirley_normal_incidence_closed_form():
    nu, nv, rd, rs = 30.0, 500.0, 0.6, 0.04
    n = direction(0.0)
    value = AshikhminShirley(nu, nv, diffuse=rd, specular=rs)(n, n, WL1)[0, 0]
    # h = n, h·k = 1, cos θi = cos θo = 1: the lobe is 1 and F(1) = Rs.
    specular = np.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * rs
    diffuse = 28 * rd / (23 * np.pi) * (1 - rs) * (1 - 0.5**5) ** 2
    assert value == pytest.approx(specular + diffuse, rel=1e-14)


@pytest.mark.parametrize("plane, exponent_name", [(0.0, "nu"), (90.0, "nv")])
def test_ashikhmin_shirley_off_specular_in_a_principal_plane(plane, exponent_name):
    nu, nv, rd, rs = 30.0, 500.0, 0.3, 0.1
    exponent = {"nu": nu, "nv": nv}[exponent_name]
    a, b = np.radians(50.0), np.radians(10.0)  # polar angles of wi and wo, same azimuth
    th, half = (a + b) / 2, (a - b) / 2  # h at θh = 30° in that plane; h·k = cos 20°
    model = AshikhminShirley(nu, nv, diffuse=rd, specular=rs)
    value = model(direction(50.0, plane), direction(10.0, plane), WL1)[0, 0]
    hk = np.cos(half)
    fresnel = rs + (1 - rs) * (1 - hk) ** 5
    specular = (np.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * np.cos(th) ** exponent
                / (hk * max(np.cos(a), np.cos(b))) * fresnel)
    diffuse = (28 * rd / (23 * np.pi) * (1 - rs) * (1 - (1 - np.cos(a) / 2) ** 5)
               * (1 - (1 - np.cos(b) / 2) ** 5))
    assert value == pytest.approx(specular + diffuse, rel=1e-12)


def test_ward_reference_values():
    ax, ay, rd, rs = 0.2, 0.35, 0.4, 0.3
    model = WardAnisotropic(ax, ay, diffuse=rd, specular=rs)
    n = direction(0.0)
    expected = rd / np.pi + rs / (4 * np.pi * ax * ay)
    assert model(n, n, WL1)[0, 0] == pytest.approx(expected, rel=1e-14)
    # h tilted by 30° in the xz plane: exponent tan²30°/αx².
    value = model(direction(50.0), direction(10.0), WL1)[0, 0]
    lobe = np.exp(-np.tan(np.radians(30.0)) ** 2 / ax**2)
    lobe /= 4 * np.pi * ax * ay * np.sqrt(np.cos(np.radians(50.0)) * np.cos(np.radians(10.0)))
    assert value == pytest.approx(rd / np.pi + rs * lobe, rel=1e-12)


@pytest.mark.parametrize("wavelengths", [WL1, WL81], ids=["L1", "L81"])
def test_ggx_normal_incidence(wavelengths):
    ax, ay = 0.3, 0.12
    n_spec = (WL81, np.linspace(0.15, 1.8, 81))
    k_spec = (WL81, np.linspace(4.0, 0.0, 81))
    model = CookTorranceGGX(ax, ay, ior_n=n_spec, ior_k=k_spec, diffuse=0.05)
    n = spectra.spectrum_values(n_spec, wavelengths)
    k = spectra.spectrum_values(k_spec, wavelengths)
    fresnel = ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)
    up = direction(0.0)
    # D(n) = 1/(π αx αy), G2 = 1, 4 cos θi cos θo = 4.
    expected = fresnel / (np.pi * ax * ay) / 4 + 0.05 / np.pi
    value = model(up, up, wavelengths)
    assert value.shape == (1, wavelengths.size)
    np.testing.assert_allclose(value[0], expected, rtol=1e-13)


@pytest.mark.parametrize("plane, alpha_name", [(0.0, "x"), (90.0, "y")])
def test_ggx_off_specular_against_textbook_formulas(plane, alpha_name):
    ax, ay, n_ior, k_ior = 0.25, 0.6, 0.2, 3.0
    alpha = {"x": ax, "y": ay}[alpha_name]
    a, b = np.radians(50.0), np.radians(10.0)
    model = CookTorranceGGX(ax, ay, ior_n=n_ior, ior_k=k_ior)
    value = model(direction(50.0, plane), direction(10.0, plane), WL1)[0, 0]
    th = (a + b) / 2
    d = 1 / (np.pi * ax * ay * (np.sin(th) ** 2 / alpha**2 + np.cos(th) ** 2) ** 2)

    def lam(theta):  # Heitz 2014, Λ for a direction in the principal plane of `alpha`
        return (-1 + np.sqrt(1 + alpha**2 * np.tan(theta) ** 2)) / 2

    g2 = 1 / (1 + lam(a) + lam(b))
    f = fresnel_conductor(np.array([np.cos((a - b) / 2)]), n_ior, k_ior)[0, 0]
    assert value == pytest.approx(d * g2 * f / (4 * np.cos(a) * np.cos(b)), rel=1e-12)


def born_wolf_reflectance(theta, n, k):
    """Conductor Fresnel in the real a, b form (Born & Wolf §14.2), independent code."""
    s2, c = np.sin(theta) ** 2, np.cos(theta)
    t = n**2 - k**2 - s2
    ab = np.sqrt(t**2 + 4 * n**2 * k**2)
    a = np.sqrt((ab + t) / 2)
    rs = (ab - 2 * a * c + c**2) / (ab + 2 * a * c + c**2)
    st = np.sin(theta) * np.tan(theta)
    rp = rs * (ab - 2 * a * st + st**2) / (ab + 2 * a * st + st**2)
    return (rs + rp) / 2


def test_fresnel_conductor():
    n = np.array([0.05, 0.2, 1.5, 1.0, 2.4])
    k = np.array([4.0, 3.0, 0.0, 0.0, 1.2])
    normal = fresnel_conductor(np.array([1.0]), n, k)[0]
    np.testing.assert_allclose(normal, ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2), rtol=1e-14)
    interface = n != 1.0  # n = 1, k = 0 is no interface at all: R = 0 at every angle
    grazing = fresnel_conductor(np.array([0.0]), n, k)[0]
    np.testing.assert_array_equal(grazing, np.where(interface, 1.0, 0.0))
    near = fresnel_conductor(np.array([np.cos(np.radians(89.999))]), n, k)[0]
    assert np.all(near[interface] > 0.99) and np.all(near <= 1.0)
    assert near[~interface] == pytest.approx(0.0, abs=1e-15)
    for deg in (20.0, 45.0, 70.0, 85.0):
        theta = np.radians(deg)
        got = fresnel_conductor(np.array([np.cos(theta)]), n, k)[0]
        np.testing.assert_allclose(got, born_wolf_reflectance(theta, n, k), rtol=1e-12, atol=1e-15)
    # Dielectric, textbook real form.
    theta, eta = np.radians(40.0), 1.5
    ct = np.sqrt(1 - (np.sin(theta) / eta) ** 2)
    r_s = ((np.cos(theta) - eta * ct) / (np.cos(theta) + eta * ct)) ** 2
    r_p = ((ct - eta * np.cos(theta)) / (ct + eta * np.cos(theta))) ** 2
    got = fresnel_conductor(np.array([np.cos(theta)]), eta, 0.0)[0, 0]
    assert got == pytest.approx((r_s + r_p) / 2, rel=1e-14)
    # Index 1: no interface, no reflection; n < 1 past the critical angle: total reflection.
    assert fresnel_conductor(np.array([0.3]), 1.0, 0.0)[0, 0] == pytest.approx(0.0, abs=1e-16)
    assert fresnel_conductor(np.array([0.1]), 0.5, 0.0)[0, 0] == pytest.approx(1.0, rel=1e-14)


# --------------------------------------------------------------------------- stiff cases

@pytest.fixture
def strict():
    with warnings.catch_warnings(), np.errstate(all="raise"):
        warnings.simplefilter("error")
        yield


def grazing_pairs(theta_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Both directions at θ, azimuth differences 0°, 1°, 90°, 179°, 180°."""
    wi = np.repeat(direction(theta_deg, 0.0), 5, axis=0)
    wo = np.concatenate([direction(theta_deg, p) for p in (0.0, 1.0, 90.0, 179.0, 180.0)])
    return wi, wo


@pytest.mark.parametrize("nu, nv", [(1e4, 1e4), (0.0, 1e4), (1e6, 1e6), (0.0, 0.0)])
def test_ashikhmin_shirley_stiff(strict, nu, nv):
    model = AshikhminShirley(nu, nv, diffuse=0.2, specular=0.05)
    n = direction(0.0)
    at_pole = model(n, n, WL81)
    if nu == nv:
        expected = np.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * 0.05
        expected += 28 * 0.2 / (23 * np.pi) * 0.95 * (1 - 0.5**5) ** 2
        np.testing.assert_allclose(at_pole, expected, rtol=1e-13)
    off = np.array([[1e-8, 0.0, 1.0]]) / np.hypot(1e-8, 1.0)
    near_pole = model(off, n, WL81)
    # log hz = −(hx² + hy²)/2 ≈ −1.25e-17 so the lobe is 1 − E·1.25e-17.
    np.testing.assert_allclose(near_pole, at_pole, rtol=max(nu, nv) * 1e-16 + 1e-14)
    assert np.all(near_pole <= at_pole * (1 + 1e-15))
    for theta in (89.9, 90.0 - 1e-9):
        value = model(*grazing_pairs(theta), WL81)
        assert np.isfinite(value).all() and np.all(value >= 0)
    # Both directions a hair above the horizon, facing each other: h = n, h·k → 0.
    tiny = np.array([[1.0, 0.0, 1e-300]]), np.array([[-1.0, 0.0, 1e-300]])
    value = model(*tiny, WL1)
    assert np.isfinite(value).all() and np.all(value > 0)


def test_ashikhmin_shirley_lobe_decays_without_nan(strict):
    model = AshikhminShirley(1e4, 1e4, diffuse=0.0, specular=1.0)
    thetas = np.array([0.0, 1e-6, 1e-3, 0.01, 0.1, 1.0, 10.0, 80.0])
    wo = np.concatenate([direction(t) for t in thetas])
    value = model(np.repeat(direction(0.0), len(thetas), axis=0), wo, WL1)[:, 0]
    assert np.isfinite(value).all() and np.all(value >= 0)
    assert np.all(np.diff(value) <= 0) and value[-1] == 0.0


@pytest.mark.parametrize("sigma", [0.0, 10.0, 1e300])
def test_oren_nayar_stiff(strict, sigma):
    model = OrenNayar(0.5, sigma=sigma)
    rng = np.random.default_rng(5)
    wi, wo = random_directions(rng, 200, True), random_directions(rng, 200, True)
    wi[0] = wo[1] = [0.0, 0.0, 1.0]  # poles
    for pair in [(wi, wo), grazing_pairs(89.9), grazing_pairs(90.0 - 1e-9)]:
        value = model(*pair, WL81)
        assert np.isfinite(value).all() and np.all(value >= 0)
    if sigma == 0.0:
        np.testing.assert_array_equal(model(wi, wo, WL81), 0.5 / np.pi)


@pytest.mark.parametrize("model", [
    WardAnisotropic(1e-6, 10.0, diffuse=0.1, specular=0.9),
    WardAnisotropic(10.0, 10.0, diffuse=0.1, specular=0.9),
    CookTorranceGGX(1e-4, 1e-4, ior_n=0.2, ior_k=3.0),
    CookTorranceGGX(1e-4, 1.0, ior_n=1.5, ior_k=0.0),
    CookTorranceGGX(1.0, 1.0, ior_n=100.0, ior_k=100.0),
], ids=repr)
def test_ward_and_ggx_stiff(strict, model):
    n = direction(0.0)
    assert np.isfinite(model(n, n, WL81)).all()
    rng = np.random.default_rng(6)
    wi, wo = random_directions(rng, 500, True), random_directions(rng, 500, True)
    for pair in [(wi, wo), grazing_pairs(89.9), grazing_pairs(90.0 - 1e-9),
                 (np.array([[1.0, 0.0, 1e-300]]), np.array([[-1.0, 0.0, 1e-300]]))]:
        value = model(*pair, WL81)
        assert np.isfinite(value).all() and np.all(value >= 0)


def test_ggx_small_alpha_peak():
    model = CookTorranceGGX(1e-4, 1e-4, ior_n=0.2, ior_k=3.0)
    n = direction(0.0)
    peak = model(n, n, WL1)[0, 0]
    fresnel = (0.8**2 + 9.0) / (1.2**2 + 9.0)
    assert peak == pytest.approx(fresnel / (4 * np.pi * 1e-8), rel=1e-12)
    assert model(n, direction(5.0), WL1)[0, 0] < 1e-6 * peak


# --------------------------------------------------------------------------- validation

@pytest.mark.parametrize("model", all_models(), ids=MODEL_IDS)
def test_invalid_directions_raise(model):
    good = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
    nan = good.copy()
    nan[1, 0] = np.nan
    with pytest.raises(ValueError, match="wi contains NaN"):
        model(nan, good, WL81)
    with pytest.raises(ValueError, match="wo contains NaN"):
        model(good, np.where(np.isnan(nan), np.inf, nan), WL81)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        model(good[:, :2], good, WL81)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        model(good[0], good[0], WL81)
    with pytest.raises(ValueError, match="same shape"):
        model(good, good[:1], WL81)
    with pytest.raises(ValueError, match="unit vectors"):
        model(good * 2.0, good, WL81)
    with pytest.raises(ValueError, match="unit vectors"):
        model(np.zeros((1, 3)), good[:1], WL81)
    with pytest.raises(ValueError, match="1-D"):
        model(good, good, WL81[None, :])
    with pytest.raises(ValueError):
        model(good, good, WL81[::-1])
    assert model(np.zeros((0, 3)), np.zeros((0, 3)), WL81).shape == (0, 81)


@pytest.mark.parametrize("cls, kwargs, word", [
    (Lambert, {"albedo": 1.5}, "albedo"),
    (Lambert, {"albedo": (WL81, np.full(81, -0.1))}, "albedo"),
    (Lambert, {"albedo": "red"}, "albedo"),
    (OrenNayar, {"sigma": -0.1}, "sigma"),
    (OrenNayar, {"sigma": np.nan}, "sigma"),
    (AshikhminShirley, {"nu": -1.0}, "nu"),
    (AshikhminShirley, {"nv": 2e6}, "nv"),
    (AshikhminShirley, {"specular": 1.2}, "specular"),
    (WardAnisotropic, {"alpha_x": 0.0}, "alpha_x"),
    (WardAnisotropic, {"alpha_y": 11.0}, "alpha_y"),
    (WardAnisotropic, {"diffuse": -0.2}, "diffuse"),
    (CookTorranceGGX, {"alpha_x": 1e-5}, "alpha_x"),
    (CookTorranceGGX, {"alpha_y": 1.5}, "alpha_y"),
    (CookTorranceGGX, {"ior_n": 0.0}, "ior_n"),
    (CookTorranceGGX, {"ior_k": -1.0}, "ior_k"),
])
def test_invalid_parameters_raise(cls, kwargs, word):
    with pytest.raises(ValueError, match=word):
        cls(**kwargs)


def test_callable_spectrum_checked_per_grid_and_cached():
    calls = []

    def albedo(wl):
        calls.append(wl.size)
        return np.where(wl > 1000.0, 2.0, 0.5)

    model = Lambert(albedo)
    n = direction(0.0)
    for _ in range(3):
        model(n, n, WL81)
        model(n, n, WL1)
    assert calls == [81, 1]  # reference grid at construction, then 550 nm once
    with pytest.raises(ValueError, match="albedo"):
        model(n, n, np.array([1200.0]))


# --------------------------------------------------------------------------- registry

def test_registry_and_describe_round_trip():
    assert set(MODELS) == {"lambert", "oren_nayar", "ashikhmin_shirley", "ward", "ggx"}
    rng = np.random.default_rng(7)
    wi, wo = random_directions(rng, 100, True), random_directions(rng, 100, True)
    for model in all_models():
        info = json.loads(json.dumps(model.describe()))
        assert MODELS[info["name"]] is type(model)
        rebuilt = make_model(**info)
        np.testing.assert_allclose(rebuilt(wi, wo, WL81), model(wi, wo, WL81), rtol=1e-14)
    assert make_model("lambert", albedo=0.3).describe() == {"name": "lambert", "albedo": 0.3}
    assert isinstance(make_model("GGX"), CookTorranceGGX)
    with pytest.raises(ValueError, match="unknown BRDF model"):
        make_model("phong")
    with pytest.raises(ValueError, match="sigma"):
        make_model("lambert", sigma=0.2)
