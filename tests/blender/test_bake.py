"""PRT transfer bake on the bpy module: known transfer for an unoccluded sphere, self-
shadowing in a concave mesh, storage with staleness, cancellation, bad input."""

from __future__ import annotations

import numpy as np
import pytest

bpy = pytest.importorskip("bpy")

from spectral_materials.blender import bake  # noqa: E402
from spectral_materials.core.errors import Cancelled  # noqa: E402


def _linear_basis(directions):
    """1, x, y, z: enough to check the projection (the SH module supplies real bases)."""
    return np.concatenate([np.ones((len(directions), 1)), directions], axis=1)


def test_convex_sphere_sees_the_whole_hemisphere(clean_scene):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
    sphere = bpy.context.active_object
    result = bake.bake_transfer(sphere, _linear_basis, rays=512)
    mesh = sphere.data
    normals = np.empty(len(mesh.vertices) * 3)
    mesh.vertex_normals.foreach_get("vector", normals)
    normals = normals.reshape(-1, 3)
    # Unoccluded: ∫ max(n·ω, 0) dω = π, ∫ max(n·ω, 0) ω dω = (2π/3) n.
    np.testing.assert_allclose(result.coefficients[:, 0], np.pi, rtol=0.02)
    np.testing.assert_allclose(result.coefficients[:, 1:], 2 * np.pi / 3 * normals, atol=0.05)
    assert result.rays_per_second > 0 and result.rays_cast > 0


def test_concave_mesh_is_self_shadowed(clean_scene):
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
    sphere = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.flip_normals()            # the inside of a sphere: every ray is blocked
    bpy.ops.object.mode_set(mode="OBJECT")
    result = bake.bake_transfer(sphere, _linear_basis, rays=128)
    assert np.abs(result.coefficients).max() < 0.05


def test_store_load_and_staleness(clean_scene):
    cube = bpy.data.objects["Cube"]
    result = bake.bake_transfer(cube, _linear_basis, rays=64)
    bake.store_transfer(cube.data, result)
    np.testing.assert_array_equal(bake.load_transfer(cube.data), result.coefficients)
    cube.data.vertices[0].co.x += 0.5
    assert bake.load_transfer(cube.data) is None           # the geometry changed
    bake.clear_transfer(cube.data)
    assert not any(a.name.startswith(bake.ATTRIBUTE_PREFIX) for a in cube.data.attributes)


def test_cancel_stores_nothing(clean_scene):
    cube = bpy.data.objects["Cube"]
    with pytest.raises(Cancelled):
        bake.bake_transfer(cube, _linear_basis, rays=64, callback=lambda f, m: True)
    assert bake.load_transfer(cube.data) is None


def test_bad_input(clean_scene):
    with pytest.raises(ValueError, match="is not one"):
        bake.bake_transfer(bpy.data.objects["Camera"], _linear_basis)
    mesh = bpy.data.meshes.new("Empty")
    empty = bpy.data.objects.new("Empty", mesh)
    clean_scene.collection.objects.link(empty)
    with pytest.raises(ValueError, match="no faces"):
        bake.bake_transfer(empty, _linear_basis)
    with pytest.raises(ValueError, match="ray count"):
        bake.bake_transfer(bpy.data.objects["Cube"], _linear_basis, rays=0)


def test_unoccluded_transfer_is_the_clamped_cosine_about_the_normal(clean_scene):
    """With the real SH basis: a convex object's transfer is max(n·ω, 0) projected,
    whose coefficients are known in closed form (core.sh.clamped_cosine_zonal)."""
    from spectral_materials.core import sh

    bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
    sphere = bpy.context.active_object
    result = bake.bake_transfer(sphere, lambda d: sh.sh_basis(d, 3), rays=4096)
    normals = np.empty(len(sphere.data.vertices) * 3)
    sphere.data.vertex_normals.foreach_get("vector", normals)
    expected = sh.zonal_to_sh(sh.clamped_cosine_zonal(3), normals.reshape(-1, 3))
    np.testing.assert_allclose(result.coefficients, expected, atol=0.01)
