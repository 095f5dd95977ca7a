"""The BTF container, hemisphere view interpolation and the draw layout's Python side."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.btf import container as btf, render as btf_render
from spectral_materials.core.colour import spectra
from spectral_materials.core.lights import SpectralLight

WL = spectra.WAVELENGTHS_REFERENCE


def _random_hemisphere(n, seed=0):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _small_btf(views=None, lights=None, texels=(2, 3), channels=4, seed=0):
    views = btf.ring_directions() if views is None else views
    lights = btf.ring_directions() if lights is None else lights
    rng = np.random.default_rng(seed)
    values = rng.uniform(0.0, 1.0, (len(views), len(lights), *texels, channels))
    return btf.BTF(values, views, lights, np.linspace(400, 700, channels), "small")


# ------------------------------------------------------------------- container


def test_ring_directions_are_the_ubo_set():
    d = btf.ring_directions()
    assert d.shape == (81, 3)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    theta = np.degrees(np.arccos(np.clip(d[:, 2], -1, 1)))
    assert sorted(np.unique(theta.round(6))) == [0, 15, 30, 45, 60, 75]


def test_luminance_of_a_grey_is_its_reflectance():
    b = _small_btf(channels=5)
    b.values[:] = 0.37
    assert np.allclose(b.luminance(), 0.37, atol=1e-6)
    rgb = btf.BTF(np.full((3, 2, 1, 1, 3), 0.5), btf.ring_directions()[:3],
                  btf.ring_directions()[:2])
    assert np.allclose(rgb.luminance(), 0.5)


@pytest.mark.parametrize("mutate, message", [
    (lambda v: v.__setitem__((0, 0, 0, 0, 0), np.inf), "infinite"),
    (lambda v: v.__setitem__((0, 0, 0, 0, 0), -0.5), "negative"),
    (lambda v: v.__setitem__((0, 0, 0, 0, 0), np.nan), "partly NaN"),
])
def test_bad_samples_are_named(mutate, message):
    b = _small_btf()
    values = b.values.copy()
    mutate(values)
    with pytest.raises(btf.InvalidBTF, match=message):
        btf.BTF(values, b.views, b.lights, b.wavelengths)


def test_missing_images_are_flagged_not_invented():
    b = _small_btf()
    values = b.values.copy()
    values[3, 7] = np.nan
    out = btf.BTF(values, b.views, b.lights, b.wavelengths)
    assert not out.present[3, 7] and out.present.sum() == 81 * 81 - 1
    values[:] = np.nan
    with pytest.raises(btf.InvalidBTF, match="no .* image holds data"):
        btf.BTF(values, b.views, b.lights, b.wavelengths)


def test_shape_and_direction_errors():
    views = btf.ring_directions()[:4]
    with pytest.raises(btf.InvalidBTF, match="views × .* lights"):
        btf.BTF(np.zeros((4, 3, 1, 1, 3)), views, views)
    below = views.copy()
    below[1, 2] = -0.5
    with pytest.raises(btf.InvalidBTF, match="upper hemisphere"):
        btf.BTF(np.zeros((4, 4, 1, 1, 3)), below, views)
    with pytest.raises(btf.InvalidBTF, match="RGB BTF needs 3"):
        btf.BTF(np.zeros((4, 4, 1, 1, 2)), views, views)


def test_rgb_spectral_reflectance_uses_smits():
    b = btf.BTF(np.full((2, 2, 1, 1, 3), 0.6), btf.ring_directions()[:2],
                btf.ring_directions()[:2])
    spectrum = b.spectral_reflectance()
    assert spectrum.shape == (2, 2, 1, 1, len(WL))
    assert np.allclose(spectrum, 0.6, atol=1e-3)     # Smits: a grey is (nearly) flat


# --------------------------------------------------------------- triangulation


def test_weights_reproduce_measured_directions_exactly():
    d = btf.ring_directions()
    tri = btf.HemisphereTriangulation(d)
    index, weight = tri.weights(d)
    best = index[np.arange(len(d)), weight.argmax(axis=1)]
    assert np.array_equal(best, np.arange(len(d)))
    assert np.allclose(weight.max(axis=1), 1.0)


def test_weights_are_barycentric_inside_the_hull():
    d = btf.ring_directions()
    tri = btf.HemisphereTriangulation(d)
    v = _random_hemisphere(5000)
    index, weight = tri.weights(v)
    assert weight.min() >= 0 and np.allclose(weight.sum(axis=1), 1.0)
    inside = np.degrees(np.arccos(v[:, 2])) < 74.0
    rebuilt = np.einsum("nk,nkc->nc", weight, d[index])
    rebuilt /= np.linalg.norm(rebuilt, axis=1, keepdims=True)
    assert np.abs(rebuilt[inside] - v[inside]).max() < 1e-12


def test_views_beyond_the_last_ring_and_below_the_horizon_clamp():
    tri = btf.HemisphereTriangulation(btf.ring_directions())
    grazing = np.array([[1.0, 0.0, 0.01], [0.0, -1.0, 0.0], [0.3, 0.2, -0.5]])
    index, weight = tri.weights(grazing)
    assert np.isfinite(weight).all() and weight.min() >= 0
    assert np.allclose(weight.sum(axis=1), 1.0)
    theta = np.degrees(np.arccos(tri.directions[index][..., 2]))
    assert theta.min() > 59.0          # blended from the outer rings only


def test_dense_and_degenerate_direction_sets():
    dense = _random_hemisphere(151, seed=3)
    tri = btf.HemisphereTriangulation(dense)
    assert tri.cell_count.max() > 8        # long candidate lists are kept, not refused
    v = _random_hemisphere(2000, seed=4)
    index, w = tri.weights(v)
    assert np.isfinite(w).all() and w.min() >= 0
    inside = np.einsum("nk,nkc->nc", w, dense[index])
    inside /= np.linalg.norm(inside, axis=1, keepdims=True)
    hull = np.abs(inside - v).max(axis=1) < 1e-9
    assert hull.mean() > 0.8
    line = np.array([[0.0, 0.0, 1.0], [np.sin(0.2), 0, np.cos(0.2)], [np.sin(0.4), 0,
                                                                        np.cos(0.4)]])
    with pytest.raises(btf.InvalidBTF, match="do not span"):
        btf.HemisphereTriangulation(line)


def test_resample_is_exact_at_measured_directions_and_linear_between():
    b = _small_btf(texels=(1, 2), channels=3)
    same = btf.resample(b, views=b.views, lights=b.lights)
    assert np.allclose(same.values, b.values, atol=1e-6)
    # A BTF linear in the light direction is reproduced between samples up to the
    # projection's curvature (weights are gnomonic barycentrics).
    lights = btf.ring_directions()
    values = np.repeat((0.5 + 0.3 * lights[:, 0])[None, :, None, None, None], 2, axis=0)
    linear = btf.BTF(np.broadcast_to(values, (2, 81, 1, 1, 3)).copy(),
                     btf.ring_directions()[:2], lights)
    target = _random_hemisphere(50, seed=9)
    target = target[np.degrees(np.arccos(target[:, 2])) < 70]
    out = btf.resample(linear, lights=target)
    assert np.abs(out.values[0, :, 0, 0, 0] - (0.5 + 0.3 * target[:, 0])).max() < 0.02


def test_resample_skips_missing_images():
    b = _small_btf(texels=(1, 1), channels=3)
    values = b.values.copy()
    values[:, 0] = np.nan                  # the pole light missing everywhere
    holed = btf.BTF(values, b.views, b.lights, b.wavelengths)
    out = btf.resample(holed, lights=np.array([[0.0, 0.0, 1.0], [0.05, 0.0, 0.9987]]))
    assert np.isfinite(out.values).all()


# ---------------------------------------------------------------- draw layout


def test_tile_layout_fits_the_limits():
    lay = btf_render.TileLayout.plan(32, 32, 250, max_layers=16, max_size=256)
    assert lay.layers <= 16 and lay.size[0] <= 256 and lay.size[1] <= 256
    layer, x, y = lay.locate(np.arange(250))
    keys = set(zip(layer.tolist(), x.tolist(), y.tolist()))
    assert len(keys) == 250                          # no two records share a tile
    with pytest.raises(ValueError, match="do not fit"):
        btf_render.TileLayout.plan(64, 64, 10_000, max_layers=8, max_size=256)


def test_albedo_basis_is_exact_for_few_spectra():
    patches = np.stack([spectra.colorchecker(p, WL) for p in (2, 7, 14)])
    albedo = patches[np.array([[0, 1], [2, 0]])]
    basis, c = btf_render.albedo_basis(albedo, 6)
    assert basis.shape[1] == 3
    assert np.allclose(c @ basis.T, albedo, atol=1e-10)


def _drawable(kind, params, lobes=0):
    views = btf.ring_directions()
    basis = np.ones((len(WL), 1)) / np.sqrt(len(WL))
    coefficients = np.full((1, 1, 1), np.sqrt(len(WL)), np.float32)   # albedo ≡ 1
    full = np.broadcast_to(np.asarray(params, np.float32), (len(views), 1, 1, len(params)))
    return btf_render.DrawableBTF(kind, lobes, views, full.copy(), coefficients, basis)


def test_rfp_luminance_reference_values():
    d = _drawable("RFP", [1.0, 2.0, 0.5, 0.25, -0.5, 0.75, 0, 0])
    l = np.array([[0.3, 0.4, np.sqrt(0.75)], [0.0, 0.0, 1.0], [0.5, 0.0, -0.2]])
    y = d.luminance(np.zeros(3, int), np.zeros(3, int), np.zeros(3, int), l)
    expected = 0.09 + 2 * 0.16 + 0.5 * 0.12 + 0.25 * 0.3 - 0.5 * 0.4 + 0.75
    assert y == pytest.approx([expected, 0.75, 0.0])


def test_rfnl_luminance_reference_values_and_extremes():
    t = np.array([0.0, 0.6, 0.8])
    d = _drawable("RFNL", [0.1, 2.0, 0, 0, *t, 10.0], lobes=1)
    l = np.array([[0.0, 0.6, 0.8], [0.0, 0.0, 1.0]])
    y = d.luminance(np.zeros(2, int), np.zeros(2, int), np.zeros(2, int), l)
    assert y == pytest.approx([2.1, 0.1 + 2.0 * 0.8**10])
    extreme = _drawable("RFNL", [0.0, btf_render.AMPLITUDE_MAX, 0, 0, *t,
                                 btf_render.N_MAX], lobes=1)
    y = extreme.luminance(np.zeros(2, int), np.zeros(2, int), np.zeros(2, int), l)
    assert np.isfinite(y).all() and np.isfinite(y.astype(np.float16)).all()


def test_white_lambertian_btf_shades_to_y_equal_irradiance_times_cos():
    """value = cos θl (white Lambertian) → Y = E cos θl, the protocol's normalisation."""
    d = _drawable("RFNL", [0.0, 1.0, 0, 0, 0.0, 0.0, 1.0, 1.0], lobes=1)
    light = SpectralLight("SUN", spectra.illuminant("D65", WL), WL, strength=2.0,
                          axis=(-0.6, 0.0, -0.8))
    frames = np.broadcast_to(np.eye(3), (4, 3, 3))
    toward = _random_hemisphere(4, seed=2)
    xyz = d.shade_xyz(np.zeros((4, 2)), frames, np.zeros((4, 3)), toward, [light])
    assert np.allclose(xyz[:, 1], 2.0 * 0.8, rtol=1e-6)


def test_drawable_refuses_bad_parameters():
    views = btf.ring_directions()
    basis = np.ones((len(WL), 1)) / np.sqrt(len(WL))
    params = np.zeros((81, 1, 1, 8), np.float32)
    params[0, 0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        btf_render.DrawableBTF("RFP", 0, views, params, np.ones((1, 1, 1)), basis)
    with pytest.raises(ValueError, match="1..3 lobes"):
        btf_render.DrawableBTF("RFNL", 4, views, np.zeros((81, 1, 1, 20)), np.ones((1, 1, 1)),
                               basis)


def test_views_used_are_those_with_weight():
    d = _drawable("RFP", [0, 0, 0, 0, 0, 1, 0, 0])
    assert d.views_used(np.array([[0.0, 0.0, 1.0]])).tolist() == [0]
    oblique = np.array([np.sin(0.5), 0.0, np.cos(0.5)])
    used = d.views_used(oblique[None])
    assert 1 <= len(used) <= 3
    everything = d.views_used(_random_hemisphere(20000, seed=1))
    assert len(everything) == 81
