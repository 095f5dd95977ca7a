"""PRT transfer bake: per-vertex visibility by ray casting, stored on the mesh.

``bake_transfer(obj)`` casts, from every vertex of the evaluated mesh (object space,
offset along its normal), rays along a fixed spherical Fibonacci set of directions
(``core.prt``) against the object's own BVH (``mathutils.bvhtree``: self-shadowing
only), and projects ``V(ω) max(n·ω, 0)`` onto the given SH basis. The callback
``callback(fraction, message) -> stop?`` reports progress and cancels (``report``
raises ``Cancelled``; nothing is stored). ``store_transfer`` writes the coefficients as
point-domain float attributes ``sm_prt_00 …`` with a geometry key in the mesh's custom
properties, so they persist in the .blend and are known stale when the mesh changes.
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass

import bpy
import numpy as np

from ..core.progress import ProgressCallback, report

ATTRIBUTE_PREFIX = "sm_prt_"
KEY_PROPERTY = "sm_prt_key"
#: Ray origins move this far along the normal, relative to the mesh's bounding-box
#: diagonal, so that a ray does not hit its own vertex's faces.
ORIGIN_OFFSET = 1e-4


@dataclass
class TransferBake:
    coefficients: np.ndarray          # (vertices, K) float32
    rays: int                         # directions per vertex (all of them; half are culled)
    rays_cast: int
    seconds: float
    key: str

    @property
    def rays_per_second(self) -> float:
        return self.rays_cast / max(self.seconds, 1e-9)


def _mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    count = len(mesh.vertices)
    co = np.empty(count * 3, dtype=np.float64)
    normals = np.empty(count * 3, dtype=np.float64)
    mesh.vertices.foreach_get("co", co)
    mesh.vertex_normals.foreach_get("vector", normals)
    return co.reshape(-1, 3), normals.reshape(-1, 3)


def geometry_key(mesh) -> str:
    """A digest of the vertex positions and faces: the transfer is stale when it changes."""
    co, _ = _mesh_arrays(mesh)
    loops = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    digest = hashlib.sha256(co.astype(np.float32).tobytes())
    digest.update(loops.tobytes())
    return digest.hexdigest()[:16]


def bake_transfer(obj, basis_fn, *, rays: int = 256,
                  callback: ProgressCallback | None = None, depsgraph=None) -> TransferBake:
    """Transfer vectors of ``obj``'s evaluated mesh; ``basis_fn(directions) -> (R, K)``."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    from ..core import prt

    if obj is None or obj.type != "MESH":
        raise ValueError(f"PRT bakes meshes; '{getattr(obj, 'name', obj)}' is not one")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        if len(mesh.vertices) == 0 or len(mesh.polygons) == 0:
            raise ValueError(f"Object '{obj.name}' has no faces to bake")
        co, normals = _mesh_arrays(mesh)
        key = geometry_key(mesh)
    finally:
        evaluated.to_mesh_clear()
    lengths = np.linalg.norm(normals, axis=1)
    normals = np.where(lengths[:, None] > 0, normals / np.maximum(lengths, 1e-30)[:, None], 0.0)
    directions = prt.fibonacci_directions(rays)
    basis = np.asarray(basis_fn(directions), dtype=np.float64)
    tree = BVHTree.FromObject(obj, depsgraph)
    offset = ORIGIN_OFFSET * float(np.linalg.norm(co.max(axis=0) - co.min(axis=0)) or 1.0)
    visible = np.zeros((len(co), rays), dtype=bool)
    vectors = [Vector(d) for d in directions]
    start = time.perf_counter()
    cast = 0
    chunk = max(1, 2000 // max(rays // 64, 1))
    for begin in range(0, len(co), chunk):
        report(callback, begin / len(co), f"tracing vertex {begin} of {len(co)}")
        for v in range(begin, min(begin + chunk, len(co))):
            n = normals[v]
            origin = Vector(co[v] + offset * n)
            above = np.flatnonzero(directions @ n > 0.0)
            cast += len(above)
            row = visible[v]
            for r in above:
                row[r] = tree.ray_cast(origin, vectors[r])[0] is None
    seconds = time.perf_counter() - start
    report(callback, 1.0, "projecting")
    coefficients = prt.transfer_from_visibility(normals, directions, visible, basis)
    return TransferBake(coefficients.astype(np.float32), rays, cast, seconds, key)


def store_transfer(mesh, bake: TransferBake) -> None:
    """Write the coefficients as point attributes and remember the geometry key."""
    clear_transfer(mesh)
    for k in range(bake.coefficients.shape[1]):
        attribute = mesh.attributes.new(f"{ATTRIBUTE_PREFIX}{k:02d}", "FLOAT", "POINT")
        attribute.data.foreach_set("value", np.ascontiguousarray(bake.coefficients[:, k]))
    mesh[KEY_PROPERTY] = bake.key
    mesh.update_tag()


def load_transfer(mesh) -> np.ndarray | None:
    """The stored coefficients (vertices, K), or None when absent or stale."""
    names = sorted(a.name for a in mesh.attributes if a.name.startswith(ATTRIBUTE_PREFIX))
    if not names or mesh.get(KEY_PROPERTY) != geometry_key(mesh):
        return None
    out = np.empty((len(mesh.vertices), len(names)), dtype=np.float32)
    for k, name in enumerate(names):
        column = np.empty(len(mesh.vertices), dtype=np.float32)
        mesh.attributes[name].data.foreach_get("value", column)
        out[:, k] = column
    return out


def clear_transfer(mesh) -> None:
    for name in [a.name for a in mesh.attributes if a.name.startswith(ATTRIBUTE_PREFIX)]:
        mesh.attributes.remove(mesh.attributes[name])
    if KEY_PROPERTY in mesh:
        del mesh[KEY_PROPERTY]
