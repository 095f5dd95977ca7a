"""Vertex colours of PRT objects in float64, the numbers the viewport draws: the transfer
times the environment in the object's frame, times the albedo layers at the vertices."""

from __future__ import annotations

import bpy
import numpy as np

from ...core.prt import albedo as core_albedo, transfer as core_prt
from ..gpu.mesh_arrays import evaluated_mesh, vertex_uvs
from . import bake
from .inputs import PRTError
from .state import albedo_layers, object_environment


def _evaluated_arrays(obj, depsgraph):
    """(transfer (V, K), vertex UVs (V, 2)) of the evaluated mesh."""
    with evaluated_mesh(obj, depsgraph) as mesh:
        transfer = bake.load_transfer(mesh)
        if transfer is None:
            raise PRTError(f"Object '{obj.name}' has no current PRT transfer: bake it "
                           "(the mesh changed or was never baked)")
        uv = vertex_uvs(mesh)
    return transfer, uv


def vertex_xyz(obj, scene=None, depsgraph=None) -> np.ndarray:
    """Linear CIE XYZ (n_vertices, 3) of the outgoing radiance at each vertex of ``obj``
    under the scene's current environment, normalised to the environment's white (a
    white, unoccluded Lambertian facing world up has Y = 1, however the object is turned:
    the scene's ``white_y``, which the viewport divides by too). Float64; the viewport
    draws the same numbers interpolated over the faces.

    The environment is turned into the object's frame by :func:`object_rotation`
    (mirrors included); scale is not baked: uniform scale is exact, non-uniform scale an
    approximation (:func:`scale_anisotropy`).
    """
    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    if obj is None or obj.type != "MESH":
        raise PRTError(f"'{getattr(obj, 'name', obj)}' is not a mesh")
    transfer, uv = _evaluated_arrays(obj, depsgraph)
    environment = object_environment(obj, scene)
    if transfer.shape[1] != environment.coefficients.shape[0]:
        raise PRTError(f"Object '{obj.name}' was baked with {transfer.shape[1]} SH "
                       f"coefficients, the environment has {environment.coefficients.shape[0]}"
                       " (SH bands changed): bake it again")
    weights = core_albedo.sample_layers(albedo_layers(obj, scene).layers, uv)
    return core_prt.vertex_xyz(transfer, environment, weights)

