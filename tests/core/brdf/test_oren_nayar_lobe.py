"""Oren–Nayar's back-scatter term drawn in closed form beside the packs (core/brdf/lobe.py,
family ``oren_nayar``; issue 18's grazing corner).

References are independent of the lobe's code: the model's formula written with its
angles (α, β, Δφ, as Oren & Nayar 1994 print it), the model of core/brdf/models.py, and
the protocol's 5 nm reference; never the lobe measured against itself.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factor import build_basis, factor_brdf
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.job import LOBE_MIN_GAIN, FactorOptions, factor_material
from spectral_materials.core.brdf.lobe import (
    LOBE_FAMILIES,
    SpecularLobe,
    family_code,
    family_terms,
    fit_lobe,
    oren_nayar_terms,
)
from spectral_materials.core.colour import spectra

WL = spectra.WAVELENGTHS_REFERENCE


def _clay(sigma: float = 0.52, patch: int = 15):
    return models.make_model("oren_nayar", albedo=(WL, spectra.colorchecker(patch, WL)),
                             sigma=sigma)


def _directions(theta_deg: np.ndarray, phi: np.ndarray) -> np.ndarray:
    t = np.radians(theta_deg)
    return np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi), np.cos(t)], -1)


def _corner_pairs(n: int = 4000, seed: int = 7, low: float = 89.5, high: float = 89.999):
    """Both directions between ``low`` and ``high`` degrees from the normal, in azimuths
    turned at random about the normal: the corner where the term has no bound."""
    rng = np.random.default_rng(seed)
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    spread = rng.normal(0.0, 0.3, n)                  # mostly the same azimuth: the ridge
    return (_directions(rng.uniform(low, high, n), phi),
            _directions(rng.uniform(low, high, n), phi + spread))


def _angle_form(wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """max(0, cos(φi − φo))·sin α·tan β with the angles themselves."""
    ti, to = np.arccos(wi[:, 2]), np.arccos(wo[:, 2])
    dphi = np.arctan2(wi[:, 1], wi[:, 0]) - np.arctan2(wo[:, 1], wo[:, 0])
    alpha, beta = np.maximum(ti, to), np.minimum(ti, to)
    return np.maximum(np.cos(dphi), 0.0) * np.sin(alpha) * np.tan(beta)


def test_the_term_is_oren_nayars_written_with_angles():
    wi, wo = metrics.random_direction_pairs(3000, 5)
    gi, go = _corner_pairs(1000, low=85.0, high=89.99)
    wi, wo = np.concatenate([wi, gi]), np.concatenate([wo, go])
    terms = oren_nayar_terms(wi, wo)
    np.testing.assert_allclose(terms[:, 0], _angle_form(wi, wo), rtol=1e-9, atol=1e-12)
    assert (terms[:, 1] == 0).all()
    # With c₀ = ρB/π beside ρA/π the lobe is the whole model, at 5 nm.
    brdf = _clay()
    rho = spectra.colorchecker(15, WL)
    whole = rho[None, :] / np.pi * (brdf._a + brdf._b * terms[:, :1])
    np.testing.assert_allclose(whole, brdf(wi, wo, WL), rtol=1e-9)


def test_the_term_at_the_horizon_the_pole_and_on_bad_input():
    wi = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [1.0, 0.0, 0.0], [np.nan, 0, 1],
                   [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.6, 0.0, 0.8]])
    wo = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [1.0, 0.0, 0.0], [0, 0, 1],
                   [np.inf, 0, 1], [0.0, 0.0, 1.0], [-0.6, 0.0, 0.8]])
    t = oren_nayar_terms(wi, wo)
    assert t.shape == (7, 2) and np.isfinite(t).all()
    assert t[0, 0] == 0.0                          # the pole: no azimuth, no term
    np.testing.assert_allclose(t[1, 0], 0.36 / 0.8)       # sin α tan β = 0.6 · 0.75
    assert (t[2:6] == 0).all()                     # horizon, NaN, inf, below
    assert t[6, 0] == 0.0                          # opposite azimuths: cos Δφ < 0
    # 1e-4° from the horizon in one azimuth: large, finite, and cosθi brings it back.
    near = _directions(np.array([90.0 - 1e-4]), np.array([0.3]))
    a = oren_nayar_terms(near, near)[0, 0]
    assert 1e5 < a < 1e7 and a * near[0, 2] == pytest.approx(1.0, rel=1e-6)


def test_validate_and_codes():
    spectral = np.zeros((8, 2), np.float32)
    spectral[:, 0] = 0.1
    good = SpecularLobe("oren_nayar", 0.0, 0.0, spectral)
    good.validate()
    for bad in (replace(good, nu=3.0), replace(good, nv=np.nan)):
        with pytest.raises(ValueError, match="no exponents"):
            bad.validate()
    # Its second term is 0: a spectrum there is refused (the GPU would draw 0·inf).
    with pytest.raises(ValueError, match="second spectrum must be 0"):
        replace(good, spectral=np.ones((8, 2), np.float32)).validate()
    with pytest.raises(ValueError, match="unknown lobe family"):
        family_terms("phong", np.zeros((1, 3)), np.zeros((1, 3)), 1.0, 1.0)
    with pytest.raises(ValueError, match="outside"):
        replace(good, family="ashikhmin_shirley").validate()
    assert [family_code(f) for f in LOBE_FAMILIES] == [1, 2]


@pytest.mark.parametrize("sigma, gain", [(0.1, (10.0, 20.0)), (0.52, (100.0, np.inf)),
                                         (3.0, (100.0, np.inf))])
def test_fit_recovers_rho_b_over_pi(sigma, gain):
    brdf = _clay(sigma)
    fit = fit_lobe(brdf, WL, family="oren_nayar")
    rho = spectra.colorchecker(15, WL)
    np.testing.assert_allclose(fit.lobe.spectral[:, 0], rho * brdf._b / np.pi, atol=1e-6)
    assert (fit.lobe.spectral[:, 1] == 0).all() and fit.evaluations == 1
    assert (fit.lobe.nu, fit.lobe.nv) == (0.0, 0.0)
    # A small σ's term is small beside ρA/π, but the fit is exact: the gain is the
    # smooth stand-in's miss over the floor (job.LOBE_MIN_GAIN's comment cites these).
    assert LOBE_MIN_GAIN <= gain[0] < fit.gain < gain[1]


def test_other_materials_gain_little_from_the_term():
    assert fit_lobe(models.make_model("lambert", albedo=0.7), WL,
                    family="oren_nayar").gain < LOBE_MIN_GAIN
    glossy = models.make_model("ashikhmin_shirley", nu=32.0, nv=32.0, specular=0.05,
                               diffuse=(WL, spectra.colorchecker(12, WL)))
    assert fit_lobe(glossy, WL, family="oren_nayar").gain < 1.1


def _corner_de(model, brdf, wi, wo, illuminant="FL11"):
    return metrics.delta_e94_image(metrics.reference_xyz(brdf, wi, wo, illuminant),
                                   model.xyz(wi, wo, illuminant), illuminant)


@pytest.mark.parametrize("sigma, patch", [(0.52, 15), (0.3, 13)])
def test_automatic_takes_the_term_and_the_corner_falls_to_90(sigma, patch):
    """Automatic picks the term for an Oren–Nayar material; the pack count stops where
    the rest (ρA/π, one exact pack) leaves nothing; and in the corner where both
    directions graze, against the 5 nm reference under FL11, the error stays far below
    what packs alone leave there."""
    brdf = _clay(sigma, patch)
    basis = build_basis(brdf, WL, True, 6)
    options = FactorOptions(parameterization="io_iso", resolution=(32, 64, 32),
                            isotropic=True, packs=4, lobe="auto")
    job = factor_material(brdf, basis, options)
    model = job.model
    assert model.lobe.family == "oren_nayar" and model.report["lobe_kept"]
    assert [row["packs"] for row in job.series] == [1]
    assert model.report["stopped"] == "error floor" and model.report["requested_packs"] == 4
    plain = factor_material(brdf, basis, replace(options, lobe="off")).model
    wi, wo = _corner_pairs()
    de, de_plain = _corner_de(model, brdf, wi, wo), _corner_de(plain, brdf, wi, wo)
    assert de.max() < 0.1 and de_plain.max() > 5.0, (de.max(), de_plain.max())
    # Rotated about the normal and with the roles swapped: the same.
    assert _corner_de(model, brdf, wo, wi).max() < 0.1
    mean, _ = job.series[-1]["de94"]["mean"], None
    assert mean < 0.05


def test_save_load_keeps_the_family_and_refuses_exponents(tmp_path):
    import json

    model = factor_brdf(_clay(), parameterization="io_iso", isotropic=True,
                        resolution=(8, 16, 8), packs=1, spectral_basis=6, lobe="oren_nayar")
    path = model.save(tmp_path / "clay.npz")
    loaded = FactoredBRDF.load(path)
    assert loaded.lobe.family == "oren_nayar"
    wi, wo = _corner_pairs(300)
    np.testing.assert_array_equal(loaded.coefficients(wi, wo), model.coefficients(wi, wo))
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(arrays["meta"].tobytes().decode())
    meta["lobe"]["nu"] = 12.0
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    bad = tmp_path / "clay_with_exponent.npz"
    np.savez(bad, **arrays)
    with pytest.raises(ValueError, match=bad.name):
        FactoredBRDF.load(bad)
