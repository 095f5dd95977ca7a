"""The analytic specular lobe beside the factor packs (core/brdf/lobe.py, issue 18).

References are independent of the lobe's code: the Ashikhmin–Shirley model of
core/brdf/models.py (its own implementation of the same formula) and the protocol's
5 nm reference of each BRDF; never the lobe measured against itself.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factor import build_basis, factor_brdf
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.job import (
    ISOTROPIC_RESIDUAL,
    LOBE_MIN_GAIN,
    LOBE_SURE_GAIN,
    FactorOptions,
    factor_material,
)
from spectral_materials.core.brdf.lobe import (
    LobeResidual,
    SpecularLobe,
    fit_lobe,
    lobe_terms,
    residual_anisotropy,
)
from spectral_materials.core.brdf.params import get_parameterization
from spectral_materials.core.brdf.tabulate import Grid, tabulate
from spectral_materials.core.colour import spectra
from spectral_materials.core.errors import Cancelled, InvalidBRDFData

WL = spectra.WAVELENGTHS_REFERENCE


def _glossy(nu=32.0, nv=32.0, patch=12, specular=0.05):
    return models.make_model("ashikhmin_shirley", nu=nu, nv=nv,
                             diffuse=(WL, spectra.colorchecker(patch, WL)), specular=specular)


def _grazing_pairs(n=4000, seed=3):
    """Pairs with both directions within 10° of the horizon, rotated about the normal."""
    rng = np.random.default_rng(seed)
    theta = np.radians(rng.uniform(80.0, 89.99, (2, n)))
    phi = rng.uniform(0, 2 * np.pi, (2, n))
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    return d[0], d[1]


@pytest.mark.parametrize("nu, nv", [(32.0, 32.0), (8.0, 64.0), (1000.0, 3.0)])
def test_lobe_is_the_ashikhmin_shirley_specular_term(nu, nv):
    """With c₀ = Rs and c₁ = 1 the lobe is the model's specular term, grazing pairs too."""
    reference = models.make_model("ashikhmin_shirley", nu=nu, nv=nv, diffuse=0.0,
                                  specular=0.2)
    wi, wo = metrics.random_direction_pairs(3000, 11)
    gi, go = _grazing_pairs()
    wi, wo = np.concatenate([wi, gi]), np.concatenate([wo, go])
    expected = reference(wi, wo, np.array([550.0]))[:, 0]
    terms = lobe_terms(wi, wo, nu, nv)
    np.testing.assert_allclose(terms @ np.array([0.2, 1.0]), expected, rtol=1e-9, atol=1e-12)


def test_lobe_terms_shapes_horizon_and_bad_input():
    wi = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [1.0, 0.0, 0.0], [np.nan, 0, 1],
                   [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    wo = np.array([[0.0, 0.0, 1.0], [-0.6, 0.0, 0.8], [-1.0, 0.0, 0.0], [0, 0, 1],
                   [np.inf, 0, 1], [0.0, 0.0, 1.0]])
    t = lobe_terms(wi, wo, 10.0, 10.0)
    assert t.shape == (6, 2) and np.isfinite(t).all()
    assert (t[2:] == 0).all()                      # horizon, NaN, inf, below: nothing
    # At normal incidence h·k = 1: no Schlick grazing part, and the peak (n·h)^E = 1.
    np.testing.assert_allclose(t[0], [11.0 / (8 * np.pi), 0.0], rtol=1e-12)
    assert lobe_terms(np.zeros((0, 3)), np.zeros((0, 3)), 5.0, 5.0).shape == (0, 2)


def test_specular_lobe_validate():
    good = SpecularLobe("ashikhmin_shirley", 10.0, 20.0, np.ones((8, 2), np.float32))
    good.validate()
    for bad in (replace(good, family="phong"), replace(good, nu=0.0),
                replace(good, nv=np.inf), replace(good, nu=1e7),
                replace(good, spectral=np.ones((8, 3))),
                replace(good, spectral=np.full((8, 2), np.nan))):
        with pytest.raises(ValueError):
            bad.validate()


@pytest.mark.parametrize("nu, nv", [(8.0, 64.0), (200.0, 20.0)])
def test_fit_recovers_the_exponents_and_fresnel(nu, nv):
    fit = fit_lobe(_glossy(nu, nv, specular=0.04), WL)
    assert fit.lobe.nu == pytest.approx(nu, rel=0.01)
    assert fit.lobe.nv == pytest.approx(nv, rel=0.01)
    np.testing.assert_allclose(fit.lobe.spectral[:, 0], 0.04, atol=0.003)   # Rs
    np.testing.assert_allclose(fit.lobe.spectral[:, 1], 1.0, atol=0.02)     # F(90°) = 1
    assert fit.gain >= LOBE_SURE_GAIN


@pytest.mark.parametrize("brdf", [models.make_model("lambert", albedo=0.7),
                                  models.make_model("oren_nayar", sigma=0.5, albedo=0.5)],
                         ids=["lambert", "oren_nayar"])
def test_a_diffuse_brdf_gains_nothing_from_a_specular_lobe(brdf):
    """(Oren–Nayar's own term is another family: tests/core/brdf/test_oren_nayar_lobe.py.)"""
    assert fit_lobe(brdf, WL).gain < LOBE_MIN_GAIN


def test_fit_cancels_and_rejects_non_finite():
    with pytest.raises(Cancelled):
        fit_lobe(_glossy(), WL, callback=lambda fraction, message: fraction > 0.1)

    def broken(wi, wo, wl):
        out = _glossy()(wi, wo, wl)
        out[5] = np.nan
        return out

    with pytest.raises(ValueError, match="non-finite"):
        fit_lobe(broken, WL)
    with pytest.raises(ValueError, match="family"):
        fit_lobe(_glossy(), WL, family="phong")


def test_residual_is_signed_and_tabulate_refuses_negatives_unless_told():
    lobe = SpecularLobe("ashikhmin_shirley", 30.0, 30.0,
                        np.full((WL.size, 2), 2.0, np.float32))   # overshoots everywhere
    residual = LobeResidual(_glossy(), lobe, WL, None)
    grid = Grid(get_parameterization("io", True), (6, 12, 6))
    with pytest.raises(InvalidBRDFData, match="negative"):
        tabulate(residual, grid, WL)
    table = tabulate(residual, grid, WL, signed=True)
    assert (table.values < 0).any()


def _stats(model, brdf, wi, wo):
    de = metrics.delta_e94_image(metrics.reference_xyz(brdf, wi, wo, "D65"),
                                 model.xyz(wi, wo, "D65"), "D65")
    return de.mean(), de.max()


@pytest.mark.parametrize("parameterization, nu, nv, max_bound", [("io_iso", 32.0, 32.0, 5.0),
                                                                 ("io", 8.0, 64.0, 40.0)])
def test_packs_with_a_lobe_against_the_5nm_reference(parameterization, nu, nv, max_bound):
    """At the default 4 packs the lobe takes the isotropic glossy case from maxima of
    100–200 to within the issue's 5 below 89.5°, and both means under 0.5. (The
    anisotropic case, on a coarse 16-cell grid here, keeps maxima of ~30 near grazing.)"""
    brdf = _glossy(nu, nv)
    iso = parameterization.endswith("_iso")
    resolution = get_parameterization(parameterization.removesuffix("_iso"), iso
                                      ).theta_resolution(16 if not iso else 32)
    common = dict(parameterization=parameterization, isotropic=iso, resolution=resolution,
                  packs=4, spectral_basis=8)
    with_lobe = factor_brdf(brdf, lobe="ashikhmin_shirley", **common)
    without = factor_brdf(brdf, **common)
    assert with_lobe.lobe is not None and without.lobe is None
    wi, wo = metrics.random_direction_pairs(6000, 99)
    below = np.maximum(np.degrees(np.arccos(wi[:, 2])), np.degrees(np.arccos(wo[:, 2]))) < 89.5
    mean_lobe, max_lobe = _stats(with_lobe, brdf, wi[below], wo[below])
    mean_plain, max_plain = _stats(without, brdf, wi[below], wo[below])
    assert mean_lobe < 0.5 and max_lobe < max_bound, (mean_lobe, max_lobe)
    assert mean_lobe < 0.5 * mean_plain and max_lobe < 0.2 * max_plain
    gi, go = _grazing_pairs()
    assert np.isfinite(with_lobe.xyz(gi, go, "FL11")).all()


def test_save_load_and_truncate_keep_the_lobe(tmp_path):
    model = factor_brdf(_glossy(16.0, 16.0), parameterization="io_iso", isotropic=True,
                        resolution=(8, 16, 8), packs=2, spectral_basis=6,
                        lobe="ashikhmin_shirley")
    path = model.save(tmp_path / "lobe.npz")
    loaded = FactoredBRDF.load(path)
    assert loaded.lobe.nu == model.lobe.nu and loaded.lobe.nv == model.lobe.nv
    wi, wo = metrics.random_direction_pairs(500, 5)
    np.testing.assert_array_equal(loaded.coefficients(wi, wo), model.coefficients(wi, wo))
    assert model.truncated(1).lobe is model.lobe
    bad = replace(model, lobe=replace(model.lobe, spectral=np.ones((3, 2), np.float32)))
    with pytest.raises(ValueError, match="lobe has 3 spectral"):
        bad.validate()


def test_auto_keeps_the_lobe_only_where_it_measures_better():
    options = FactorOptions(parameterization="io_iso", resolution=(12, 24, 12),
                            isotropic=True, packs=2, lobe="auto")

    def factored(brdf):
        return factor_material(brdf, build_basis(brdf, WL, True, 6), options)

    glossy = factored(_glossy())
    assert glossy.model.lobe is not None and glossy.model.report["lobe_kept"]
    assert glossy.model.lobe.family == "ashikhmin_shirley"
    assert glossy.model.report["lobe_family_gains"]["oren_nayar"] < LOBE_MIN_GAIN
    diffuse = factored(models.make_model("lambert", albedo=0.6))
    assert diffuse.model.lobe is None and not diffuse.model.report["lobe_kept"]
    # An Ashikhmin–Shirley lobe on GGX (fit gain between LOBE_MIN_GAIN and
    # LOBE_SURE_GAIN: measured both ways): on the protocol's own pairs, which the choice
    # never saw, Automatic is no worse than packs alone.
    brdf = models.make_model("ggx", alpha_x=0.2, alpha_y=0.2)
    ggx = factored(brdf)
    assert LOBE_MIN_GAIN <= ggx.model.report["lobe_fit_gain"] < LOBE_SURE_GAIN
    plain = factor_material(brdf, build_basis(brdf, WL, True, 6), replace(options, lobe="off"))
    assert ggx.series[-1]["de94"]["mean"] <= 1.05 * plain.series[-1]["de94"]["mean"]
    with pytest.raises(ValueError, match="lobe must be one of"):
        factor_material(_glossy(), None, replace(options, lobe="phong"))


def test_residual_anisotropy_separates_a_matching_lobe_from_another_shape():
    brushed = _glossy(8.0, 64.0)
    assert residual_anisotropy(brushed, fit_lobe(brushed, WL).lobe, WL) < ISOTROPIC_RESIDUAL
    ward = models.make_model("ward", alpha_x=0.1, alpha_y=0.3)
    assert residual_anisotropy(ward, fit_lobe(ward, WL).lobe, WL) > 3 * ISOTROPIC_RESIDUAL


def test_an_anisotropic_lobe_lets_the_packs_take_the_isotropic_layout():
    """Brushed metal (AS 8/64): the lobe carries the anisotropy, the packs the isotropic
    rest on io_iso with the same θ cells; measured against the 5 nm reference, rotated
    pairs included, it beats the anisotropic packs without a lobe."""
    brdf = _glossy(8.0, 64.0, patch=6)
    basis = build_basis(brdf, WL, False, 8)
    options = FactorOptions(parameterization="io", resolution=(16, 32, 16, 32),
                            isotropic=False, packs=2, lobe="auto", automatic=True)
    job = factor_material(brdf, basis, options)
    model = job.model
    assert model.lobe is not None and model.parameterization == "io_iso"
    assert model.resolution == (16, 32, 16)
    assert model.report["residual_anisotropy"] < ISOTROPIC_RESIDUAL
    plain = factor_material(brdf, basis, replace(options, lobe="off")).model
    assert plain.parameterization == "io" and plain.lobe is None
    wi, wo = metrics.random_direction_pairs(4000, 21)
    mean_lobe, _ = _stats(model, brdf, wi, wo)
    mean_plain, _ = _stats(plain, brdf, wi, wo)
    assert mean_lobe < 0.3 and mean_lobe < 0.5 * mean_plain
    assert model.nbytes < plain.nbytes


def test_an_explicit_layout_is_kept_and_automatic_falls_back_without_the_lobe():
    """Only Automatic moves packs to io_iso; and where Automatic drops the lobe (Ward,
    whose rest stays anisotropic), packs alone take the layout Automatic gives them
    (half/difference), not the one meant for packs beside a lobe."""
    brushed = _glossy(8.0, 64.0, patch=6)
    basis = build_basis(brushed, WL, False, 6)
    explicit = FactorOptions(parameterization="io", resolution=(8, 16, 8, 16),
                             isotropic=False, packs=1, lobe="ashikhmin_shirley")
    assert factor_material(brushed, basis, explicit).model.parameterization == "io"
    ward = models.make_model("ward", alpha_x=0.1, alpha_y=0.3)
    basis = build_basis(ward, WL, False, 6)
    hd = ("hd", (12, 6, 12, 6))
    automatic = FactorOptions(parameterization="io", resolution=(12, 24, 12, 24),
                              isotropic=False, packs=2, lobe="auto", automatic=True,
                              plain_layout=hd)
    job = factor_material(ward, basis, automatic)
    kept = job.model.report["lobe_kept"]
    assert job.model.parameterization == ("io" if kept else "hd")
    plain = factor_material(ward, basis, replace(automatic, lobe="off"))
    assert plain.model.parameterization == "hd" and plain.model.lobe is None
    assert job.series[-1]["de94"]["mean"] <= 1.05 * plain.series[-1]["de94"]["mean"]


def test_hostile_lobe_files_are_refused_naming_the_file(tmp_path):
    """A lobe with a NaN exponent, spectra of the wrong length, or a missing array: a
    ValueError naming the file, never a model that draws garbage."""
    import json as json_module

    model = factor_brdf(_glossy(16.0, 16.0), parameterization="io_iso", isotropic=True,
                        resolution=(6, 12, 6), packs=1, spectral_basis=4,
                        lobe="ashikhmin_shirley")
    path = model.save(tmp_path / "good.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json_module.loads(arrays["meta"].tobytes().decode())
    assert meta["version"] == 2

    def write(name, meta_patch=None, drop=None, replace_arrays=None):
        doc = dict(meta, **(meta_patch or {}))
        out = {k: v for k, v in arrays.items() if k != drop}
        out.update(replace_arrays or {})
        out["meta"] = np.frombuffer(json_module.dumps(doc).encode(), dtype=np.uint8)
        target = tmp_path / name
        np.savez(target, **out)
        return target

    nan_lobe = dict(meta["lobe"], nu=float("nan"))
    for bad in (write("nan.npz", {"lobe": nan_lobe}),
                write("short.npz", replace_arrays={"lobe_spectral": np.ones((3, 2), np.float32)}),
                write("missing.npz", drop="lobe_spectral"),
                write("future.npz", {"version": 4})):
        with pytest.raises(ValueError, match=bad.name):
            FactoredBRDF.load(bad)
