"""MERL reading fills invalid samples from their valid neighbours (``fill="neighbours"``).

Checked against the analytic BRDF the file was written from, not against the fill rule:
cells a real file marks −1 (below-horizon centres) and scattered NaN cells, at the θh = 0
edge and across the φd seam; a constant BRDF and a single valid cell, which any mean of
neighbours must reproduce exactly; and the cost on a full-size table.
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np
import pytest

from spectral_materials.core.brdf import models
from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats import merl, merl_fill

SMALL = (4, 3, 6)


def _as_rgb(wi, wo):
    """Ashikhmin–Shirley (nu = nv = 32, Rs = 0.05) with an RGB diffuse colour (linear in Rd)."""
    rd = np.array([0.45, 0.25, 0.08])
    wl = np.array([550.0])
    one = models.make_model("ashikhmin_shirley", nu=32, nv=32, diffuse=1.0, specular=0.05)
    zero = models.make_model("ashikhmin_shirley", nu=32, nv=32, diffuse=0.0, specular=0.05)
    s = zero(wi, wo, wl)
    return (one(wi, wo, wl) - s) * rd + s


def _hemisphere_pairs(n, seed):
    rng = np.random.default_rng(seed)

    def hemi():
        v = rng.normal(size=(n, 3))
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    return hemi(), hemi()


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """A full-size file of the analytic BRDF (−1 at below-horizon centres) and its table."""
    table = merl.merl_table_from_brdf(_as_rgb)
    path = tmp_path_factory.mktemp("merl_fill") / "as.binary"
    merl.write_merl(path, table)
    return path, table


@pytest.fixture(scope="module")
def both(written):
    """The file read with the fill (the default) and with ``fill="zero"``."""
    return merl.read_merl(written[0]), merl.read_merl(written[0], fill="zero")


def test_valid_samples_untouched_and_counts(written, both):
    filled, zero = both
    valid = written[1] >= 0
    assert np.array_equal(filled.table[valid], zero.table[valid])  # bit for bit
    assert not zero.table[~valid].any()
    assert np.isfinite(filled.table).all() and (filled.table > 0).all()
    d = filled.defects
    assert d["fill"] == "neighbours" and zero.defects["fill"] == "zero"
    assert d["filled_samples"] == d["negative"] == (~valid).sum()
    assert d["filled_cells"] == d["invalid_cells"] == (~valid[..., 0]).sum()
    assert 0 < d["fill_passes"] < 200
    assert zero.defects["filled_cells"] == zero.defects["filled_samples"] == 0


def test_below_horizon_cells_close_to_the_model(written, both):
    """Pairs above the horizon whose cell centre is below it (−1 in the file): the filled
    value is far closer to the analytic BRDF than 0 and no worse than the nearest-cell
    lookup itself is at equally grazing pairs whose cells hold measurements."""
    filled, zero = both
    wi, wo = _hemisphere_pairs(300_000, seed=11)
    marked = (written[1][..., 0] < 0).ravel()[filled.cell_index(wi, wo)]
    assert 500 < marked.sum() < 0.02 * marked.size
    truth = _as_rgb(wi[marked], wo[marked])
    err_fill = np.abs(filled.rgb(wi[marked], wo[marked]) - truth).mean()
    err_zero = np.abs(zero.rgb(wi[marked], wo[marked]) - truth).mean()
    assert err_zero == pytest.approx(truth.mean())  # 0 is what fill="zero" gives there
    assert err_fill < 0.2 * err_zero  # about 0.14 with these pairs
    grazing = np.minimum(wi[:, 2], wo[:, 2]).copy()
    near = ~marked & (grazing < grazing[marked].max())
    err_lookup = np.abs(filled.rgb(wi[near], wo[near]) - _as_rgb(wi[near], wo[near])).mean()
    assert err_fill < err_lookup


def _damaged(table, seed=4):
    """``table`` with NaN in scattered valid cells (some in one channel only), the whole
    θh = 0 slab and the first four φd slabs; the mask of what was damaged."""
    rng = np.random.default_rng(seed)
    out = table.copy()
    hit = np.zeros(out.shape, dtype=bool)
    valid = np.flatnonzero(table[..., 0].ravel() >= 0)
    cells = rng.choice(valid, 400, replace=False)
    flat = hit.reshape(-1, 3)
    flat[cells[:200]] = True                        # whole cells
    flat[cells[200:], rng.integers(0, 3, 200)] = True  # one channel
    hit[0] = True                                   # the θh = 0 edge
    hit[:, :, :4] = True                            # φd cells 0–3, beside the seam
    hit &= table >= 0                               # −1 cells stay −1
    out[hit] = np.nan
    return out, hit


def test_nan_cells_close_to_the_model(tmp_path, written):
    """Scattered NaN samples, the θh = 0 edge and the φd seam, read with
    on_invalid="clamp": each filled sample near what the file would have held."""
    damaged, hit = _damaged(written[1])
    path = merl.write_merl(tmp_path / "nan.binary", damaged, allow_invalid=True)
    with pytest.raises(InvalidBRDFData, match="NaN"):
        merl.read_merl(path)
    b = merl.read_merl(path, on_invalid="clamp")
    zero = merl.read_merl(path, on_invalid="clamp", fill="zero")
    assert np.isfinite(b.table).all()
    truth = written[1].astype(np.float32)
    untouched = truth >= 0
    untouched &= ~hit
    assert np.array_equal(b.table[untouched], truth[untouched])  # incl. a NaN cell's others
    assert not zero.table[hit].any()
    rel = np.abs(b.table[hit] - truth[hit]) / truth[hit]
    assert np.median(rel) < 0.02 and np.percentile(rel, 99) < 0.2
    edge = np.zeros_like(hit)
    edge[0] = hit[0]                                 # the θh = 0 edge: from θh[1]
    assert np.median(np.abs(b.table[edge] - truth[edge]) / truth[edge]) < 0.02
    # φd cell 0's only valid neighbour lies across the seam: cell 179 at φd = −0.5° (mod π),
    # which holds the same value by isotropy and reciprocity, f(φd) = f(−φd) = f(φd + π).
    seam = hit[:, :, 0] & ~hit[:, :, 179] & (written[1][:, :, 179] >= 0)
    assert seam.sum() > 10_000
    np.testing.assert_allclose(b.table[:, :, 0][seam], truth[:, :, 0][seam], rtol=1e-6)
    assert b.defects["filled_samples"] == hit.sum() + b.defects["below_horizon_marker"]


def test_constant_brdf_filled_exactly(tmp_path, written):
    """A Lambertian file: every −1 cell reads albedo/π, as the BRDF is there."""
    albedo = np.array([0.62, 0.35, 0.12])
    table = np.where(written[1] < 0, -1.0, albedo / np.pi)
    b = merl.read_merl(merl.write_merl(tmp_path / "lambert.binary", table))
    np.testing.assert_array_equal(b.table, np.broadcast_to(b.table[0, 0, 0], b.table.shape))
    np.testing.assert_allclose(b.table[0, 0, 0], albedo / np.pi, rtol=1e-7)


def test_one_valid_cell_fills_everything(tmp_path):
    table = -np.ones(SMALL + (3,))
    table[3, 2, 5] = [0.1, 0.2, 0.3]  # the far corner: the fill crosses the whole grid
    b = merl._read_merl(merl._write_merl(tmp_path / "one.binary", table, SMALL, False),
                        shape=SMALL)
    np.testing.assert_array_equal(b.table, np.broadcast_to(b.table[3, 2, 5], b.table.shape))
    np.testing.assert_allclose(b.table[3, 2, 5], [0.1, 0.2, 0.3], rtol=1e-7)
    assert b.defects["filled_cells"] == 71 and b.defects["filled_samples"] == 213
    # One valid sample per channel, in different cells: each channel fills from its own.
    table = np.full(SMALL + (3,), np.nan)
    table[0, 0, 0] = [0.5, np.nan, 0.25]
    table[1, 1, 1] = [0.7, 0.125, 0.6]
    b = merl._read_merl(merl._write_merl(tmp_path / "two.binary", table, SMALL, True),
                        shape=SMALL, on_invalid="clamp")
    assert np.isfinite(b.table).all() and (b.table[..., 1] == np.float32(0.125)).all()
    assert b.table[0, 0, 0, 0] == np.float32(0.5) and b.table[1, 1, 1, 0] == np.float32(0.7)


def test_all_invalid_refused_whatever_the_fill(tmp_path):
    for fill in ("neighbours", "zero"):
        path = merl._write_merl(tmp_path / "dead.binary", -np.ones(SMALL + (3,)), SMALL, False)
        with pytest.raises(InvalidBRDFData, match="all 72 cells"):
            merl._read_merl(path, shape=SMALL, fill=fill)
        table = np.full(SMALL + (3,), np.nan)
        table[..., 0] = 1.0  # one channel valid everywhere is not a measurement
        path = merl._write_merl(tmp_path / "nan.binary", table, SMALL, True)
        with pytest.raises(InvalidBRDFData, match="all 72 cells"):
            merl._read_merl(path, shape=SMALL, on_invalid="clamp", fill=fill)
    with pytest.raises(ValueError, match="fill must be one of"):
        merl.read_merl(path, fill="nearest")


def test_full_size_cost_in_proportion(written):
    """The fill of a full table, and the worst case (one valid cell: the fill crosses the
    grid in 268 passes), in seconds (about 0.3 s and 1.1 s alone) and in less extra
    memory than the table itself; reading with the fill peaks no higher than without."""
    table = merl.read_merl(written[0], fill="zero").table
    for invalid in (np.broadcast_to((written[1] < 0)[..., :1], table.shape),
                    np.arange(table.size).reshape(table.shape) // 3 != 0):
        work = table.copy()
        work[invalid] = 0.0
        invalid = np.ascontiguousarray(invalid)
        tracemalloc.start()
        start = time.perf_counter()
        counts = merl_fill.fill_invalid(work, invalid)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert counts["filled_samples"] == invalid.sum()
        assert seconds < 6.0, seconds
        assert peak < table.nbytes, (peak, table.nbytes)
    peaks = {}
    for fill in merl_fill.FILL_RULES:
        tracemalloc.start()
        merl.read_merl(written[0], fill=fill)
        peaks[fill] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peaks["neighbours"] < peaks["zero"] + 0.1 * table.nbytes, peaks
