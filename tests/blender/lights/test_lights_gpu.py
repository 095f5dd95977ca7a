"""Each light type, and a mix of eight, drawn on the sphere against the float64 mirror.

``render_sphere(model, lights=[…])`` draws the unit sphere seen orthographically
down −z with the given lights; the mirror is ``shade_xyz`` on the same pixel
centres (``sphere_pixels``) with n = P and the generated tangent field. ΔE94 uses
the white of D65 and is measured where the reference Y > 1e-3; elsewhere the
XYZ must agree in absolute terms.
"""

from __future__ import annotations

import numpy as np
import pytest
from gpu_helpers import DARK_Y, MAX_DE94, WL, compare_lit, lights_pair, spd

from spectral_materials.core.brdf import shading
from spectral_materials.core.colour.spectrum_library import blackbody_spd
from spectral_materials.core.lights import SpectralLight

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

SPOT_POSITION = (0.5, 0.5, 2.5)
SPOT_AXIS = (-0.2, -0.2, -1.0)


def _lights() -> dict[str, SpectralLight]:
    """One light of each kind around the sphere, lighting it to Y ≈ 0.05–2."""
    return {
        "sun": SpectralLight("SUN", spd("D65"), WL, 1.5, axis=(-0.3, -0.4, -1.0), name="sun"),
        "point": SpectralLight("POINT", spd("A"), WL, 100.0, position=(1.5, 1.0, 2.0),
                               name="point"),
        "spot_hard": SpectralLight("SPOT", spd("FL2"), WL, 100.0, position=SPOT_POSITION,
                                   axis=SPOT_AXIS, spot_size=np.radians(40.0), spot_blend=0.0,
                                   name="spot hard"),
        "spot_blend": SpectralLight("SPOT", spd("FL2"), WL, 100.0, position=SPOT_POSITION,
                                    axis=SPOT_AXIS, spot_size=np.radians(40.0), spot_blend=0.3,
                                    name="spot blend"),
        "area": SpectralLight("AREA", blackbody_spd(4000.0, WL), WL, 30.0,
                              position=(-1.5, 0.5, 2.0), axis=(1.5, -0.5, -2.0), name="area"),
    }


LIGHTS = _lights()


@pytest.fixture(scope="module")
def model(factored):
    return factored("hd")


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
@pytest.mark.parametrize("name", sorted(LIGHTS))
def test_single_light(model, name, precontract):
    light = LIGHTS[name]
    got, reference = lights_pair(model, [light], precontract=precontract)
    assert 0.05 < reference[:, 1].max() < 5.0
    de = compare_lit(got, reference)
    print(f"\n{name:>10} {'precontract' if precontract else 'per-coefficient'}: "
          f"max ΔE94 {de:.2e}")


def test_spot_cone_cuts_the_sphere():
    """The spot's cone edge crosses the visible sphere: part of the lit side is masked off."""
    points, _ = shading.sphere_pixels(64)
    for name in ("spot_hard", "spot_blend"):
        light = LIGHTS[name]
        wi, _ = light.incidence(points)
        facing = np.einsum("ij,ij->i", wi, points) > 0
        mask = light.spot_mask(-(wi @ np.asarray(light.axis)))
        assert (facing & (mask == 0)).sum() > 100 and (facing & (mask == 1)).sum() > 100
        if name == "spot_blend":
            assert ((mask > 0.01) & (mask < 0.99)).sum() > 50      # a real blend band
        else:
            # No pixel within float32 reach of the hard edge (where the two could differ).
            cos_angle = -(wi @ np.asarray(light.axis))
            assert np.abs(cos_angle - light.spot_cos).min() > 1e-5


def test_spot_blend_changes_the_picture(model):
    hard, _ = lights_pair(model, [LIGHTS["spot_hard"]])
    soft, _ = lights_pair(model, [LIGHTS["spot_blend"]])
    assert np.abs(hard - soft).max() > 0.05


def test_area_light_is_one_sided(model):
    """An area light facing away from the sphere lights nothing."""
    light = SpectralLight("AREA", spd("D65"), WL, 30.0, position=(0.0, 0.0, 3.0),
                          axis=(0.0, 0.0, 1.0))
    got, reference = lights_pair(model, [light])
    assert not reference.any() and not got.any()


def _eight_lights() -> list[SpectralLight]:
    bb3000, bb6500 = blackbody_spd(3000.0, WL), blackbody_spd(6500.0, WL)
    return [
        SpectralLight("SUN", spd("D65"), WL, 0.4, axis=(-0.5, 0.2, -1.0), name="sun D65"),
        SpectralLight("SUN", bb3000, WL, 0.3, axis=(0.8, -0.3, -0.4), name="sun 3000 K"),
        SpectralLight("POINT", spd("A"), WL, 40.0, position=(1.5, 1.0, 2.0), name="point A"),
        SpectralLight("POINT", spd("FL2"), WL, 30.0, position=(-2.0, -0.5, 1.0),
                      name="point FL2"),
        SpectralLight("SPOT", spd("FL2"), WL, 60.0, position=SPOT_POSITION, axis=SPOT_AXIS,
                      spot_size=np.radians(40.0), spot_blend=0.0, name="spot hard"),
        SpectralLight("SPOT", bb6500, WL, 50.0, position=(-0.5, 2.0, 1.5),
                      axis=(0.3, -1.0, -0.7), spot_size=np.radians(60.0), spot_blend=0.3,
                      name="spot blend"),
        SpectralLight("AREA", bb3000, WL, 15.0, position=(-1.5, 0.5, 2.0),
                      axis=(1.5, -0.5, -2.0), name="area 3000 K"),
        SpectralLight("AREA", spd("D65"), WL, 10.0, position=(0.5, -2.0, 1.0),
                      axis=(-0.5, 2.0, -1.0), name="area D65"),
    ]


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
@pytest.mark.parametrize("parameterization", ["hd", "io_iso"])
def test_eight_mixed_lights(factored, parameterization, precontract):
    model = factored(parameterization)
    lights = _eight_lights()
    got, reference = lights_pair(model, lights, precontract=precontract)
    assert 0.5 < reference[:, 1].max() < 5.0
    assert (reference[:, 1] > DARK_Y).mean() > 0.9            # lit nearly everywhere
    de = compare_lit(got, reference)
    # The mix is the sum of its parts (each light drawn alone, by the mirror).
    points, _ = shading.sphere_pixels(64)
    parts = sum(shading.shade_xyz(model, points, points, np.zeros_like(points), shading.View(),
                                  [light], two_sided=False) for light in lights)
    np.testing.assert_allclose(reference, parts, rtol=1e-12, atol=1e-12)
    print(f"\n8 lights {parameterization} {'precontract' if precontract else 'per-coefficient'}: "
          f"max ΔE94 {de:.2e}")
    assert de <= MAX_DE94
