"""Bake the active object's PRT transfer (a modal job) and clear it."""

from __future__ import annotations

import bpy

from ..ui.modal_job import ModalJob
from . import scene as prt


class SPECTRAL_OT_bake_prt(ModalJob, bpy.types.Operator):
    """Bake the active object's PRT transfer (self-shadowing by ray casting) and store its
    spectral albedo layers; Esc cancels and leaves everything as it was"""

    bl_idname = "spectral.bake_prt"
    bl_label = "Bake PRT"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            cls.poll_message_set("Select a mesh object")
            return False
        return True

    def plan(self, context):
        return prt.plan_bake(context.active_object, context.scene)

    def run(self, plan, callback=None):
        return prt.run_bake(plan, callback)

    def commit(self, context, plan, result) -> str:
        prt.commit_bake(context.scene, plan, result)
        from ..viewport import draw

        draw.redraw_viewports()
        return (f"'{plan.object_name}': {len(plan.geometry.positions)} vertices × "
                f"{plan.rays} rays in {result.seconds:.1f} s "
                f"({result.rays_per_second / 1e6:.2f} M rays/s, {result.backend})")


class SPECTRAL_OT_clear_prt(bpy.types.Operator):
    """Remove the active object's PRT transfer and albedo layers"""

    bl_idname = "spectral.clear_prt"
    bl_label = "Clear PRT"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and obj.type == "MESH"

    def execute(self, context):
        prt.clear_prt(context.active_object)
        return {"FINISHED"}


CLASSES = (SPECTRAL_OT_bake_prt, SPECTRAL_OT_clear_prt)
