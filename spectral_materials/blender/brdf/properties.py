"""A material's spectral BRDF: its source, the factorisation settings and the stored result
(``Material.spectral``).

What a user types here is validated when a job starts (see :mod:`.sources`), not by
hard limits on the properties: a clamped slider would hide an absurd value, while a
job refuses it with a message that names it. Soft limits keep the sliders sensible.
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

from ...core.brdf.filtered_factors import FACTOR_PRECISIONS
from ...core.brdf.params import PARAMETERIZATIONS
from ..ui.spectrum import SPECTRAL_PG_spectrum

MODEL_ITEMS = [
    ("LAMBERT", "Lambert", "Ideal diffuse reflector: albedo / π"),
    ("OREN_NAYAR", "Oren–Nayar", "Rough diffuse (Oren & Nayar 1994); σ is the facet slope "
     "deviation in radians"),
    ("ASHIKHMIN_SHIRLEY", "Ashikhmin–Shirley", "Anisotropic Phong with Fresnel "
     "(Ashikhmin & Shirley 2000): exponents nu, nv, diffuse Rd and specular Rs spectra"),
    ("WARD", "Ward", "Anisotropic Gaussian lobe (Ward 1992), roughness αx, αy"),
    ("GGX", "GGX microfacet", "Cook–Torrance with anisotropic GGX and a spectral complex "
     "index of refraction n + ik"),
]
#: Property enum identifier → core model registry name.
MODEL_KEYS = {"LAMBERT": "lambert", "OREN_NAYAR": "oren_nayar",
              "ASHIKHMIN_SHIRLEY": "ashikhmin_shirley", "WARD": "ward", "GGX": "ggx"}

#: The parameterisations offered, from the one list of them (core/brdf/params.py); the
#: isotropic variants are not offered: the BRDF chooses them. Identifiers are the names
#: upper-cased, in the list's order after "AUTO", so stored enum values stay where they were.
_OFFERED = [p for p in PARAMETERIZATIONS.values() if not p.isotropic]
PARAMETERIZATION_ITEMS = [
    ("AUTO", "Automatic", "Half/difference angles for anisotropic glossy models "
     "(Ashikhmin–Shirley, Ward, GGX), input/output angles otherwise; the isotropic 3-axis "
     "layout when the BRDF is isotropic"),
    *((p.name.upper(), p.label, p.summary) for p in _OFFERED),
]
#: The specular lobe settings (core/brdf/job.py LOBE_SETTINGS), identifiers upper-cased.
LOBE_ITEMS = [
    ("AUTO", "Automatic", "Fit each lobe family; keep the one that explains the material "
                          "best where the material has a lobe of that shape and the packs "
                          "measure better with it"),
    ("OFF", "Off", "Factor packs alone"),
    ("ASHIKHMIN_SHIRLEY", "Ashikhmin–Shirley", "Always fit and keep an Ashikhmin–Shirley "
                                               "specular lobe with free Fresnel spectra"),
    ("OREN_NAYAR", "Oren–Nayar", "Always fit and keep Oren–Nayar's back-scatter term (a "
                                 "rough surface's ridge at grazing) with a free spectrum"),
]
#: Whether a measured table's model is drawn in its cells (core/brdf/job.py CELL_SETTINGS).
CELL_ITEMS = [
    ("AUTO", "Automatic", "In the file's cells where its readers look pairs up in cells "
                          "(MERL), as the reference does; smooth otherwise"),
    ("CELLS", "Cells", "Evaluate at the centre of the file's cell each pair falls in, as "
                       "the file's readers look it up"),
    ("SMOOTH", "Smooth", "Interpolate smoothly between the tabulated angles"),
]
#: Property enum identifier → parameterisation name (sources.py resolves AUTO per BRDF).
PARAMETERIZATION_KEYS = {"AUTO": "io", **{p.name.upper(): p.name for p in _OFFERED}}


class SPECTRAL_PG_result(bpy.types.PropertyGroup):
    """What the last factorisation stored; written in one step by :mod:`.storage`."""

    image: PointerProperty(type=bpy.types.Image, name="Factor image",
                           description="Float image holding the factor packs and basis")
    plot: PointerProperty(type=bpy.types.Image, name="Error plot",
                          description="ΔE94 against packs, drawn when the factors were stored")
    parameterization: StringProperty(name="Parameterisation",
                                     description="Core parameterisation key of the factors")
    resolution: StringProperty(name="Resolution", description="Cells per axis, e.g. '32x64x32'")
    packs: IntProperty(name="Packs", min=0, description="Stored factor packs")
    terms: IntProperty(name="Terms", min=0, description="Rank-one terms in all packs")
    pack_size: IntProperty(name="Pack size", min=0, description="Terms per pack")
    spectral_size: IntProperty(name="Basis size", min=0,
                               description="Spectral coefficients per term")
    cosine_weighted: BoolProperty(name="Cosine weighted",
                                  description="The factors hold f·cosθi rather than f")
    edge: StringProperty(name="Edge rule", description="θ-end rule of the lookups")
    lobe: StringProperty(name="Analytic lobe",
                         description="The analytic lobe's family, empty when there is none "
                                     "(its exponents and spectra are ID properties)")
    de94_mean: FloatProperty(name="Mean ΔE94", precision=3,
                             description="Mean ΔE94 under D65 at the protocol's 20 000 random "
                                         "direction pairs, against the 5 nm reference")
    de94_p95: FloatProperty(name="95th percentile ΔE94", precision=3,
                            description="95th percentile of the same ΔE94 values")
    de94_max: FloatProperty(name="Max ΔE94", precision=3,
                            description="Largest of the same ΔE94 values")
    seconds: FloatProperty(name="Seconds", precision=2, unit="TIME_ABSOLUTE",
                           description="Wall time of tabulation and factorisation")
    nbytes: IntProperty(name="Bytes", description="Bytes of the stored factor arrays (float32)")
    input_hash: StringProperty(name="Input hash",
                               description="Hash of everything the factors depend on; a "
                                           "different hash means the factors are out of date")
    report_json: StringProperty(name="Report", description="The factorisation's full report "
                                                           "(JSON)")


#: The viewport's factor precisions (core/brdf/filtered_factors.py); descriptions quote
#: docs/bench_factor_precision.md.
DRAW_PRECISION_TEXT = {
    "exact": ("Exact", "Float32 factors interpolated in the shader: the reference path"),
    "unorm16": ("16-bit", "16-bit factors interpolated in the shader: half the bytes per "
                          "fetch; ΔE94 against exact 0.01–0.35 on the demo materials, "
                          "3.6 on a 16-pack anisotropic one"),
    "unorm16_filtered": ("16-bit, filtered", "16-bit factors filtered by the texture unit: "
                         "one fetch per axis; its 8-bit weights cost up to ΔE94 ~1 at "
                         "glossy peaks"),
    "half_filtered": ("Half float, filtered", "Half-float factors filtered by the texture "
                      "unit; relative precision, but terms that cancel near grazing "
                      "lose more than with 16-bit"),
}
DRAW_PRECISION_ITEMS = [
    ("AUTO", "Automatic", "The fastest precision whose ΔE94 against exact stays within 0.05 "
                          "on this material (measured when it is first drawn), else exact"),
    *[(p.upper(), *DRAW_PRECISION_TEXT[p]) for p in FACTOR_PRECISIONS]]


def _redraw_viewports(self, context) -> None:
    for window in getattr(context.window_manager, "windows", []):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


class SPECTRAL_PG_material(bpy.types.PropertyGroup):
    """A material's spectral BRDF source, factorisation settings and stored result."""

    enabled: BoolProperty(name="Spectral", default=False,
                          description="Describe this material spectrally and factor it")
    source: EnumProperty(
        name="Source", default="ANALYTIC",
        items=[("ANALYTIC", "Analytic model", "A BRDF model with spectra from the library"),
               ("FILE", "Data file", "A measured or tabulated BRDF: .npz (the project's "
                       "format), MERL .binary or RGL .bsdf")],
        description="Where the spectral BRDF comes from")
    model: EnumProperty(name="Model", items=MODEL_ITEMS, default="OREN_NAYAR",
                        description="Analytic BRDF model")
    sigma: FloatProperty(name="σ", default=0.3, soft_min=0.0, soft_max=1.5, precision=3,
                         description="Oren–Nayar roughness: slope standard deviation in "
                                     "radians, 0 = Lambert")
    nu: FloatProperty(name="nu", default=100.0, soft_min=1.0, soft_max=10000.0,
                      description="Ashikhmin–Shirley Phong exponent along the tangent")
    nv: FloatProperty(name="nv", default=100.0, soft_min=1.0, soft_max=10000.0,
                      description="Ashikhmin–Shirley Phong exponent along the bitangent")
    alpha_x: FloatProperty(name="αx", default=0.2, soft_min=0.01, soft_max=1.0, precision=3,
                           description="Roughness along the tangent (Ward, GGX)")
    alpha_y: FloatProperty(name="αy", default=0.2, soft_min=0.01, soft_max=1.0, precision=3,
                           description="Roughness along the bitangent (Ward, GGX)")
    diffuse: PointerProperty(type=SPECTRAL_PG_spectrum, name="Diffuse",
                             description="Diffuse reflectance (albedo) spectrum, in [0, 1]")
    specular: PointerProperty(type=SPECTRAL_PG_spectrum, name="Specular",
                              description="Specular reflectance spectrum, in [0, 1]")
    ior_n: PointerProperty(type=SPECTRAL_PG_spectrum, name="IOR n",
                           description="Real part of the refractive index (GGX)")
    ior_k: PointerProperty(type=SPECTRAL_PG_spectrum, name="IOR k",
                           description="Extinction coefficient (GGX); 0 for a dielectric")
    filepath: StringProperty(name="Data file", subtype="FILE_PATH", default="",
                             description="BRDF data: .npz (tabulated, see README), MERL "
                                       ".binary or RGL .bsdf")

    parameterization: EnumProperty(name="Parameterisation", items=PARAMETERIZATION_ITEMS,
                                   default="AUTO",
                                   description="Angular parameterisation of the table")
    theta_cells: IntProperty(name="θ cells", default=32, soft_min=8, soft_max=90,
                             description="Cells over 90° of elevation; the other axes "
                                         "scale with it (90 = the paper's 90×180×90). "
                                         "With the Automatic parameterisation they are "
                                         "doubled where the packs' error near the horizon "
                                         "asks for it and twice them is at most 64")
    use_target: BoolProperty(name="Target ΔE94", default=False,
                             description="Add packs until the mean ΔE94 reaches the target "
                                         "(up to 'Packs')")
    packs: IntProperty(name="Packs", default=4, soft_min=1, soft_max=64,
                       description="Factor packs to fit (the maximum with a target)")
    target_de94: FloatProperty(name="Target", default=0.5, soft_min=0.05, soft_max=5.0,
                               precision=2,
                               description="Mean ΔE94 (D65, protocol pairs) to stop at")
    pack_size: IntProperty(name="Pack size", default=4, soft_min=1, soft_max=8,
                           description="Rank-one terms per pack; 4 fill one RGBA texel")
    smoothing: IntProperty(name="Smoothing", default=0, soft_min=0, soft_max=9,
                           description="Moving-average width on the angular factors; 0 = off")
    specular_lobe: EnumProperty(
        name="Analytic lobe", items=LOBE_ITEMS, default="AUTO",
        description="An analytic lobe evaluated beside the factor packs, which then hold "
                    "only the rest: glossy highlights and a rough surface's grazing "
                    "back-scatter stay sharp at every angle")
    measured_cells: EnumProperty(
        name="Measured cells", items=CELL_ITEMS, default="AUTO",
        description="For a measured file: whether the viewport draws it in the file's own "
                    "cells, as the file's readers look it up (MERL: nearest cell), or "
                    "smoothly between them")
    draw_precision: EnumProperty(
        name="Factor precision", items=DRAW_PRECISION_ITEMS, default="EXACT",
        update=_redraw_viewports,
        description="How the spectral viewport stores and interpolates this material's "
                    "factors (the stored factors are not changed)")
    result: PointerProperty(type=SPECTRAL_PG_result, name="Result",
                            description="Stored factors and their measured figures")


CLASSES = (SPECTRAL_PG_result, SPECTRAL_PG_material)
