"""Spectral environments on SH × a spectral basis: known projections, equirectangular maps,
rotation by SH matrices, sky normalisation, and a sun that stays non-negative."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_materials.core.colour import spectra
from spectral_materials.core.prt import environment, sh

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


# ------------------------------------------------------------------ Monte Carlo reference


@pytest.mark.parametrize("sky", ["uniform", "overcast", "clear"])
def test_sky_reference_is_the_light_sky_environment_projects(sky):
    """Same scale factors: the reference's radiance, projected at the quadrature the sky
    was normalised with, gives sky_environment's coefficients; the sun carries
    π·sun_fraction of the horizontal irradiance."""
    sun, fraction = np.array([0.3, 0.2, 0.9]), 0.3
    reference = environment.sky_reference("FL2", WL, sky=sky, sun_direction=sun,
                                          sun_fraction=fraction, quadrature=32)
    projected = environment.sky_environment("FL2", WL, sky=sky, sun_direction=sun,
                                            sun_fraction=0.0, bands=4, window="none",
                                            quadrature=32)
    directions, weights = sh.sphere_quadrature(32)
    sky_only = environment.project_samples(directions, weights,
                                           reference.radiance(directions), WL, bands=4,
                                           window="none")
    # Without the sun the sky carries all of π; with it, (1 − fraction) of π.
    np.testing.assert_allclose(sky_only.coefficients, (1.0 - fraction) * projected.coefficients,
                               rtol=1e-12, atol=1e-14)
    ((direction, irradiance),) = reference.suns
    spd = spectra.illuminant("FL2", WL)
    np.testing.assert_allclose(direction * irradiance[0] / spd[0] * spd.max(),
                               np.pi * fraction * sun / np.linalg.norm(sun) / direction[2],
                               rtol=1e-12)
    assert environment.sky_reference("D65", WL, sky=sky).suns == ()


def test_sky_reference_refuses_what_sky_environment_refuses():
    with pytest.raises(ValueError, match="below the horizon"):
        environment.sky_reference("D65", WL, sun_direction=(0, 0, -1), sun_fraction=0.5)
    with pytest.raises(ValueError, match="needs a sun_direction"):
        environment.sky_reference("D65", WL, sun_fraction=0.5)
    with pytest.raises(ValueError, match="sun fraction"):
        environment.sky_reference("D65", WL, sun_direction=(0, 0, 1), sun_fraction=1.0)
    for bad in ((0, 0, 0), (np.nan, 0, 1), (1, 2)):
        with pytest.raises(ValueError, match="sun_direction must be"):
            environment.sky_environment("D65", WL, sun_direction=bad, sun_fraction=0.2)
    with pytest.raises(ValueError, match="unknown sky"):
        environment.sky_reference("D65", WL, sky="stormy")


@pytest.mark.parametrize("rgb", [False, True])
def test_equirect_reference_returns_the_pixel_containing_the_direction(rgb):
    height, width = 6, 10
    rng = np.random.default_rng(2)
    values = rng.uniform(0.0, 2.0, (height, width, 3 if rgb else WL.size))
    reference = environment.equirect_reference(values, WL, rgb=rgb)
    centres, solid = environment.equirect_directions(height, width)
    from spectral_materials.core.colour.uplift import SmitsUplift

    spectral = SmitsUplift()(values.reshape(-1, 3), WL).reshape(height, width, -1) if rgb \
        else values
    np.testing.assert_allclose(reference.radiance(centres.reshape(-1, 3)),
                               spectral.reshape(-1, WL.size), rtol=1e-12)
    # Directions just inside a pixel's corners stay in it (nearest, no filtering).
    row, column = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    for du, dv in ((0.001, 0.001), (0.999, 0.001), (0.001, 0.999), (0.999, 0.999)):
        u = (column + du) / width
        v = 1.0 - (row + dv) / height                      # row 0 at the top
        azimuth, elevation = (u - 0.5) * 2.0 * np.pi, (v - 0.5) * np.pi
        corner = np.stack([-np.cos(elevation) * np.cos(azimuth),
                           np.cos(elevation) * np.sin(azimuth), np.sin(elevation)], axis=-1)
        np.testing.assert_allclose(reference.radiance(corner.reshape(-1, 3)),
                                   spectral.reshape(-1, WL.size), rtol=1e-12)
    # Nearly straight up (looking along −x, the map's centre column) is row 0.
    np.testing.assert_allclose(reference.radiance(np.array([[-0.01, 0.0, 1.0]]))[0],
                               spectral[0, width // 2], rtol=1e-12)
    # The white's irradiance is exact: it equals summing cos θ over finely split pixels.
    fine = 8
    dirs, fine_solid = environment.equirect_directions(height * fine, width * fine)
    up = np.clip(dirs[..., 2], 0.0, None) * fine_solid
    per_pixel = up.reshape(height, fine, width, fine).sum(axis=(1, 3))
    np.testing.assert_allclose(reference.up_irradiance,
                               np.einsum("hw,hwl->l", per_pixel, spectral), rtol=2e-3)
    assert np.isclose(solid.sum(), 4 * np.pi)


def test_equirect_reference_odd_height_splits_the_horizon_row():
    spd = spectra.illuminant("D65", WL)
    values = np.zeros((3, 4, WL.size))
    values[1] = spd                                    # only the row across the horizon
    reference = environment.equirect_reference(values, WL)
    # ∫ z dω over el ∈ [0, π/6]: π sin²(π/6) = π/4.
    np.testing.assert_allclose(reference.up_irradiance, np.pi / 4 * spd, rtol=1e-12)
    values[2, 3, :2] = np.nan
    with pytest.raises(ValueError, match="2 non-finite"):
        environment.equirect_reference(values, WL)
    with pytest.raises(ValueError, match="map must be"):
        environment.equirect_reference(np.ones((3, 4, 5)), WL)


# ------------------------------------------------------------------------ reading maps


def _top_bright(height=4, width=8, channels=3):
    """An array in the writers' convention (row 0 at the bottom) whose TOP row is bright."""
    values = np.full((height, width, channels), 0.1, dtype=np.float32)
    values[-1] = 5.0
    return values


def test_read_rgb_exr_puts_the_top_row_first_and_lights_from_above(tmp_path):
    pytest.importorskip("OpenEXR")
    from spectral_materials.core.formats.exr import write_exr

    values = _top_bright()
    values[0, 0] = (0.1, 0.2, 0.3)                      # bottom-left: the last row read
    path = write_exr(tmp_path / "sky.exr", {c: values[..., i] for i, c in enumerate("RGB")}
                     | {"A": np.ones(values.shape[:2])})
    read, wavelengths, rgb = environment.read_environment_map(path)
    assert rgb and wavelengths is None and read.shape == (4, 8, 3)
    assert np.all(read[0] == 5.0) and np.allclose(read[-1, 0], (0.1, 0.2, 0.3))
    env = environment.equirect_environment(read, WL, rgb=True, bands=3, window="none")
    up, down = env.radiance(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])).mean(axis=1)
    assert up > 3 * down


def test_read_spectral_exr_puts_the_top_row_first(tmp_path):
    pytest.importorskip("OpenEXR")
    from spectral_materials.core.formats.spectral_exr import write_spectral_exr

    file_wl = np.array([400.0, 500.0, 600.0, 700.0])
    values = _top_bright(channels=file_wl.size)
    path = write_spectral_exr(tmp_path / "sky.exr", file_wl, values, kind="emissive")
    read, wavelengths, rgb = environment.read_environment_map(path)
    assert not rgb and read.shape == (4, 8, 4)
    np.testing.assert_array_equal(wavelengths, file_wl)
    np.testing.assert_array_equal(read, values[::-1])
    reference = environment.equirect_reference(read, file_wl)
    assert reference.radiance(np.array([[0.0, 0.0, 1.0]]))[0, 0] == 5.0


def test_read_environment_map_refusals(tmp_path):
    pytest.importorskip("OpenEXR")
    from spectral_materials.core.formats.exr import write_exr
    from spectral_materials.core.formats.spectral_exr import write_spectral_exr

    for name in ("sky.hdr", "sky.png"):
        (tmp_path / name).write_bytes(b"#?RADIANCE\n")
        with pytest.raises(ValueError, match=r"\.exr.*Blender's image loader"):
            environment.read_environment_map(tmp_path / name)
    with pytest.raises(ValueError, match="no such file"):
        environment.read_environment_map(tmp_path / "missing.exr")
    reflective = write_spectral_exr(tmp_path / "paint.exr", [500.0, 600.0], np.ones((2, 2, 2)))
    with pytest.raises(ValueError, match=r"paint.exr.*reflectances.*S0"):
        environment.read_environment_map(reflective)
    grey = write_exr(tmp_path / "grey.exr", {"Y": np.ones((2, 4))})
    with pytest.raises(ValueError, match=r"grey.exr.*missing R, G, B"):
        environment.read_environment_map(grey)
    nan = np.ones((2, 4))
    nan[0, :3] = np.nan
    broken = write_exr(tmp_path / "nan.exr", {"R": nan, "G": np.ones((2, 4)),
                                              "B": np.ones((2, 4))})
    with pytest.raises(ValueError, match=r"nan.exr: 3 NaN or inf"):
        environment.read_environment_map(broken)
    for kind, path in (("rgb", write_exr(tmp_path / "rgb.exr",
                                         {c: np.ones((8, 16)) for c in "RGB"})),
                       ("spectral", write_spectral_exr(tmp_path / "spec.exr", [500.0, 600.0],
                                                       np.ones((8, 16, 2)), kind="emissive"))):
        raw = path.read_bytes()
        for cut in (0, 3, 40, len(raw) // 2, len(raw) - 1):
            truncated = tmp_path / f"{kind}{cut}.exr"
            truncated.write_bytes(raw[:cut])
            with pytest.raises(ValueError, match=f"{kind}{cut}.exr"):
                environment.read_environment_map(truncated)
