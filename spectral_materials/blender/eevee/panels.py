"""The EEVEE box in the material's Stored Factors panel (``brdf.panels``): whether the
node group is applied, for which key light and how well, and its buttons.

The box is a section of that panel rather than a panel of its own, so that it stays
where it was, above the Clear button; the package's ``register()`` adds it there."""

from __future__ import annotations

import bpy

from . import apply as eevee


def draw_eevee(layout, material) -> None:
    """The EEVEE box of ``material``."""
    box = layout.box()
    record = eevee.applied(material)
    box.prop(bpy.context.scene.spectral, "eevee_spectral_lights")
    box.prop(bpy.context.scene.spectral, "eevee_spectral_shadows")
    if record is None:
        box.label(text="EEVEE: not applied", icon="SHADING_RENDERED")
        box.operator("spectral.eevee_apply", icon="NODETREE")
        return
    lights = record.get("lights") or [record["light"]]
    box.label(text=f"EEVEE: spectral {', '.join(repr(n) for n in lights)} "
                   f"({record['working_space']})", icon="SHADING_RENDERED")
    box.label(text=f"{record['nodes']} nodes, {record['images']} texture(s)")
    de = record.get("de94")
    if de:
        box.label(text=f"Key light ΔE94 mean {de['mean']:.3f}, p95 {de['p95']:.3f}, "
                       f"max {de['max']:.3f} (5 nm)")
    row = box.row(align=True)
    row.operator("spectral.eevee_apply", text="Rebuild", icon="FILE_REFRESH")
    row.operator("spectral.eevee_remove", icon="X")


#: No panel classes: the box is drawn by ``brdf.panels.SPECTRAL_PT_material_result``.
CLASSES = ()
