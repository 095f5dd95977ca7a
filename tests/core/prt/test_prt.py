"""PRT core: transfer vectors, albedo weights and vertex colours against a Monte Carlo
reference with the same visibility."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import pipeline as colour_pipeline, spectra
from spectral_materials.core.prt import environment, sh, transfer as prt

WL = spectra.WAVELENGTHS_REFERENCE


def test_fibonacci_directions_are_unit_and_balanced():
    d = prt.fibonacci_directions(1000)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.abs(d.mean(axis=0)).max() < 2e-3
    with pytest.raises(ValueError, match="ray count"):
        prt.fibonacci_directions(0)


def test_white_up_is_one_and_colour_matches_a_direct_integral():
    env = environment.sky_environment("D65", WL, sky="overcast", bands=5, window="none")
    up = sh.zonal_to_sh(sh.clamped_cosine_zonal(5), np.array([0.0, 0.0, 1.0]))[None]
    assert prt.vertex_xyz(up, env, np.ones(WL.size))[0, 1] == pytest.approx(1.0)
    # A tilted, half-shadowed vertex: transfer from visibility, then XYZ, against a direct
    # Monte Carlo sum of the band-limited sky over the same visible directions.
    normal = np.array([0.6, 0.0, 0.8])
    directions = prt.fibonacci_directions(20000)
    visible = (directions[:, 1] > 0)[None]                  # a wall blocks y < 0
    transfer = prt.transfer_from_visibility(normal[None], directions, visible,
                                            sh.sh_basis(directions, 5))
    albedo = spectra.colorchecker(13, WL)
    xyz = prt.vertex_xyz(transfer, env, albedo)[0]
    radiance = env.radiance(directions)                     # (R, L)
    cosine = np.clip(directions @ normal, 0, None) * visible[0]
    spectral_irradiance = (cosine[:, None] * radiance).sum(axis=0) * 4 * np.pi / len(directions)
    white = prt.albedo_weights(np.ones(WL.size), WL)
    up_irradiance = (np.clip(directions[:, 2], 0, None)[:, None] * radiance).sum(axis=0) \
        * 4 * np.pi / len(directions)
    reference = spectral_irradiance @ prt.albedo_weights(albedo, WL) / \
        (up_irradiance @ white[:, 1])
    white_xyz = colour_pipeline.white_xyz("D65", WL)
    de = colour_pipeline.delta_e94(reference[None], xyz[None], white_xyz)
    assert de[0] < 0.5


def test_a_complete_spectral_basis_changes_nothing():
    """Ê·R̃ in any orthonormal basis of the whole space equals the per-wavelength sum."""
    basis = np.linalg.qr(np.random.default_rng(1).standard_normal((WL.size, WL.size)))[0]
    full = environment.sky_environment("FL2", WL, sky="clear", sun_direction=(0.2, 0.3, 0.9),
                                       bands=4, window="none")
    reduced = environment.sky_environment("FL2", WL, basis, sky="clear",
                                          sun_direction=(0.2, 0.3, 0.9), bands=4,
                                          window="none")
    transfer = sh.zonal_to_sh(sh.clamped_cosine_zonal(4), np.array([[0.0, 0.6, 0.8]]))
    albedo = spectra.colorchecker(9, WL)
    np.testing.assert_allclose(prt.vertex_xyz(transfer, reduced, albedo),
                               prt.vertex_xyz(transfer, full, albedo), rtol=1e-9)


def test_bad_input():
    env = environment.sky_environment("D65", WL, bands=3, window="none")
    with pytest.raises(ValueError, match="transfer must be"):
        prt.vertex_xyz(np.ones((2, 4)), env, np.ones(WL.size))
    with pytest.raises(ValueError, match="albedo must be"):
        prt.vertex_xyz(np.ones((2, 9)), env, np.ones(5))


def test_albedo_layers_on_the_prt_basis_give_vertex_xyz():
    """The fragment shader's Σ_j Ê_j R̃_j(uv), with R̃ from core.albedo sampled at a texel
    centre and the basis from albedo.prt_basis, equals vertex_xyz of the spectrum — and,
    the light (and the albedos × CMFs) lying in the basis' span, the full 5 nm result."""
    from spectral_materials.core.prt import albedo

    patches = np.stack([spectra.colorchecker(i, WL) for i in (4, 11, 18)])
    basis = albedo.prt_basis(patches, ["FL4"], WL, 10)
    env = environment.sky_environment("FL4", WL, basis, sky="overcast", bands=4, window="none")
    full = environment.sky_environment("FL4", WL, sky="overcast", bands=4, window="none")
    transfer = sh.zonal_to_sh(sh.clamped_cosine_zonal(4), np.array([[0.0, 0.6, 0.8]]))
    layers = albedo.albedo_layers_from_spectra(patches[None], WL, basis)          # 1 × 3
    white = albedo.albedo_layers_from_spectra(np.ones(WL.size), WL, basis).layers[:, 0, 0]
    up = sh.zonal_to_sh(sh.clamped_cosine_zonal(4), np.array([0.0, 0.0, 1.0]))
    white_y = (up @ env.coefficients) @ white[:, 1]
    for i, patch in enumerate(patches):
        r = albedo.sample_layers(layers.layers, np.array([[(i + 0.5) / 3, 0.5]]))[0]
        xyz = (transfer @ env.coefficients) @ r / white_y
        np.testing.assert_allclose(xyz, prt.vertex_xyz(transfer, env, patch), rtol=1e-5)
        np.testing.assert_allclose(xyz, prt.vertex_xyz(transfer, full, patch), rtol=1e-5)


def _euler_xyz(x_deg: float, y_deg: float, z_deg: float) -> np.ndarray:
    """Blender's XYZ Euler rotation matrix (Rz Ry Rx)."""
    x, y, z = np.radians([x_deg, y_deg, z_deg])
    rx = np.array([[1, 0, 0], [0, np.cos(x), -np.sin(x)], [0, np.sin(x), np.cos(x)]])
    ry = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]])
    rz = np.array([[np.cos(z), -np.sin(z), 0], [np.sin(z), np.cos(z), 0], [0, 0, 1]])
    return rz @ ry @ rx


#: Object frames: turns about each axis, a compound turn, and mirrors (det −1).
FRAMES = {
    "x57": _euler_xyz(57, 0, 0), "x143": _euler_xyz(143, 0, 0), "y-110": _euler_xyz(0, -110, 0),
    "z70": _euler_xyz(0, 0, 70), "compound": _euler_xyz(57, -31, 143),
    "mirror x": np.diag([-1.0, 1.0, 1.0]),
    "mirror x, compound": _euler_xyz(57, -31, 143) @ np.diag([-1.0, 1.0, 1.0]),
    "inversion": -np.eye(3),
}


@pytest.mark.parametrize("frame", FRAMES)
def test_turning_the_environment_into_an_object_frame_keeps_the_world_white(frame):
    """The white is the world's (a white Lambertian facing world up): the same number
    however the environment is turned, and a vertex gives the same colour whether its
    transfer and the light are both in the world frame or both in the object's frame —
    for reflections too (a mirrored object's frame)."""
    q = FRAMES[frame]
    env = environment.sky_environment("FL2", WL, sky="clear", sun_direction=(0.3, 0.2, 0.9),
                                      sun_fraction=0.4, bands=5, window="none")
    turned = env.rotated(q.T)                      # the light in the object's frame
    np.testing.assert_allclose(turned.up, q.T @ [0.0, 0.0, 1.0], atol=1e-15)
    assert prt.white_y(turned) == pytest.approx(prt.white_y(env), rel=1e-12)
    normals_object = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -0.8, 0.6],
                               [0.36, 0.48, -0.8]])
    cosine = sh.clamped_cosine_zonal(5)
    in_object = sh.zonal_to_sh(cosine, normals_object)
    in_world = sh.zonal_to_sh(cosine, normals_object @ q.T)          # world normals q n
    albedo = spectra.colorchecker(13, WL)
    expected = prt.vertex_xyz(in_world, env, albedo)
    np.testing.assert_allclose(prt.vertex_xyz(in_object, turned, albedo), expected,
                               rtol=1e-10, atol=1e-12)
    rgb = prt.rgb_albedo(albedo, WL)
    np.testing.assert_allclose(prt.rgb_vertex_xyz(in_object, turned, rgb),
                               prt.rgb_vertex_xyz(in_world, env, rgb), rtol=1e-10, atol=1e-12)
