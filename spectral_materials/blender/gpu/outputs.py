"""What a shader variant writes: one name, one code and one meaning per output.

Every shader family (factor packs, PRT, BTF) writes its shaded colour or, for the tests
and the scene reference, one geometric quantity instead. The codes reach GLSL as
``#define``s (:func:`output_defines`): ``SM_OUTPUT`` is the variant's code and
``SM_OUTPUT_<NAME>`` names every code, so the GLSL compares against names
(``#if SM_OUTPUT == SM_OUTPUT_UV``) and the numbers live only in :data:`OUTPUTS`.

A caller asks a family for an output by a *request* name (``render_camera(output=…)``
asks every family drawn for the same one). Each family's request table maps the
requests it answers to its outputs: its own outputs by their names, and the request
``"COORDINATES"`` to the coordinates its tables are looked up at, the
parameterisation's coordinates for factor-pack materials and the UV for BTF and PRT,
so that one G-buffer serves every capability's Python mirror.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Output:
    """One thing a fragment stage can write to the colour target."""

    name: str
    code: int
    meaning: str


OUTPUTS: tuple[Output, ...] = (
    Output("XYZ", 0, "linear CIE XYZ"),
    Output("DISPLAY", 1, "display sRGB: adapted, tone-mapped and encoded"),
    Output("POSITION", 2, "the world position"),
    Output("NORMAL", 3, "the geometric normal, turned to face the viewer"),
    Output("TANGENT", 4, "the interpolated tangent, as the mesh gives it"),
    Output("PARAMETERIZATION", 5, "the parameterisation's coordinates for light 0"),
    Output("UV", 6, "the texture coordinates"),
    Output("PRIMITIVE", 7, "the index of the triangle drawn"),
)
OUTPUT_CODES: dict[str, int] = {output.name: output.code for output in OUTPUTS}

#: The request for "the coordinates this material is looked up at".
COORDINATES = "COORDINATES"


def output_defines(output: str) -> dict[str, str]:
    """``SM_OUTPUT`` (the code of ``output``) and ``SM_OUTPUT_<NAME>`` for every output."""
    defines = {f"SM_OUTPUT_{item.name}": str(item.code) for item in OUTPUTS}
    defines["SM_OUTPUT"] = str(OUTPUT_CODES[output])
    return defines


def requests(outputs: tuple[str, ...], coordinates: str, **aliases: str) -> dict[str, str]:
    """A family's request table: each of ``outputs`` by its own name, ``"COORDINATES"``
    → ``coordinates``, and the ``aliases`` (request → output)."""
    table = {name: name for name in outputs}
    table[COORDINATES] = coordinates
    table.update(aliases)
    assert set(table.values()) <= set(OUTPUT_CODES), table
    return table


_GEOMETRY = ("XYZ", "DISPLAY", "POSITION", "NORMAL", "TANGENT")

#: Factor-pack materials (glsl/brdf/surface_frag.glsl).
SURFACE_REQUESTS = requests((*_GEOMETRY, "PARAMETERIZATION"), "PARAMETERIZATION")
#: BTF materials (glsl/btf/btf_frag.glsl).
BTF_REQUESTS = requests((*_GEOMETRY, "UV"), "UV")
#: PRT objects (glsl/prt/prt_frag.glsl). The PRT shader has no normal or tangent output:
#: those requests draw its display colour, as they did when the codes were shared.
PRT_REQUESTS = requests(("XYZ", "DISPLAY", "POSITION", "UV", "PRIMITIVE"), "UV",
                        NORMAL="DISPLAY", TANGENT="DISPLAY")
