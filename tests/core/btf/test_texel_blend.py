"""DrawableBTF.texel_blend: texels blend across their edges, so shading is continuous in
the UV (issue 19: no jumps where a float32 UV sits on a texel edge)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.btf import container as btf, render as btf_render
from spectral_materials.core.colour import spectra
from spectral_materials.core.lights import SpectralLight

WL = spectra.WAVELENGTHS_REFERENCE
EPS = btf_render.EDGE_BLEND


def _checker(width=4, height=2):
    """A Lambertian RFP BTF whose texels alternate between albedo 1 and 0.2."""
    views = btf.ring_directions()
    params = np.zeros((len(views), height, width, 8), np.float32)
    params[..., 5] = 1.0                                    # RFP constant term: Y = 1
    basis = np.ones((len(WL), 1)) / np.sqrt(len(WL))
    value = np.where((np.add.outer(np.arange(height), np.arange(width)) % 2) == 0, 1.0, 0.2)
    coefficients = (value * np.sqrt(len(WL)))[..., None].astype(np.float32)
    return btf_render.DrawableBTF("RFP", 0, views, params, coefficients, basis)


def test_hand_values():
    d = _checker()                              # 4 columns, 2 rows: texel width 0.25 in u
    uv = np.array([[0.125, 0.25],               # texel (0, 0) centre: alone
                   [0.25, 0.25],                # on the edge between columns 0 and 1
                   [0.0, 0.0],                  # corner of four, wrapping to column 3, row 1
                   [0.25 * (1 - EPS / 2), 0.25]])   # half-way into column 0's band
    rows, cols, w = d.texel_blend(uv)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-7)
    assert (rows[0, 0], cols[0, 0], w[0, 0]) == (0, 0, 1.0) and not w[0, 1:].any()
    assert (cols[1, 0], cols[1, 1]) == (1, 0)
    np.testing.assert_allclose(w[1, :2], [0.5, 0.5], atol=1e-7)
    assert set(zip(rows[2], cols[2])) == {(0, 0), (0, 3), (1, 0), (1, 3)}
    np.testing.assert_allclose(w[2], 0.25, atol=1e-7)
    assert (cols[3, 0], cols[3, 1]) == (0, 1)
    np.testing.assert_allclose(w[3, :2], [0.75, 0.25], atol=1e-6)


def _shade(d, uv):
    light = SpectralLight("SUN", spectra.illuminant("D65", WL), WL, strength=1.0,
                          axis=(0.0, 0.0, -1.0))
    n = len(uv)
    frames = np.broadcast_to(np.eye(3), (n, 3, 3))
    toward = np.tile([0.0, 0.0, 1.0], (n, 1))
    return d.shade_xyz(uv, frames, np.zeros((n, 3)), toward, [light])[:, 1]


def test_shading_is_continuous_across_an_edge_where_nearest_jumps():
    """One float32 ulp either side of a texel edge: nearest texels differ (albedo 1 against
    0.2, the test's reason to exist), the blended shading by about one ulp's worth."""
    d = _checker()
    edge = np.float32(0.25)
    below, above = np.nextafter(edge, np.float32(0)), np.nextafter(edge, np.float32(1))
    uv = np.array([[below, 0.25], [edge, 0.25], [above, 0.25]], np.float32)
    _, cols = d.texel_of(uv)
    assert cols[0] != cols[2]                         # nearest picks different texels
    y = _shade(d, uv)
    assert np.ptp(y) < 1e-5 * y.max()
    assert y[1] == pytest.approx(0.5 * (1.0 + 0.2), rel=1e-5)


def test_shading_is_continuous_everywhere_on_a_fine_sweep():
    d = _checker()
    u = np.linspace(0.0, 1.0, 20001, dtype=np.float32)
    uv = np.stack([u, np.full_like(u, 0.3)], axis=1)
    y = _shade(d, uv)
    step = float(u[1] - u[0])
    # The steepest slope is across a band: Δalbedo / (2 ε texels) per texel.
    slope = 0.8 / (2 * EPS * 0.25)
    assert np.abs(np.diff(y)).max() <= 1.01 * slope * step
    interior = (np.abs((u * 4) % 1 - 0.5) < 0.5 - EPS - 1e-3)
    np.testing.assert_allclose(y[interior], np.where((np.floor(u[interior] * 4) % 2) == 0,
                                                     1.0, 0.2), rtol=1e-5)


def test_n_dimensional_and_scaled_uv():
    d = _checker()
    uv = np.random.default_rng(3).uniform(-5, 5, (3, 7, 2))
    rows, cols, w = d.texel_blend(uv, scale=(2.0, 3.0))
    assert rows.shape == cols.shape == w.shape == (3, 7, 4)
    assert (rows >= 0).all() and (rows < 2).all() and (cols >= 0).all() and (cols < 4).all()
    np.testing.assert_allclose(w.sum(axis=-1), 1.0, atol=1e-6)
    assert (w >= 0).all()
