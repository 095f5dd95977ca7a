"""The mesh draw path: GPU images against the Python mirror at the GPU's own geometry,
batch and variant caching, the viewport handler's life cycle, and headless outputs."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from blender_helpers import cube_material

from spectral_materials.blender.brdf import storage
from spectral_materials.blender.gpu import batches as mesh_batches, shaders
from spectral_materials.blender.lights import scene_lights
from spectral_materials.blender.viewport import draw
from spectral_materials.core.brdf import factor, metrics, models, shading
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.formats.exr import read_exr

REPO = Path(__file__).resolve().parents[3]
WL = spectra.WAVELENGTHS_REFERENCE
SIZE = (160, 120)


@pytest.fixture(scope="module")
def glossy_model():
    brdf = models.make_model("ashikhmin_shirley", diffuse=(WL, spectra.colorchecker(12)),
                             nu=32, nv=32)
    return factor.factor_brdf(brdf, parameterization="io", resolution=(12, 24, 12), packs=2,
                              spectral_basis=8)


@pytest.fixture(scope="module")
def anisotropic_model():
    brdf = models.make_model("ashikhmin_shirley", diffuse=(WL, spectra.colorchecker(6)),
                             nu=8, nv=64)
    return factor.factor_brdf(brdf, parameterization="hd", isotropic=False,
                              resolution=(10, 12, 10, 12), packs=2, spectral_basis=8)


def _sphere_with(model, name="Probe", *, uv=True, location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, location=location,
                                         calc_uvs=uv)
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    material = bpy.data.materials.new(name)
    material.spectral.enabled = True
    obj.data.materials.append(material)
    storage.store_factored(material, model)
    return obj, material


def _gpu_against_mirror(scene, material, mirror=None) -> np.ndarray:
    """ΔE94 per covered pixel: the GPU's XYZ against shade_xyz at the GPU's geometry, of
    the stored model or of ``mirror(model)``."""
    xyz, stats = draw.render_camera(scene, width=SIZE[0], height=SIZE[1])
    gbuffer = {out: draw.render_camera(scene, width=SIZE[0], height=SIZE[1], output=out)[0]
               for out in ("POSITION", "NORMAL", "TANGENT")}
    covered = xyz[..., 3] > 0
    assert covered.sum() > 500 and np.isfinite(xyz).all()
    camera = scene.camera
    _, view = draw.camera_view(camera, SIZE[0], SIZE[1], bpy.context.evaluated_depsgraph_get())
    lights, _ = scene_lights.drawn_lights(scene, np.asarray(view.origin))
    model = storage.load_factored(material)
    if mirror is not None:
        model = mirror(model)
    reference = shading.shade_xyz(model, gbuffer["POSITION"][covered, :3],
                                  gbuffer["NORMAL"][covered, :3],
                                  gbuffer["TANGENT"][covered, :3], view, lights)
    scale = max(reference[:, 1].max(), 1e-6)      # compare at a white of Y = 1 at the max
    return colour_pipeline.delta_e94(reference / scale, xyz[covered, :3] / scale,
                                     colour_pipeline.white_xyz("D65", WL))


def test_mesh_matches_mirror_with_uv_tangents(clean_scene, anisotropic_model):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    _sphere_with(anisotropic_model)
    de = _gpu_against_mirror(clean_scene, bpy.data.materials["Probe"])
    assert de.max() <= 0.1


def test_the_materials_factor_precision_reaches_the_viewport(clean_scene, anisotropic_model):
    """The material's precision picks the factor texture; the image is that path's mirror
    (float filter weights, as llvmpipe filters), and switching back rebuilds the texture."""
    from spectral_materials.blender.brdf import drawer
    from spectral_materials.core.brdf.filtered_factors import filtered_factors

    bpy.data.objects.remove(bpy.data.objects["Cube"])
    _, material = _sphere_with(anisotropic_model)
    material.spectral.draw_precision = "UNORM16_FILTERED"
    de = _gpu_against_mirror(clean_scene, material,
                             lambda m: filtered_factors(m, "unorm16", weight_bits=None))
    assert de.max() <= 0.1
    assert drawer.gpu_material(material).precision == "unorm16_filtered"
    material.spectral.draw_precision = "EXACT"
    assert drawer.gpu_material(material).precision == "exact"


def test_mesh_without_uvs_uses_the_generated_tangent_field(clean_scene, anisotropic_model):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    obj, material = _sphere_with(anisotropic_model, uv=False)
    arrays = mesh_batches.mesh_arrays(obj.data)
    assert not arrays.has_tangents and not arrays.tangents.any()
    assert _gpu_against_mirror(clean_scene, material).max() <= 0.1


#: Each parameterisation's small grid for the four-light scene: with 12 packs io, io_iso
#: and ea draw their view axes once per pack for all lights (SM_SHARE_VIEW), hd light by
#: light.
FOUR_LIGHT_GRIDS = {"io": (12, 24, 12, 24), "io_iso": (12, 24, 12), "ea": (12, 12, 24, 24),
                    "hd": (10, 12, 10, 12)}


@pytest.mark.parametrize(("parameterization", "copies", "packs"),
                         [(name, 1, 12) for name in FOUR_LIGHT_GRIDS]
                         + [("io_iso", 1, 2), ("io_iso", 3, 2)],
                         ids=[*FOUR_LIGHT_GRIDS, "io_iso-2-packs", "io_iso-12-lights"])
def test_every_light_type_in_a_scene(clean_scene, parameterization, copies, packs):
    """Four lights with 12 packs share the view's axes per pack (SM_SHARE_VIEW); with 2
    packs, or twelve lights (more than shaders.SHARED_VIEW_RULE_LIGHTS), they go light by
    light. Each against the mirror."""
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    bpy.data.objects.remove(bpy.data.objects["Light"])
    model = factor.factor_brdf(
        models.make_model("ashikhmin_shirley", diffuse=(WL, spectra.colorchecker(12)),
                          nu=32, nv=32),
        parameterization=parameterization, isotropic=parameterization == "io_iso",
        resolution=FOUR_LIGHT_GRIDS[parameterization], packs=packs, spectral_basis=8)
    assert model.parameterization == parameterization
    assert shaders.shares_view_axes(parameterization, model.packs, 4 * copies) == (
        parameterization != "hd" and packs == 12 and copies == 1)
    _, material = _sphere_with(model)
    _four_lights(clean_scene, copies)
    assert _gpu_against_mirror(clean_scene, material).max() <= 0.1


def _four_lights(scene, copies: int = 1) -> None:
    """A sun, a point, a spot and an area light (``copies`` times), aimed at the origin."""
    for copy in range(copies):
        for kind, location, energy in (("SUN", (2, -2, 3), 2.0), ("POINT", (3, -4, 2), 400.0),
                                       ("SPOT", (6, -6, 4), 2000.0),
                                       ("AREA", (-3, -5, 3), 300.0)):
            data = bpy.data.lights.new(kind, kind)
            data.energy = energy / copies
            data.spectral.illuminant = {"SUN": "D65", "POINT": "A", "SPOT": "FL2",
                                        "AREA": "FL11"}[kind]
            obj = bpy.data.objects.new(kind, data)
            obj.location = (location[0] + copy, location[1], location[2] + 0.5 * copy)
            scene.collection.objects.link(obj)
            # Aim at the origin: a light shines along its local −Z.
            obj.rotation_euler = _track(-np.asarray(obj.location, dtype=float))
    bpy.context.view_layer.update()
    lights, _ = scene_lights.drawn_lights(scene)
    assert sorted(light.kind for light in lights) == sorted(["AREA", "POINT", "SPOT",
                                                             "SUN"] * copies)


@pytest.mark.parametrize("packs", [2, 12], ids=["light-by-light", "packs-outermost"])
def test_each_lights_negative_xyz_is_drawn_as_zero(clean_scene, packs):
    """Packs whose spectral factor is lowered until parts of the sphere reflect a negative
    XYZ under some lights: each light's XYZ is clamped at 0 in both light loops, as the
    mirror clamps it (a negative sum from one light must not darken another's)."""
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    bpy.data.objects.remove(bpy.data.objects["Light"])
    fitted = factor.factor_brdf(
        models.make_model("ashikhmin_shirley", diffuse=(WL, spectra.colorchecker(12)),
                          nu=32, nv=32),
        parameterization="io_iso", isotropic=True, resolution=FOUR_LIGHT_GRIDS["io_iso"],
        packs=packs, spectral_basis=8)
    spectral = np.asarray(fitted.spectral)
    model = replace(fitted, spectral=spectral - 0.6 * np.abs(spectral).mean(axis=0))
    assert shaders.shares_view_axes("io_iso", model.packs, 4) == (packs == 12)
    _, material = _sphere_with(model)
    _four_lights(clean_scene)
    wi, wo = metrics.random_direction_pairs(4000, seed=3)
    signed = model.coefficients(wi, wo) @ colour_pipeline.xyz_weights(
        "D65", model.wavelengths, model.basis)
    assert 0.05 < (signed < 0).any(axis=1).mean() < 0.95, "negative somewhere, not everywhere"
    assert np.array_equal(model.xyz(wi, wo), np.maximum(signed, 0.0))
    assert _gpu_against_mirror(clean_scene, material).max() <= 0.1
    xyz, _ = draw.render_camera(clean_scene, width=SIZE[0], height=SIZE[1])
    assert xyz[..., :3].min() >= 0.0


def test_the_view_axes_mask_is_carried_by_at_most_eight_lights():
    """SM_VIEW_AXES (what the packs-outermost loop needs, and the benchmarks force) up to
    MAX_SHARED_VIEW_LIGHTS; whether the loop is taken is shares_view_axes."""
    from spectral_materials.blender.gpu import shaders

    def mask(lights):
        return shaders.ShaderKey("io_iso", 3, 2, 8, lights, frozenset({"SUN"})).defines()[
            "SM_VIEW_AXES"]

    assert (mask(1), mask(shaders.MAX_SHARED_VIEW_LIGHTS),
            mask(shaders.MAX_SHARED_VIEW_LIGHTS + 1)) == ("4", "4", "0")
    assert shaders.ShaderKey("hd", 4, 2, 8, 2, frozenset({"SUN"})).defines()[
        "SM_VIEW_AXES"] == "0"


def _track(direction):
    from mathutils import Vector

    return Vector(direction).to_track_quat("-Z", "Y").to_euler()


def test_degenerate_faces_and_zero_normals_stay_finite(clean_scene, glossy_model):
    cube = bpy.data.objects["Cube"]
    mesh = cube.data
    # Collapse one face to a point: zero area, zero normal.
    for index in mesh.polygons[0].vertices:
        mesh.vertices[index].co = (1.0, 1.0, 1.0)
    mesh.update()
    cube_material(glossy_model)
    image, stats = draw.render_camera(clean_scene, width=64, height=48)
    assert stats.objects == ["Cube"]
    assert np.isfinite(image).all()


def test_batches_rebuilt_only_when_geometry_changes(clean_scene, glossy_model):
    obj = bpy.data.objects["Cube"]
    cube_material(glossy_model)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    first = mesh_batches.object_batches(obj, depsgraph)
    obj.location.x += 0.5                       # a transform is not geometry
    bpy.context.view_layer.update()
    assert mesh_batches.object_batches(obj, bpy.context.evaluated_depsgraph_get()) is first
    obj.data.vertices[0].co.z += 0.25
    obj.data.update()
    bpy.context.view_layer.update()
    second = mesh_batches.object_batches(obj, bpy.context.evaluated_depsgraph_get())
    assert second is not first
    assert second.arrays.positions[:, 2].max() > first.arrays.positions[:, 2].max()


def test_variants_cached_and_rebuilt_when_lights_change(clean_scene, glossy_model):
    cube_material(glossy_model)
    draw.render_camera(clean_scene, width=32, height=24)
    before = set(shaders.cached_variants())
    draw.render_camera(clean_scene, width=32, height=24)
    assert set(shaders.cached_variants()) == before
    data = bpy.data.lights.new("Second", "SUN")
    second = bpy.data.objects.new("Second", data)
    clean_scene.collection.objects.link(second)
    _, stats = draw.render_camera(clean_scene, width=32, height=24)
    (key,) = stats.variants
    assert key.lights == 2 and key.light_types == frozenset({"POINT", "SUN"})
    assert key not in before


def test_only_what_the_scene_needs_is_compiled(clean_scene, glossy_model):
    cube_material(glossy_model)
    _, stats = draw.render_camera(clean_scene, width=32, height=24)
    (key,) = stats.variants
    defines = key.defines()
    assert defines["SM_LIGHT_TYPES"] == "2"          # the start-up file's point light only
    assert defines["SM_PACKS"] == "2" and defines["SM_AXES"] == "3"
    assert defines["SM_PARAM"] == "1"                # io_iso
    assert "SM_GEOMETRY_SPHERE" not in defines


def test_spectral_power_scales_the_light(clean_scene, glossy_model):
    cube_material(glossy_model)
    once, _ = draw.render_camera(clean_scene, width=32, height=24)
    bpy.data.objects["Light"].data.spectral.power = 2.5
    scaled, _ = draw.render_camera(clean_scene, width=32, height=24)
    covered = once[..., 3] > 0
    np.testing.assert_allclose(scaled[covered, :3], 2.5 * once[covered, :3], rtol=1e-5,
                               atol=1e-7)


def test_too_many_lights_is_a_clear_error():
    key = shaders.ShaderKey("io_iso", 3, 1, 8, shaders.MAX_LIGHTS + 1, frozenset({"SUN"}))
    with pytest.raises(ValueError, match="hide or disable some lights"):
        key.validate()


def test_no_camera_or_nothing_factored_is_a_clear_error(clean_scene):
    with pytest.raises(ValueError, match="no visible object has a factored"):
        draw.render_camera(clean_scene, width=16, height=16)
    bpy.data.objects.remove(bpy.data.objects["Camera"])
    with pytest.raises(ValueError, match="no camera"):
        draw.render_camera(clean_scene, width=16, height=16)


def test_unfactored_geometry_occludes(clean_scene, glossy_model):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    _sphere_with(glossy_model, location=(0.0, 0.0, 0.0))
    open_image, _ = draw.render_camera(clean_scene, width=64, height=48)
    camera = clean_scene.camera.matrix_world.translation
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=camera * 0.5)   # between, unfactored
    blocked, _ = draw.render_camera(clean_scene, width=64, height=48)
    assert blocked[..., 3].sum() < open_image[..., 3].sum()


def test_viewport_handler_life_cycle(clean_scene):
    assert not draw.viewport_enabled()
    clean_scene.spectral.viewport_draw = True
    assert draw.viewport_enabled()
    clean_scene.spectral.viewport_draw = False
    assert not draw.viewport_enabled()
    clean_scene.spectral.viewport_draw = True
    bpy.ops.wm.read_homefile(use_factory_startup=True)   # load_pre removes it, load_post
    assert not draw.viewport_enabled()                    # finds no scene asking for it
    bpy.context.scene.spectral.viewport_draw = True
    from spectral_materials import blender as addon

    addon.unregister()
    try:
        assert not draw.viewport_enabled()
        assert draw._on_load_pre not in bpy.app.handlers.load_pre
    finally:
        addon.register()
    bpy.context.scene.spectral.viewport_draw = False


def test_render_spectral_script_writes_exr_and_png(clean_scene, glossy_model, tmp_path):
    cube_material(glossy_model)
    blend = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    stem = tmp_path / "frame"
    run = subprocess.run([sys.executable, str(REPO / "scripts" / "render_spectral.py"),
                          str(blend), "--out", str(stem), "--width", "48", "--height", "32"],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    channels, header = read_exr(tmp_path / "frame_xyz.exr")
    assert sorted(channels) == ["A", "X", "Y", "Z"] and channels["Y"].shape == (32, 48)
    assert channels["A"].sum() > 0 and np.isfinite(channels["Y"]).all()
    srgb, _ = read_exr(tmp_path / "frame_srgb.exr")
    assert sorted(srgb) == ["A", "B", "G", "R"]
    assert (tmp_path / "frame.png").stat().st_size > 0
    missing = subprocess.run([sys.executable, str(REPO / "scripts" / "render_spectral.py"),
                              str(tmp_path / "nope.blend"), "--out", str(stem)],
                             capture_output=True, text=True, timeout=600)
    assert missing.returncode == 1 and "does not exist" in missing.stderr


def test_render_sphere_command_matches_the_mirror(glossy_model, tmp_path):
    path = glossy_model.save(tmp_path / "gloss.npz")
    out = tmp_path / "sphere.exr"
    run = subprocess.run([sys.executable, "-m", "spectral_materials", "render-sphere", str(path),
                          "--incidence", "30", "--illuminant", "FL2", "--out", str(out),
                          "--size", "48", "--quiet"], capture_output=True, text=True,
                         timeout=600, cwd=REPO)
    assert run.returncode == 0, run.stderr
    channels, header = read_exr(out)
    assert sorted(channels) == ["X", "Y", "Z"] and header["illuminant"] == "FL2"
    xyz = np.stack([channels[c] for c in "XYZ"], axis=-1).astype(np.float64)
    reference, mask = shading.sphere_xyz(glossy_model, 30, "FL2", 48)
    de = colour_pipeline.delta_e94(reference[mask], xyz[mask],
                                   colour_pipeline.white_xyz("FL2", WL))
    assert de.max() <= 0.1
    bad = subprocess.run([sys.executable, "-m", "spectral_materials", "render-sphere",
                          str(path), "--illuminant", "XYZ", "--out", str(out)],
                         capture_output=True, text=True, timeout=600, cwd=REPO)
    assert bad.returncode == 2 and "unknown illuminant" in bad.stderr
