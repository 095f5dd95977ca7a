"""The twin lights through which the EEVEE node group reads a spectral light's own shadow.

A spectral light is excluded from lighting its material's objects (``apply.py``): the
node group adds its radiance as an Emission, which EEVEE does not shadow. To keep EEVEE's
shadow, each such light gets two twins, children of the light (so they follow it) with
its type, shape and shadow settings:

* both light only the material's objects (light linking), and only through the
  transmission class (diffuse, specular and volume factors 0), which the group's own
  Principled BSDF does not use;
* the *shadowed* twin is red and casts EEVEE's shadows; the *unshadowed* twin is green and
  casts none;
* their power is the light's (a driver, :data:`TWIN_GAIN`). The probe reading them
  (``shadow_nodes.py``) returns about 12 per unit of irradiance at its lobe's peak, far
  above what other lights add in its tail, and far below the 65504 where EEVEE's half
  floats would clip red and green alike (and so turn soft shadow edges hard).

Twins are shared by every material applied with the light and removed with the last.
"""

from __future__ import annotations

import bpy

from ..lights.visibility import SHADOW_TWIN_KEY

#: Twin power over the light's.
TWIN_GAIN = 1.0
TWIN_PREFIX = "SM shadow twin"
RECEIVERS_PREFIX = "SM shadow receivers of "
#: (role, colour, casts shadows): the probe's red is the shadowed twin, its green the other.
ROLES = (("shadowed", (1.0, 0.0, 0.0), True), ("unshadowed", (0.0, 1.0, 0.0), False))
#: Light settings a twin copies, driven where they are numbers (they move with the light).
SHAPE_SETTINGS = ("shadow_soft_size", "angle", "spot_size", "spot_blend", "size", "size_y",
                  "spread",
                  "shadow_jitter_overblur", "shadow_filter_radius",
                  "shadow_maximum_resolution", "shadow_resolution_limit")
FLAG_SETTINGS = ("shape", "use_soft_falloff", "use_shadow_jitter", "use_square")


def twin_name(light_object, role: str) -> str:
    return f"{TWIN_PREFIX} {role} of {light_object.name}"


def twins_of(light_object) -> list:
    """The light's twin objects that exist (shadowed first)."""
    return [obj for role, _, _ in ROLES
            if (obj := bpy.data.objects.get(twin_name(light_object, role))) is not None]


def ensure_twins(light_object, objects) -> list:
    """Create or update the light's twins and add ``objects`` to their receivers."""
    receivers = _receivers(light_object)
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
        twin.light_linking.receiver_collection = receivers
        twins.append(twin)
    return twins


def release_twins(light_object, objects_still_needed: set[str]) -> None:
    """Keep only ``objects_still_needed`` as the twins' receivers; with none, delete the
    twins and their receiver collection."""
    receivers = bpy.data.collections.get(RECEIVERS_PREFIX + light_object.name)
    if objects_still_needed and receivers is not None:
        for obj in list(receivers.objects):
            if obj.name not in objects_still_needed:
                receivers.objects.unlink(obj)
        return
    for twin in twins_of(light_object):
        data = twin.data
        bpy.data.objects.remove(twin)
        if data.users == 0:
            bpy.data.lights.remove(data)
    if receivers is not None:
        bpy.data.collections.remove(receivers)


def _receivers(light_object):
    name = RECEIVERS_PREFIX + light_object.name
    return bpy.data.collections.get(name) or bpy.data.collections.new(name)


def _twin(light_object, role: str):
    """The twin object ``role`` of the light, (re)made with the light's type and settings."""
    name = twin_name(light_object, role)
    twin = bpy.data.objects.get(name)
    source = light_object.data
    if twin is not None and twin.data.type != source.type:
        data = twin.data
        bpy.data.objects.remove(twin)
        bpy.data.lights.remove(data)
        twin = None
    if twin is None:
        data = bpy.data.lights.new(name, source.type)
        data[SHADOW_TWIN_KEY] = True
        twin = bpy.data.objects.new(name, data)
        twin[SHADOW_TWIN_KEY] = True
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
    _drive(data, "energy", source, "energy", f"v * {TWIN_GAIN!r}")
    for name in SHAPE_SETTINGS:
        if hasattr(source, name) and hasattr(data, name):
            data.driver_remove(name)
            setattr(data, name, getattr(source, name))
            _drive(data, name, source, name, "v")


def _drive(data, name: str, source, source_name: str, expression: str) -> None:
    driver = data.driver_add(name).driver
    driver.type = "SCRIPTED"
    var = driver.variables.new()
    var.name = "v"
    var.type = "SINGLE_PROP"
    var.targets[0].id_type = "LIGHT"
    var.targets[0].id = source
    var.targets[0].data_path = source_name
    driver.expression = expression
