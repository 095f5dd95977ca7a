"""Drawing factored materials: the viewport draw handler and offscreen scene renders.

:func:`draw_objects` draws every visible object whose material slots hold stored
factor packs, through the shader variant each material needs (``shaders.py``),
with the scene's lights (``scene_lights.py``). Other geometry is drawn into the
depth buffer only, so that it hides what is behind it. The viewport draw handler
(``SpaceView3D``, ``POST_VIEW``, depth-tested against Blender's own drawing) and
:func:`render_camera` (an RGBA32F offscreen from the scene camera) both call it.

Caches: shader variants (``shaders``), batches per object (``mesh_batches``,
rebuilt when geometry changes), and factor textures per material (rebuilt when
its stored factors change). :func:`reset` drops them all; it runs on file load
and on unregister, which also remove the handler.
"""

from __future__ import annotations

import atexit
from dataclasses import dataclass, field

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ...core.brdf.shading import View
from ..brdf import storage
from ..brdf.gpu_material import DisplaySettings, GPUMaterial
from ..brdf.scene import GEOMETRY_TYPES, _renders
from ..btf import drawer as btf_gpu
from ..btf import storage as btf_storage
from ..gpu import batches as mesh_batches
from ..gpu import shaders
from ..gpu.offscreen import Target
from ..gpu.state import spectral_draw_state
from ..lights import scene_lights
from ..prt import drawer as prt_gpu
from ..prt import scene as prt

_MATERIALS: dict[str, tuple] = {}
_HANDLE = None
_OCCLUDER_SHADER = None
#: Materials that failed to draw: name → (factor key, reason); shown in the panel and
#: not retried until their factors change.
FAILED: dict[str, tuple] = {}
#: Why the last viewport draw stopped (e.g. a light with an unusable SPD), or "".
VIEWPORT_ERROR = ""
#: What the last viewport draw drew (shown in the panel).
LAST_STATS = None


@dataclass
class DrawStats:
    """What one :func:`draw_objects` call drew."""

    objects: list[str] = field(default_factory=list)
    materials: list[str] = field(default_factory=list)
    variants: set = field(default_factory=set)
    triangles: int = 0
    texture_bytes: int = 0
    vertex_bytes: int = 0
    prt_objects: list[str] = field(default_factory=list)


def viewport_summary() -> str:
    """One line about the last viewport draw, for the panel ("" before the first)."""
    stats = LAST_STATS
    if stats is None:
        return ""
    return (f"{len(stats.objects)} objects, {len(stats.materials)} materials, "
            f"{len(stats.variants)} shader variants, "
            f"{(stats.texture_bytes + stats.vertex_bytes) / 1024:.0f} KiB on the GPU")


def failed_materials() -> list[tuple[str, str]]:
    """(what, reason) for materials the draw path refused and a stopped viewport draw."""
    out = [(name, reason) for name, (_, reason) in sorted(FAILED.items())]
    out += sorted(prt_gpu.FAILED.items()) + sorted(btf_gpu.FAILED.items())
    return out + ([("Viewport", VIEWPORT_ERROR)] if VIEWPORT_ERROR else [])


def _material_key(material) -> tuple | None:
    result = material.spectral.result
    if not material.spectral.enabled or result.image is None:
        return None
    return (result.image.name, result.input_hash, result.terms, result.spectral_size,
            result.image.size[0], result.image.size[1])


def gpu_material(material) -> GPUMaterial | None:
    """The cached :class:`GPUMaterial` of a material with stored factors (else None)."""
    key = _material_key(material)
    if key is None:
        return None
    cached = _MATERIALS.get(material.name)
    if cached is not None and cached[0] == key:
        return cached[1]
    if FAILED.get(material.name, (None,))[0] == key:
        return None
    try:
        resource = GPUMaterial(storage.load_factored(material))
    except ValueError as exc:
        FAILED[material.name] = (key, str(exc))
        print(f"Spectral Materials: not drawing '{material.name}': {exc}")
        return None
    _MATERIALS[material.name] = (key, resource)
    return resource


def _resource(material):
    """What draws ``material``: its factor packs, its BTF, or None (an occluder)."""
    if btf_storage.has_btf(material):
        return btf_gpu.btf_material(material)
    return gpu_material(material)


def _occluder_shader():
    global _OCCLUDER_SHADER
    if _OCCLUDER_SHADER is None:
        import gpu

        info = gpu.types.GPUShaderCreateInfo()
        info.push_constant("MAT4", "mvp")
        info.vertex_in(0, "VEC3", "position")
        info.fragment_out(0, "VEC4", "frag_colour")
        info.vertex_source("void main() { gl_Position = mvp * vec4(position, 1.0); }")
        info.fragment_source("void main() { frag_colour = vec4(0.0); }")
        _OCCLUDER_SHADER = gpu.shader.create_from_info(info)
    return _OCCLUDER_SHADER


def _column_major(matrix) -> list[float]:
    return [float(v) for v in np.asarray(matrix, dtype=np.float64).T.ravel()]


def set_matrix(shader, name: str, matrix) -> None:
    """Set a mat4 push constant; variants that do not read it have optimised it away."""
    try:
        shader.uniform_float(name, _column_major(matrix))
    except ValueError as exc:
        if "not found" not in str(exc):
            raise


def drawable_objects(scene, view_layer=None) -> list:
    view_layer = view_layer or scene.view_layers[0]
    return [o for o in scene.objects
            if o.type in GEOMETRY_TYPES and _renders(o, view_layer)]


def draw_objects(scene, depsgraph, view_projection: np.ndarray, view: View, *,
                 output: str = "DISPLAY", display: DisplaySettings | None = None,
                 lights: tuple | None = None, occluders: bool = True,
                 only: set[str] | None = None) -> DrawStats:
    """Draw the scene's factored materials into the bound framebuffer (depth test on).

    ``only`` names the materials to shade; the others are then drawn as occluders.
    """
    import gpu

    stats = DrawStats()
    toward_viewer = np.asarray(view.origin, dtype=np.float64)
    light_list, lights_key = lights or scene_lights.drawn_lights(scene, toward_viewer)
    display = display or scene_lights.display_settings(scene)
    vp = np.asarray(view_projection, dtype=np.float64)
    work = []                     # (object, batches, {slot: GPUMaterial or None})
    prt_objects = prt.prt_objects(scene) if only is None else []
    for obj in drawable_objects(scene):
        if obj in prt_objects:
            continue            # drawn below, by the PRT shaders
        slots = {i: _resource(s.material)
                 if s.material is not None and (only is None or s.material.name in only)
                 else None for i, s in enumerate(obj.material_slots)}
        if not occluders and not any(r is not None for r in slots.values()):
            continue
        batches = mesh_batches.object_batches(obj, depsgraph)
        if batches is not None:
            work.append((obj, batches, slots))
    if occluders:
        # Depth first, so that geometry we do not shade hides what lies behind it.
        shader = _occluder_shader()
        gpu.state.color_mask_set(False, False, False, False)
        try:
            for obj, batches, slots in work:
                shader.bind()
                shader.uniform_float("mvp", _column_major(vp @ np.array(obj.matrix_world)))
                for slot, batch in batches.batches.items():
                    if slots.get(slot) is None:
                        batch.draw(shader)
        finally:
            gpu.state.color_mask_set(True, True, True, True)
    for obj, batches, slots in work:
        model_matrix = np.array(obj.matrix_world)
        normal_matrix = np.linalg.inv(model_matrix).T if abs(np.linalg.det(model_matrix)) \
            > 1e-30 else np.eye(4)
        drawn_here = False
        for slot, batch in batches.batches.items():
            resource = slots.get(slot)
            if resource is None:
                continue
            key = resource.key(light_list, output=output)
            if isinstance(resource, btf_gpu.BTFMaterial):
                shader = btf_gpu.get_shader(key)
                # Held until the draw: a freed uniform buffer leaves the block unbound.
                params = resource.params(display, view.uniform(), vp)
                resource.bind(shader, resource.light_texture(light_list, lights_key), params)
            else:
                shader = shaders.get_shader(key)
                params = resource.params(display, view_origin=view.uniform(),
                                         view_projection=vp)
                resource.bind(shader, resource.light_texture(light_list, key.precontract,
                                                             lights_key), params)
            set_matrix(shader, "model_matrix", model_matrix)
            set_matrix(shader, "normal_matrix", normal_matrix)
            batch.draw(shader)
            drawn_here = True
            stats.variants.add(key)
            stats.triangles += len(batches.arrays.triangles[slot])
            name = obj.material_slots[slot].material.name
            if name not in stats.materials:
                stats.materials.append(name)
                stats.texture_bytes += resource.nbytes
        if drawn_here:
            stats.objects.append(obj.name)
            stats.vertex_bytes += batches.arrays.nbytes
    if prt_objects:
        prt_output = output if output in prt_gpu.PRT_OUTPUTS else "XYZ"
        stats.prt_objects = prt_gpu.draw_prt_objects(scene, depsgraph, vp, output=prt_output,
                                                     display=display, objects=prt_objects)
        stats.objects += stats.prt_objects
    return stats


def camera_view(camera, width: int, height: int, depsgraph) -> tuple[np.ndarray, View]:
    """(view-projection matrix, View) of a camera object for a width × height image."""
    render = depsgraph.scene.render
    projection = np.array(camera.calc_matrix_camera(
        depsgraph, x=width, y=height, scale_x=render.pixel_aspect_x,
        scale_y=render.pixel_aspect_y))
    world = np.array(camera.matrix_world)
    view_matrix = np.linalg.inv(world)
    if camera.data.type == "ORTHO":
        toward = world[:3, 2] / np.linalg.norm(world[:3, 2])
        view = View(tuple(toward), perspective=False)
    else:
        view = View(tuple(world[:3, 3]), perspective=True)
    return projection @ view_matrix, view


def render_camera(scene, *, width: int | None = None, height: int | None = None,
                  output: str = "XYZ", camera=None, only: set[str] | None = None
                  ) -> tuple[np.ndarray, DrawStats]:
    """Draw the scene from its camera offscreen: ((height, width, 4) float32, stats).

    Row 0 is the bottom. Size defaults to the scene's render resolution. Raises
    ValueError when the scene has no camera or nothing factored to draw.
    """
    camera = camera or scene.camera
    if camera is None or camera.type != "CAMERA":
        raise ValueError(f"Scene '{scene.name}' has no camera to render from")
    r = scene.render
    width = width or max(1, r.resolution_x * r.resolution_percentage // 100)
    height = height or max(1, r.resolution_y * r.resolution_percentage // 100)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view_projection, view = camera_view(camera, width, height, depsgraph)
    with Target(width, height) as target:
        stats = draw_objects(scene, depsgraph, view_projection, view, output=output,
                             only=only)
        image = target.read()
    if not stats.objects:
        raise ValueError(f"Scene '{scene.name}': no visible object has a factored spectral "
                         "material or a baked PRT transfer to draw (factor or bake first)")
    return image, stats


# ------------------------------------------------------------------- viewport handler


def _viewport_callback() -> None:
    context = bpy.context
    scene = context.scene
    region_data = context.region_data
    if scene is None or region_data is None or not scene.spectral.viewport_draw:
        return
    view_inverse = np.array(region_data.view_matrix.inverted())
    if region_data.is_perspective:
        view = View(tuple(view_inverse[:3, 3]), perspective=True)
    else:
        view = View(tuple(view_inverse[:3, 2] / np.linalg.norm(view_inverse[:3, 2])))
    global VIEWPORT_ERROR, LAST_STATS
    try:
        with spectral_draw_state():
            LAST_STATS = draw_objects(scene, context.evaluated_depsgraph_get(),
                                      np.array(region_data.perspective_matrix), view,
                                      occluders=False)
    except (ValueError, OSError) as exc:
        # A draw callback runs every redraw: report once, show it in the panel, go on.
        if str(exc) != VIEWPORT_ERROR:
            print(f"Spectral Materials: viewport drawing stopped: {exc}")
        VIEWPORT_ERROR = str(exc)
    else:
        VIEWPORT_ERROR = ""


def enable_viewport() -> None:
    """Add the draw handler (once)."""
    global _HANDLE
    if _HANDLE is None:
        _HANDLE = bpy.types.SpaceView3D.draw_handler_add(_viewport_callback, (), "WINDOW",
                                                         "POST_VIEW")


def disable_viewport() -> None:
    global _HANDLE
    if _HANDLE is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_HANDLE, "WINDOW")
        _HANDLE = None


def viewport_enabled() -> bool:
    return _HANDLE is not None


def redraw_viewports() -> None:
    wm = bpy.context.window_manager
    for window in getattr(wm, "windows", []):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


def reset() -> None:
    """Drop every GPU resource (textures, batches, shader variants)."""
    global VIEWPORT_ERROR, LAST_STATS
    VIEWPORT_ERROR = ""
    LAST_STATS = None
    _MATERIALS.clear()
    FAILED.clear()
    mesh_batches.clear_cache()
    shaders.clear_cache()
    prt_gpu.clear_cache()
    prt.clear_cache()
    btf_gpu.clear_cache()
    global _OCCLUDER_SHADER
    _OCCLUDER_SHADER = None


# GPU objects freed after Blender has torn its GPU context down crash the process at
# exit (seen with the bpy module): drop them first. atexit runs this before the
# exit handler Blender registered when bpy was imported.
atexit.register(reset)


@persistent
def _on_load_pre(*_args) -> None:
    disable_viewport()
    reset()


@persistent
def _on_load_post(*_args) -> None:
    if any(s.spectral.viewport_draw for s in bpy.data.scenes):
        enable_viewport()


@persistent
def _on_depsgraph_update(_scene, depsgraph) -> None:
    mesh_batches.note_depsgraph_updates(depsgraph)


_APP_HANDLERS = (("load_pre", _on_load_pre), ("load_post", _on_load_post),
                 ("depsgraph_update_post", _on_depsgraph_update))


def register() -> None:
    for name, function in _APP_HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if function not in handlers:
            handlers.append(function)
    if any(s.spectral.viewport_draw for s in getattr(bpy.data, "scenes", [])):
        enable_viewport()


def unregister() -> None:
    for name, function in _APP_HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if function in handlers:
            handlers.remove(function)
    disable_viewport()
    reset()
