"""Spectral environments on SH × a spectral basis: known projections, equirectangular maps,
rotation by SH matrices, sky normalisation, and a sun that stays non-negative."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core import environment, sh, spectra

WL = spectra.WAVELENGTHS_REFERENCE


def _orthonormal_basis(m=6, seed=3):
    return np.linalg.qr(np.random.default_rng(seed).standard_normal((WL.size, m)))[0]


def test_uniform_light_has_only_the_constant_band():
    spd = np.linspace(0.5, 1.5, WL.size)
    env = environment.equirect_environment(np.broadcast_to(spd, (32, 64, WL.size)).copy(), WL,
                                           window="none")
    # ∫ Y00 dω = 4π / (2√π) = 2√π.
    # Exact pixel areas make the constant band exact; the others carry the midpoint
    # rule's O(1/H²) error per pixel row.
    np.testing.assert_allclose(env.coefficients[0], 2.0 * np.sqrt(np.pi) * spd, rtol=1e-12)
    assert np.abs(env.coefficients[1:]).max() < 2e-3 * np.abs(env.coefficients[0]).max()
    np.testing.assert_allclose(env.radiance(np.array([[0.3, -0.2, 0.9]]))[0], spd, rtol=5e-3)


def test_spectral_basis_coefficients_are_the_projection():
    basis = _orthonormal_basis()
    spd = spectra.illuminant("FL2", WL)
    env = environment.equirect_environment(np.broadcast_to(spd, (16, 32, WL.size)).copy(), WL,
                                           basis, window="none")
    np.testing.assert_allclose(env.coefficients[0], 2.0 * np.sqrt(np.pi) * (spd @ basis),
                               rtol=1e-10, atol=1e-12)


def test_equirect_mapping_follows_blender():
    dirs, solid = environment.equirect_directions(4, 8)
    assert np.isclose(solid.sum(), 4.0 * np.pi)
    assert dirs[0, 0, 2] > 0.9 and dirs[-1, 0, 2] < -0.9                 # row 0 is the top
    # The map's centre column (u = 1/2) looks along −x (Blender's world mapping).
    centre = environment.equirect_directions(1, 2)[0][0]
    assert np.allclose(centre.mean(axis=0), [0.0, 0.0, 0.0], atol=1e-12)
    u = (np.arctan2(dirs[..., 1], -dirs[..., 0]) / (2 * np.pi) + 0.5)
    np.testing.assert_allclose(u[0], (np.arange(8) + 0.5) / 8)


def test_rgb_map_uplift_of_white_is_flat():
    env = environment.equirect_environment(np.ones((16, 32, 3)), WL, rgb=True, window="none")
    constant = env.coefficients[0] / (2.0 * np.sqrt(np.pi))
    assert np.ptp(constant) < 0.05 * constant.mean()


def test_rotation_by_sh_matrices_matches_reprojecting_a_rotated_map():
    rng = np.random.default_rng(0)
    a = rng.standard_normal((3, 3))
    q, _ = np.linalg.qr(a)
    rotation = q * np.sign(np.linalg.det(q))
    axis = np.array([0.3, 0.5, 0.8])
    directions, weights = sh.sphere_quadrature(48)
    # A band-limited light (degree 2), so that the quadrature is exact for both.
    light = 1.0 + (directions @ (axis / np.linalg.norm(axis))) ** 2
    env = environment.project_samples(directions, weights, light[:, None] * np.ones(WL.size),
                                      WL, bands=5, window="none")
    turned_axis = rotation @ axis
    turned = 1.0 + (directions @ (turned_axis / np.linalg.norm(turned_axis))) ** 2
    expected = environment.project_samples(directions, weights,
                                           turned[:, None] * np.ones(WL.size), WL, bands=5,
                                           window="none")
    np.testing.assert_allclose(env.rotated(rotation).coefficients, expected.coefficients,
                               atol=1e-10)


@pytest.mark.parametrize("sky", ["uniform", "overcast", "clear"])
def test_sky_is_normalised_to_horizontal_irradiance_pi(sky):
    env = environment.sky_environment("D65", WL, sky=sky, sun_direction=(0.3, 0.2, 0.9),
                                      window="none")
    # Irradiance on an upward normal = Σ_l √(4π/(2l+1)) z_l c_l0 (Funk–Hecke), per λ.
    irradiance = sh.convolve_zonal(env.coefficients.T, sh.clamped_cosine_zonal(env.bands))
    up = irradiance @ sh.sh_basis(np.array([0.0, 0.0, 1.0]), env.bands)
    spd = spectra.illuminant("D65", WL)
    np.testing.assert_allclose(up, np.pi * spd / spd.max(), rtol=0.03)


def test_overcast_is_three_times_brighter_at_the_zenith_than_the_horizon_like_cie():
    values = environment.cie_sky_luminance(np.array([[0, 0, 1.0], [1, 0, 1e-3], [0, 0, -1.0]]),
                                           "overcast")
    assert values[0] == pytest.approx(1.0)
    assert 0.2 < values[1] < 0.5 and values[2] == 0.0


def test_sun_rings_negative_without_a_window_and_not_with_cesaro():
    sun = np.array([0.0, 0.6, 0.8])
    check = sh.sphere_quadrature(64)[0]
    raw = environment.sky_environment("D65", WL, sky="uniform", sun_direction=sun,
                                      sun_fraction=0.8, bands=8, window="none")
    windowed = environment.sky_environment("D65", WL, sky="uniform", sun_direction=sun,
                                           sun_fraction=0.8, bands=8, window="cesaro")
    assert raw.radiance(check).min() < 0.0
    assert windowed.radiance(check).min() >= -1e-9


def test_bad_input():
    with pytest.raises(ValueError, match="non-finite"):
        environment.equirect_environment(np.full((4, 8, 3), np.nan), WL, rgb=True)
    with pytest.raises(ValueError, match="map must be"):
        environment.equirect_environment(np.ones((4, 8, 5)), WL)
    with pytest.raises(ValueError, match="unknown sky"):
        environment.sky_environment("D65", WL, sky="stormy")
    with pytest.raises(ValueError, match="below the horizon"):
        environment.sky_environment("D65", WL, sun_direction=(0, 0, -1), sun_fraction=0.5)
    with pytest.raises(ValueError, match="non-negative"):
        d, w = sh.sphere_quadrature(4)
        environment.project_samples(d, w, -np.ones((len(d), WL.size)), WL)
