"""The viewport handler draws through the registry of drawers and knows none of them."""

from __future__ import annotations

import ast
import importlib
import pathlib

import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from spectral_materials.blender.viewport import draw, registry

VIEWPORT = pathlib.Path(draw.__file__).parent
CAPABILITIES = ("brdf", "prt", "btf", "eevee", "ui")


def test_the_capabilities_register_their_drawers_in_claiming_order():
    assert registry.drawer_names() == ["BTF", "PRT", "factor packs"]
    assert [d.name for d in registry.material_drawers()] == ["BTF", "factor packs"]
    assert [d.name for d in registry.object_drawers()] == ["PRT"]


def test_no_viewport_module_imports_a_capability():
    for path in VIEWPORT.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level == 2:
                assert (node.module or "").split(".")[0] not in CAPABILITIES, \
                    f"{path.name} imports {node.module}"


def test_a_btf_material_is_claimed_before_its_factor_packs(clean_scene):
    from spectral_materials.blender.btf import storage as btf_storage

    material = bpy.data.materials.new("Both")
    assert registry.claiming_drawer(material).name == "factor packs"
    material[btf_storage.PROPERTY] = {"token": "x"}
    assert registry.claiming_drawer(material).name == "BTF"


def test_a_registered_object_drawer_is_asked_and_reset(clean_scene):
    calls = {"draw": [], "clear": 0}
    cube = bpy.data.objects["Cube"]

    def draw_whole(scene, depsgraph, objects, frame):
        calls["draw"].append(([o.name for o in objects], frame.output))
        return [o.name for o in objects]

    def clear():
        calls["clear"] += 1

    registry.register(registry.ObjectDrawer(
        name="test", order=99, objects=lambda scene: [cube], draw=draw_whole,
        clear_cache=clear, failures=lambda: {"Cube": "a reason"}))
    try:
        _, stats = draw.render_camera(clean_scene, width=8, height=8, output="XYZ")
        assert calls["draw"] == [(["Cube"], "XYZ")]
        assert stats.objects == ["Cube"] and stats.drawn_whole["test"] == ["Cube"]
        assert ("Cube", "a reason") in draw.failed_materials()
        assert registry.failure("test", "Cube") == "a reason"
        draw.reset()
        assert calls["clear"] == 1
    finally:
        registry.unregister("test")
    assert "test" not in registry.drawer_names()


@pytest.mark.parametrize(("old", "name", "new"), [
    ("blender.gpu.offscreen", "render_sphere", "blender.brdf.sphere"),
    ("blender.viewport.draw", "gpu_material", "blender.brdf.drawer"),
])
def test_names_that_left_a_module_still_import_with_a_warning(old, name, new):
    module = importlib.import_module(f"spectral_materials.{old}")
    with pytest.warns(DeprecationWarning, match=rf"spectral_materials\.{new}\.{name}"):
        value = getattr(module, name)
    assert value is getattr(importlib.import_module(f"spectral_materials.{new}"), name)
