"""factor_brdf and FactoredBRDF: accuracy against the protocol reference, storage, stiff cases."""

import numpy as np
import pytest

from spectral_materials.core import Cancelled, FactoredBRDF, InvalidBRDFData, factor_brdf
from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factor import factor_brdf_series, is_isotropic
from spectral_materials.core.colour import spectra

SMALL_ISO = (24, 48, 24)
PATCH9 = spectra.colorchecker_spectrum(9)


@pytest.fixture(scope="module")
def pairs():
    return metrics.random_direction_pairs(3000, seed=5)


def mean_de94(brdf, model, pairs, illuminant="D65"):
    ref = metrics.reference_xyz(brdf, *pairs, illuminant)
    return metrics.delta_e94_stats(ref, model.xyz(*pairs, illuminant), illuminant)


def test_lambert_is_one_exact_pack(pairs):
    brdf = models.Lambert(albedo=PATCH9)
    model = factor_brdf(brdf, resolution=SMALL_ISO, packs=4, spectral_basis=6)
    assert model.report["packs"] == 1  # stops at the float32 floor
    stats = mean_de94(brdf, model, pairs)
    assert stats["max"] < 0.05
    f = model.evaluate(*pairs)
    assert f.shape == (3000, spectra.WAVELENGTHS_REFERENCE.size)
    np.testing.assert_allclose(f[pairs[0][:, 2] > 0.05], brdf(*pairs, model.wavelengths)[
        pairs[0][:, 2] > 0.05], rtol=2e-3, atol=1e-5)


def test_oren_nayar_error_falls_with_packs_against_the_5nm_reference(pairs):
    brdf = models.OrenNayar(albedo=PATCH9, sigma=0.52)
    series = factor_brdf_series(brdf, pack_counts=[1, 2, 4], resolution=SMALL_ISO,
                                spectral_basis=8)
    means = [mean_de94(brdf, m, pairs)["mean"] for m in series]
    assert means[0] > means[1] > means[2]
    assert means[1] < 0.3
    rms = [m.report["relative_rms"] for m in series]
    assert rms[0] > rms[1] > rms[2]


def test_isotropy_detection_and_layouts():
    wl = spectra.WAVELENGTHS_REFERENCE
    assert is_isotropic(models.OrenNayar(albedo=0.5, sigma=0.3), wl)
    assert not is_isotropic(models.AshikhminShirley(nu=1, nv=8, diffuse=0, specular=0.5), wl)
    iso = factor_brdf(models.Lambert(albedo=0.5), resolution=(6, 8, 6), packs=1)
    assert iso.parameterization == "io_iso"


@pytest.mark.parametrize("parameterization, resolution", [
    ("io", (8, 16, 8, 16)), ("hd", (12, 8, 12, 8)), ("gs", (10, 10, 10, 10)),
    ("ea", (8, 8, 16, 16)), ("hd_iso", (16, 16, 16)),
])
def test_every_parameterisation_factors_and_evaluates(parameterization, resolution, pairs):
    brdf = models.AshikhminShirley(nu=4, nv=12, diffuse=PATCH9, specular=0.05)
    model = factor_brdf(brdf, parameterization=parameterization, isotropic=False
                        if parameterization != "hd_iso" else None, resolution=resolution,
                        packs=8, spectral_basis=5)
    xyz = model.xyz(*pairs)
    assert np.isfinite(xyz).all()
    # Coarse grids (≤ 16 cells per axis): a sanity bound; measured 2.8–4.5 at 8 packs.
    assert mean_de94(brdf, model, pairs)["mean"] < 6
    assert model.report["relative_rms"] < 0.1


@pytest.mark.parametrize("method", ["svd", "nd"])
def test_separable_forms_through_factor_brdf(method, pairs, tmp_path):
    brdf = models.OrenNayar(albedo=PATCH9, sigma=0.3)
    series = factor_brdf_series(brdf, pack_counts=[1, 3], method=method, resolution=SMALL_ISO,
                                spectral_basis=6)
    assert series[1].report["relative_rms"] <= series[0].report["relative_rms"] + 1e-9
    loaded = FactoredBRDF.load(series[1].save(tmp_path / "sep.npz"))
    np.testing.assert_allclose(loaded.xyz(*pairs), series[1].xyz(*pairs), rtol=1e-6, atol=1e-9)


def test_save_load_round_trip_is_exact(tmp_path, pairs):
    brdf = models.AshikhminShirley(nu=8, nv=8, diffuse=PATCH9, specular=0.05)
    model = factor_brdf(brdf, resolution=SMALL_ISO, packs=2, spectral_basis=6)
    path = model.save(tmp_path / "m.npz")
    loaded = FactoredBRDF.load(path)
    np.testing.assert_array_equal(loaded.evaluate(*pairs), model.evaluate(*pairs))
    assert loaded.report["packs"] == 2
    assert loaded.parameterization == "io_iso"
    assert [t.shape for t in loaded.pack_textures()] == [(24, 2, 4), (48, 2, 4), (24, 2, 4),
                                                         (6, 2, 4)]


def test_load_refuses_truncated_and_foreign_files(tmp_path):
    model = factor_brdf(models.Lambert(albedo=0.5), resolution=(6, 8, 6), packs=1)
    good = model.save(tmp_path / "m.npz").read_bytes()
    for cut in (0, 10, len(good) // 2, len(good) - 10):
        bad = tmp_path / f"cut{cut}.npz"
        bad.write_bytes(good[:cut])
        with pytest.raises(ValueError):
            FactoredBRDF.load(bad)
    other = tmp_path / "other.npz"
    np.savez(other, x=np.zeros(3))
    with pytest.raises(ValueError, match="meta"):
        FactoredBRDF.load(other)


def test_same_seed_same_factors():
    brdf = models.OrenNayar(albedo=PATCH9, sigma=0.52)
    a = factor_brdf(brdf, resolution=(12, 24, 12), packs=2, spectral_basis=5, seed=3)
    b = factor_brdf(brdf, resolution=(12, 24, 12), packs=2, spectral_basis=5, seed=3)
    for fa, fb in zip(a.factors + [a.spectral], b.factors + [b.spectral]):
        np.testing.assert_array_equal(fa, fb)


def test_target_de94_stops_at_the_first_pack_count_meeting_it():
    brdf = models.OrenNayar(albedo=PATCH9, sigma=0.52)
    model = factor_brdf(brdf, resolution=SMALL_ISO, target_de94=0.2, packs=12, spectral_basis=8)
    per_pack = model.report["per_pack"]
    assert per_pack[-1]["mean_de94_d65"] <= 0.2
    assert all(row["mean_de94_d65"] > 0.2 for row in per_pack[:-1])
    assert model.report["stopped"] == "target reached"


def test_progress_reaches_the_callback_and_cancel_stops():
    calls = []
    factor_brdf(models.Lambert(albedo=0.5), resolution=(6, 8, 6), packs=1,
                callback=lambda f, m: calls.append((f, m)) or False)
    fractions = [f for f, _ in calls]
    assert fractions and all(0 <= f <= 1 for f in fractions)
    with pytest.raises(Cancelled):
        factor_brdf(models.Lambert(albedo=0.5), resolution=(6, 8, 6), packs=1,
                    callback=lambda f, m: True)


# ----------------------------------------------------------------- stiff cases


def test_nan_brdf_is_rejected_with_count_and_location():
    inner = models.Lambert(albedo=0.5)

    def broken(wi, wo, wl):
        f = inner(wi, wo, wl)
        f[wi[:, 2] < 0.2] = np.nan
        return f

    with pytest.raises(InvalidBRDFData, match=r"\d+ NaN.*first at \(theta_i=\d"):
        factor_brdf(broken, isotropic=True, resolution=(12, 8, 12), packs=1)


def test_zero_and_near_zero_brdfs():
    zero = factor_brdf(models.Lambert(albedo=0.0), resolution=(6, 8, 6), packs=8)
    wi, wo = metrics.random_direction_pairs(50)
    assert np.all(zero.evaluate(wi, wo) == 0)
    tiny = factor_brdf(models.Lambert(albedo=1e-30), resolution=(6, 8, 6), packs=2)
    f = tiny.evaluate(wi, wo)
    assert np.isfinite(f).all() and f.max() < 1e-29


def test_mirror_like_lobe_exponent_1e4_stays_finite_and_monotone():
    brdf = models.AshikhminShirley(nu=1e4, nv=1e4, diffuse=1e-4, specular=0.9)
    model = factor_brdf(brdf, parameterization="hd", resolution=(32, 16, 8), packs=4,
                        spectral_basis=4)
    rms = [row["fitted_relative_error"] for row in model.report["per_pack"]]
    assert np.all(np.diff(rms) <= 1e-12)
    wi, wo = metrics.random_direction_pairs(500)
    assert np.isfinite(model.evaluate(wi, wo)).all()
    # values span > 1e8 between the diffuse floor and the peak
    table_peak = brdf(np.array([[0, 0, 1.0]]), np.array([[0, 0, 1.0]]), [550.0])[0, 0]
    assert table_peak / 1e-4 * np.pi > 1e6


@pytest.mark.parametrize("sigma", [0.0, 1e-6, 5.0])
def test_oren_nayar_extreme_roughness(sigma, pairs):
    brdf = models.OrenNayar(albedo=PATCH9, sigma=sigma)
    model = factor_brdf(brdf, resolution=SMALL_ISO, packs=2, spectral_basis=6)
    assert mean_de94(brdf, model, pairs)["p95"] < 1.0


def test_grazing_and_pole_evaluation_is_finite():
    model = factor_brdf(models.OrenNayar(albedo=0.7, sigma=0.5), resolution=(12, 24, 12), packs=2)
    grazing = np.radians([0.0, 45.0, 89.9, 89.999, 90.0])
    wi = np.stack([np.sin(grazing), 0 * grazing, np.cos(grazing)], axis=-1)
    wi[-1] = [1.0, 0.0, 0.0]  # exactly on the horizon
    wo = wi[::-1] * np.array([-1, 1, 1])
    with np.errstate(all="raise"):
        f = model.evaluate(wi, wo)
    assert np.isfinite(f).all() and (f >= 0).all()
    assert (f[-1] == 0).all() and (f[0] == 0).all()


def test_absurd_parameters_get_clear_errors():
    brdf = models.Lambert(albedo=0.5)
    with pytest.raises(ValueError, match="packs"):
        factor_brdf(brdf, packs=0)
    with pytest.raises(ValueError, match="resolution"):
        factor_brdf(brdf, isotropic=True, resolution=(10, 10))
    with pytest.raises(ValueError, match="entries"):
        factor_brdf(brdf, isotropic=False, resolution=(900, 1800, 900, 1800))
    with pytest.raises(ValueError, match="target_de94"):
        factor_brdf(brdf, target_de94=-1)
    with pytest.raises(TypeError, match="callable"):
        factor_brdf("not a brdf")


# ----------------------------------------------------------- perceptual weighting


def test_mode_weights_and_scaling_fold_back_exactly():
    from spectral_materials.core.brdf.factor import mode_weights, scale_modes

    rng = np.random.default_rng(0)
    tensor = rng.uniform(0, 1, (6, 7, 5, 3)).astype(np.float32)
    tensor[2] *= 1e-3  # a dim slice gets a large weight
    tensor[4] = 0.0    # an empty slice gets weight 1
    weights = mode_weights(tensor, 0.5)
    assert [w.shape for w in weights] == [(6,), (7,), (5,)]
    assert weights[0][2] > 10 and weights[0][4] == 1.0
    assert all((w >= 1).all() and (w <= 1e3).all() for w in weights)
    scaled = scale_modes(tensor, weights)
    expected = tensor * np.einsum("i,j,k->ijk", *weights)[..., None]
    np.testing.assert_allclose(scaled, expected, rtol=1e-6)
    assert all((w == 1).all() for w in mode_weights(tensor, 0.0))


def test_weighted_factors_fold_back_to_the_unweighted_table():
    from spectral_materials.core.brdf.factor import prepare_table
    from spectral_materials.core.decomposition import cp

    brdf = models.AshikhminShirley(nu=32, nv=32, diffuse=spectra.colorchecker_spectrum(12),
                                   specular=0.05)
    table = prepare_table(brdf, isotropic=True, resolution=SMALL_ISO, spectral_basis=6)
    (model,) = factor_brdf_series(brdf, table=table, pack_counts=[4], weighting=0.7)
    assert model.report["weighting"] == 0.7
    reconstructed = cp.reconstruct(model.factors + [model.spectral])
    direct = np.sum((table.values.astype(np.float64) - reconstructed) ** 2)
    expected = np.sqrt((direct + table.basis_error_sq) / table.norm_sq)
    assert model.report["relative_rms"] == pytest.approx(expected, rel=1e-4)
    fitted = [row["fitted_relative_error"] for row in model.report["per_pack"]]
    assert np.all(np.diff(fitted) <= 1e-12)


def test_weighting_out_of_range_is_refused():
    with pytest.raises(ValueError, match="weighting"):
        factor_brdf(models.Lambert(albedo=0.5), packs=1, weighting=-1.0)


def test_load_refuses_malformed_meta(tmp_path):
    import json

    model = factor_brdf(models.Lambert(albedo=0.5), resolution=(6, 8, 6), packs=1)
    path = model.save(tmp_path / "m.npz")
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(arrays["meta"].tobytes())
    for key, value in (("form", "tucker"), ("pack_size", 0), ("edge", "cubic"), ("grid", None)):
        broken = dict(meta, **{key: value})
        arrays["meta"] = np.frombuffer(json.dumps(broken).encode(), dtype=np.uint8)
        np.savez(tmp_path / "bad.npz", **arrays)
        with pytest.raises(ValueError):
            FactoredBRDF.load(tmp_path / "bad.npz")


def test_smoothing_is_counted_in_the_reported_error():
    brdf = models.AshikhminShirley(nu=16, nv=16, diffuse=PATCH9, specular=0.05)
    plain = factor_brdf(brdf, resolution=SMALL_ISO, packs=2, spectral_basis=5, weighting=0.0)
    smooth = factor_brdf(brdf, resolution=SMALL_ISO, packs=2, spectral_basis=5, weighting=0.0,
                         smoothing=4)
    assert smooth.report["relative_rms"] > plain.report["relative_rms"]


def test_tabulation_never_writes_into_the_callers_array():
    inner = models.Lambert(albedo=0.5)

    def read_only(wi, wo, wl):
        out = inner(wi, wo, wl)
        out.setflags(write=False)
        return out

    model = factor_brdf(read_only, isotropic=True, resolution=(6, 8, 6), packs=1)
    assert model.report["relative_rms"] < 1e-3


def test_values_beyond_float32_are_refused_and_truncation_keeps_a_pack():
    inner = models.Lambert(albedo=0.5)
    with pytest.raises(InvalidBRDFData, match="float32"):
        factor_brdf(lambda wi, wo, wl: inner(wi, wo, wl) * 1e40, isotropic=True,
                    resolution=(6, 8, 6), packs=1)
    model = factor_brdf(inner, resolution=(6, 8, 6), packs=1)
    with pytest.raises(ValueError, match="at least one pack"):
        model.truncated(0)
