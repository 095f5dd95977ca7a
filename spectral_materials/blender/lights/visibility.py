"""Which objects of a scene render: visible in the view layer and not hidden from renders.

The drawers, the factor-pack scene analysis and the PRT objects all ask the same
question; the lights that reach the scene (:func:`scene_lights`) are the renderable
lights with power.
"""

from __future__ import annotations

#: ID property marking the EEVEE path's shadow twins (``blender/eevee/shadow_twins.py``):
#: helper lights that no spectral path draws or counts.
SHADOW_TWIN_KEY = "sm_shadow_twin"
GEOMETRY_TYPES = {"MESH", "CURVE", "CURVES", "SURFACE", "META", "FONT", "POINTCLOUD", "VOLUME"}


def renders(obj, view_layer) -> bool:
    """Whether ``obj`` is visible in ``view_layer`` and not hidden from renders."""
    try:
        visible = obj.visible_get(view_layer=view_layer)
    except (RuntimeError, TypeError):
        visible = not obj.hide_get()
    return visible and not obj.hide_render


def scene_lights(scene, view_layer=None) -> tuple[list, list[str]]:
    """(light objects that reach the scene, names of those left out and why)."""
    view_layer = view_layer or scene.view_layers[0]
    reaching, left_out = [], []
    for obj in sorted((o for o in scene.objects if o.type == "LIGHT"), key=lambda o: o.name):
        if obj.get(SHADOW_TWIN_KEY):
            continue
        if not renders(obj, view_layer):
            left_out.append(f"{obj.name} (hidden)")
        elif obj.data.energy <= 0 or obj.data.spectral.power <= 0:
            left_out.append(f"{obj.name} (no power)")
        else:
            reaching.append(obj)
    return reaching, left_out
