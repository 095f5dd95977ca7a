"""The .blend saved by the code before the package reorganisation (issue 17) opens with
today's code, keeps its stored results, and draws what it drew then."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from spectral_materials.blender.viewport import draw

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "premove"


@pytest.fixture
def premove_scene():
    bpy.ops.wm.open_mainfile(filepath=str(DATA / "scene.blend"))
    yield bpy.context.scene
    bpy.ops.wm.read_homefile(use_factory_startup=True)


def test_stored_results_read_back(premove_scene):
    paint = bpy.data.materials["Paint"]
    assert paint.spectral.result.packs == 2 and paint.spectral.result.image is not None
    assert 0.0 < paint.spectral.result.de94_mean < 1.0
    assert bpy.data.materials["Corduroy"].spectral_btf.model == "RFP"
    assert bpy.data.objects["Ball"].spectral_prt.rays == 64
    assert bpy.data.lights["Light"].spectral.illuminant == "FL2"
    assert any(g.name.startswith("Spectral") for g in bpy.data.node_groups) or \
        paint.node_tree is not None


@pytest.fixture
def nearest_btf_texels(monkeypatch):
    """BTF texels as they were drawn when the file was saved: nearest, no blend across
    their edges (issue 19 added the blend, on purpose; render.EDGE_BLEND)."""
    from spectral_materials.blender.btf import drawer as btf_drawer
    from spectral_materials.blender.gpu import shaders

    shaders.clear_cache()
    monkeypatch.setattr(btf_drawer, "EDGE_BLEND", 0.0)
    yield
    shaders.clear_cache()


def test_draws_what_it_drew_before_the_move(premove_scene, nearest_btf_texels):
    before = np.load(DATA / "pixels.npz")["xyz"]
    height, width = before.shape[:2]
    after, stats = draw.render_camera(premove_scene, width=width, height=height)
    assert {"Paint", "Corduroy"} <= set(stats.materials)
    assert (before[..., 3] > 0).sum() > 2000
    np.testing.assert_array_equal(after[..., 3] > 0, before[..., 3] > 0)
    # Bit-identical on OpenGL through llvmpipe; Vulkan (lavapipe) rounds a few float32
    # operations differently (measured: 5.8e-6 at most on values up to 1).
    np.testing.assert_allclose(after, before, rtol=0.0, atol=5e-5)


def test_the_btf_texel_blend_changes_only_pixels_near_texel_edges(premove_scene):
    """Today's rule on the same file: the BRDF and PRT objects draw as before, and the
    BTF differs only where texels now blend across an edge: a minority of its pixels."""
    from spectral_materials.blender.gpu import shaders

    shaders.clear_cache()
    before = np.load(DATA / "pixels.npz")["xyz"]
    height, width = before.shape[:2]
    after, _ = draw.render_camera(premove_scene, width=width, height=height)
    np.testing.assert_array_equal(after[..., 3] > 0, before[..., 3] > 0)
    changed = np.abs(after - before).max(axis=-1) > 5e-5
    assert 0 < changed.sum() < 0.1 * (before[..., 3] > 0).sum()
