"""Panels: Material and Light properties, and a 3D-view sidebar tab for the scene."""

from __future__ import annotations

import bpy

from ..brdf import jobs, sources
from ..btf import fit as btf
from ..eevee import apply as eevee
from ..lights import plots
from ..prt import scene as prt
from ..viewport import draw as spectral_draw
from .properties import MODEL_KEYS


def _draw_spectrum(layout, group, label: str) -> None:
    box = layout.box()
    row = box.row(align=True)
    row.label(text=label)
    row.prop(group, "kind", text="")
    if group.kind == "COLORCHECKER":
        box.prop(group, "patch")
    elif group.kind == "CONSTANT":
        box.prop(group, "constant")
    elif group.kind == "TEXT":
        box.prop(group, "text")
    else:
        box.prop(group, "filepath")


def _draw_job(layout, context) -> bool:
    job = context.window_manager.spectral_job
    if job.running:
        layout.progress(factor=job.fraction, type="BAR",
                        text=f"{100 * job.fraction:.0f}% {job.message}  (Esc cancels)")
    return job.running


def _draw_image(layout, image, scale: float) -> None:
    if image is None:
        return
    image.preview_ensure()
    layout.template_icon(icon_value=image.preview.icon_id, scale=scale)


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
                _draw_spectrum(layout, getattr(s, prop), sources.spectrum_label(s, param, prop))
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
        if not _draw_job(layout, context):
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
        grid.label(text="ΔE94 mean / p95 / max")
        grid.label(text=f"{r.de94_mean:.3f} / {r.de94_p95:.3f} / {r.de94_max:.3f}")
        grid.label(text="Time")
        grid.label(text=f"{r.seconds:.2f} s")
        grid.label(text="Size")
        grid.label(text=f"{r.nbytes / 1024:.1f} KiB")
        _draw_image(layout, r.plot, 8.0)
        layout.label(text="ΔE94 (D65, protocol pairs) against packs; dashed: target")
        _draw_eevee(layout, material)
        layout.operator("spectral.clear_results", icon="TRASH").scope = "ACTIVE"


def _draw_eevee(layout, material) -> None:
    box = layout.box()
    record = eevee.applied(material)
    if record is None:
        box.label(text="EEVEE: not applied", icon="SHADING_RENDERED")
        box.operator("spectral.eevee_apply", icon="NODETREE")
        return
    box.label(text=f"EEVEE: key light '{record['light']}' ({record['working_space']})",
              icon="SHADING_RENDERED")
    box.label(text=f"{record['nodes']} nodes, {record['images']} texture(s)")
    de = record.get("de94")
    if de:
        box.label(text=f"Key light ΔE94 mean {de['mean']:.3f}, p95 {de['p95']:.3f}, "
                       f"max {de['max']:.3f} (5 nm)")
    row = box.row(align=True)
    row.operator("spectral.eevee_apply", text="Rebuild", icon="FILE_REFRESH")
    row.operator("spectral.eevee_remove", icon="X")


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
        except sources.SourceError as exc:
            layout.label(text=str(exc), icon="ERROR")
        else:
            _draw_image(layout, image, 6.0)


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
        if not _draw_job(layout, context):
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
            _draw_spectrum(layout, p.albedo, "Albedo")
        elif p.albedo_kind == "IMAGE":
            layout.template_ID(p, "image", open="image.open")
        elif p.albedo_kind == "SPECTRAL_EXR":
            layout.prop(p, "filepath")
        layout.prop(p, "rays")
        if not _draw_job(layout, context):
            row = layout.row(align=True)
            row.operator("spectral.bake_prt", icon="RENDER_STILL")
            row.operator("spectral.clear_prt", icon="TRASH")
        layout.label(text=prt.transfer_status(obj), icon="INFO")
        reason = spectral_draw.prt_gpu.FAILED.get(obj.name)
        if reason:
            layout.label(text=reason, icon="ERROR")


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
        if not _draw_job(layout, context):
            row = layout.row(align=True)
            row.operator("spectral.fit_btf", icon="TEXTURE")
            row.operator("spectral.clear_btf", icon="TRASH")
        layout.label(text=btf.status(material), icon="INFO")
        reason = spectral_draw.btf_gpu.FAILED.get(material.name)
        if reason:
            layout.label(text=reason, icon="ERROR")


CLASSES = (
    SPECTRAL_PT_material,
    SPECTRAL_PT_material_settings,
    SPECTRAL_PT_material_result,
    SPECTRAL_PT_light,
    SPECTRAL_PT_scene,
    SPECTRAL_PT_scene_analysis,
    SPECTRAL_PT_environment,
    SPECTRAL_PT_prt_object,
    SPECTRAL_PT_btf,
)
