"""BTF materials in the draw handler: the GPU image against the Python mirror pixel by
pixel (both RF kinds, view interpolation, tiled records), storage round trips, extreme
lobes, and clear errors."""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from mathutils import Vector

from spectral_materials.blender.btf import drawer as btf_gpu, storage as btf_storage
from spectral_materials.blender.lights import scene_lights
from spectral_materials.blender.viewport import draw
from spectral_materials.core.brdf.shading import shading_frame
from spectral_materials.core.btf import container as btf, render as btf_render
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

WL = spectra.WAVELENGTHS_REFERENCE
SIZE = (128, 96)


def synthetic_drawable(kind: str, *, texels=(6, 8), lobes=2, seed=0, extreme=False,
                       views=None) -> btf_render.DrawableBTF:
    """Random but plausible parameters over the UBO 81 views (or ``views``); albedo from
    chart patches."""
    rng = np.random.default_rng(seed)
    views = btf.ring_directions() if views is None else views
    h, w = texels
    if kind == "RFP":
        params = np.zeros((len(views), h, w, 8), np.float32)
        params[..., :5] = rng.normal(0.0, 0.15, (len(views), h, w, 5))
        params[..., 5] = rng.uniform(0.3, 0.8, (len(views), h, w))
    else:
        params = np.zeros((len(views), h, w, 4 + 4 * lobes), np.float32)
        params[..., 0] = rng.uniform(0.05, 0.3, (len(views), h, w))
        for j in range(lobes):
            params[..., 1 + j] = rng.uniform(0.1, 1.0, (len(views), h, w))
            t = rng.normal(size=(len(views), h, w, 3))
            t[..., 2] = np.abs(t[..., 2]) + 1.0
            params[..., 4 + 4 * j: 7 + 4 * j] = t / np.linalg.norm(t, axis=-1, keepdims=True)
            params[..., 7 + 4 * j] = rng.uniform(1.0, 40.0, (len(views), h, w))
        if extreme:
            params[..., 1] = btf_render.AMPLITUDE_MAX
            params[..., 7] = btf_render.N_MAX
    patches = np.stack([spectra.colorchecker(p, WL) for p in (1, 6, 13, 19)])
    albedo = patches[rng.integers(0, 4, (h, w))]
    basis, coefficients = btf_render.albedo_basis(albedo, 4)
    return btf_render.DrawableBTF(kind, lobes if kind == "RFNL" else 0, views, params,
                                  coefficients, basis, name=f"synthetic {kind}")


def _btf_sphere(drawable, *, uv_scale=(2.0, 1.0), location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, location=location)
    obj = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    material = bpy.data.materials.new("BTF probe")
    obj.data.materials.append(material)
    btf_storage.store_btf(material, drawable, uv_scale=uv_scale)
    camera = bpy.context.scene.camera
    camera.location = (2.4, -2.0, 1.6)
    camera.rotation_euler = (-Vector(camera.location)).to_track_quat("-Z", "Y").to_euler()
    return obj, material


def _gpu_against_mirror(scene, material, *, tile_limits=None):
    if tile_limits is not None:
        btf_gpu.clear_cache()
        resource = btf_gpu.btf_material(material)
        btf_gpu._MATERIALS[material.name] = _with_limits(resource, tile_limits)
    xyz, stats = draw.render_camera(scene, width=SIZE[0], height=SIZE[1])
    gbuffer = {out: draw.render_camera(scene, width=SIZE[0], height=SIZE[1], output=out)[0]
               for out in ("POSITION", "NORMAL", "TANGENT", "COORDINATES")}
    covered = xyz[..., 3] > 0
    assert covered.sum() > 1000 and np.isfinite(xyz).all()
    _, view = draw.camera_view(scene.camera, SIZE[0], SIZE[1],
                               bpy.context.evaluated_depsgraph_get())
    lights, _ = scene_lights.drawn_lights(scene, np.asarray(view.origin))
    drawable = btf_storage.load_btf(material)
    points = gbuffer["POSITION"][covered, :3].astype(np.float64)
    t, b, n = shading_frame(gbuffer["NORMAL"][covered, :3], gbuffer["TANGENT"][covered, :3])
    frames = np.stack([t, b, n], axis=1)
    reference = drawable.shade_xyz(gbuffer["COORDINATES"][covered, :2], frames, points,
                                   view.directions(points), lights,
                                   scale=btf_storage.uv_scale(material))
    scale = max(reference[:, 1].max(), 1e-6)
    de = colour_pipeline.delta_e94(reference / scale, xyz[covered, :3] / scale,
                                   colour_pipeline.white_xyz("D65", WL))
    return de, stats


def _with_limits(resource, limits):
    rebuilt = btf_gpu.BTFMaterial(resource.drawable, resource.uv_scale, limits=limits)
    rebuilt.cache_key = resource.cache_key
    return rebuilt


def _add_lights(scene) -> None:
    """Three more lights of other kinds and spectra, aimed at the origin: with the scene's
    own, four (RFNL's texel-outermost loop and RFP's light-outermost one both run)."""
    from mathutils import Vector

    for kind, location, energy, illuminant in (("POINT", (3, -4, 2), 300.0, "A"),
                                               ("SPOT", (-4, -5, 4), 1500.0, "FL2"),
                                               ("SUN", (-2, -3, 5), 1.5, "FL11")):
        data = bpy.data.lights.new(kind, kind)
        data.energy = energy
        data.spectral.illuminant = illuminant
        obj = bpy.data.objects.new(kind, data)
        obj.location = location
        obj.rotation_euler = (-Vector(location)).to_track_quat("-Z", "Y").to_euler()
        scene.collection.objects.link(obj)
    bpy.context.view_layer.update()


@pytest.mark.parametrize("lights", [1, 4])
@pytest.mark.parametrize("kind", ["RFP", "RFNL"])
def test_gpu_matches_the_mirror(clean_scene, kind, lights):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    if lights == 4:
        _add_lights(clean_scene)
    _, material = _btf_sphere(synthetic_drawable(kind))
    de, stats = _gpu_against_mirror(clean_scene, material)
    drawn, _ = scene_lights.drawn_lights(clean_scene)
    assert len(drawn) == lights
    # Every pixel: texels blend continuously across their edges (texel_blend), so a
    # float32 UV on an edge no longer picks a texel the mirror might not.
    assert de.max() < 0.01, (np.percentile(de, 99.5), de.max())
    assert material.name in stats.materials


def test_tiled_records_and_a_dense_view_set_draw_the_same(clean_scene):
    """Fewer array layers than records: records share layers as tiles. 151 scattered
    views: view cells list more than 8 candidate triangles."""
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    views = np.random.default_rng(5).normal(size=(151, 3))
    views[:, 2] = np.abs(views[:, 2])
    drawable = synthetic_drawable("RFNL", lobes=1, views=views)
    assert drawable.triangulation.cell_count.max() > 8
    _, material = _btf_sphere(drawable)
    de, _ = _gpu_against_mirror(clean_scene, material, tile_limits=(16, 4096))
    assert btf_gpu._MATERIALS[material.name].layout.tiles_per_layer > 1
    assert np.mean(de < 0.01) > 0.995


def test_extreme_lobes_stay_finite(clean_scene):
    """Amplitude at its clamp and n = 10 000: no inf or NaN reaches the target."""
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    _, material = _btf_sphere(synthetic_drawable("RFNL", extreme=True))
    xyz, _ = draw.render_camera(clean_scene, width=64, height=48)
    assert np.isfinite(xyz).all()
    display, _ = draw.render_camera(clean_scene, width=64, height=48, output="DISPLAY")
    assert np.isfinite(display).all() and display[..., :3].max() <= 1.0


def test_storage_round_trip_is_bit_identical(clean_scene):
    drawable = synthetic_drawable("RFNL", texels=(5, 7), lobes=3)
    material = bpy.data.materials.new("Stored")
    btf_storage.store_btf(material, drawable, uv_scale=(3.0, 2.0), figures={"eps": 0.1})
    loaded = btf_storage.load_btf(material)
    assert np.array_equal(loaded.params, drawable.params)
    assert np.array_equal(loaded.coefficients, drawable.coefficients)
    assert np.allclose(loaded.views, drawable.views) and loaded.kind == "RFNL"
    assert btf_storage.uv_scale(material) == (3.0, 2.0)
    assert btf_storage.figures(material) == {"eps": 0.1}
    image_name = btf_storage.btf_image(material).name
    assert btf_storage.clear_btf(material) and image_name not in bpy.data.images
    with pytest.raises(ValueError, match="no BTF"):
        btf_storage.load_btf(material)


def test_a_damaged_image_is_a_clear_error(clean_scene):
    material = bpy.data.materials.new("Damaged")
    btf_storage.store_btf(material, synthetic_drawable("RFP"))
    image = btf_storage.btf_image(material)
    image.scale(image.size[0] // 2, image.size[1])
    with pytest.raises(ValueError, match="fit the BTF again"):
        btf_storage.load_btf(material)
    assert btf_gpu.btf_material(material) is None
    assert "fit the BTF again" in btf_gpu.FAILED[material.name]


def _material_on_plane(name="Corduroy"):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    obj = bpy.context.active_object
    material = bpy.data.materials.new(name)
    obj.data.materials.append(material)
    return obj, material


def test_fit_operator_stores_a_drawable_btf_and_survives_reload(clean_scene, tmp_path):
    obj, material = _material_on_plane()
    s = material.spectral_btf
    s.source, s.texels, s.model = "CORDUROY", 4, "RFP"
    assert bpy.ops.spectral.fit_btf() == {"FINISHED"}
    figures = btf_storage.figures(material)
    assert figures["model"] == "RFP" and figures["views"] == 81
    assert 0 < figures["epsilon_avg"] < 0.2 and figures["gpu_bytes"] > 0
    xyz, stats = draw.render_camera(clean_scene, width=48, height=36)
    assert material.name in stats.materials and np.isfinite(xyz).all()
    assert xyz[..., 1].max() > 0
    before = btf_storage.load_btf(material)
    path = str(tmp_path / "btf.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    after = btf_storage.load_btf(bpy.data.materials["Corduroy"])
    assert np.array_equal(before.params, after.params)
    assert np.array_equal(before.coefficients, after.coefficients)


def test_fit_with_a_missing_file_changes_nothing(clean_scene, tmp_path):
    obj, material = _material_on_plane("Fabric")
    btf_storage.store_btf(material, synthetic_drawable("RFP"))
    token = material[btf_storage.PROPERTY]["token"]
    s = material.spectral_btf
    s.source, s.filepath = "UBO2003", str(tmp_path / "missing.zip")
    with pytest.raises(RuntimeError, match="no such file"):
        bpy.ops.spectral.fit_btf()
    assert material[btf_storage.PROPERTY]["token"] == token
    s.filepath = ""
    with pytest.raises(RuntimeError, match="choose the UBO2003 file"):
        bpy.ops.spectral.fit_btf()
