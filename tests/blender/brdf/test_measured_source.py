"""A material whose source is a measured file (MERL .binary) factors through the operator."""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.bpy

from spectral_materials.blender.brdf import gpu_material, sources, storage
from spectral_materials.core.brdf import shading
from spectral_materials.core.formats import merl


def _sun():
    return shading.protocol_sun(30.0, "D65")


def _lambert_rgb(wi, wo):
    return np.broadcast_to(np.array([0.6, 0.3, 0.1]) / np.pi, (len(wi), 3))


def test_merl_file_material_factors(clean_scene, tmp_path):
    path = merl.write_merl(tmp_path / "red.binary", merl.merl_table_from_brdf(_lambert_rgb),
                           allow_invalid=True)
    material = bpy.data.materials.new("Measured")
    material.spectral.enabled = True
    material.spectral.source = "FILE"
    material.spectral.filepath = str(path)
    material.spectral.theta_cells = 8
    material.spectral.packs = 1
    cube = bpy.data.objects["Cube"]
    cube.data.materials.clear()
    cube.data.materials.append(material)
    bpy.context.view_layer.objects.active = cube
    assert bpy.ops.spectral.factor_material() == {"FINISHED"}
    result = material.spectral.result
    assert result.packs == 1 and result.image is not None
    assert result.de94_mean < 1.0         # a Lambertian table factors almost exactly
    # Automatic draws a MERL file in its cells, as its readers look it up; the stored
    # model keeps them, the viewport's shader variant draws them, and the setting is part
    # of the inputs: "Smooth" makes the stored factors stale.
    stored = storage.load_factored(material)
    assert stored.cells == merl.MERL_SHAPE
    assert gpu_material.GPUMaterial(stored).key([_sun()]).cells == merl.MERL_SHAPE
    before = sources.input_hash(sources.material_inputs(material), stored.basis)
    material.spectral.measured_cells = "SMOOTH"
    after = sources.input_hash(sources.material_inputs(material), stored.basis)
    assert after != before
    assert bpy.ops.spectral.factor_material() == {"FINISHED"}
    assert storage.load_factored(material).cells is None


def test_unknown_file_type_is_a_clear_error(clean_scene, tmp_path):
    path = tmp_path / "brdf.xyz"
    path.write_bytes(b"not a brdf")
    material = bpy.data.materials.new("Odd")
    material.spectral.enabled = True
    material.spectral.source = "FILE"
    material.spectral.filepath = str(path)
    cube = bpy.data.objects["Cube"]
    cube.data.materials.clear()
    cube.data.materials.append(material)
    bpy.context.view_layer.objects.active = cube
    with pytest.raises(RuntimeError, match="unknown BRDF file type"):
        bpy.ops.spectral.factor_material()
    assert material.spectral.result.image is None
