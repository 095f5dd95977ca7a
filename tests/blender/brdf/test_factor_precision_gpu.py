"""The fast factor paths (core/brdf/filtered_factors.py) drawn by the shaders, pixel by
pixel against their float64 mirror, and against the exact path.

llvmpipe filters with float weights: the filtered paths are compared with the mirror
at ``weight_bits=None``; the 8-bit weights a hardware filter uses are the mirror's
default and what the colour-error figures (benchmarks/draw_variants.py) state.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gpu_helpers import SIZE, delta_e

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import shading
from spectral_materials.core.brdf.filtered_factors import (
    FACTOR_PRECISIONS,
    PRECISION_TEXELS,
    drawn_model,
    filtered_factors,
)

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

FAST = [p for p in FACTOR_PRECISIONS if p != "exact"]
CASES = ((0.0, "D65"), (60.0, "FL2"), (80.0, "FL11"))


def _mirror(model, precision):
    encoding, filtered = PRECISION_TEXELS[precision]
    return filtered_factors(model, encoding, None)       # llvmpipe: float filter weights


def _pair(model, precision, incidence, illuminant):
    image = render_sphere(model, incidence, illuminant, SIZE, factors=precision)
    reference, mask = shading.sphere_xyz(_mirror(model, precision), incidence, illuminant, SIZE)
    return image[mask][:, :3].astype(np.float64), reference[mask]


@pytest.mark.parametrize("precision", FAST)
@pytest.mark.parametrize("parameterization", ["io", "io_iso", "hd", "ea"])
def test_fast_paths_match_their_mirror(factored, parameterization, precision):
    model = factored(parameterization)
    for incidence, illuminant in CASES:
        got, reference = _pair(model, precision, incidence, illuminant)
        bright = reference[:, 1] > 1e-3
        assert bright.sum() > 200
        de = delta_e(reference[bright], got[bright], illuminant)
        assert de.max() <= 0.02, f"{incidence}° {illuminant}: max ΔE94 {de.max():.4g}"
        np.testing.assert_allclose(got[~bright], reference[~bright], rtol=1e-4, atol=2e-5)


@pytest.mark.parametrize("edge", ["linear", "clamp", "horizon", "horizons"])
def test_pads_draw_every_edge_rule(factored, edge):
    """At 80° the rim reads the pads: the filtered path follows its mirror there under
    every rule (whose pads the core tests prove equal to the exact lookup's rule), and
    the rule reaches the shader."""
    model = replace(factored("io"), edge=edge)
    got, reference = _pair(model, "unorm16_filtered", 80.0, "FL11")
    bright = reference[:, 1] > 1e-3
    assert bright.sum() > 1000
    assert delta_e(reference[bright], got[bright], "FL11").max() <= 0.02
    other = replace(model, edge="clamp" if edge != "clamp" else "linear")
    a = render_sphere(model, 80.0, "FL11", SIZE, factors="unorm16_filtered")
    b = render_sphere(other, 80.0, "FL11", SIZE, factors="unorm16_filtered")
    assert float(delta_e(a[..., :3], b[..., :3], "FL11").max()) > 1.0


def test_precisions_differ_from_exact_by_what_the_mirror_says(factored):
    """The GPU's exact-to-fast difference is the mirror's, pixel by pixel."""
    model = factored("hd_iso")
    exact_gpu = render_sphere(model, 30.0, "D65", SIZE)[..., :3].astype(np.float64)
    exact_mirror, mask = shading.sphere_xyz(model, 30.0, "D65", SIZE)
    for precision in FAST:
        fast_gpu = render_sphere(model, 30.0, "D65", SIZE, factors=precision)
        fast_mirror, _ = shading.sphere_xyz(_mirror(model, precision), 30.0, "D65", SIZE)
        gpu_change = fast_gpu[..., :3][mask] - exact_gpu[mask]
        mirror_change = fast_mirror[mask] - exact_mirror[mask]
        assert np.abs(mirror_change).max() > 1e-6                   # the paths do differ
        np.testing.assert_allclose(gpu_change, mirror_change, atol=5e-6)


def test_unknown_precision_is_refused(factored):
    with pytest.raises(ValueError, match="factor precision"):
        render_sphere(factored("io"), 0.0, "D65", 8, factors="fp8")


def test_fast_precisions_refuse_the_per_coefficient_mode(factored):
    """That mode reads the spectral factor from the factor texture, which the 16-bit
    paths do not upload."""
    with pytest.raises(ValueError, match="pre-contracted"):
        render_sphere(factored("io"), 0.0, "D65", 8, factors="unorm16", precontract=False)


def test_drawn_model_of_exact_is_the_model(factored):
    model = factored("io")
    assert drawn_model(model, "exact") is model
