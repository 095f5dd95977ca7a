"""EEVEE's own shadows of the spectral lights (blender/eevee/shadow_twins.py and
shadow_nodes.py): a plate above a plane shadows each sun where EEVEE shadows it, the lit
part still matches the float64 evaluation, each light's shadow is its own, and removing
the path removes the twins."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

from spectral_materials.blender.brdf import storage
from spectral_materials.blender.eevee import apply as eevee, shadow_twins
from spectral_materials.blender.eevee.render import (
    _render_rgb,
    black_world,
    new_scene,
    new_sun,
    scene_linear_to_xyz,
)
from spectral_materials.blender.lights import scene_lights
from spectral_materials.blender.lights.visibility import SHADOW_TWIN_KEY
from spectral_materials.core.brdf import factor, models, prefilter, shading
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

WL = spectra.WAVELENGTHS_REFERENCE
SIZE = 48
#: The plane spans [−1, 1]², the camera looks down on it; pixel (row, column) centres.
CENTRES = (np.arange(SIZE) + 0.5) / SIZE * 2.0 - 1.0


@pytest.fixture(scope="module")
def model():
    brdf = models.make_model("ashikhmin_shirley", diffuse=(WL, spectra.colorchecker(12)),
                             nu=32.0, nv=32.0)
    return storage.as_stored(factor.factor_brdf(brdf, parameterization="io_iso",
                                                resolution=(16, 32, 16), packs=2,
                                                spectral_basis=8))


def _toward(incidence: float, azimuth: float) -> np.ndarray:
    a, p = np.radians(incidence), np.radians(azimuth)
    return np.array([np.sin(a) * np.cos(p), np.sin(a) * np.sin(p), np.cos(a)])


def _scene(model, suns, plates, tilt_deg: float = 0.0):
    """A plane of the factored material under ``suns`` ((incidence, azimuth, illuminant)),
    with square ``plates`` ((x, y, height, half size)) above it casting shadows; the plane
    and everything above it tilted about x by ``tilt_deg``."""
    scene = new_scene("shadows")
    bpy.context.window.scene = scene
    mesh = bpy.data.meshes.new("plane")
    mesh.from_pydata([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], [], [(0, 1, 2, 3)])
    plane = bpy.data.objects.new("plane", mesh)
    material = bpy.data.materials.new("shadowed")
    material.spectral.enabled = True
    mesh.materials.append(material)
    storage.store_factored(material, model)
    objects = [plane]
    for k, (x, y, height, half) in enumerate(plates):
        plate_mesh = bpy.data.meshes.new(f"plate {k}")
        plate_mesh.from_pydata([(x - half, y - half, height), (x + half, y - half, height),
                                (x + half, y + half, height), (x - half, y + half, height)],
                               [], [(0, 1, 2, 3)])
        objects.append(bpy.data.objects.new(f"plate {k}", plate_mesh))
    lights = [new_sun(f"sun {k}", incidence, illuminant, azimuth_deg=azimuth)
              for k, (incidence, azimuth, illuminant) in enumerate(suns)]
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type, camera.data.ortho_scale, camera.location = "ORTHO", 2.0, (0, 0, 5)
    for obj in objects + lights + [camera]:
        scene.collection.objects.link(obj)
    scene.camera, scene.world = camera, black_world("black")
    return scene, material, lights


def _reference(model, suns) -> np.ndarray:
    """XYZ of the plane's pixels under each sun alone, float64: (suns, pixels, 3)."""
    points = np.zeros((1, 3))
    out = []
    for incidence, azimuth, illuminant in suns:
        light = replace(shading.protocol_sun(0.0, illuminant, WL),
                        axis=tuple(-_toward(incidence, azimuth)))
        out.append(shading.shade_xyz(model, points, np.array([[0.0, 0.0, 1.0]]),
                                     np.array([[1.0, 0.0, 0.0]]), shading.View(),
                                     [light])[0])
    return np.array(out)


def _shadow_mask(plate, incidence: float, azimuth: float, margin: float) -> np.ndarray:
    """Pixels (row, column) inside the plate's shadow on the plane, shrunk (margin > 0) or
    grown (margin < 0) by ``margin``; row 0 is the image's bottom (y = −1)."""
    x, y, height, half = plate
    toward = _toward(incidence, azimuth)
    sx, sy = x - height * toward[0] / toward[2], y - height * toward[1] / toward[2]
    ys, xs = np.meshgrid(CENTRES, CENTRES, indexing="ij")
    return (np.abs(xs - sx) < half - margin) & (np.abs(ys - sy) < half - margin)


def _plate_mask(plate, margin: float) -> np.ndarray:
    x, y, _, half = plate
    ys, xs = np.meshgrid(CENTRES, CENTRES, indexing="ij")
    return (np.abs(xs - x) < half + margin) & (np.abs(ys - y) < half + margin)


def _assert_no_twins() -> None:
    """No object, light or receiver collection of a shadow twin is left, whatever its name."""
    assert not [o.name for o in bpy.data.objects if o.get(SHADOW_TWIN_KEY)]
    assert not [light.name for light in bpy.data.lights if light.get(SHADOW_TWIN_KEY)]
    assert not [c.name for c in bpy.data.collections
                if c.name.startswith(shadow_twins.RECEIVERS_PREFIX)]


def _render_xyz(scene, samples: int = 1) -> np.ndarray:
    rgb, _ = _render_rgb(scene, SIZE, samples)
    return scene_linear_to_xyz(rgb, scene.spectral.adaptation_white)


def _de(reference_xyz: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    to_rgb = prefilter.scene_linear_matrix(colour_pipeline.white_xyz("D65", WL),
                                           eevee.working_space())
    reference = np.broadcast_to(prefilter.clamped_xyz(reference_xyz[None], to_rgb)[0],
                                xyz.shape)
    return colour_pipeline.delta_e94(reference, xyz, colour_pipeline.white_xyz("D65", WL))


def test_a_spectral_sun_keeps_its_eevee_shadow(clean_scene, model):
    suns = [(35.0, 200.0, "D65")]
    plate = (0.1, 0.2, 0.6, 0.3)
    scene, material, lights = _scene(model, suns, [plate])
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1)
    xyz = _render_xyz(scene)
    reference = _reference(model, suns)[0]
    shadow = _shadow_mask(plate, *suns[0][:2], margin=0.08) & ~_plate_mask(plate, 0.05)
    lit = ~_shadow_mask(plate, *suns[0][:2], margin=-0.08) & ~_plate_mask(plate, 0.05)
    assert shadow.sum() > 20 and lit.sum() > 500
    de = _de(reference, xyz[lit])
    assert de.mean() <= 0.1, de.mean()
    # In the shadow nothing lights the plane: the spectral sun's term is gone.
    assert np.abs(xyz[shadow][:, 1]).max() <= 0.01 * reference[1], xyz[shadow][:, 1].max()
    # Without the twins the sun shines through the plate, as before this path had them.
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1, shadows=False)
    assert not shadow_twins.twins_of(lights[0])
    unshadowed = _render_xyz(scene)
    assert _de(reference, unshadowed[shadow]).mean() <= 0.1


def test_each_spectral_light_keeps_its_own_shadow(clean_scene, model):
    """Two suns of different spectra, a plate each: where one sun is shadowed the plane
    shows the other's term alone, so the probes do not mix the lights up."""
    suns = [(30.0, 0.0, "D65"), (40.0, 120.0, "FL2")]
    plates = [(-0.45, 0.45, 0.5, 0.25), (0.45, -0.45, 0.5, 0.25)]
    scene, material, lights = _scene(model, suns, plates)
    counts = eevee.apply_eevee(material, scene, light_object=lights[0], lights=2)
    assert counts["lights"] == ["sun 0", "sun 1"]
    xyz = _render_xyz(scene)
    reference = _reference(model, suns)
    plates_mask = _plate_mask(plates[0], 0.05) | _plate_mask(plates[1], 0.05)
    for k in range(2):
        alone = np.zeros(SIZE * SIZE, bool).reshape(SIZE, SIZE)
        for plate in plates:
            alone |= _shadow_mask(plate, *suns[k][:2], margin=0.06)
        other = 1 - k
        grown = np.zeros_like(alone)
        for plate in plates:
            grown |= _shadow_mask(plate, *suns[other][:2], margin=-0.06)
        only_other = alone & ~grown & ~plates_mask
        assert only_other.sum() > 10
        assert _de(reference[other], xyz[only_other]).mean() <= 0.2


def test_twins_follow_apply_and_remove(clean_scene, model):
    suns = [(35.0, 200.0, "D65")]
    scene, material, lights = _scene(model, suns, [])
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1)
    output = next(n for n in material.node_tree.nodes
                  if n.bl_idname == "ShaderNodeOutputMaterial")
    # Thin probes (thickness 0) where EEVEE lights them: 5.0 and later.
    assert output.inputs["Thickness"].is_linked == (bpy.app.version >= (5, 0, 0))
    twins = shadow_twins.twins_of(lights[0])
    assert [t.data.color[:] for t in twins] == [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]
    assert [t.data.use_shadow for t in twins] == [True, False]
    assert all(t.parent == lights[0] for t in twins)
    assert all(t.data.diffuse_factor == 0 and t.data.specular_factor == 0 for t in twins)
    receivers = twins[0].light_linking.receiver_collection
    assert [o.name for o in receivers.objects] == ["plane"]
    # The twins are helpers: no spectral path counts them as lights.
    reaching, _ = scene_lights.scene_lights(scene)
    assert [o.name for o in reaching] == ["sun 0"]
    # Their power follows the light's through a driver.
    # What EEVEE renders: the evaluated copy (Blender 4.5 does not write a driver's value
    # back to the original on frame_set).
    lights[0].data.energy = 3.0
    scene.frame_set(scene.frame_current)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for twin in twins:
        assert twin.data.evaluated_get(depsgraph).energy == pytest.approx(
            3.0 * shadow_twins.TWIN_GAIN)
    # Cycles ignores a light's factors: the twins keep transmission rays only.
    assert not any(t.visible_diffuse or t.visible_glossy or t.visible_camera for t in twins)
    eevee.remove_eevee(material, scene)
    _assert_no_twins()
    assert not output.inputs["Thickness"].is_linked


def test_soft_shadow_edges_are_eevees_own(clean_scene, model):
    """A sun of angular diameter 8° casts a penumbra. The spectral term's visibility (the
    render over the same render without shadows) matches EEVEE's own shadow of that sun
    on a plain Diffuse BSDF, pixel by pixel, penumbra included."""
    suns = [(30.0, 90.0, "D65")]
    plate = (0.0, -0.3, 0.8, 0.35)
    scene, material, lights = _scene(model, suns, [plate])
    lights[0].data.angle = np.radians(8.0)
    lights[0].data.use_shadow_jitter = True      # EEVEE's soft shadows, over the samples
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1)
    shadowed = _render_xyz(scene, 16)[..., 1]
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1, shadows=False)
    ours = shadowed / np.maximum(_render_xyz(scene, 16)[..., 1], 1e-9)
    # EEVEE's own: the same plane with a Diffuse BSDF, lit by the same sun directly.
    eevee.remove_eevee(material, scene)
    plain = bpy.data.materials.new("plain diffuse")
    plain.use_nodes = True
    bpy.data.objects["plane"].data.materials[0] = plain
    lit = _render_xyz(scene, 16)[..., 1]
    lights[0].data.use_shadow = False
    eevees = lit / np.maximum(_render_xyz(scene, 16)[..., 1], 1e-9)
    keep = ~_plate_mask(plate, 0.05)
    penumbra = keep & (eevees > 0.1) & (eevees < 0.9)
    assert penumbra.sum() >= 10, penumbra.sum()
    assert np.abs(ours - eevees)[keep].mean() <= 0.02
    assert np.abs(ours - eevees)[penumbra].mean() <= 0.1, np.abs(ours - eevees)[penumbra]


def test_twins_are_shared_until_the_last_material_lets_go(clean_scene, model):
    scene, first, lights = _scene(model, [(35.0, 200.0, "D65")], [])
    mesh = bpy.data.meshes.new("second")
    mesh.from_pydata([(2, -1, 0), (4, -1, 0), (4, 1, 0), (2, 1, 0)], [], [(0, 1, 2, 3)])
    second = bpy.data.materials.new("second")
    second.spectral.enabled = True
    mesh.materials.append(second)
    storage.store_factored(second, model)
    scene.collection.objects.link(bpy.data.objects.new("second plane", mesh))
    for material in (first, second):
        eevee.apply_eevee(material, scene, light_object=lights[0], lights=1)
    receivers = shadow_twins.twins_of(lights[0])[0].light_linking.receiver_collection
    assert sorted(o.name for o in receivers.objects) == ["plane", "second plane"]
    eevee.remove_eevee(first, scene)
    twins = shadow_twins.twins_of(lights[0])
    assert len(twins) == 2
    assert [o.name for o in twins[0].light_linking.receiver_collection.objects] == \
        ["second plane"]
    eevee.remove_eevee(second, scene)
    _assert_no_twins()


def test_a_point_light_keeps_its_shadow_beside_a_light_left_to_rgb(clean_scene, model):
    """A point light (whose twins EEVEE 5.0 would drop without a reach of their own) is
    the spectral light; an FL2 sun, coloured, is left to the RGB Principled BSDF and
    reaches the probes too. In the point light's shadow the plane shows the sun's RGB
    term alone; outside it, what it shows without the shadows."""
    suns = [(50.0, 0.0, "FL2")]
    plate = (0.2, 0.0, 0.5, 0.25)
    scene, material, lights = _scene(model, suns, [plate])
    point = bpy.data.objects.new("point", bpy.data.lights.new("point", "POINT"))
    point.data.energy = 400.0
    point.data.shadow_soft_size = 0.0
    point.location = (-0.8, 0.0, 2.0)
    scene.collection.objects.link(point)
    counts = eevee.apply_eevee(material, scene, light_object=point, lights=1)
    assert counts["lights"] == ["point"] and counts["shadows"]
    shadowed = _render_xyz(scene)[..., 1]
    eevee.apply_eevee(material, scene, light_object=point, lights=1, shadows=False)
    unshadowed = _render_xyz(scene)[..., 1]
    point.data.energy = 0.0                       # the spectral term gone: the sun alone
    sun_alone = _render_xyz(scene)[..., 1]
    # The plate's shadow from the point light: its corners projected from the light.
    x, y, height, half = plate
    scale = point.location.z / (point.location.z - height)
    sx = point.location.x + (x - point.location.x) * scale
    ys, xs = np.meshgrid(CENTRES, CENTRES, indexing="ij")
    inside = (np.abs(xs - sx) < half * scale - 0.08) & (np.abs(ys - y) < half * scale - 0.08)
    shadow = inside & ~_plate_mask(plate, 0.05)
    outside = ~((np.abs(xs - sx) < half * scale + 0.08) & (np.abs(ys - y) < half * scale + 0.08))
    lit = outside & ~_plate_mask(plate, 0.05) & ~_shadow_mask(plate, 50.0, 0.0, -0.08)
    assert shadow.sum() > 20 and lit.sum() > 500
    term = unshadowed - sun_alone
    assert term[shadow].mean() > 0.02               # the point light does reach there
    assert np.abs(shadowed - sun_alone)[shadow].max() <= 0.02 * term[shadow].mean()
    assert np.abs(shadowed - unshadowed)[lit].max() <= 0.02 * term[lit].mean()


def test_a_renamed_light_keeps_and_then_frees_its_twins(clean_scene, model):
    scene, material, lights = _scene(model, [(35.0, 200.0, "D65")], [])
    eevee.apply_eevee(material, scene, light_object=lights[0], lights=1)
    lights[0].name = "key sun"
    assert len(shadow_twins.twins_of(lights[0])) == 2
    bpy.data.objects.remove(lights[0])            # the light deleted, its twins orphaned
    eevee.remove_eevee(material, scene)
    _assert_no_twins()
