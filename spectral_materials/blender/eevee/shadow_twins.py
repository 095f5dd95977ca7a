"""The twin lights through which the EEVEE node group reads a spectral light's own shadow.

A spectral light is excluded from lighting its material's objects (``apply.py``): the
node group adds its radiance as an Emission, which EEVEE does not shadow. To keep EEVEE's
shadow, each such light gets two twins, children of the light (so they follow it) with
its type, shape and shadow settings:

* both light only the material's objects (light linking), and only through the
  transmission class (diffuse, specular and volume factors 0), which the group's own
  Principled BSDF does not use; their ray visibility is transmission only, which is what
  keeps them out of Cycles' shading (Cycles ignores a light's factors);
* the *shadowed* twin is red and casts EEVEE's shadows; the *unshadowed* twin is green and
  casts none;
* their power is the light's (a driver, :data:`TWIN_GAIN`). The probe reading them
  (``shadow_nodes.py``) returns about 12 per unit of irradiance at its lobe's peak, far
  above what other lights add in its tail, and far below the 65504 where EEVEE's half
  floats would clip red and green alike (and so turn soft shadow edges hard);
* a point, spot or area twin reaches as far as the light does: EEVEE 5.0 and 5.2 size a
  light's reach from its diffuse and specular factors and drop a light whose reach is 0,
  so the twins carry the light's reach as a custom distance.

A twin is found as a child of its light carrying :data:`SHADOW_TWIN_KEY` (its role), so a
renamed light keeps its twins. Twins are shared by every material applied with the light
and removed with the last; :func:`sweep_twins` removes those whose light is gone.
"""

from __future__ import annotations

import math

import bpy

from ..lights.visibility import SHADOW_TWIN_KEY
from .drivers import follow

#: Twin power over the light's.
TWIN_GAIN = 1.0
TWIN_PREFIX = "SM shadow twin"
RECEIVERS_PREFIX = "SM shadow receivers of "
#: (role, colour, casts shadows): the probe's red is the shadowed twin, its green the other.
ROLES = (("shadowed", (1.0, 0.0, 0.0), True), ("unshadowed", (0.0, 1.0, 0.0), False))
#: Light settings a twin copies, driven where they are numbers (they move with the light).
SHAPE_SETTINGS = ("shadow_soft_size", "angle", "spot_size", "spot_blend", "size", "size_y",
                  "spread", "shadow_jitter_overblur", "shadow_filter_radius",
                  "shadow_maximum_resolution", "exposure")
#: Settings copied when applied (re-apply after changing them).
FLAG_SETTINGS = ("shape", "use_soft_falloff", "use_shadow_jitter", "use_square",
                 "use_absolute_resolution", "normalize")
#: Ray visibility a twin keeps: transmission only (EEVEE scales a light's power by these
#: too, so its probe still sees the twin).
HIDDEN_RAYS = ("visible_camera", "visible_diffuse", "visible_glossy", "visible_volume_scatter")


def twins_of(light_object) -> list:
    """The light's twin objects that exist (shadowed first)."""
    found = {child.get(SHADOW_TWIN_KEY): child for child in light_object.children
             if child.get(SHADOW_TWIN_KEY)}
    return [found[role] for role, _, _ in ROLES if role in found]


def ensure_twins(light_object, objects, scene) -> list:
    """Create or update the light's twins and add ``objects`` to their receivers
    (``scene``: whose EEVEE light threshold sizes a local light's reach)."""
    existing = twins_of(light_object)
    receivers = (existing[0].light_linking.receiver_collection if existing else None) \
        or bpy.data.collections.new(RECEIVERS_PREFIX + light_object.name)
    for obj in objects:
        if obj.name not in receivers.objects:
            receivers.objects.link(obj)
    twins = []
    for role, colour, shadow in ROLES:
        twin = _twin(light_object, role)
        data = twin.data
        data.color = colour
        data.diffuse_factor = data.specular_factor = data.volume_factor = 0.0
        data.transmission_factor = 1.0
        # A light the user keeps from casting shadows keeps its spectral term unshadowed.
        data.use_shadow = shadow and light_object.data.use_shadow
        _copy_reach(light_object.data, data, scene)
        twin.light_linking.receiver_collection = receivers
        twin.light_linking.blocker_collection = light_object.light_linking.blocker_collection
        for name in HIDDEN_RAYS:
            if hasattr(twin, name):
                setattr(twin, name, False)
        twins.append(twin)
    return twins


def release_twins(light_object, objects_still_needed: set[str]) -> None:
    """Keep only ``objects_still_needed`` as the twins' receivers; with none, delete the
    twins and their receiver collection."""
    twins = twins_of(light_object)
    receivers = twins[0].light_linking.receiver_collection if twins else None
    if objects_still_needed:
        for obj in list(receivers.objects) if receivers is not None else ():
            if obj.name not in objects_still_needed:
                receivers.objects.unlink(obj)
        return
    _delete(twins)


def sweep_twins() -> None:
    """Delete twins whose light is gone (deleted: the twin lost its parent)."""
    _delete([obj for obj in bpy.data.objects
             if obj.get(SHADOW_TWIN_KEY) and (obj.parent is None or obj.parent.type != "LIGHT")])


def _delete(twins: list) -> None:
    collections = {t.light_linking.receiver_collection for t in twins} - {None}
    for twin in twins:
        data = twin.data
        bpy.data.objects.remove(twin)
        if data.users == 0:
            bpy.data.lights.remove(data)
    for collection in collections:
        if not any(o.get(SHADOW_TWIN_KEY) and o.light_linking.receiver_collection == collection
                   for o in bpy.data.objects):
            bpy.data.collections.remove(collection)


def _twin(light_object, role: str):
    """The twin object ``role`` of the light, (re)made with the light's type and settings."""
    twin = next((t for t in twins_of(light_object) if t.get(SHADOW_TWIN_KEY) == role), None)
    source = light_object.data
    if twin is not None and twin.data.type != source.type:
        data = twin.data
        bpy.data.objects.remove(twin)
        bpy.data.lights.remove(data)
        twin = None
    if twin is None:
        name = f"{TWIN_PREFIX} {role} of {light_object.name}"
        data = bpy.data.lights.new(name, source.type)
        data[SHADOW_TWIN_KEY] = role
        twin = bpy.data.objects.new(name, data)
        twin[SHADOW_TWIN_KEY] = role
        for collection in light_object.users_collection:
            collection.objects.link(twin)
    twin.parent = light_object
    twin.matrix_parent_inverse.identity()
    twin.location, twin.rotation_euler, twin.scale = (0, 0, 0), (0, 0, 0), (1, 1, 1)
    twin.hide_select = True
    _copy_settings(source, twin.data)
    return twin


def _copy_settings(source, data) -> None:
    """Flags copied; numbers, and the power times :data:`TWIN_GAIN`, driven by the light."""
    for name in FLAG_SETTINGS:
        if hasattr(source, name) and hasattr(data, name):
            setattr(data, name, getattr(source, name))
    data.driver_remove("energy")
    follow(data, "energy", source, "energy", TWIN_GAIN)
    for name in SHAPE_SETTINGS:
        if hasattr(source, name) and hasattr(data, name):
            data.driver_remove(name)
            setattr(data, name, getattr(source, name))
            follow(data, name, source, name)


def _copy_reach(source, data, scene) -> None:
    """A point, spot or area twin's reach: the light's custom distance, or the radius
    EEVEE gives the light itself (where its influence falls below the scene's light
    threshold: √(max colour · power / 100 / threshold)), as a custom distance."""
    if not hasattr(data, "use_custom_distance") or source.type == "SUN":
        return
    if source.use_custom_distance:
        reach = source.cutoff_distance
    else:
        threshold = max(scene.eevee.light_threshold, 1e-6)
        power = max(source.color) * abs(source.energy) * TWIN_GAIN / 100.0
        reach = math.sqrt(power / threshold)
    data.use_custom_distance = True
    data.cutoff_distance = max(reach, 1e-3)

