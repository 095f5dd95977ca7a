"""The viewport draw handler and offscreen scene renders, over the registered drawers.

:func:`draw_objects` draws every visible object through the drawers the capabilities
registered (:mod:`.registry`): object drawers take whole objects (PRT), material drawers
the slots whose material they claim (BTF, factor packs), with the scene's lights
(``lights.scene_lights``). Geometry no drawer shades is drawn into the depth buffer only,
so that it hides what is behind it. The viewport draw handler (``SpaceView3D``,
``POST_VIEW``, depth-tested against Blender's own drawing) and :func:`render_camera` (an
RGBA32F offscreen from the scene camera) both call it. This module imports no drawer.

Caches: shader variants (``gpu.shaders``), batches per object (``gpu.batches``, rebuilt
when geometry changes) and each drawer's own. :func:`reset` drops them all; it runs on
file load and on unregister, which also remove the handler.
"""

from __future__ import annotations

import atexit
from dataclasses import dataclass, field

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..._moved import forward_names
from ...core.brdf.shading import View
from ..gpu import batches as mesh_batches, shaders
from ..gpu.display import DisplaySettings
from ..gpu.matrices import normal_matrix, set_matrix
from ..gpu.offscreen import Target
from ..gpu.state import spectral_draw_state
from ..lights import scene_lights
from ..lights.visibility import GEOMETRY_TYPES, renders
from . import registry
from .occluders import clear_cache as _clear_occluder_shader, draw_occluders
from .registry import DrawFrame

__all__ = ["DrawStats", "camera_view", "disable_viewport", "draw_objects", "drawable_objects",
           "enable_viewport", "failed_materials", "redraw_viewports", "register",
           "render_camera", "reset", "set_matrix", "unregister", "viewport_enabled",
           "viewport_summary"]

_HANDLE = None
#: Why the last viewport draw stopped (e.g. a light with an unusable SPD), or "".
VIEWPORT_ERROR = ""
#: What the last viewport draw drew (shown in the panel).
LAST_STATS = None
#: Names that left this module for a drawer: name → module relative to ``blender``.
# Names that moved to the factor-pack drawer, served from here for one release.
__getattr__ = forward_names(__name__, dict.fromkeys(("gpu_material", "FAILED", "_MATERIALS"),
                                                 "blender.brdf.drawer"))


@dataclass
class DrawStats:
    """What one :func:`draw_objects` call drew."""

    objects: list[str] = field(default_factory=list)
    materials: list[str] = field(default_factory=list)
    variants: set = field(default_factory=set)
    triangles: int = 0
    texture_bytes: int = 0
    vertex_bytes: int = 0
    #: Objects each object drawer drew whole: drawer name → object names.
    drawn_whole: dict[str, list[str]] = field(default_factory=dict)


def viewport_summary() -> str:
    """One line about the last viewport draw, for the panel ("" before the first)."""
    stats = LAST_STATS
    if stats is None:
        return ""
    return (f"{len(stats.objects)} objects, {len(stats.materials)} materials, "
            f"{len(stats.variants)} shader variants, "
            f"{(stats.texture_bytes + stats.vertex_bytes) / 1024:.0f} KiB on the GPU")


def failed_materials() -> list[tuple[str, str]]:
    """(what, reason) for what the drawers refused and a stopped viewport draw."""
    out = registry.failures()
    return out + ([("Viewport", VIEWPORT_ERROR)] if VIEWPORT_ERROR else [])


def drawable_objects(scene, view_layer=None) -> list:
    """The scene's visible, renderable objects with geometry."""
    view_layer = view_layer or scene.view_layers[0]
    return [o for o in scene.objects
            if o.type in GEOMETRY_TYPES and renders(o, view_layer)]


def _slot_resource(material, only: set[str] | None):
    """(drawer, resource) drawing ``material``, or None: an occluder."""
    if material is None or (only is not None and material.name not in only):
        return None
    drawer = registry.claiming_drawer(material)
    resource = drawer.resource(material) if drawer is not None else None
    return None if resource is None else (drawer, resource)


def _slot_work(scene, depsgraph, taken: list, only, occluders_too: bool) -> list:
    """(object, batches, {slot: (drawer, resource) or None}) of the objects drawn by slot."""
    work = []
    for obj in drawable_objects(scene):
        if obj in taken:
            continue            # drawn whole, by its object drawer
        slots = {i: _slot_resource(s.material, only) for i, s in enumerate(obj.material_slots)}
        if not occluders_too and not any(r is not None for r in slots.values()):
            continue
        batches = mesh_batches.object_batches(obj, depsgraph)
        if batches is not None:
            work.append((obj, batches, slots))
    return work


def _draw_slots(work: list, frame: DrawFrame, stats: DrawStats) -> None:
    for obj, batches, slots in work:
        model_matrix = np.array(obj.matrix_world)
        normals = normal_matrix(model_matrix)
        drawn_here = False
        for slot, batch in batches.batches.items():
            if slots.get(slot) is None:
                continue
            drawer, resource = slots[slot]
            bound = drawer.bind(resource, frame)
            set_matrix(bound.shader, "model_matrix", model_matrix)
            set_matrix(bound.shader, "normal_matrix", normals)
            batch.draw(bound.shader)
            drawn_here = True
            stats.variants.add(bound.key)
            stats.triangles += len(batches.arrays.triangles[slot])
            name = obj.material_slots[slot].material.name
            if name not in stats.materials:
                stats.materials.append(name)
                stats.texture_bytes += resource.nbytes
        if drawn_here:
            stats.objects.append(obj.name)
            stats.vertex_bytes += batches.arrays.nbytes


def draw_objects(scene, depsgraph, view_projection: np.ndarray, view: View, *,
                 output: str = "DISPLAY", display: DisplaySettings | None = None,
                 lights: tuple | None = None, occluders: bool = True,
                 only: set[str] | None = None) -> DrawStats:
    """Draw the scene's drawable objects into the bound framebuffer (depth test on).

    ``only`` names the materials to shade; the others are then drawn as occluders and
    no object drawer draws.
    """
    stats = DrawStats()
    toward_viewer = np.asarray(view.origin, dtype=np.float64)
    light_list, lights_key = lights or scene_lights.drawn_lights(scene, toward_viewer)
    frame = DrawFrame(np.asarray(view_projection, dtype=np.float64), view, light_list,
                      lights_key, display or scene_lights.display_settings(scene), output)
    whole = [(d, d.objects(scene)) for d in registry.object_drawers()] if only is None else []
    taken = [obj for _, objects in whole for obj in objects]
    work = _slot_work(scene, depsgraph, taken, only, occluders)
    if occluders:
        # Depth first, so that geometry we do not shade hides what lies behind it.
        draw_occluders(work, frame.view_projection)
    _draw_slots(work, frame, stats)
    for drawer, objects in whole:
        if objects:
            drawn = drawer.draw(scene, depsgraph, objects, frame)
            stats.drawn_whole[drawer.name] = drawn
            stats.objects += drawn
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
    """Drop every GPU resource (each drawer's, batches, shader variants)."""
    global VIEWPORT_ERROR, LAST_STATS
    VIEWPORT_ERROR = ""
    LAST_STATS = None
    registry.clear_caches()
    mesh_batches.clear_cache()
    shaders.clear_cache()
    _clear_occluder_shader()


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
