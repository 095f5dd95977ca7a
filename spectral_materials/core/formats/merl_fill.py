"""Filling a MERL table's invalid samples from their valid neighbours.

The rule (``fill="neighbours"``, what :func:`~.merl.read_merl` does by default)
------------------------------------------------------------------------------
Each channel is filled on its own: a sample is invalid when the file holds a
negative value there (the −1 below-horizon marker) or, read with
``on_invalid="clamp"``, NaN or ±inf. Per channel rather than per cell because
the file stores each channel as its own plane and damage is per sample: a cell
whose green is NaN keeps its measured red and blue. For the −1 markers, which
real files write in all three channels of a cell, both readings give the same
result.

The fill proceeds in passes. In each pass every still-invalid sample that has
at least one valid face neighbour on the (θh, θd, φd) grid takes the plain mean
of those valid neighbours' values, all computed from the values valid *before*
the pass (so the result does not depend on any visiting order); those samples
then count as valid. Passes repeat until no invalid sample is left: a sample
``d`` grid steps from the nearest valid one is filled in pass ``d``. The
neighbours of cell (i, j, k):

* θh: i ± 1, none beyond 0 or n_θh − 1 (the axis is clamped, as the lookup is);
* θd: j ± 1, likewise clamped;
* φd: (k ± 1) mod n_φd. MERL stores φd over [0, π) because reciprocity makes
  the BRDF π-periodic in φd, so cell n_φd − 1 (just below π) and cell 0 (just
  above 0 ≡ π) are neighbours across the seam.

Samples valid in the file are never written. The filled values are means of
the table's float32 values computed in float64 and stored as float32.

Cost: each pass visits only the samples filled in it and their neighbours, so
the whole fill costs O(invalid samples) time and memory (a few tens of bytes
per invalid sample), however many passes it takes.

``fill="zero"`` keeps the earlier behaviour: invalid samples read as 0.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FILL_RULES", "apply_fill", "check_fill", "fill_invalid"]

#: Fill rules understood by :func:`fill_invalid` (and ``merl.read_merl``'s ``fill``).
FILL_RULES = ("neighbours", "zero")


def check_fill(fill: str) -> str:
    """``fill`` if it names a rule, else ValueError."""
    if fill not in FILL_RULES:
        raise ValueError(f"fill must be one of {FILL_RULES}, got {fill!r}")
    return fill


def _neighbours(cells: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """``(m, 6)`` flat indices of the face neighbours of ``cells``.

    Where a clamped axis ends, the cell itself stands in for the missing
    neighbour: the cell is invalid when this is asked, so it never contributes.
    """
    n_h, n_d, n_p = shape
    rest, k = np.divmod(cells, n_p)
    i, j = np.divmod(rest, n_d)
    base_h, base_d = i * (n_d * n_p), j * n_p
    out = np.empty((cells.size, 6), dtype=np.intp)
    out[:, 0] = np.maximum(i - 1, 0) * (n_d * n_p) + base_d + k
    out[:, 1] = np.minimum(i + 1, n_h - 1) * (n_d * n_p) + base_d + k
    out[:, 2] = base_h + np.maximum(j - 1, 0) * n_p + k
    out[:, 3] = base_h + np.minimum(j + 1, n_d - 1) * n_p + k
    out[:, 4] = base_h + base_d + (k - 1) % n_p
    out[:, 5] = base_h + base_d + (k + 1) % n_p
    return out


def _first_front(invalid: np.ndarray, valid: np.ndarray, shape: tuple[int, int, int],
                 chunk: int = 1 << 16) -> np.ndarray:
    """The invalid samples with a valid neighbour, found a chunk of the grid at a time
    (memory in proportion to the chunk and the front, not to the invalid samples)."""
    parts = []
    for begin in range(0, invalid.size, chunk):
        todo = begin + np.flatnonzero(invalid[begin : begin + chunk])
        parts.append(todo[valid[_neighbours(todo, shape)].any(axis=1)])
    return np.concatenate(parts)


def _fill_channel(values: np.ndarray, invalid: np.ndarray,
                  shape: tuple[int, int, int]) -> int:
    """Fill ``values`` (one channel of the flat table, a view written in place) where
    ``invalid``; the number of passes."""
    valid = ~invalid
    if valid.all() or not valid.any():
        return 0
    front = _first_front(invalid, valid, shape)
    passes = 0
    while front.size:
        near = _neighbours(front, shape)
        usable = valid[near]
        total = np.where(usable, values[near].astype(np.float64), 0.0).sum(axis=1)
        values[front] = total / usable.sum(axis=1)
        valid[front] = True
        passes += 1
        # The next front: the still-invalid neighbours of the samples just filled.
        near = near[~valid[near]]
        front = np.unique(near)
    return passes


def fill_invalid(table: np.ndarray, invalid: np.ndarray) -> dict:
    """Fill the ``invalid`` samples of ``table`` in place by the rule of this module.

    Parameters
    ----------
    table : ndarray (n_θh, n_θd, n_φd, 3), C-contiguous
        The BRDF table; its invalid samples are overwritten, the others untouched.
    invalid : bool ndarray, the same shape
        Which samples to fill. Each channel needs at least one valid sample, or
        it is left as it is.

    Returns
    -------
    dict
        ``filled_samples``, ``filled_cells`` (cells with any sample filled) and
        ``fill_passes`` (the most passes any channel needed).
    """
    if table.shape != invalid.shape or table.ndim != 4 or table.shape[-1] != 3:
        raise ValueError(f"table {table.shape} and invalid {invalid.shape} must both be "
                         "(n_θh, n_θd, n_φd, 3)")
    if not table.flags.c_contiguous:
        raise ValueError("table must be C-contiguous (it is filled in place)")
    shape = tuple(table.shape[:3])
    flat = table.reshape(-1, 3)  # a view: the caller's table is filled
    marks = invalid.reshape(-1, 3)
    filled_samples, passes, done = 0, 0, []
    for c in range(3):
        if marks[:, c].all():
            continue  # nothing to fill from: left as it is
        # The grid is connected: from one valid sample the fill reaches every invalid one.
        passes = max(passes, _fill_channel(flat[:, c], marks[:, c], shape))
        filled_samples += int(marks[:, c].sum())
        done.append(c)
    return {
        "filled_samples": filled_samples,
        "filled_cells": int(marks[:, done].any(axis=1).sum()) if done else 0,
        "fill_passes": passes,
    }


def apply_fill(table: np.ndarray, invalid: np.ndarray, fill: str) -> dict:
    """Replace the ``invalid`` samples of ``table`` (0 so far) by the rule ``fill``; the
    counts for the reader's ``defects``. ``"zero"`` leaves them 0."""
    if check_fill(fill) == "neighbours":
        return {"fill": fill, **fill_invalid(table, invalid)}
    return {"fill": fill, "filled_samples": 0, "filled_cells": 0, "fill_passes": 0}
