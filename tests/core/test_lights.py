"""Tests of spectral_materials.core.lights: validation, irradiance per kind, spectral weights."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.lights import LIGHT_CODES, MIN_DISTANCE_SQ, SpectralLight

WL = spectra.WAVELENGTHS_REFERENCE
D65 = spectra.illuminant("D65", WL)


def light(kind="POINT", **kw) -> SpectralLight:
    kw.setdefault("spd", D65)
    kw.setdefault("wavelengths", WL)
    return SpectralLight(kind, **kw)


# ------------------------------------------------------------------ validation

@pytest.mark.parametrize(("kwargs", "message"), [
    ({"kind": "LASER"}, "kind must be one of"),
    ({"kind": "sun"}, "kind must be one of"),
    ({"strength": -1.0}, "strength must be finite and ≥ 0"),
    ({"strength": float("inf")}, "strength must be finite"),
    ({"strength": float("nan")}, "strength must be finite"),
    ({"position": (0.0, float("nan"), 0.0)}, "position must be finite"),
    ({"position": (float("inf"), 0.0, 0.0)}, "position must be finite"),
    ({"axis": (0.0, 0.0, 0.0)}, "axis must be a finite non-zero 3-vector"),
    ({"axis": (0.0, float("nan"), 1.0)}, "axis must be a finite non-zero 3-vector"),
    ({"spot_size": 0.0}, r"spot size must be in \(0, π\]"),
    ({"spot_size": -0.5}, r"spot size must be in \(0, π\]"),
    ({"spot_size": 3.5}, r"spot size must be in \(0, π\]"),
    ({"spot_blend": -0.1}, r"spot blend must be in \[0, 1\]"),
    ({"spot_blend": 1.5}, r"spot blend must be in \[0, 1\]"),
    ({"spd": D65[:-1]}, "SPD must be finite, non-negative and match its 81 wavelengths"),
    ({"spd": -D65}, "SPD must be finite, non-negative"),
    ({"spd": np.where(WL == 500, np.nan, D65)}, "SPD must be finite"),
])
def test_invalid_lights_raise_naming_the_problem(kwargs, message):
    kwargs = {"kind": "SPOT", "name": "Lamp", **kwargs}
    with pytest.raises(ValueError, match=message) as info:
        light(**kwargs)
    assert "'Lamp'" in str(info.value)


def test_bad_wavelengths_raise():
    with pytest.raises(ValueError, match="strictly increasing"):
        SpectralLight("SUN", D65, WL[::-1])


def test_fields_are_normalised():
    lamp = light("SPOT", axis=(0.0, 0.0, -4.0), position=[1, 2, 3], strength=5)
    assert lamp.axis == (0.0, 0.0, -1.0)
    assert lamp.position == (1.0, 2.0, 3.0)
    assert lamp.spd.dtype == np.float64 and lamp.wavelengths.dtype == np.float64
    assert {k: light(k).code for k in LIGHT_CODES} == LIGHT_CODES
    # π exactly is a valid (hemispherical) cone; blend 0 and 1 are the ends.
    assert light("SPOT", spot_size=np.pi, spot_blend=1.0).spot_cos == pytest.approx(0.0,
                                                                                  abs=1e-15)
    assert light("SPOT", spot_blend=0.0).spot_blend_width == 0.0


# ------------------------------------------------------------------ irradiance

def test_sun_irradiance_is_its_strength_everywhere():
    sun = light("SUN", strength=2.5, axis=(1.0, -2.0, -2.0))
    points = np.random.default_rng(1).normal(size=(50, 3)) * 10
    wi, irradiance = sun.incidence(points)
    np.testing.assert_array_equal(irradiance, 2.5)
    np.testing.assert_allclose(wi, np.broadcast_to(np.array([-1.0, 2.0, 2.0]) / 3.0, (50, 3)),
                               atol=1e-15)


def test_point_irradiance_and_inverse_square():
    lamp = light("POINT", strength=100.0, position=(1.0, 2.0, 3.0))
    offsets = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -2.0], [0.0, 0.0, -4.0], [3.0, 4.0, 0.0]])
    wi, irradiance = lamp.incidence(np.array(lamp.position) + offsets)
    r = np.linalg.norm(offsets, axis=1)
    np.testing.assert_allclose(irradiance, 100.0 / (4.0 * np.pi * r ** 2), rtol=1e-15)
    np.testing.assert_allclose(irradiance[0] / irradiance[1:3], [4.0, 16.0], rtol=1e-14)
    np.testing.assert_allclose(wi, -offsets / r[:, None], atol=1e-15)
    # Blender's units: a sun of strength E equals a point light of power 4π r² E at r.
    sun_like = light("POINT", strength=4 * np.pi * 25.0 * 3.0, position=(0.0, 0.0, 5.0))
    assert sun_like.incidence(np.zeros((1, 3)))[1][0] == pytest.approx(3.0, rel=1e-14)


def test_point_light_on_the_point_contributes_nothing():
    lamp = light("POINT", strength=1e3, position=(0.5, 0.5, 0.5))
    near = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 0.5 + 0.5e-5], [0.5, 0.5, 0.5 + 2e-5]])
    wi, irradiance = lamp.incidence(near)
    assert np.sqrt(MIN_DISTANCE_SQ) == pytest.approx(1e-5)
    np.testing.assert_array_equal(wi[:2], 0.0)
    np.testing.assert_array_equal(irradiance[:2], 0.0)
    assert irradiance[2] == pytest.approx(1e3 / (4 * np.pi * 4e-10))
    assert np.isfinite(wi).all() and np.isfinite(irradiance).all()


def _spot_points(angles_deg, distance=2.0):
    """Points at ``distance`` below a spot at the origin pointing −z, ``angles`` off its axis."""
    a = np.radians(np.asarray(angles_deg, dtype=np.float64))
    return distance * np.stack([np.sin(a), np.zeros_like(a), -np.cos(a)], axis=-1)


def test_spot_smoothstep_mask():
    size, blend = np.radians(60.0), 0.5
    spot = light("SPOT", strength=50.0, spot_size=size, spot_blend=blend)
    cos_half = np.cos(size / 2)
    width = (1 - cos_half) * blend
    assert spot.spot_cos == pytest.approx(cos_half) and spot.spot_blend_width == pytest.approx(
        width)
    # cos α at the edge, a quarter, half and all the way into the band, and outside.
    cosines = np.array([cos_half, cos_half + 0.25 * width, cos_half + 0.5 * width,
                        cos_half + width, 1.0, cos_half - 0.01])
    t = np.clip((cosines - cos_half) / width, 0, 1)
    expected = t * t * (3 - 2 * t)
    np.testing.assert_allclose(spot.spot_mask(cosines), expected, atol=1e-15)
    np.testing.assert_allclose(spot.spot_mask(cosines)[:4], [0.0, 0.15625, 0.5, 1.0],
                               atol=1e-12)
    # Through incidence: point irradiance times the mask.
    points = _spot_points(np.degrees(np.arccos(np.clip(cosines, -1, 1))))
    _, irradiance = spot.incidence(points)
    np.testing.assert_allclose(irradiance, 50.0 / (4 * np.pi * 4.0) * expected, rtol=1e-9,
                               atol=1e-15)


def test_spot_hard_edge_at_blend_zero():
    spot = light("SPOT", strength=50.0, spot_size=np.radians(60.0), spot_blend=0.0)
    _, irradiance = spot.incidence(_spot_points([0.0, 10.0, 29.9, 30.1, 45.0, 120.0]))
    full = 50.0 / (4 * np.pi * 4.0)
    np.testing.assert_allclose(irradiance, [full, full, full, 0, 0, 0], rtol=1e-14)
    assert spot.spot_mask(np.array([spot.spot_cos]))[0] == 1.0      # the edge is inside


def test_area_irradiance_lambertian_emitter():
    area = light("AREA", strength=20.0, position=(0.0, 0.0, 2.0), axis=(0.0, 0.0, -1.0))
    # Straight below at r = 2; 60° off the emitter's axis at r = 4; behind it.
    points = np.array([[0.0, 0.0, 0.0],
                       [4.0 * np.sin(np.pi / 3), 0.0, 2.0 - 4.0 * np.cos(np.pi / 3)],
                       [0.0, 0.0, 3.0], [5.0, 0.0, 2.0]])
    wi, irradiance = area.incidence(points)
    expected = [20.0 / (np.pi * 4.0), 20.0 * 0.5 / (np.pi * 16.0), 0.0, 0.0]
    np.testing.assert_allclose(irradiance, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(wi[0], [0.0, 0.0, 1.0])
    # 1/r² along the axis.
    _, far = area.incidence(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [0.0, 0.0, -7.0]]))
    np.testing.assert_allclose(far[0] / far[1:], [9.0, 81.0], rtol=1e-14)


def test_incidence_accepts_any_point_shape():
    wi, irradiance = light("POINT", position=(0, 0, 1)).incidence([0.0, 0.0, 0.0])
    assert wi.shape == (1, 3) and irradiance.shape == (1,)


# ------------------------------------------------------------------ spectral weights

def test_weights_on_own_grid_are_the_protocol_weights():
    lamp = light("SUN", spd=spectra.illuminant("A", WL))
    np.testing.assert_allclose(lamp.weights(WL, None), colour_pipeline.xyz_weights("A", WL),
                               rtol=1e-14)
    basis = np.linalg.qr(np.random.default_rng(3).normal(size=(WL.size, 6)))[0]
    np.testing.assert_allclose(lamp.weights(WL, basis),
                               basis.T @ colour_pipeline.xyz_weights("A", WL), rtol=1e-12,
                               atol=1e-14)
    # The SPD's scale does not matter: it only sets the colour.
    np.testing.assert_allclose(light("SUN", spd=7.0 * lamp.spd).weights(WL, None),
                               lamp.weights(WL, None), rtol=1e-14)


def test_weights_resample_a_light_on_another_grid():
    coarse = spectra.wavelength_grid(380.0, 780.0, 10.0)
    ramp = 0.5 + (coarse - 380.0) / 400.0                   # linear: resampled exactly
    lamp = SpectralLight("SUN", ramp, coarse)
    on_fine = 0.5 + (WL - 380.0) / 400.0
    np.testing.assert_allclose(lamp.weights(WL, None), colour_pipeline.xyz_weights(on_fine, WL),
                               rtol=1e-12)
    # A light known only on 450–650 nm is dark outside it.
    narrow_wl = spectra.wavelength_grid(450.0, 650.0, 10.0)
    narrow = SpectralLight("SUN", np.ones(narrow_wl.size), narrow_wl)
    weights = narrow.weights(WL, None)
    outside = (WL < 450.0) | (WL > 650.0)
    assert not weights[outside].any() and (weights[~outside, 1] > 0).all()
    with pytest.raises(ValueError, match="no luminance"):
        SpectralLight("SUN", np.ones(3), np.array([800.0, 900.0, 1000.0])).weights(WL, None)
