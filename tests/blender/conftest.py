"""Fixtures for tests on the ``bpy`` module: the add-on registered once, a clean scene per test."""

from __future__ import annotations

import pytest

bpy = pytest.importorskip("bpy")

from spectral_materials import blender as addon


@pytest.fixture(scope="session", autouse=True)
def registered():
    addon.register()
    yield
    addon.unregister()


@pytest.fixture
def clean_scene():
    """Blender's factory start-up file (cube, light, camera); the add-on stays registered."""
    bpy.ops.wm.read_homefile(use_factory_startup=True)
    for material in list(bpy.data.materials):
        bpy.data.materials.remove(material)
    yield bpy.context.scene
