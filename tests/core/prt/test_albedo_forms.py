"""The albedo forms spectral PRT draws (core/prt/albedo_forms.py): 16-bit layers over
each component's range, against an encoding done here and the exact layers' colours;
which form Automatic takes; the scene's light in the check; wrap padding; bad input."""

from __future__ import annotations

import numpy as np
import pytest
from albedo_charts import chart_texture

from spectral_materials.core.colour.pipeline import delta_e94, illuminant_spd
from spectral_materials.core.prt import albedo as core_albedo
from spectral_materials.core.prt.albedo_colour import layers_colour_error
from spectral_materials.core.prt.albedo_forms import (
    ALBEDO_FORMS,
    DrawnAlbedo,
    drawn_albedo,
    unorm16_texels,
)

WL = np.arange(400.0, 701.0, 10.0)


def _chart(patch: int = 2) -> np.ndarray:
    return chart_texture(WL, patch)


def _albedo(m: int = 8, rgb: np.ndarray | None = None) -> core_albedo.AlbedoLayers:
    basis = core_albedo.prt_basis(_chart(1).reshape(-1, WL.size), ["FL4"], WL, m)
    if rgb is not None:
        return core_albedo.albedo_layers_from_rgb(rgb, WL, basis)
    return core_albedo.albedo_layers_from_spectra(_chart(), WL, basis)


def _max_de(albedo: core_albedo.AlbedoLayers, drawn: np.ndarray, illuminant: str) -> float:
    """ΔE94 of every texel lit by ``illuminant`` through ``drawn`` against the exact
    layers, computed here from the basis."""
    light = albedo.basis.T @ illuminant_spd(illuminant, WL)
    unit = core_albedo.albedo_layers_from_spectra(np.ones((1, 1, WL.size)), WL, albedo.basis)
    white = light @ unit.layers[:, 0, 0].astype(np.float64)
    exact = np.einsum("j,jhwc->hwc", light, albedo.layers.astype(np.float64))
    approx = np.einsum("j,jhwc->hwc", light, np.asarray(drawn, np.float64))
    return float(delta_e94(exact / white[1], approx / white[1], white / white[1]).max())


def _steps(layers: np.ndarray) -> np.ndarray:
    """The packed layers rounded to 16 bits over each component's range, done here."""
    packed = core_albedo.layers_to_rgba(layers).astype(np.float64)
    low = packed.min(axis=(1, 2), keepdims=True)
    span = packed.max(axis=(1, 2), keepdims=True) - low
    span[span == 0] = 1.0
    return np.round((packed - low) / span * 65535) / 65535 * span + low


@pytest.mark.parametrize("m", [8, 5, 3])
def test_unorm16_texels_are_codes_whose_decoding_is_the_rounded_layers(m):
    albedo = _albedo(m)
    encoded = unorm16_texels(albedo.layers)
    count = core_albedo.packed_layer_count(m)
    assert encoded.texels.shape[0] == count and encoded.low.shape == (count, 4)
    # Every texel is k/65535 (the upload converts it to k exactly), within [0, 1].
    codes = encoded.texels.astype(np.float64) * 65535
    np.testing.assert_allclose(codes, np.round(codes), atol=1e-3)
    assert encoded.texels.min() == 0.0 and encoded.texels.max() == 1.0
    span = encoded.span[:, None, None]
    assert (np.abs(encoded.decoded() - _steps(albedo.layers)) <= span / 65535 * 1.001).all()
    # The range buffer: low then span, per layer.
    np.testing.assert_array_equal(encoded.range_texels()[0::2], encoded.low)
    np.testing.assert_array_equal(encoded.range_texels()[1::2], encoded.span)


@pytest.mark.parametrize("illuminant", ["D65", "FL11", "A", "FL2", "FL4"])
def test_16_bit_layers_keep_the_chart_and_an_rgb_image_far_within_the_bound(illuminant):
    for albedo in (_albedo(), _albedo(rgb=np.random.default_rng(3).random((24, 40, 3)))):
        drawn = drawn_albedo(albedo, "unorm16")
        # Measured 0.004-0.005 (half floats: 0.06-0.09, so they are not a form).
        assert _max_de(albedo, drawn.layers, illuminant) < 0.01
        assert _max_de(albedo, albedo.layers.astype(np.float16), illuminant) > 0.04


def test_automatic_takes_16_bit_layers_and_states_their_error():
    albedo = _albedo()
    drawn = drawn_albedo(albedo)
    assert drawn.form == "unorm16" and drawn.filtered and drawn.texture_format == "RGBA16"
    worst = max(_max_de(albedo, drawn.layers, i) for i in ("D65", "FL11", "A"))
    assert drawn.delta_e94 == pytest.approx(worst, rel=1e-6)
    assert drawn.texels().shape == (6, 8 + 2, 12 + 2, 4)          # wrap-padded


def test_the_scenes_own_light_is_in_the_check():
    albedo = _albedo()
    drawn = drawn_albedo(albedo, "unorm16")
    fl4 = albedo.basis.T @ illuminant_spd("FL4", WL)
    with_fl4 = layers_colour_error(albedo, drawn.layers, lights=(fl4,))
    assert with_fl4 == pytest.approx(max(drawn.delta_e94, _max_de(albedo, drawn.layers, "FL4")),
                                     rel=1e-6)
    assert drawn_albedo(albedo, "unorm16", lights=(fl4,)).delta_e94 == with_fl4
    # A light that does not light a white albedo says nothing; a malformed one is refused.
    assert layers_colour_error(albedo, drawn.layers, lights=(-fl4,)) == drawn.delta_e94
    with pytest.raises(ValueError, match="finite"):
        layers_colour_error(albedo, drawn.layers, lights=(np.full(8, np.nan),))


def test_automatic_falls_back_to_the_basis_then_to_the_exact_layers():
    albedo = _albedo()
    # A bound 16 bits cannot meet: the chart's basis meets it with 16 weights.
    basis = drawn_albedo(albedo, bound=1e-3)
    assert basis.form == "basis" and basis.basis.rank == 16 and basis.delta_e94 <= 1e-3
    np.testing.assert_array_equal(basis.texels(), basis.basis.weights_padded())
    # One nothing meets: the exact layers, unpadded and filtered by hand.
    exact = drawn_albedo(albedo, bound=0.0)
    assert exact.form == "exact" and not exact.filtered and exact.delta_e94 == 0.0
    np.testing.assert_array_equal(exact.texels(), core_albedo.layers_to_rgba(albedo.layers))


def test_forced_forms_are_drawn_whatever_their_error():
    albedo = _albedo()
    unorm = drawn_albedo(albedo, "unorm16", bound=0.0)
    assert unorm.form == "unorm16" and unorm.delta_e94 > 0.0
    assert drawn_albedo(albedo, "exact").form == "exact"
    assert drawn_albedo(albedo, "basis").form == "basis"


def test_filtering_the_padded_texels_equals_repeat_sampling_the_drawn_layers():
    albedo = _albedo(5)
    drawn = drawn_albedo(albedo, "unorm16")
    padded = drawn.texels().astype(np.float64)
    m, h, w, _ = albedo.layers.shape
    uv = np.random.default_rng(4).uniform(-2.0, 2.0, (300, 2))
    mapped = (np.mod(uv, 1.0) * (w, h) + 1.0) / (w + 2, h + 2)
    # A texture unit with clamped coordinates (the padding stands in for REPEAT).
    s, t = mapped[:, 0] * (w + 2) - 0.5, mapped[:, 1] * (h + 2) - 0.5
    i0, j0 = np.floor(s).astype(int), np.floor(t).astype(int)
    fs, ft = (s - i0)[:, None, None], (t - j0)[:, None, None]
    unit = ((1 - fs) * (1 - ft) * padded[:, j0, i0].transpose(1, 0, 2)
            + fs * (1 - ft) * padded[:, j0, i0 + 1].transpose(1, 0, 2)
            + (1 - fs) * ft * padded[:, j0 + 1, i0].transpose(1, 0, 2)
            + fs * ft * padded[:, j0 + 1, i0 + 1].transpose(1, 0, 2))
    decoded = drawn.unorm16.low + drawn.unorm16.span * unit          # the shader's decode
    values = decoded.reshape(len(uv), -1)[:, : 3 * m].reshape(len(uv), m, 3)
    np.testing.assert_allclose(values, core_albedo.sample_layers(drawn.layers, uv),
                               rtol=0, atol=1e-6)


def test_bad_input_is_refused_and_constant_components_decode_exactly():
    albedo = _albedo(3)
    with pytest.raises(ValueError, match="unknown albedo form 'fast'"):
        drawn_albedo(albedo, "fast")
    nan = albedo.layers.copy()
    nan[1, 2, 3, 1] = np.inf
    with pytest.raises(ValueError, match="1 non-finite"):
        unorm16_texels(nan)
    wide = albedo.layers.copy()
    wide[0, 0, 0, 0], wide[0, 0, 1, 0] = 3e38, -3e38          # finite, but no float32 span
    with pytest.raises(ValueError, match="span more than float32"):
        unorm16_texels(wide)
    flat = np.full((3, 4, 4, 3), 0.25, dtype=np.float32)
    encoded = unorm16_texels(flat)
    np.testing.assert_array_equal(encoded.decoded()[:, ..., :1], 0.25)
    assert set(ALBEDO_FORMS) == {"auto", "unorm16", "basis", "exact"}
    assert DrawnAlbedo("exact", albedo.layers).texture_format == "RGBA32F"
