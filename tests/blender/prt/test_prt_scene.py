"""Spectral PRT in Blender: vertex colours against the Monte Carlo reference, the GPU
drawing against the Python evaluation pixel by pixel, storage, rotation, bad input."""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from blender_helpers import ledge_mesh

from spectral_materials.blender.gpu import shaders
from spectral_materials.blender.prt import (
    drawer as prt_gpu,
    images as prt_images,
    scene as prt,
)
from spectral_materials.blender.viewport import draw
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.prt import albedo as core_albedo, transfer as core_prt

WL = spectra.WAVELENGTHS_REFERENCE


def _ledge_scene(scene, *, subdivisions: int = 12):
    """The ledge (one self-shadowing mesh) seen from above at 48 × 48 px."""
    obj = ledge_mesh(subdivisions)
    obj.name = "Ledge"
    camera = scene.camera
    camera.location = (5.0, -5.0, 5.0)
    camera.rotation_euler = (np.radians(54.7), 0.0, np.radians(45.0))
    scene.render.resolution_x = scene.render.resolution_y = 48
    scene.render.resolution_percentage = 100
    return obj


def _setup(scene, obj, *, illuminant="D65", kind="CHART", bands=5, rays=256):
    env = scene.spectral.environment
    env.source, env.illuminant, env.sky, env.bands = "SKY", illuminant, "OVERCAST", bands
    obj.spectral_prt.albedo_kind = kind
    obj.spectral_prt.rays = rays
    prt.bake_prt(obj, scene)


def test_vertex_xyz_against_the_monte_carlo_reference(clean_scene):
    obj = _ledge_scene(clean_scene)
    _setup(clean_scene, obj, kind="SPECTRUM", bands=5, rays=1024)
    obj.spectral_prt.albedo.patch = "13"            # blue: far from white, under FL2 too
    for illuminant in ("D65", "FL2"):
        clean_scene.spectral.environment.illuminant = illuminant
        xyz = prt.vertex_xyz(obj)
        reference = prt.vertex_reference_xyz(obj, rays=4096)
        white = prt.environment_white_xyz(clean_scene)
        de = colour_pipeline.delta_e94(reference, xyz, white)
        assert xyz.shape == (len(obj.data.vertices), 3) and np.isfinite(xyz).all()
        # Measured: mean ≈ 0.4, p95 ≈ 1.5 (5 SH bands against shadows with sharp edges).
        assert np.mean(de) < 1.0 and np.percentile(de, 95) < 3.0, (illuminant, de.mean())


@pytest.mark.parametrize("albedo", ["EXACT", "BASIS", "UNORM16"])
@pytest.mark.parametrize("environment_in", ["buffer", "texture"])
@pytest.mark.parametrize("basis", [8, 5], ids=["m8", "m5"])
def test_gpu_matches_the_python_evaluation_pixel_by_pixel(clean_scene, basis, environment_in,
                                                          albedo, monkeypatch):
    """m = 5 leaves the last group of packed albedo layers partly empty. L̃ comes from the
    uniform buffer where it fits (always, at 5 bands); the texture path is forced. The
    albedo is drawn as the float32 R̃ layers, the chart's texture basis (12 weights at
    m = 8, 8 at m = 5) or the 16-bit layers; each against the values that form holds,
    filtered with exact weights as llvmpipe filters
    (a GPU's texture unit rounds them to 8 bits: albedo.sample_layers' weight_bits, the
    size of the difference docs/bench_gpu.md shows on an H200)."""
    if environment_in == "texture":
        monkeypatch.setattr(prt_gpu, "environment_fits", lambda k, m: False)
    obj = _ledge_scene(clean_scene, subdivisions=6)
    clean_scene.spectral.environment.basis_size = basis
    obj.spectral_prt.albedo_texture = albedo
    _setup(clean_scene, obj, kind="CHART", rays=128)
    assert prt.albedo_layers(obj, clean_scene).layers.shape[0] == basis
    clean_scene.spectral.environment.rotation = 0.7
    obj.rotation_euler = (0.0, 0.0, 0.4)
    bpy.context.view_layer.update()
    image = draw.render_camera(clean_scene, output="XYZ")[0]
    geometry = prt_images.pixel_geometry(clean_scene, obj)
    np.testing.assert_array_equal(geometry.covered, image[..., 3] > 0.5)
    assert geometry.covered.sum() > 300
    environment = prt.object_environment(obj, clean_scene)
    transfer = prt_gpu._OBJECTS[obj.name]["arrays"].transfer
    e = prt_images.interpolate(geometry, core_prt.irradiance(transfer, environment))
    drawn = prt_gpu._OBJECTS[obj.name]["albedo_drawn"]
    assert drawn.form == albedo.lower()
    layers = prt.albedo_layers(obj, clean_scene).layers
    if albedo == "UNORM16":
        # What the texture holds, rebuilt here: 16 bits over each layer component's range.
        packed = core_albedo.layers_to_rgba(layers).astype(np.float64)
        low = packed.min(axis=(1, 2), keepdims=True)
        span = packed.max(axis=(1, 2), keepdims=True) - low
        span[span == 0] = 1.0                       # the padding component at m = 5
        steps = np.round((packed - low) / span * 65535) / 65535 * span + low
        # Within one step (a code may round the other way from float32 ranges), and not
        # the float32 values themselves.
        error = np.abs(core_albedo.layers_to_rgba(drawn.layers) - steps)
        assert (error <= span / 65535 * 1.001).all()
        assert np.abs(drawn.layers - layers).max() > 1e-6 * np.abs(packed).max()
    weights = core_albedo.sample_layers(drawn.layers, geometry.uv)
    expected = np.clip(np.einsum("pm,pmc->pc", e, weights), 0.0, None)
    gpu_xyz = image[..., :3][geometry.covered]
    white = prt.environment_white_xyz(clean_scene)
    de = colour_pipeline.delta_e94(expected, gpu_xyz, white)
    assert de.max() < 0.02, de.max()
    keys = [k for k in shaders.cached_variants() if isinstance(k, prt_gpu.PRTShaderKey)]
    assert any(k.environment_buffer == (environment_in == "buffer") for k in keys), keys
    assert any(bool(k.albedo_basis_layers) == (albedo == "BASIS") and
               k.unorm_layers == (albedo == "UNORM16") for k in keys), keys
    if albedo != "EXACT":
        # Against the full layers: the form's own error.
        full = np.clip(np.einsum("pm,pmc->pc", e, core_albedo.sample_layers(layers,
                                                                           geometry.uv)), 0, None)
        assert colour_pipeline.delta_e94(full, gpu_xyz, white).max() < 0.05


def test_automatic_draws_16_bit_layers_and_the_panel_says_so(clean_scene):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    _setup(clean_scene, obj, kind="CHART", rays=32)
    assert obj.spectral_prt.albedo_texture == "AUTO"
    draw.render_camera(clean_scene, output="XYZ")
    drawn = prt_gpu._OBJECTS[obj.name]["albedo_drawn"]
    assert drawn.form == "unorm16" and 0 < drawn.delta_e94 < 0.05
    status = prt_gpu.albedo_status(obj)
    assert "16-bit values" in status and "6 layers" in status, status
    obj.spectral_prt.albedo_texture = "EXACT"
    assert prt_gpu.albedo_status(obj) == ""          # until drawn with the new setting


def test_rgb_prt_white_matches_spectral_and_colours_differ_under_fl4(clean_scene):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    _setup(clean_scene, obj, kind="SPECTRUM", illuminant="FL4", rays=64)
    obj.spectral_prt.albedo.kind = "CONSTANT"
    obj.spectral_prt.albedo.constant = 1.0
    rgb_white = draw.render_camera(clean_scene, output="XYZ")[0]
    prt_gpu.clear_cache()
    spectral = prt.vertex_xyz(obj)
    assert np.isfinite(rgb_white).all() and np.isfinite(spectral).all()


def test_stored_albedo_layers_and_transfer_survive_save_and_reload(clean_scene, tmp_path):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    _setup(clean_scene, obj, kind="CHART", rays=64)
    before = prt.vertex_xyz(obj)
    image = obj.spectral_prt.albedo_image
    assert image is not None and image.packed_file is not None
    path = str(tmp_path / "prt.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Ledge"]
    np.testing.assert_allclose(prt.vertex_xyz(obj), before, rtol=1e-5, atol=1e-6)


def test_environment_rotation_equals_rotating_the_object_the_other_way(clean_scene):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    env = clean_scene.spectral.environment
    env.sky, env.sun_fraction = "CLEAR", 0.5
    _setup(clean_scene, obj, kind="CHART", rays=64)
    env.sky, env.sun_fraction = "CLEAR", 0.5
    env.rotation = 0.9
    turned_env = prt.vertex_xyz(obj)
    env.rotation = 0.0
    obj.rotation_euler = (0.0, 0.0, -0.9)
    bpy.context.view_layer.update()
    np.testing.assert_allclose(prt.vertex_xyz(obj), turned_env, rtol=1e-6, atol=1e-7)


def test_unbaked_and_stale_objects_say_so_and_others_still_draw(clean_scene):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    obj.spectral_prt.enabled = True
    with pytest.raises(prt.PRTError, match="no current PRT transfer"):
        prt.vertex_xyz(obj)
    _setup(clean_scene, obj, rays=32)
    obj.data.vertices[0].co.z += 0.1
    obj.data.update()
    with pytest.raises(prt.PRTError, match="bake it"):
        prt.vertex_xyz(obj)
    with pytest.raises(ValueError, match="no visible object"):
        draw.render_camera(clean_scene)
    assert "Ledge" in prt_gpu.FAILED


@pytest.mark.parametrize("albedo", ["AUTO", "BASIS", "EXACT"])
def test_a_corrupt_stored_albedo_image_is_named_and_others_still_draw(clean_scene, albedo):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    obj.spectral_prt.albedo_texture = albedo
    _setup(clean_scene, obj, kind="CHART", rays=32)
    other = obj.copy()
    other.data = obj.data.copy()
    other.name = "Second ledge"
    other.location.x = 0.5
    clean_scene.collection.objects.link(other)
    _setup(clean_scene, other, kind="CHART", rays=32)
    image = obj.spectral_prt.albedo_image
    assert image is not None and other.spectral_prt.albedo_image not in (None, image)
    pixels = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels[5] = np.nan
    image.pixels.foreach_set(pixels)
    prt.clear_cache()
    prt_gpu.clear_cache()
    draw.render_camera(clean_scene, output="XYZ")
    assert "non-finite" in prt_gpu.FAILED.get("Ledge", ""), dict(prt_gpu.FAILED)
    assert image.name in prt_gpu.FAILED["Ledge"] and "Second ledge" not in prt_gpu.FAILED


def test_bad_environment_and_albedo_files_are_named(clean_scene, tmp_path):
    obj = _ledge_scene(clean_scene, subdivisions=4)
    env = clean_scene.spectral.environment
    env.source, env.filepath = "SPECTRAL_EXR", str(tmp_path / "missing.exr")
    obj.spectral_prt.enabled = True
    with pytest.raises(prt.PRTError, match="missing.exr"):
        prt.scene_environment(clean_scene)
    env.source = "SKY"
    obj.spectral_prt.albedo_kind = "SPECTRAL_EXR"
    broken = tmp_path / "broken.exr"
    broken.write_bytes(b"v/1\x01" + b"\0" * 40)
    obj.spectral_prt.filepath = str(broken)
    mesh_before = obj.data.attributes.keys()
    with pytest.raises(prt.PRTError, match="broken.exr"):
        prt.bake_prt(obj, clean_scene)
    assert obj.data.attributes.keys() == mesh_before


def test_operators_bake_clear_and_cancel(clean_scene):
    from spectral_materials.core.errors import Cancelled

    obj = _ledge_scene(clean_scene, subdivisions=4)
    obj.spectral_prt.albedo_kind = "CHART"
    obj.spectral_prt.rays = 32
    assert prt.transfer_status(obj) == "Not baked"
    assert bpy.ops.spectral.bake_prt() == {"FINISHED"}
    assert prt.transfer_status(obj).startswith("Baked")
    assert obj.spectral_prt.enabled and obj.spectral_prt.albedo_image is not None
    # A cancelled bake stores nothing: the earlier transfer stays as it was.
    before = prt.vertex_xyz(obj)
    plan = prt.plan_bake(obj, clean_scene)
    with pytest.raises(Cancelled):
        prt.run_bake(plan, lambda fraction, message: True)
    np.testing.assert_array_equal(prt.vertex_xyz(obj), before)
    assert bpy.ops.spectral.clear_prt() == {"FINISHED"}
    assert prt.transfer_status(obj) == "Not baked" and obj.spectral_prt.albedo_image is None
    obj.data.vertices[0].co.z += 0.1
    assert bpy.ops.spectral.bake_prt() == {"FINISHED"}
    obj.data.vertices[1].co.z += 0.1
    obj.data.update()
    assert prt.transfer_status(obj).startswith("Stale")


def test_stiff_geometry_gives_no_nan_and_no_negative(clean_scene):
    """An open, single-sided mesh with degenerate triangles and a vertex inside geometry,
    under a clear sky with a strong sun (ringing): finite, non-negative colours."""
    import bmesh

    for obj in list(bpy.data.objects):
        if obj.type != "CAMERA":
            bpy.data.objects.remove(obj)
    mesh = bpy.data.meshes.new("stiff")
    bm = bmesh.new()
    grid = [bm.verts.new((x, y, 0.0)) for y in range(4) for x in range(4)]
    for y in range(3):
        for x in range(3):
            i = 4 * y + x
            bm.faces.new((grid[i], grid[i + 1], grid[i + 5], grid[i + 4]))
    a, b = bm.verts.new((0.5, 0.5, 0.0)), bm.verts.new((0.5, 0.5, 0.0))
    c = bm.verts.new((0.5, 0.5, 0.0))
    bm.faces.new((a, b, c))                                  # zero area
    wall = [bm.verts.new(p) for p in ((1, 1, 0), (2, 1, 0), (2, 1, 1), (1, 1, 1))]
    bm.faces.new(wall)                                       # a single-sided wall
    bm.verts.new((1.5, 1.5, -0.5))                           # loose, below the floor
    bm.to_mesh(mesh)
    bm.free()
    obj = bpy.data.objects.new("Stiff", mesh)
    clean_scene.collection.objects.link(obj)
    env = clean_scene.spectral.environment
    env.sky, env.sun_fraction, env.sun_elevation, env.window = "CLEAR", 0.95, 0.3, "NONE"
    obj.spectral_prt.albedo.kind = "CONSTANT"
    obj.spectral_prt.albedo.constant = 1.0
    obj.spectral_prt.rays = 256
    prt.bake_prt(obj, clean_scene)
    xyz = prt.vertex_xyz(obj)
    assert np.isfinite(xyz).all() and (xyz >= 0).all()
    irradiance = core_prt.irradiance(prt._evaluated_arrays(
        obj, bpy.context.evaluated_depsgraph_get())[0], prt.object_environment(obj, clean_scene))
    assert np.isfinite(irradiance).all()
    reference = prt.vertex_reference_xyz(obj, rays=256)
    assert np.isfinite(reference).all() and (reference >= 0).all()


def test_the_albedo_basis_buffer_holds_the_mixing_where_the_shader_reads_it():
    from spectral_materials.core.prt.albedo_basis import AlbedoBasis

    rank, m = 6, 5
    mixing = np.arange(rank * m * 3, dtype=np.float32).reshape(rank, m, 3) + 1
    basis = AlbedoBasis(np.zeros((rank, 2, 2), np.float32), mixing, 0.0)
    texels = prt_gpu.albedo_basis_texels(basis, m)
    width = 4 * -(-m // 4)                                   # j padded to 8
    assert texels.shape == (3 * 2 * width, 4)
    for k in range(rank):
        for j in range(m):
            for c in range(3):
                # prt_frag.glsl: texel (l·3 + c)·4⌈m/4⌉ + j, component k % 4, l = k // 4.
                assert texels[((k // 4) * 3 + c) * width + j, k % 4] == mixing[k, j, c]
    assert np.count_nonzero(texels) == mixing.size
