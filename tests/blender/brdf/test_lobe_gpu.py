"""Factor packs with an analytic specular lobe (core/brdf/lobe.py) drawn by the shaders
against the float64 mirror (core/brdf/shading.py), pixel by pixel.

The lobe is where the highlight is: incidences to 85°, a near-mirror lobe, several
lights of every kind (the packs-outermost loop), the per-coefficient mode, a filtered
16-bit precision and truncated packs. Bound: the issue's max ΔE94 ≤ 0.1.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gpu_helpers import (
    DARK_Y,
    MAX_DE94,
    SIZE,
    WL,
    delta_e,
    four_lights,
    lights_pair,
    protocol_pair,
)

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.brdf.filtered_factors import drawn_model
from spectral_materials.core.brdf.shading import sphere_xyz
from spectral_materials.core.colour import spectra

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

CASES = ((0.0, "D65"), (40.0, "FL2"), (70.0, "A"), (85.0, "FL11"))


def _lobe_model(parameterization: str, nu: float, nv: float, patch: int = 12):
    brdf = models.make_model("ashikhmin_shirley", nu=nu, nv=nv,
                             diffuse=(WL, spectra.colorchecker(patch, WL)), specular=0.05)
    iso = parameterization.endswith("_iso")
    resolution = (16, 32, 16) if iso else (12, 12, 12, 12)
    model = factor_brdf(brdf, parameterization=parameterization, isotropic=iso,
                        resolution=resolution, packs=2, spectral_basis=8,
                        lobe="ashikhmin_shirley")
    assert model.lobe is not None
    return model


def _oren_nayar_model():
    """Red clay with Oren–Nayar's back-scatter term drawn beside the packs (the other lobe
    family): its ridge is at the silhouette, where light and view both graze."""
    brdf = models.make_model("oren_nayar", albedo=(WL, spectra.colorchecker(15, WL)),
                             sigma=0.52)
    model = factor_brdf(brdf, parameterization="io_iso", isotropic=True,
                        resolution=(16, 32, 16), packs=2, spectral_basis=8, lobe="oren_nayar")
    assert model.lobe.family == "oren_nayar"
    return model


@pytest.fixture(scope="module")
def lobe_models():
    return {"io_iso": _lobe_model("io_iso", 32.0, 32.0),
            "io": _lobe_model("io", 8.0, 64.0, patch=6),
            "mirror": _lobe_model("io_iso", 3000.0, 3000.0, patch=3),
            "oren_nayar": _oren_nayar_model()}


def _check(got, reference, illuminant, what):
    lit = reference[:, 1] > DARK_Y
    assert lit.sum() > 300, f"{what}: the sphere is barely lit"
    de = delta_e(reference, got, illuminant)
    assert de.max() <= MAX_DE94, f"{what}: max ΔE94 {de.max():.4g}"
    return de.max()


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
@pytest.mark.parametrize("name", ["io_iso", "io", "mirror", "oren_nayar"])
def test_lobe_sphere_matches_mirror(lobe_models, name, precontract):
    model = lobe_models[name]
    for incidence, illuminant in CASES:
        got, reference = protocol_pair(model, incidence, illuminant, precontract=precontract)
        _check(got, reference, illuminant, f"{name} {incidence}° {illuminant}")


@pytest.mark.parametrize("name, incidence, changed", [("io_iso", 40.0, 5.0),
                                                     ("oren_nayar", 85.0, 1.0)])
def test_lobe_changes_the_image(lobe_models, name, incidence, changed):
    """The lobe is drawn: without it the same packs give another highlight (or, for Oren–
    Nayar's term, less back-scatter towards the grazing light: ΔE94 2.1 at most)."""
    model = lobe_models[name]
    with_lobe, _ = protocol_pair(model, incidence)
    without, reference = protocol_pair(replace(model, lobe=None), incidence)
    assert delta_e(with_lobe, without).max() > changed
    assert delta_e(reference, without).max() <= MAX_DE94     # the mirror follows too


@pytest.mark.parametrize("edge", ["horizon", "horizons"])
@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
def test_lobe_under_several_lights(lobe_models, precontract, edge):
    """Four light kinds at once, each light's θo scale included where the view's axes are
    shared across lights ("horizons" holds θo as well as θi)."""
    lights = four_lights()
    for name in ("io_iso", "io", "oren_nayar"):
        model = replace(lobe_models[name], edge=edge)
        got, reference = lights_pair(model, lights, precontract=precontract)
        _check(got, reference, "D65", f"{name} {len(lights)} lights, {edge}")


def test_lobe_with_truncated_packs_and_filtered_factors(lobe_models):
    model = lobe_models["io"]
    got, reference = protocol_pair(model.truncated(1), 30.0, "FL2")
    _check(got, reference, "FL2", "one pack")
    image = render_sphere(model, 30.0, "FL2", SIZE, factors="unorm16_filtered")
    drawn = drawn_model(model, "unorm16_filtered")
    assert drawn.lobe is model.lobe
    reference, mask = sphere_xyz(drawn, 30.0, "FL2", SIZE)
    _check(image[mask][:, :3].astype(np.float64), reference[mask], "FL2", "unorm16 filtered")


def test_a_shader_key_refuses_an_unknown_lobe_family(lobe_models):
    """A family code the GLSL has no branch for would compile another family's."""
    from spectral_materials.blender.brdf.gpu_material import GPUMaterial
    from spectral_materials.blender.gpu import shaders

    key = GPUMaterial(lobe_models["oren_nayar"]).key(four_lights())
    assert key.lobe_family == 2 and key.defines()["SM_LOBE_FAMILY"] == "2"
    key.validate()
    for code in (0, 3):
        with pytest.raises(ValueError, match="lobe family code"):
            replace(key, lobe_family=code).validate()
    assert shaders.ShaderKey("io_iso", 3, 1, 8, 1, frozenset({"SUN"})).lobe_family == 1
