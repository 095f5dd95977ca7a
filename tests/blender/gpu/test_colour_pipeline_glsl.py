"""Every stage of glsl/common/colour_pipeline.glsl, drawn offscreen, against colour-science.

A harness shader (params.glsl's ``SmParams`` block, the library's common.glsl and
colour_pipeline.glsl) reads one input value per texel of an RGBA32F texture with
``texelFetch``, applies the stage that ``SM_STAGE`` selects and writes the result to
an RGBA32F offscreen, which is read back. The parameter block is the add-on's own
(``gpu_material.params_block``), so the matrices the shaders get are the ones under
test too. References are colour-science (Bradford Von Kries adaptation, ``XYZ_to_RGB``,
``eotf_inverse_sRGB``) and, for the tone map, which colour-science does not ship,
``core.colour_pipeline.tonemap_sigmoid``.

Tolerances are those of float32 arithmetic: a 3 × 3 product may lose
``~3 ε₃₂ Σ|Mᵢⱼ xⱼ|`` (which is what a matrix stage is held to, per component), an
elementwise stage ``rtol 1e-5 / atol 1e-6``; the sRGB encoding's ``pow`` ``atol 2e-6``.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest

pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

import gpu  # noqa: E402  (importable once bpy is)

from spectral_materials.blender.brdf.gpu_material import (
    DisplaySettings,
    MaterialUniforms,
    float_texture,
    params_block,
)
from spectral_materials.blender.gpu import context as gpu_context
from spectral_materials.blender.gpu.offscreen import Target
from spectral_materials.blender.gpu.shaders import glsl_source
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

EPS32 = float(np.finfo(np.float32).eps)
SIZE = 32                                  # texels a side of every input grid
STAGES = {"adapt": 0, "xyz_to_linear_srgb": 1, "tonemap": 2, "srgb_encode": 3,
          "xyz_to_display": 4}
SRGB = colour.RGB_COLOURSPACES["sRGB"]
D65_XYZ = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
SCENE_WHITES = ("A", "FL2", "D50", "D65")

_FRAGMENT_MAIN = """
void main()
{
  vec3 v = texelFetch(input_tex, ivec2(gl_FragCoord.xy), 0).rgb;
#if SM_STAGE == 0
  vec3 result = sm_adapt(v);
#elif SM_STAGE == 1
  vec3 result = sm_xyz_to_linear_srgb(v);
#elif SM_STAGE == 2
  vec3 result = sm_tonemap(v, sm.display.y);
#elif SM_STAGE == 3
  vec3 result = sm_srgb_encode(v);
#else
  vec3 result = sm_xyz_to_display(v);
#endif
  frag_colour = vec4(result, 1.0);
}
"""

_VERTEX = """
void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
"""

_QUAD = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]], dtype=np.float32)

#: Uniforms of no material: the colour pipeline reads only display, adaptation, xyz_to_rgb.
_DUMMY_AXES = MaterialUniforms(axis_lo=(0.0,) * 4, axis_span=(1.0,) * 4, axis_flags=(0,) * 4,
                               axis_cells=(1,) * 4, edge_rule=1, pack_rows=1)


@pytest.fixture(scope="module")
def harness():
    """``run(stage, values (h, w, 3), display) -> (h, w, 3)``: one stage drawn on the GPU."""
    from gpu_extras.batch import batch_for_shader

    gpu_context.ensure_gpu()
    shaders = {}

    def shader_for(stage: str):
        if stage not in shaders:
            info = gpu.types.GPUShaderCreateInfo()
            info.define("SM_STAGE", str(STAGES[stage]))
            info.typedef_source(glsl_source("brdf/params.glsl"))
            info.uniform_buf(0, "SmParams", "sm")
            info.sampler(0, "FLOAT_2D", "input_tex")
            info.vertex_in(0, "VEC2", "corner")
            info.vertex_source(_VERTEX)
            info.fragment_out(0, "VEC4", "frag_colour")
            info.fragment_source(glsl_source("common/common.glsl") + "\n"
                                 + glsl_source("common/colour_pipeline.glsl") + "\n"
                                 + _FRAGMENT_MAIN)
            shader = gpu.shader.create_from_info(info)
            shaders[stage] = (shader, batch_for_shader(shader, "TRI_FAN", {"corner": _QUAD}))
        return shaders[stage]

    def run(stage: str, values: np.ndarray, display: DisplaySettings) -> np.ndarray:
        values = np.asarray(values, dtype=np.float32)
        height, width = values.shape[:2]
        texels = np.ones((height, width, 4), dtype=np.float32)
        texels[..., :3] = values
        texture = float_texture(np.ascontiguousarray(texels))
        shader, batch = shader_for(stage)
        params = gpu.types.GPUUniformBuf(params_block(_DUMMY_AXES, display))
        with Target(width, height) as target:
            shader.bind()
            shader.uniform_block("sm", params)
            shader.uniform_sampler("input_tex", texture)
            batch.draw(shader)
            out = target.read()
        assert np.all(out[..., 3] == 1.0), "some texel was not drawn"
        return out[..., :3].astype(np.float64)

    return run


def _xyz_grid(seed: int, hi: float = 4.0) -> np.ndarray:
    """(SIZE, SIZE, 3) float32 XYZ: seeded uniform 0..hi, plus edge rows (0, tiny, whites)."""
    rng = np.random.default_rng(seed)
    grid = rng.uniform(0.0, hi, size=(SIZE, SIZE, 3))
    edges = [np.zeros(3), np.full(3, 1e-8), np.full(3, hi), D65_XYZ, D65_XYZ * hi,
             *(colour_pipeline.white_xyz(n, spectra.WAVELENGTHS_REFERENCE) for n in SCENE_WHITES),
             np.array([hi, 0.0, 0.0]), np.array([0.0, hi, 0.0]), np.array([0.0, 0.0, hi])]
    grid[0, : len(edges)] = edges
    return np.ascontiguousarray(grid, dtype=np.float32)


def _scalar_grid(values: np.ndarray) -> np.ndarray:
    """(SIZE, SIZE, 3) float32 from up to SIZE² × 3 scalars, padded by repeating the last."""
    flat = np.asarray(values, dtype=np.float32).ravel()
    count = SIZE * SIZE * 3
    assert flat.size <= count
    flat = np.concatenate([flat, np.full(count - flat.size, flat[-1], np.float32)])
    return np.ascontiguousarray(flat.reshape(SIZE, SIZE, 3))


def _assert_matrix_stage(gpu_out: np.ndarray, reference: np.ndarray, matrix: np.ndarray,
                         xyz: np.ndarray) -> float:
    """GPU ≈ ``reference`` within float32 rounding of ``matrix @ xyz`` (per component)."""
    magnitude = np.abs(xyz.astype(np.float64)) @ np.abs(matrix).T
    bound = 4.0 * EPS32 * magnitude + 1e-6 * np.abs(reference) + 1e-30
    err = np.abs(gpu_out - reference)
    worst = np.unravel_index(np.argmax(err / bound), err.shape)
    assert np.all(err <= bound), (
        f"max |Δ| {err.max():.3g}; worst at {worst[:2]}: input {xyz[worst[:2]]}, "
        f"GPU {gpu_out[worst[:2]]}, reference {reference[worst[:2]]}")
    return float(err.max())


# -- Bradford adaptation --------------------------------------------------------------

@pytest.mark.parametrize("name", SCENE_WHITES)
def test_adapt_matches_colour_bradford(harness, name):
    white = colour_pipeline.white_xyz(name, spectra.WAVELENGTHS_REFERENCE)
    xyz = _xyz_grid(seed=1)
    out = harness("adapt", xyz, DisplaySettings(scene_white=tuple(white)))
    reference = colour.adaptation.chromatic_adaptation_VonKries(
        xyz.astype(np.float64), white, D65_XYZ, transform="Bradford")
    matrix = colour.adaptation.matrix_chromatic_adaptation_VonKries(white, D65_XYZ,
                                                                     transform="Bradford")
    _assert_matrix_stage(out, reference, matrix, xyz)
    # The scene white itself lands on the display white.
    np.testing.assert_allclose(out[0, 5 + SCENE_WHITES.index(name)], D65_XYZ, rtol=1e-6)


def test_adapt_is_identity_under_the_display_white(harness):
    np.testing.assert_allclose(colour_pipeline.DISPLAY_WHITE_XYZ, D65_XYZ, rtol=1e-12)
    xyz = _xyz_grid(seed=2)
    out = harness("adapt", xyz, DisplaySettings(scene_white=tuple(D65_XYZ)))
    np.testing.assert_allclose(out, xyz.astype(np.float64), rtol=2 * EPS32, atol=1e-12)


# -- XYZ → linear sRGB ----------------------------------------------------------------

def test_python_xyz_to_linear_srgb_is_colour_xyz_to_rgb():
    xyz = _xyz_grid(seed=3).astype(np.float64)
    reference = colour.XYZ_to_RGB(xyz, SRGB, illuminant=SRGB.whitepoint,
                                  chromatic_adaptation_transform=None)
    np.testing.assert_allclose(colour_pipeline.xyz_to_linear_srgb(xyz), reference,
                               rtol=1e-12, atol=1e-12)


def test_xyz_to_linear_srgb_matches_colour(harness):
    xyz = _xyz_grid(seed=4)
    out = harness("xyz_to_linear_srgb", xyz, DisplaySettings())
    reference = colour.XYZ_to_RGB(xyz.astype(np.float64), SRGB, illuminant=SRGB.whitepoint,
                                  chromatic_adaptation_transform=None)
    _assert_matrix_stage(out, reference, SRGB.matrix_XYZ_to_RGB, xyz)
    # D65 white → RGB ≈ (1, 1, 1): colour-science ships IEC 61966-2-1's 4-digit matrix,
    # not one derived from the primaries, so neutral is off by up to 1.6e-4.
    np.testing.assert_allclose(out[0, 3], 1.0, rtol=0, atol=2e-4)


# -- tone map -------------------------------------------------------------------------

@pytest.mark.parametrize("white", [1.0, 4.0, 64.0])
def test_tonemap_matches_python(harness, white):
    rng = np.random.default_rng(5)
    edges = np.array([-1e30, -5.0, -1e-3, -0.0, 0.0, 1e-8, 1e-4, 0.5, 1.0, white * 0.999,
                      white, white * 1.001, 2 * white, 100 * white, 1e6, 1e15, 1e30])
    values = np.concatenate([edges, rng.uniform(-1.0, 2.0 * white, 1500),
                             np.exp(rng.uniform(-10.0, 10.0, 1000))])
    grid = _scalar_grid(values)
    out = harness("tonemap", grid, DisplaySettings(tone_white=white))
    assert np.isfinite(out).all()
    reference = colour_pipeline.tonemap_sigmoid(grid.astype(np.float64), white=white)
    np.testing.assert_allclose(out, reference, rtol=1e-5, atol=1e-6)
    flat = out.ravel()
    assert np.all(flat[:4] == 0.0)                   # negatives and −0 → 0
    assert np.all(flat[10:17] == 1.0)                # at and beyond the white → 1


# -- sRGB encoding --------------------------------------------------------------------

def test_srgb_encode_matches_colour(harness):
    rng = np.random.default_rng(6)
    breakpoint_ = 0.0031308
    values = np.concatenate([
        np.linspace(0.0, 1.0, 1025),
        np.linspace(breakpoint_ * 0.99, breakpoint_ * 1.01, 201),
        np.nextafter(np.float32(breakpoint_), np.float32([0.0, 1.0])),
        [breakpoint_, 1e-7, 1e-5, 0.04045 / 12.92],
        rng.uniform(0.0, 1.0, 1000), np.exp(rng.uniform(-14.0, 0.0, 500)),
    ])
    grid = _scalar_grid(values)
    out = harness("srgb_encode", grid, DisplaySettings())
    reference = colour.models.eotf_inverse_sRGB(grid.astype(np.float64))
    np.testing.assert_allclose(out, reference, rtol=0.0, atol=2e-6)
    np.testing.assert_allclose(colour_pipeline.srgb_encode(grid), reference, rtol=0, atol=0)


def test_srgb_encode_clips(harness):
    values = np.array([-1e30, -2.0, -1e-6, -0.0, 1.0, 1.0 + 1e-6, 1.5, 1e30])
    out = harness("srgb_encode", _scalar_grid(values), DisplaySettings()).ravel()
    np.testing.assert_array_equal(out[:4], 0.0)
    np.testing.assert_allclose(out[4:len(values)], 1.0, rtol=0, atol=2e-7)
    assert np.all(out[4:len(values)] <= 1.0 + 2e-7)


# -- the whole pipeline ---------------------------------------------------------------

@pytest.mark.parametrize("exposure", [0.5, 2.0])
@pytest.mark.parametrize("name", ["A", "D65"])
def test_xyz_to_display_matches_colour(harness, name, exposure):
    white = colour_pipeline.white_xyz(name, spectra.WAVELENGTHS_REFERENCE)
    xyz = _xyz_grid(seed=7)
    display = DisplaySettings(scene_white=tuple(white), exposure=exposure, tone_white=4.0)
    out = harness("xyz_to_display", xyz, display)
    x64 = xyz.astype(np.float64)
    reference = colour_pipeline.xyz_to_display(x64, white, exposure=exposure, tonemap_white=4.0)
    # The same chain spelled with colour-science's own functions.
    adapted = colour.adaptation.chromatic_adaptation_VonKries(x64 * exposure, white, D65_XYZ,
                                                              transform="Bradford")
    linear = colour.XYZ_to_RGB(adapted, SRGB, illuminant=SRGB.whitepoint,
                               chromatic_adaptation_transform=None)
    direct = colour.models.eotf_inverse_sRGB(
        np.clip(colour_pipeline.tonemap_sigmoid(linear, white=4.0), 0.0, 1.0))
    np.testing.assert_allclose(reference, direct, rtol=0, atol=1e-12)
    # Float32 error of the linear stages (bounded as in _assert_matrix_stage), amplified by
    # the tone map's slope (≤ 1 + 2x/w² ≤ 1.5 below the white) and the encoding's
    # (12.92 at most), plus the encoding's own 2e-6.
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(white, D65_XYZ,
                                                                  transform="Bradford")
    chain = np.abs(SRGB.matrix_XYZ_to_RGB) @ np.abs(cat)
    linear_bound = 8.0 * EPS32 * (np.abs(x64 * exposure) @ chain.T) + 1e-6 * np.abs(linear)
    bound = 12.92 * 1.5 * linear_bound + 2e-6
    err = np.abs(out - reference)
    assert np.all(err <= bound), f"max |Δ| {err.max():.3g}, worst ratio {(err / bound).max():.3g}"
    assert np.all((out >= 0.0) & (out <= 1.0))


@pytest.mark.parametrize("exposure", [0.5, 2.0])
@pytest.mark.parametrize("name", ["A", "D65"])
def test_xyz_to_display_is_finite_on_extremes(harness, name, exposure):
    white = colour_pipeline.white_xyz(name, spectra.WAVELENGTHS_REFERENCE)
    extremes = [0.0, -0.0, 1e-38, 1e-30, 1.0, 1e10, 1e20, 1e30, -1e30]
    grid = np.array([[a, b, c] for a in extremes for b in extremes for c in extremes])
    xyz = np.zeros((SIZE, SIZE, 3), dtype=np.float32)
    xyz.reshape(-1, 3)[: len(grid)] = grid
    display = DisplaySettings(scene_white=tuple(white), exposure=exposure, tone_white=4.0)
    out = harness("xyz_to_display", np.ascontiguousarray(xyz), display)
    assert np.isfinite(out).all()
    assert np.all((out >= 0.0) & (out <= 1.0))
    np.testing.assert_array_equal(out[0, 0], 0.0)                  # black stays black
    reference = colour_pipeline.xyz_to_display(xyz.astype(np.float64), white,
                                               exposure=exposure, tonemap_white=4.0)
    # Saturated and black channels agree exactly; the rest within the pipeline's rounding.
    np.testing.assert_allclose(out, reference, rtol=0, atol=5e-4)
