"""MERL ``.binary`` reader/writer and the spectral BRDF callable built on it."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from colour.recovery import RGB_to_sd_Smits1999

from spectral_materials.core.brdf import models
from spectral_materials.core.brdf.params import PARAMETERIZATIONS
from spectral_materials.core.colour import uplift
from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats import merl

WL = np.arange(400.0, 701.0, 10.0)
SMALL = (4, 3, 6)  # a small table for the private shape-generic reader (fuzzing)


def _as_rgb():
    """Ashikhmin–Shirley (nu = nv = 32, Rs = 0.05) with an RGB diffuse colour.

    The model is linear in Rd for fixed Rs: f = Rd·D + S, evaluated at one wavelength.
    """
    rd = np.array([0.45, 0.25, 0.08])
    one = models.make_model("ashikhmin_shirley", nu=32, nv=32, diffuse=1.0, specular=0.05)
    zero = models.make_model("ashikhmin_shirley", nu=32, nv=32, diffuse=0.0, specular=0.05)

    def brdf_rgb(wi, wo):
        s = zero(wi, wo, np.array([550.0]))
        d = one(wi, wo, np.array([550.0])) - s
        return d * rd + s

    return brdf_rgb


def _random_pairs(n, seed=3):
    rng = np.random.default_rng(seed)

    def hemi(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2]) + 1e-3
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    return hemi(n), hemi(n)


def _rotate_z(v, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1], v[..., 2]],
                    axis=-1)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """One full-size file written from the analytic RGB BRDF, and the table written."""
    table = merl.merl_table_from_brdf(_as_rgb())
    path = tmp_path_factory.mktemp("merl") / "as.binary"
    merl.write_merl(path, table)
    return path, table


@pytest.fixture(scope="module")
def brdf(written):
    return merl.read_merl(written[0])


@pytest.fixture(scope="module")
def below(written):
    return written[1][..., 0] < 0


def _small_file(path, seed=0):
    rng = np.random.default_rng(seed)
    table = rng.uniform(0.0, 2.0, SMALL + (3,))
    table[0, 0, 0] = -1.0
    merl._write_merl(path, table, SMALL, allow_invalid=False)
    return table


# --------------------------------------------------------------------------- round trip


def test_file_layout(written):
    path, table = written
    raw = path.read_bytes()
    assert len(raw) == merl.FILE_BYTES == 34_992_012
    assert np.frombuffer(raw[:12], "<i4").tolist() == [90, 90, 180]
    body = np.frombuffer(raw[12:], "<f8").reshape(3, -1)  # planar R, G, B
    n = 90 * 90 * 180
    cell = 17 + 180 * (40 + 90 * 12)  # φd 17, θd 40, θh 12
    for c, scale in enumerate(merl.CHANNEL_SCALES):
        assert body[c].size == n
        assert body[c, cell] * scale == pytest.approx(table[12, 40, 17, c], rel=1e-12)


def test_round_trip(written, brdf, below):
    path, table = written
    assert brdf.table.dtype == np.float32 and brdf.table.shape == (90, 90, 180, 3)
    expected = np.where(table < 0, 0.0, table).astype(np.float32)
    zero = merl.read_merl(path, fill="zero")  # −1 cells read as 0, as before the fill
    np.testing.assert_allclose(zero.table, expected, rtol=1e-6, atol=0)
    # The default fills the −1 cells (test_formats_merl_fill.py) and leaves the others be.
    assert np.array_equal(brdf.table[~below], zero.table[~below])
    assert (brdf.table[below] > 0).all()
    assert brdf.defects["negative"] == brdf.defects["below_horizon_marker"] == 3 * below.sum()
    assert brdf.defects["invalid_cells"] == brdf.defects["filled_cells"] == below.sum()
    assert brdf.defects["nan"] == brdf.defects["inf"] == 0
    assert 0.2 < below.mean() < 0.3
    assert brdf.describe()["shape"] == [90, 90, 180]


def test_cell_centres_exact(written, brdf, below):
    """At cell centres (rotated by any φh) the lookup returns the written value exactly."""
    rng = np.random.default_rng(5)
    cells = rng.choice(np.nonzero(~below.ravel())[0], 3000, replace=False)
    wi, wo, valid = PARAMETERIZATIONS["hd_iso"].inverse(merl.cell_centres()[cells])
    assert valid.all()
    angle = rng.uniform(0, 2 * np.pi, (cells.size, 1))
    wi, wo = _rotate_z(wi, angle[:, 0]), _rotate_z(wo, angle[:, 0])
    assert np.array_equal(brdf.cell_index(wi, wo), cells)
    rgb = brdf.rgb(wi, wo)
    assert np.array_equal(rgb, brdf.table.reshape(-1, 3)[cells].astype(np.float64))
    np.testing.assert_allclose(rgb, written[1].reshape(-1, 3)[cells], rtol=1e-6)


def test_indices_match_reference_formulas():
    """θh: ⌊√(θh/(π/2))·90⌋, θd: ⌊θd/(π/2)·90⌋, φd folded (atan2 < 0 → +π), clamped."""
    th = np.array([0.0, -1e-9, 1e-4, (0.5 / 90) ** 2 * math.pi / 2, math.pi / 2, 2.0])
    assert merl.merl_indices(th, 0 * th, 0 * th).tolist() == [
        0, 0, 180 * 90 * int(math.sqrt(1e-4 / (math.pi / 2)) * 90), 0, 180 * 90 * 89,
        180 * 90 * 89]
    td = np.array([0.0, math.pi / 4, math.pi / 2])
    assert (merl.merl_indices(0 * td, td, 0 * td) // 180).tolist() == [0, 45, 89]
    atan2 = np.array([0.0, 0.3, -0.3, math.pi, -math.pi + 1e-9, math.pi - 1e-9])
    folded = np.where(atan2 < 0, atan2 + math.pi, atan2)  # the reference
    expected = np.clip(np.floor(folded / math.pi * 180), 0, 179)
    wrapped = np.mod(atan2, 2 * math.pi)  # what params._hd_forward gives
    assert merl.merl_indices(0 * atan2, 0 * atan2, wrapped).tolist() == expected.tolist()
    assert merl.merl_indices(0 * atan2, 0 * atan2, atan2).tolist() == expected.tolist()


def test_reciprocity_folding(brdf):
    rng = np.random.default_rng(9)
    th = rng.uniform(0, 1.2, 500)
    td = rng.uniform(0, 1.2, 500)
    pd = rng.uniform(0, np.pi, 500)
    inv = PARAMETERIZATIONS["hd_iso"].inverse
    wi1, wo1, v1 = inv(np.stack([th, td, pd], -1))
    wi2, wo2, v2 = inv(np.stack([th, td, pd + np.pi], -1))
    ok = v1 & v2 & (wi1[:, 2] > 0.01) & (wo1[:, 2] > 0.01)
    assert ok.sum() > 100
    np.testing.assert_array_equal(brdf.rgb(wi1[ok], wo1[ok]), brdf.rgb(wi2[ok], wo2[ok]))
    wi, wo = _random_pairs(2000)
    np.testing.assert_array_equal(brdf(wi, wo, WL), brdf(wo, wi, WL))


def test_close_to_the_analytic_model(brdf):
    """Nearest-cell lookup of the tabulated model stays close to it away from the peak."""
    wi, wo = _random_pairs(4000)
    exact = _as_rgb()(wi, wo)
    got = brdf.rgb(wi, wo)
    err = np.abs(got - exact) / np.maximum(exact, 1e-3)
    assert np.median(err) < 0.05


# --------------------------------------------------------------------------- uplift


@pytest.mark.parametrize("rgb", [(0.2, 0.5, 0.9), (0.9, 0.1, 0.3), (0.4, 0.4, 0.1),
                                 (0.3, 0.7, 0.7), (0.5, 0.5, 0.5), (0.0, 0.0, 0.0),
                                 (0.05, 0.9, 0.02)])
def test_smits_matches_colour_science(rgb):
    sd = RGB_to_sd_Smits1999(np.array(rgb))
    up = uplift.SmitsUplift()
    got = up(np.array([rgb]), sd.wavelengths)[0]
    np.testing.assert_allclose(got, sd.values, atol=1e-12)
    # linear in scale (k >= 0), so BRDF values above 1 are fine
    np.testing.assert_allclose(up(np.array([rgb]) * 40.0, sd.wavelengths)[0], 40 * sd.values,
                               atol=1e-10)
    # off colour-science's own samples: linear interpolation of its distributions
    wl = np.arange(380.0, 781.0, 5.0)
    np.testing.assert_allclose(up(np.array([rgb]), wl)[0],
                               np.interp(wl, sd.wavelengths, sd.values), atol=1e-12)


def test_smits_vectorised_many():
    rng = np.random.default_rng(1)
    rgb = rng.uniform(0, 1, (50, 3))
    up = uplift.SmitsUplift()
    sd0 = RGB_to_sd_Smits1999(rgb[0])
    got = up(rgb, sd0.wavelengths)
    ref = np.stack([RGB_to_sd_Smits1999(c).values for c in rgb])
    np.testing.assert_allclose(got, ref, atol=1e-12)


def test_lambert_albedo(tmp_path, below):
    """A Lambertian file reads back as albedo/π, uplifted by Smits."""
    albedo = np.array([0.62, 0.35, 0.12])
    table = np.where(below[..., None], -1.0, albedo / np.pi)
    path = merl.write_merl(tmp_path / "lambert.binary", table)
    b = merl.read_merl(path)
    wi, wo = _random_pairs(1000)
    # Near grazing, a pair can fall in a cell whose centre is below the horizon (marked −1
    # in the file): the reference's nearest-cell lookup then has no value; fill="zero"
    # gives 0 there, the default fill the mean of the valid neighbours: albedo/π here.
    marked = below.ravel()[b.cell_index(wi, wo)]
    assert 0 < marked.mean() < 0.02
    assert not merl.read_merl(path, fill="zero").rgb(wi[marked], wo[marked]).any()
    np.testing.assert_allclose(b.rgb(wi, wo), np.broadcast_to(albedo / np.pi, wi.shape),
                               rtol=1e-6)
    sd = RGB_to_sd_Smits1999(albedo)
    f = b(wi, wo, sd.wavelengths)
    np.testing.assert_allclose(f, np.broadcast_to(sd.values / np.pi, f.shape), rtol=1e-6)
    # grey: Smits' white is flat to 1e-3, so the spectrum is albedo/π within that
    grey = uplift.SmitsUplift()(np.array([[0.5, 0.5, 0.5]]) / np.pi, WL)
    np.testing.assert_allclose(grey, 0.5 / np.pi, rtol=1e-3)


def test_jakob2019_uplift(tmp_path, below):
    lut = uplift.jakob2019_lut(3, tmp_path)  # tiny LUT: ~2 s to generate
    assert (tmp_path / "jakob2019_srgb_3.coeff").is_file()
    albedo = np.array([0.6, 0.3, 0.1])
    table = np.where(below[..., None], -1.0, albedo / np.pi)
    path = merl.write_merl(tmp_path / "lambert.binary", table)
    b = merl.read_merl(path, uplift="jakob2019", jakob_lut=lut)
    wi, wo = _random_pairs(50)
    wl = np.arange(400.0, 701.0, 5.0)
    f = b(wi, wo, wl)
    coeffs = lut.RGB_to_coefficients(albedo)
    u = coeffs[0] * wl**2 + coeffs[1] * wl + coeffs[2]
    refl = 0.5 + u / (2 * np.sqrt(1 + u * u))
    np.testing.assert_allclose(f, np.broadcast_to(refl / np.pi, f.shape), rtol=1e-5)
    up = uplift.Jakob2019Uplift(lut)
    # brighter than a reflectance: uplifted at unit peak and scaled back
    bright = up(np.array([[6.0, 3.0, 1.0]]) / np.pi, wl)
    np.testing.assert_allclose(bright, 6.0 * up(np.array([[1.0, 0.5, 1 / 6]]) / np.pi, wl),
                               rtol=1e-6)
    assert np.array_equal(up(np.zeros((2, 3)), wl), np.zeros((2, wl.size)))
    assert up(np.zeros((0, 3)), wl).shape == (0, wl.size)


def test_moved_uplift_names_still_served_with_a_warning():
    """The uplift moved to core.colour.uplift (issue 17); merl's old names forward there."""
    for old, new in (("SmitsUplift", "SmitsUplift"), ("Jakob2019Uplift", "Jakob2019Uplift"),
                     ("jakob2019_lut", "jakob2019_lut"), ("UPLIFTS", "UPLIFTS"),
                     ("JAKOB2019_LUT_SIZE", "JAKOB2019_LUT_SIZE"), ("_make_uplift", "make_uplift")):
        with pytest.warns(DeprecationWarning, match=f"merl.{old} moved to .*uplift.{new}"):
            assert getattr(merl, old) is getattr(uplift, new)
    with pytest.raises(AttributeError):
        merl.no_such_name  # noqa: B018
    assert isinstance(merl.MERLBRDF(np.zeros((2, 2, 2, 3))).uplift, uplift.SmitsUplift)


def test_shapes_and_horizon(brdf):
    wi, wo = _random_pairs(10)
    f = brdf(wi.reshape(2, 5, 3), wo.reshape(2, 5, 3), WL)
    assert f.shape == (2, 5, WL.size)
    np.testing.assert_array_equal(f.reshape(10, -1), brdf(wi, wo, WL))
    assert brdf.rgb(wi.reshape(5, 2, 3), wo.reshape(5, 2, 3)).shape == (5, 2, 3)
    assert brdf(np.zeros((0, 3)), np.zeros((0, 3)), WL).shape == (0, WL.size)
    assert brdf.rgb(np.zeros((0, 3)), np.zeros((0, 3))).shape == (0, 3)
    assert brdf(wi[0], wo[0], WL).shape == (WL.size,)
    flipped = wo * np.array([1, 1, -1])
    assert not brdf(wi, flipped, WL).any()
    assert not brdf(wi * np.array([1, 1, -1]), wo, WL).any()
    with pytest.raises(ValueError):
        brdf(wi[:, :2], wo[:, :2], WL)
    with pytest.raises(ValueError):
        brdf(wi * np.nan, wo, WL)


def test_factor_brdf(brdf):
    from spectral_materials.core.brdf.factor import factor_brdf

    model = factor_brdf(brdf, parameterization="hd", isotropic=True, resolution=(16, 16, 32),
                        packs=2, spectral_basis=8)
    wi, wo = _random_pairs(200)
    approx = model.evaluate(wi, wo)
    assert approx.shape == (200, model.wavelengths.size) and np.isfinite(approx).all()
    exact = brdf(wi, wo, model.wavelengths)
    cos = wi[:, 2:3]
    rel = np.linalg.norm((approx - exact) * cos) / np.linalg.norm(exact * cos)
    assert rel < 0.5  # 16×16×32 cells and 2 packs of a glossy lobe: coarse, but sane


# --------------------------------------------------------------------------- bad input


def _header(dims, dtype="<i4"):
    return np.asarray(dims, dtype=dtype).tobytes()


@pytest.mark.parametrize("dims, message", [
    ((90, 90, 360), "header dimensions"),
    ((180, 90, 90), "wrong order"),
    ((0, 0, 0), "header dimensions"),
    ((-90, 90, 180), "header dimensions"),
])
def test_bad_dims(tmp_path, dims, message):
    path = tmp_path / "bad.binary"
    path.write_bytes(_header(dims) + b"\0" * 64)
    with pytest.raises(InvalidBRDFData, match=message) as info:
        merl.read_merl(path)
    assert str(path) in str(info.value)


def test_big_endian_and_wrong_magic(tmp_path):
    path = tmp_path / "be.binary"
    path.write_bytes(_header((90, 90, 180), ">i4") + b"\0" * 64)
    with pytest.raises(InvalidBRDFData, match="big-endian"):
        merl.read_merl(path)
    path.write_bytes(b"tensor_file\0" + b"\0" * 64)
    with pytest.raises(InvalidBRDFData, match="not a MERL"):
        merl.read_merl(path)


def test_huge_dims_fail_fast(tmp_path):
    path = tmp_path / "huge.binary"
    path.write_bytes(_header((2**31 - 1, 2**31 - 1, 2**31 - 1)))
    start = time.perf_counter()
    with pytest.raises(InvalidBRDFData, match="header dimensions"):
        merl.read_merl(path)
    assert time.perf_counter() - start < 0.5


@pytest.mark.parametrize("size, message", [
    (0, "empty"), (5, "too short"), (12, "truncated"), (12 + 8 * 1000, "truncated"),
    (merl.FILE_BYTES - 1, "truncated"), (merl.FILE_BYTES + 8, "trailing"),
])
def test_wrong_size(tmp_path, size, message):
    path = tmp_path / "short.binary"
    with open(path, "wb") as f:
        f.write(_header((90, 90, 180))[:size])
        if size > 12:
            f.truncate(size)  # sparse: no 35 MB write
    with pytest.raises(InvalidBRDFData, match=message) as info:
        merl.read_merl(path)
    assert str(path) in str(info.value)


def test_missing_and_directory(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        merl.read_merl(tmp_path / "nope.binary")
    with pytest.raises(IsADirectoryError, match=str(tmp_path)):
        merl.read_merl(tmp_path)


def test_bad_arguments(written):
    with pytest.raises(ValueError, match="on_invalid"):
        merl.read_merl(written[0], on_invalid="ignore")
    with pytest.raises(ValueError, match="uplift"):
        merl.read_merl(written[0], uplift="nearest")
    with pytest.raises(ValueError, match="shape"):
        merl.write_merl(written[0].parent / "x.binary", np.zeros((90, 90, 90, 3)))
    with pytest.raises(InvalidBRDFData, match="NaN"):
        merl.write_merl(written[0].parent / "x.binary", np.full((90, 90, 180, 3), np.nan))
    assert not (written[0].parent / "x.binary").exists()


def test_nan_samples_raise_or_clamp(tmp_path):
    table = _small_file(tmp_path / "ok.binary")
    table[1, 2, 3, 1] = np.nan
    table[2, 0, 5, 2] = np.inf
    path = merl._write_merl(tmp_path / "nan.binary", table, SMALL, allow_invalid=True)
    with pytest.raises(InvalidBRDFData, match=r"1 NaN and 1 inf") as info:
        merl._read_merl(path, shape=SMALL)
    assert str(path) in str(info.value) and "channel G" in str(info.value)
    b = merl._read_merl(path, shape=SMALL, on_invalid="clamp", fill="zero")
    assert b.defects["nan"] == 1 and b.defects["inf"] == 1
    assert b.defects["negative"] == 3 and b.defects["invalid_cells"] == 3
    assert b.table[1, 2, 3, 1] == 0 and b.table[2, 0, 5, 2] == 0 and b.table[0, 0, 0].sum() == 0
    assert np.isfinite(b.table).all()
    filled = merl._read_merl(path, shape=SMALL, on_invalid="clamp")
    assert np.isfinite(filled.table).all() and (filled.table > 0).all()
    assert filled.defects["filled_samples"] == 5 and filled.defects["filled_cells"] == 3
    bad = np.isnan(table) | np.isinf(table) | (table < 0)
    assert np.array_equal(filled.table[~bad], b.table[~bad])


def test_all_invalid(tmp_path):
    path = merl._write_merl(tmp_path / "dead.binary", -np.ones(SMALL + (3,)), SMALL, False)
    with pytest.raises(InvalidBRDFData, match="all 72 cells"):
        merl._read_merl(path, shape=SMALL, on_invalid="clamp")
    table = np.full(SMALL + (3,), np.nan)
    path = merl._write_merl(tmp_path / "nan.binary", table, SMALL, True)
    with pytest.raises(InvalidBRDFData, match="all 72 cells"):
        merl._read_merl(path, shape=SMALL, on_invalid="clamp")


def test_fuzz(tmp_path):
    """Random truncations and byte flips: InvalidBRDFData or success, nothing else."""
    good = tmp_path / "good.binary"
    _small_file(good)
    data = good.read_bytes()
    rng = np.random.default_rng(2024)
    path = tmp_path / "fuzz.binary"
    outcomes = {"ok": 0, "invalid": 0}
    for case in range(200):
        raw = bytearray(data)
        kind = case % 4
        if kind == 0:
            raw = raw[: int(rng.integers(0, len(raw)))]
        else:
            lo, hi = (0, 12) if kind == 1 else (12, len(raw))
            for _ in range(int(rng.integers(1, 6))):
                pos = int(rng.integers(lo, hi))
                raw[pos] ^= 1 << int(rng.integers(0, 8))
            if kind == 3:  # whole-double damage: NaN/inf/huge/negative patterns
                pos = 12 + 8 * int(rng.integers(0, (len(raw) - 12) // 8))
                patterns = [b"\xff" * 8, b"\x00" * 6 + b"\xf0\x7f", b"\xff" * 7 + b"\x7f",
                            np.float64(-1).tobytes()]
                raw[pos : pos + 8] = patterns[int(rng.integers(0, len(patterns)))]
        path.write_bytes(bytes(raw))
        for on_invalid in ("raise", "clamp"):
            try:
                b = merl._read_merl(path, shape=SMALL, on_invalid=on_invalid)
            except InvalidBRDFData as exc:
                assert str(path) in str(exc)
                outcomes["invalid"] += 1
            else:
                outcomes["ok"] += 1
                assert np.isfinite(b.table).all() and (b.table >= 0).all()
                wi, wo = _random_pairs(20)
                assert np.isfinite(b(wi, wo, WL)).all()
    assert outcomes["ok"] > 20 and outcomes["invalid"] > 100


@pytest.mark.parametrize("stored", [1e308, -1e308, 1e40, -5e33, 2e33])
@pytest.mark.parametrize("on_invalid", ["raise", "clamp"])
def test_extreme_samples_refused(tmp_path, stored, on_invalid):
    """Finite samples beyond ±1e30 sr⁻¹ once scaled (sample_limits) are refused at the
    reader, negative or not, naming the file, the channel and the cell."""
    path = tmp_path / "big.binary"
    _small_file(path)
    raw = bytearray(path.read_bytes())
    at = 12 + 8 * int(np.ravel_multi_index((2, 1, 4), SMALL))  # channel R, as stored
    raw[at : at + 8] = np.float64(stored).tobytes()  # the writer would turn −x into −1
    path.write_bytes(bytes(raw))
    with pytest.raises(InvalidBRDFData, match=r"1 samples of channel R lie beyond ±1e\+30") \
            as info:
        merl._read_merl(path, shape=SMALL, on_invalid=on_invalid)
    assert str(path) in str(info.value) and "θh[2]" in str(info.value)


def test_samples_up_to_the_limit_read(tmp_path):
    table = _small_file(tmp_path / "ok.binary")
    table[1, 1, 1, 2] = 0.9e30
    path = merl._write_merl(tmp_path / "edge.binary", table, SMALL, allow_invalid=False)
    b = merl._read_merl(path, shape=SMALL)
    assert b.table[1, 1, 1, 2] == np.float32(0.9e30)


def test_fuzz_header_doubles_and_truncation(tmp_path):
    """300 seeded mutations: header dimensions (larger than the body, negative, swapped),
    truncation, random bytes, and whole doubles replaced by extreme, non-finite or
    subnormal values. Every failure is InvalidBRDFData naming the file; what loads holds
    finite samples within ±1e30 and evaluates finitely."""
    good = tmp_path / "good.binary"
    _small_file(good, seed=7)
    data = good.read_bytes()
    doubles = (len(data) - 12) // 8
    specials = [np.float64(v).tobytes() for v in (1e308, -1e308, 1e31, 5e-324, np.nan,
                                                    -np.inf, -1.0, 0.0)]
    rng = np.random.default_rng(77)
    wi, wo = _random_pairs(10, seed=5)
    path = tmp_path / "fuzz.binary"
    outcomes = {"ok": 0, "invalid": 0}
    for case in range(300):
        raw = bytearray(data)
        kind = case % 4
        if kind == 0:
            raw = raw[: int(rng.integers(0, len(raw) + 1))]
        elif kind == 1:
            dims = [int(d) for d in SMALL]
            dims[int(rng.integers(0, 3))] = int(rng.integers(-(2**31), 2**31))
            raw[:12] = np.asarray(dims if rng.random() < 0.8 else dims[::-1], "<i4").tobytes()
        elif kind == 2:
            for _ in range(int(rng.integers(1, 8))):
                raw[int(rng.integers(0, len(raw)))] = int(rng.integers(0, 256))
        else:
            for _ in range(int(rng.integers(1, 4))):
                at = 12 + 8 * int(rng.integers(0, doubles))
                raw[at : at + 8] = specials[int(rng.integers(0, len(specials)))]
        path.write_bytes(bytes(raw))
        try:
            b = merl._read_merl(path, shape=SMALL, on_invalid="clamp" if case % 2 else "raise")
        except InvalidBRDFData as exc:
            assert str(path) in str(exc), exc
            outcomes["invalid"] += 1
            continue
        assert np.isfinite(b.table).all() and np.abs(b.table).max() <= 1e30
        assert np.isfinite(b(wi, wo, WL)).all()
        outcomes["ok"] += 1
    print("fuzz outcomes:", outcomes)
    assert outcomes["ok"] > 30 and outcomes["invalid"] > 150, outcomes
