"""The Monte Carlo reference of the PRT vertex colours: 5 nm, the true (unprojected)
environment, the object's own triangles as occluders, in world space."""

from __future__ import annotations

import bpy
import numpy as np

from ..gpu.mesh_arrays import (
    evaluated_mesh,
    loop_triangles,
    vertex_normals,
    vertex_positions,
    vertex_uvs,
)
from . import bake
from .albedo import vertex_albedo_spectra
from .environment import reference_environment


def world_geometry(obj, depsgraph) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions, normals, triangles, uvs) of the evaluated mesh in world space."""
    with evaluated_mesh(obj, depsgraph) as mesh:
        co, normals = vertex_positions(mesh, np.float64), vertex_normals(mesh)
        triangles = loop_triangles(mesh, of="vertices")
        uv = vertex_uvs(mesh)
    matrix = np.array(obj.matrix_world)
    world = co @ matrix[:3, :3].T + matrix[:3, 3]
    return world, bake.unit_normals(normals @ np.linalg.inv(matrix[:3, :3])), triangles, uv


def _reference_inputs(obj, depsgraph):
    """(points, normals, vertex UVs, visibility function, ray offset) in world space."""
    from ...core.prt import raycast

    points, normals, triangles, uv = world_geometry(obj, depsgraph)
    occluder = raycast.Occluder(points, triangles)
    extent = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)) or 1.0)
    return (points, normals, uv, lambda o, d: ~occluder.occluded(o, d),
            bake.ORIGIN_OFFSET * extent)


def vertex_reference_irradiance(obj, scene=None, depsgraph=None, *, rays: int = 4096,
                                seed: int = 0) -> np.ndarray:
    """Monte Carlo spectral irradiance (V, L) at ``obj``'s vertices (world space, 5 nm, the
    true environment, the object's own triangles as occluders)."""
    from ...core.prt import reference as prt_reference

    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    points, normals, _, visible, offset = _reference_inputs(obj, depsgraph)
    return prt_reference.reference_irradiance(points, normals, reference_environment(scene),
                                              visible, rays=rays, seed=seed, offset=offset)


def vertex_reference_xyz(obj, scene=None, depsgraph=None, *, rays: int = 4096,
                         seed: int = 0) -> np.ndarray:
    """The Monte Carlo reference of :func:`vertex_xyz`: 5 nm, the true (unprojected)
    environment, the same self-visibility (the object's own triangles), ``rays``
    cosine-distributed rays per vertex."""
    from ...core.prt import reference as prt_reference

    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    points, normals, uv, visible, offset = _reference_inputs(obj, depsgraph)
    return prt_reference.reference_vertex_xyz(
        points, normals, vertex_albedo_spectra(obj, uv), reference_environment(scene),
        visible, rays=rays, seed=seed, offset=offset)

