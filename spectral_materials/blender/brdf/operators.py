"""Factor-pack operators: factor the active material or the scene, build the scene's
spectral basis, clear stored factors. Thin wrappers over :mod:`.jobs` and :mod:`.storage`;
the long ones run as modal jobs (:class:`..ui.modal_job.ModalJob`)."""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty

from ..ui.modal_job import ModalJob
from . import hooks, jobs, scene, storage


class _SceneJobOperator(ModalJob):
    """Scene analysis and factoring; subclasses say what to plan and whether to factor."""

    bl_options = {"REGISTER", "UNDO"}
    factor_materials = True

    def run(self, plan, callback=None):
        return jobs.run_scene_job(plan, callback, factor=self.factor_materials)

    def commit(self, context, plan, result) -> str:
        return jobs.commit_scene_job(context.scene, result)


class SPECTRAL_OT_factor_material(_SceneJobOperator, bpy.types.Operator):
    """Factor the active material's spectral BRDF into factor packs and store them"""

    bl_idname = "spectral.factor_material"
    bl_label = "Factor Material"
    bl_options = {"REGISTER", "UNDO"}

    force: BoolProperty(name="Force", default=False,
                        description="Factor again even if the stored factors are up to date")

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        if obj is None or obj.active_material is None:
            cls.poll_message_set("Select an object with an active material")
            return False
        return True

    def plan(self, context):
        material = context.active_object.active_material
        return scene.plan_scene(context.scene, only=[material], force=self.force)


class SPECTRAL_OT_factor_scene(_SceneJobOperator, bpy.types.Operator):
    """Analyse the scene, build its spectral basis and factor every used, out-of-date material"""

    bl_idname = "spectral.factor_scene"
    bl_label = "Factor Scene"
    bl_options = {"REGISTER", "UNDO"}

    force: BoolProperty(name="Force", default=False,
                        description="Factor every used material, even those up to date")

    def plan(self, context):
        return scene.plan_scene(context.scene, force=self.force)


class SPECTRAL_OT_build_basis(_SceneJobOperator, bpy.types.Operator):
    """Analyse the scene and build its spectral basis without factoring anything"""

    bl_idname = "spectral.build_basis"
    bl_label = "Build Spectral Basis"
    bl_options = {"REGISTER", "UNDO"}
    factor_materials = False

    def plan(self, context):
        return scene.plan_scene(context.scene)


class SPECTRAL_OT_clear_results(bpy.types.Operator):
    """Remove stored factor packs (their images and metadata)"""

    bl_idname = "spectral.clear_results"
    bl_label = "Clear Spectral Results"
    bl_options = {"REGISTER", "UNDO"}

    scope: EnumProperty(
        name="Scope", default="ACTIVE",
        items=[("ACTIVE", "Active material", "The active object's active material"),
               ("ALL", "All materials", "Every material in the file, and the scene basis")],
        description="Which results to remove")

    def execute(self, context):
        if self.scope == "ACTIVE":
            obj = context.active_object
            material = obj.active_material if obj is not None else None
            if material is None:
                self.report({"ERROR"}, "No active material")
                return {"CANCELLED"}
            targets = [material]
        else:
            targets = list(bpy.data.materials)
        for material in targets:           # e.g. the EEVEE group samples the factor image
            hooks.before_clear(material, context.scene)
        cleared = [m.name for m in targets if storage.clear_factored(m)]
        if self.scope == "ALL":
            jobs.clear_scene_basis(context.scene)
        self.report({"INFO"}, f"Cleared {len(cleared)} material(s)"
                    + (": " + ", ".join(cleared) if cleared else ""))
        return {"FINISHED"}


CLASSES = (
    SPECTRAL_OT_factor_material,
    SPECTRAL_OT_factor_scene,
    SPECTRAL_OT_build_basis,
    SPECTRAL_OT_clear_results,
)
