"""PRT panels: the environment (under the 3D view's Spectral Scene tab) and the active
object's Spectral PRT settings, bake and status."""

from __future__ import annotations

import bpy

from ..ui.modal_job import draw_job
from ..ui.spectrum import draw_spectrum
from . import drawer, scene as prt


class SPECTRAL_PT_environment(bpy.types.Panel):
    """The spectral environment that lights PRT objects."""

    bl_label = "PRT Environment"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Spectral"
    bl_parent_id = "SPECTRAL_PT_scene"

    def draw(self, context):
        layout = self.layout
        env = context.scene.spectral.environment
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(env, "source")
        if env.source == "SKY":
            layout.prop(env, "illuminant")
            layout.prop(env, "sky")
            layout.prop(env, "sun_fraction")
            if env.sun_fraction > 0:
                layout.prop(env, "sun_elevation")
                layout.prop(env, "sun_azimuth")
        elif env.source == "IMAGE":
            layout.template_ID(env, "image", open="image.open")
        else:
            layout.prop(env, "filepath")
        layout.prop(env, "rotation")
        layout.prop(env, "bands")
        layout.prop(env, "window")
        layout.prop(env, "basis_size")
        if not prt.prt_objects(context.scene):
            layout.label(text="No object uses spectral PRT", icon="INFO")
            return
        try:
            state = prt.scene_environment(context.scene)
        except ValueError as exc:
            layout.label(text=str(exc), icon="ERROR")
            return
        layout.label(text=f"{state.environment.source}: {state.environment.bands}² SH × "
                          f"{state.basis.shape[1]} spectral coefficients", icon="WORLD")


class SPECTRAL_PT_prt_object(bpy.types.Panel):
    """Spectral PRT settings of the active object: albedo, bake, status."""

    bl_label = "Spectral PRT"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw_header(self, context):
        self.layout.prop(context.object.spectral_prt, "enabled", text="")

    def draw(self, context):
        layout = self.layout
        obj = context.object
        p = obj.spectral_prt
        layout.use_property_split = True
        layout.active = p.enabled
        layout.prop(p, "albedo_kind")
        if p.albedo_kind == "SPECTRUM":
            draw_spectrum(layout, p.albedo, "Albedo")
        elif p.albedo_kind == "IMAGE":
            layout.template_ID(p, "image", open="image.open")
        elif p.albedo_kind == "SPECTRAL_EXR":
            layout.prop(p, "filepath")
        layout.prop(p, "rays")
        layout.prop(p, "albedo_texture")
        status = drawer.albedo_status(obj)
        if status:
            layout.label(text=status, icon="TEXTURE")
        if not draw_job(layout, context):
            row = layout.row(align=True)
            row.operator("spectral.bake_prt", icon="RENDER_STILL")
            row.operator("spectral.clear_prt", icon="TRASH")
        layout.label(text=prt.transfer_status(obj), icon="INFO")
        reason = drawer.FAILED.get(obj.name)
        if reason:
            layout.label(text=reason, icon="ERROR")


#: The environment panel hangs below ``brdf.panels.SPECTRAL_PT_scene``, registered before.
CLASSES = (SPECTRAL_PT_environment, SPECTRAL_PT_prt_object)
