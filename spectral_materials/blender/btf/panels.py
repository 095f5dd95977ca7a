"""The material's Spectral BTF panel: source, reflectance-field model, fit, figures."""

from __future__ import annotations

import bpy

from ..ui.modal_job import draw_job
from . import drawer, fit as btf


class SPECTRAL_PT_btf(bpy.types.Panel):
    """The active material's BTF: source, reflectance-field model, fit, figures."""

    bl_label = "Spectral BTF"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw(self, context):
        layout = self.layout
        material = context.material
        s = material.spectral_btf
        layout.use_property_split = True
        layout.prop(s, "source")
        if s.source.startswith("UBO"):
            layout.prop(s, "filepath")
        layout.prop(s, "texels")
        layout.prop(s, "model")
        if s.model == "RFNL":
            layout.prop(s, "lobes")
        layout.prop(s, "uv_scale")
        if not draw_job(layout, context):
            row = layout.row(align=True)
            row.operator("spectral.fit_btf", icon="TEXTURE")
            row.operator("spectral.clear_btf", icon="TRASH")
        layout.label(text=btf.status(material), icon="INFO")
        reason = drawer.FAILED.get(material.name)
        if reason:
            layout.label(text=reason, icon="ERROR")


CLASSES = (SPECTRAL_PT_btf,)
