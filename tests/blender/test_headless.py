"""scripts/factor_scene.py with the bpy module: progress, JSON report, exit codes."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import bpy
import pytest
from blender_helpers import spectral_material

from spectral_materials import blender as addon
from spectral_materials.blender.lights import plots

pytestmark = pytest.mark.bpy

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "factor_scene.py"


def _run(*args, timeout=300):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True,
                          text=True, timeout=timeout)


@pytest.fixture
def saved_scene(clean_scene, tmp_path):
    spectral_material("Paint", patch="12")
    spectral_material("Felt", patch="13")
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def test_factor_scene_script_writes_report_and_file(saved_scene, tmp_path):
    report, output = tmp_path / "report.json", tmp_path / "factored.blend"
    run = _run(saved_scene, "--report", report, "--output", output)
    assert run.returncode == 0, run.stderr
    assert "100.0%" in run.stderr                      # the progress bar (not a tty here)
    data = json.loads(report.read_text())
    assert sorted(data["factored"]) == ["Felt", "Paint"]
    assert data["basis"]["met"] and data["basis"]["size"] >= 1
    bpy.ops.wm.open_mainfile(filepath=str(output))
    # Oren–Nayar beside its own lobe family: the rest is one exact pack, where the fit
    # stops (2 were asked for).
    assert bpy.data.materials["Paint"].spectral.result.packs == 1
    assert bpy.data.materials["Paint"].spectral.result.lobe == "oren_nayar"
    # Run again on the factored file: everything is up to date.
    run = _run(output, "--report", report)
    assert run.returncode == 0, run.stderr
    assert json.loads(report.read_text())["up_to_date"] == ["Felt", "Paint"]


def test_factor_scene_script_fails_clearly(saved_scene, tmp_path):
    run = _run(tmp_path / "missing.blend")
    assert run.returncode == 1 and "does not exist" in run.stderr
    run = _run(saved_scene, "--materials", "Nope")
    assert run.returncode == 1 and "no material named Nope" in run.stderr
    run = _run(saved_scene, "--tolerance", "-1")
    assert run.returncode == 1 and "basis tolerance must be" in run.stderr
    run = _run(saved_scene, "--bogus")
    assert run.returncode == 2


def test_every_property_has_a_tooltip():
    groups = [cls for package in addon.PACKAGES for cls in package.CLASSES
              if issubclass(cls, bpy.types.PropertyGroup) and cls.__name__ != "SPECTRAL_PG_job"]
    missing = [f"{cls.__name__}.{prop.identifier}" for cls in groups
               for prop in cls.bl_rna.properties
               if prop.identifier not in {"rna_type", "name", "plot_key"}
               and not prop.description]
    assert not missing, missing


def test_operators_have_descriptions():
    operators = [cls for package in addon.PACKAGES for cls in package.CLASSES
                 if issubclass(cls, bpy.types.Operator)]
    assert len(operators) == 11
    for cls in operators:
        assert cls.__doc__ and cls.bl_idname.startswith("spectral.")


def test_light_spd_plot(clean_scene):
    light = bpy.data.lights["Light"]
    light.spectral.kind = "BLACKBODY"
    light.spectral.temperature = 3000.0
    plots.refresh_light_plot(light)
    image = light.spectral.plot
    assert image is not None and tuple(image.size) == (320, 120)
    light.spectral.temperature = 9000.0
    plots.refresh_light_plot(light)
    assert [i.name for i in bpy.data.images if i.name.startswith(plots.SPD_PREFIX)] == \
        [light.spectral.plot.name]


def test_light_spd_errors_name_the_light(clean_scene):
    from spectral_materials.blender.brdf import sources

    light = bpy.data.lights["Light"]
    light.spectral.kind = "TEXT"
    light.spectral.text = "400:1, 500:-2"
    with pytest.raises(sources.SourceError, match="Light 'Light'"):
        sources.light_spd(light)
    light.spectral.kind = "BLACKBODY"
    light.spectral.temperature = float("nan")
    with pytest.raises(sources.SourceError, match="temperature"):
        sources.light_spd(light)


def test_panel_staleness_check(clean_scene):
    from spectral_materials.blender.brdf import panels

    material = spectral_material()
    assert bpy.ops.spectral.factor_material() == {"FINISHED"}
    assert panels._stale(bpy.context, material) == ""
    # The result says which lobe family Automatic kept (Oren–Nayar's term for this one).
    assert panels.lobe_label(material.spectral.result.lobe) == "Oren–Nayar"
    assert panels.lobe_label("") == "None"
    material.spectral.sigma = 0.6
    assert "Out of date" in panels._stale(bpy.context, material)
    material.spectral.sigma = -1.0
    assert "σ must be in" in panels._stale(bpy.context, material)
