"""PRT transfer bake: per-vertex visibility by ray casting, stored on the mesh.

``bake_transfer(obj)`` casts, from every vertex of the evaluated mesh (object space,
offset along its normal), rays along a fixed spherical Fibonacci set of directions
(``core.prt``) against the object's own triangles (self-shadowing only), and projects
``V(ω) max(n·ω, 0)`` onto the given SH basis. ``backend`` picks the ray caster:
"bvhtree" is Blender's ``mathutils.bvhtree`` of the same triangles (one ``ray_cast`` per
ray: the baseline, which needs nothing beyond Blender); "embree", "numpy" (and the slow
"reference") are ``core.raycast`` backends, given the evaluated mesh's loop triangles and
asked in chunks of whole directions; "auto" takes the fastest available
(``core.raycast.AUTO_ORDER``): Embree when the optional ``embreex`` loads, else the
BVHTree baseline (docs/bench_raycast.md). The callback ``callback(fraction, message) ->
stop?`` reports progress and cancels between chunks (``report`` raises ``Cancelled``;
nothing is stored). ``store_transfer`` writes the coefficients as point-domain float
attributes ``sm_prt_00 …`` with a geometry key in the mesh's custom properties, so they
persist in the .blend and are known stale when the mesh changes.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass

import bpy
import numpy as np

from ...core.progress import ProgressCallback, report
from ...core.prt import raycast
from ..gpu.mesh_arrays import (
    corner_vertices,
    evaluated_mesh,
    loop_triangles,
    vertex_normals,
    vertex_positions,
)

ATTRIBUTE_PREFIX = "sm_prt_"
KEY_PROPERTY = "sm_prt_key"
#: Ray origins move this far along the normal, relative to the mesh's bounding-box
#: diagonal, so that a ray does not hit its own vertex's faces.
ORIGIN_OFFSET = 1e-4
#: Backends ``bake_transfer`` accepts: "auto", the BVHTree baseline and core.raycast's.
BACKENDS = ("auto", "bvhtree", *(n for n in raycast.BACKENDS if n != "bvhtree"))
#: Rays per chunk of the core.raycast backends (progress and cancellation in between).
CHUNK_RAYS = 1 << 17


@dataclass
class TransferBake:
    coefficients: np.ndarray          # (vertices, K) float32
    rays: int                         # directions per vertex (all of them; half are culled)
    rays_cast: int
    seconds: float
    key: str
    backend: str                      # the ray caster used ("bvhtree", "embree", "numpy")

    @property
    def rays_per_second(self) -> float:
        return self.rays_cast / max(self.seconds, 1e-9)


def geometry_key(mesh) -> str:
    """A digest of the vertex positions and faces: the transfer is stale when it changes."""
    co = vertex_positions(mesh, np.float64)
    digest = hashlib.sha256(co.astype(np.float32).tobytes())
    digest.update(corner_vertices(mesh).tobytes())
    return digest.hexdigest()[:16]


@dataclass
class MeshGeometry:
    """An evaluated mesh as the bake needs it (plain arrays: safe to hand to a thread)."""

    positions: np.ndarray             # (vertices, 3) object space
    normals: np.ndarray               # (vertices, 3) unit (zero where undefined)
    triangles: np.ndarray             # (T, 3) vertex indices of the loop triangles
    key: str                          # geometry_key of the mesh


@dataclass
class Visibility:
    """Ray-cast visibility of an evaluated mesh's vertices along shared directions."""

    visible: np.ndarray               # (vertices, directions) bool; False below the horizon
    normals: np.ndarray               # (vertices, 3) unit (zero where undefined)
    directions: np.ndarray            # (directions, 3) spherical Fibonacci set
    rays_cast: int
    seconds: float                    # tracing only
    build_seconds: float              # the backend's acceleration structure
    key: str
    backend: str


def unit_normals(normals: np.ndarray) -> np.ndarray:
    """Normals scaled to unit length; zero stays zero (vertices of degenerate faces only,
    whose transfer is then zero)."""
    lengths = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.where(lengths > 0, normals / np.maximum(lengths, 1e-30), 0.0)


def read_geometry(obj, depsgraph=None) -> MeshGeometry:
    """The evaluated mesh of ``obj`` (main thread: it reads ``bpy`` data)."""
    if obj is None or obj.type != "MESH":
        raise ValueError(f"PRT bakes meshes; '{getattr(obj, 'name', obj)}' is not one")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    with evaluated_mesh(obj, depsgraph) as mesh:
        if len(mesh.vertices) == 0 or len(mesh.polygons) == 0:
            raise ValueError(f"Object '{obj.name}' has no faces to bake")
        co = vertex_positions(mesh, np.float64)
        return MeshGeometry(co, unit_normals(vertex_normals(mesh)),
                            loop_triangles(mesh, of="vertices"), geometry_key(mesh))


def trace_geometry(geometry: MeshGeometry, *, rays: int = 256,
                   callback: ProgressCallback | None = None, backend: str = "auto",
                   threads: int | None = None) -> Visibility:
    """Visibility from each vertex of ``geometry`` along ``rays`` directions (never touches
    ``bpy`` data: safe in a worker thread).

    ``backend``: one of :data:`BACKENDS`; a named backend that cannot run here raises
    ``core.raycast.BackendUnavailable``. ``threads``: for the core.raycast backends
    (default: every core this process may use); "bvhtree" runs on one.
    """
    from ...core.prt import transfer as prt

    if backend not in BACKENDS:
        raise ValueError(f"unknown ray-casting backend {backend!r}; choose one of {BACKENDS}")
    # "auto" without Embree is the BVHTree baseline (faster here than core.raycast's
    # "bvhtree", which converts every ray, and than "numpy": docs/bench_raycast.md).
    backend = "bvhtree" if backend == "bvhtree" else raycast.resolve(backend)
    co, normals, triangles = geometry.positions, geometry.normals, geometry.triangles
    directions = prt.fibonacci_directions(rays)
    offset = ORIGIN_OFFSET * float(np.linalg.norm(co.max(axis=0) - co.min(axis=0)) or 1.0)
    origins = co + offset * normals
    start = time.perf_counter()
    if backend == "bvhtree":
        from mathutils.bvhtree import BVHTree

        tree = BVHTree.FromPolygons(co.tolist(), triangles.tolist())
        built = time.perf_counter()
        visible, cast = _trace_bvhtree(tree, origins, normals, directions, callback)
    else:
        occluder = raycast.Occluder(co, triangles, backend=backend, threads=threads)
        built = time.perf_counter()
        above = normals @ directions.T > 0.0                     # (V, R): rays to cast
        visible, cast = _trace_chunks(occluder, origins, directions, above, callback)
    seconds = time.perf_counter() - built
    return Visibility(visible, normals, directions, cast, seconds, built - start,
                      geometry.key, backend)


def trace_visibility(obj, *, rays: int = 256, callback: ProgressCallback | None = None,
                     depsgraph=None, backend: str = "auto",
                     threads: int | None = None) -> Visibility:
    """Visibility of ``obj``'s evaluated mesh: :func:`read_geometry`, then
    :func:`trace_geometry`."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown ray-casting backend {backend!r}; choose one of {BACKENDS}")
    return trace_geometry(read_geometry(obj, depsgraph), rays=rays, callback=callback,
                          backend=backend, threads=threads)


def project_transfer(seen: Visibility, basis: np.ndarray,
                     callback: ProgressCallback | None = None) -> TransferBake:
    """Transfer vectors from visibility; ``basis`` (R, K) holds the basis functions at
    ``seen.directions``."""
    from ...core.prt import transfer as prt

    report(callback, 1.0, "projecting")
    coefficients = prt.transfer_from_visibility(seen.normals, seen.directions, seen.visible,
                                                np.asarray(basis, dtype=np.float64))
    return TransferBake(coefficients.astype(np.float32), len(seen.directions),
                        seen.rays_cast, seen.seconds, seen.key, seen.backend)


def bake_transfer(obj, basis_fn, *, rays: int = 256,
                  callback: ProgressCallback | None = None, depsgraph=None,
                  backend: str = "auto", threads: int | None = None) -> TransferBake:
    """Transfer vectors of ``obj``'s evaluated mesh; ``basis_fn(directions) -> (R, K)``.
    ``backend`` and ``threads`` as for :func:`trace_geometry`."""
    from ...core.prt import transfer as prt

    basis = basis_fn(prt.fibonacci_directions(rays))     # a bad basis fails before tracing
    seen = trace_visibility(obj, rays=rays, callback=callback, depsgraph=depsgraph,
                            backend=backend, threads=threads)
    return project_transfer(seen, basis, callback)


def _trace_bvhtree(tree, origins, normals, directions, callback):
    """The baseline: Blender's BVHTree of the triangles, one ray_cast per ray."""
    from mathutils import Vector

    count, rays = len(origins), len(directions)
    visible = np.zeros((count, rays), dtype=bool)
    vectors = [Vector(d) for d in directions]
    cast = 0
    chunk = max(1, 2000 // max(rays // 64, 1))
    for begin in range(0, count, chunk):
        report(callback, begin / count, f"tracing vertex {begin} of {count} (bvhtree)")
        for v in range(begin, min(begin + chunk, count)):
            origin = Vector(origins[v])
            above = np.flatnonzero(directions @ normals[v] > 0.0)
            cast += len(above)
            row = visible[v]
            for r in above:
                row[r] = tree.ray_cast(origin, vectors[r])[0] is None
    return visible, cast


def _trace_chunks(occluder: raycast.Occluder, origins, directions, above, callback):
    """A core.raycast backend, in chunks of whole directions of about CHUNK_RAYS rays."""
    count, rays = above.shape
    visible = np.zeros((rays, count), dtype=bool)                # transposed while filled
    origins = origins.astype(occluder.dtype)                     # the backend's precision
    directions = directions.astype(occluder.dtype)
    cumulative = np.cumsum(np.count_nonzero(above, axis=0))
    total = int(cumulative[-1])
    done = 0
    begin = 0
    while begin < rays:
        # The most directions whose rays fit in CHUNK_RAYS, at least one.
        end = int(np.searchsorted(cumulative, done + CHUNK_RAYS, side="right"))
        end = min(max(end, begin + 1), rays)
        report(callback, done / max(total, 1),
               f"tracing direction {begin} of {rays} ({occluder.backend})")
        # Direction-major: consecutive rays share a direction (coherent for every backend).
        cast = np.ascontiguousarray(above[:, begin:end].T)
        direction, vertex = np.nonzero(cast)
        hit = occluder.occluded(origins[vertex], directions[direction + begin])
        visible[begin:end][cast] = ~hit               # boolean order = np.nonzero's order
        done += len(vertex)
        begin = end
    return np.ascontiguousarray(visible.T), done


def store_transfer(mesh, bake: TransferBake) -> None:
    """Write the coefficients as point attributes and remember the geometry key."""
    clear_transfer(mesh)
    for k in range(bake.coefficients.shape[1]):
        attribute = mesh.attributes.new(f"{ATTRIBUTE_PREFIX}{k:02d}", "FLOAT", "POINT")
        attribute.data.foreach_set("value", np.ascontiguousarray(bake.coefficients[:, k]))
    mesh[KEY_PROPERTY] = bake.key
    mesh.update_tag()


def transfer_names(mesh) -> list[str]:
    """Names of the stored transfer attributes, in coefficient order."""
    return sorted(a.name for a in mesh.attributes if a.name.startswith(ATTRIBUTE_PREFIX))


def transfer_state(mesh) -> str:
    """"absent", "stale" (the mesh changed since the bake) or "current"."""
    if not transfer_names(mesh):
        return "absent"
    return "current" if mesh.get(KEY_PROPERTY) == geometry_key(mesh) else "stale"


def load_transfer(mesh) -> np.ndarray | None:
    """The stored coefficients (vertices, K), or None when absent or stale."""
    if transfer_state(mesh) != "current":
        return None
    names = transfer_names(mesh)
    out = np.empty((len(mesh.vertices), len(names)), dtype=np.float32)
    for k, name in enumerate(names):
        column = np.empty(len(mesh.vertices), dtype=np.float32)
        mesh.attributes[name].data.foreach_get("value", column)
        out[:, k] = column
    return out


def clear_transfer(mesh) -> None:
    for name in transfer_names(mesh):
        mesh.attributes.remove(mesh.attributes[name])
    if KEY_PROPERTY in mesh:
        del mesh[KEY_PROPERTY]
