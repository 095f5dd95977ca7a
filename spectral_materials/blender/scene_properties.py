"""The scene's spectral settings (``Scene.spectral``): the viewport switch, the colour
options every drawer reads, the factor-pack scene basis and the PRT environment.

Why here, at the top of ``blender/``: the group points to the PRT environment group
(``prt.properties``) and its switches call the viewport, while factor packs, PRT, BTF and
the viewport all read it. Only the root sits above all of them; the capabilities reach
the group through ``scene.spectral`` at run time and never import this module.
"""

from __future__ import annotations

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from .eevee.nodes import MAX_SPECTRAL_LIGHTS
from .prt.properties import SPECTRAL_PG_environment
from .ui.enums import ILLUMINANT_ITEMS, OBSERVER_ITEMS, TONE_MAP_ITEMS


def _viewport_draw_changed(self, context) -> None:
    from .viewport import draw

    if self.viewport_draw:
        draw.enable_viewport()
    elif not any(s.spectral.viewport_draw for s in bpy.data.scenes):
        draw.disable_viewport()
    draw.redraw_viewports()


def _redraw(self, context) -> None:
    from .viewport import draw

    draw.redraw_viewports()


class SPECTRAL_PG_scene(bpy.types.PropertyGroup):
    """Scene-wide colour options and the shared spectral basis."""

    viewport_draw: BoolProperty(name="Spectral Viewport", default=False,
                                update=_viewport_draw_changed,
                                description="Draw objects with factored materials through the "
                                            "spectral shaders, lit by the scene's lights")
    observer: EnumProperty(name="Observer", items=OBSERVER_ITEMS, default="CIE_1931_2",
                           description="Colour matching functions for every XYZ")
    adaptation_white: EnumProperty(name="Adaptation white", items=ILLUMINANT_ITEMS,
                                   default="D65", update=_redraw,
                                   description="Scene white the display adapts from "
                                               "(Bradford) before sRGB")
    tone_mapping: EnumProperty(name="Tone mapping", items=TONE_MAP_ITEMS, default="SIGMOID",
                               update=_redraw,
                               description="Curve from linear sRGB to the display")
    tone_white: FloatProperty(name="White", default=4.0, soft_min=1.0, soft_max=64.0,
                              update=_redraw,
                              description="Linear value that maps to display white (sigmoid)")
    basis_tolerance: FloatProperty(name="Basis tolerance", default=0.05, soft_min=0.001,
                                   soft_max=1.0, precision=3,
                                   description="Largest ΔE94 the spectral basis may cost any "
                                               "light × material pair, against 5 nm")
    eevee_spectral_lights: IntProperty(
        name="Spectral lights", default=MAX_SPECTRAL_LIGHTS, min=1, max=MAX_SPECTRAL_LIGHTS,
        description="At most this many lights the EEVEE node group evaluates spectrally "
                    "through the factor packs (the brightest at the material first; fewer "
                    "where the nodes would exceed EEVEE's limit); the others are shaded in "
                    "RGB, with EEVEE's shadows")
    eevee_spectral_shadows: BoolProperty(
        name="Shadows of spectral lights", default=True,
        description="Keep EEVEE's own shadows of the spectral lights on the material, read "
                    "through two helper lights per light that light only the material's "
                    "objects (through transmission); off, the spectral lights cast no "
                    "shadow on it")
    basis_max_size: IntProperty(name="Max basis size", default=16, soft_min=1, soft_max=32,
                                description="Upper bound on basis coefficients")
    basis_size: IntProperty(name="Basis size", min=0,
                            description="Coefficients of the stored scene basis (0 = none)")
    basis_max_de94: FloatProperty(name="Basis max ΔE94", precision=4,
                                  description="Worst light × material ΔE94 of the basis")
    analysis: StringProperty(name="Scene analysis",
                             description="What the last scene analysis kept and left out")
    analysis_json: StringProperty(description="The last scene analysis (JSON)")
    environment: PointerProperty(type=SPECTRAL_PG_environment, name="Environment",
                                 description="The spectral environment of PRT objects")


#: Registered by ``blender.register()`` after every capability's classes.
CLASSES = (SPECTRAL_PG_scene,)


def register() -> None:
    """Give every scene its spectral settings."""
    bpy.types.Scene.spectral = PointerProperty(type=SPECTRAL_PG_scene)


def unregister() -> None:
    del bpy.types.Scene.spectral
