"""Procedural BTFs (core.btf_generate): checks of physics that cannot be faked.

A flat height field must reproduce the Lambertian answer exactly; relief must cast shadows
where light crosses ridges and not where it runs along them; grazing views must hide the
grooves; shifting the height field must shift the images; a lit matte texel's spectrum must
be its region's reflectance; glossy stones must show a highlight at the mirror direction.
Sizes are small (64² height fields, a handful of directions) so that each test is fast.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from spectral_materials.core.btf import generate as gen
from spectral_materials.core.btf.container import BTF, ring_directions
from spectral_materials.core.colour import spectra
from spectral_materials.core.errors import Cancelled

WL = np.array([420.0, 480.0, 550.0, 610.0, 680.0])


def direction(theta: float, phi: float) -> np.ndarray:
    t, p = np.radians(theta), np.radians(phi)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


#: A small direction set: the pole, oblique and grazing rings (a view at 80°, a light at
#: the horizon).
SMALL = ring_directions(((0.0, 1), (30.0, 3), (60.0, 4), (75.0, 3)))
VIEWS = np.vstack([SMALL, direction(80.0, 40.0)])
LIGHTS = np.vstack([SMALL, direction(90.0, 10.0)])


def flat(reflectances, labels=None, *, height=0.0, r=64) -> gen.HeightFieldMaterial:
    reflectances = np.atleast_2d(reflectances)
    k = len(reflectances)
    return gen.HeightFieldMaterial(
        "flat", np.full((r, r), height),
        np.zeros((r, r), dtype=np.int64) if labels is None else labels,
        reflectances, np.zeros(k), np.ones(k))


def band(spectrum: np.ndarray, wavelengths=WL) -> np.ndarray:
    return np.interp(wavelengths, spectra.WAVELENGTHS_REFERENCE, spectrum)


# ----------------------------------------------------------------------- flat surfaces


def test_flat_white_reads_cos_theta_light_everywhere():
    white = np.ones(len(spectra.WAVELENGTHS_REFERENCE))
    # A flat field off the reference plane: oblique views hit it shifted, which must not
    # matter for a uniform surface.
    btf = gen.generate_btf(flat(white, height=0.37), texels=4, views=VIEWS, lights=LIGHTS,
                           wavelengths=WL, supersample=2)
    assert btf.shape == (len(VIEWS), len(LIGHTS), 4, 4, len(WL))
    assert btf.values.dtype == np.float32
    expected = np.broadcast_to(btf.lights[None, :, 2, None, None, None], btf.shape)
    np.testing.assert_allclose(btf.values, expected, rtol=1e-6, atol=1e-7)
    assert np.all(btf.values[:, -1] <= 1e-7)                     # the horizon light


def test_flat_grey_reads_reflectance_times_cos():
    grey = spectra.colorchecker(22)
    btf = gen.generate_btf(flat(grey), texels=4, views=VIEWS, lights=LIGHTS, wavelengths=WL,
                           supersample=2)
    expected = btf.lights[None, :, 2, None, None, None] * band(grey)
    np.testing.assert_allclose(btf.values, np.broadcast_to(expected, btf.shape), rtol=1e-6,
                               atol=1e-7)


def test_flat_two_regions_each_texel_reads_its_own():
    r, texels = 64, 8
    labels = np.zeros((r, r), dtype=np.int64)
    labels[:, r // 2:] = 1                                       # right half: grey
    grey = spectra.colorchecker(21)
    material = flat(np.stack([np.ones_like(grey), grey]), labels, r=r)
    btf = gen.generate_btf(material, texels=texels, views=VIEWS, lights=LIGHTS,
                           wavelengths=WL, supersample=2)
    cos = btf.lights[None, :, 2, None, None]
    left, right = btf.values[:, :, :, : texels // 2], btf.values[:, :, :, texels // 2:]
    np.testing.assert_allclose(left, np.broadcast_to(cos[..., None], left.shape), rtol=1e-6,
                               atol=1e-7)
    np.testing.assert_allclose(right, np.broadcast_to(cos[..., None] * band(grey),
                                                      right.shape), rtol=1e-6, atol=1e-7)


# ----------------------------------------------------------------- relief: energy, shadows


@pytest.mark.parametrize("name", ["corduroy", "knit", "stones"])
def test_values_finite_non_negative_and_bounded(name):
    material = gen.MATERIALS[name](64)
    btf = gen.generate_btf(material, texels=8, views=VIEWS, lights=LIGHTS, wavelengths=WL,
                           supersample=2)
    assert np.all(np.isfinite(btf.values)) and btf.present.all()
    assert btf.values.min() >= 0.0
    albedo = max(band(rho).max() for rho in material.reflectances)
    if not material.specular.any():
        # Matte: ρ · max(n·l, 0) · visibility can never exceed the brightest albedo.
        assert btf.values.max() <= albedo * (1 + 1e-6)
    else:
        # Glossy: a highlight may pass 1, but not absurdly.
        assert btf.values.max() < 3.0
    # Something is lit and something is dark at grazing light.
    assert btf.values.max() > 0.1 and (btf.values[:, -2] < 1e-3).any()


def test_corduroy_shadows_light_across_the_wales_not_along():
    material = gen.corduroy(128)
    white = dataclasses.replace(material, reflectances=np.ones_like(material.reflectances))
    across, along = direction(75.0, 0.0), direction(75.0, 90.0)      # wales run along y
    kwargs = dict(texels=32, views=[direction(0.0, 0.0)], lights=[across, along],
                  wavelengths=[550.0], supersample=4)
    lit = gen.generate_btf(white, **kwargs).values[0].mean(axis=(1, 2, 3))
    unshadowed = gen.generate_btf(white, shadows=False, **kwargs).values[0].mean(axis=(1, 2, 3))
    # Across: the grooves and the wales' far flanks lie in the next wale's shadow.
    assert lit[0] < 0.75 * unshadowed[0]
    # Along: the light runs down the grooves; only the pile's fuzz shadows anything.
    assert lit[1] > 0.97 * unshadowed[1]
    # Energy: seen from above, lit power is weighted by n_z ≤ 1, so a white relief can
    # never read more than the flat surface's cos θ_l.
    assert np.all(lit < np.array([across[2], along[2]]))
    assert np.all(unshadowed[1] < along[2])


def test_shadow_masks_pole_light_and_grazing_light_along_ridges_are_lit():
    surface = gen._Surface(gen.corduroy(64))
    masks = gen._shadow_masks(surface, np.array([[0.0, 0.0, 1.0], direction(85.0, 90.0),
                                                 direction(85.0, 0.0), [1.0, 0.0, 0.0]]))
    assert masks.shape == (65 * 65, 4)
    assert masks[:, 0].min() == 1.0                        # the pole shadows nothing
    assert masks[:, 1].mean() > 0.9                        # down the grooves: the fuzz only
    assert masks[:, 2].mean() < 0.4                        # across the wales
    assert masks[:, 3].mean() < 0.05                       # the horizon: only the crests


def test_grazing_view_across_the_wales_hides_the_grooves():
    material = gen.corduroy(64)
    kwargs = dict(texels=16, supersample=4)         # 64 points a side: each sample once
    groove = {}
    for key, view in {"top": direction(0.0, 0.0), "across": direction(75.0, 0.0),
                      "along": direction(75.0, 90.0)}.items():
        points, labels = gen.visible_surface(material, view, **kwargs)
        groove[key] = float(np.mean(labels == 1))
    top_view_share = float(np.mean(material.labels == 1))
    assert groove["top"] == pytest.approx(top_view_share, abs=1e-12)
    assert groove["across"] < 0.5 * groove["top"]          # hidden behind the wales
    assert groove["along"] == pytest.approx(groove["top"], abs=0.03)


def test_visible_points_lie_on_the_surface_and_on_the_view_ray():
    material = gen.knit(64)
    view = direction(60.0, 30.0)
    points, _ = gen.visible_surface(material, view, texels=8, supersample=2)
    surface = gen._Surface(material)
    r = surface.r
    pts = points.reshape(-1, 3)
    # On the surface (bisection leaves 2⁻¹⁰ of a half-sample step).
    height = surface.height_at(pts[:, 0] * r, pts[:, 1] * r)
    np.testing.assert_allclose(pts[:, 2], height, atol=1e-4)
    # On the ray through the texel's sample point of the reference plane.
    u, w = gen._sample_points(8, 2, r)
    back = pts[:, :2] - pts[:, 2:3] * view[:2] / view[2]
    np.testing.assert_allclose(back * r, np.stack([u, w], axis=-1), atol=1e-6)
    # Nothing between the hit and the camera is above the ray, up to what half-sample
    # steps can miss: a bump narrower than a step that the ray grazes.
    span = surface.highest - surface.lowest
    excess = np.zeros(len(pts))
    for z in np.linspace(0.0, 1.0, 200)[1:]:
        lift = pts[:, 2] + z * span
        ray = pts[:, :2] + (lift - pts[:, 2])[:, None] * view[:2] / view[2]
        excess = np.maximum(excess, surface.height_at(ray[:, 0] * r, ray[:, 1] * r) - lift)
    assert np.mean(excess > 1e-9) < 0.03 and excess.max() < 0.03 * span


def test_working_in_small_blocks_changes_nothing(monkeypatch):
    # Blocks of texel rows, of lights and of shadow rays bound the memory of big renders;
    # they must not change a value.
    kwargs = dict(texels=8, views=VIEWS[[0, 4, 8]], lights=LIGHTS, wavelengths=WL,
                  supersample=2)
    whole = gen.generate_btf(gen.stones(32), **kwargs).values
    monkeypatch.setattr(gen, "_BLOCK", 100)
    pieces = gen.generate_btf(gen.stones(32), **kwargs).values
    np.testing.assert_allclose(pieces, whole, rtol=1e-6, atol=1e-7)


# ------------------------------------------------------------ periodicity, determinism


def rolled(material: gen.HeightFieldMaterial, shift: tuple[int, int]) -> gen.HeightFieldMaterial:
    return dataclasses.replace(material, height=np.roll(material.height, shift, axis=(0, 1)),
                               labels=np.roll(material.labels, shift, axis=(0, 1)))


def test_shifting_the_height_field_shifts_the_images():
    material, texels = gen.knit(64), 8
    step = 64 // texels                                    # samples per texel
    kwargs = dict(texels=texels, views=VIEWS[[0, 3, 8]], lights=LIGHTS[[0, 5, 9]],
                  wavelengths=WL, supersample=2)
    base = gen.generate_btf(material, **kwargs).values
    moved = gen.generate_btf(rolled(material, (step, 3 * step)), **kwargs).values
    np.testing.assert_allclose(moved, np.roll(base, (1, 3), axis=(2, 3)), atol=1e-5)
    # A whole tile is no shift at all.
    whole = gen.generate_btf(rolled(material, (64, -64)), **kwargs).values
    np.testing.assert_array_equal(whole, base)


def test_generators_and_rendering_are_deterministic():
    for name, make in gen.MATERIALS.items():
        a, b, c = make(64, seed=3), make(64, seed=3), make(64, seed=4)
        np.testing.assert_array_equal(a.height, b.height)
        np.testing.assert_array_equal(a.labels, b.labels)
        np.testing.assert_array_equal(a.reflectances, b.reflectances)
        assert not np.array_equal(a.height, c.height), name
        assert a.height.shape == (64, 64) and abs(a.height.mean()) < 1e-12
        assert np.ptp(a.height) > 0.06, name                # deep enough to shadow
    kwargs = dict(texels=4, views=VIEWS[:4], lights=LIGHTS[:4], wavelengths=WL,
                  supersample=2)
    first = gen.generate_btf(gen.stones(64, seed=1), **kwargs)
    second = gen.generate_btf(gen.stones(64, seed=1), **kwargs)
    np.testing.assert_array_equal(first.values, second.values)


def test_generated_height_fields_are_periodic():
    # The field continues across the tile's edge as it does inside: the jump between the
    # last and first row (column) is no larger than between neighbours inside.
    for make in gen.MATERIALS.values():
        h = make(128).height
        for axis in (0, 1):
            inside = np.abs(np.diff(h, axis=axis)).max()
            edge = np.abs(np.take(h, 0, axis=axis) - np.take(h, -1, axis=axis)).max()
            assert edge <= inside + 1e-12


# ------------------------------------------------------------------------- spectra


def test_lit_matte_texel_spectrum_is_its_region_reflectance():
    material = gen.corduroy(64)
    texels = 16
    for view in (direction(0.0, 0.0), direction(45.0, 30.0)):
        btf = gen.generate_btf(material, texels=texels, views=[view],
                               lights=[direction(30.0, 200.0)], wavelengths=WL,
                               supersample=1)
        _, labels = gen.visible_surface(material, view, texels=texels, supersample=1)
        values = btf.values[0, 0].reshape(-1, len(WL)).astype(np.float64)
        expected = np.stack([band(rho) for rho in material.reflectances])[labels.ravel()]
        lit = values.max(axis=1) > 1e-4
        assert lit.sum() > texels * texels // 2
        ratio = values[lit] / expected[lit]
        np.testing.assert_allclose(ratio, np.broadcast_to(ratio[:, :1], ratio.shape),
                                   rtol=1e-5)
        assert {0, 1} <= set(labels.ravel()[lit].tolist())


def test_default_bands_and_names():
    material = flat(spectra.colorchecker(19), r=16)
    btf = gen.generate_btf(material, texels=2, views=[[0, 0, 1]], lights=[[0, 0, 1]],
                           supersample=1, name="patch")
    assert len(btf.wavelengths) == 16 and btf.wavelengths[0] == 400 and \
        btf.wavelengths[-1] == 700
    assert btf.name == "patch"
    np.testing.assert_allclose(btf.values[0, 0, 0, 0], band(spectra.colorchecker(19),
                                                              gen.DEFAULT_WAVELENGTHS),
                               rtol=1e-6)
    by_name = gen.generate_btf("corduroy", texels=2, views=[[0, 0, 1]], lights=[[0, 0, 1]],
                               supersample=1)
    assert by_name.name == "corduroy" and by_name.spectral


# ------------------------------------------------------------------------ specular


def test_stones_show_a_highlight_at_the_mirror_direction():
    material = gen.stones(64)
    matte = dataclasses.replace(material, specular=np.zeros_like(material.specular))
    view, lights = direction(15.0, 0.0), ring_directions()
    kwargs = dict(texels=16, views=[view], lights=lights, wavelengths=WL, supersample=2)
    glossy = gen.generate_btf(material, **kwargs).values[0].mean(axis=(1, 2, 3))
    diffuse = gen.generate_btf(matte, **kwargs).values[0].mean(axis=(1, 2, 3))
    assert np.all(glossy >= diffuse - 1e-7)
    assert glossy.max() > 1.3 * diffuse.max()
    mirror = np.array([-view[0], -view[1], view[2]])
    brightest = lights[np.argmax(glossy / diffuse)]
    assert np.degrees(np.arccos(np.clip(brightest @ mirror, -1, 1))) < 16.0


# ------------------------------------------------------------------ progress callback


def test_callback_reports_each_view_and_can_cancel():
    calls = []
    material = flat(np.ones(len(spectra.WAVELENGTHS_REFERENCE)), r=16)
    gen.generate_btf(material, texels=2, views=SMALL[:3], lights=SMALL[:2], wavelengths=WL,
                     supersample=1, callback=lambda f, m: calls.append(f))
    assert len(calls) == 4 and calls[-1] == 1.0 and calls == sorted(calls)
    with pytest.raises(Cancelled):
        gen.generate_btf(material, texels=2, views=SMALL[:3], lights=SMALL[:2],
                         wavelengths=WL, supersample=1, callback=lambda f, m: f > 0.5)


# ------------------------------------------------------------ noise and missing data


def small_btf() -> BTF:
    return gen.generate_btf(gen.corduroy(64), texels=4, views=SMALL[:6], lights=SMALL[:8],
                            wavelengths=WL, supersample=1)


def test_add_noise_is_multiplicative_clipped_and_seeded():
    btf = small_btf()
    noisy = gen.add_noise(btf, 0.1, seed=5)
    assert noisy.shape == btf.shape and noisy.values.min() >= 0.0
    ok = btf.values > 1e-3
    ratio = noisy.values[ok] / btf.values[ok]
    assert ratio.mean() == pytest.approx(1.0, abs=0.01)
    assert ratio.std() == pytest.approx(0.1, rel=0.1)
    np.testing.assert_array_equal(gen.add_noise(btf, 0.1, seed=5).values, noisy.values)
    assert not np.array_equal(gen.add_noise(btf, 0.1, seed=6).values, noisy.values)
    np.testing.assert_array_equal(gen.add_noise(btf, 0.0).values, btf.values)
    wild = gen.add_noise(btf, 2.0, seed=1)
    assert wild.values.min() == 0.0 and (wild.values[ok] == 0.0).any()
    # Missing images stay missing.
    gappy = gen.add_noise(gen.drop_samples(btf, 0.25, seed=2), 0.1)
    np.testing.assert_array_equal(gappy.present, gen.drop_samples(btf, 0.25, seed=2).present)
    with pytest.raises(ValueError, match="relative_sigma"):
        gen.add_noise(btf, -0.1)


def test_drop_samples_removes_whole_images_but_never_a_whole_view():
    btf = small_btf()
    v, lc = btf.present.shape
    dropped = gen.drop_samples(btf, 0.5, seed=1)
    assert (~dropped.present).sum() == round(0.5 * v * lc)
    assert dropped.present.any(axis=1).all()
    assert np.all(np.isnan(dropped.values[~dropped.present]))
    np.testing.assert_array_equal(dropped.values[dropped.present], btf.values[dropped.present])
    np.testing.assert_array_equal(gen.drop_samples(btf, 0.5, seed=1).present, dropped.present)
    most = gen.drop_samples(btf, 1.0 - 1.0 / lc, seed=3)
    np.testing.assert_array_equal(most.present.sum(axis=1), np.ones(v))
    assert gen.drop_samples(btf, 0.0).present.all()
    # Dropping more from a gappy BTF still leaves each view a present image.
    again = gen.drop_samples(dropped, 0.8, seed=4)
    assert again.present.any(axis=1).all()
    with pytest.raises(ValueError, match="keep one light per view"):
        gen.drop_samples(btf, 0.95)
    with pytest.raises(ValueError, match="fraction"):
        gen.drop_samples(btf, -0.1)


# ------------------------------------------------------------------------- errors


def test_bad_arguments_raise_value_errors_naming_the_problem():
    material = gen.corduroy(32)
    small = dict(views=[[0, 0, 1]], lights=[[0, 0, 1]], wavelengths=WL)
    with pytest.raises(ValueError, match="texels"):
        gen.generate_btf(material, texels=0, **small)
    with pytest.raises(ValueError, match="texels"):
        gen.generate_btf(material, texels=2.5, **small)
    with pytest.raises(ValueError, match="supersample"):
        gen.generate_btf(material, supersample=0, **small)
    with pytest.raises(ValueError, match="GiB"):
        gen.generate_btf(material, texels=2048)                 # 81 × 81 × 2048² × 16
    with pytest.raises(ValueError, match="unknown material 'velvet'"):
        gen.generate_btf("velvet")
    with pytest.raises(ValueError, match="from the normal"):
        gen.generate_btf(material, views=[direction(89.0, 0.0)], lights=[[0, 0, 1]])
    with pytest.raises(ValueError, match="upper hemisphere"):
        gen.generate_btf(material, views=[[0, 0, 1]], lights=[[0.0, 0.6, -0.8]])
    with pytest.raises(ValueError, match="resolution"):
        gen.knit(8)
    broken = np.array(material.height)
    broken[3, 4] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        dataclasses.replace(material, height=broken)
    material.height[3, 4] = np.inf                              # changed after checking
    with pytest.raises(ValueError, match="non-finite"):
        gen.generate_btf(material, **small)
    fine = gen.corduroy(32)
    with pytest.raises(ValueError, match="labels span"):
        dataclasses.replace(fine, labels=fine.labels + 1)
    with pytest.raises(ValueError, match="roughness"):
        dataclasses.replace(fine, roughness=np.zeros(2))
    with pytest.raises(ValueError, match="reflectances"):
        dataclasses.replace(fine, reflectances=fine.reflectances[:, :10])
