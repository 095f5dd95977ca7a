"""The albedo forms spectral PRT draws (core/prt/albedo_forms.py): half-float layers with
the first layer's rounding error, against float16 rounding done here and the exact layers'
colours; which form Automatic takes; wrap padding; bad input."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.colour.pipeline import delta_e94, illuminant_spd
from spectral_materials.core.prt import albedo as core_albedo
from spectral_materials.core.prt.albedo_forms import (
    ALBEDO_FORMS,
    DrawnAlbedo,
    drawn_albedo,
    half_texels,
)

WL = np.arange(400.0, 701.0, 10.0)


def _chart(patch: int = 2) -> np.ndarray:
    patches = np.stack([spectra.colorchecker(i, WL) for i in range(1, 25)])
    return np.repeat(np.repeat(patches.reshape(4, 6, -1), patch, 0), patch, 1)


def _albedo(m: int = 8, rgb: np.ndarray | None = None) -> core_albedo.AlbedoLayers:
    basis = core_albedo.prt_basis(_chart(1).reshape(-1, WL.size), ["FL4"], WL, m)
    if rgb is not None:
        return core_albedo.albedo_layers_from_rgb(rgb, WL, basis)
    return core_albedo.albedo_layers_from_spectra(_chart(), WL, basis)


def _max_de(albedo: core_albedo.AlbedoLayers, drawn: np.ndarray, illuminant: str) -> float:
    """ΔE94 of every texel lit by ``illuminant`` through ``drawn`` against the 5 nm
    spectra's own colours through the exact layers, computed here from the basis."""
    light = albedo.basis.T @ illuminant_spd(illuminant, WL)
    unit = core_albedo.albedo_layers_from_spectra(np.ones((1, 1, WL.size)), WL, albedo.basis)
    white = light @ unit.layers[:, 0, 0].astype(np.float64)
    exact = np.einsum("j,jhwc->hwc", light, albedo.layers.astype(np.float64))
    approx = np.einsum("j,jhwc->hwc", light, np.asarray(drawn, np.float64))
    return float(delta_e94(exact / white[1], approx / white[1], white / white[1]).max())


@pytest.mark.parametrize("m", [8, 5, 3])
def test_half_texels_are_float16_rounding_with_the_first_layers_error_after(m):
    albedo = _albedo(m)
    texels, drawn = half_texels(albedo.layers)
    packed = core_albedo.layers_to_rgba(albedo.layers).astype(np.float64)
    count = core_albedo.packed_layer_count(m)
    assert texels.shape == (count + 1,) + packed.shape[1:]
    # Every texel value is exact in half (the upload cannot round it again).
    np.testing.assert_array_equal(texels, texels.astype(np.float16).astype(np.float32))
    np.testing.assert_array_equal(texels[:count], packed.astype(np.float16))
    np.testing.assert_array_equal(texels[count], (packed[0] - texels[0]).astype(np.float16))
    # The first layer is then good to ~22 bits, the others to 11.
    error = np.abs(core_albedo.layers_to_rgba(drawn) - packed)
    # (the second half of a small value is subnormal: spaced 2⁻²⁴ apart)
    assert (error[0] <= 2.0 ** -21 * np.abs(packed[0]) + 2.0 ** -25).all()
    assert (error <= 2.0 ** -11 * np.abs(packed)).all()


@pytest.mark.parametrize("illuminant", ["D65", "FL11", "A", "FL2"])
def test_half_floats_keep_the_chart_and_an_rgb_image_within_the_bound(illuminant):
    chart = _albedo()
    image = _albedo(rgb=np.random.default_rng(3).random((24, 40, 3)))
    for albedo in (chart, image):
        _, drawn = half_texels(albedo.layers)
        # Measured 0.005-0.013 for the chart, up to 0.026 for the image.
        assert _max_de(albedo, drawn, illuminant) < 0.04
    # Plain float16 (no second half for the first layer) moves the chart's white
    # beyond the bound under the incandescent light: why the extra layer is there.
    if illuminant == "A":
        plain = chart.layers.astype(np.float16)
        assert _max_de(chart, plain, illuminant) > 0.05


def test_automatic_takes_half_floats_and_states_their_error():
    albedo = _albedo()
    drawn = drawn_albedo(albedo)
    assert drawn.form == "half" and drawn.filtered and drawn.texture_format == "RGBA16F"
    worst = max(_max_de(albedo, drawn.layers, i) for i in ("D65", "FL11", "A"))
    assert drawn.delta_e94 == pytest.approx(worst, rel=1e-6)
    assert drawn.texels().shape == (7, 8 + 2, 12 + 2, 4)          # wrap-padded


def test_automatic_falls_back_to_the_basis_then_to_the_exact_layers():
    albedo = _albedo()
    # A bound half floats cannot meet: the chart's basis meets it with 16 weights.
    basis = drawn_albedo(albedo, bound=1e-3)
    assert basis.form == "basis" and basis.basis.rank == 16 and basis.delta_e94 <= 1e-3
    np.testing.assert_array_equal(basis.texels(), basis.basis.weights_padded())
    # One nothing meets: the exact layers, unpadded and filtered by hand.
    exact = drawn_albedo(albedo, bound=0.0)
    assert exact.form == "exact" and not exact.filtered and exact.delta_e94 == 0.0
    np.testing.assert_array_equal(exact.texels(), core_albedo.layers_to_rgba(albedo.layers))


def test_forced_forms_are_drawn_whatever_their_error():
    albedo = _albedo()
    half = drawn_albedo(albedo, "half", bound=0.0)
    assert half.form == "half" and half.delta_e94 > 0.0
    assert drawn_albedo(albedo, "exact").form == "exact"
    assert drawn_albedo(albedo, "basis").form == "basis"


def test_filtering_the_padded_half_texels_equals_repeat_sampling_the_drawn_layers():
    albedo = _albedo(5)
    drawn = drawn_albedo(albedo, "half")
    padded = drawn.texels()
    m, h, w, _ = albedo.layers.shape
    count = core_albedo.packed_layer_count(m)
    uv = np.random.default_rng(4).uniform(-2.0, 2.0, (300, 2))
    mapped = (np.mod(uv, 1.0) * (w, h) + 1.0) / (w + 2, h + 2)
    # A texture unit with clamped coordinates (the padding stands in for REPEAT).
    s, t = mapped[:, 0] * (w + 2) - 0.5, mapped[:, 1] * (h + 2) - 0.5
    i0, j0 = np.floor(s).astype(int), np.floor(t).astype(int)
    fs, ft = (s - i0)[:, None, None], (t - j0)[:, None, None]
    layers = padded.astype(np.float64)
    unit = ((1 - fs) * (1 - ft) * layers[:, j0, i0].transpose(1, 0, 2)
            + fs * (1 - ft) * layers[:, j0, i0 + 1].transpose(1, 0, 2)
            + (1 - fs) * ft * layers[:, j0 + 1, i0].transpose(1, 0, 2)
            + fs * ft * layers[:, j0 + 1, i0 + 1].transpose(1, 0, 2))
    unit[:, 0] += unit[:, count]                         # the shader adds the last layer
    values = unit[:, :count].reshape(len(uv), -1)[:, : 3 * m].reshape(len(uv), m, 3)
    np.testing.assert_allclose(values, core_albedo.sample_layers(drawn.layers, uv),
                               rtol=0, atol=1e-6)


def test_bad_input_is_refused():
    albedo = _albedo(3)
    with pytest.raises(ValueError, match="unknown albedo form 'fast'"):
        drawn_albedo(albedo, "fast")
    huge = albedo.layers.copy()
    huge[0, 0, 0, 0] = 1e6
    with pytest.raises(ValueError, match="1 albedo values exceed half"):
        half_texels(huge)
    bright = core_albedo.AlbedoLayers(huge, albedo.wavelengths, albedo.basis)
    assert drawn_albedo(bright).form in ("basis", "exact")      # Automatic skips half
    with pytest.raises(ValueError, match="exceed half"):
        drawn_albedo(bright, "half")
    nan = albedo.layers.copy()
    nan[1, 2, 3, 1] = np.nan
    with pytest.raises(ValueError, match="1 non-finite"):
        half_texels(nan)
    assert set(ALBEDO_FORMS) == {"auto", "half", "basis", "exact"}
    assert DrawnAlbedo("exact", albedo.layers).texture_format == "RGBA32F"
