"""Operators and jobs: factor, skip what is current, undo, and leave the scene as it was on
failure or cancel."""

from __future__ import annotations

import math

import bpy
import numpy as np
import pytest
from blender_helpers import snapshot, spectral_material

from spectral_materials.blender.brdf import jobs, scene, sources, storage
from spectral_materials.core.brdf.metrics import random_direction_pairs, reference_xyz
from spectral_materials.core.errors import Cancelled

pytestmark = pytest.mark.bpy


def _factor(**kwargs) -> set[str]:
    return bpy.ops.spectral.factor_material(**kwargs)


@pytest.mark.parametrize("model", ["LAMBERT", "OREN_NAYAR", "ASHIKHMIN_SHIRLEY", "WARD", "GGX"])
def test_factor_material_every_model(clean_scene, model):
    material = spectral_material(model=model, packs=1)
    s = material.spectral
    s.nu = s.nv = 8.0
    s.alpha_x = s.alpha_y = 0.4
    s.specular.kind = "CONSTANT"
    s.specular.constant = 0.05
    s.ior_n.kind = "CONSTANT"
    s.ior_n.constant = 1.5
    s.ior_k.kind = "CONSTANT"
    s.ior_k.constant = 0.0
    assert _factor() == {"FINISHED"}
    r = material.spectral.result
    assert r.packs == 1 and r.terms == 4 and r.image is not None and r.plot is not None
    assert np.isfinite([r.de94_mean, r.de94_p95, r.de94_max]).all()
    assert r.de94_mean <= r.de94_p95 <= r.de94_max
    assert r.seconds > 0 and r.nbytes > 0 and len(r.input_hash) == 64


def test_errors_are_measured_against_the_reference(clean_scene):
    """The panel's ΔE94 is the protocol's: recompute it from the 5 nm reference here."""
    material = spectral_material(packs=2)
    assert _factor() == {"FINISHED"}
    model = storage.load_factored(material)
    inputs = sources.material_inputs(material)
    wi, wo = random_direction_pairs()
    from spectral_materials.core.brdf.metrics import delta_e94_stats
    stats = delta_e94_stats(reference_xyz(inputs.brdf(), wi, wo, "D65"),
                            model.xyz(wi, wo, "D65"), "D65")
    assert material.spectral.result.de94_mean == pytest.approx(stats["mean"], rel=1e-5)
    assert material.spectral.result.de94_max == pytest.approx(stats["max"], rel=1e-5)


def test_up_to_date_material_is_skipped_and_changes_refactor(clean_scene):
    material = spectral_material()
    assert _factor() == {"FINISHED"}
    image = material.spectral.result.image.name
    assert _factor() == {"FINISHED"}
    assert material.spectral.result.image.name == image
    analysis = bpy.context.scene.spectral.analysis
    assert "1 material(s) up to date" in analysis and "0 factored" in analysis
    material.spectral.sigma = 0.5
    assert _factor() == {"FINISHED"}
    assert "1 factored" in bpy.context.scene.spectral.analysis


def test_more_packs_lower_the_error(clean_scene):
    material = spectral_material(model="ASHIKHMIN_SHIRLEY", packs=4, theta_cells=12)
    material.spectral.nu = material.spectral.nv = 16.0
    # Packs alone: with the lobe (test_a_glossy_material_keeps_its_lobe) one pack already
    # holds the smooth rest, and more change the mean by less than the noise.
    material.spectral.specular_lobe = "OFF"
    assert _factor() == {"FINISHED"}
    import json
    series = json.loads(material.spectral.result.report_json)["series"]
    means = [row["de94"]["mean"] for row in series]
    assert [row["packs"] for row in series] == [1, 2, 3, 4]
    assert means[-1] < means[0]


def test_target_de94_stops_early(clean_scene):
    material = spectral_material(packs=8)
    material.spectral.use_target = True
    material.spectral.target_de94 = 1.0
    assert _factor() == {"FINISHED"}
    r = material.spectral.result
    assert r.packs < 8 and r.de94_mean <= 1.5


def test_undo_restores_the_previous_state(clean_scene):
    material = spectral_material()
    bpy.ops.ed.undo_push(message="start")  # the first push only starts the undo stack
    bpy.ops.ed.undo_push(message="before factoring")
    before = snapshot(bpy.context.scene)
    # undo=True pushes the operator's undo step as a UI call does (scripts skip it).
    assert bpy.ops.spectral.factor_material("EXEC_DEFAULT", True) == {"FINISHED"}
    assert bpy.data.materials["Paint"].spectral.result.image is not None
    bpy.ops.ed.undo()
    assert snapshot(bpy.context.scene) == before
    assert bpy.data.materials["Paint"].spectral.result.image is None
    del material


@pytest.mark.parametrize("setup, message", [
    (lambda s: setattr(s, "sigma", -0.1), "σ must be in"),
    (lambda s: setattr(s, "sigma", math.nan), r"σ \(sigma\) is nan"),
    (lambda s: (setattr(s, "model", "ASHIKHMIN_SHIRLEY"), setattr(s, "nu", 0.0)),
     "exponent nu must be in"),
    (lambda s: (setattr(s, "model", "ASHIKHMIN_SHIRLEY"), setattr(s, "nv", 1e9)),
     "exponent nv must be in"),
    (lambda s: (setattr(s.diffuse, "kind", "CONSTANT"), setattr(s.diffuse, "constant", 1.5)),
     "outside"),
    (lambda s: (setattr(s.diffuse, "kind", "TEXT"), setattr(s.diffuse, "text", "0.2, abc")),
     "albedo spectrum"),
    (lambda s: (setattr(s.diffuse, "kind", "CSV"), setattr(s.diffuse, "filepath", "/nope.csv")),
     "nope.csv"),
    (lambda s: (setattr(s, "source", "FILE"), setattr(s, "filepath", "/missing/brdf.npz")),
     "does not exist"),
    (lambda s: setattr(s, "theta_cells", 100000), "θ cells must be"),
    (lambda s: setattr(s, "packs", 0), "packs must be"),
])
def test_bad_input_is_refused_and_nothing_changes(clean_scene, setup, message):
    material = spectral_material()
    assert _factor() == {"FINISHED"}           # there is a previous result to keep
    before = snapshot(bpy.context.scene)
    setup(material.spectral)
    after_setup = snapshot(bpy.context.scene)
    with pytest.raises(RuntimeError, match=message):
        _factor()
    assert snapshot(bpy.context.scene) == after_setup
    assert after_setup["images"] == before["images"]


def test_corrupt_data_file_is_refused(clean_scene, tmp_path):
    path = tmp_path / "broken.npz"
    path.write_bytes(b"PK\x03\x04 this is not a real archive")
    material = spectral_material()
    material.spectral.source = "FILE"
    material.spectral.filepath = str(path)
    before = snapshot(bpy.context.scene)
    with pytest.raises(RuntimeError, match="broken.npz"):
        _factor()
    assert snapshot(bpy.context.scene) == before


def test_empty_scene_is_refused(clean_scene):
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    with pytest.raises(RuntimeError, match="nothing to factor"):
        bpy.ops.spectral.factor_scene()


def test_cancel_leaves_the_scene_as_it_was(clean_scene):
    spectral_material()
    before = snapshot(bpy.context.scene)
    plan = scene.plan_scene(bpy.context.scene)
    calls = []

    def stop_after_a_while(fraction, message):
        calls.append(message)
        return len(calls) > 5

    with pytest.raises(Cancelled):
        jobs.run_scene_job(plan, stop_after_a_while)
    assert snapshot(bpy.context.scene) == before


def test_commit_is_all_or_nothing(clean_scene):
    spectral_material("A")
    spectral_material("B", patch="12")
    plan = scene.plan_scene(bpy.context.scene)
    result = jobs.run_scene_job(plan)
    before = snapshot(bpy.context.scene)
    bpy.data.materials.remove(bpy.data.materials["B"])   # vanishes while the job ran
    after_removal = snapshot(bpy.context.scene)
    with pytest.raises(storage.StorageError, match="was removed"):
        jobs.commit_scene_job(bpy.context.scene, result)
    assert snapshot(bpy.context.scene) == after_removal
    assert "B" in before["materials"]


def test_clear_results(clean_scene):
    material = spectral_material()
    assert bpy.ops.spectral.factor_scene() == {"FINISHED"}
    assert bpy.context.scene.spectral.basis_size > 0
    assert bpy.ops.spectral.clear_results(scope="ALL") == {"FINISHED"}
    assert material.spectral.result.image is None
    assert bpy.context.scene.spectral.basis_size == 0
    assert not [i for i in bpy.data.images if i.name.startswith("SM ")]


def test_build_basis_factors_nothing(clean_scene):
    material = spectral_material()
    assert bpy.ops.spectral.build_basis() == {"FINISHED"}
    assert bpy.context.scene.spectral.basis_size >= 1
    assert material.spectral.result.image is None
    assert jobs.load_scene_basis(bpy.context.scene).vectors.shape[0] == 81


def test_factor_a_tabulated_data_file(clean_scene, tmp_path):
    from spectral_materials.core.brdf import models
    from spectral_materials.core.colour import spectra
    from spectral_materials.core.formats.tabulated import tabulate_to_file

    brdf = models.OrenNayar(albedo=spectra.colorchecker_spectrum(12), sigma=0.4)
    path = tabulate_to_file(brdf, tmp_path / "felt.npz", "io_iso", resolution=(12, 24, 12))
    material = spectral_material()
    material.spectral.source = "FILE"
    material.spectral.filepath = str(path)
    assert _factor() == {"FINISHED"}
    r = material.spectral.result
    assert r.packs == 2 and r.de94_mean < 1.0
    digest = r.input_hash
    path.write_bytes(path.read_bytes())          # same contents: still up to date
    assert _factor() == {"FINISHED"} and material.spectral.result.input_hash == digest


def test_a_glossy_material_keeps_its_lobe(clean_scene):
    """Automatic: a glossy model gets the lobe, stored on the material and reloaded
    bit-identical; its measured error is the protocol's, below the packs alone."""
    from spectral_materials.blender.brdf import storage

    material = spectral_material(model="ASHIKHMIN_SHIRLEY", packs=2, theta_cells=12)
    material.spectral.nu, material.spectral.nv = 8.0, 64.0
    assert material.spectral.specular_lobe == "AUTO"
    assert _factor() == {"FINISHED"}
    result = material.spectral.result
    # The lobe carries the anisotropy: the packs take the isotropic layout.
    assert result.lobe == "ashikhmin_shirley" and result.parameterization == "io_iso"
    model = storage.load_factored(material)
    assert model.lobe.nu == pytest.approx(8.0, rel=0.02)
    assert model.lobe.nv == pytest.approx(64.0, rel=0.02)
    with_lobe = result.de94_mean
    reloaded = storage.load_factored(material)
    np.testing.assert_array_equal(reloaded.lobe.spectral, model.lobe.spectral)
    material.spectral.specular_lobe = "OFF"
    assert _factor() == {"FINISHED"}
    assert result.lobe == "" and storage.load_factored(material).lobe is None
    assert result.de94_mean > 2.0 * with_lobe
