"""Every GLSL file names the Python it mirrors, and the names hold.

Each file of ``glsl/`` starts with ``/* Mirror: spectral_materials.x.y, … */`` (or
``/* Mirror: none (why) */``): every name must import. Each shader family is assembled
by its own ``create_info`` (recorded here through ``glsl_source``): every ``SM_…`` name
its files use must be ``#define``d in them or by its shader key, every ``sm.field`` must
be a field of its parameter block. ``glsl/README.md`` lists every file with its mirrors.
Needs bpy (the drawers import it and ``create_info`` builds a ``GPUShaderCreateInfo``).
"""

from __future__ import annotations

import importlib
import re

import pytest

from spectral_materials.blender.brdf import gpu_material
from spectral_materials.blender.btf import drawer as btf_drawer
from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.prt import drawer as prt_drawer
from spectral_materials.core import lights
from spectral_materials.core.brdf import shading

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

GLSL = shaders.GLSL_DIR
FILES = sorted(p.relative_to(GLSL).as_posix() for p in GLSL.rglob("*.glsl"))
HEADER = re.compile(r"^/\* Mirror: (.+) \*/$")
PREFIX = "spectral_materials."
#: Compiled by the draw benchmark (benchmarks/), not by the package's shader families.
BENCHMARK_ONLY = {"brdf/baseline_blinn_phong_vert.glsl", "brdf/baseline_blinn_phong_frag.glsl"}
SM_NAME = re.compile(r"\bSM_[A-Z0-9]+(?:_[A-Z0-9]+)*\b")
GLSL_DEFINE = re.compile(r"^\s*#\s*define\s+(\w+)", re.MULTILINE)
#: GLSL constants that copy a Python one: #define name → the Python value.
COPIED_CONSTANTS = {
    "SM_LIGHT_HEADER": shading.LIGHT_HEADER,
    "SM_MIN_DISTANCE_SQ": lights.MIN_DISTANCE_SQ,
    "SM_TANGENT_EPS_SQ": shading.TANGENT_EPS_SQ,
    **{f"SM_{kind}": code for kind, code in lights.LIGHT_CODES.items()},
}


def header(name: str) -> str:
    first = (GLSL / name).read_text(encoding="utf-8").splitlines()[0]
    match = HEADER.match(first)
    assert match, f"glsl/{name}: the first line must be /* Mirror: … */, not {first!r}"
    return match.group(1)


def mirrors(name: str) -> list[str]:
    """The dotted names of the file's mirror ([] for ``none (why)``)."""
    text = header(name)
    return [] if text.startswith("none (") else [m.strip() for m in text.split(",")]


def resolve(dotted: str):
    """The object a dotted name names: its longest importable module, then attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            target = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attribute in parts[cut:]:
            target = getattr(target, attribute)
        return target
    raise ModuleNotFoundError(dotted)


@pytest.mark.parametrize("name", FILES)
def test_every_file_names_a_mirror_that_exists(name):
    text = header(name)
    if text.startswith("none ("):
        assert text.endswith(")") and len(text) > len("none ()"), f"{name}: say why"
        return
    for dotted in mirrors(name):
        assert dotted.startswith(PREFIX), f"{name}: {dotted} is not a package name"
        try:
            resolve(dotted)
        except (ImportError, AttributeError) as exc:
            pytest.fail(f"glsl/{name} names {dotted}, which does not exist: {exc}")


def test_readme_lists_every_file_with_its_mirrors():
    rows = {}
    for line in (GLSL / "README.md").read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and cells[0].startswith("`") and cells[0].endswith(".glsl`"):
            rows[cells[0].strip("`")] = cells[2]
    assert sorted(rows) == FILES
    for name, cell in rows.items():
        named = mirrors(name)
        if not named:
            assert cell.startswith("none"), (name, cell)
        for dotted in named:
            assert f"`{dotted.removeprefix(PREFIX)}`" in cell, (name, dotted, cell)


def test_every_path_named_into_glsl_exists():
    """Docstrings, comments and docs that name ``glsl/<path>.glsl`` name a file there."""
    root = GLSL.parent
    texts = [*root.glob("*.md"), *root.glob("docs/*.md"), GLSL / "README.md",
             *root.glob("spectral_materials/**/*.py"), *root.glob("benchmarks/*.py"),
             *root.glob("scripts/*.py"), *root.glob("tests/**/*.py")]
    stale = []
    for path in texts:
        for named in re.findall(r"glsl/([\w/*]+\.glsl)", path.read_text(encoding="utf-8")):
            if not list(GLSL.glob(named)):
                stale.append(f"{path.relative_to(root)}: glsl/{named}")
    assert not stale, stale


def _families() -> dict:
    every_light = frozenset(lights.LIGHT_CODES)
    surface = shaders.ShaderKey("hd", 4, 2, 8, 2, every_light, light_stride=9)
    return {
        "factor packs": (shaders.create_info, [surface, shaders.ShaderKey(
            "io_iso", 3, 1, 8, 1, frozenset({"SUN"}), sphere=True)], gpu_material.PARAMS),
        "PRT": (prt_drawer.create_info, [prt_drawer.PRTShaderKey(9, 8)], prt_drawer.PARAMS),
        "BTF": (btf_drawer.create_info, [btf_drawer.BTFShaderKey("RFNL", 2, 8, 2, every_light)],
                btf_drawer.PARAMS),
    }


@pytest.fixture(scope="module")
def family_sources() -> dict:
    """Family → (files its create_info reads, the defines its keys generate, its block)."""
    out = {}
    original = shaders.glsl_source
    patch = pytest.MonkeyPatch()
    try:
        for family, (create, keys, block) in _families().items():
            read: list[str] = []

            def recording(name: str, read=read) -> str:
                read.append(name)
                return original(name)

            for module in (shaders, prt_drawer, btf_drawer):
                patch.setattr(module, "glsl_source", recording)
            defines: set[str] = set()
            for key in keys:
                create(key)
                defines |= set(key.defines())
            out[family] = (sorted(set(read)), defines, block)
            patch.undo()
    finally:
        patch.undo()
    return out


def test_every_shader_file_is_compiled_by_a_family(family_sources):
    used = set().union(*(files for files, _, _ in family_sources.values()))
    assert used | BENCHMARK_ONLY == set(FILES)


@pytest.mark.parametrize("family", list(_families()))
def test_every_define_a_family_uses_is_defined(family, family_sources):
    files, generated, _ = family_sources[family]
    sources = {name: (GLSL / name).read_text(encoding="utf-8") for name in files}
    defined = generated.union(*(GLSL_DEFINE.findall(text) for text in sources.values()))
    for name, text in sources.items():
        unknown = sorted(set(SM_NAME.findall(text)) - defined)
        assert not unknown, f"glsl/{name} ({family}) uses {unknown}: defined nowhere"


@pytest.mark.parametrize("family", list(_families()))
def test_every_block_field_a_family_reads_is_packed(family, family_sources):
    files, _, block = family_sources[family]
    fields = {field.name for field in block.fields}
    for name in files:
        read = set(re.findall(r"\bsm\.(\w+)", (GLSL / name).read_text(encoding="utf-8")))
        assert read <= fields, f"glsl/{name} reads {sorted(read - fields)} of {block.name}"


def test_glsl_constants_equal_their_python_originals():
    found = {}
    for name in FILES:
        text = (GLSL / name).read_text(encoding="utf-8")
        for define, value in re.findall(r"^#define\s+(SM_\w+)\s+(\S+)", text, re.MULTILINE):
            if define in COPIED_CONSTANTS:
                found[define] = float(value)
    assert found == {k: float(v) for k, v in COPIED_CONSTANTS.items()}
