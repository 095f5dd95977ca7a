"""The std140 parameter blocks: offsets by the std140 rules, read from the GLSL struct
(the one spec), and packers that write the same bytes as the hand-concatenated packers
they replaced. Needs bpy (the drawers import it), not a GPU."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from spectral_materials.blender.brdf import gpu_material
from spectral_materials.blender.brdf.gpu_material import (
    DisplaySettings,
    display_matrices,
    std140_mat4,
)
from spectral_materials.blender.btf import drawer as btf_drawer
from spectral_materials.blender.gpu import std140
from spectral_materials.blender.prt import drawer as prt_drawer

pytestmark = [pytest.mark.bpy, pytest.mark.gpu]

RNG = np.random.default_rng(17)

#: std140's classic traps: a float packs into a vec3's tail, vec2 aligns to 8, arrays
#: and matrices align and stride to 16, the block ends on a multiple of 16.
TRAPS = """
struct Traps {
  float a;      /* 0 */
  vec3 b;       /* 16 */
  float c;      /* 28: in b's fourth slot */
  vec2 d;       /* 32 */
  float e[2];   /* 48, stride 16 */
  mat4 f;       /* 80 */
  ivec3 g;      /* 144 */
  mat3 h;       /* 160: three columns of 16 */
  int i;        // 208
};
"""


def test_offsets_follow_the_std140_rules():
    block = std140.parse_struct(TRAPS, "Traps")
    assert [(f.name, f.glsl_type, f.length) for f in block.fields] == [
        ("a", "float", 0), ("b", "vec3", 0), ("c", "float", 0), ("d", "vec2", 0),
        ("e", "float", 2), ("f", "mat4", 0), ("g", "ivec3", 0), ("h", "mat3", 0),
        ("i", "int", 0)]
    assert block.offsets == {"a": 0, "b": 16, "c": 28, "d": 32, "e": 48, "f": 80, "g": 144,
                             "h": 160, "i": 208}
    assert block.size == 224


def test_pack_writes_each_field_at_its_offset_and_refuses_mismatches():
    block = std140.parse_struct(TRAPS, "Traps")
    values = dict(a=1.0, b=(2, 3, 4), c=5.0, d=(6, 7), e=(8, 9), f=np.arange(16.0).reshape(4, 4),
                  g=(10, 11, 12), h=np.arange(9.0).reshape(3, 3), i=13)
    data = block.pack(**values)
    floats, ints = np.frombuffer(data, "<f4"), np.frombuffer(data, "<i4")
    assert floats[[0, 4, 5, 6, 7, 8, 9, 12, 16]].tolist() == [1, 2, 3, 4, 5, 6, 7, 8, 9]
    assert floats[20:36].tolist() == list(range(16))
    assert ints[36:39].tolist() == [10, 11, 12]
    assert floats[[40, 41, 42, 44, 48]].tolist() == [0, 1, 2, 3, 6]
    assert ints[52] == 13
    with pytest.raises(ValueError, match="missing"):
        block.pack(**{k: v for k, v in values.items() if k != "c"})
    with pytest.raises(ValueError, match="not in the block"):
        block.pack(**values, extra=1.0)
    with pytest.raises(ValueError, match="shape"):
        block.pack(**dict(values, b=(1, 2)))


def _display() -> DisplaySettings:
    return DisplaySettings(scene_white=(0.95, 1.0, 1.09), exposure=1.3, tone_white=3.5)


def test_factor_pack_block_bytes_are_unchanged():
    u = SimpleNamespace(axis_lo=RNG.random(4), axis_span=RNG.random(4),
                        axis_flags=(1, 0, 2, 3), axis_cells=(16, 32, 16, 1), edge_rule=True,
                        pack_rows=3, lobe=(8.5, 64.25, 0.0, 0.0))
    display, vp = _display(), RNG.random((4, 4))
    # The packer as it was: its parts concatenated in the declared order.
    adapt, rgb, _ = display_matrices(tuple(display.scene_white))
    parts = [np.asarray(u.axis_lo, np.float32), np.asarray(u.axis_span, np.float32),
             np.asarray(u.axis_flags, np.int32), np.asarray(u.axis_cells, np.int32),
             np.asarray((u.edge_rule, u.pack_rows, 0, 0), np.int32),
             np.asarray((display.exposure, display.tone_white, 64.0, 48.0), np.float32),
             np.asarray((0.1, 0.2, 0.3, 1.0), np.float32),
             np.asarray(u.lobe, np.float32), adapt, rgb, std140_mat4(vp)]
    expected = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    got = gpu_material.params_block(u, display, (0.1, 0.2, 0.3, 1.0), vp, (64.0, 48.0))
    assert got == expected and len(got) == gpu_material.PARAMS_BYTES == 320


def test_prt_block_bytes_are_unchanged():
    display, vp = _display(), RNG.random((4, 4))
    adapt, to_rgb, to_xyz = display_matrices(tuple(display.scene_white))
    parts = [std140_mat4(vp), adapt, to_rgb, to_xyz,
             np.asarray((display.exposure, display.tone_white, 0.0, 0.0), np.float32),
             np.asarray((4096, 640, 480, 0), np.int32)]
    expected = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    got = prt_drawer.params_block(vp, display, 4096, (640, 480))
    assert got == expected and len(got) == prt_drawer.PARAMS_BYTES == 288


def test_btf_block_bytes_are_unchanged():
    display, vp = _display(), RNG.random((4, 4))
    material = SimpleNamespace(
        uv_scale=(2.0, 3.0), grid=9,
        layout=SimpleNamespace(width=64, height=32, tiles_per_layer=6, columns=3),
        drawable=SimpleNamespace(albedo_records=2, records_per_view=5))
    adapt, to_rgb, _ = display_matrices(tuple(display.scene_white))
    parts = [std140_mat4(vp), adapt, to_rgb,
             np.asarray((display.exposure, display.tone_white, 0.0, 0.0), np.float32),
             np.asarray((0.0, 0.0, 1.0, 0.0), np.float32),
             np.asarray((2.0, 3.0, 0.0, 0.0), np.float32),
             np.asarray((64, 32, 6, 3), np.int32), np.asarray((2, 5, 9, 0), np.int32)]
    expected = b"".join(np.ascontiguousarray(p).tobytes() for p in parts)
    got = btf_drawer.BTFMaterial.params_block(material, display, (0.0, 0.0, 1.0, 0.0), vp)
    assert got == expected and len(got) == btf_drawer.PARAMS_BYTES == 272
