"""The "horizon" edge rule (core/brdf/axes.py): a cosine-weighted table f·cosθi falls to 0
at θi = 90°, where linear extrapolation beyond the last cell centre does not.

References are the functions themselves (cos θ, a Lambertian's and Oren–Nayar's f·cosθi
from the analytic model), never the lookup.
"""

import math

import numpy as np
import pytest

from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.axes import Axis, axis_lookup, horizon_scale
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.params import get_parameterization
from spectral_materials.core.colour import spectra

THETA_I = Axis("theta_i", 0.0, math.pi / 2, periodic=False, horizon=True)
THETA_O = Axis("theta_o", 0.0, math.pi / 2, periodic=False)
WL = spectra.WAVELENGTHS_REFERENCE[::4]


def _interp(table, lookup, scale=1.0):
    i0, i1, w = lookup
    return ((1 - w) * table[i0] + w * table[i1]) * scale


def test_hand_values_on_four_cells():
    """Centres 11.25°, 33.75°, 56.25°, 78.75°: at 84.375° (x = 3.25) the lookup holds cell 3
    and the scale is 2·(3.5 − 3.25) = 0.5; at 90° it is 0; up to 78.75° it is 1."""
    v = np.radians([0.0, 45.0, 78.75, 84.375, 90.0])
    i0, i1, w = axis_lookup(THETA_I, 4, v, edge="horizon")
    assert i0.tolist() == [0, 1, 2, 2, 2] and i1.tolist() == [1, 2, 3, 3, 3]
    np.testing.assert_allclose(w, [-0.5, 0.5, 1.0, 1.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(horizon_scale(THETA_I, 4, v), [1, 1, 1, 0.5, 0], atol=1e-12)


def test_cosine_reaches_zero_at_the_horizon_and_linear_does_not():
    n = 8
    table = np.cos(THETA_I.centres(n))
    v = np.radians(np.linspace(80.0, 90.0, 101))
    horizon = _interp(table, axis_lookup(THETA_I, n, v, edge="horizon"),
                      horizon_scale(THETA_I, n, v))
    linear = _interp(table, axis_lookup(THETA_I, n, v, edge="linear"))
    assert horizon[-1] == 0.0
    assert abs(linear[-1]) > 1e-3                      # linear misses the cosine's zero
    last = THETA_I.centres(n)[-1]
    beyond = v > last
    # Between the last centre and the horizon the rule is exact to the cosine's
    # curvature: |cos − chord| ≤ h²/8 · max|cos''| with h = half a cell.
    half_cell = math.pi / 2 / n / 2
    assert np.max(np.abs(horizon[beyond] - np.cos(v[beyond]))) <= half_cell**2 / 8 + 1e-12
    assert np.all(np.diff(horizon[beyond]) <= 0)       # falls monotonically


def _same_lookups(first: tuple, second: tuple, n: int, v: np.ndarray) -> None:
    """axis_lookup under (axis, edge) ``first`` and ``second`` agree at ``v``."""
    for a, b in zip(axis_lookup(first[0], n, v, edge=first[1]),
                    axis_lookup(second[0], n, v, edge=second[1]), strict=True):
        np.testing.assert_array_equal(a, b)


def test_other_axes_and_the_low_end_stay_linear():
    n = 10
    v = np.linspace(0.0, math.pi / 2, 77)
    _same_lookups((THETA_O, "horizon"), (THETA_O, "linear"), n, v)
    assert np.all(horizon_scale(THETA_O, n, v) == 1.0)
    low = v < THETA_I.centres(n)[0]
    _same_lookups((THETA_I, "horizon"), (THETA_I, "linear"), n, v[low])


def test_n_dimensional_nan_and_inf():
    v = np.array([[np.nan, np.inf], [-np.inf, 0.3], [2.0, -1.0]])
    scale = horizon_scale(THETA_I, 6, v)
    assert scale.shape == v.shape
    np.testing.assert_array_equal(scale, [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    i0, i1, w = axis_lookup(THETA_I, 6, v, edge="horizon")
    assert i0.shape == v.shape and np.isfinite(w).all() and np.all(w <= 1.0)
    with pytest.raises(ValueError, match="at least one cell"):
        horizon_scale(THETA_I, 0, v)


def test_a_periodic_axis_cannot_be_a_horizon():
    with pytest.raises(ValueError, match="periodic axis has no horizon"):
        Axis("phi", 0.0, 2 * math.pi, periodic=True, horizon=True)


def test_theta_i_is_the_only_horizon_axis_of_each_parameterisation():
    for name, iso in (("io", False), ("io_iso", True), ("ea", False), ("hd", False),
                      ("hd_iso", True), ("gs", False)):
        axes = get_parameterization(name, iso).axes
        assert [a.name for a in axes if a.horizon] == (["theta_i"] if "theta_i" in
                                                       [a.name for a in axes] else [])


def _grazing_pairs(theta_i_deg, theta_o_deg=60.0, phi_deg=180.0):
    ti, to, ph = np.radians(theta_i_deg), np.radians(theta_o_deg), np.radians(phi_deg)
    wi = np.stack([np.sin(ti), np.zeros_like(ti), np.cos(ti)], -1)
    wo = np.array([np.sin(to) * np.cos(ph), np.sin(to) * np.sin(ph), np.cos(to)])
    return wi, np.broadcast_to(wo, wi.shape).copy()


def test_new_factor_packs_fall_to_zero_with_the_reference():
    """Oren–Nayar (σ 0.5) at 12 θ cells, seen at θo 85° in the plane of incidence: beyond
    the last θi centre (86.25°) the stored f·cosθi stays within 15 % (of its value at 86°)
    of the model's own, and is 0 at the horizon; the same packs under the old linear rule
    are still at 87 % there."""
    brdf = models.make_model("oren_nayar", sigma=0.5, albedo=0.8)
    model = factor_brdf(brdf, parameterization="io_iso", resolution=(12, 24, 12), packs=2,
                        wavelengths=WL)
    assert model.edge == "horizon" and model.cosine_weighted
    angles = np.linspace(86.0, 90.0, 41)
    wi, wo = _grazing_pairs(angles, 85.0, 0.0)
    reference = brdf(wi, wo, WL)[:, 10] * wi[:, 2]
    scale = reference[0]
    beyond = angles > np.degrees(get_parameterization("io_iso", True).axes[0].centres(12)[-1])
    got = model.evaluate_cosine_weighted(wi, wo)[:, 10]
    old = FactoredBRDF(**{**model.__dict__, "edge": "linear"}).evaluate_cosine_weighted(
        wi, wo)[:, 10]
    assert got[-1] == 0.0 and reference[-1] < 1e-12
    assert np.max(np.abs(got - reference)[beyond]) <= 0.15 * scale
    assert old[-1] > 0.5 * scale
    assert np.max(np.abs(got - reference)[beyond]) < 0.25 * np.max(np.abs(old - reference)[beyond])


def test_uncosined_tables_keep_linear_extrapolation():
    brdf = models.make_model("lambert", albedo=0.5)
    model = factor_brdf(brdf, parameterization="io_iso", resolution=(8, 8, 8), packs=1,
                        wavelengths=WL, cosine_weighted=False)
    assert model.edge == "linear"


def test_the_rule_survives_a_file_round_trip(tmp_path):
    brdf = models.make_model("oren_nayar", sigma=0.3, albedo=0.5)
    model = factor_brdf(brdf, parameterization="io_iso", resolution=(8, 16, 8), packs=1,
                        wavelengths=WL)
    path = tmp_path / "m.npz"
    model.save(path)
    back = FactoredBRDF.load(path)
    assert back.edge == "horizon"
    wi, wo = _grazing_pairs(np.array([88.0, 89.9]))
    np.testing.assert_array_equal(back.coefficients(wi, wo), model.coefficients(wi, wo))


# ------------------------------------------------ "horizons": the view's horizon too

VIEW_THETA_O = Axis("theta_o", 0.0, math.pi / 2, periodic=False, view_horizon=True)


def test_horizons_hold_the_view_axis_and_horizon_only_the_light_axis():
    n = 10
    v = np.linspace(0.0, math.pi / 2, 77)
    # Under "horizons" θo behaves as θi does under "horizon"; under "horizon" it is linear.
    _same_lookups((VIEW_THETA_O, "horizons"), (THETA_I, "horizon"), n, v)
    np.testing.assert_array_equal(horizon_scale(VIEW_THETA_O, n, v, "horizons"),
                                  horizon_scale(THETA_I, n, v, "horizon"))
    assert np.all(horizon_scale(VIEW_THETA_O, n, v, "horizon") == 1.0)
    assert horizon_scale(VIEW_THETA_O, n, np.array([math.pi / 2]), "horizons")[0] == 0.0
    assert np.all(horizon_scale(THETA_I, n, v, "horizons") == horizon_scale(THETA_I, n, v))
    params = get_parameterization("io_iso", True)
    assert [a.view_horizon for a in params.axes] == [False, False, True]
    with pytest.raises(ValueError, match="no horizon"):
        Axis("phi", 0.0, 1.0, periodic=True, view_horizon=True)


def _view_grazing_errors(brdf, model, seed=5, n=4000):
    """Mean |f·cosθi| error per band of θo (88–89.5°, 89.5–90°) against the model's own
    values, θi uniform on the hemisphere."""
    from spectral_materials.core.brdf import grazing, metrics

    wi = metrics.uniform_hemisphere(np.random.default_rng(seed), n)
    bands = []
    for lo, hi in ((88.0, 89.5), (89.5, 90.0)):
        _, wo = grazing.grazing_pairs(n, seed + 1, (lo, hi))
        reference = brdf(wi, wo, model.wavelengths) * wi[:, 2:3]
        bands.append(float(np.abs(model.evaluate_cosine_weighted(wi, wo) - reference).mean()))
    return bands


def test_automatic_takes_horizons_beside_a_glossy_lobe_and_keeps_horizon_on_oren_nayar():
    from spectral_materials.core.brdf import grazing
    from spectral_materials.core.brdf.factor import build_basis
    from spectral_materials.core.brdf.job import FactorOptions, factor_material

    options = FactorOptions(parameterization="io_iso", resolution=(16, 32, 16),
                            isotropic=True, packs=2, lobe="auto", automatic=True)
    glossy = models.make_model("ashikhmin_shirley", nu=32.0, nv=32.0, specular=0.05,
                               diffuse=(spectra.WAVELENGTHS_REFERENCE,
                                        spectra.colorchecker(12)))
    job = factor_material(glossy, build_basis(glossy, spectra.WAVELENGTHS_REFERENCE, True, 6),
                          options)
    model = job.model
    assert model.lobe is not None and model.edge == "horizons"
    assert all(m.edge == "horizons" for m in job.models)
    # On pairs the choice did not see, the error falls toward the view's horizon under
    # "horizons" and not under "horizon".
    kept = _view_grazing_errors(glossy, model)
    other = _view_grazing_errors(glossy, FactoredBRDF(**{**model.__dict__, "edge": "horizon"}))
    assert kept[1] < kept[0] and other[1] > other[0] and kept[1] < other[1]
    clay = models.make_model("oren_nayar", sigma=0.52, albedo=0.6)
    job = factor_material(clay, build_basis(clay, spectra.WAVELENGTHS_REFERENCE, True, 3),
                          options)
    assert job.model.edge == "horizon"
    figures = job.model.report["view_horizon_de94"]
    assert figures["horizon"] < figures["horizons"]
    assert grazing.choose_edge(clay, [FactoredBRDF(**{**job.model.__dict__,
                                                      "edge": "linear"})]) == {}


def test_horizons_survive_a_file_round_trip(tmp_path):
    brdf = models.make_model("lambert", albedo=0.5)
    model = factor_brdf(brdf, parameterization="io_iso", resolution=(8, 16, 8), packs=1,
                        wavelengths=WL)
    model.edge = "horizons"
    back = FactoredBRDF.load(model.save(tmp_path / "m.npz"))
    assert back.edge == "horizons"
    wi, wo = _grazing_pairs(np.array([30.0, 40.0]), 89.9)
    np.testing.assert_array_equal(back.coefficients(wi, wo), model.coefficients(wi, wo))
    # θo at 89.9° is past the last centre: the view's horizon takes the value toward 0.
    horizon = FactoredBRDF(**{**model.__dict__, "edge": "horizon"}).coefficients(wi, wo)
    assert np.all(np.abs(back.coefficients(wi, wo)) < 0.2 * np.abs(horizon))
