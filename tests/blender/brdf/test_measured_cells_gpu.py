"""Models drawn in a measured table's cells (core/brdf/measured_cells.py) by the shaders
(glsl/brdf/measured_cells.glsl) against the float64 mirror, pixel by pixel.

Cells are MERL's and a coarse 9 × 9 × 18 grid whose steps are large: a pixel whose pair
lies within float32 rounding of a cell edge may land in the neighbouring cell on the GPU,
so the bound (the issue's ΔE94 ≤ 0.1) holds on every pixel whose pair is further than
that from an edge, and those edge pixels must be few. Incidences reach 85°,
where cells whose centre is below the horizon take the fill's mean; several lights, a
lobe and a table that is not cosine-weighted are drawn too.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from gpu_helpers import (
    DARK_Y,
    MAX_DE94,
    SIZE,
    WL,
    build_model,
    delta_e,
    four_lights,
    lights_pair,
)

from spectral_materials.blender.brdf.sphere import render_sphere
from spectral_materials.core.brdf import measured_cells, models, shading
from spectral_materials.core.brdf.factor import factor_brdf
from spectral_materials.core.colour import spectra

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

COARSE = (9, 9, 18)
#: The sun and the orthographic view keep θd at half the incidence on every pixel: these
#: put it mid-cell (40° would put every pixel on MERL's θd edge at 20°).
CASES = ((5.0, "D65"), (43.0, "FL2"), (71.0, "A"), (85.0, "FL11"))


@pytest.fixture(scope="module")
def cell_models():
    plain = build_model("io_iso")
    brdf = models.make_model("ashikhmin_shirley", nu=32.0, nv=32.0,
                             diffuse=(WL, spectra.colorchecker(12, WL)), specular=0.05)
    lobe = factor_brdf(brdf, parameterization="io_iso", isotropic=True,
                       resolution=(16, 32, 16), packs=2, spectral_basis=8,
                       lobe="ashikhmin_shirley", cells=measured_cells.MERL_SHAPE)
    return {"merl": replace(plain, cells=measured_cells.MERL_SHAPE),
            "coarse": replace(plain, cells=COARSE),
            "lobe": lobe,
            "uncosined": replace(build_model("io_iso", cosine_weighted=False), cells=COARSE)}


def _sphere(model, incidence: float, illuminant: str) -> tuple[np.ndarray, np.ndarray]:
    image, mask = shading.sphere_xyz(model, incidence, illuminant, SIZE)
    return image[mask], mask


def _pairs(incidence: float, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The local (wi, wo) of the protocol sphere's pixels in ``mask``, as the mirror
    shades them (shading._shade's frame)."""
    points = shading.sphere_pixels(SIZE)[0]
    frame = shading.shading_frame(points, np.zeros_like(points))
    wo = shading.to_local(frame, shading.View().directions(points))
    wi = shading.to_local(frame, shading.protocol_sun(incidence, "D65", WL).incidence(points)[0])
    assert len(points) == mask.sum()
    return wi, wo


def _edge_pixels(wi: np.ndarray, wo: np.ndarray, cells) -> np.ndarray:
    """Pixels whose pair lies within float32 reach of a cell edge: 10⁻³ of a cell on θh
    and θd, and on φd that over sin θd (φd's rounding grows as d nears the pole)."""
    th, _, td, pd = measured_cells._hd_forward(wi, wo)
    n_h, n_d, n_p = cells
    pd = np.mod(pd, 2 * np.pi)
    pd = np.where(pd > np.pi, pd - np.pi, pd)
    u = (np.sqrt(th / (np.pi / 2)) * n_h, td / (np.pi / 2) * n_d, pd / np.pi * n_p)
    margin = (1e-3, 1e-3, 1e-3 / np.maximum(np.sin(td), 1e-3))
    return np.any([np.abs(x - np.round(x)) < m for x, m in zip(u, margin)], axis=0)


def _check_in_cells(model, incidence: float, illuminant: str, what: str) -> np.ndarray:
    """Compare the GPU with the mirror off the cell edges; ΔE94 per pixel."""
    reference, mask = _sphere(model, incidence, illuminant)
    got = render_sphere(model, incidence, illuminant, SIZE)[mask][:, :3].astype(np.float64)
    edge = _edge_pixels(*_pairs(incidence, mask), model.cells)
    lit = reference[:, 1] > DARK_Y
    assert lit.sum() > 300, f"{what}: the sphere is barely lit"
    de = delta_e(reference, got, illuminant)
    off_edge = lit & ~edge
    assert de[off_edge].max() <= MAX_DE94, f"{what}: max ΔE94 {de[off_edge].max():.4g}"
    assert (lit & edge).sum() <= 0.1 * lit.sum(), f"{what}: {(lit & edge).sum()} edge pixels"
    return de


@pytest.mark.parametrize("name", ["merl", "coarse", "lobe", "uncosined"])
def test_cells_match_mirror(cell_models, name):
    for incidence, illuminant in CASES:
        _check_in_cells(cell_models[name], incidence, illuminant,
                        f"{name} {incidence}° {illuminant}")


def test_cells_at_the_retro_pole(cell_models):
    """At normal incidence the protocol sphere's every pair has wi = wo, where φd is not
    defined: both the mirror and the shader take φd = 0 there (directions.spherical and
    sm_spherical's pole rules), and so the same cell, on every pixel."""
    for name in ("merl", "coarse"):
        reference, mask = _sphere(cell_models[name], 0.0, "D65")
        got = render_sphere(cell_models[name], 0.0, "D65", SIZE)[mask][:, :3]
        lit = reference[:, 1] > DARK_Y
        de = delta_e(reference, got.astype(np.float64))
        assert de[lit].max() <= MAX_DE94, f"{name}: max ΔE94 {de[lit].max():.4g}"


def test_the_fill_is_drawn(cell_models):
    """At 85° some lit pixels, off the cell edges, fall in coarse cells whose centre is
    below the horizon, and the GPU draws them as the mirror's fill does."""
    model = cell_models["coarse"]
    reference, mask = _sphere(model, 85.0, "FL11")
    wi, wo = _pairs(85.0, mask)
    th, ph, td, pd = measured_cells._hd_forward(wi, wo)
    ih, idd, ip = measured_cells.cell_indices(th, td, pd, COARSE)
    upper = np.mod(pd, 2 * np.pi) > np.pi
    ci, co = measured_cells._centre_pairs(ih, idd, ip, ph, upper, COARSE)
    hidden = (ci[:, 2] <= 0) | (co[:, 2] <= 0)
    compared = hidden & (reference[:, 1] > DARK_Y) & ~_edge_pixels(wi, wo, COARSE)
    assert compared.sum() > 20, f"only {compared.sum()} compared pixels in filled cells"
    de = _check_in_cells(model, 85.0, "FL11", "coarse fill")
    assert de[compared].max() <= MAX_DE94


def test_cells_change_the_image(cell_models):
    """The cells are drawn: the smooth model gives another image, the mirror follows."""
    coarse = cell_models["coarse"]
    image = render_sphere(coarse, 43.0, "D65", SIZE)
    smooth = render_sphere(replace(coarse, cells=None), 43.0, "D65", SIZE)
    reference, mask = _sphere(replace(coarse, cells=None), 43.0, "D65")
    assert delta_e(image[mask][:, :3], smooth[mask][:, :3]).max() > 5.0
    assert delta_e(reference, smooth[mask][:, :3].astype(np.float64)).max() <= MAX_DE94


def test_cells_under_several_lights(cell_models):
    """Four kinds of light at once take the light-by-light loop (the view's axes are not
    shared across lights in cells)."""
    lights = four_lights()
    got, reference = lights_pair(cell_models["lobe"], lights)
    lit = reference[:, 1] > DARK_Y
    de = delta_e(reference, got)
    # Four lights give four sets of cell edges: the bound holds on 98 % of lit pixels.
    assert np.percentile(de[lit], 98) <= MAX_DE94, f"p98 ΔE94 {np.percentile(de[lit], 98):.4g}"
