"""Factor-pack panels: the material's Spectral BRDF (source, factorisation, stored
factors) and the 3D view's Spectral Scene tab (viewport, colour options, scene basis).

The Stored Factors panel draws, between its figures and its Clear button, the sections
that other capabilities add to :data:`RESULT_SECTIONS` (the EEVEE box), so that this
package need not know them. The PRT Environment panel hangs below Spectral Scene.
"""

from __future__ import annotations

from collections.abc import Callable

import bpy

from ..ui.modal_job import draw_job
from ..ui.spectrum import draw_spectrum
from ..ui.widgets import draw_image
from ..viewport import draw as spectral_draw
from . import drawer, jobs, sources
from .properties import LOBE_ITEMS, MODEL_KEYS

#: ``section(layout, material)``, drawn in the Stored Factors panel in this order.
RESULT_SECTIONS: list[Callable[..., None]] = []


class SPECTRAL_PT_material(bpy.types.Panel):
    bl_label = "Spectral BRDF"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw_header(self, context):
        self.layout.prop(context.material.spectral, "enabled", text="")

    def draw(self, context):
        layout = self.layout
        s = context.material.spectral
        layout.use_property_split = True
        layout.active = s.enabled
        layout.prop(s, "source")
        if s.source == "ANALYTIC":
            layout.prop(s, "model")
            model = MODEL_KEYS[s.model]
            for name in sources.MODEL_SCALARS[model]:
                layout.prop(s, name)
            for param, prop in sources.MODEL_SPECTRA[model].items():
                draw_spectrum(layout, getattr(s, prop), sources.spectrum_label(s, param, prop))
        else:
            layout.prop(s, "filepath")


class SPECTRAL_PT_material_settings(bpy.types.Panel):
    bl_label = "Factorisation"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_parent_id = "SPECTRAL_PT_material"

    def draw(self, context):
        layout = self.layout
        s = context.material.spectral
        layout.use_property_split = True
        layout.prop(s, "parameterization")
        layout.prop(s, "theta_cells")
        layout.prop(s, "packs")
        row = layout.row(heading="Target ΔE94")
        row.prop(s, "use_target", text="")
        sub = row.row()
        sub.active = s.use_target
        sub.prop(s, "target_de94", text="")
        layout.prop(s, "pack_size")
        layout.prop(s, "smoothing")
        layout.prop(s, "specular_lobe")
        if s.source == "FILE":
            layout.prop(s, "measured_cells")
        if not draw_job(layout, context):
            layout.operator("spectral.factor_material", icon="PLAY")


class SPECTRAL_PT_material_result(bpy.types.Panel):
    bl_label = "Stored Factors"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"
    bl_parent_id = "SPECTRAL_PT_material"

    def draw(self, context):
        layout = self.layout
        material = context.material
        r = material.spectral.result
        if r.image is None:
            layout.label(text="Not factored yet", icon="INFO")
            return
        stale = _stale(context, material)
        if stale:
            layout.label(text=stale, icon="ERROR")
        grid = layout.grid_flow(columns=2, even_columns=True)
        grid.label(text="Packs")
        grid.label(text=f"{r.packs} ({r.terms} terms of {r.spectral_size} coefficients)")
        grid.label(text="Grid")
        grid.label(text=f"{r.parameterization} {r.resolution}")
        grid.label(text="Analytic lobe")
        grid.label(text=lobe_label(r.lobe))
        grid.label(text="ΔE94 mean / p95 / max")
        grid.label(text=f"{r.de94_mean:.3f} / {r.de94_p95:.3f} / {r.de94_max:.3f}")
        grid.label(text="Time")
        grid.label(text=f"{r.seconds:.2f} s")
        grid.label(text="Size")
        grid.label(text=f"{r.nbytes / 1024:.1f} KiB")
        layout.prop(material.spectral, "draw_precision")
        drawn = drawer.drawn_precision(material)
        if material.spectral.draw_precision == "AUTO" and drawn is not None:
            layout.label(text=f"Drawn as: {drawn}", icon="INFO")
        draw_image(layout, r.plot, 8.0)
        layout.label(text="ΔE94 (D65, protocol pairs) against packs; dashed: target")
        for section in RESULT_SECTIONS:
            section(layout, material)
        layout.operator("spectral.clear_results", icon="TRASH").scope = "ACTIVE"


def lobe_label(family: str) -> str:
    """The result's lobe family as the *Analytic lobe* setting names it ("None" without)."""
    names = {identifier.lower(): name for identifier, name, _ in LOBE_ITEMS}
    return names.get(family, family) if family else "None"


def _stale(context, material) -> str:
    """Why the stored factors are out of date, or ''.

    Analytic sources are re-hashed on every redraw (cheap); data files are not read
    here, since hashing a large table on each redraw would stall the UI.
    """
    if material.spectral.source != "ANALYTIC":
        return ""
    try:
        inputs = sources.material_inputs(material)
    except sources.SourceError as exc:
        return str(exc)
    basis = jobs.load_scene_basis(context.scene)
    if basis is None:
        return "Out of date: the scene has no spectral basis"
    if sources.input_hash(inputs, basis.vectors) != material.spectral.result.input_hash:
        return "Out of date: inputs or the scene basis changed; factor again"
    return ""


class SPECTRAL_PT_scene(bpy.types.Panel):
    bl_label = "Spectral Scene"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Spectral"

    def draw(self, context):
        layout = self.layout
        s = context.scene.spectral
        layout.prop(s, "viewport_draw", icon="SHADING_RENDERED", toggle=True)
        summary = spectral_draw.viewport_summary()
        if s.viewport_draw and summary:
            layout.label(text=summary, icon="INFO")
        failed = spectral_draw.failed_materials()
        for name, reason in failed:
            layout.label(text=f"{name}: {reason}", icon="ERROR")
        layout.use_property_split = True
        layout.use_property_decorate = False
        layout.prop(s, "observer")
        layout.prop(s, "adaptation_white")
        layout.prop(s, "tone_mapping")
        if s.tone_mapping == "SIGMOID":
            layout.prop(s, "tone_white")
        layout.prop(s, "basis_tolerance")
        layout.prop(s, "basis_max_size")
        if not draw_job(layout, context):
            col = layout.column(align=True)
            col.operator("spectral.factor_scene", icon="PLAY")
            col.operator("spectral.build_basis", icon="NODE_TEXTURE")
            col.operator("spectral.clear_results", icon="TRASH").scope = "ALL"


class SPECTRAL_PT_scene_analysis(bpy.types.Panel):
    bl_label = "Scene Analysis"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Spectral"
    bl_parent_id = "SPECTRAL_PT_scene"

    def draw(self, context):
        layout = self.layout
        s = context.scene.spectral
        if not s.analysis:
            layout.label(text="Not analysed yet")
            return
        layout.label(text=f"Basis: {s.basis_size} coefficients, max ΔE94 {s.basis_max_de94:.3f}")
        col = layout.column(align=True)
        for part in s.analysis.split("; "):
            col.label(text=part)


CLASSES = (
    SPECTRAL_PT_material,
    SPECTRAL_PT_material_settings,
    SPECTRAL_PT_material_result,
    SPECTRAL_PT_scene,
    SPECTRAL_PT_scene_analysis,
)
