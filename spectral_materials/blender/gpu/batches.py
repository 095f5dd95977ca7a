"""GPU batches of evaluated meshes, rebuilt only when their geometry changes.

Vertices are mesh corners (loops), so that split normals and UV tangents stay per
corner: ``position`` (object space), ``normal`` (the corner normal) and ``tangent``
(xyz from the active UV map's tangent space, w its bitangent sign) and ``uv`` (the
active UV map; BTF materials read it). A mesh without
UVs, or whose tangents cannot be computed, gets zero tangents: the shader then
uses the generated field (glsl/frame.glsl). One index buffer per material slot.

The cache is keyed by object name and invalidated by a ``depsgraph_update_post``
handler (:func:`note_depsgraph_updates`) when an object's geometry changes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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


def mesh_arrays(mesh) -> MeshArrays:
    """Read a (evaluated) mesh's corners and loop triangles into arrays."""
    mesh.calc_loop_triangles()
    corners = len(mesh.loops)
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    vertex_index = np.empty(corners, dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", vertex_index)
    positions = co.reshape(-1, 3)[vertex_index]
    normals = np.empty(corners * 3, dtype=np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    tangents = np.zeros((corners, 4), dtype=np.float32)
    uvs = np.zeros((corners, 2), dtype=np.float32)
    has_tangents = False
    if mesh.uv_layers.active is not None and corners:
        mesh.uv_layers.active.uv.foreach_get("vector", uvs.ravel())
    if mesh.uv_layers.active is not None and corners:
        try:
            mesh.calc_tangents(uvmap=mesh.uv_layers.active.name)
        except RuntimeError:
            pass        # n-gons without a tangent space: the generated field is used
        else:
            t = np.empty(corners * 3, dtype=np.float32)
            sign = np.empty(corners, dtype=np.float32)
            mesh.loops.foreach_get("tangent", t)
            mesh.loops.foreach_get("bitangent_sign", sign)
            tangents[:, :3] = t.reshape(-1, 3)
            tangents[:, 3] = sign
            has_tangents = True
            mesh.free_tangents()
    count = len(mesh.loop_triangles)
    loops = np.empty(count * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    slots = np.empty(count, dtype=np.int32)
    mesh.loop_triangles.foreach_get("material_index", slots)
    loops = loops.reshape(-1, 3)
    triangles = {int(s): np.ascontiguousarray(loops[slots == s]) for s in np.unique(slots)}
    finite = np.isfinite(positions).all() and np.isfinite(normals).all()
    if not finite:
        raise ValueError(f"mesh '{mesh.name}' has non-finite vertex positions or normals")
    return MeshArrays(np.ascontiguousarray(positions), normals.reshape(-1, 3), tangents,
                      uvs, triangles, has_tangents)


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
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        if mesh is None:
            return None
        batches = MeshBatches.build(mesh_arrays(mesh))
    finally:
        evaluated.to_mesh_clear()
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
