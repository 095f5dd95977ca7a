"""The Light properties panel: the spectral power distribution and its plot."""

from __future__ import annotations

import bpy

from ..ui.widgets import draw_image
from . import plots
from .spd import SourceError


class SPECTRAL_PT_light(bpy.types.Panel):
    bl_label = "Spectral Power Distribution"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "data"

    @classmethod
    def poll(cls, context):
        return isinstance(context.light, bpy.types.Light)

    def draw(self, context):
        layout = self.layout
        light = context.light
        s = light.spectral
        layout.use_property_split = True
        layout.prop(s, "kind")
        if s.kind == "ILLUMINANT":
            layout.prop(s, "illuminant")
        elif s.kind == "BLACKBODY":
            layout.prop(s, "temperature")
        elif s.kind == "TEXT":
            layout.prop(s, "text")
        else:
            layout.prop(s, "filepath")
        layout.prop(s, "power")
        try:
            image = plots.light_plot(light)
        except SourceError as exc:
            layout.label(text=str(exc), icon="ERROR")
        else:
            draw_image(layout, image, 6.0)


CLASSES = (SPECTRAL_PT_light,)
