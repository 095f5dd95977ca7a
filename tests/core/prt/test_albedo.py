"""Spectral albedo textures (core/prt/albedo.py): R̃ layers equal prt.albedo_weights per texel,
a complete basis changes nothing, GLSL-style bilinear sampling, spectral EXR input, the
Smits uplift of grey, the PRT basis, and refusals of bad input."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.prt import albedo, transfer as prt

WL = spectra.WAVELENGTHS_REFERENCE


def _orthonormal(m, seed=2):
    return np.linalg.qr(np.random.default_rng(seed).standard_normal((WL.size, m)))[0]


def _texture(height=3, width=4, seed=0):
    rng = np.random.default_rng(seed)
    patches = np.stack([spectra.colorchecker(i, WL) for i in range(1, 25)])
    return patches[rng.integers(0, 24, (height, width))] * rng.uniform(0.5, 1.0,
                                                                        (height, width, 1))


@pytest.mark.parametrize("basis", [None, _orthonormal(6)])
def test_layers_of_a_constant_spectrum_are_albedo_weights(basis):
    spectrum = spectra.colorchecker(9, WL)
    layers = albedo.albedo_layers_from_spectra(np.broadcast_to(spectrum, (2, 3, WL.size)),
                                               WL, basis)
    m = WL.size if basis is None else basis.shape[1]
    assert layers.layers.shape == (m, 2, 3, 3) and layers.layers.dtype == np.float32
    assert layers.nbytes == m * 2 * 3 * 3 * 4 and layers.count == m
    expected = prt.albedo_weights(spectrum, WL, basis)                      # (m, 3)
    np.testing.assert_allclose(layers.layers, np.broadcast_to(expected[:, None, None, :],
                                                              layers.layers.shape),
                               rtol=1e-6, atol=1e-9)


def test_every_texel_is_albedo_weights_and_rows_stay_in_place():
    texture = _texture()
    basis = _orthonormal(5)
    layers = albedo.albedo_layers_from_spectra(texture, WL, basis).layers
    for j, i in [(0, 0), (0, 3), (2, 1), (1, 2)]:
        np.testing.assert_allclose(layers[:, j, i], prt.albedo_weights(texture[j, i], WL, basis),
                                   rtol=1e-5, atol=1e-8)


def test_a_complete_basis_gives_identical_xyz():
    """Σ_j Ê_j R̃_j in any orthonormal basis of the whole space is the per-wavelength sum."""
    texture = _texture(2, 2, seed=4)
    basis = _orthonormal(WL.size, seed=7)
    full = albedo.albedo_layers_from_spectra(texture, WL).layers
    rotated = albedo.albedo_layers_from_spectra(texture, WL, basis).layers
    irradiance = spectra.illuminant("FL2", WL)                      # Ê per wavelength
    xyz_full = np.einsum("l,lhwc->hwc", irradiance, full.astype(np.float64))
    xyz_basis = np.einsum("l,lhwc->hwc", irradiance @ basis, rotated.astype(np.float64))
    np.testing.assert_allclose(xyz_basis, xyz_full, rtol=1e-5)


def test_single_spectrum_is_a_one_texel_texture():
    spectrum = spectra.colorchecker(3, WL)
    layers = albedo.albedo_layers_from_spectra(spectrum, WL)
    assert layers.layers.shape == (WL.size, 1, 1, 3)
    for uv in ([0.5, 0.5], [0.0, 0.0], [-3.7, 12.25]):
        np.testing.assert_allclose(albedo.sample_layers(layers.layers, np.array([uv]))[0],
                                   prt.albedo_weights(spectrum, WL), rtol=1e-6)
    rgb = albedo.albedo_layers_from_rgb(np.array([0.2, 0.4, 0.6]), WL)
    assert rgb.layers.shape == (WL.size, 1, 1, 3)


def _hand_layers():
    """m = 2 layers of a 2 × 3 (H × W) texture; texel (row j, column i) holds distinct
    values."""
    values = np.arange(2 * 2 * 3 * 3, dtype=np.float32).reshape(2, 2, 3, 3) ** 1.5
    return values


def test_sample_layers_by_hand():
    layers = _hand_layers()
    h, w = 2, 3

    def texel(j, i):
        return layers[:, j, i].astype(np.float64)

    # Texel centres give the texel itself; row 0 is v near 0.
    for j in range(h):
        for i in range(w):
            uv = np.array([[(i + 0.5) / w, (j + 0.5) / h]])
            np.testing.assert_allclose(albedo.sample_layers(layers, uv)[0], texel(j, i))
    # Halfway between the centres of columns 0 and 1, a quarter between rows 0 and 1.
    uv = np.array([[1.0 / w, (0.5 + 0.25) / h]])
    expected = 0.75 * (0.5 * texel(0, 0) + 0.5 * texel(0, 1)) + \
        0.25 * (0.5 * texel(1, 0) + 0.5 * texel(1, 1))
    np.testing.assert_allclose(albedo.sample_layers(layers, uv)[0], expected)
    # The edges u = 0 and v = 0 blend with the opposite side (REPEAT).
    corner = 0.25 * (texel(0, 0) + texel(0, w - 1) + texel(h - 1, 0) + texel(h - 1, w - 1))
    np.testing.assert_allclose(albedo.sample_layers(layers, np.array([[0.0, 0.0]]))[0], corner)
    np.testing.assert_allclose(albedo.sample_layers(layers, np.array([[1.0, 1.0]]))[0], corner)
    # Wrapping by whole periods changes nothing.
    rng = np.random.default_rng(1)
    uv = rng.random((50, 2))
    shifted = uv + rng.integers(-5, 6, (50, 2))
    np.testing.assert_allclose(albedo.sample_layers(layers, shifted),
                               albedo.sample_layers(layers, uv), atol=1e-9)
    # (N, 2) → (N, m, 3); (..., 2) keeps the leading shape.
    assert albedo.sample_layers(layers, uv).shape == (50, 2, 3)
    assert albedo.sample_layers(layers, uv.reshape(5, 10, 2)).shape == (5, 10, 2, 3)


def test_sample_layers_matches_a_brute_force_glsl_mirror():
    layers = np.random.default_rng(3).random((3, 5, 7, 3)).astype(np.float32)
    uv = np.random.default_rng(4).uniform(-2.0, 3.0, (200, 2))
    m, h, w, _ = layers.shape
    expected = np.empty((len(uv), m, 3))
    for n, (u, v) in enumerate(uv):                       # prt_frag.glsl, line by line
        s, t = u * w - 0.5, v * h - 0.5
        cs, ct = np.floor(s), np.floor(t)
        fx, fy = s - cs, t - ct
        c0 = (int(cs), int(ct))

        def fetch(dx, dy, c0=c0):
            i, j = (c0[0] + dx) % w, (c0[1] + dy) % h
            return layers[:, j, i].astype(np.float64)

        expected[n] = ((1 - fx) * (1 - fy) * fetch(0, 0) + fx * (1 - fy) * fetch(1, 0)
                       + (1 - fx) * fy * fetch(0, 1) + fx * fy * fetch(1, 1))
    np.testing.assert_allclose(albedo.sample_layers(layers, uv), expected, rtol=1e-12)


def test_bad_input_is_refused_with_counts():
    texture = _texture(2, 2)
    broken = texture.copy()
    broken[0, 0, :2] = np.nan
    broken[1, 1, 5] = np.inf
    with pytest.raises(ValueError, match="3 non-finite"):
        albedo.albedo_layers_from_spectra(broken, WL)
    negative = texture.copy()
    negative[0, 1, 3:5] = -0.1
    with pytest.raises(ValueError, match="2 negative"):
        albedo.albedo_layers_from_spectra(negative, WL)
    with pytest.raises(ValueError, match="reflectance must be"):
        albedo.albedo_layers_from_spectra(np.ones((2, 2, 5)), WL)
    with pytest.raises(ValueError, match="reflectance must be"):
        albedo.albedo_layers_from_spectra(np.ones((2, WL.size)), WL)
    with pytest.raises(ValueError, match="basis must be"):
        albedo.albedo_layers_from_spectra(texture, WL, np.ones((5, 2)))
    with pytest.raises(ValueError, match="1 non-finite"):
        albedo.albedo_layers_from_rgb(np.array([[[0.1, np.nan, 0.2]]]), WL)
    with pytest.raises(ValueError, match="rgb must be"):
        albedo.albedo_layers_from_rgb(np.ones((2, 2, 4)), WL)
    layers = _hand_layers()
    with pytest.raises(ValueError, match="2 non-finite"):
        albedo.sample_layers(layers, np.array([[np.nan, 0.5], [0.1, np.inf]]))
    with pytest.raises(ValueError, match="uv must be"):
        albedo.sample_layers(layers, np.ones((4, 3)))
    with pytest.raises(ValueError, match="layers must be"):
        albedo.sample_layers(layers[0], np.ones((4, 2)))


def test_rgb_uplift_of_grey_is_flat():
    grey = albedo.albedo_layers_from_rgb(np.full((2, 3, 3), 0.18), WL)
    flat = albedo.albedo_layers_from_spectra(np.full(WL.size, 0.18), WL)
    np.testing.assert_allclose(grey.layers, np.broadcast_to(flat.layers, grey.layers.shape),
                               rtol=2e-3, atol=1e-6)
    # With a basis, the uplifted texels are projected like any spectrum.
    basis = _orthonormal(4)
    rgb = np.array([[[0.7, 0.2, 0.1], [0.05, 0.3, 0.6]]])
    from spectral_materials.core.colour.uplift import SmitsUplift

    spectra_rgb = SmitsUplift()(rgb.reshape(-1, 3), WL).reshape(1, 2, WL.size)
    np.testing.assert_allclose(albedo.albedo_layers_from_rgb(rgb, WL, basis).layers,
                               albedo.albedo_layers_from_spectra(spectra_rgb, WL, basis).layers,
                               rtol=1e-5, atol=1e-8)


def test_spectral_exr_round_trip(tmp_path):
    pytest.importorskip("OpenEXR")
    from spectral_materials.core.formats.spectral_exr import write_spectral_exr

    file_wl = np.arange(400.0, 701.0, 10.0)          # narrower than WL: ends are held
    rng = np.random.default_rng(0)
    values = rng.uniform(0.05, 0.9, (3, 4, file_wl.size)).astype(np.float32)
    path = write_spectral_exr(tmp_path / "albedo.exr", file_wl, values)
    basis = _orthonormal(6)
    layers = albedo.albedo_layers_from_spectral_exr(path, WL, basis)
    resampled = np.stack([[np.interp(WL, file_wl, values[j, i]) for i in range(4)]
                          for j in range(3)])
    assert resampled[0, 0, 0] == values[0, 0, 0] and resampled[0, 0, -1] == values[0, 0, -1]
    expected = albedo.albedo_layers_from_spectra(resampled, WL, basis)
    np.testing.assert_allclose(layers.layers, expected.layers, rtol=1e-5, atol=1e-7)
    assert "albedo.exr" in layers.source
    np.testing.assert_allclose(albedo.read_reflectance_exr(path, WL), resampled, rtol=1e-6)


def test_spectral_exr_without_a_reflective_layer_is_refused(tmp_path):
    pytest.importorskip("OpenEXR")
    from spectral_materials.core.formats.exr import write_exr
    from spectral_materials.core.formats.spectral_exr import write_spectral_exr

    emissive = write_spectral_exr(tmp_path / "light.exr", [500.0, 600.0],
                                  np.ones((2, 2, 2)), kind="emissive")
    with pytest.raises(ValueError, match=r"light.exr.*reflective.*T\.<λ>"):
        albedo.albedo_layers_from_spectral_exr(emissive, WL)
    rgb = write_exr(tmp_path / "rgb.exr", {c: np.ones((2, 2)) for c in "RGB"})
    with pytest.raises(ValueError, match=r"rgb.exr.*not a spectral image"):
        albedo.albedo_layers_from_spectral_exr(rgb, WL)
    negative = write_spectral_exr(tmp_path / "neg.exr", [500.0, 600.0],
                                  -np.ones((2, 2, 2)), allow_invalid=True)
    with pytest.raises(ValueError, match="8 negative"):
        albedo.albedo_layers_from_spectral_exr(negative, WL)
    with pytest.raises(FileNotFoundError):
        albedo.albedo_layers_from_spectral_exr(tmp_path / "missing.exr", WL)


def test_prt_basis_is_orthonormal_and_exact_for_its_inputs():
    albedos = np.stack([spectra.colorchecker(i, WL) for i in (2, 9, 14)])
    basis = albedo.prt_basis(albedos, ["FL2"], WL, 8)
    assert basis.shape == (WL.size, 8)
    np.testing.assert_allclose(basis.T @ basis, np.eye(8), atol=1e-12)
    # 3 albedos × 3 CMFs + 1 light = 10 spectra: a 12-vector basis is completed, and the
    # inputs lie in its span, so Σ R̃ L̂ is exact for them.
    basis = albedo.prt_basis(albedos, ["FL2"], WL, 12)
    np.testing.assert_allclose(basis.T @ basis, np.eye(12), atol=1e-12)
    light = spectra.illuminant("FL2", WL)
    for a in albedos:
        exact = light @ prt.albedo_weights(a, WL)
        np.testing.assert_allclose((light @ basis) @ prt.albedo_weights(a, WL, basis), exact,
                                   rtol=1e-10)
    # The light alone in the span makes any albedo exact.
    other = spectra.colorchecker(20, WL)
    np.testing.assert_allclose((light @ basis) @ prt.albedo_weights(other, WL, basis),
                               light @ prt.albedo_weights(other, WL), rtol=1e-10)
    np.testing.assert_array_equal(albedo.prt_basis(albedos, ["D65"], WL, WL.size),
                                  np.eye(WL.size))
    with pytest.raises(ValueError, match="basis count"):
        albedo.prt_basis(albedos, ["D65"], WL, 0)
    with pytest.raises(ValueError, match="1 non-finite"):
        albedo.prt_basis(np.where(np.arange(WL.size) == 3, np.nan, 0.5), ["D65"], WL, 4)
    with pytest.raises(ValueError, match="albedos must be"):
        albedo.prt_basis(np.ones((2, 7)), ["D65"], WL, 4)


# ------------------------------------------------------------- packing for the GPU


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 8, 16])
def test_layers_to_rgba_packs_four_values_to_a_texel_and_back(m):
    rng = np.random.default_rng(m)
    layers = rng.uniform(0.0, 2.0, (m, 3, 5, 3))
    packed = albedo.layers_to_rgba(layers)
    assert packed.shape == (-(-3 * m // 4), 3, 5, 4) and packed.dtype == np.float32
    np.testing.assert_array_equal(albedo.rgba_to_layers(packed, m),
                                  layers.astype(np.float32))
    # value q = 3j + c sits in component q % 4 of layer q // 4; padding is zero
    for j in range(m):
        for c in range(3):
            q = 3 * j + c
            np.testing.assert_array_equal(packed[q // 4, :, :, q % 4],
                                          layers[j, :, :, c].astype(np.float32))
    tail = packed.transpose(1, 2, 0, 3).reshape(3, 5, -1)[..., 3 * m:]
    assert not tail.any()


def test_layers_to_rgba_hand_values():
    """m = 2: six values R̃0 = (1, 2, 3), R̃1 = (4, 5, 6) → layers (1, 2, 3, 4), (5, 6, 0, 0)."""
    layers = np.array([[[[1.0, 2.0, 3.0]]], [[[4.0, 5.0, 6.0]]]])
    packed = albedo.layers_to_rgba(layers)
    np.testing.assert_array_equal(packed[:, 0, 0], [[1, 2, 3, 4], [5, 6, 0, 0]])


def test_layers_to_rgba_keeps_nan_and_refuses_bad_shapes():
    layers = np.full((2, 1, 1, 3), np.nan)
    assert np.isnan(albedo.layers_to_rgba(layers)[:, 0, 0].ravel()[:6]).all()
    with pytest.raises(ValueError, match=r"\(m, H, W, 3\)"):
        albedo.layers_to_rgba(np.zeros((2, 4, 4, 4)))
    with pytest.raises(ValueError, match="packed layers"):
        albedo.rgba_to_layers(np.zeros((3, 2, 2, 4)), 2)
