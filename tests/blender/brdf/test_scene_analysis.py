"""Scene analysis: only visible, renderable materials and the lights that reach them count."""

from __future__ import annotations

import json

import bpy
import numpy as np
import pytest
from blender_helpers import add_sphere, spectral_material

from spectral_materials.blender.brdf import jobs, scene
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

pytestmark = pytest.mark.bpy


def _analysis() -> dict:
    return json.loads(bpy.context.scene.spectral.analysis_json)


def test_hidden_and_unused_materials_are_left_out(clean_scene):
    spectral_material("Seen", patch="9")
    hidden = add_sphere("Hidden", location=(3, 0, 0))
    spectral_material("OnHidden", patch="12", obj=hidden)
    hidden.hide_render = True
    orphan = bpy.data.materials.new("Orphan")
    orphan.spectral.enabled = True
    assert bpy.ops.spectral.factor_scene() == {"FINISHED"}
    analysis = _analysis()
    assert analysis["materials_used"] == ["Seen"]
    assert analysis["materials_unused"] == ["OnHidden", "Orphan"]
    assert list(analysis["factored"]) == ["Seen"]
    assert bpy.data.materials["OnHidden"].spectral.result.image is None
    assert "2 unused material(s) skipped" in bpy.context.scene.spectral.analysis


def test_non_spectral_materials_are_ignored(clean_scene):
    spectral_material("Spectral")
    plain = bpy.data.materials.new("Plain")
    add_sphere("Ball", location=(3, 0, 0)).data.materials.append(plain)
    plan = scene.plan_scene(bpy.context.scene)
    assert list(plan.materials) == ["Spectral"]


def test_lights_that_do_not_reach_are_left_out(clean_scene):
    spectral_material()
    sun = bpy.data.lights.new("Sun", "SUN")
    sun_obj = bpy.data.objects.new("Sun", sun)
    bpy.context.scene.collection.objects.link(sun_obj)
    sun.spectral.kind = "ILLUMINANT"
    sun.spectral.illuminant = "FL2"
    sun_obj.hide_render = True
    dark = bpy.data.lights.new("Dark", "POINT")
    dark.energy = 0.0
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Dark", dark))
    plan = scene.plan_scene(bpy.context.scene)
    assert list(plan.lights) == ["Light"]
    assert plan.hidden_lights == ["Dark (no power)", "Sun (hidden)"]


def test_no_light_falls_back_to_the_adaptation_white(clean_scene):
    spectral_material()
    bpy.data.objects.remove(bpy.data.objects["Light"])
    bpy.context.scene.spectral.adaptation_white = "D50"
    plan = scene.plan_scene(bpy.context.scene)
    assert plan.implicit_light == "D50"
    np.testing.assert_allclose(next(iter(plan.lights.values())),
                               spectra.illuminant("D50", spectra.WAVELENGTHS_REFERENCE))


def test_a_fluorescent_light_costs_coefficients(clean_scene):
    for patch in ("1", "2", "6", "12", "13", "15"):
        spectral_material(f"Patch {patch}", patch=patch)
    bpy.context.scene.spectral.basis_tolerance = 0.02
    assert bpy.ops.spectral.build_basis() == {"FINISHED"}
    daylight = bpy.context.scene.spectral.basis_size
    shop = bpy.data.lights.new("Shop", "POINT")
    shop.spectral.illuminant = "FL2"
    bpy.context.scene.collection.objects.link(bpy.data.objects.new("Shop", shop))
    assert bpy.ops.spectral.build_basis() == {"FINISHED"}
    assert bpy.context.scene.spectral.basis_size > daylight
    basis = _analysis()["basis"]
    assert basis["met"] and basis["max_de94"] <= 0.02
    assert _analysis()["lights"] == ["Light", "Shop"]


def test_basis_meets_the_tolerance_against_5nm(clean_scene):
    """Check the stored basis independently: ΨΨᵀ applied to each albedo/π, ΔE94 vs 5 nm."""
    for patch, name in (("1", "A"), ("6", "B"), ("15", "C")):
        spectral_material(name, patch=patch, model="LAMBERT")
    bpy.data.lights["Light"].spectral.illuminant = "FL11"
    tolerance = bpy.context.scene.spectral.basis_tolerance
    assert bpy.ops.spectral.build_basis() == {"FINISHED"}
    psi = jobs.load_scene_basis(bpy.context.scene).vectors.astype(np.float64)
    wl = spectra.WAVELENGTHS_REFERENCE
    weights = colour_pipeline.xyz_weights("FL11", wl)
    white = colour_pipeline.white_xyz("FL11", wl)
    for patch in (1, 6, 15):
        reflectance = spectra.colorchecker(patch, wl) / np.pi
        full = reflectance @ weights
        through = (psi.T @ reflectance) @ (psi.T @ weights)
        assert colour_pipeline.delta_e94(full, through, white) <= tolerance * 1.0001


def test_absurd_scene_settings_are_refused(clean_scene):
    spectral_material()
    bpy.context.scene.spectral.basis_tolerance = -1.0
    with pytest.raises(RuntimeError, match="basis tolerance must be"):
        bpy.ops.spectral.factor_scene()
