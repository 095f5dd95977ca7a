"""Tests of spectral_materials.core.brdf.metrics (the measurement protocol in code)."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from spectral_materials.core.brdf.metrics import (
    RANDOM_PAIRS,
    RANDOM_PAIRS_SEED,
    SPHERE_INCIDENCES_DEG,
    SPHERE_SIZE,
    cosine_weighted_luminance_rms,
    delta_e94_image,
    delta_e94_stats,
    random_direction_pairs,
    reference_xyz,
    sphere_directions,
)
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

WL = spectra.WAVELENGTHS_REFERENCE
Y_HAT = np.array([0.0, 1.0, 0.0])


def lambertian(albedo=1.0):
    """A Lambertian BRDF f = albedo(λ)/π, as the protocol's callable ``f(wi, wo, wl)``."""

    def brdf(wi, wo, wavelengths):
        a = spectra.spectrum_values(albedo, wavelengths)
        return np.broadcast_to(a / np.pi, (len(wi), len(wavelengths)))

    return brdf


def protocol_sphere(incidence_deg: float, size: int):
    """The sphere protocol written out pixel by pixel (independent of the module's algebra).

    Returns (wi, wo, lit, inside) as (size, size, 3) / (size, size) arrays.
    """
    alpha = np.radians(incidence_deg)
    light = np.array([np.sin(alpha), 0.0, np.cos(alpha)])
    view = np.array([0.0, 0.0, 1.0])
    wi = np.full((size, size, 3), np.nan)
    wo = np.full((size, size, 3), np.nan)
    inside = np.zeros((size, size), bool)
    for row in range(size):
        for col in range(size):
            # Pixel centres; row 0 is the top of the image (+y).
            x = -1.0 + (col + 0.5) * 2.0 / size
            y = 1.0 - (row + 0.5) * 2.0 / size
            if x * x + y * y >= 1.0:
                continue
            inside[row, col] = True
            n = np.array([x, y, np.sqrt(1.0 - x * x - y * y)])
            t = np.cross(Y_HAT, n)
            t = t / np.linalg.norm(t) if np.linalg.norm(t) > 1e-12 else np.array([1.0, 0, 0])
            b = np.cross(n, t)  # local y = z × x
            frame = np.stack([t, b, n])
            wi[row, col] = frame @ light
            wo[row, col] = frame @ view
    lit = inside & (wi[..., 2] > 0) & (wo[..., 2] > 0)
    return wi, wo, lit, inside


# Module-level (pytest 9 deprecates class-scoped fixtures defined as instance methods).
@pytest.fixture(scope="module")
def pairs():
    return random_direction_pairs()


class TestRandomDirectionPairs:
    """:func:`random_direction_pairs`: uniform in solid angle on the upper hemisphere."""

    def test_defaults(self, pairs):
        wi, wo = pairs
        assert RANDOM_PAIRS == 20_000
        assert wi.shape == wo.shape == (RANDOM_PAIRS, 3)
        np.testing.assert_array_equal(wi, random_direction_pairs(RANDOM_PAIRS,
                                                                 RANDOM_PAIRS_SEED)[0])

    def test_unit_upper(self, pairs):
        for d in pairs:
            np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
            assert np.all(d[:, 2] > 0)

    def test_reproducible(self):
        a = random_direction_pairs(100, seed=5)
        b = random_direction_pairs(100, seed=5)
        c = random_direction_pairs(100, seed=6)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
        assert not np.allclose(a[0], c[0])
        # wi and wo are different draws.
        assert not np.allclose(a[0], a[1])

    def test_uniform_solid_angle(self, pairs):
        # Uniform in solid angle ⇔ cos θ uniform on [0, 1], φ uniform: E[z] = 1/2,
        # E[z²] = 1/3, E[x] = E[y] = 0; σ of each mean over 20 000 draws is ≤ 0.003.
        for d in pairs:
            assert d[:, 2].mean() == pytest.approx(0.5, abs=0.01)
            assert (d[:, 2] ** 2).mean() == pytest.approx(1 / 3, abs=0.01)
            np.testing.assert_allclose(d[:, :2].mean(axis=0), 0.0, atol=0.015)
            counts, _ = np.histogram(d[:, 2], bins=10, range=(0.0, 1.0))
            # 2000 expected per bin, σ ≈ 42.
            assert np.all(np.abs(counts - 2000) < 250)

    def test_empty(self):
        wi, wo = random_direction_pairs(0)
        assert wi.shape == wo.shape == (0, 3)


class TestSphereDirections:
    """:func:`sphere_directions`: the sphere protocol's per-pixel local directions."""

    def test_defaults(self):
        assert SPHERE_SIZE == 256
        assert SPHERE_INCIDENCES_DEG == (0.0, 30.0, 60.0, 80.0)
        view = sphere_directions(0.0)
        assert view.size == 256
        assert view.mask.shape == (256, 256)
        assert view.wi.shape == view.wo.shape == (int(view.mask.sum()), 3)

    @pytest.mark.parametrize("incidence", [0.0, 30.0, 60.0, 80.0])
    def test_against_protocol(self, incidence):
        size = 33
        view = sphere_directions(incidence, size)
        wi, wo, lit, _ = protocol_sphere(incidence, size)
        np.testing.assert_array_equal(view.mask, lit)
        # The module's rows are the lit pixels in row-major order.
        np.testing.assert_allclose(view.wi, wi[lit], atol=1e-12)
        np.testing.assert_allclose(view.wo, wo[lit], atol=1e-12)

    @pytest.mark.parametrize("incidence", SPHERE_INCIDENCES_DEG)
    def test_unit_vectors(self, incidence):
        view = sphere_directions(incidence)
        for d in (view.wi, view.wo):
            assert np.isfinite(d).all()
            np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
            assert np.all(d[:, 2] > 0)

    def test_centre_pixel(self):
        # Odd size: the centre pixel's normal is exactly (0, 0, 1).
        size = 257
        c = size // 2
        for incidence in (0.0, 30.0, 60.0, 80.0):
            view = sphere_directions(incidence, size)
            index = np.flatnonzero(view.mask.ravel() == 1).tolist().index(c * size + c)
            a = np.radians(incidence)
            np.testing.assert_allclose(view.wo[index], [0.0, 0.0, 1.0], atol=1e-15)
            np.testing.assert_allclose(view.wi[index], [np.sin(a), 0.0, np.cos(a)], atol=1e-15)
        # 256 × 256: the four pixels around the centre are within a pixel of the normal.
        view = sphere_directions(0.0)
        rows, cols = np.nonzero(view.mask)
        near = (np.abs(rows - 127.5) < 1) & (np.abs(cols - 127.5) < 1)
        assert near.sum() == 4
        np.testing.assert_allclose(view.wi[near], [[0.0, 0.0, 1.0]] * 4, atol=1e-2)
        np.testing.assert_allclose(view.wi[near], view.wo[near], atol=1e-15)
        view = sphere_directions(30.0)
        rows, cols = np.nonzero(view.mask)
        near = (np.abs(rows - 127.5) < 1) & (np.abs(cols - 127.5) < 1)
        assert near.sum() == 4
        np.testing.assert_allclose(view.wi[near][:, 2], np.cos(np.radians(30.0)), atol=1e-2)

    @pytest.mark.parametrize("incidence", [0.0, 30.0, 60.0])
    def test_vertical_midline(self, incidence):
        # On x = 0: n = (0, y, z), t = normalize(ŷ × n) = (1, 0, 0), b = n × t = (0, z, −y):
        # wi = (sin α, −y cos α, z cos α), wo = (0, −y, z).
        size = 255
        view = sphere_directions(incidence, size)
        rows, cols = np.nonzero(view.mask)
        mid = cols == size // 2
        assert mid.sum() == size  # the whole column is on the sphere and lit
        y = 1.0 - (rows[mid] + 0.5) * 2.0 / size
        z = np.sqrt(1.0 - y * y)
        a = np.radians(incidence)
        expected_wi = np.stack([np.full_like(y, np.sin(a)), -y * np.cos(a), z * np.cos(a)], -1)
        np.testing.assert_allclose(view.wi[mid], expected_wi, atol=1e-12)
        np.testing.assert_allclose(view.wo[mid], np.stack([0 * y, -y, z], -1), atol=1e-12)

    def test_tangent_is_longitude(self):
        # wo = (t·v, b·v, n·v) with v = ẑ; t ⟂ ŷ ⇒ the tangent's world y is 0, so
        # t = (n_z, 0, −n_x)/|…| and wo_x = −n_x / √(n_x² + n_z²).
        size = 64
        view = sphere_directions(0.0, size)
        rows, cols = np.nonzero(view.mask)
        x = -1.0 + (cols + 0.5) * 2.0 / size
        y = 1.0 - (rows + 0.5) * 2.0 / size
        z = np.sqrt(1.0 - x * x - y * y)
        np.testing.assert_allclose(view.wo[:, 0], -x / np.hypot(x, z), atol=1e-12)
        np.testing.assert_allclose(view.wo[:, 2], z, atol=1e-12)

    @pytest.mark.parametrize("size", [1, 2, 3, 5])
    def test_small_sizes_near_poles(self, size):
        # The poles (n = ±ŷ) lie on the silhouette, never at a pixel centre inside the disc;
        # the pixels nearest to them (top/bottom of the middle column) stay finite.
        for incidence in SPHERE_INCIDENCES_DEG:
            view = sphere_directions(incidence, size)
            assert view.mask.shape == (size, size)
            assert np.isfinite(view.wi).all() and np.isfinite(view.wo).all()
            if view.wi.size:
                np.testing.assert_allclose(np.linalg.norm(view.wi, axis=1), 1.0, atol=1e-12)
            wi, wo, lit, _ = protocol_sphere(incidence, size)
            np.testing.assert_array_equal(view.mask, lit)
            np.testing.assert_allclose(view.wi, wi[lit], atol=1e-12)
        assert sphere_directions(0.0, 1).mask.tolist() == [[True]]

    def test_lit_mask_at_80(self):
        size = 128
        view = sphere_directions(80.0, size)
        _, _, _, inside = protocol_sphere(0.0, size)
        assert not np.any(view.mask & ~inside)
        # Every inside pixel left out has cos θi = n·l ≤ 0, every kept one > 0.
        rows, cols = np.nonzero(inside)
        x = -1.0 + (cols + 0.5) * 2.0 / size
        y = 1.0 - (rows + 0.5) * 2.0 / size
        z = np.sqrt(1.0 - x * x - y * y)
        a = np.radians(80.0)
        cos_i = x * np.sin(a) + z * np.cos(a)
        kept = view.mask[rows, cols]
        assert np.all(cos_i[kept] > 0) and np.all(cos_i[~kept] <= 0)
        assert (~kept).sum() > 0.3 * kept.size
        np.testing.assert_allclose(view.wi[:, 2], cos_i[kept], atol=1e-12)
        # Lit area: half disc + half an ellipse of semi-axis cos α → (1 + cos α)/2 of the disc.
        full = sphere_directions(0.0, size).mask
        assert full.sum() == inside.sum()
        assert view.mask.sum() / full.sum() == pytest.approx((1 + np.cos(a)) / 2, abs=0.01)

    @pytest.mark.parametrize("size", [0, -1, 8193])
    def test_invalid_size(self, size):
        with pytest.raises(ValueError, match="size"):
            sphere_directions(0.0, size)


class TestReferenceXyz:
    """:func:`reference_xyz`: 5 nm sum of f·cosθi·E·cmf, protocol-normalised."""

    @pytest.mark.parametrize("name", ["D65", "A", "FL2", "FL11"])
    def test_white_lambertian_normal_incidence(self, name):
        wi = np.array([[0.0, 0.0, 1.0]] * 3)
        wo = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -0.6, 0.8]])
        xyz = reference_xyz(lambertian(), wi, wo, name)
        assert xyz.shape == (3, 3)
        np.testing.assert_allclose(xyz[:, 1], 1.0, atol=1e-12)
        np.testing.assert_allclose(xyz, np.tile(colour_pipeline.white_xyz(name, WL), (3, 1)),
                                   rtol=1e-12)

    def test_default_illuminant_is_d65(self):
        wi = wo = np.array([[0.0, 0.0, 1.0]])
        np.testing.assert_allclose(reference_xyz(lambertian(), wi, wo)[0],
                                   colour_pipeline.white_xyz("D65", WL), rtol=1e-12)

    def test_cosine_and_horizon(self):
        theta = np.radians([0.0, 60.0, 90.0, 120.0])
        wi = np.stack([np.sin(theta), 0 * theta, np.cos(theta)], -1)
        wo = np.tile([0.0, 0.0, 1.0], (4, 1))
        y = reference_xyz(lambertian(), wi, wo)[:, 1]
        np.testing.assert_allclose(y, [1.0, 0.5, 0.0, 0.0], atol=1e-12)

    def test_against_colour_integration(self):
        # A ColorChecker patch as a Lambertian: XYZ·100 = colour's integration method.
        sd = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]["moderate red"]
        patch = (WL, spectra.colorchecker(9))
        wi = wo = np.array([[0.0, 0.0, 1.0]])
        shape = colour.SpectralShape(380, 780, 5)
        for name in ("D65", "A", "FL2"):
            expected = colour.sd_to_XYZ(
                sd, colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape),
                colour.SDS_ILLUMINANTS[name].copy().align(shape), method="Integration",
                shape=shape)
            np.testing.assert_allclose(reference_xyz(lambertian(patch), wi, wo, name)[0] * 100,
                                       expected, rtol=1e-6)

    def test_chunking(self):
        wi, wo = random_direction_pairs(50, seed=3)

        def brdf(wi, wo, wavelengths):
            # Depends on both directions and on λ.
            return (1.0 + wi[:, :1] * wo[:, 1:2]) * (wavelengths / 780.0)[None, :]

        whole = reference_xyz(brdf, wi, wo, "FL11")
        np.testing.assert_allclose(reference_xyz(brdf, wi, wo, "FL11", chunk=7), whole,
                                   rtol=1e-14)
        np.testing.assert_allclose(reference_xyz(brdf, wi, wo, "FL11", chunk=1), whole,
                                   rtol=1e-14)

    def test_spd_array(self):
        wi = wo = np.array([[0.0, 0.0, 1.0]])
        spd = spectra.illuminant("A", WL) * 3.0
        np.testing.assert_allclose(reference_xyz(lambertian(), wi, wo, spd),
                                   reference_xyz(lambertian(), wi, wo, "A"), rtol=1e-12)


class TestDeltaE94Stats:
    """:func:`delta_e94_stats` and :func:`delta_e94_image`."""

    def test_identical(self):
        xyz = np.random.default_rng(0).uniform(0.01, 1.0, (100, 3))
        stats = delta_e94_stats(xyz, xyz)
        assert set(stats) == {"mean", "p95", "max", "count"}
        assert stats["mean"] == stats["p95"] == stats["max"] == 0.0
        assert stats["count"] == 100
        assert isinstance(stats["mean"], float) and isinstance(stats["count"], int)

    @pytest.mark.parametrize("name", ["D65", "FL2"])
    def test_values(self, name):
        rng = np.random.default_rng(1)
        ref = rng.uniform(0.01, 1.0, (200, 3))
        test = ref * rng.uniform(0.9, 1.1, (200, 3))
        white = colour_pipeline.white_xyz(name, WL)
        de = colour_pipeline.delta_e94(ref, test, white)
        np.testing.assert_allclose(delta_e94_image(ref, test, name), de, rtol=1e-15)
        stats = delta_e94_stats(ref, test, name)
        assert stats["mean"] == pytest.approx(de.mean(), rel=1e-12)
        assert stats["p95"] == pytest.approx(np.percentile(de, 95), rel=1e-12)
        assert stats["max"] == pytest.approx(de.max(), rel=1e-12)
        assert stats["count"] == 200
        assert 0 < stats["mean"] <= stats["p95"] <= stats["max"]

    def test_n_dimensional(self):
        rng = np.random.default_rng(2)
        ref = rng.uniform(0.01, 1.0, (4, 5, 3))
        test = ref * 1.05
        assert delta_e94_image(ref, test).shape == (4, 5)
        flat = delta_e94_stats(ref.reshape(-1, 3), test.reshape(-1, 3))
        assert delta_e94_stats(ref, test) == pytest.approx(flat)

    def test_empty(self):
        empty = np.zeros((0, 3))
        assert delta_e94_stats(empty, empty) == {"mean": 0.0, "p95": 0.0, "max": 0.0,
                                                 "count": 0}

    def test_non_finite(self):
        ref = np.ones((3, 3)) * 0.5
        test = ref.copy()
        test[0, 0] = np.nan
        with pytest.raises(ValueError, match="non-finite"):
            delta_e94_stats(ref, test)


class _ReferenceModel:
    """A stand-in for a fitted model: ``xyz(wi, wo, illuminant)`` of a known BRDF."""

    wavelengths = WL

    def __init__(self, brdf):
        self.brdf = brdf

    def xyz(self, wi, wo, illuminant):
        return reference_xyz(self.brdf, wi, wo, illuminant)


class TestCosineWeightedLuminanceRms:
    """:func:`cosine_weighted_luminance_rms` (Kautz & McCool's radiometric error)."""

    def test_exact_model(self):
        brdf = lambertian(spectra.colorchecker_spectrum(12))
        assert cosine_weighted_luminance_rms(brdf, _ReferenceModel(brdf)) == pytest.approx(
            0.0, abs=1e-15)

    def test_half_albedo(self):
        # Equal-energy light, normalised white: Y = albedo·cosθi, so the error of a model at
        # half albedo is 0.5·cosθi and its RMS is 0.5·√E[cos²θi] ≈ 0.5/√3.
        rms = cosine_weighted_luminance_rms(lambertian(1.0), _ReferenceModel(lambertian(0.5)))
        wi, _ = random_direction_pairs(8000, 1999)
        assert rms == pytest.approx(0.5 * np.sqrt(np.mean(wi[:, 2] ** 2)), rel=1e-12)
        assert rms == pytest.approx(0.5 / np.sqrt(3.0), abs=0.01)
