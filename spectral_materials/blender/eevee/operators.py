"""Apply and remove the EEVEE node group of the active material."""

from __future__ import annotations

import bpy

from ..ui.modal_job import EXPECTED_ERRORS
from ..ui.widgets import active_material
from . import apply as eevee


class SPECTRAL_OT_eevee_apply(bpy.types.Operator):
    """Reconstruct the active material's factor packs in an EEVEE node group (the scene's
    Spectral lights count of lights spectrally, the others and the world through a fitted
    RGB Principled BSDF)"""

    bl_idname = "spectral.eevee_apply"
    bl_label = "Apply EEVEE Node Group"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        material = active_material(context)
        return material is not None and material.spectral.result.image is not None

    def execute(self, context):
        material = active_material(context)
        try:
            settings = context.scene.spectral
            counts = eevee.apply_eevee(material, context.scene, measure=True,
                                       lights=settings.eevee_spectral_lights,
                                       shadows=settings.eevee_spectral_shadows)
        except EXPECTED_ERRORS as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        de = counts["de94"]
        rgb = counts["lights_left_to_rgb"]
        self.report({"INFO"}, f"'{material.name}': spectral light(s) "
                              f"{', '.join(counts['lights'])}, {counts['nodes']} nodes, "
                              f"{counts['images']} texture(s); key light ΔE94 mean "
                              f"{de['mean']:.3f}, p95 {de['p95']:.3f} against 5 nm"
                              + (f"; {', '.join(rgb)} left to RGB: the nodes would exceed "
                                 "EEVEE's limit" if rgb else ""))
        if counts["shadows"] and not getattr(context.scene.eevee, "use_shadows", True):
            self.report({"WARNING"}, "The scene's EEVEE Shadows are off (Render Properties "
                                     "▸ Shadows): no light casts a shadow, spectral or not")
        return {"FINISHED"}


class SPECTRAL_OT_eevee_remove(bpy.types.Operator):
    """Remove the EEVEE node group and restore the material's original node links"""

    bl_idname = "spectral.eevee_remove"
    bl_label = "Remove EEVEE Node Group"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        material = active_material(context)
        return material is not None and eevee.applied(material) is not None

    def execute(self, context):
        material = active_material(context)
        eevee.remove_eevee(material, context.scene)
        self.report({"INFO"}, f"'{material.name}': original node tree restored")
        return {"FINISHED"}


CLASSES = (SPECTRAL_OT_eevee_apply, SPECTRAL_OT_eevee_remove)
