"""The ray caster's input checks (see :mod:`.raycast`): the mesh cleaned of degenerate
triangles, the rays checked, and rays grouped by equal direction."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Triangles whose doubled area is at most this fraction of their longest edge squared
#: are degenerate (collinear to double precision) and dropped.
DEGENERATE_RELATIVE_AREA = 1e-12

@dataclass(frozen=True)
class CleanMesh:
    vertices: np.ndarray        # (N, 3) float64, C-contiguous
    triangles: np.ndarray       # (T, 3) int64, no degenerate triangle
    dropped: int                # degenerate triangles removed


def clean_mesh(vertices, triangles) -> CleanMesh:
    """Checked float64 vertices and int64 triangles without zero-area triangles."""
    v = np.ascontiguousarray(vertices, dtype=np.float64)
    if v.size == 0:
        v = v.reshape(0, 3)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"vertices must be (N, 3), got shape {v.shape}")
    if not np.isfinite(v).all():
        raise ValueError("vertices must be finite")
    t = np.asarray(triangles)
    if t.size == 0:
        t = t.reshape(0, 3)
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"triangles must be (T, 3), got shape {t.shape}")
    if t.size and not np.issubdtype(t.dtype, np.integer):
        raise ValueError(f"triangles must hold integer vertex indices, got {t.dtype}")
    t = np.ascontiguousarray(t, dtype=np.int64)
    if t.size and (t.min() < 0 or t.max() >= len(v)):
        raise ValueError(f"triangle indices must be 0..{len(v) - 1}")
    if len(t):
        a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
        e1, e2, e3 = b - a, c - a, c - b
        cross = np.stack([e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
                          e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
                          e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]], axis=1)
        longest = np.max([np.einsum("ij,ij->i", e, e) for e in (e1, e2, e3)], axis=0)
        keep = np.sqrt(np.einsum("ij,ij->i", cross, cross)) > DEGENERATE_RELATIVE_AREA * longest
        dropped = int(len(t) - np.count_nonzero(keep))
        if dropped:
            t = np.ascontiguousarray(t[keep])
    else:
        dropped = 0
    return CleanMesh(v, t, dropped)


def _as_float(values) -> np.ndarray:
    """C-contiguous float32 or float64 (kept as given; anything else becomes float64)."""
    array = np.asarray(values)
    dtype = array.dtype if array.dtype in (np.float32, np.float64) else np.float64
    return np.ascontiguousarray(array, dtype=dtype)


def _check_rays(origins, directions) -> tuple[np.ndarray, np.ndarray]:
    o = _as_float(origins)
    d = _as_float(directions)
    if o.size == 0 and d.size == 0:
        return o.reshape(0, 3), d.reshape(0, 3)
    if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
        raise ValueError(f"origins and directions must both be (R, 3), got {o.shape} "
                         f"and {d.shape}")
    if not (np.isfinite(o).all() and np.isfinite(d).all()):
        raise ValueError("ray origins and directions must be finite")
    return o, d


def group_by_direction(directions: np.ndarray) -> list[np.ndarray]:
    """Ray indices grouped by equal direction (exact duplicates; a lexicographic sort,
    several times faster than ``np.unique(axis=0)``)."""
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    if len(d) == 0:
        return []
    order = np.lexsort((d[:, 2], d[:, 1], d[:, 0]))
    ordered = d[order]
    starts = np.flatnonzero(np.any(ordered[1:] != ordered[:-1], axis=1)) + 1
    return np.split(order, starts)
