"""Baking an object's transfer in three steps, so that the tracing may run in a worker
thread: :func:`plan_bake` reads the scene (main thread), :func:`run_bake` traces and
projects (no ``bpy``), :func:`commit_bake` stores the transfer and the albedo layers
(main thread); and what the panel says of an object's bake."""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ...core.prt import sh, transfer as core_prt
from ..brdf import storage
from ..gpu.mesh_arrays import evaluated_mesh
from . import bake
from .albedo import albedo_source
from .inputs import PRTError, forget, prt_objects
from .state import scale_anisotropy, store_albedo


@dataclass
class BakePlan:
    """What a transfer bake needs, read from the scene on the main thread (plain data: the
    tracing may run in a worker thread)."""

    object_name: str
    geometry: bake.MeshGeometry
    rays: int
    bands: int
    backend: str = "auto"


def plan_bake(obj, scene=None, *, backend: str = "auto", depsgraph=None) -> BakePlan:
    """Check ``obj`` and read its evaluated mesh for :func:`run_bake`."""
    scene = scene or bpy.context.scene
    if obj is None or obj.type != "MESH":
        raise PRTError(f"PRT bakes meshes; '{getattr(obj, 'name', obj)}' is not one")
    albedo_source(obj)                     # a bad albedo fails before the long part
    rays = int(obj.spectral_prt.rays)
    if not 1 <= rays <= core_prt.MAX_RAYS:
        raise PRTError(f"Object '{obj.name}': rays per vertex must be 1..{core_prt.MAX_RAYS}, "
                       f"got {rays}")
    try:
        geometry = bake.read_geometry(obj, depsgraph)
    except ValueError as exc:
        raise PRTError(str(exc)) from None
    if len(geometry.positions) != len(obj.data.vertices):
        raise PRTError(f"Object '{obj.name}': its modifiers change the vertex count "
                       f"({len(obj.data.vertices)} → {len(geometry.positions)}); PRT stores "
                       "the transfer per mesh vertex, so apply those modifiers first")
    if not np.isfinite(geometry.positions).all():
        raise PRTError(f"Object '{obj.name}' has non-finite vertex positions")
    return BakePlan(obj.name, geometry, rays, int(scene.spectral.environment.bands), backend)


def run_bake(plan: BakePlan, callback=None) -> bake.TransferBake:
    """Trace and project (never touches ``bpy`` data: safe in a worker thread)."""
    seen = bake.trace_geometry(plan.geometry, rays=plan.rays, callback=callback,
                               backend=plan.backend)
    return bake.project_transfer(seen, sh.sh_basis(seen.directions, plan.bands), callback)


def commit_bake(scene, plan: BakePlan, result: bake.TransferBake) -> None:
    """Store the transfer on the mesh and every PRT object's albedo layers (main thread).
    Refuses a result whose mesh changed while it was traced."""
    obj = bpy.data.objects.get(plan.object_name)
    if obj is None:
        raise PRTError(f"Object '{plan.object_name}' was removed during the bake")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    with evaluated_mesh(obj, depsgraph) as mesh:
        current = bake.geometry_key(mesh)
    if current != result.key:
        raise PRTError(f"Object '{obj.name}' changed during the bake; bake it again")
    was_enabled = obj.spectral_prt.enabled
    obj.spectral_prt.enabled = True        # its albedo enters the scene's basis
    try:
        for other in prt_objects(scene):   # the basis may change for every object
            store_albedo(other, scene)
    except BaseException:
        obj.spectral_prt.enabled = was_enabled
        raise
    bake.store_transfer(obj.data, result)


def bake_prt(obj, scene=None, *, callback=None, backend: str = "auto", depsgraph=None
             ) -> bake.TransferBake:
    """Bake ``obj``'s transfer (the scene's SH bands, the object's ray count) and store it
    with the albedo layers: :func:`plan_bake`, :func:`run_bake`, :func:`commit_bake`.
    Nothing changes if it fails or is cancelled."""
    scene = scene or bpy.context.scene
    plan = plan_bake(obj, scene, backend=backend, depsgraph=depsgraph)
    result = run_bake(plan, callback)
    commit_bake(scene, plan, result)
    return result


def clear_prt(obj) -> None:
    """Remove the object's stored transfer and albedo layers."""
    bake.clear_transfer(obj.data)
    image = obj.spectral_prt.albedo_image
    obj.spectral_prt.albedo_image = None
    if image is not None and image.users == 1 and image.use_fake_user:
        storage.remove_image(image)
    forget(f"albedo_layers:{obj.name}")


#: Scale anisotropy (:func:`scale_anisotropy`) the panel lets pass as uniform (float32
#: matrices and typed-in scales carry ~1e-7).
ANISOTROPY_TOLERANCE = 1e-4


def transfer_status(obj) -> str:
    """One line for the panel: baked (how), stale, not baked, or baked but approximate
    (a non-uniform scale, which the bake does not include)."""
    mesh = obj.data
    state = bake.transfer_state(mesh)
    if state == "absent":
        return "Not baked"
    if state == "stale":
        return "Stale: the mesh changed since the bake; bake again"
    if scale_anisotropy(obj) > ANISOTROPY_TOLERANCE:
        return "Approximate: the object's scale is not uniform and the transfer was baked " \
            "without it; apply the scale and bake again"
    return f"Baked: {len(mesh.vertices)} vertices × {len(bake.transfer_names(mesh))} SH " \
        "coefficients"

