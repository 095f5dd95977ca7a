"""Numerically hard cases for the shaders: no NaN/inf, and the same answer as the mirror.

Grazing light, a near-mirror lobe at h ≈ n, lights behind, inside and on the
sphere, a 10⁶ dynamic range, a 48-pack model with signed factors rendered in
float32 against float64, and factor values beyond half float's range (which is
why the factor and light textures are RGBA32F).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gpu_helpers import (
    MAX_DE94,
    PARAMETERIZATIONS,
    SIZE,
    WL,
    check_image,
    compare_lit,
    delta_e,
    lights_pair,
    protocol_pair,
    spd,
)

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import shading
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.lights import SpectralLight

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

HALF_MAX = float(np.finfo(np.float16).max)              # 65504
HALF_TINY = float(np.finfo(np.float16).tiny)            # 6.1e-5, the smallest normal


@pytest.mark.parametrize("parameterization", PARAMETERIZATIONS)
def test_grazing_incidence(factored, parameterization):
    got, reference = protocol_pair(factored(parameterization), 89.9)
    de = compare_lit(got, reference, dark_abs=1e-4)
    print(f"\n{parameterization:>6} 89.9°: max ΔE94 {de:.2e}")


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
@pytest.mark.parametrize("incidence", [0.0, 30.0])
def test_mirror_like_lobe(factored, incidence, precontract):
    """Ashikhmin–Shirley nu = nv = 10⁴ on hd_iso: a spike at h ≈ n (θh → 0, the √ warp)."""
    model = factored("hd_iso", brdf="mirror")
    got, reference = protocol_pair(model, incidence, precontract=precontract)
    assert reference[:, 1].max() > 5.0                   # a bright highlight, not a dull ball
    de = delta_e(reference, got)
    assert de.max() <= MAX_DE94, f"max ΔE94 {de.max():.4g}"
    bright = reference[:, 1] > 1e-3
    relative = np.abs(got[bright] - reference[bright]).max(axis=1) / reference[bright, 1]
    assert relative.max() < 1e-3


def test_light_behind_the_sphere_gives_zeros(factored):
    model = factored("hd")
    behind = SpectralLight("SUN", spd("D65"), WL, 1.0, axis=(0.0, 0.0, 1.0))
    got, reference = lights_pair(model, [behind])
    assert not got.any() and not reference.any()
    # The protocol's sun at 180°: l = (sin π, 0, cos π), a hair off −z.
    got, reference = protocol_pair(model, 180.0)
    assert not got.any() and not reference.any()


def test_point_light_inside_the_sphere_gives_zeros(factored):
    light = SpectralLight("POINT", spd("D65"), WL, 100.0, position=(0.0, 0.0, 0.0))
    got, reference = lights_pair(factored("hd"), [light])    # finite: checked there
    assert not got.any() and not reference.any()


def test_point_light_on_the_surface(factored):
    """A light exactly on a shaded point: that point gets nothing (its direction is
    undefined); every other point sees it below its horizon (a chord runs inside)."""
    model = factored("hd")
    points, _ = shading.sphere_pixels(SIZE)
    on = points[len(points) // 3]
    light = SpectralLight("POINT", spd("D65"), WL, 10.0, position=tuple(on))
    got, reference = lights_pair(model, [light])
    assert not reference.any()
    np.testing.assert_allclose(got, reference, atol=1e-6)
    # Just above the surface: a tiny, extremely bright spot, still finite and the same
    # to float32's precision (the light's offset is 1e-3 of |P|: ~1e-4 relative).
    above = SpectralLight("POINT", spd("D65"), WL, 10.0, position=tuple(on * 1.001))
    got, reference = lights_pair(model, [above])
    lit = reference[:, 1] > 1e-3
    assert 0 < lit.sum() < 20 and reference[:, 1].max() > 1e4
    relative = np.abs(got[lit] - reference[lit]).max(axis=1) / reference[lit, 1]
    assert relative.max() < 1e-3
    assert np.abs(got[~lit] - reference[~lit]).max() < 1e-6


@pytest.mark.parametrize("kind", ["SUN", "POINT"])
def test_huge_dynamic_range(factored, kind):
    model = factored("hd")
    position, axis = (1.5, 1.0, 2.0), (-0.3, -0.2, -1.0)

    def draw(strength):
        light = SpectralLight(kind, spd("D65"), WL, strength, position=position, axis=axis)
        return render_sphere(model, lights=[light], size=SIZE)

    one, huge = draw(1.0), draw(1e6)
    assert np.isfinite(huge).all()
    np.testing.assert_array_equal(huge[..., 3], one[..., 3])
    expected = 1e6 * one[..., :3].astype(np.float64)
    np.testing.assert_allclose(huge[..., :3], expected, rtol=1e-5,
                               atol=1e-5 * np.abs(expected).max())


# ------------------------------------------------------------------ 48 packs, signed

PACKS_48_SHAPE = (16, 32, 16)
TERMS_48 = 192


@pytest.fixture(scope="module")
def model_48() -> FactoredBRDF:
    """48 packs (192 terms) on io_iso with signed angular factors, an 8-vector orthonormal
    basis (its first vector flat, so that spectra are mostly positive) and signed
    spectral coefficients: Y ≈ 0.3–0.6 on the sphere, each pixel a sum of 192 terms."""
    rng = np.random.default_rng(20240048)
    factors = [rng.normal(0.5, 0.5, (n, TERMS_48)) for n in PACKS_48_SHAPE]
    assert all((f < 0).mean() > 0.1 for f in factors)      # really signed
    raw = rng.normal(size=(WL.size, 8))
    raw[:, 0] = 1.0
    q, r = np.linalg.qr(raw)
    basis = q * np.sign(np.diag(r))[None, :]
    spectral = np.empty((8, TERMS_48))
    spectral[0] = rng.uniform(0.5, 1.5, TERMS_48)
    spectral[1:] = 0.1 * rng.normal(size=(7, TERMS_48))
    model = FactoredBRDF("io_iso", PACKS_48_SHAPE, WL.copy(), basis, True,
                         factors=factors, spectral=0.04 * spectral)
    model.validate()
    assert model.packs == 48
    np.testing.assert_allclose(basis.T @ basis, np.eye(8), atol=1e-12)
    return model


@pytest.mark.parametrize("precontract", [True, False], ids=["precontract", "per_coefficient"])
def test_48_signed_packs_float32_against_float64(model_48, precontract):
    worst_de, worst_y = 0.0, 0.0
    for incidence, illuminant in ((0.0, "D65"), (30.0, "A"), (60.0, "FL2"), (80.0, "FL11")):
        got, reference = protocol_pair(model_48, incidence, illuminant, precontract=precontract)
        bright = reference[:, 1] > 1e-3
        assert bright.mean() > 0.5 and 0.1 < reference[:, 1].max() < 2.0
        worst_de = max(worst_de, float(delta_e(reference, got, illuminant).max()))
        relative_y = np.abs(got[bright, 1] - reference[bright, 1]) / reference[bright, 1]
        worst_y = max(worst_y, float(relative_y.max()))
    print(f"\n48 packs {'precontract' if precontract else 'per-coefficient'}: "
          f"max ΔE94 {worst_de:.2e}, max relative Y error {worst_y:.2e}")
    assert worst_de <= MAX_DE94
    assert worst_y < 1e-4


def test_factors_beyond_half_float(model_48):
    """One axis ×1e5, another ×1e-5: the same products, values half float cannot hold
    (above 65504, below its smallest normal), drawn the same within float32 rounding."""
    scaled = replace(model_48, factors=[model_48.factors[0] * 1e5, model_48.factors[1] * 1e-5,
                                        model_48.factors[2]])
    assert np.abs(scaled.factors[0]).max() > HALF_MAX
    assert np.median(np.abs(scaled.factors[1])) < HALF_TINY
    with np.errstate(over="ignore"):
        assert not np.isfinite(scaled.factors[0].astype(np.float16)).all()
    # The mirror sees the same BRDF …
    reference, mask = shading.sphere_xyz(model_48, 30.0, "D65", SIZE)
    moved, _ = shading.sphere_xyz(scaled, 30.0, "D65", SIZE)
    np.testing.assert_allclose(moved, reference, rtol=1e-10, atol=1e-12)
    # … and so does the GPU, to float32 rounding.
    for precontract in (True, False):
        a = render_sphere(model_48, 30.0, "D65", SIZE, precontract=precontract)
        b = render_sphere(scaled, 30.0, "D65", SIZE, precontract=precontract)
        check_image(b, mask)
        scale = np.abs(a[..., :3]).max()
        np.testing.assert_allclose(b[..., :3], a[..., :3], rtol=1e-5, atol=1e-6 * scale)
        assert delta_e(reference[mask], b[mask][:, :3].astype(np.float64)).max() <= MAX_DE94
