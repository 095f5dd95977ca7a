"""A light's spectral power distribution and power (``Light.spectral``).

What a user types here is validated when it is read (:func:`.spd.light_spd`), not by
hard limits: a clamped slider would hide an absurd value, while the reader refuses it
with a message that names it. Soft limits keep the sliders sensible.
"""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty, FloatProperty, PointerProperty, StringProperty

from ..ui.enums import ILLUMINANT_ITEMS

SPD_KIND_ITEMS = [
    ("ILLUMINANT", "CIE illuminant", "A CIE standard illuminant (A, D50, D65, FL1–FL12)"),
    ("BLACKBODY", "Blackbody", "Planck's law at a colour temperature"),
    ("TEXT", "Typed", "Values typed in: 'nm:value, …' or evenly spaced over 380–780 nm"),
    ("CSV", "CSV file", "Two columns: wavelength (nm), relative power"),
]


class SPECTRAL_PG_light(bpy.types.PropertyGroup):
    """A light's spectral power distribution and power."""

    kind: EnumProperty(name="SPD", items=SPD_KIND_ITEMS, default="ILLUMINANT",
                       description="Where the light's spectrum comes from")
    illuminant: EnumProperty(name="Illuminant", items=ILLUMINANT_ITEMS, default="D65",
                             description="CIE standard illuminant")
    temperature: FloatProperty(name="Temperature", default=6500.0, soft_min=1000.0,
                               soft_max=20000.0, subtype="TEMPERATURE",
                               description="Blackbody colour temperature in kelvin")
    text: StringProperty(name="Values", default="",
                         description="'nm:value, nm:value, …' or values evenly spaced over "
                                     "380–780 nm")
    filepath: StringProperty(name="CSV", subtype="FILE_PATH", default="",
                             description="CSV with two columns: wavelength (nm), power")
    power: FloatProperty(name="Power", default=1.0, soft_min=0.0, soft_max=100.0,
                         description="Scale on the normalised SPD (1 = a white Lambertian "
                                     "lit head-on reflects luminance 1)")
    plot: PointerProperty(type=bpy.types.Image, name="SPD plot",
                          description="Picture of the SPD shown in the Light panel")
    plot_key: StringProperty(description="Inputs the SPD plot was drawn from")


CLASSES = (SPECTRAL_PG_light,)
