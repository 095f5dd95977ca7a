"""Occlusion rays against a triangle mesh, with interchangeable backends.

``occluded(vertices, triangles, origins, directions)`` says, per ray, whether the ray
meets any triangle at a distance ``t > 0`` (no far limit, both faces count). Origins are
used as given: offsetting them off the surface they start on is the caller's job. A ray
that *starts on* a triangle (``t = 0`` exactly) is left unspecified: backends differ.
:class:`Occluder` prepares a mesh once for many queries (the PRT bake asks in chunks).

Backends, in the order ``backend="auto"`` tries them (fastest first, as measured by
``scripts/bench_raycast.py`` on the PRT bake's rays, docs/bench_raycast.md):

``embree``
    Intel Embree 4 through ``embreex`` (optional: imported lazily; "auto" skips it when
    it is missing or fails to load). float32; queries run on ``threads`` threads (embreex
    releases the GIL). 4.9–5.3× the bake's BVHTree rays/s on one thread
    (docs/bench_raycast.md).
``bvhtree``
    Blender's ``mathutils.bvhtree.BVHTree`` (float32), one ``ray_cast`` per ray from
    Python; only where ``mathutils`` imports (inside Blender, or once the ``bpy`` module
    is imported). Holds the GIL. (The bake's own BVHTree path, ``blender.bake``, reuses
    its Vectors and is about twice as fast as this generic one.)
``numpy``
    Pure NumPy, for *coherent* rays, many of which share a direction (the PRT bake casts
    the same direction set from every vertex). Per distinct direction, the mesh and the
    origins are projected orthographically along it; origins are binned into a uniform 2D
    grid, every triangle is paired with the origins in the cells its projected bounding
    box covers, and each pair is an exact 2D point-in-triangle test plus a depth test
    (the same predicate as Möller–Trumbore, evaluated in that frame), in float64.
    Directions are spread over ``threads`` threads (NumPy releases the GIL in its loops);
    directions with fewer than :data:`SMALL_GROUP` rays go through the brute-force
    reference instead. Measured at 0.4–0.6× the bake's BVHTree rays/s on one thread and
    0.5–0.7× on two, relatively slower on larger meshes: it does not beat BVHTree, and is
    here as the fallback that needs neither Blender nor a compiled package.
``reference``
    Brute-force Möller–Trumbore in float64 over every (ray, triangle) pair, O(R·T): the
    tests' reference; "auto" never picks it.

Triangles of zero area (repeated vertices, collinear corners: :func:`clean_mesh`) are
dropped before any backend sees them, so no backend has to handle them; a mesh left with
no triangles occludes nothing. Rays with a zero direction are never occluded.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .raycast_input import (  # noqa: F401  (re-exported: importable from here as before)
    DEGENERATE_RELATIVE_AREA,
    CleanMesh,
    _as_float,
    _check_rays,
    clean_mesh,
    group_by_direction,
)

#: Directions with fewer rays than this skip the ``numpy`` grid (brute force instead).
SMALL_GROUP = 8
#: The ``numpy`` grid: cell side = this × mean projected triangle extent (0.35–0.5 did
#: best on Suzanne with 2 subdivision levels when tuned), but at most CELLS_PER_ORIGIN
#: cells per origin, and at most SLAB_ORIGINS origins per grid (more: slabs along x).
CELL_FACTOR = 0.4
CELLS_PER_ORIGIN = 4
SLAB_ORIGINS = 1 << 15
#: Largest (ray, triangle) or (triangle, cell) batch held at once (bounds the memory).
PAIR_BUDGET = 1 << 22
#: Rays per embree call (a thread's unit of work).
EMBREE_CHUNK = 1 << 14


class BackendUnavailable(RuntimeError):
    """The backend asked for by name cannot run here (its module is missing)."""


Query = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Backend:
    """A registered backend: ``build(vertices, triangles, threads) -> query``, where
    ``query(origins, directions) -> occluded`` takes C-contiguous (R, 3) float32 or float64
    arrays with no zero direction, and the mesh is already clean (:func:`clean_mesh`, at
    least 1 triangle). ``dtype``: the precision it computes in (callers that build many
    rays can hand it that type and save a conversion)."""

    name: str
    summary: str
    available: Callable[[], bool]
    build: Callable[[np.ndarray, np.ndarray, int], Query]
    auto: bool = True
    dtype: type = np.float64


BACKENDS: dict[str, Backend] = {}
#: "auto"'s preference, fastest first (docs/bench_raycast.md).
AUTO_ORDER = ("embree", "bvhtree", "numpy")


def register(backend: Backend) -> None:
    BACKENDS[backend.name] = backend


def available() -> list[str]:
    """Names of the registered backends that can run here, in registration order."""
    return [name for name, b in BACKENDS.items() if b.available()]


def resolve(backend: str = "auto") -> str:
    """The backend that ``backend`` names: itself, or for "auto" the first available in
    :data:`AUTO_ORDER`."""
    if backend == "auto":
        for name in AUTO_ORDER:
            if name in BACKENDS and BACKENDS[name].auto and BACKENDS[name].available():
                return name
        raise BackendUnavailable("no ray-casting backend is available")  # numpy always is
    if backend not in BACKENDS:
        raise ValueError(f"unknown ray-casting backend {backend!r}; "
                         f"choose 'auto' or one of {sorted(BACKENDS)}")
    if not BACKENDS[backend].available():
        raise BackendUnavailable(f"ray-casting backend {backend!r} is not available here "
                                 f"({BACKENDS[backend].summary}); available: {available()}")
    return backend


def default_threads() -> int:
    """The CPU cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:                      # macOS, Windows
        return max(1, os.cpu_count() or 1)


# --------------------------------------------------------------------- the API


class Occluder:
    """A mesh prepared once for occlusion queries by one backend."""

    def __init__(self, vertices, triangles, *, backend: str = "auto",
                 threads: int | None = None):
        self.mesh = clean_mesh(vertices, triangles)
        self.backend = resolve(backend)
        self.threads = max(1, int(threads)) if threads else default_threads()
        self.dtype = BACKENDS[self.backend].dtype
        self._query: Query | None = None
        if len(self.mesh.triangles):
            self._query = BACKENDS[self.backend].build(self.mesh.vertices,
                                                       self.mesh.triangles, self.threads)

    def occluded(self, origins, directions) -> np.ndarray:
        """bool (R,): does ray r meet a triangle at t > 0?"""
        o, d = _check_rays(origins, directions)
        out = np.zeros(len(o), dtype=bool)
        if self._query is None or len(o) == 0:
            return out
        live = np.any(d != 0.0, axis=1)
        if live.all():
            out[:] = self._query(o, d)
        elif live.any():
            out[live] = self._query(np.ascontiguousarray(o[live]),
                                    np.ascontiguousarray(d[live]))
        return out

    __call__ = occluded


def prepare(vertices, triangles, *, backend: str = "auto",
            threads: int | None = None) -> Occluder:
    """An :class:`Occluder`: the mesh checked and built once for ``backend``."""
    return Occluder(vertices, triangles, backend=backend, threads=threads)


def occluded(vertices, triangles, origins, directions, *, backend: str = "auto",
             threads: int | None = None) -> np.ndarray:
    """bool (R,): whether each ray (origins (R, 3), directions (R, 3)) meets a triangle of
    the mesh (vertices (N, 3), triangles (T, 3) int) at t > 0. ``backend``: "auto" (the
    fastest available, :data:`AUTO_ORDER`) or a name in :data:`BACKENDS`; ``threads``:
    for the backends that use them (default: every core this process may use)."""
    o, d = _check_rays(origins, directions)
    return Occluder(vertices, triangles, backend=backend, threads=threads).occluded(o, d)


# ------------------------------------------------------------ reference backend


def _moller_trumbore(vertices: np.ndarray, triangles: np.ndarray, origins: np.ndarray,
                     directions: np.ndarray) -> np.ndarray:
    """Brute force over every (ray, triangle) pair, float64, edges inclusive."""
    a = vertices[triangles[:, 0]]
    e1 = vertices[triangles[:, 1]] - a
    e2 = vertices[triangles[:, 2]] - a
    out = np.zeros(len(origins), dtype=bool)
    step = max(1, PAIR_BUDGET // (8 * max(len(triangles), 1)))
    for begin in range(0, len(origins), step):
        d = directions[begin:begin + step, None, :]
        s = origins[begin:begin + step, None, :] - a[None]
        p = np.cross(d, e2[None])
        det = np.einsum("rtk,tk->rt", p, e1)
        ok = det != 0.0
        inv = 1.0 / np.where(ok, det, 1.0)
        u = np.einsum("rtk,rtk->rt", s, p) * inv
        q = np.cross(s, e1[None])
        v = np.einsum("rtk,rtk->rt", np.broadcast_to(d, q.shape), q) * inv
        t = np.einsum("rtk,tk->rt", q, e2) * inv
        hit = ok & (u >= 0.0) & (v >= 0.0) & (u + v <= 1.0) & (t > 0.0)
        out[begin:begin + step] = hit.any(axis=1)
    return out


def _reference_build(vertices, triangles, threads) -> Query:
    return lambda o, d: _moller_trumbore(vertices, triangles, o, d)


register(Backend("reference", "brute-force Möller–Trumbore, NumPy float64, O(rays × "
                              "triangles)", lambda: True, _reference_build, auto=False))


# ---------------------------------------------------------------- numpy backend


def _frame(direction: np.ndarray) -> np.ndarray:
    """(3, 3) with columns u, w, d̂: an orthonormal frame whose third axis is d̂
    (Duff et al. 2017, "Building an orthonormal basis, revisited")."""
    x, y, z = (float(c) for c in direction)
    length = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / length, y / length, z / length
    sign = math.copysign(1.0, z)
    a = -1.0 / (sign + z)
    b = x * y * a
    return np.array([[1.0 + sign * x * x * a, b, x],
                     [sign * b, sign + y * y * a, y],
                     [-sign * x, -y, z]])


def _expand(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For items grouped by owner (``counts`` per owner): (owner, rank within owner)."""
    owner = np.repeat(np.arange(len(counts)), counts)
    rank = np.arange(len(owner)) - np.repeat(np.cumsum(counts) - counts, counts)
    return owner, rank


def _cell_pairs(t: np.ndarray, first: np.ndarray, cnt: np.ndarray, order: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """(triangle, origin) pairs: the j-th origin of every cell holding more than j, for
    (triangle ``t``, cell whose origins start at ``first`` and number ``cnt``) entries."""
    pt, po, live, j = [], [], np.arange(len(t)), 0
    while len(live):
        pt.append(t[live])
        po.append(order[first[live] + j])
        j += 1
        live = live[cnt[live] > j]
    return np.concatenate(pt), np.concatenate(po)


def _hit_origins(tri: tuple, pt: np.ndarray, po: np.ndarray, qx: np.ndarray,
                 qy: np.ndarray, qz: np.ndarray) -> np.ndarray:
    """The origins of the (triangle ``pt``, origin ``po``) pairs whose triangle covers the
    origin in the projected frame and lies ahead of it along d̂."""
    ax, ay, az, bx, by, bz, cx, cy, cz, sign = tri
    # Edge functions (inside ≥ 0 for either winding), dropping pairs as they fail.
    px, py = qx[po], qy[po]
    e0 = ((bx[pt] - px) * (cy[pt] - py) - (by[pt] - py) * (cx[pt] - px)) * sign[pt]
    ok = np.flatnonzero(e0 >= 0.0)
    pt, po, px, py, e0 = pt[ok], po[ok], px[ok], py[ok], e0[ok]
    e1 = ((cx[pt] - px) * (ay[pt] - py) - (cy[pt] - py) * (ax[pt] - px)) * sign[pt]
    ok = np.flatnonzero(e1 >= 0.0)
    pt, po, px, py, e0, e1 = pt[ok], po[ok], px[ok], py[ok], e0[ok], e1[ok]
    e2 = ((ax[pt] - px) * (by[pt] - py) - (ay[pt] - py) * (bx[pt] - px)) * sign[pt]
    ok = np.flatnonzero(e2 >= 0.0)
    pt, po, e0, e1, e2 = pt[ok], po[ok], e0[ok], e1[ok], e2[ok]
    # Depth of the hit along d̂ (barycentric), ahead of the origin: t > 0.
    depth = (e0 * az[pt] + e1 * bz[pt] + e2 * cz[pt]) / (e0 + e1 + e2)
    return po[depth > qz[po]]


def _grid_test(tri: tuple, qx: np.ndarray, qy: np.ndarray, qz: np.ndarray) -> np.ndarray:
    """Occlusion of the origins (qx, qy, qz) in a projected frame by the projected
    triangles ``tri`` = (ax, ay, az, bx, by, bz, cx, cy, cz, sign of doubled area)."""
    ax, ay, az, bx, by, bz, cx, cy, cz, sign = tri
    n = len(qx)
    out = np.zeros(n, dtype=bool)
    x0, x1, y0, y1 = qx.min(), qx.max(), qy.min(), qy.max()
    lox = np.minimum(np.minimum(ax, bx), cx)
    hix = np.maximum(np.maximum(ax, bx), cx)
    loy = np.minimum(np.minimum(ay, by), cy)
    hiy = np.maximum(np.maximum(ay, by), cy)
    keep = np.flatnonzero((hix >= x0) & (lox <= x1) & (hiy >= y0) & (loy <= y1))
    if len(keep) == 0:
        return out
    ax, ay, az, bx, by, bz, cx, cy, cz, sign, lox, hix, loy, hiy = (
        v[keep] for v in (ax, ay, az, bx, by, bz, cx, cy, cz, sign, lox, hix, loy, hiy))
    size = CELL_FACTOR * float(np.mean(np.maximum(hix - lox, hiy - loy)))
    size = max(size, math.sqrt((x1 - x0) * (y1 - y0) / (CELLS_PER_ORIGIN * n)),
               max(x1 - x0, y1 - y0) / (CELLS_PER_ORIGIN * n), 1e-300)
    nx = int((x1 - x0) / size) + 1
    ny = int((y1 - y0) / size) + 1
    # Origins sorted by cell: cell c holds order[start[c] : start[c] + count[c]].
    ocell = (np.minimum(((qx - x0) / size).astype(np.int64), nx - 1) * ny
             + np.minimum(((qy - y0) / size).astype(np.int64), ny - 1))
    order = np.argsort(ocell, kind="stable")
    count = np.bincount(ocell, minlength=nx * ny)
    start = np.cumsum(count) - count
    c0x = np.clip(((lox - x0) / size).astype(np.int64), 0, nx - 1)
    c1x = np.clip(((hix - x0) / size).astype(np.int64), 0, nx - 1)
    c0y = np.clip(((loy - y0) / size).astype(np.int64), 0, ny - 1)
    c1y = np.clip(((hiy - y0) / size).astype(np.int64), 0, ny - 1)
    height = c1y - c0y + 1
    cells = (c1x - c0x + 1) * height
    kept = (ax, ay, az, bx, by, bz, cx, cy, cz, sign)
    # Triangles in batches of at most PAIR_BUDGET (triangle, cell) entries.
    ends = np.cumsum(cells)
    cuts = np.searchsorted(ends, np.arange(PAIR_BUDGET, int(ends[-1]), PAIR_BUDGET))
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, len(cells)]):
        if hi <= lo:
            continue
        t, k = _expand(cells[lo:hi])
        t += lo
        kx, ky = np.divmod(k, height[t])
        cell = (c0x[t] + kx) * ny + (c0y[t] + ky)
        cnt = count[cell]
        nonempty = np.flatnonzero(cnt)
        t, first, cnt = t[nonempty], start[cell[nonempty]], cnt[nonempty]
        pt, po = _cell_pairs(t, first, cnt, order)
        out[_hit_origins(kept, pt, po, qx, qy, qz)] = True
    return out


def _occluded_along(vertices: np.ndarray, triangles: np.ndarray, origins: np.ndarray,
                    direction: np.ndarray) -> np.ndarray:
    """Occlusion of rays from ``origins`` (n, 3) all along ``direction``."""
    frame = _frame(direction)
    pv = np.ascontiguousarray((vertices @ frame).T)
    po = np.ascontiguousarray((origins @ frame).T)
    qx, qy, qz = po
    corners = [pv[:, triangles[:, i]] for i in range(3)]     # each (3, T): x, y, depth
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = corners
    area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    # Edge-on triangles (the ray runs in their plane) and those wholly behind every
    # origin cannot be hit.
    front = np.maximum(np.maximum(az, bz), cz) > qz.min()
    keep = np.flatnonzero((area != 0.0) & front)
    out = np.zeros(len(origins), dtype=bool)
    if len(keep) == 0:
        return out
    tri = tuple(v[keep] for v in (ax, ay, az, bx, by, bz, cx, cy, cz, np.sign(area)))
    if len(origins) <= SLAB_ORIGINS:
        return _grid_test(tri, qx, qy, qz)
    by_x = np.argsort(qx, kind="stable")
    for begin in range(0, len(by_x), SLAB_ORIGINS):
        index = by_x[begin:begin + SLAB_ORIGINS]
        out[index] = _grid_test(tri, qx[index], qy[index], qz[index])
    return out


def _numpy_build(vertices, triangles, threads) -> Query:
    def query(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        groups = group_by_direction(directions)
        out = np.zeros(len(origins), dtype=bool)
        small = [g for g in groups if len(g) < SMALL_GROUP]
        if small:
            rays = np.concatenate(small)
            out[rays] = _moller_trumbore(vertices, triangles, origins[rays], directions[rays])
        large = [g for g in groups if len(g) >= SMALL_GROUP]

        def one(group: np.ndarray) -> np.ndarray:
            return _occluded_along(vertices, triangles, origins[group],
                                   directions[group[0]])

        if threads > 1 and len(large) > 1:
            with ThreadPoolExecutor(min(threads, len(large))) as pool:
                results = list(pool.map(one, large))
        else:
            results = [one(g) for g in large]
        for group, hit in zip(large, results):
            out[group] = hit
        return out

    return query


register(Backend("numpy", "pure NumPy projected grid per shared direction, float64",
                 lambda: True, _numpy_build))


# ---------------------------------------------------------------- embree backend


@functools.cache
def _embree():
    """(rtcore_scene, mesh_construction) of embreex, or None when it cannot load."""
    try:
        from embreex import mesh_construction, rtcore_scene
    except Exception:               # ImportError, or OSError from a library that won't load
        return None
    return rtcore_scene, mesh_construction


def embree_version() -> str | None:
    """"embreex X (Embree Y)" when embreex loads, else None."""
    modules = _embree()
    if modules is None:
        return None
    from importlib.metadata import PackageNotFoundError, version

    from embreex import rtcore

    try:
        package = version("embreex")
    except PackageNotFoundError:
        package = "?"
    return f"embreex {package} ({repr(rtcore.EmbreeDevice()).split(':')[-1].strip()})"


def _embree_build(vertices, triangles, threads) -> Query:
    rtcore_scene, mesh_construction = _embree()
    scene = rtcore_scene.EmbreeScene()
    mesh_construction.TriangleMesh(scene, np.ascontiguousarray(vertices, dtype=np.float32),
                                   np.ascontiguousarray(triangles, dtype=np.int32))
    # The first query commits the scene (builds the BVH); do it before any threads.
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), query="OCCLUDED")

    def run(o: np.ndarray, d: np.ndarray) -> np.ndarray:
        return scene.run(o, d, query="OCCLUDED") == 0

    def query(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        o = np.ascontiguousarray(origins, dtype=np.float32)
        d = np.ascontiguousarray(directions, dtype=np.float32)
        if threads == 1 or len(o) <= EMBREE_CHUNK:
            return run(o, d)
        step = max(EMBREE_CHUNK, -(-len(o) // (4 * threads)))
        spans = [slice(b, b + step) for b in range(0, len(o), step)]
        with ThreadPoolExecutor(min(threads, len(spans))) as pool:
            return np.concatenate(list(pool.map(lambda s: run(o[s], d[s]), spans)))

    return query


register(Backend("embree", "Intel Embree 4 via the optional embreex package, float32",
                 lambda: _embree() is not None, _embree_build, dtype=np.float32))


# --------------------------------------------------------------- bvhtree backend


def _mathutils_bvhtree():
    try:
        from mathutils.bvhtree import BVHTree
    except ImportError:
        return None
    return BVHTree


def _bvhtree_build(vertices, triangles, threads) -> Query:
    tree = _mathutils_bvhtree().FromPolygons(vertices.tolist(), triangles.tolist(),
                                             all_triangles=True)

    def query(origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        cast = tree.ray_cast
        return np.fromiter((cast(o, d)[0] is not None for o, d in zip(origins, directions)),
                           dtype=bool, count=len(origins))

    return query


register(Backend("bvhtree", "Blender's mathutils.bvhtree.BVHTree, one ray_cast per ray, "
                            "float32 (needs mathutils)",
                 lambda: _mathutils_bvhtree() is not None, _bvhtree_build, dtype=np.float32))
