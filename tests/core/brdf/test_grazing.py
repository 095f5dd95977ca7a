"""Automatic θ cells (core/brdf/grazing.py): the finer grid is taken where the error near
the horizon is the cells', against the 5 nm reference on pairs the check never saw."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from spectral_materials.core.brdf import grazing, metrics, models
from spectral_materials.core.brdf.factor import build_basis
from spectral_materials.core.brdf.job import FactorOptions, factor_material
from spectral_materials.core.colour import spectra

WL = spectra.WAVELENGTHS_REFERENCE


def _clay():
    """Red clay: Oren–Nayar, σ 0.52, ColorChecker patch 15 (the demo's)."""
    return models.make_model("oren_nayar", sigma=0.52, albedo=(WL, spectra.colorchecker(15, WL)))


def _options(**changes) -> FactorOptions:
    return replace(FactorOptions(parameterization="io_iso", resolution=(32, 64, 32),
                                 isotropic=True, packs=4, lobe="auto", automatic=True),
                   **changes)


def _max_below_89_5(model, brdf, seed=77) -> float:
    """Largest ΔE94 (D65) at 20 000 pairs (not the check's) with θi, θo in [85°, 89.5°)."""
    wi, wo = grazing.grazing_pairs(20_000, seed, (85.0, 89.5))
    reference = metrics.reference_xyz(brdf, wi, wo, "D65")
    return float(metrics.delta_e94_stats(reference, model.xyz(wi, wo, "D65"), "D65")["max"])


def test_grazing_pairs_are_seeded_unit_and_in_range():
    wi, wo = grazing.grazing_pairs(500, 3)
    again = grazing.grazing_pairs(500, 3)
    np.testing.assert_array_equal(wi, again[0])
    for d in (wi, wo):
        np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
        theta = np.degrees(np.arccos(d[:, 2]))
        assert theta.min() >= 80.0 and theta.max() < 89.5


def test_check_pairs_add_the_view_grazing_alone():
    """Half the check's pairs graze both ways; the other half graze the view alone, with
    the light anywhere on the hemisphere (where a coarse grid's error showed, issue 18)."""
    wi, wo = grazing.check_pairs(500, 3)
    np.testing.assert_array_equal(wi, grazing.check_pairs(500, 3)[0])
    assert wi.shape == wo.shape == (1000, 3)
    theta_i = np.degrees(np.arccos(wi[:, 2]))
    theta_o = np.degrees(np.arccos(wo[:, 2]))
    assert theta_o.min() >= 80.0 and theta_o.max() < 89.5
    assert theta_i[:500].min() >= 80.0 and theta_i[:500].max() < 89.5
    # The light alone: uniform in solid angle, so half of it within 60° of the normal.
    assert theta_i[500:].min() < 20.0 and 0.4 < np.mean(theta_i[500:] < 60.0) < 0.6
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name, iso, resolution, finer", [
    ("io_iso", True, (32, 64, 32), (64, 128, 64)),
    ("io", False, (32, 64, 32, 64), (64, 128, 64, 128)),
    ("io_iso", True, (64, 128, 64), None),
    ("io_iso", True, None, None),                        # the default grid: 90 θ cells
])
def test_finer_resolution_doubles_the_theta_cells_up_to_the_demos(name, iso, resolution, finer):
    assert grazing.finer_resolution(name, iso, resolution) == finer


def test_oren_nayar_at_the_horizon_takes_the_finer_grid_and_meets_the_goal():
    """Packs alone (the material's own lobe family is off): twice the θ cells."""
    brdf = _clay()
    basis = build_basis(brdf, WL, True, 6)
    coarse = factor_material(brdf, basis, _options(automatic=False, lobe="off"))
    auto = factor_material(brdf, basis, _options(lobe="off"))
    report = auto.model.report
    assert report["grazing_refined"] and auto.model.resolution == (64, 128, 64)
    assert report["grazing_finer_max_de94"] < report["grazing_max_de94"]
    # On pairs the check did not use: above issue 18's bound of 5 at 32 θ cells (measured
    # 7.0 on the protocol's pairs), within it at 64.
    assert _max_below_89_5(coarse.model, brdf) > 5.0
    assert _max_below_89_5(auto.model, brdf) < 5.0
    assert auto.series[-1]["de94"]["mean"] <= coarse.series[-1]["de94"]["mean"]


def test_no_refinement_without_automatic_or_where_the_horizon_is_fine():
    lambert = models.make_model("lambert", albedo=0.5)
    basis = build_basis(lambert, WL, True, 3)
    job = factor_material(lambert, basis, _options(packs=1))
    assert not job.model.report["grazing_refined"]
    assert job.model.report["grazing_max_de94"] < grazing.REFINE_ABOVE
    assert job.model.resolution == (32, 64, 32)
    manual = factor_material(lambert, basis, _options(packs=1, automatic=False))
    assert "grazing_refined" not in manual.model.report


def test_oren_nayar_beside_its_own_term_needs_no_finer_grid():
    """With the lobe Automatic chooses (Oren–Nayar's term, core/brdf/lobe.py) the horizon
    is the term's, in closed form: no refinement, and far within the bound."""
    brdf = _clay()
    job = factor_material(brdf, build_basis(brdf, WL, True, 6), _options())
    assert job.model.lobe.family == "oren_nayar"
    assert not job.model.report["grazing_refined"]
    assert job.model.resolution == (32, 64, 32)
    assert _max_below_89_5(job.model, brdf) < 0.2
