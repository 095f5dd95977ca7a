"""RGL ``.bsdf`` tensor files: container, evaluation as the reference loader, damage, fuzzing."""

from __future__ import annotations

import math
import struct
import time
import tracemalloc

import numpy as np
import pytest

from spectral_materials.core.colour.uplift import SmitsUplift
from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats import rgl_bsdf

F32 = np.float32
WL_FILE = (400.0, 500.0, 600.0, 700.0)


def _fields(*, npi=5, nti=4, n=6, nv=(7, 8), nn=(9, 10), wl=WL_FILE, rgb=False, jac=1,
            seed=0, span=None):
    """A random but well-formed material (anisotropic when npi > 2)."""
    rng = np.random.default_rng(seed)
    theta = np.linspace(0.0, math.radians(85.0), nti).astype(F32)
    if npi <= 2:
        phi = np.arange(npi, dtype=F32)
    else:
        phi = np.linspace(-math.pi, -math.pi + (span or 2 * math.pi), npi).astype(F32)
    fields = {
        "description": np.frombuffer(b"synthetic test material", np.uint8),
        "jacobian": np.array([jac], np.uint8),
        "theta_i": theta,
        "phi_i": phi,
        "ndf": rng.uniform(0.5, 2.0, nn).astype(F32),
        "sigma": rng.uniform(0.5, 2.0, nn).astype(F32),
        "vndf": rng.uniform(0.2, 2.0, (npi, nti) + tuple(nv)).astype(F32),
        "luminance": rng.uniform(0.2, 2.0, (npi, nti, n, n)).astype(F32),
    }
    values = rng.uniform(0.0, 1.0, (npi, nti, 3 if rgb else len(wl), n, n)).astype(F32)
    if rgb:
        fields["rgb"] = values
    else:
        fields["wavelengths"] = np.asarray(wl, F32)
        fields["spectra"] = values
    return fields


def _write(tmp_path, name="m.bsdf", **kw):
    fields = kw.pop("fields", None) or _fields(**kw)
    return rgl_bsdf.write_tensor_file(tmp_path / name, fields), fields


def _hemi(rng, k, zmin=0.05):
    v = rng.normal(size=(k, 3))
    v[:, 2] = np.abs(v[:, 2]) + zmin
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _rotate_z(v, angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=-1)


def _uniform_fields(spectrum=(0.2, 0.4, 0.6, 0.8), ndf=1.7, sigma=0.9, ramp=False, jac=1):
    """Uniform vndf (identity warp), constant ndf/σ, spectra constant (or ramp in x)."""
    n = 5
    s = np.asarray(spectrum, F32)[None, None, :, None, None]
    if ramp:  # value = s(λ) · x on the unit square (x the last axis)
        x = np.linspace(0.0, 1.0, n, dtype=F32)[None, None, None, None, :]
        values = np.broadcast_to(s * x, (1, 3, 4, n, n))
    else:
        values = np.broadcast_to(s, (1, 3, 4, n, n))
    return {
        "description": np.frombuffer(b"uniform", np.uint8),
        "jacobian": np.array([jac], np.uint8),
        "theta_i": np.array([0.0, 0.5, 1.2], F32),
        "phi_i": np.array([0.0], F32),
        "ndf": np.full((4, 6), ndf, F32),
        "sigma": np.full((3, 7), sigma, F32),
        "vndf": np.ones((1, 3, 6, 4), F32),
        "luminance": np.ones((1, 3, n, n), F32),
        "wavelengths": np.asarray(WL_FILE, F32),
        "spectra": np.ascontiguousarray(values, dtype=F32),
    }


# --------------------------------------------------------------------------- container


def test_tensor_roundtrip_all_dtypes(tmp_path):
    fields = {f"f{code}": (np.arange(6).reshape(2, 3) * 3).astype(dt)
              for code, dt in rgl_bsdf.DTYPE_CODES.items()}
    fields["scalar"] = np.array(7.5, np.float64)
    fields["empty"] = np.zeros((0, 4), np.float32)
    path = rgl_bsdf.write_tensor_file(tmp_path / "t.bsdf", fields)
    back = rgl_bsdf.read_tensor_file(path)
    assert set(back) == set(fields)
    for k, v in fields.items():
        assert back[k].dtype == v.dtype.newbyteorder("=") and back[k].shape == v.shape
        np.testing.assert_array_equal(back[k], v)
    raw = path.read_bytes()
    assert raw[:12] == b"tensor_file\x00" and raw[12:14] == b"\x01\x00"
    assert struct.unpack_from("<I", raw, 14)[0] == len(fields)


def test_reads_header_fields_and_flags(tmp_path):
    path, fields = _write(tmp_path)
    b = rgl_bsdf.read_rgl_bsdf(path)
    assert not b.isotropic and b.reduction == 1 and b.jacobian and not b.is_rgb
    assert b.description == "synthetic test material"
    np.testing.assert_array_equal(b.wavelengths, WL_FILE)
    assert b.defects == {"nan": 0, "inf": 0, "negative": 0, "fields": {}}
    d = b.describe()
    assert d["kind"] == "spectral" and d["phi_i"] == 5 and d["resolution"] == [6, 6]
    # ≤ 2 phi_i entries is isotropic, as the reference (powitacq.inl: phi_i.shape[0] <= 2)
    assert rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "i1.bsdf", npi=1)[0]).isotropic
    assert rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "i2.bsdf", npi=2)[0]).isotropic
    assert not rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "a3.bsdf", npi=3)[0]).isotropic
    half = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "r2.bsdf", npi=5, span=math.pi)[0])
    quarter = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "r4.bsdf", npi=5, span=math.pi / 2)[0])
    assert (half.reduction, quarter.reduction) == (2, 4)


# --------------------------------------------------------------------------- evaluation


def test_uniform_warp_closed_form(tmp_path):
    """Uniform vndf → identity warp: fr = s(λ)·ndf/(4σ); a ramp in x gives s(λ)·√(2θm/π)·…"""
    rng = np.random.default_rng(1)
    wi, wo = _hemi(rng, 300), _hemi(rng, 300)
    s = np.array([0.2, 0.4, 0.6, 0.8])
    wl = np.asarray(WL_FILE)
    path = rgl_bsdf.write_tensor_file(tmp_path / "u.bsdf", _uniform_fields())
    b = rgl_bsdf.read_rgl_bsdf(path)
    expected = s * 1.7 / (4 * 0.9)
    np.testing.assert_allclose(b(wi, wo, wl), np.broadcast_to(expected, (300, 4)), rtol=1e-6)

    path = rgl_bsdf.write_tensor_file(tmp_path / "r.bsdf", _uniform_fields(ramp=True))
    b = rgl_bsdf.read_rgl_bsdf(path)
    wm = (wi + wo) / np.linalg.norm(wi + wo, axis=1, keepdims=True)
    u_theta = np.sqrt(np.arccos(np.clip(wm[:, 2], -1, 1)) * 2 / math.pi)
    np.testing.assert_allclose(b(wi, wo, wl), u_theta[:, None] * expected, rtol=1e-5,
                               atol=1e-7)

    # jacobian flag cleared: the spectra alone (as Mitsuba's measured plugin)
    path = rgl_bsdf.write_tensor_file(tmp_path / "j.bsdf", _uniform_fields(jac=0))
    b = rgl_bsdf.read_rgl_bsdf(path)
    assert not b.jacobian
    np.testing.assert_allclose(b(wi, wo, wl), np.broadcast_to(s, (300, 4)), rtol=1e-6)


def test_no_reciprocity_imposed(tmp_path):
    """The format is not symmetric in wi/wo (σ depends on wi only; the warp on wi): the
    reader evaluates it as stored and does not symmetrise it."""
    rng = np.random.default_rng(9)
    wi, wo = _hemi(rng, 100), _hemi(rng, 100)
    wl = np.asarray(WL_FILE)
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path)[0])
    assert not np.allclose(b(wi, wo, wl), b(wo, wi, wl), rtol=1e-3)
    # with a uniform warp and constant tables it is reciprocal (depends on wm only)
    u = rgl_bsdf.read_rgl_bsdf(
        rgl_bsdf.write_tensor_file(tmp_path / "u.bsdf", _uniform_fields(ramp=True)))
    np.testing.assert_allclose(u(wi, wo, wl), u(wo, wi, wl), rtol=1e-9)


def test_below_horizon_is_zero(tmp_path):
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path)[0])
    rng = np.random.default_rng(2)
    up, up2 = _hemi(rng, 50), _hemi(rng, 50)
    down = up * np.array([1, 1, -1])
    flat = up.copy()
    flat[:, 2] = 0.0
    wl = np.asarray(WL_FILE)
    for wi, wo in ((up, down), (down, up), (down, down), (flat, up2), (up2, flat)):
        assert np.all(b(wi, wo, wl) == 0.0)
        assert np.all(b.eval_native(wi, wo) == 0.0)
    assert np.all(b(up, up2, wl) > 0)


def test_isotropic_rotation_invariance(tmp_path):
    """φm − φi makes an isotropic file rotation-invariant when σ does not vary with φ."""
    fields = _fields(npi=1, seed=3)
    fields["sigma"] = np.repeat(fields["sigma"][:1], fields["sigma"].shape[0], axis=0)
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, fields=fields)[0])
    rng = np.random.default_rng(4)
    wi, wo = _hemi(rng, 200), _hemi(rng, 200)
    wl = np.linspace(400, 700, 7)
    f0 = b(wi, wo, wl)
    for angle in (0.3, 1.9, -2.5):
        np.testing.assert_allclose(b(_rotate_z(wi, angle), _rotate_z(wo, angle), wl), f0,
                                   rtol=1e-9, atol=1e-12)
    # an anisotropic file is not
    a = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "a.bsdf", npi=5, seed=3)[0])
    g0 = a(wi, wo, wl)
    assert not np.allclose(a(_rotate_z(wi, 1.0), _rotate_z(wo, 1.0), wl), g0, rtol=1e-3)


def test_wavelength_resampling(tmp_path):
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path)[0])
    rng = np.random.default_rng(5)
    wi, wo = _hemi(rng, 100), _hemi(rng, 100)
    native = b.eval_native(wi, wo)
    np.testing.assert_allclose(b(wi, wo, np.asarray(WL_FILE)), native, rtol=1e-12)
    mid = b(wi, wo, np.array([450.0, 525.0, 690.0]))
    np.testing.assert_allclose(mid[:, 0], 0.5 * (native[:, 0] + native[:, 1]), rtol=1e-12)
    np.testing.assert_allclose(mid[:, 1], 0.75 * native[:, 1] + 0.25 * native[:, 2],
                               rtol=1e-12)
    np.testing.assert_allclose(mid[:, 2], 0.1 * native[:, 2] + 0.9 * native[:, 3], rtol=1e-12)
    outside = b(wi, wo, np.array([380.0, 399.0, 701.0, 780.0]))
    assert np.all(outside == 0.0)  # zero outside the measured range (documented)


def test_rgb_file_and_smits_uplift(tmp_path):
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, rgb=True)[0])
    assert b.is_rgb and b.describe()["kind"] == "rgb"
    rng = np.random.default_rng(6)
    wi, wo = _hemi(rng, 64), _hemi(rng, 64)
    rgb = b.rgb(wi, wo)
    assert rgb.shape == (64, 3) and np.all(rgb > 0)
    wl = np.arange(380.0, 781.0, 10.0)
    np.testing.assert_allclose(b(wi, wo, wl), SmitsUplift()(rgb, wl), rtol=1e-12)
    spectral = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "s.bsdf")[0])
    with pytest.raises(TypeError):
        spectral.rgb(wi, wo)


def test_factor_brdf_accepts_it(tmp_path):
    from spectral_materials.core.brdf.factor import factor_brdf

    fields = _fields(npi=1, seed=7)
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, fields=fields)[0])
    fac = factor_brdf(b, parameterization="hd", isotropic=True, resolution=(8, 8, 16), packs=1,
                      spectral_basis=4)
    assert fac is not None


# --------------------------------------------------------------------------- Mitsuba 3


def _mitsuba_eval(mi, path, wi, wo, wavelengths=None):
    bsdf = mi.load_dict({"type": "measured", "filename": str(path)})
    ctx = mi.BSDFContext()
    si = mi.SurfaceInteraction3f()
    if wavelengths is not None:
        si.wavelengths = mi.Spectrum([float(w) for w in wavelengths])
    out = []
    for a, c in zip(wi, wo):
        si.wi = mi.Vector3f(*map(float, a))
        out.append(np.array(bsdf.eval(ctx, si, mi.Vector3f(*map(float, c)))))
    return np.array(out, dtype=np.float64)


MITSUBA_CASES = {
    "aniso": dict(npi=5, seed=11),
    "aniso_reduction2": dict(npi=5, span=math.pi, seed=12),
    "aniso_reduction4": dict(npi=4, span=math.pi / 2, seed=13),
    "iso_1": dict(npi=1, seed=14),
    "iso_2": dict(npi=2, seed=15),
    "no_jacobian": dict(npi=5, jac=0, seed=16),
}


@pytest.mark.parametrize("case", sorted(MITSUBA_CASES))
def test_matches_mitsuba_measured_spectral(tmp_path, case):
    """Mitsuba 3's ``measured`` plugin (scalar_spectral) on the same file.

    Its eval returns the BRDF without a cosine factor, interpolating the file's spectra
    linearly at ``si.wavelengths``; we pick wavelengths inside the file's range.
    """
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_spectral")
    path, _ = _write(tmp_path, **MITSUBA_CASES[case])
    rng = np.random.default_rng(21)
    wi, wo = _hemi(rng, 150, zmin=0.02), _hemi(rng, 150, zmin=0.02)
    if MITSUBA_CASES[case]["npi"] <= 2:
        # Mitsuba leaves m_reduction uninitialised for isotropic files and may fold wi/wo
        # by it; with wi.x < 0 and wi.y < 0 every folding is the identity.
        wi[:, :2] = -np.abs(wi[:, :2])
    wl = np.array([412.0, 455.5, 587.0, 699.0])
    ref = _mitsuba_eval(mi, path, wi, wo, wl)
    mine = rgl_bsdf.read_rgl_bsdf(path)(wi, wo, wl)
    rel = np.abs(mine - ref) / np.maximum(np.abs(ref), 1e-4)
    assert rel.max() < 1e-4, (case, rel.max())


def test_matches_mitsuba_measured_rgb(tmp_path):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    path, _ = _write(tmp_path, rgb=True, npi=5, seed=17)
    rng = np.random.default_rng(22)
    wi, wo = _hemi(rng, 150, zmin=0.02), _hemi(rng, 150, zmin=0.02)
    ref = _mitsuba_eval(mi, path, wi, wo)
    mine = rgl_bsdf.read_rgl_bsdf(path).rgb(wi, wo)
    rel = np.abs(mine - ref) / np.maximum(np.abs(ref), 1e-4)
    assert rel.max() < 1e-4, rel.max()


# --------------------------------------------------------------------------- bad input


def _field_entry_pos(raw: bytes, name: str) -> int:
    """Byte position of the ndim field of ``name``'s table entry."""
    key = struct.pack("<H", len(name)) + name.encode()
    return raw.index(key, 18) + len(key)


def _expect_invalid(path, match, **kw):
    with pytest.raises(InvalidBRDFData, match=match) as info:
        rgl_bsdf.read_rgl_bsdf(path, **kw)
    assert str(path) in str(info.value)
    return info.value


def test_wrong_magic_version_truncated(tmp_path):
    path, _ = _write(tmp_path)
    raw = path.read_bytes()
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(b"tensor_fila\x00" + raw[12:])
    _expect_invalid(bad, "magic")
    bad.write_bytes(raw[:12] + b"\x02\x00" + raw[14:])
    _expect_invalid(bad, "version 2.0")
    bad.write_bytes(raw[:10])
    _expect_invalid(bad, "too short")
    bad.write_bytes(raw[:60])
    _expect_invalid(bad, "truncated")
    bad.write_bytes(raw[: len(raw) // 2])
    _expect_invalid(bad, "past the end")
    bad.write_bytes(b"")
    _expect_invalid(bad, "too short")


def test_field_offset_past_end_and_unknown_dtype(tmp_path):
    path, _ = _write(tmp_path)
    raw = bytearray(path.read_bytes())
    pos = _field_entry_pos(bytes(raw), "ndf")
    bad = tmp_path / "bad.bsdf"
    patched = raw.copy()
    patched[pos + 3 : pos + 11] = struct.pack("<Q", len(raw) + 10)
    bad.write_bytes(bytes(patched))
    _expect_invalid(bad, "'ndf'.*past the end")
    patched = raw.copy()
    patched[pos + 2] = 12
    bad.write_bytes(bytes(patched))
    _expect_invalid(bad, "unknown dtype code 12")


def test_huge_declared_shape_refused_without_allocation(tmp_path):
    path, _ = _write(tmp_path)
    raw = bytearray(path.read_bytes())
    pos = _field_entry_pos(bytes(raw), "spectra")
    assert struct.unpack_from("<H", raw, pos)[0] == 5
    raw[pos + 11 : pos + 19] = struct.pack("<Q", 1 << 40)  # φi = 2⁴⁰: 2²⁴ TB
    bad = tmp_path / "huge.bsdf"
    bad.write_bytes(bytes(raw))
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        _expect_invalid(bad, "'spectra'.*(past the end|larger than)")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1 << 20 and time.perf_counter() - t0 < 1.0
    # a valid file above the memory limit is refused before reading
    _expect_invalid(path, "max_bytes", max_bytes=1000)


@pytest.mark.parametrize("missing", ["ndf", "sigma", "vndf", "luminance", "spectra",
                                     "theta_i", "phi_i", "jacobian", "description"])
def test_missing_required_field(tmp_path, missing):
    fields = _fields()
    del fields[missing]
    path, _ = _write(tmp_path, fields=fields)
    _expect_invalid(path, f"required field '{missing}' is missing")


def test_missing_fields_rgb_and_wavelengths(tmp_path):
    fields = _fields(rgb=True)
    del fields["rgb"]
    _expect_invalid(_write(tmp_path, "a.bsdf", fields=fields)[0], "'wavelengths' is missing")
    fields = _fields()
    del fields["wavelengths"]
    _expect_invalid(_write(tmp_path, "b.bsdf", fields=fields)[0], "'wavelengths' is missing")


def test_wrong_dtype_and_shapes(tmp_path):
    fields = _fields()
    fields["sigma"] = fields["sigma"].astype(np.float64)
    _expect_invalid(_write(tmp_path, "a.bsdf", fields=fields)[0], "'sigma' has dtype float64")
    fields = _fields()
    fields["spectra"] = fields["spectra"][:, :, :3]
    _expect_invalid(_write(tmp_path, "b.bsdf", fields=fields)[0], "channels")
    fields = _fields()
    fields["vndf"] = fields["vndf"][:, :2]
    _expect_invalid(_write(tmp_path, "c.bsdf", fields=fields)[0], "'vndf'.*phi_i, theta_i")
    fields = _fields()
    fields["jacobian"] = np.array([1, 1], np.uint8)
    _expect_invalid(_write(tmp_path, "d.bsdf", fields=fields)[0], "'jacobian'")
    fields = _fields()
    fields["ndf"] = fields["ndf"][:1]
    _expect_invalid(_write(tmp_path, "e.bsdf", fields=fields)[0], "2 × 2")
    fields = _fields(npi=5)
    fields["phi_i"] = np.linspace(-1.0, 0.0, 5).astype(F32)  # reduction rint(2π) = 6
    _expect_invalid(_write(tmp_path, "f.bsdf", fields=fields)[0], "reduction 6")


def test_non_monotonic_axes(tmp_path):
    fields = _fields()
    fields["wavelengths"] = np.array([400, 600, 500, 700], F32)
    _expect_invalid(_write(tmp_path, "a.bsdf", fields=fields)[0],
                    "wavelengths is not strictly increasing")
    fields = _fields()
    fields["theta_i"] = fields["theta_i"][::-1].copy()
    _expect_invalid(_write(tmp_path, "b.bsdf", fields=fields)[0], "theta_i is not strictly")


def test_nan_samples_raise_or_clamp(tmp_path):
    fields = _fields()
    fields["spectra"][0, 0, 1, 2, 3] = np.nan
    fields["spectra"][1, 2, 0, 0, 0] = np.inf
    fields["spectra"][2, 1, 0, 0, 0] = -0.5
    fields["vndf"][0, 0, 0, 0] = -1.0
    path, _ = _write(tmp_path, fields=fields)
    _expect_invalid(path, "'spectra' holds 1 NaN and 1 inf")
    b = rgl_bsdf.read_rgl_bsdf(path, on_invalid="clamp")
    assert b.defects["nan"] == 1 and b.defects["inf"] == 1 and b.defects["negative"] == 2
    assert b.defects["fields"]["spectra"] == {"nan": 1, "inf": 1, "negative": 1}
    assert b.defects["fields"]["vndf"]["negative"] == 1
    rng = np.random.default_rng(8)
    f = b(_hemi(rng, 200), _hemi(rng, 200), np.asarray(WL_FILE))
    assert np.isfinite(f).all() and (f >= 0).all()
    with pytest.raises(ValueError):
        rgl_bsdf.read_rgl_bsdf(path, on_invalid="ignore")


def test_all_zero_spectra_and_degenerate_vndf(tmp_path):
    fields = _fields()
    fields["spectra"][:] = 0.0
    _expect_invalid(_write(tmp_path, "a.bsdf", fields=fields)[0], "all zero")
    fields = _fields()
    fields["vndf"][1, 2] = 0.0
    _expect_invalid(_write(tmp_path, "b.bsdf", fields=fields)[0], r"vndf slice \(phi_i\[1\]")


def test_missing_file_is_oserror(tmp_path):
    with pytest.raises(FileNotFoundError):
        rgl_bsdf.read_rgl_bsdf(tmp_path / "nope.bsdf")
    with pytest.raises(IsADirectoryError):
        rgl_bsdf.read_rgl_bsdf(tmp_path)


def test_fuzz_mutations_and_truncations(tmp_path):
    """200 damaged copies: each must load (and evaluate finitely) or raise InvalidBRDFData."""
    path, _ = _write(tmp_path, npi=3, nti=2, n=3, nv=(3, 4), nn=(3, 3), seed=9)
    raw = path.read_bytes()
    table_end = _field_entry_pos(raw, "spectra") + 2 + 1 + 8 + 5 * 8
    rng = np.random.default_rng(1234)
    wi, wo = _hemi(rng, 16), _hemi(rng, 16)
    outcomes = {"ok": 0, "invalid": 0}
    bad = tmp_path / "fuzz.bsdf"
    for case in range(200):
        data = bytearray(raw)
        kind = case % 4
        if kind == 0:  # truncation
            data = data[: int(rng.integers(0, len(raw)))]
        else:  # 1–8 random bytes, in the table for half of the cases
            hi = table_end if kind in (1, 2) else len(raw)
            for _ in range(int(rng.integers(1, 9))):
                pos = int(rng.integers(0, hi))
                data[pos] = int(rng.integers(0, 256)) if kind != 2 else data[pos] ^ 0xFF
        bad.write_bytes(bytes(data))
        try:
            b = rgl_bsdf.read_rgl_bsdf(bad, on_invalid="clamp" if case % 2 else "raise")
        except InvalidBRDFData as exc:
            assert str(bad) in str(exc)
            outcomes["invalid"] += 1
            continue
        f = b(wi, wo, np.asarray(WL_FILE))
        assert f.shape == (16, 4) and np.isfinite(f).all()
        outcomes["ok"] += 1
    assert sum(outcomes.values()) == 200
    assert outcomes["invalid"] > 50
    print("fuzz outcomes:", outcomes)


# --------------------------------------------------------------------------- layout and limits


def _patch(raw: bytes, name: str, *, offset: int | None = None) -> bytes:
    """``raw`` with field ``name``'s data offset replaced."""
    data = bytearray(raw)
    pos = _field_entry_pos(raw, name)
    if offset is not None:
        data[pos + 3 : pos + 11] = struct.pack("<Q", offset)
    return bytes(data)


def _offset_of(raw: bytes, name: str) -> int:
    return struct.unpack_from("<Q", raw, _field_entry_pos(raw, name) + 3)[0]


def test_overlapping_fields_refused(tmp_path):
    """Fields sharing bytes (or lying in the table) would let a small file declare many
    times its size: the layout is checked before any data are read."""
    path, _ = _write(tmp_path)
    raw = path.read_bytes()
    bad = tmp_path / "bad.bsdf"
    bad.write_bytes(_patch(raw, "sigma", offset=_offset_of(raw, "ndf")))
    _expect_invalid(bad, "'(ndf|sigma)'.*overlaps field '(ndf|sigma)'")
    bad.write_bytes(_patch(raw, "ndf", offset=_offset_of(raw, "ndf") + 4))  # into sigma
    _expect_invalid(bad, "overlaps")
    bad.write_bytes(_patch(raw, "jacobian", offset=8))
    _expect_invalid(bad, "'jacobian'.*overlaps the field table")
    with pytest.raises(InvalidBRDFData, match="overlaps"):
        rgl_bsdf.read_tensor_file(bad)


def test_empty_fields_may_point_anywhere(tmp_path):
    """An empty field reads nothing; Mitsuba's writer can align it past the end."""
    fields = _fields()
    fields["notes"] = np.zeros((0,), np.float32)
    path, _ = _write(tmp_path, fields=fields)
    raw = path.read_bytes()
    path.write_bytes(_patch(raw, "notes", offset=len(raw) + 8))
    back = rgl_bsdf.read_tensor_file(path)
    assert back["notes"].shape == (0,)
    assert rgl_bsdf.read_rgl_bsdf(path).describe()["kind"] == "spectral"


def test_too_many_fields_refused(tmp_path):
    path, _ = _write(tmp_path)
    raw = bytearray(path.read_bytes())
    raw[14:18] = struct.pack("<I", rgl_bsdf.MAX_FIELDS + 1)
    raw += b"\0" * (13 * (rgl_bsdf.MAX_FIELDS + 1))  # enough bytes for the table check
    bad = tmp_path / "many.bsdf"
    bad.write_bytes(bytes(raw))
    _expect_invalid(bad, f"{rgl_bsdf.MAX_FIELDS + 1:,} fields declared; at most")


def test_long_description_refused(tmp_path):
    fields = _fields()
    fields["description"] = np.full(rgl_bsdf.MAX_DESCRIPTION_BYTES + 1, ord("a"), np.uint8)
    _expect_invalid(_write(tmp_path, fields=fields)[0], "'description' holds 1,048,577 bytes")
    fields["description"] = np.full(rgl_bsdf.MAX_DESCRIPTION_BYTES, 0xFF, np.uint8)
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "ok.bsdf", fields=fields)[0])
    assert b.description == "\ufffd" * rgl_bsdf.MAX_DESCRIPTION_BYTES


@pytest.mark.parametrize("name", ["spectra", "luminance", "vndf", "ndf", "sigma"])
@pytest.mark.parametrize("value", [3e38, -3e38, 1.5e30])
@pytest.mark.parametrize("on_invalid", ["raise", "clamp"])
def test_extreme_samples_refused(tmp_path, name, value, on_invalid):
    """Finite values no measurement gives (beyond ±1e30, sample_limits) are refused at the
    reader, naming the file and the field, whatever on_invalid says."""
    fields = _fields()
    fields[name].flat[3] = value
    path, _ = _write(tmp_path, fields=fields)
    err = _expect_invalid(path, f"field '{name}' holds 1 values beyond ±1e\\+30",
                          on_invalid=on_invalid)
    assert f"{np.float32(value):g}" in str(err)


def test_extreme_rgb_refused_and_limit_itself_accepted(tmp_path):
    fields = _fields(rgb=True)
    fields["rgb"].flat[0] = 2e30
    _expect_invalid(_write(tmp_path, "a.bsdf", fields=fields)[0], "'rgb' holds 1 values")
    fields = _fields()
    fields["spectra"].flat[0] = 1e29
    b = rgl_bsdf.read_rgl_bsdf(_write(tmp_path, "b.bsdf", fields=fields)[0])
    assert b.values.flat[0] == np.float32(1e29)


def test_float64_samples_of_1e308_refused(tmp_path):
    """The format's tables are float32: a float64 table (the only way to hold 1e308) is
    refused by its dtype before its values are looked at."""
    fields = _fields()
    fields["spectra"] = fields["spectra"].astype(np.float64)
    fields["spectra"].flat[0] = 1e308
    _expect_invalid(_write(tmp_path, fields=fields)[0], "'spectra' has dtype float64")


@pytest.mark.parametrize("wl, match", [
    ((5.0, 500.0, 600.0, 700.0), "wavelengths runs from 5 to 700 nm, outside 10..100000 nm"),
    ((400.0, 500.0, 600.0, 2e5), "outside 10..100000 nm"),
    ((-400.0, 500.0, 600.0, 700.0), "outside 10..100000 nm"),
    ((0.0, 500.0, 600.0, 700.0), "outside"),
    ((400.0, 500.0, 600.0, 3e38), "outside"),
    ((400.0, np.nan, 600.0, 700.0), "wavelengths holds NaN/inf"),
    ((400.0, 500.0, 600.0, np.inf), "wavelengths holds NaN/inf"),
])
def test_implausible_wavelengths_refused(tmp_path, wl, match):
    fields = _fields()
    fields["wavelengths"] = np.asarray(wl, F32)
    _expect_invalid(_write(tmp_path, fields=fields)[0], match)


@pytest.mark.parametrize("axis, values, match", [
    ("theta_i", (-0.1, 0.2, 0.4, 0.6), "theta_i runs from -0.1"),
    ("theta_i", (0.0, 0.5, 1.0, 1.6), "outside -0.0001..1.5709"),
    ("theta_i", (0.0, 0.5, 1.0, 3e38), "theta_i runs"),
    ("phi_i", (-7.0, -3.0, -1.0, 0.0, 1.0), "phi_i runs from -7"),
    ("phi_i", (0.0, 1.0, 2.0, 3.0, np.inf), "phi_i holds NaN/inf"),
])
def test_implausible_angles_refused(tmp_path, axis, values, match):
    fields = _fields()
    fields[axis] = np.asarray(values, F32)
    _expect_invalid(_write(tmp_path, fields=fields)[0], match)


def test_warp_matches_float64_marginal2d(tmp_path):
    """The float32 cumulative table (marginal in the conditional's free column, the
    normalisation on the corner weights) inverts as Marginal2D built in float64."""
    rng = np.random.default_rng(31)
    vndf = rng.uniform(0.05, 3.0, (3, 2, 7, 9))
    warp = rgl_bsdf._Warp.build(vndf)
    # Marginal2D<2>::build_cdf in float64, normalised (the previous implementation)
    cond = np.zeros_like(vndf)
    cond[..., 1:] = np.cumsum(0.5 * (vndf[..., 1:] + vndf[..., :-1]), axis=-1)
    rows = cond[..., -1]
    marg = np.zeros(vndf.shape[:-1])
    marg[..., 1:] = np.cumsum(0.5 * (rows[..., 1:] + rows[..., :-1]), axis=-1)
    np.testing.assert_allclose(warp.totals, marg[..., -1], rtol=1e-6)
    np.testing.assert_allclose(warp.cumulative[..., 1:], cond[..., 1:], rtol=1e-6)
    np.testing.assert_allclose(warp.cumulative[..., 0], marg, rtol=1e-6, atol=1e-12)
    u = rng.uniform(0, 1, (500, 2))
    a = rng.integers(0, 3, 500)
    b = rng.integers(0, 2, 500)
    corners = [(a, b, np.ones(500))]
    norm = 1.0 / marg[..., -1]
    ny, nx = vndf.shape[2:]
    ix, fx = rgl_bsdf._cell(u[:, 0], nx)
    iy, fy = rgl_bsdf._cell(u[:, 1], ny)
    d = vndf[a, b] * norm[a, b][:, None, None]
    c = cond[a, b] * norm[a, b][:, None, None]
    m = marg[a, b] * norm[a, b][:, None]
    k = np.arange(500)
    c0 = (1 - fy) * d[k, iy, ix] + fy * d[k, iy + 1, ix]
    c1 = (1 - fy) * d[k, iy, ix + 1] + fy * d[k, iy + 1, ix + 1]
    x = fx * (c0 + 0.5 * fx * (c1 - c0)) + (1 - fy) * c[k, iy, ix] + fy * c[k, iy + 1, ix]
    r0, r1 = c[k, iy, nx - 1], c[k, iy + 1, nx - 1]
    x /= (1 - fy) * r0 + fy * r1
    y = fy * (r0 + 0.5 * fy * (r1 - r0)) + m[k, iy]
    np.testing.assert_allclose(warp.invert(u, corners), np.stack([x, y], -1), atol=2e-6)


@pytest.mark.parametrize("shape, block", [((5, 7), 1), ((5, 7), 3), ((4, 9), 4), ((3, 1), 2),
                                          ((6, 50), 10_000)])
def test_cumulative_trapezoid_blocks(shape, block):
    """Blocked sums (rows and columns split, running sums carried) equal one cumsum."""
    src = np.random.default_rng(2).uniform(0, 2, shape)
    out = np.empty(shape)
    rgl_bsdf._cumulative_trapezoid(src, out, block)
    steps = np.cumsum(0.5 * (src[:, 1:] + src[:, :-1]), axis=1)
    np.testing.assert_allclose(out, np.concatenate([np.zeros((shape[0], 1)), steps], 1),
                               rtol=1e-14, atol=1e-14)


def _table_slots(raw: bytes, names) -> list[tuple[int, int]]:
    """(position, ndim) of each field's ndim in the table."""
    out = []
    for name in names:
        pos = _field_entry_pos(raw, name)
        out.append((pos, struct.unpack_from("<H", raw, pos)[0]))
    return out


def test_fuzz_table_and_values(tmp_path):
    """400 seeded mutations aimed at what the reader must bound: offsets (overlap, past
    the end), shapes, the field count, truncation, and extreme or non-finite float32
    samples. Every failure is InvalidBRDFData naming the file; nothing else escapes, and
    what loads evaluates finitely."""
    fields = _fields(npi=3, nti=2, n=3, nv=(3, 4), nn=(3, 3), seed=21)
    path, _ = _write(tmp_path, fields=fields)
    raw = path.read_bytes()
    slots = _table_slots(raw, fields)
    data_start = min(_offset_of(raw, name) for name in fields)
    rng = np.random.default_rng(4321)
    wi, wo = _hemi(rng, 8), _hemi(rng, 8)
    specials = [np.float32(v).tobytes() for v in (3e38, -3e38, 2e30, np.nan, np.inf, -1.0)]
    bad = tmp_path / "fuzz.bsdf"
    outcomes = {"ok": 0, "invalid": 0}
    for case in range(400):
        data = bytearray(raw)
        kind = case % 5
        if kind == 0:  # truncation
            data = data[: int(rng.integers(0, len(raw)))]
        elif kind == 1:  # an offset moved: onto another field, into the table, past the end
            pos, _ = slots[int(rng.integers(0, len(slots)))]
            target = int(rng.choice([_offset_of(raw, str(rng.choice(list(fields)))),
                                     int(rng.integers(0, len(raw) + 64))]))
            data[pos + 3 : pos + 11] = struct.pack("<Q", target)
        elif kind == 2:  # a dimension rewritten
            pos, ndim = slots[int(rng.integers(0, len(slots)))]
            if ndim:
                at = pos + 11 + 8 * int(rng.integers(0, ndim))
                dims = [0, 1, 2, 7, len(raw), 1 << 33, (1 << 64) - 1]
                dim = dims[int(rng.integers(0, len(dims)))]
                data[at : at + 8] = struct.pack("<Q", dim)
        elif kind == 3:  # extreme or non-finite samples in the data
            for _ in range(int(rng.integers(1, 4))):
                at = data_start + 4 * int(rng.integers(0, (len(raw) - data_start) // 4))
                data[at : at + 4] = specials[int(rng.integers(0, len(specials)))]
        else:  # the field count, or random bytes anywhere
            if rng.random() < 0.3:
                data[14:18] = struct.pack("<I", int(rng.integers(0, 1 << 32)))
            for _ in range(int(rng.integers(1, 6))):
                data[int(rng.integers(0, len(data)))] = int(rng.integers(0, 256))
        bad.write_bytes(bytes(data))
        try:
            b = rgl_bsdf.read_rgl_bsdf(bad, on_invalid="clamp" if case % 2 else "raise")
        except InvalidBRDFData as exc:
            assert str(bad) in str(exc), exc
            outcomes["invalid"] += 1
            continue
        for table in (b.values, b.ndf, b.sigma, b.vndf, b.luminance):
            assert np.abs(table).max() <= 1e30
        assert np.isfinite(b(wi, wo, np.asarray(WL_FILE))).all()
        outcomes["ok"] += 1
    print("fuzz outcomes:", outcomes)
    assert outcomes["invalid"] > 150 and outcomes["ok"] > 20, outcomes
