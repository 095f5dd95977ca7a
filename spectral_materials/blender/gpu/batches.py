"""GPU batches of evaluated meshes, rebuilt only when their geometry changes.

Vertices are mesh corners (loops), so that split normals and UV tangents stay per
corner: ``position`` (object space), ``normal`` (the corner normal) and ``tangent``
(xyz from the active UV map's tangent space, w its bitangent sign) and ``uv`` (the
active UV map; BTF materials read it). A mesh without
UVs, or whose tangents cannot be computed, gets zero tangents: the shader then
uses the generated field (glsl/common/frame.glsl). One index buffer per material slot.

The cache is keyed by object name and invalidated by a ``depsgraph_update_post``
handler (:func:`note_depsgraph_updates`) when an object's geometry changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .mesh_arrays import (
    check_finite,
    corner_normals,
    corner_uvs,
    corner_vertices,
    evaluated_mesh,
    loop_triangles,
    triangle_slots,
    vertex_positions,
)

_CACHE: dict[str, tuple] = {}
_SERIAL: dict[str, int] = {}


@dataclass
class MeshArrays:
    """Per-corner attributes and per-slot triangle indices of one evaluated mesh."""

    positions: np.ndarray                  # (C, 3) float32
    normals: np.ndarray                    # (C, 3) float32
    tangents: np.ndarray                   # (C, 4) float32
    uvs: np.ndarray                        # (C, 2) float32, zeros without a UV map
    triangles: dict[int, np.ndarray] = field(default_factory=dict)  # slot → (T, 3) int32
    has_tangents: bool = False

    @property
    def nbytes(self) -> int:
        return int(self.positions.nbytes + self.normals.nbytes + self.tangents.nbytes
                   + self.uvs.nbytes + sum(t.nbytes for t in self.triangles.values()))


def _tangents(mesh) -> np.ndarray | None:
    """(C, 4) tangents of the active UV map (xyz, bitangent sign), or None where Blender
    cannot compute them (no UV map, n-gons without a tangent space)."""
    if mesh.uv_layers.active is None or not len(mesh.loops):
        return None
    try:
        mesh.calc_tangents(uvmap=mesh.uv_layers.active.name)
    except RuntimeError:
        return None     # the generated field is used
    corners = len(mesh.loops)
    t = np.empty(corners * 3, dtype=np.float32)
    sign = np.empty(corners, dtype=np.float32)
    mesh.loops.foreach_get("tangent", t)
    mesh.loops.foreach_get("bitangent_sign", sign)
    mesh.free_tangents()
    tangents = np.empty((corners, 4), dtype=np.float32)
    tangents[:, :3] = t.reshape(-1, 3)
    tangents[:, 3] = sign
    return tangents


def mesh_arrays(mesh) -> MeshArrays:
    """Read a (evaluated) mesh's corners and loop triangles into arrays."""
    loops = loop_triangles(mesh)
    slots = triangle_slots(mesh)
    positions = np.ascontiguousarray(vertex_positions(mesh)[corner_vertices(mesh)])
    normals = corner_normals(mesh)
    check_finite(mesh, positions, normals)
    uvs = corner_uvs(mesh)
    tangents = _tangents(mesh)
    has_tangents = tangents is not None
    if tangents is None:
        tangents = np.zeros((len(mesh.loops), 4), dtype=np.float32)
    triangles = {int(s): np.ascontiguousarray(loops[slots == s]) for s in np.unique(slots)}
    return MeshArrays(positions, normals, tangents, uvs, triangles, has_tangents)


VERTEX_ATTRIBUTES = (("position", 3), ("normal", 3), ("tangent", 4), ("uv", 2))


@dataclass
class MeshBatches:
    """GPU batches per material slot of one object, and the arrays they hold."""

    arrays: MeshArrays
    batches: dict[int, object]

    @classmethod
    def build(cls, arrays: MeshArrays) -> MeshBatches:
        import gpu

        fmt = gpu.types.GPUVertFormat()
        for name, length in VERTEX_ATTRIBUTES:
            fmt.attr_add(id=name, comp_type="F32", len=length, fetch_mode="FLOAT")
        vbo = gpu.types.GPUVertBuf(fmt, len(arrays.positions))
        vbo.attr_fill("position", arrays.positions)
        vbo.attr_fill("normal", arrays.normals)
        vbo.attr_fill("tangent", arrays.tangents)
        vbo.attr_fill("uv", arrays.uvs)
        batches = {}
        for slot, tris in arrays.triangles.items():
            if len(tris):
                ibo = gpu.types.GPUIndexBuf(type="TRIS", seq=tris)
                batches[slot] = gpu.types.GPUBatch(type="TRIS", buf=vbo, elem=ibo)
        return cls(arrays, batches)


def object_batches(obj, depsgraph) -> MeshBatches | None:
    """The cached batches of ``obj`` (evaluated), rebuilt if its geometry changed."""
    key = (obj.name, obj.data.name if obj.data else "", _SERIAL.get(obj.name, 0))
    cached = _CACHE.get(obj.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    with evaluated_mesh(obj, depsgraph) as mesh:
        if mesh is None:
            return None
        batches = MeshBatches.build(mesh_arrays(mesh))
    _CACHE[obj.name] = (key, batches)
    return batches


def note_depsgraph_updates(depsgraph) -> None:
    """Invalidate the batches of objects whose geometry the update changed."""
    for update in depsgraph.updates:
        target = getattr(update.id, "original", update.id)
        if update.is_updated_geometry:
            name = target.name
            _SERIAL[name] = _SERIAL.get(name, 0) + 1
            # A mesh datablock changed: every object using it is stale.
            for obj_name, (key, _) in list(_CACHE.items()):
                if key[1] == name:
                    _SERIAL[obj_name] = _SERIAL.get(obj_name, 0) + 1


def serial(name: str) -> int:
    """How many geometry changes of object ``name`` were seen (for other caches' keys)."""
    return _SERIAL.get(name, 0)


def clear_cache() -> None:
    _CACHE.clear()
    _SERIAL.clear()


def cached_objects() -> list[str]:
    return list(_CACHE)
