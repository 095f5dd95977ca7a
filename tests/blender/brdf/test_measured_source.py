"""A material whose source is a measured file (MERL .binary) factors through the operator."""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

pytestmark = pytest.mark.bpy

from spectral_materials.core.formats import merl


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
