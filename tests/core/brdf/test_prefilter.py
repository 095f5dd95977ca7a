"""The EEVEE path's RGB side (core/brdf/prefilter.py): the spectrum the Principled fit is
made under, and the fit's colour against the material's own reflectance spectrum."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.brdf import models, prefilter
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.lights import SpectralLight

WL = spectra.WAVELENGTHS_REFERENCE
TO_RGB = prefilter.scene_linear_matrix(colour_pipeline.white_xyz("D65", WL), "Linear Rec.2020")


def _light(name: str, scale: float = 1.0) -> SpectralLight:
    return SpectralLight("POINT", scale * spectra.illuminant(name, WL), WL, name=name)


def _luminance(spd):
    return float(spd @ (spectra.cmfs(WL)[:, 1] * spectra.sample_weights(WL)))


def test_fill_light_mixes_by_irradiance_at_unit_luminance():
    assert prefilter.fill_light([]) is None
    assert prefilter.fill_light([(_light("FL2"), 0.0)]) is None
    one = prefilter.fill_light([(_light("FL2", 37.0), 2.0)])
    fl2 = spectra.illuminant("FL2", WL)
    np.testing.assert_allclose(one.spd, fl2 / _luminance(fl2), rtol=1e-12)
    a, d65 = spectra.illuminant("A", WL), spectra.illuminant("D65", WL)
    mixed = prefilter.fill_light([(_light("A", 5.0), 3.0), (_light("D65", 0.1), 1.0)])
    expected = 0.75 * a / _luminance(a) + 0.25 * d65 / _luminance(d65)
    np.testing.assert_allclose(mixed.spd, expected, rtol=1e-12)
    assert _luminance(mixed.spd) == pytest.approx(1.0)


@pytest.mark.parametrize("patch", [2, 12, 15])
def test_principled_colour_is_exact_for_the_light_it_is_fitted_under(patch):
    """A Lambertian patch: base colour × the light's RGB is the patch's reflected RGB under
    FL2, computed from its reflectance spectrum (not from the factors). Fitted under D65
    instead, the same product is off under FL2: what the fill light is for."""
    albedo = spectra.colorchecker(patch, WL)
    model = factor_brdf(models.make_model("lambert", albedo=(WL, albedo)),
                        parameterization="io_iso", isotropic=True, resolution=(8, 16, 8),
                        packs=1, spectral_basis=8)
    fl2 = prefilter.fill_light([(_light("FL2"), 1.0)])
    reference = TO_RGB @ (albedo @ fl2.weights(WL, None)) / np.pi     # f = albedo / π
    fitted = prefilter.fit_principled(model, fl2, TO_RGB)
    got = np.asarray(fitted["base_color"]) * prefilter.light_rgb(fl2, TO_RGB)
    np.testing.assert_allclose(got, reference, rtol=0.02, atol=2e-3)
    under_d65 = prefilter.fit_principled(model, _light("D65"), TO_RGB)
    wrong = np.asarray(under_d65["base_color"]) * prefilter.light_rgb(fl2, TO_RGB)
    assert np.abs(wrong - reference).max() > 3 * np.abs(got - reference).max()
