"""Shader variants: the GLSL in ``glsl/`` assembled through ``gpu.shader.create_from_info``.

A :class:`ShaderKey` is everything a variant is compiled with (``#define``s): the
geometry (mesh or the protocol sphere), the parameterisation, the axis count, the
packs drawn, the spectral size, the light count and types, the spectral mode and
the output. Only what the key names is compiled in; :func:`get_shader` caches one
shader per key, so a variant is rebuilt only when the scene's needs change.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ...core.brdf.axes import EDGE_RULES
from ...core.brdf.filtered_factors import FACTOR_PRECISIONS, PRECISION_TEXELS
from ...core.brdf.lobe import DENOMINATOR_FLOOR, LOBE_FAMILIES
from ...core.brdf.measured_cells import MIN_CENTRE_COSINE
from ...core.brdf.params import PARAMETERIZATIONS, get_parameterization
from ...core.brdf.shading import LOBE_TEXELS, light_row_texels
from ...core.lights import LIGHT_CODES
from .outputs import SURFACE_REQUESTS, output_defines

GLSL_DIR = Path(__file__).resolve().parents[3] / "glsl"

#: ``SM_PARAM``'s value per parameterisation, in the order of the one list of them
#: (core/brdf/params.py); glsl/brdf/parameterization.glsl compares against the
#: generated names ``SM_PARAM_<NAME>``, never against these numbers.
PARAMETERIZATION_CODES = {name: code for code, name in enumerate(PARAMETERIZATIONS)}
#: Fragment sources in the order they are concatenated (each uses the ones before).
FRAGMENT_LIBRARY = ("common/common.glsl", "brdf/parameterization.glsl", "brdf/axis_lookup.glsl",
                    "brdf/factor_packs.glsl", "common/light_rows.glsl",
                    "brdf/spectral_basis.glsl", "brdf/specular_lobe.glsl",
                    "brdf/pair_xyz.glsl", "brdf/measured_cells.glsl",
                    "common/lights.glsl", "common/frame.glsl", "common/colour_pipeline.glsl")

#: Lights one variant draws. The light loop may be unrolled into one copy of the pack
#: loop per light, and the frame time grows linearly with lights (docs/bench_draw.md):
#: a bound keeps compile time and frame time predictable.
MAX_LIGHTS = 32

#: Up to this many lights a variant carries the view's axes mask (``SM_VIEW_AXES``), so
#: that its packs can run outermost (glsl/brdf/surface_frag.glsl; the benchmarks force
#: that order to time it). Whether a variant does is :func:`shares_view_axes`, which
#: takes it with at most :data:`SHARED_VIEW_RULE_LIGHTS`: each light costs 17 live values
#: there (its lookups, weight and own sum).
MAX_SHARED_VIEW_LIGHTS = 8

#: Light rows go in a uniform buffer while they fit 16 KiB (1024 vec4), the size every
#: OpenGL implementation must allow (GL_MAX_UNIFORM_BLOCK_SIZE ≥ 16384); larger ones
#: (many lights × many packs) stay in the light texture.
MAX_LIGHT_BUFFER_TEXELS = 1024

_CACHE: dict = {}


def parameterization_defines(name: str) -> dict[str, str]:
    """``SM_PARAM`` (the code of ``name``) and ``SM_PARAM_<NAME>`` for every parameterisation."""
    defines = {f"SM_PARAM_{key.upper()}": str(code) for key, code in PARAMETERIZATION_CODES.items()}
    defines["SM_PARAM"] = str(PARAMETERIZATION_CODES[name])
    return defines


def edge_defines() -> dict[str, str]:
    """``SM_EDGE_<RULE>``: the code of each edge rule (its index in ``axes.EDGE_RULES``),
    which the parameter block's ``misc.x`` carries (``gpu_material.MaterialUniforms``)."""
    return {f"SM_EDGE_{rule.upper()}": str(code) for code, rule in enumerate(EDGE_RULES)}


def factor_defines(precision: str) -> dict[str, str]:
    """``SM_FACTORS`` (the index of ``precision`` in ``FACTOR_PRECISIONS``), a
    ``SM_FACTORS_<NAME>`` code per precision, and whether the texture unit filters
    (``SM_FACTORS_FILTERED``) and unorm16 decodes (``SM_FACTORS_UNORM``):
    glsl/brdf/factor_packs.glsl."""
    encoding, filtered = PRECISION_TEXELS.get(precision, ("float32", False))
    return {
        **{f"SM_FACTORS_{name.upper()}": str(code)
           for code, name in enumerate(FACTOR_PRECISIONS)},
        "SM_FACTORS": str(FACTOR_PRECISIONS.index(precision)),
        "SM_FACTORS_FILTERED": "1" if filtered else "0",
        "SM_FACTORS_UNORM": "1" if encoding == "unorm16" else "0",
    }


def cell_defines(cells: tuple) -> dict[str, str]:
    """``SM_CELLS`` and the cell counts ``SM_CELLS_H/_D/_P`` of a model drawn in a measured
    table's cells (glsl/brdf/measured_cells.glsl), with the centre cosine's floor."""
    counts = tuple(int(n) for n in cells) if cells else (1, 1, 1)
    return {"SM_CELLS": "1" if cells else "0",
            **{f"SM_CELLS_{axis}": str(n) for axis, n in zip("HDP", counts)},
            "SM_MIN_CENTRE_COSINE": f"{MIN_CENTRE_COSINE:.9g}"}


#: At most this many lights share the view's axes (:func:`shares_view_axes`): beyond,
#: each light's own sum (kept for its clamp at 0) costs a GPU more than the sharing saves.
SHARED_VIEW_RULE_LIGHTS = 4


def shares_view_axes(parameterization: str, packs: int, lights: int) -> bool:
    """``SM_SHARE_VIEW``: whether the packs run outermost, the view's axes fetched once
    per pack for all lights, rather than light by light.

    That order keeps every light's lookups and its own XYZ sum live (each light's XYZ is
    clamped at 0), which costs a GPU occupancy until enough packs share the view's
    fetches. On an NVIDIA H200 (docs/bench_gpu_variants.md, io_iso, 1.0 M pixels) it
    took 0.85× the light-by-light frame with 2 lights from 8 packs on (1.10× at 4), and
    with 4 lights 0.96× at 12 packs, 0.80× at 22 (1.19× at 8); with 8 lights it lost at
    every pack count measured (1.07× at 22, 1.78× at 8). llvmpipe gains from fewer packs
    (0.80× at 4 packs × 4 lights, 0.84× with 8), but a viewport draws on a GPU.
    Measured on io_iso (one view axis) alone, on one GPU: the rule between those counts,
    and for io and ea (whose φo is shared too), is unmeasured.
    """
    return (1 < lights <= SHARED_VIEW_RULE_LIGHTS
            and view_axes_mask(parameterization) != 0 and packs >= 2 * lights + 4)


def view_axes_mask(name: str) -> int:
    """``SM_VIEW_AXES``: bit k set where axis k of the parameterisation depends on the
    view alone (``Parameterization.view_axes``)."""
    if name not in PARAMETERIZATION_CODES:
        return 0            # validate() names the unknown parameterisation
    mask = 0
    for k in get_parameterization(name).view_axes:
        mask |= 1 << k
    return mask


def light_type_bits(kinds) -> int:
    """``SM_LIGHT_TYPES``: bit ``LIGHT_CODES[kind]`` set for each light type drawn, so that
    glsl/common/lights.glsl compiles only the branches a scene needs."""
    bits = 0
    for kind in kinds:
        bits |= 1 << LIGHT_CODES[kind]
    return bits


@dataclass(frozen=True)
class ShaderKey:
    """The ``#define``s of one variant."""

    parameterization: str
    axes: int
    packs: int
    coefficients: int
    lights: int
    light_types: frozenset
    cosine_weighted: bool = True
    precontract: bool = True
    output: str = "XYZ"         # a request of outputs.SURFACE_REQUESTS
    sphere: bool = False
    #: Texels per light row in the uniform buffer ``sm_lights``; 0: rows in ``light_tex``.
    light_stride: int = 0
    #: How the factor texture is read (``filtered_factors.FACTOR_PRECISIONS``).
    factors: str = "exact"
    #: Light-row texel of an analytic lobe's two weights (glsl/brdf/specular_lobe.glsl);
    #: 0: the model has no lobe.
    lobe_texel: int = 0
    #: The lobe's family, ``core.brdf.lobe.family_code`` (1: Ashikhmin–Shirley).
    lobe_family: int = 1
    #: (θh, θd, φd) cells of the measured table the model is drawn in
    #: (glsl/brdf/measured_cells.glsl); (): drawn smooth.
    cells: tuple = ()

    def defines(self) -> dict[str, str]:
        out = {
            **parameterization_defines(self.parameterization),
            **edge_defines(),
            "SM_AXES": str(self.axes),
            "SM_PACKS": str(self.packs),
            "SM_COEFFS": str(self.coefficients),
            "SM_LIGHTS": str(self.lights),
            "SM_LIGHT_TYPES": str(light_type_bits(self.light_types)),
            "SM_LIGHT_STRIDE": str(self.light_stride),
            "SM_VIEW_AXES": str(view_axes_mask(self.parameterization)
                                if self.lights <= MAX_SHARED_VIEW_LIGHTS else 0),
            "SM_SHARE_VIEW": "1" if shares_view_axes(self.parameterization, self.packs,
                                                     self.lights) else "0",
            "SM_COSINE_WEIGHTED": "1" if self.cosine_weighted else "0",
            "SM_PRECONTRACT": "1" if self.precontract else "0",
            **output_defines(SURFACE_REQUESTS[self.output]),
            **factor_defines(self.factors),
            "SM_LOBE_TEXEL": str(self.lobe_texel),
            "SM_LOBE_FAMILY": str(self.lobe_family),
            "SM_LOBE_DENOMINATOR_FLOOR": f"{DENOMINATOR_FLOOR:.9g}",
            **cell_defines(self.cells),
        }
        if self.sphere:
            out["SM_GEOMETRY_SPHERE"] = "1"
        return out

    def validate(self) -> None:
        if not 1 <= self.lobe_family <= len(LOBE_FAMILIES):
            raise ValueError(f"lobe family code {self.lobe_family} is not one of "
                             f"1..{len(LOBE_FAMILIES)} ({', '.join(LOBE_FAMILIES)})")
        if self.factors not in FACTOR_PRECISIONS:
            raise ValueError(f"factor precision must be one of {FACTOR_PRECISIONS}, "
                             f"got {self.factors!r}")
        if self.factors != "exact" and not self.precontract:
            # The per-coefficient mode reads the spectral factor from the factor texture,
            # which only the exact precision uploads.
            raise ValueError(f"factor precision {self.factors!r} draws pre-contracted light "
                             "weights only; use precontract=True or the exact precision")
        if self.parameterization not in PARAMETERIZATION_CODES:
            raise ValueError(f"no shader for parameterisation {self.parameterization!r}")
        if not 1 <= self.axes <= 4:
            raise ValueError(f"shaders handle 1..4 angular axes, got {self.axes}")
        if self.packs < 1 or self.coefficients < 1 or self.lights < 1:
            raise ValueError(f"a variant needs ≥ 1 pack, coefficient and light: {self}")
        if self.lights > MAX_LIGHTS:
            raise ValueError(f"{self.lights} lights reach the scene; the spectral shaders draw "
                             f"at most {MAX_LIGHTS}: hide or disable some lights")
        if self.output not in SURFACE_REQUESTS:
            raise ValueError(f"unknown output {self.output!r}; valid: {sorted(SURFACE_REQUESTS)}")
        if self.light_stride and self.lights * self.light_stride > MAX_LIGHT_BUFFER_TEXELS:
            raise ValueError(f"{self.lights} light rows of {self.light_stride} texels exceed the "
                             f"uniform buffer's {MAX_LIGHT_BUFFER_TEXELS}")
        # A row holds the header and 3 texels per pack (pre-contracted) or one per
        # coefficient; a shorter stride would read the next light's row.
        needed = light_row_texels(self.packs, self.coefficients, self.precontract)
        if self.lobe_texel:
            if self.lobe_texel < needed:
                raise ValueError(f"the lobe's texel {self.lobe_texel} overlaps the "
                                 f"{needed} texels of the packs' light weights")
            needed = self.lobe_texel + LOBE_TEXELS
        if self.light_stride and self.light_stride < needed:
            raise ValueError(f"light rows of {self.light_stride} texels are shorter than the "
                             f"{needed} this variant reads")


def glsl_source(name: str) -> str:
    """One file of ``glsl/``, by its path there (``"brdf/params.glsl"``)."""
    return (GLSL_DIR / name).read_text(encoding="utf-8")


def fragment_source() -> str:
    return "\n".join(glsl_source(name) for name in FRAGMENT_LIBRARY) + "\n" + \
        glsl_source("brdf/surface_frag.glsl")


def create_info(key: ShaderKey, fragment: str | None = None):
    """The ``GPUShaderCreateInfo`` of a variant. ``fragment`` replaces the fragment source
    (:func:`fragment_source`): the draw benchmark's rolled-loop control passes a variant."""
    import gpu

    key.validate()
    info = gpu.types.GPUShaderCreateInfo()
    for name, value in key.defines().items():
        info.define(name, value)
    typedefs = glsl_source("brdf/params.glsl")
    if key.light_stride:
        # One struct per size: the array length is the variant's light rows.
        typedefs += (f"\nstruct SmLights {{\n  vec4 texels[{key.lights * key.light_stride}];"
                     "\n};\n")
    info.typedef_source(typedefs)
    info.uniform_buf(0, "SmParams", "sm")
    info.sampler(0, "FLOAT_2D", "factor_tex")
    if key.light_stride:
        info.uniform_buf(1, "SmLights", "sm_lights")
    else:
        info.sampler(1, "FLOAT_2D", "light_tex")
    if key.sphere:
        info.vertex_in(0, "VEC2", "corner")
        info.vertex_source(glsl_source("brdf/sphere_vert.glsl"))
    else:
        # Per object: exactly the 128 bytes of push constants every backend supports.
        info.push_constant("MAT4", "model_matrix")
        info.push_constant("MAT4", "normal_matrix")
        info.vertex_in(0, "VEC3", "position")
        info.vertex_in(1, "VEC3", "normal")
        info.vertex_in(2, "VEC4", "tangent")
        interface = gpu.types.GPUStageInterfaceInfo("sm_surface_interface")
        for name in ("world_position", "world_normal", "world_tangent"):
            interface.smooth("VEC3", name)
        info.vertex_out(interface)
        info.vertex_source(glsl_source("brdf/mesh_vert.glsl"))
    info.fragment_out(0, "VEC4", "frag_colour")
    info.fragment_source(fragment_source() if fragment is None else fragment)
    return info


def get_shader(key, create=None):
    """The compiled variant for ``key`` (cached): ``create(key)`` gives its create-info,
    :func:`create_info` by default (other shader families, e.g. ``prt_gpu``, pass theirs;
    their keys are other types, so they never collide)."""
    shader = _CACHE.get(key)
    if shader is None:
        import gpu

        from .context import ensure_gpu

        ensure_gpu()
        shader = gpu.shader.create_from_info((create or create_info)(key))
        _CACHE[key] = shader
    return shader


def cached_variants() -> list[ShaderKey]:
    return list(_CACHE)


def clear_cache() -> None:
    # Blender's GPU context remembers the last bound shader by address; freeing the
    # variants while one is bound leaves that address behind (see gpu_state).
    if _CACHE:
        import gpu

        gpu.shader.unbind()
    _CACHE.clear()
