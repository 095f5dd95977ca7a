"""What survives from one draw, scene or file to the next: GPU pipeline state left set by
an earlier draw, objects recreated under an old name, and caches across file loads.

The demo's main job died on a clean machine when a plane facing the camera drew no pixel
after earlier sections had run in the same process; leaving back-face culling with the
winding flipped recreates exactly that (see ``blender/gpu/state.py``).
"""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]
gpu = pytest.importorskip("gpu")

from spectral_materials.blender.brdf import storage
from spectral_materials.blender.gpu import (
    batches as mesh_batches,
    context as gpu_context,
)
from spectral_materials.blender.viewport import draw
from spectral_materials.core.brdf import factor, models
from spectral_materials.core.colour import spectra

WL = spectra.WAVELENGTHS_REFERENCE
SIZE = (96, 64)


@pytest.fixture(scope="module")
def matte_model():
    brdf = models.make_model("lambert", albedo=(WL, spectra.colorchecker(12)))
    return factor.factor_brdf(brdf, parameterization="io", resolution=(8, 16, 8), packs=1,
                              spectral_basis=8)


def _painted(obj, model, name="Matte"):
    material = bpy.data.materials.new(name)
    material.spectral.enabled = True
    obj.data.materials.append(material)
    storage.store_factored(material, model)
    return material


def _plane_facing_camera(model, name="Floor"):
    """A plane at z = 0 seen straight from above, the camera looking down −z, alone (the
    start-up cube would hide it)."""
    for obj in [o for o in bpy.data.objects if o.type == "MESH"]:
        bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    plane.name = name
    _painted(plane, model)
    camera = bpy.context.scene.camera
    camera.location, camera.rotation_euler = (0.0, 0.0, 6.0), (0.0, 0.0, 0.0)
    return plane


def _render(output="POSITION") -> np.ndarray:
    return draw.render_camera(bpy.context.scene, width=SIZE[0], height=SIZE[1],
                              output=output)[0]


def _hostile_state() -> None:
    """What another draw might leave behind: the plane's front culled, blending on, one
    colour channel masked, a one-pixel scissor."""
    gpu.state.face_culling_set("BACK")
    gpu.state.front_facing_set(True)
    gpu.state.blend_set("ALPHA")
    gpu.state.color_mask_set(True, False, True, True)
    gpu.state.scissor_set(0, 0, 1, 1)
    gpu.state.scissor_test_set(True)


def test_left_over_pipeline_state_changes_no_pixel(clean_scene, matte_model):
    _plane_facing_camera(matte_model)
    gpu_context.ensure_gpu()
    clean = {out: _render(out) for out in ("POSITION", "XYZ")}
    assert (clean["POSITION"][..., 3] > 0.5).mean() > 0.2
    try:
        _hostile_state()
        left_over = {out: _render(out) for out in ("POSITION", "XYZ")}
        # What the draw can read back is as it was before the draw.
        assert gpu.state.blend_get() == "ALPHA"
    finally:
        gpu.state.blend_set("NONE")
        gpu.state.color_mask_set(True, True, True, True)
        gpu.state.scissor_test_set(False)
        gpu.state.face_culling_set("NONE")
        gpu.state.front_facing_set(False)
    for out, image in clean.items():
        np.testing.assert_array_equal(left_over[out], image, err_msg=out)


def test_an_object_recreated_under_an_old_name_draws_its_own_geometry(clean_scene,
                                                                      matte_model):
    """Delete an object and its mesh, make another under both names: the batch cached for
    the first must not be drawn for the second."""
    first = _plane_facing_camera(matte_model, "Thing")
    mesh_name = first.data.name
    before = _render()
    bpy.data.meshes.remove(first.data)               # removes the object's user too
    for obj in [o for o in bpy.data.objects if o.name == "Thing"]:
        bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0.6, 0.0, 0.0))
    second = bpy.context.active_object
    second.name, second.data.name = "Thing", mesh_name
    _painted(second, matte_model, "Matte 2")
    assert (second.name, second.data.name) == ("Thing", mesh_name)
    after = _render()
    mesh_batches.clear_cache()
    draw.reset()
    fresh = _render()
    np.testing.assert_array_equal(after, fresh)
    assert (after[..., 3] > 0.5).sum() < (before[..., 3] > 0.5).sum() / 4


def test_every_cache_is_emptied_by_a_file_load(clean_scene, matte_model, tmp_path):
    from spectral_materials.blender.brdf import drawer as brdf_drawer
    from spectral_materials.blender.btf import drawer as btf_gpu
    from spectral_materials.blender.gpu import shaders
    from spectral_materials.blender.prt import drawer as prt_gpu, scene as prt

    _plane_facing_camera(matte_model)
    _render("XYZ")
    assert mesh_batches.cached_objects()
    path = tmp_path / "drawn.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert not mesh_batches.cached_objects()
    assert not brdf_drawer._MATERIALS and not shaders._CACHE and not prt._CACHE
    assert not prt_gpu._OBJECTS and not btf_gpu._MATERIALS
    # And the reopened scene draws as before.
    assert (_render()[..., 3] > 0.5).mean() > 0.2


def test_initialising_the_gpu_prints_nothing_a_user_cannot_act_on():
    """Blender's EGL probing ("EGL_BAD_MATCH" per failed configuration) is kept off the
    terminal when a working context follows; a fresh process, as a user's script starts."""
    import subprocess
    import sys
    from pathlib import Path

    code = ("import bpy\nfrom spectral_materials import blender as addon\naddon.register()\n"
            "from spectral_materials.blender.gpu import context as gpu_context\n"
            "gpu_context.ensure_gpu()\n"
            "import gpu\ngpu.types.GPUOffScreen(4, 4).free()\nprint('drawn')\n"
            "gpu_context.exit_process(0)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, cwd=Path(__file__).resolve().parents[3], check=False)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().endswith("drawn")
    assert "EGL_BAD_MATCH" not in done.stderr + done.stdout, done.stderr


def test_a_variant_compiled_after_a_file_load_really_binds():
    """Thirty fresh scenes in one process, each first drawn after a file load freed the
    variants: every one covers its pixels. Before the unbind, about one in five drew
    nothing (a new variant at a freed one's address was taken as already bound)."""
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[3]
    done = subprocess.run([sys.executable, str(repo / "scripts" / "check_fresh_scene_draws.py"),
                           "--trials", "30"], capture_output=True, text=True, timeout=600,
                          cwd=repo, check=False)
    assert "blank 0 of 30" in done.stdout, done.stdout + done.stderr[-2000:]
    assert done.returncode == 0
