"""A spectral light's visibility, EEVEE's own shadow, read in the node group.

EEVEE tells a node tree about the lights only through Shader to RGB, which sums every
light reaching a closure. The light's two twins (``shadow_twins.py``) reach only
transmission closures, which the group's Principled BSDF does not have. So a Refraction
BSDF *probe* read through Shader to RGB sees, in red, the shadowed twin and, in green,
the unshadowed one, each times the same lobe response; their ratio is the light's
visibility, soft shadow edges included. Blue, which no twin has, stands for what the
user's own lights and the world add to the probe and is taken off both: exact for grey
light; a coloured light (each light's colour is its SPD's) leaves its colour's
difference, which the aim keeps small: such a light reaches the probe through the lobe's
tail, its own twins through its peak (``tests/blender/eevee/test_eevee_shadows.py``
holds a shadow under an FL2 sun left to RGB).

The probe's normal is aimed so that its (rough, narrow) lobe peaks towards the light:
its own twins then stand far above other lights' twins, which fall in the lobe's tail.
With the material output's thickness 0 (a thin sheet) EEVEE's lobe peaks where the probe
normal is −normalize(η·l + v), η the probe's IOR, l towards the light, v towards the
viewer: the refraction half vector (measured on Blender 5.0, 5.2 and 5.3 by
``scripts/check_eevee_light_visibility.py``, ``docs/eevee_light_visibility.md``). Where
the probe sees nothing of the twins (a light behind the lobe, or Cycles, which has no
Shader to RGB) the light counts as visible: its radiance is unshadowed, as without the
probe.

Blender 4.5 gives a thin probe no light at all, so there the probe keeps EEVEE's own
thickness (:func:`thin_probes`), through which it sees its twins too, with the same
aim. (A scene made by ``bpy.data.scenes.new`` in 4.5 has EEVEE's *Shadows* off, unlike
the startup file's: no light casts a shadow there, twins included.)
"""

from __future__ import annotations

import bpy

PROBE_IOR = 1.5
#: Roughness of the probe's lobe: aiming errors of a degree cost little, while lights
#: 10° apart differ by about 100× in response.
PROBE_ROUGHNESS = 0.5
#: Below this twin response (green − blue) the probe saw no twin: visible. The aimed
#: probe returns about 12 per unit of the twin's irradiance.
MIN_RESPONSE = 1e-3


def thin_probes() -> bool:
    """Whether the probes are thin sheets (the material output's thickness 0): Blender
    5.0 and later. Blender 4.5 gives a thin refraction closure no light."""
    return bpy.app.version >= (5, 0, 0)


def light_visibility(g, wi_world, view, column: int, label: str):
    """The light's visibility in [0, 1] from its probe (``g``: the group's Graph)."""
    g.begin(f"{label}: EEVEE shadow (twin lights through a refraction probe)")
    towards = g.vmath("ADD", g.vmath("SCALE", wi_world, scale=PROBE_IOR, column=column),
                      view, column=column)
    normal = g.vmath("SCALE", g.vmath("NORMALIZE", towards, column=column + 1), scale=-1.0,
                     column=column + 2, label="probe normal")
    probe = g.node("ShaderNodeBsdfRefraction", column + 3, "probe")
    probe.inputs["IOR"].default_value = PROBE_IOR
    probe.inputs["Roughness"].default_value = PROBE_ROUGHNESS
    g.tree.links.new(normal, probe.inputs["Normal"])
    to_rgb = g.node("ShaderNodeShaderToRGB", column + 4, "probe's light")
    g.tree.links.new(probe.outputs[0], to_rgb.inputs[0])
    red, green, blue = g.separate(to_rgb.outputs[0], column=column + 5)
    shadowed = g.math("SUBTRACT", red, blue, column=column + 6, label="shadowed twin")
    unshadowed = g.math("SUBTRACT", green, blue, column=column + 6, label="unshadowed twin")
    seen = g.math("GREATER_THAN", unshadowed, MIN_RESPONSE, column=column + 7)
    ratio = g.math("DIVIDE", shadowed, g.math("MAXIMUM", unshadowed, MIN_RESPONSE,
                                              column=column + 7), column=column + 8)
    ratio = g.math("MINIMUM", g.math("MAXIMUM", ratio, 0.0, column=column + 8), 1.0,
                   column=column + 8)
    return g.math("MULTIPLY_ADD", seen, g.math("SUBTRACT", ratio, 1.0, column=column + 9),
                  1.0, column=column + 9, label="visibility")
