"""The protocol sphere drawn by the shaders against the float64 mirror (core/brdf/shading.py).

Every parameterisation, incidences 0–80°, both spectral modes (pre-contracted
light weights and the paper's per-coefficient dot products), the four protocol
illuminants; the issue's bound is max ΔE94 ≤ 0.1 over the sphere.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gpu_helpers import MAX_DE94, PARAMETERIZATIONS, RESOLUTIONS, SIZE, WL, delta_e, protocol_pair

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import models, shading
from spectral_materials.core.brdf.factor import factor_brdf

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

#: (incidence in degrees, illuminant): each illuminant at least once.
CASES = ((0.0, "D65"), (30.0, "A"), (60.0, "FL2"), (80.0, "FL11"))


def _max_de(model, incidence, illuminant, **kw) -> tuple[float, np.ndarray]:
    got, reference = protocol_pair(model, incidence, illuminant, **kw)
    return float(delta_e(reference, got, illuminant).max()), reference


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
@pytest.mark.parametrize("parameterization", PARAMETERIZATIONS)
def test_sphere_matches_mirror(factored, parameterization, precontract):
    model = factored(parameterization)
    figures = {}
    for incidence, illuminant in CASES:
        de, reference = _max_de(model, incidence, illuminant, precontract=precontract)
        assert (reference[:, 1] > 1e-3).sum() > 500, "the sphere is barely lit"
        figures[f"{incidence:g}° {illuminant}"] = de
    mode = "precontract" if precontract else "per-coefficient"
    print(f"\n{parameterization:>6} {mode:>15}: max ΔE94 "
          + ", ".join(f"{k} {v:.2e}" for k, v in figures.items()))
    worst = max(figures, key=figures.get)
    assert figures[worst] <= MAX_DE94, f"{worst}: max ΔE94 {figures[worst]:.4g}"


@pytest.mark.parametrize("illuminant", ["D65", "A", "FL2", "FL11"])
def test_every_illuminant_at_normal_incidence(factored, illuminant):
    de, _ = _max_de(factored("hd"), 0.0, illuminant)
    assert de <= MAX_DE94


@pytest.mark.parametrize("parameterization", ["io", "hd_iso"])
def test_not_cosine_weighted(factored, parameterization):
    """A model of f (not f·cosθi): the shader multiplies by cosθi itself."""
    model = factored(parameterization, cosine_weighted=False)
    assert not model.cosine_weighted
    for incidence, illuminant in CASES:
        for precontract in (True, False):
            de, _ = _max_de(model, incidence, illuminant, precontract=precontract)
            assert de <= MAX_DE94, f"{incidence}° {illuminant} {precontract}: {de:.4g}"


@pytest.mark.parametrize("parameterization", ["io", "hd"])
def test_edge_clamp(factored, parameterization):
    """edge == "clamp" holds the end cells instead of extrapolating; the shader follows."""
    linear = replace(factored(parameterization), edge="linear")
    clamped = replace(linear, edge="clamp")
    change = 0.0
    for incidence, illuminant in CASES:
        de, _ = _max_de(clamped, incidence, illuminant)
        assert de <= MAX_DE94, f"{incidence}°: {de:.4g}"
        # The rule reaches the shader: where a θ lies outside the end cell centres
        # (θo near the rim, θd ≈ 0 at normal incidence) the two images differ.
        a = render_sphere(linear, incidence, illuminant, SIZE)
        b = render_sphere(clamped, incidence, illuminant, SIZE)
        change = max(change, float(delta_e(a[..., :3], b[..., :3], illuminant).max()))
    assert change > 10 * MAX_DE94


#: (edge rule, the rule it replaces, light incidence, least change): "horizon" takes
#: f·cosθi to 0 at θi = 90° (new packs' rule), seen on the rim a light at 80° draws past
#: the last θi centre; "horizons" on θo too, seen on the silhouette.
EDGE_CHANGES = {"horizon": ("linear", 80.0, 10 * MAX_DE94),
                "horizons": ("horizon", 40.0, 2 * MAX_DE94)}


@pytest.mark.parametrize("edge, parameterization", [
    ("horizon", "io"), ("horizon", "io_iso"), ("horizon", "ea"),
    ("horizons", "io"), ("horizons", "io_iso")])
def test_edge_horizon_rules(factored, edge, parameterization):
    """The shader follows the mirror under the rule, and the rule reaches it: the pixels
    past the last cell centre differ from the rule it replaces."""
    model = factored(parameterization)
    assert model.edge == "horizon"
    model = replace(model, edge=edge)
    for incidence, illuminant in CASES:
        de, _ = _max_de(model, incidence, illuminant)
        assert de <= MAX_DE94, f"{incidence}°: {de:.4g}"
    other, incidence, least = EDGE_CHANGES[edge]
    a = render_sphere(model, incidence, "FL11", SIZE)
    b = render_sphere(replace(model, edge=other), incidence, "FL11", SIZE)
    assert float(delta_e(a[..., :3], b[..., :3], "FL11").max()) > least


def test_edge_horizon_without_a_theta_i_axis_is_linear(factored):
    """hd has no θi axis: "horizon" draws exactly what "linear" draws."""
    model = factored("hd")
    a = render_sphere(model, 60.0, "D65", SIZE)
    b = render_sphere(replace(model, edge="linear"), 60.0, "D65", SIZE)
    np.testing.assert_array_equal(a, b)


def test_packs_truncation(factored):
    """Drawing ``packs=1`` of a 4-pack model is drawing ``model.truncated(1)``."""
    model = factored("hd")
    assert model.packs == 4
    first = model.truncated(1)
    for incidence, illuminant in CASES:
        for precontract in (True, False):
            image = render_sphere(model, incidence, illuminant, SIZE, packs=1,
                                  precontract=precontract)
            reference, mask = shading.sphere_xyz(first, incidence, illuminant, SIZE)
            got = image[mask][:, :3].astype(np.float64)
            de = delta_e(reference[mask], got, illuminant)
            assert de.max() <= MAX_DE94, f"{incidence}° {precontract}: {de.max():.4g}"
            scale = np.abs(reference).max()
            np.testing.assert_allclose(got, reference[mask], rtol=0, atol=1e-5 * scale)
    # and truncation changes the picture: the other three packs matter.
    full, mask = shading.sphere_xyz(model, 30.0, "A", SIZE)
    one, _ = shading.sphere_xyz(first, 30.0, "A", SIZE)
    assert delta_e(full[mask], one[mask], "A").max() > 10 * MAX_DE94


def test_packs_beyond_the_model_draw_everything(factored):
    model = factored("io_iso")
    a = render_sphere(model, 30.0, "D65", SIZE)
    b = render_sphere(model, 30.0, "D65", SIZE, packs=99)
    np.testing.assert_array_equal(a, b)


def test_packs_truncation_with_pack_size_3():
    """A known mismatch, kept visible: with pack_size 3, packs=2 draws 8 terms, not 6."""
    brdf = models.make_model("ashikhmin_shirley", nu=32.0, nv=32.0, diffuse=0.4)
    model = factor_brdf(brdf, parameterization="hd_iso", resolution=RESOLUTIONS["hd_iso"],
                        packs=3, pack_size=3, spectral_basis=8, wavelengths=WL)
    image = render_sphere(model, 30.0, "A", SIZE, packs=2)                  # 6 terms
    reference, mask = shading.sphere_xyz(model.truncated(2), 30.0, "A", SIZE)
    de = delta_e(reference[mask], image[mask][:, :3].astype(np.float64), "A")
    assert de.max() <= MAX_DE94


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
def test_light_rows_in_a_texture_draw_what_the_uniform_buffer_draws(factored, monkeypatch,
                                                                     precontract):
    """Light rows that fit 16 KiB go in the uniform buffer ``sm_lights``; larger ones stay
    in the light texture. Both hold the same float32 rows: the images agree to float32
    rounding (two compiled programs need not round alike; llvmpipe's are identical)."""
    from spectral_materials.blender.brdf import gpu_material

    model = factored("io_iso")
    material = gpu_material.GPUMaterial(model)
    lights = [shading.protocol_sun(30.0, "A", model.wavelengths)]
    assert material.key(lights, precontract=precontract).light_stride > 0
    buffered = render_sphere(model, 30.0, "A", SIZE, precontract=precontract)
    monkeypatch.setattr(gpu_material, "MAX_LIGHT_BUFFER_TEXELS", 0)
    assert material.key(lights, precontract=precontract).light_stride == 0
    textured = render_sphere(model, 30.0, "A", SIZE, precontract=precontract)
    np.testing.assert_allclose(buffered, textured, rtol=1e-6, atol=1e-7)
    reference, mask = shading.sphere_xyz(model, 30.0, "A", SIZE)
    assert delta_e(reference[mask], textured[mask][:, :3].astype(np.float64), "A").max() \
        <= MAX_DE94


def test_a_key_whose_light_rows_overflow_the_buffer_is_refused():
    from spectral_materials.blender.gpu.shaders import MAX_LIGHT_BUFFER_TEXELS, ShaderKey

    key = ShaderKey("io_iso", 3, 4, 8, 8, frozenset({"SUN"}), light_stride=15)
    key.validate()
    too_many = ShaderKey("io_iso", 3, 48, 8, 8, frozenset({"SUN"}),
                         light_stride=MAX_LIGHT_BUFFER_TEXELS // 8 + 1)
    with pytest.raises(ValueError, match="exceed the uniform buffer"):
        too_many.validate()
    # 3 header texels + 3 per pack: 4 packs need 15; 14 would read into the next row.
    short = ShaderKey("io_iso", 3, 4, 8, 2, frozenset({"SUN"}), light_stride=14)
    with pytest.raises(ValueError, match="shorter than the 15"):
        short.validate()
    per_coefficient = ShaderKey("io_iso", 3, 4, 8, 2, frozenset({"SUN"}), precontract=False,
                                light_stride=11)
    per_coefficient.validate()                               # 3 + 8 coefficients
