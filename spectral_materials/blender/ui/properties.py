"""Property groups: a material's spectral source and settings, a light's SPD, scene options.

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
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ...core.colour import spectra

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

PARAMETERIZATION_ITEMS = [
    ("AUTO", "Automatic", "Half/difference angles for anisotropic glossy models "
     "(Ashikhmin–Shirley, Ward, GGX), input/output angles otherwise; the isotropic 3-axis "
     "layout when the BRDF is isotropic"),
    ("IO", "Input/output angles", "(θi, φi, θo, φo); (θi, φo−φi, θo) when isotropic"),
    ("HD", "Half/difference", "Rusinkiewicz (θh, φh, θd, φd), θh square-root warped; "
     "best for sharp highlights"),
    ("GS", "Gram–Schmidt half vector", "Kautz–McCool's half-vector frame"),
    ("EA", "Elevation/azimuth", "Elevation/azimuth of both directions"),
]
PARAMETERIZATION_KEYS = {"AUTO": "io", "IO": "io", "HD": "hd", "GS": "gs", "EA": "ea"}

SPECTRUM_KIND_ITEMS = [
    ("COLORCHECKER", "ColorChecker", "A patch of the ColorChecker (N Ohta measurements)"),
    ("CONSTANT", "Constant", "The same value at every wavelength"),
    ("TEXT", "Typed", "Values typed in: 'nm:value, nm:value, …', or values evenly spaced "
     "over 380–780 nm"),
    ("CSV", "CSV file", "Two columns: wavelength (nm), value"),
]
ILLUMINANT_ITEMS = [(name, name, f"CIE standard illuminant {name}")
                    for name in spectra.ILLUMINANT_NAMES]
SPD_KIND_ITEMS = [
    ("ILLUMINANT", "CIE illuminant", "A CIE standard illuminant (A, D50, D65, FL1–FL12)"),
    ("BLACKBODY", "Blackbody", "Planck's law at a colour temperature"),
    ("TEXT", "Typed", "Values typed in: 'nm:value, …' or evenly spaced over 380–780 nm"),
    ("CSV", "CSV file", "Two columns: wavelength (nm), relative power"),
]
OBSERVER_ITEMS = [
    ("CIE_1931_2", "CIE 1931 2°", "The 2° standard observer (the measurement protocol's)"),
    ("CIE_1964_10", "CIE 1964 10°", "The 10° supplementary standard observer"),
]
OBSERVER_NAMES = {"CIE_1931_2": "CIE 1931 2 Degree Standard Observer",
                  "CIE_1964_10": "CIE 1964 10 Degree Standard Observer"}
TONE_MAP_ITEMS = [
    ("SIGMOID", "Sigmoid", "Extended Reinhard curve; values up to 'White' map to display white"),
    ("CLIP", "Clip", "No tone mapping: linear sRGB clipped to [0, 1]"),
]


def _colorchecker_items() -> list[tuple[str, str, str]]:
    return [(str(i), f"{i:2d} {name}", f"ColorChecker patch {i}: {name}")
            for i, name in enumerate(spectra.colorchecker_names(), start=1)]


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
                                         "scale with it (90 = the paper's 90×180×90)")
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
    result: PointerProperty(type=SPECTRAL_PG_result, name="Result",
                            description="Stored factors and their measured figures")


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


def _viewport_draw_changed(self, context) -> None:
    from ..viewport import draw

    if self.viewport_draw:
        draw.enable_viewport()
    elif not any(s.spectral.viewport_draw for s in bpy.data.scenes):
        draw.disable_viewport()
    draw.redraw_viewports()


def _redraw(self, context) -> None:
    from ..viewport import draw

    draw.redraw_viewports()


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
    albedo_image: PointerProperty(type=bpy.types.Image, name="Albedo layers",
                                  description="Stored R̃ layers (albedo × CMF on the PRT "
                                              "basis), one per basis vector, stacked")


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


class SPECTRAL_PG_scene(bpy.types.PropertyGroup):
    """Scene-wide colour options and the shared spectral basis."""

    viewport_draw: BoolProperty(name="Spectral Viewport", default=False,
                                update=_viewport_draw_changed,
                                description="Draw objects with factored materials through the "
                                            "spectral shaders, lit by the scene's lights")
    observer: EnumProperty(name="Observer", items=OBSERVER_ITEMS, default="CIE_1931_2",
                           description="Colour matching functions for every XYZ")
    adaptation_white: EnumProperty(name="Adaptation white", items=ILLUMINANT_ITEMS,
                                   default="D65", update=_redraw,
                                   description="Scene white the display adapts from "
                                               "(Bradford) before sRGB")
    tone_mapping: EnumProperty(name="Tone mapping", items=TONE_MAP_ITEMS, default="SIGMOID",
                               update=_redraw,
                               description="Curve from linear sRGB to the display")
    tone_white: FloatProperty(name="White", default=4.0, soft_min=1.0, soft_max=64.0,
                              update=_redraw,
                              description="Linear value that maps to display white (sigmoid)")
    basis_tolerance: FloatProperty(name="Basis tolerance", default=0.05, soft_min=0.001,
                                   soft_max=1.0, precision=3,
                                   description="Largest ΔE94 the spectral basis may cost any "
                                               "light × material pair, against 5 nm")
    basis_max_size: IntProperty(name="Max basis size", default=16, soft_min=1, soft_max=32,
                                description="Upper bound on basis coefficients")
    basis_size: IntProperty(name="Basis size", min=0,
                            description="Coefficients of the stored scene basis (0 = none)")
    basis_max_de94: FloatProperty(name="Basis max ΔE94", precision=4,
                                  description="Worst light × material ΔE94 of the basis")
    analysis: StringProperty(name="Scene analysis",
                             description="What the last scene analysis kept and left out")
    analysis_json: StringProperty(description="The last scene analysis (JSON)")
    environment: PointerProperty(type=SPECTRAL_PG_environment, name="Environment",
                                 description="The spectral environment of PRT objects")


class SPECTRAL_PG_job(bpy.types.PropertyGroup):
    """State of the running job, shown as a progress bar (not saved meaningfully)."""

    running: BoolProperty(default=False)
    fraction: FloatProperty(default=0.0, min=0.0, max=1.0, subtype="FACTOR")
    message: StringProperty(default="")


CLASSES = (
    SPECTRAL_PG_spectrum,
    SPECTRAL_PG_result,
    SPECTRAL_PG_material,
    SPECTRAL_PG_light,
    SPECTRAL_PG_environment,
    SPECTRAL_PG_prt_object,
    SPECTRAL_PG_btf,
    SPECTRAL_PG_scene,
    SPECTRAL_PG_job,
)

_POINTERS = (
    (bpy.types.Material, "spectral", SPECTRAL_PG_material),
    (bpy.types.Light, "spectral", SPECTRAL_PG_light),
    (bpy.types.Scene, "spectral", SPECTRAL_PG_scene),
    (bpy.types.Object, "spectral_prt", SPECTRAL_PG_prt_object),
    (bpy.types.Material, "spectral_btf", SPECTRAL_PG_btf),
    (bpy.types.WindowManager, "spectral_job", SPECTRAL_PG_job),
)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    for owner, name, group in _POINTERS:
        setattr(owner, name, PointerProperty(type=group))


def unregister() -> None:
    for owner, name, _group in reversed(_POINTERS):
        delattr(owner, name)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
