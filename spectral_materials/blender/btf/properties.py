"""Where a material's BTF comes from and how it is fitted (``Material.spectral_btf``).

Only the tile's repeat redraws the viewport at once; the other settings take effect
when the BTF is fitted again (``spectral.fit_btf``), which validates them.
"""

from __future__ import annotations

import bpy
from bpy.props import EnumProperty, FloatVectorProperty, IntProperty, StringProperty

BTF_SOURCE_ITEMS = [
    ("CORDUROY", "Corduroy (generated)", "Procedural corduroy: ridges and deep grooves, two "
                                         "dyes, rendered with self-shadowing and masking"),
    ("KNIT", "Knit (generated)", "Procedural knitted wool bumps"),
    ("STONES", "Stones (generated)", "Procedural glossy cobbles in mortar"),
    ("UBO2003", "UBO2003 archive", "Bonn BTF database zip of 81 × 81 JPEG images"),
    ("UBO2014", "UBO2014 file", "Bonn BTF database .btf (SVD-compressed, 151 × 151)"),
]
BTF_MODEL_ITEMS = [
    ("RFNL", "Lobes (RFNL)", "Per view: ρd + Σ a·max(t̂·l, 0)^n, Levenberg–Marquardt (the "
                             "paper's non-linear reflectance field)"),
    ("RFP", "Polynomial (RFP)", "Per view: biquadratic in the light direction, linear least "
                                "squares (fast; blurs highlights)"),
]


def _redraw(self, context) -> None:
    from ..viewport import draw

    draw.redraw_viewports()


class SPECTRAL_PG_btf(bpy.types.PropertyGroup):
    """Where a material's BTF comes from and how it is fitted (Fit BTF stores the result)."""

    source: EnumProperty(name="Source", items=BTF_SOURCE_ITEMS, default="CORDUROY",
                         description="The BTF to fit")
    filepath: StringProperty(name="File", subtype="FILE_PATH", default="",
                             description="UBO2003 zip or UBO2014 .btf")
    texels: IntProperty(name="Texels", default=32, min=1, soft_min=4, soft_max=128,
                        description="Generated: texels per side. Files: the side of the "
                                    "window cropped from the sample's corner (0 = all)")
    model: EnumProperty(name="Model", items=BTF_MODEL_ITEMS, default="RFNL",
                        description="Reflectance-field model fitted per measured view")
    lobes: IntProperty(name="Lobes", default=2, min=1, max=3,
                       description="RFNL lobes per view")
    uv_scale: FloatVectorProperty(name="Repeat", size=2, default=(4.0, 4.0), min=1e-3,
                                  soft_max=64.0, update=_redraw,
                                  description="How often the BTF tile repeats across the "
                                              "UV square")


CLASSES = (SPECTRAL_PG_btf,)
