"""Tests of spectral_materials.core.brdf.shading, the float64 mirror of the shaders (no GPU)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from spectral_materials.core.brdf import metrics, models, shading
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.colour import spectra
from spectral_materials.core.lights import SpectralLight

WL = spectra.WAVELENGTHS_REFERENCE
D65 = spectra.illuminant("D65", WL)


@pytest.fixture(scope="module")
def model():
    """A small factored glossy BRDF (hd_iso, 2 packs = 8 terms, 6-vector basis)."""
    brdf = models.make_model("ashikhmin_shirley", nu=24.0, nv=24.0,
                             diffuse=(WL, spectra.colorchecker(9)), specular=0.05)
    return factor_brdf(brdf, parameterization="hd_iso", resolution=(10, 10, 20), packs=2,
                       spectral_basis=6)


# ------------------------------------------------------------------ frames

def _assert_orthonormal_right_handed(t, b, n):
    for a in (t, b, n):
        np.testing.assert_allclose(np.einsum("ij,ij->i", a, a), 1.0, atol=1e-12)
    for a, c in ((t, b), (b, n), (n, t)):
        np.testing.assert_allclose(np.einsum("ij,ij->i", a, c), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.cross(t, b), n, atol=1e-12)      # det = +1
    assert np.isfinite(t).all() and np.isfinite(b).all() and np.isfinite(n).all()


def test_shading_frame_projects_a_given_tangent():
    rng = np.random.default_rng(5)
    normals = rng.normal(size=(200, 3))
    tangents = rng.normal(size=(200, 3))
    t, b, n = shading.shading_frame(normals, tangents)
    _assert_orthonormal_right_handed(t, b, n)
    np.testing.assert_allclose(n, normals / np.linalg.norm(normals, axis=1, keepdims=True))
    # t is the normalised part of the tangent orthogonal to n (Gram–Schmidt).
    projected = tangents - n * np.einsum("ij,ij->i", n, tangents)[:, None]
    np.testing.assert_allclose(t, projected / np.linalg.norm(projected, axis=1, keepdims=True),
                               atol=1e-12)


def test_shading_frame_fallbacks():
    s = np.sqrt(0.5)
    normals = np.array([
        [0.0, 0.0, 1.0],        # zero tangent → ŷ × n = x̂
        [s, 0.0, s],            # zero tangent → normalize(ŷ × n)
        [0.3, -0.4, 0.5],       # tangent parallel to n
        [0.0, 0.0, 0.0],        # zero normal → +z
        [0.0, 1.0, 0.0],        # pole n = +ŷ: ŷ × n = 0 → x̂
        [0.0, -1.0, 0.0],       # pole n = −ŷ
        [0.0, 2.0, 0.0],        # pole, unnormalised, with a tangent along it
    ])
    tangents = np.array([
        [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.6, -0.8, 1.0], [0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, -3.0, 0.0],
    ])
    t, b, n = shading.shading_frame(normals, tangents)
    _assert_orthonormal_right_handed(t, b, n)
    np.testing.assert_allclose(t[0], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(t[1], [s, 0.0, -s])
    n2 = normals[2] / np.linalg.norm(normals[2])
    g = np.cross([0.0, 1.0, 0.0], n2)
    np.testing.assert_allclose(t[2], g / np.linalg.norm(g), atol=1e-12)
    np.testing.assert_allclose(n[3], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(t[3], [1.0, 0.0, 0.0])
    for row in (4, 5, 6):
        np.testing.assert_allclose(t[row], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(b[4], [0.0, 0.0, -1.0])          # n × t = ŷ × x̂ = −ẑ
    np.testing.assert_allclose(b[5], [0.0, 0.0, 1.0])
    # generated_tangent is the protocol's tangent field (metrics.sphere_directions).
    np.testing.assert_allclose(shading.generated_tangent(normals[[0, 1, 4]]),
                               [[1, 0, 0], [s, 0, -s], [1, 0, 0]], atol=1e-15)


def test_to_local_is_the_frame_transpose():
    rng = np.random.default_rng(6)
    frame = shading.shading_frame(rng.normal(size=(20, 3)), rng.normal(size=(20, 3)))
    v = rng.normal(size=(20, 3))
    local = shading.to_local(frame, v)
    t, b, n = frame
    back = local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n
    np.testing.assert_allclose(back, v, atol=1e-12)


# ------------------------------------------------------------------ view

def test_view_directions_orthographic_and_perspective():
    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [0.0, 0.0, 5.0]])
    ortho = shading.View(origin=(0.0, 3.0, 4.0))
    np.testing.assert_allclose(ortho.directions(points), [[0.0, 0.6, 0.8]] * 3)
    assert ortho.uniform() == (0.0, 3.0, 4.0, 0.0)
    eye = shading.View(origin=(0.0, 0.0, 5.0), perspective=True)
    np.testing.assert_allclose(eye.directions(points),
                               [[0.0, 0.0, 1.0], np.array([-1.0, -2.0, 2.0]) / 3.0,
                                [0.0, 0.0, 1.0]])      # the eye on the point: fallback +z
    assert eye.uniform() == (0.0, 0.0, 5.0, 1.0)
    assert shading.View().directions(points).flags.writeable


# ------------------------------------------------------------------ sphere

def test_sphere_pixels_layout():
    points, mask = shading.sphere_pixels(4)
    # Pixel centres at ±0.25, ±0.75: the four corners fall outside the unit disc.
    assert mask.sum() == 12 and not mask[0, 0] and not mask[3, 3]
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), 1.0)
    assert points[0, 1] < 0                                  # row 0 is the bottom (−y)
    with pytest.raises(ValueError, match="1..8192"):
        shading.sphere_pixels(0)


@pytest.mark.parametrize(("incidence", "illuminant"), [(0.0, "D65"), (30.0, "A"),
                                                       (60.0, "FL2"), (85.0, "FL11")])
def test_sphere_xyz_is_model_xyz_on_the_protocol_sphere(model, incidence, illuminant):
    size = 48
    image, mask = shading.sphere_xyz(model, incidence, illuminant, size)
    view = metrics.sphere_directions(incidence, size)        # row 0 is the top there
    flipped = image[::-1]
    expected = model.xyz(view.wi, view.wo, illuminant)
    np.testing.assert_allclose(flipped[view.mask], expected, rtol=1e-9, atol=1e-12)
    assert not flipped[~view.mask].any()                     # unlit and off-sphere: zero
    np.testing.assert_array_equal(mask[::-1] | view.mask, mask[::-1])
    assert image.shape == (size, size, 3) and mask.shape == (size, size)


def test_protocol_sun():
    sun = shading.protocol_sun(60.0, "A")
    assert sun.kind == "SUN" and sun.strength == 1.0 and sun.name == "A"
    np.testing.assert_allclose(sun.axis, [-np.sin(np.pi / 3), 0.0, -0.5])
    np.testing.assert_allclose(sun.spd, spectra.illuminant("A", WL))


def test_shade_xyz_two_sided_and_not_cosine_weighted(model):
    sun = shading.protocol_sun(20.0, "D65")
    points = np.array([[0.0, 0.0, 0.0]] * 2)
    normals = np.array([[0.1, 0.0, 1.0], [-0.1, 0.0, -1.0]])   # the second faces away
    tangents = np.zeros((2, 3))
    two = shading.shade_xyz(model, points, normals, tangents, shading.View(), [sun])
    np.testing.assert_allclose(two[1], two[0], rtol=1e-12)
    one = shading.shade_xyz(model, points, normals, tangents, shading.View(), [sun],
                            two_sided=False)
    np.testing.assert_allclose(one[0], two[0])
    assert not one[1].any()
    # A model of f (not f·cosθi) is multiplied by cosθi here.
    plain = replace(model, cosine_weighted=False)
    wi = shading.to_local(shading.shading_frame(normals[:1], tangents[:1]),
                          -np.asarray(sun.axis)[None])
    np.testing.assert_allclose(
        shading.shade_xyz(plain, points[:1], normals[:1], tangents[:1], shading.View(), [sun]),
        two[:1] * wi[0, 2], rtol=1e-12)


# ------------------------------------------------------------------ light texture

def _lights():
    return [
        SpectralLight("SUN", D65, WL, 2.0, axis=(0.0, -1.0, -1.0)),
        SpectralLight("SPOT", spectra.illuminant("A", WL), WL, 40.0, position=(1.0, 2.0, 3.0),
                      axis=(0.0, 0.0, -1.0), spot_size=1.0, spot_blend=0.2),
        SpectralLight("AREA", spectra.illuminant("FL2", WL), WL, 5.0, position=(-1, 0, 2)),
    ]


def test_light_texels_header(model):
    lights = _lights()
    texels = shading.light_texels(model, lights)
    groups = -(-model.terms // 4)
    assert texels.dtype == np.float32
    assert texels.shape == (3, shading.LIGHT_HEADER + 3 * groups, 4)
    for row, light in enumerate(lights):
        np.testing.assert_allclose(texels[row, 0], [*light.position, light.code], rtol=1e-7)
        np.testing.assert_allclose(texels[row, 1], [*light.axis, light.strength], rtol=1e-7)
        np.testing.assert_allclose(texels[row, 2],
                                   [light.spot_cos, light.spot_blend_width, 0.0, 0.0], rtol=1e-7)
    assert texels[1, 2, 0] == pytest.approx(np.cos(0.5), rel=1e-7)
    assert texels[1, 2, 1] == pytest.approx((1 - np.cos(0.5)) * 0.2, rel=1e-6)


def test_light_texels_precontracted_weights(model):
    lights = _lights()
    texels = shading.light_texels(model, lights, precontract=True)
    groups = -(-model.terms // 4)
    for row, light in enumerate(lights):
        k = model.spectral.T @ light.weights(model.wavelengths, model.basis)     # (R, 3)
        padded = np.zeros((4 * groups, 3))
        padded[: model.terms] = k
        for g in range(groups):
            for c in range(3):                  # texel 3g + c: the X/Y/Z weights of 4 terms
                np.testing.assert_allclose(texels[row, shading.LIGHT_HEADER + 3 * g + c],
                                           padded[4 * g: 4 * g + 4, c], rtol=1e-6, atol=1e-7)


def test_light_texels_per_coefficient_weights(model):
    lights = _lights()
    texels = shading.light_texels(model, lights, precontract=False)
    assert texels.shape == (3, shading.LIGHT_HEADER + model.spectral_size, 4)
    for row, light in enumerate(lights):
        weights = light.weights(model.wavelengths, model.basis)
        np.testing.assert_allclose(texels[row, shading.LIGHT_HEADER:, :3], weights, rtol=1e-6,
                                   atol=1e-7)
        assert not texels[row, shading.LIGHT_HEADER:, 3].any()


def test_light_texels_partial_last_pack_is_zero_padded(model):
    odd = replace(model, factors=[f[:, :5] for f in model.factors], spectral=model.spectral[:, :5])
    texels = shading.light_texels(odd, _lights()[:1])
    assert texels.shape[1] == shading.LIGHT_HEADER + 3 * 2
    assert not texels[0, shading.LIGHT_HEADER + 3:, 1:].any()       # terms 5–7 are padding


def test_light_texels_refuse_what_cannot_be_drawn(model):
    with pytest.raises(ValueError, match="overflow float32"):
        shading.light_texels(model, [SpectralLight("SUN", D65, WL, 1e39)])
    with pytest.raises(ValueError, match="no lights"):
        shading.light_texels(model, [])
    with pytest.raises(ValueError, match="CP factor packs"):
        shading.light_texels(replace(model, form="separable"), _lights())


def test_shade_xyz_matches_the_light_texture_contraction(model):
    """XYZ = E · Σ_terms product · K: what the shader computes from the precontracted texels."""
    light = _lights()[1]
    points = np.array([[0.9, 2.0, 0.5], [1.1, 1.8, 0.0]])
    normals = np.array([[0.0, 0.0, 1.0], [0.2, 0.1, 1.0]])
    tangents = np.zeros_like(points)
    xyz = shading.shade_xyz(model, points, normals, tangents, shading.View(), [light])
    wi_world, irradiance = light.incidence(points)
    frame = shading.shading_frame(normals, tangents)
    wi, wo = shading.to_local(frame, wi_world), shading.to_local(frame, np.array([[0, 0, 1.0]] * 2))
    coeffs = model.coefficients(wi, wo)
    expected = irradiance[:, None] * (coeffs @ light.weights(model.wavelengths, model.basis))
    np.testing.assert_allclose(xyz, expected, rtol=1e-12)
    assert (irradiance > 0).all() and (np.abs(xyz) > 0).all()
