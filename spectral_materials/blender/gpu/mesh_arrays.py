"""Reading an evaluated mesh into NumPy: the one set of readers every drawer and the PRT
bake use (positions, normals, corners, UVs, loop triangles).

:func:`evaluated_mesh` hands out ``obj``'s evaluated mesh for the duration of a ``with``
block and frees it afterwards, whatever happens inside. The readers use ``foreach_get``
into arrays of the dtype asked for; float32 properties read into float64 arrays are
exact, so every caller sees the numbers it read before these were merged.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np


@contextlib.contextmanager
def evaluated_mesh(obj, depsgraph) -> Iterator:
    """``obj``'s evaluated mesh (None for an object without geometry) inside the block."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        yield mesh
    finally:
        evaluated.to_mesh_clear()


def vertex_positions(mesh, dtype=np.float32) -> np.ndarray:
    """(V, 3) vertex coordinates (object space)."""
    co = np.empty(len(mesh.vertices) * 3, dtype=dtype)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def vertex_normals(mesh, dtype=np.float64) -> np.ndarray:
    """(V, 3) vertex normals as Blender computes them (not renormalised)."""
    normals = np.empty(len(mesh.vertices) * 3, dtype=dtype)
    mesh.vertex_normals.foreach_get("vector", normals)
    return normals.reshape(-1, 3)


def corner_vertices(mesh) -> np.ndarray:
    """(C,) int32: the vertex of each corner (loop)."""
    index = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", index)
    return index


def corner_normals(mesh) -> np.ndarray:
    """(C, 3) float32 corner normals (split normals included)."""
    normals = np.empty(len(mesh.loops) * 3, dtype=np.float32)
    mesh.corner_normals.foreach_get("vector", normals)
    return normals.reshape(-1, 3)


def corner_uvs(mesh) -> np.ndarray:
    """(C, 2) float32 coordinates of the active UV map (zeros without one)."""
    corners = len(mesh.loops)
    uvs = np.zeros((corners, 2), dtype=np.float32)
    if mesh.uv_layers.active is not None and corners:
        mesh.uv_layers.active.uv.foreach_get("vector", uvs.ravel())
    return uvs


def vertex_uvs(mesh) -> np.ndarray:
    """Active-UV coordinates per vertex (V, 2): the mean over the vertex's corners (zeros
    without a UV map)."""
    count = len(mesh.vertices)
    if mesh.uv_layers.active is None or not len(mesh.loops):
        return np.zeros((count, 2))
    index = corner_vertices(mesh)
    total = np.zeros((count, 2))
    np.add.at(total, index, corner_uvs(mesh))
    counts = np.bincount(index, minlength=count)[:, None]
    return total / np.maximum(counts, 1)


def loop_triangles(mesh, of: str = "loops") -> np.ndarray:
    """(T, 3) int32 loop triangles: their corners (``of="loops"``) or their vertices
    (``of="vertices"``)."""
    mesh.calc_loop_triangles()
    triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get(of, triangles)
    return triangles.reshape(-1, 3)


def triangle_slots(mesh) -> np.ndarray:
    """(T,) int32 material slot of each loop triangle (after :func:`loop_triangles`)."""
    slots = np.empty(len(mesh.loop_triangles), dtype=np.int32)
    mesh.loop_triangles.foreach_get("material_index", slots)
    return slots


def check_finite(mesh, positions: np.ndarray, normals: np.ndarray | None = None) -> None:
    """ValueError naming the mesh when positions (or normals) are not all finite."""
    finite = np.isfinite(positions).all() and (normals is None or np.isfinite(normals).all())
    if not finite:
        what = "vertex positions" if normals is None else "vertex positions or normals"
        raise ValueError(f"mesh '{mesh.name}' has non-finite {what}")
