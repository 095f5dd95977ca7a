"""PRT settings: the scene's spectral environment (``Scene.spectral.environment``) and an
object's PRT albedo and bake (``Object.spectral_prt``).

Changing what the environment or an object's albedo looks like redraws the viewport; the
drawer notices what changed. What a user types here is validated when it is read or
baked (:mod:`.scene`), not by hard limits on the properties.
"""

from __future__ import annotations

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ..ui.enums import ILLUMINANT_ITEMS
from ..ui.spectrum import SPECTRAL_PG_spectrum

ENVIRONMENT_SOURCE_ITEMS = [
    ("SKY", "CIE sky", "A CIE illuminant over a CIE standard general sky, optionally with a "
     "sun disc"),
    ("IMAGE", "HDR image", "An equirectangular RGB environment (HDR/EXR image datablock), "
     "uplifted to spectra (Smits 1999)"),
    ("SPECTRAL_EXR", "Spectral EXR", "An equirectangular spectral OpenEXR (emissive S0 "
     "layer, Fichet et al. 2021)"),
]
SKY_ITEMS = [
    ("OVERCAST", "Overcast", "CIE standard general sky type 1: steep gradation, no sun "
     "effect"),
    ("CLEAR", "Clear", "CIE standard clear sky (type 12), brightest around the sun"),
    ("UNIFORM", "Uniform", "The same radiance over the upper hemisphere"),
]
WINDOW_ITEMS = [
    ("NONE", "None", "The plain truncated series, the most accurate against the Monte Carlo "
     "reference (docs/bench_prt.md); the ringing of a sun is clipped where it would make "
     "a colour negative"),
    ("LANCZOS", "Lanczos", "Damps ringing, but also the low bands that carry most of a "
     "diffuse surface's irradiance"),
    ("HANNING", "Hanning", "Damps ringing more; a sun can still leave small negative lobes"),
    ("CESARO", "Cesàro", "Keeps every band-limited reconstruction of a non-negative light "
     "non-negative; blurs most, so shading is least accurate"),
]
ALBEDO_KIND_ITEMS = [
    ("SPECTRUM", "Spectrum", "One reflectance spectrum over the whole object"),
    ("CHART", "ColorChecker chart", "The 24 ColorChecker patches over the UV square, "
     "6 × 4, patch 1 top left"),
    ("IMAGE", "RGB image", "An image texture on the active UV map, uplifted to spectra "
     "(Smits 1999)"),
    ("SPECTRAL_EXR", "Spectral EXR", "A spectral OpenEXR texture (reflective T layer, "
     "Fichet et al. 2021) on the active UV map"),
]


def _redraw(self, context) -> None:
    from ..viewport import draw

    draw.redraw_viewports()


class SPECTRAL_PG_environment(bpy.types.PropertyGroup):
    """The spectral environment that lights PRT objects."""

    source: EnumProperty(name="Environment", items=ENVIRONMENT_SOURCE_ITEMS, default="SKY",
                         update=_redraw, description="Where the environment light comes from")
    illuminant: EnumProperty(name="Illuminant", items=ILLUMINANT_ITEMS, default="D65",
                             update=_redraw, description="The sky's spectrum")
    sky: EnumProperty(name="Sky", items=SKY_ITEMS, default="OVERCAST", update=_redraw,
                      description="CIE standard general sky luminance distribution")
    sun_fraction: FloatProperty(name="Sun", default=0.0, min=0.0, max=0.99, subtype="FACTOR",
                                update=_redraw,
                                description="Share of the horizontal irradiance from a sun "
                                            "disc (0 = none)")
    sun_elevation: FloatProperty(name="Sun elevation", default=0.7854, soft_min=0.01,
                                 soft_max=1.5708, subtype="ANGLE", update=_redraw,
                                 description="Sun height above the horizon")
    sun_azimuth: FloatProperty(name="Sun azimuth", default=0.0, subtype="ANGLE",
                               update=_redraw,
                               description="Sun direction about +Z, from +X toward +Y")
    image: PointerProperty(type=bpy.types.Image, name="Image", update=_redraw,
                           description="Equirectangular HDR/EXR image (Blender's world "
                                       "mapping)")
    filepath: StringProperty(name="Spectral EXR", subtype="FILE_PATH", default="",
                             update=_redraw,
                             description="Equirectangular spectral OpenEXR")
    rotation: FloatProperty(name="Rotation", default=0.0, subtype="ANGLE", update=_redraw,
                            description="Turn the environment about +Z (SH rotation: "
                                        "interactive)")
    bands: IntProperty(name="SH bands", default=5, min=1, soft_min=2, max=8, update=_redraw,
                       description="Spherical-harmonic bands of light and transfer (5 = 25 "
                                   "coefficients); changing it needs a new bake")
    window: EnumProperty(name="Window", items=WINDOW_ITEMS, default="NONE", update=_redraw,
                         description="Per-band window against ringing of sharp lights")
    basis_size: IntProperty(name="Spectral basis", default=8, min=1, max=16, update=_redraw,
                            description="Linear-model basis vectors for the PRT spectra "
                                        "(the paper uses 8)")


class SPECTRAL_PG_prt_object(bpy.types.PropertyGroup):
    """An object lit by the spectral environment through precomputed radiance transfer."""

    enabled: BoolProperty(name="Spectral PRT", default=False, update=_redraw,
                          description="Draw this object as a self-shadowed diffuse surface "
                                      "under the scene's spectral environment")
    albedo_kind: EnumProperty(name="Albedo", items=ALBEDO_KIND_ITEMS, default="SPECTRUM",
                              update=_redraw, description="Where the spectral albedo comes "
                                                          "from")
    albedo: PointerProperty(type=SPECTRAL_PG_spectrum, name="Albedo spectrum",
                            description="The reflectance spectrum of the whole object")
    image: PointerProperty(type=bpy.types.Image, name="Image", update=_redraw,
                           description="Albedo texture (linear or sRGB; read as reflectance)")
    filepath: StringProperty(name="Spectral EXR", subtype="FILE_PATH", default="",
                             update=_redraw, description="Spectral OpenEXR albedo texture")
    rays: IntProperty(name="Rays", default=256, min=1, soft_min=16, soft_max=4096,
                      description="Visibility rays per vertex of the transfer bake (half "
                                  "face away and cost nothing)")
    albedo_texture: EnumProperty(
        name="Albedo texture", default="AUTO", update=_redraw,
        description="How the spectral albedo is stored on the GPU and read per pixel "
                    "(core/prt/albedo_forms.py)",
        items=[("AUTO", "Automatic", "The fastest form on a GPU whose colours stay within "
                "ΔE94 0.05 of the exact layers under D65, FL11, A and the scene's light: "
                "16-bit layers, else the basis, else the exact layers"),
               ("UNORM16", "16-bit", "The R̃ layers as 16-bit integers over each value's "
                "range, filtered by the texture unit"),
               ("BASIS", "Basis", "A few weights per texel in a basis of the texture's own "
                "spectra, filtered by the texture unit (exact for RGB images, within ΔE94 "
                "0.05 otherwise, else the exact layers)"),
               ("EXACT", "Exact", "The R̃ layers as 32-bit floats filtered by hand: what "
                "the others are measured against")])
    albedo_image: PointerProperty(type=bpy.types.Image, name="Albedo layers",
                                  description="Stored R̃ layers (albedo × CMF on the PRT "
                                              "basis), one per basis vector, stacked")


CLASSES = (SPECTRAL_PG_environment, SPECTRAL_PG_prt_object)
