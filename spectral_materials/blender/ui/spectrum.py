"""The reflectance-spectrum property group and its widget, shared by a factor-pack
material's spectra and a PRT object's albedo.

What a user types here is validated when a job starts (``brdf.sources``), not by hard
limits on the properties: a clamped slider would hide an absurd value, while a job
refuses it with a message that names it. Soft limits keep the sliders sensible.
"""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty, FloatProperty, StringProperty

from ...core.colour import spectra

SPECTRUM_KIND_ITEMS = [
    ("COLORCHECKER", "ColorChecker", "A patch of the ColorChecker (N Ohta measurements)"),
    ("CONSTANT", "Constant", "The same value at every wavelength"),
    ("TEXT", "Typed", "Values typed in: 'nm:value, nm:value, …', or values evenly spaced "
     "over 380–780 nm"),
    ("CSV", "CSV file", "Two columns: wavelength (nm), value"),
]


def _colorchecker_items() -> list[tuple[str, str, str]]:
    return [(str(i), f"{i:2d} {name}", f"ColorChecker patch {i}: {name}")
            for i, name in enumerate(spectra.colorchecker_names(), start=1)]


# Built once: Blender keeps no reference to items returned by a callback.
_COLORCHECKER_ITEMS = _colorchecker_items()


class SPECTRAL_PG_spectrum(bpy.types.PropertyGroup):
    """A reflectance-like spectrum: from the ColorChecker, a constant, typed in or a CSV."""

    kind: EnumProperty(name="Spectrum", items=SPECTRUM_KIND_ITEMS, default="COLORCHECKER",
                       description="Where the spectrum comes from")
    patch: EnumProperty(name="Patch", items=_COLORCHECKER_ITEMS, default="9",
                        description="ColorChecker patch (N Ohta reflectance, 380–780 nm)")
    constant: FloatProperty(name="Value", default=0.5, soft_min=0.0, soft_max=1.0,
                            precision=4, description="Value at every wavelength")
    text: StringProperty(name="Values", default="",
                         description="'nm:value, nm:value, …' or values evenly spaced over "
                                     "380–780 nm")
    filepath: StringProperty(name="CSV", subtype="FILE_PATH", default="",
                             description="CSV with two columns: wavelength (nm), value")


def draw_spectrum(layout, group: SPECTRAL_PG_spectrum, label: str) -> None:
    """A box with the spectrum's kind and the one setting that kind needs."""
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
