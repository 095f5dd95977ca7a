"""Tests for the tabulated spectral BRDF file format (formats/tabulated.py)."""

from __future__ import annotations

import io
import json
import time
import tracemalloc
import zipfile

import numpy as np
import pytest
from bombs_archives import BOMBS

from spectral_materials.core import factor_brdf
from spectral_materials.core.brdf import metrics, models
from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.brdf.params import get_parameterization
from spectral_materials.core.colour import spectra
from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats.tabulated import (
    FORMAT,
    MAX_ENTRIES,
    TabulatedBRDF,
    read_tabulated,
    tabulate_to_file,
    write_tabulated,
)

WL = spectra.WAVELENGTHS_REFERENCE
RES = (8, 16, 8)


def _model():
    return models.OrenNayar(albedo=spectra.colorchecker_spectrum(9), sigma=0.52)


@pytest.fixture(scope="module")
def on_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("tab") / "oren_nayar.npz"
    tabulate_to_file(_model(), path, "io_iso", RES, WL)
    return path


def _centre_pairs(param_name, resolution):
    param = get_parameterization(param_name)
    wi, wo, valid = param.inverse(param.grid(resolution))
    lit = valid & (wi[:, 2] > 1e-9) & (wo[:, 2] > 1e-9)
    return wi[lit], wo[lit]


def _npy_bytes(array=None, *, header_shape=None, dtype="<f4", payload=b"") -> bytes:
    """A .npy member; with ``header_shape`` a header claiming that shape over ``payload``."""
    buffer = io.BytesIO()
    if header_shape is None:
        np.lib.format.write_array(buffer, np.asarray(array), allow_pickle=False)
    else:
        np.lib.format.write_array_header_1_0(
            buffer, {"descr": dtype, "fortran_order": False, "shape": tuple(header_shape)})
        buffer.write(payload)
    return buffer.getvalue()


def _meta(**overrides) -> np.ndarray:
    meta = {"format": FORMAT, "version": 1, "parameterization": "io_iso",
            "resolution": list(RES), "description": ""}
    meta.update(overrides)
    return np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)


def _write_zip(path, members: dict[str, bytes]) -> None:
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


# --------------------------------------------------------------------------- round trip


def test_file_layout(on_file):
    with np.load(on_file, allow_pickle=False) as data:
        assert sorted(data.files) == ["meta", "values", "wavelengths"]
        assert data["values"].dtype == np.float32
        assert data["values"].shape == RES + (WL.size,)
        assert data["wavelengths"].dtype == np.float64
        meta = json.loads(data["meta"].tobytes().decode())
    assert meta["format"] == FORMAT and meta["version"] == 1
    assert meta["parameterization"] == "io_iso" and meta["resolution"] == list(RES)
    assert json.loads(meta["description"])["name"] == "oren_nayar"


def test_round_trip_equals_model_at_grid_centres(on_file):
    tab = read_tabulated(on_file)
    assert isinstance(tab, TabulatedBRDF)
    assert tab.grid.parameterization.name == "io_iso" and tab.resolution == RES
    assert tab.defects == {"nan": 0, "inf": 0, "negative": 0}
    wi, wo = _centre_pairs("io_iso", RES)
    np.testing.assert_allclose(tab(wi, wo, WL), _model()(wi, wo, WL), rtol=2e-6, atol=1e-9)


def test_round_trip_close_in_between(tmp_path):
    path = tabulate_to_file(_model(), tmp_path / "fine.npz", "io_iso", (16, 32, 16), WL)
    tab = read_tabulated(path)
    wi, wo = metrics.random_direction_pairs(4000, seed=5)
    keep = (wi[:, 2] > 0.5) & (wo[:, 2] > 0.5)  # away from the extrapolated horizon
    ref = _model()(wi[keep], wo[keep], WL)
    got = tab(wi[keep], wo[keep], WL)
    assert np.sqrt(np.mean((got - ref) ** 2) / np.mean(ref**2)) < 0.005
    # other wavelengths: linear resampling of the file's 5 nm samples, ends held
    wl = np.array([350.0, 400.0, 402.5, 555.0, 700.0, 800.0])
    resampled = tab(wi[keep], wo[keep], wl)
    expected = np.stack([np.interp(wl, WL, row) for row in got])
    np.testing.assert_allclose(resampled, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(resampled[:, 1:5], _model()(wi[keep], wo[keep], wl[1:5]),
                               rtol=0.05)
    # below the horizon: 0, and never negative anywhere
    below = wi.copy()
    below[:, 2] *= -1
    assert np.all(tab(below, wo, WL) == 0.0)
    assert tab(wi, wo, WL).min() >= 0.0


@pytest.mark.parametrize("name, resolution", [("hd", (6, 4, 6, 4)), ("gs", (6, 6, 6, 6)),
                                              ("hd_iso", (6, 6, 12))])
def test_round_trip_other_parameterizations(tmp_path, name, resolution):
    model = models.WardAnisotropic(alpha_x=0.3, alpha_y=0.5, diffuse=0.4, specular=0.3)
    wl = np.array([450.0, 550.0, 650.0])
    path = tabulate_to_file(model, tmp_path / f"{name}.npz", name, resolution, wl)
    tab = read_tabulated(path)
    wi, wo = _centre_pairs(name, resolution)
    np.testing.assert_allclose(tab(wi, wo, wl), model(wi, wo, wl), rtol=1e-5, atol=1e-7)


def test_factor_brdf_accepts_reader_output(on_file):
    fitted = factor_brdf(read_tabulated(on_file), parameterization="io", resolution=RES,
                         packs=1, spectral_basis=4)
    assert isinstance(fitted, FactoredBRDF)
    assert fitted.parameterization == "io_iso"  # found isotropic
    assert fitted.report["relative_rms"] < 0.05


# --------------------------------------------------------------------------- invalid samples


def _values_with_defects() -> np.ndarray:
    values = np.full(RES + (4,), 0.1, dtype=np.float32)
    values[1, 2, 3, 1] = np.nan
    values[2, 0, 0, 0] = np.nan
    values[3, 3, 3, 3] = np.nan
    values[4, 5, 6, 2] = np.inf
    values[5, 5, 5, 2] = -np.inf
    values[6, 1, 1, 0] = -0.5
    return values


def test_nan_samples_raise_with_counts_and_location(tmp_path):
    wl = np.array([400.0, 500.0, 600.0, 700.0])
    with pytest.raises(InvalidBRDFData, match="refusing"):
        write_tabulated(tmp_path / "x.npz", _values_with_defects(), wl, "io_iso")
    path = write_tabulated(tmp_path / "bad.npz", _values_with_defects(), wl, "io_iso",
                           allow_invalid=True)
    with pytest.raises(InvalidBRDFData) as info:
        read_tabulated(path)
    message = str(info.value)
    assert str(path) in message
    assert "3 NaN" in message and "2 inf" in message and "2 negative" in message
    # the first defect in C order: cell (1, 2, 3) at 500 nm
    assert "theta_i=16.88°" in message and "λ=500.0 nm" in message and "[3]" in message


def test_clamp_mode_records_defects(tmp_path):
    wl = np.array([400.0, 500.0, 600.0, 700.0])
    path = write_tabulated(tmp_path / "bad.npz", _values_with_defects(), wl, "io_iso",
                           allow_invalid=True)
    tab = read_tabulated(path, on_invalid="clamp")
    assert tab.defects["nan"] == 3 and tab.defects["inf"] == 2 and tab.defects["negative"] == 2
    assert "500.0 nm" in tab.defects["first"]
    assert np.isfinite(tab.values).all() and tab.values.min() == 0.0
    assert int((tab.values == 0).sum()) == 6
    wi, wo = metrics.random_direction_pairs(100)
    assert np.isfinite(tab(wi, wo, wl)).all()
    with pytest.raises(ValueError, match="on_invalid"):
        read_tabulated(path, on_invalid="ignore")


# --------------------------------------------------------------------------- damaged files


def test_giant_header_refused_before_allocation(tmp_path):
    wl = np.arange(400.0, 801.0, 5.0)
    cases = {
        # over the entry limit
        "giant.npz": (dict(resolution=[100_000, 100_000, 100_000]),
                      (100_000, 100_000, 100_000, wl.size), "limit"),
        # under the limit, but the member holds a few bytes only
        "short.npz": (dict(resolution=[200, 400, 200]), (200, 400, 200, wl.size), "needs"),
        # values disagree with meta
        "mismatch.npz": (dict(resolution=[4, 8, 4]), (8, 16, 8, wl.size), "need"),
    }
    for name, (meta, shape, expect) in cases.items():
        path = tmp_path / name
        assert np.prod(shape, dtype=float) > MAX_ENTRIES or expect != "limit"
        _write_zip(path, {
            "meta.npy": _npy_bytes(_meta(**meta)),
            "wavelengths.npy": _npy_bytes(wl),
            "values.npy": _npy_bytes(header_shape=shape, payload=b"\0" * 4096),
        })
        tracemalloc.start()
        start = time.perf_counter()
        with pytest.raises(InvalidBRDFData, match=expect) as info:
            read_tabulated(path)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert str(path) in str(info.value)
        assert seconds < 1.0 and peak < 4 << 20, (name, seconds, peak)


def test_truncated_files_raise_value_error(on_file, tmp_path):
    raw = on_file.read_bytes()
    offsets = np.unique(np.linspace(0, len(raw) - 1, 20).astype(int))
    offsets = np.union1d(offsets, [1, 30, 200, len(raw) - 22, len(raw) - 1])
    for offset in offsets:
        path = tmp_path / f"cut_{offset}.npz"
        path.write_bytes(raw[:offset])
        with pytest.raises(ValueError) as info:
            read_tabulated(path)
        assert str(path) in str(info.value)


def test_flipped_bytes_raise_or_read_identically(on_file, tmp_path):
    raw = on_file.read_bytes()
    reference = read_tabulated(on_file).values
    rng = np.random.default_rng(1234)
    raised = 0
    trials = 60
    for trial in range(trials):
        data = bytearray(raw)
        for _ in range(int(rng.integers(1, 4))):
            if trial % 2:  # headers: the zip's local/central records and the .npy headers
                pos = int(rng.choice([rng.integers(0, 600), rng.integers(len(raw) - 600,
                                                                          len(raw))]))
            else:
                pos = int(rng.integers(0, len(raw)))
            data[pos] ^= 1 << int(rng.integers(0, 8))
        path = tmp_path / f"flip_{trial}.npz"
        path.write_bytes(bytes(data))
        try:
            tab = read_tabulated(path)
        except ValueError as exc:
            assert str(path) in str(exc)
            raised += 1
        else:  # a flip in an unchecked zip field (a timestamp, say): the data are intact
            np.testing.assert_array_equal(tab.values, reference)
    assert raised >= trials * 0.7


def test_compressed_archives_read_identically(on_file, tmp_path):
    reference = read_tabulated(on_file)
    with np.load(on_file, allow_pickle=False) as data:
        arrays = {name: data[name] for name in data.files}
    packed = tmp_path / "packed.npz"
    np.savez_compressed(packed, **arrays)
    with zipfile.ZipFile(packed) as archive:
        assert archive.getinfo("values.npy").compress_type == zipfile.ZIP_DEFLATED
    table = read_tabulated(packed)
    np.testing.assert_array_equal(table.values, reference.values)
    np.testing.assert_array_equal(table.wavelengths, reference.wavelengths)
    # float64 samples are read as float32, and a flat table deflating far beyond
    # MAX_DEFLATE_RATIO is still read while it declares at most a MiB.
    flat = tmp_path / "flat.npz"
    np.savez_compressed(flat, meta=arrays["meta"], wavelengths=arrays["wavelengths"],
                        values=np.zeros(arrays["values"].shape))
    assert read_tabulated(flat).values.dtype == np.float32


def test_declared_sizes_checked_against_the_bytes_present(tmp_path):
    lie = BOMBS["npz_declared_size"].make(tmp_path)
    with pytest.raises(InvalidBRDFData, match=r"npz_declared_size.npz: member 'values.npy' "
                                              r"declares 3,895,776,128 bytes of data from offset "
                                              r"[\d,]+, past the end of the 10,279-byte archive"):
        read_tabulated(lie)
    bomb = BOMBS["npz_deflate_bomb"].make(tmp_path)
    with pytest.raises(InvalidBRDFData, match=r"npz_deflate_bomb.npz: member 'values.npy' "
                                              r"declares 1,108,080,128 bytes from [\d,]+ "
                                              r"compressed \(1,011:1; at most 512:1"):
        read_tabulated(bomb)


def test_other_bad_files(on_file, tmp_path):
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    text = tmp_path / "text.npz"
    text.write_text("theta_i,phi,theta_o,value\n1,2,3,4\n")
    missing = tmp_path / "missing_values.npz"
    np.savez(missing, meta=_meta(), wavelengths=WL)
    factored = tmp_path / "factored.npz"
    fit = factor_brdf(models.Lambert(0.5), parameterization="io", resolution=(4, 8, 4), packs=1)
    fit.save(factored)
    bad_json = tmp_path / "bad_json.npz"
    np.savez(bad_json, meta=np.frombuffer(b"{not json", dtype=np.uint8), wavelengths=WL,
             values=np.zeros(RES + (WL.size,), np.float32))
    bad_param = tmp_path / "bad_param.npz"
    np.savez(bad_param, meta=_meta(parameterization="polar"), wavelengths=WL,
             values=np.zeros(RES + (WL.size,), np.float32))
    bad_version = tmp_path / "bad_version.npz"
    np.savez(bad_version, meta=_meta(version=2), wavelengths=WL,
             values=np.zeros(RES + (WL.size,), np.float32))
    int_values = tmp_path / "int_values.npz"
    np.savez(int_values, meta=_meta(), wavelengths=WL, values=np.zeros(RES + (WL.size,), int))
    bad_wl = tmp_path / "bad_wl.npz"
    np.savez(bad_wl, meta=_meta(), wavelengths=WL[::-1].copy(),
             values=np.zeros(RES + (WL.size,), np.float32))
    pickled = tmp_path / "pickled.npz"
    np.savez(pickled, meta=_meta(), wavelengths=WL,
             values=np.array([{"a": 1}], dtype=object))
    expectations = {empty: "empty", text: "zip", missing: "no 'values'",
                    factored: "factored_brdf", bad_json: "meta", bad_param: "polar",
                    bad_version: "version", int_values: "float32", bad_wl: "wavelengths",
                    pickled: "dtype"}
    for path, pattern in expectations.items():
        with pytest.raises(InvalidBRDFData, match=pattern) as info:
            read_tabulated(path)
        assert str(path) in str(info.value), path
    with pytest.raises(FileNotFoundError):
        read_tabulated(tmp_path / "nothing_here.npz")


def test_write_validates_arguments(tmp_path):
    values = np.zeros(RES + (3,), np.float32)
    wl = np.array([450.0, 550.0, 650.0])
    with pytest.raises(ValueError, match="parameterisation"):
        write_tabulated(tmp_path / "a.npz", values, wl, "polar")
    with pytest.raises(ValueError, match="dimensions"):
        write_tabulated(tmp_path / "a.npz", values, wl, "io")
    with pytest.raises(ValueError, match="wavelengths"):
        write_tabulated(tmp_path / "a.npz", values, wl[:2], "io_iso")
    assert not (tmp_path / "a.npz").exists()
    path = write_tabulated(tmp_path / "a.npz", values, wl, "io_iso", "zeros")
    assert read_tabulated(path).description == "zeros"
    assert [p.name for p in tmp_path.iterdir()] == ["a.npz"]  # no temporary left behind
