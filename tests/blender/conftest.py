"""Fixtures for tests on the ``bpy`` module: the add-on registered once, a clean scene per
test, and for tests marked ``gpu`` Blender's ``gpu`` module made usable and factored models
cached.

The shaders (``glsl/``) are drawn offscreen (EGL + Mesa llvmpipe when headless) and held
against their float64 mirrors. Factorising is the slow part, so each model is built once per
session, at small resolutions."""

from __future__ import annotations

import os

import pytest

bpy = pytest.importorskip("bpy")

from gpu_helpers import build_model

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


@pytest.fixture(scope="session")
def gpu_ready():
    """Initialise Blender's ``gpu`` module once (an EEVEE render the first time)."""
    import gpu

    from spectral_materials.blender.gpu.context import ensure_gpu

    ensure_gpu()
    # A leg that asks for a backend must get it: without a driver, Blender falls back from
    # Vulkan to OpenGL with only a log line, and the leg would test the wrong one.
    wanted = os.environ.get("SPECTRAL_GPU_BACKEND")
    if wanted:
        assert gpu.platform.backend_type_get() == wanted, (
            f"asked for {wanted}, Blender drew with {gpu.platform.backend_type_get()}")


@pytest.fixture(autouse=True)
def _gpu_for_gpu_tests(request):
    if request.node.get_closest_marker("gpu"):
        request.getfixturevalue("gpu_ready")


@pytest.fixture(scope="session")
def factored():
    """``factored(parameterization, brdf=None, packs=4, cosine_weighted=True)``, cached."""
    cache: dict = {}

    def get(parameterization: str, brdf: str | None = None, packs: int = 4,
            cosine_weighted: bool = True):
        key = (parameterization, brdf, packs, cosine_weighted)
        if key not in cache:
            cache[key] = build_model(parameterization, brdf, packs, cosine_weighted)
        return cache[key]

    return get
