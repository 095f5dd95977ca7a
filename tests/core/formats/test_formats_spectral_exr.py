"""Tests for spectral OpenEXR images (formats/spectral_exr.py, Fichet et al. JCGT 2021 layout)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR")

from bombs_archives import BOMBS

from spectral_materials.core.colour import spectra
from spectral_materials.core.formats import spectral_exr as sx
from spectral_materials.core.formats.exr import read_exr, write_exr
from spectral_materials.core.formats.spectral_exr import (
    InvalidSpectralImage,
    SpectralEXRFileNotFound,
    SpectralImage,
    channel_name,
    parse_channel_name,
    read_spectral_exr,
    spectral_image_to_rgb,
    spectral_image_to_xyz,
    write_spectral_exr,
)

WL = np.array([400.0, 412.5, 500.0, 587.25, 700.0, 1000.0])


def _values(shape=(3, 5), wl=WL, seed=0) -> np.ndarray:
    return np.random.default_rng(seed).random(shape + (wl.size,)).astype(np.float32) * 2.0


def _header_channels(path) -> list[str]:
    with OpenEXR.File(str(path), header_only=True) as exr:
        return [c.name for c in exr.header()["channels"]]


# --------------------------------------------------------------------------- names


def test_channel_names_are_the_papers():
    assert channel_name("emissive", 550) == "S0.550,000000nm"
    assert channel_name("emissive", 550, stokes=3) == "S3.550,000000nm"
    assert channel_name("reflective", 550) == "T.550,000000nm"
    assert channel_name("reflective", 412.5) == "T.412,500000nm"
    # more digits than %f keeps: written exactly, still with a decimal comma
    assert channel_name("reflective", 412.1234567) == "T.412,1234567nm"


@pytest.mark.parametrize("name, expected", [
    ("T.550,000000nm", ("reflective", 0, 550.0)),
    ("S0.412,5nm", ("emissive", 0, 412.5)),
    ("S2.550nm", ("emissive", 2, 550.0)),
    ("T.0,55um", ("reflective", 0, 550.0)),
    ("T.5,5E2nm", ("reflective", 0, 550.0)),
    ("T.5,5e-7m", ("reflective", 0, 550.0)),
    ("T.550000pm", ("reflective", 0, 550.0)),
    ("T.5,5dam", ("reflective", 0, 55e9)),
    ("R", None), ("A", None), ("diffuse.R", None), ("T.500nm.600nm", None),
])
def test_parse_channel_name(name, expected):
    got = parse_channel_name(name)
    if expected is None:
        assert got is None
    else:
        assert got[:2] == expected[:2] and got[2] == pytest.approx(expected[2], rel=1e-12)


def test_parse_frequency():
    kind, stokes, wl = parse_channel_name("T.499,654096666667THz")
    assert (kind, stokes) == ("reflective", 0) and wl == pytest.approx(600.0, rel=1e-9)


@pytest.mark.parametrize("name", ["T.550.0nm", "T.550,0", "T.nm", "S4.550nm", "S0.550xm",
                                  "S0.-550nm", "T.0nm", "T.550 nm", "T.,nm", "S0.1e999nm"])
def test_parse_rejects_malformed(name):
    with pytest.raises(ValueError, match="channel"):
        parse_channel_name(name)


# --------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("kind", ["reflective", "emissive"])
def test_round_trip(tmp_path, kind):
    values = _values()
    path = tmp_path / f"{kind}.exr"
    write_spectral_exr(path, WL, values, kind=kind,
                       attributes={"owner": "lab", "frame": 7, "scale": 0.5})
    layer = "T" if kind == "reflective" else "S0"
    expected = {f"{layer}.400,000000nm", f"{layer}.412,500000nm", f"{layer}.500,000000nm",
                f"{layer}.587,250000nm", f"{layer}.700,000000nm", f"{layer}.1000,000000nm"}
    assert set(_header_channels(path)) == expected | {"R", "G", "B"}

    image = read_spectral_exr(path)
    assert image.kind == kind
    np.testing.assert_array_equal(image.wavelengths, WL)
    assert image.values.dtype == np.float32 and image.values.shape == values.shape
    np.testing.assert_array_equal(image.values, values)
    assert image.attributes["spectralLayoutVersion"] == "1.0"
    assert image.attributes["EV"] == 0.0
    assert image.attributes["owner"] == "lab"
    assert image.attributes["frame"] == 7
    assert image.attributes["scale"] == 0.5
    if kind == "emissive":
        assert image.attributes["emissiveUnits"] == "W.m^-2.sr^-1" == image.units
    else:
        assert "emissiveUnits" not in image.attributes and image.units is None
    assert image.defects == {"nan": 0, "inf": 0, "negative": 0}
    assert image.notes == [] and not image.polarised


def test_rows_bottom_up_like_exr_py(tmp_path):
    values = _values(shape=(4, 2))
    path = write_spectral_exr(tmp_path / "rows.exr", WL, values, rgb_preview=False)
    channels, _ = read_exr(path)  # exr.py: row 0 at the bottom too
    np.testing.assert_array_equal(channels["T.500,000000nm"], values[:, :, 2])
    with OpenEXR.File(str(path), separate_channels=True) as exr:  # files store the top row first
        np.testing.assert_array_equal(exr.channels()["T.500,000000nm"].pixels, values[::-1, :, 2])


def test_emissive_units_and_large_values(tmp_path):
    values = _values() * 1e6  # past half float's 65504: float32 keeps them
    path = write_spectral_exr(tmp_path / "e.exr", WL, values, kind="emissive",
                              units="W.m^-2.sr^-1.nm^-1")
    image = read_spectral_exr(path)
    assert image.units == "W.m^-2.sr^-1.nm^-1"
    np.testing.assert_array_equal(image.values, values)


def test_rgb_preview(tmp_path):
    wl = spectra.WAVELENGTHS_REFERENCE
    values = np.ones((2, 3, wl.size))
    values[0, 0] = spectra.colorchecker(2, wl)
    path = write_spectral_exr(tmp_path / "white.exr", wl, values)
    channels, _ = read_exr(path)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1)
    image = read_spectral_exr(path)
    np.testing.assert_allclose(rgb, spectral_image_to_rgb(image), rtol=1e-6)
    np.testing.assert_allclose(rgb[1, 2], [1.0, 1.0, 1.0], atol=2e-3)  # white under D65
    path = write_spectral_exr(tmp_path / "none.exr", wl, values, rgb_preview=False)
    assert not {"R", "G", "B"} & set(_header_channels(path))


@pytest.mark.filterwarnings("ignore:Aligning")
def test_xyz_matches_colour_science():
    colour = pytest.importorskip("colour")
    wl = spectra.WAVELENGTHS_REFERENCE
    patch = spectra.colorchecker(3, wl)
    image = SpectralImage(wl, patch[None, None, :].astype(np.float32), "reflective")
    sd = colour.SpectralDistribution(dict(zip(wl, patch)))
    expected = colour.sd_to_XYZ(sd, illuminant=colour.SDS_ILLUMINANTS["D65"]) / 100.0
    np.testing.assert_allclose(spectral_image_to_xyz(image)[0, 0], expected, atol=2e-3)
    # emissive: Σ L x̄ Δλ (1 nm steps, no 683 factor)
    flat = SpectralImage(wl, np.ones((1, 1, wl.size), np.float32), "emissive")
    grid = np.arange(380.0, 781.0)
    np.testing.assert_allclose(spectral_image_to_xyz(flat)[0, 0],
                               spectra.cmfs(grid).sum(axis=0), rtol=1e-9)
    with pytest.raises(ValueError, match="illuminant"):
        spectral_image_to_xyz(flat, illuminant="D65")


# --------------------------------------------------------------------------- files by hand


def test_reads_hand_named_channels_written_by_exr_py(tmp_path):
    """Names spelled as other writers may (units, exponent, Hz), in alphabetical file order."""
    h, w = 2, 3
    planes = {wl: np.full((h, w), wl / 1000.0, np.float32) for wl in (400, 450, 500, 600, 1000)}
    planes[450][0, 1] = 7.0
    channels = {
        "T.4,0E2nm": planes[400], "T.450nm": planes[450], "T.0,5um": planes[500],
        "T.499,654096666667THz": planes[600], "T.1000,000000nm": planes[1000],
        "R": np.zeros((h, w)), "G": np.zeros((h, w)), "B": np.zeros((h, w)),
        "diffuse.Z": np.zeros((h, w)), "T.500nm.600nm": np.zeros((h, w)),
    }
    path = write_exr(tmp_path / "hand.exr", channels, {"owner": "someone else"})
    image = read_spectral_exr(path)
    assert image.kind == "reflective"
    np.testing.assert_allclose(image.wavelengths, [400, 450, 500, 600, 1000], rtol=1e-9)
    for i, wl in enumerate((400, 450, 500, 600, 1000)):
        np.testing.assert_array_equal(image.values[:, :, i], planes[wl])
    assert image.values[0, 1, 1] == 7.0  # row 0 at the bottom, as exr.py
    assert image.attributes == {"owner": "someone else"}
    notes = " ".join(image.notes)
    assert "bi-spectral" in notes and "spectralLayoutVersion" in notes


def test_polarised_reads_s0_only(tmp_path):
    h, w = 2, 2
    channels = {}
    for s in range(4):
        for wl in (500, 600):
            channels[f"S{s}.{wl},000000nm"] = np.full((h, w), s * 10 + wl / 1000, np.float32)
    path = write_exr(tmp_path / "pol.exr", channels,
                     {"spectralLayoutVersion": "1.0", "emissiveUnits": "W.m^-2.sr^-1",
                      "polarisationHandedness": "right"})
    image = read_spectral_exr(path)
    assert image.kind == "emissive" and image.polarised
    np.testing.assert_allclose(image.values[0, 0], [0.5, 0.6])
    assert any("S1–S3" in n for n in image.notes)
    del channels["S2.500,000000nm"], channels["S2.600,000000nm"]
    path = write_exr(tmp_path / "pol_bad.exr", channels)
    with pytest.raises(InvalidSpectralImage, match="pol_bad.exr.*S0–S3"):
        read_spectral_exr(path)


def test_mixed_kinds_need_a_choice(tmp_path):
    ones = np.ones((2, 2))
    path = write_exr(tmp_path / "mixed.exr",
                     {"S0.500nm": ones, "S0.600nm": 2 * ones, "T.500nm": 3 * ones,
                      "T.600nm": 4 * ones})
    with pytest.raises(InvalidSpectralImage, match="mixed.exr.*both emissive.*kind="):
        read_spectral_exr(path)
    emissive = read_spectral_exr(path, kind="emissive")
    reflective = read_spectral_exr(path, kind="reflective")
    assert emissive.values[0, 0].tolist() == [1, 2] and reflective.values[0, 0].tolist() == [3, 4]
    assert "reflective channels also present" in emissive.notes[0]
    only_t = write_exr(tmp_path / "t.exr", {"T.500nm": ones})
    with pytest.raises(InvalidSpectralImage, match="no emissive channels"):
        read_spectral_exr(only_t, kind="emissive")


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize("names", [
    ("T.550nm", "T.0,55um"),          # the same wavelength spelt twice
    ("T.550nm", "T.550,000000nm"),
    ("S0.550nm", "S0.5,5E2nm"),
])
def test_duplicate_wavelengths_refused(tmp_path, names):
    path = write_exr(tmp_path / "dup.exr", {n: np.ones((2, 2)) for n in names})
    with pytest.raises(InvalidSpectralImage, match="dup.exr.*same wavelength") as info:
        read_spectral_exr(path)
    assert all(repr(n) in str(info.value) for n in names)


@pytest.mark.parametrize("bad", ["T.550.5nm", "T.550,0", "S4.550nm", "S0.-550nm", "T.0nm",
                                 "T.550Xm"])
def test_bad_channel_names_refused(tmp_path, bad):
    path = write_exr(tmp_path / "bad.exr", {"T.600nm": np.ones((2, 2)), bad: np.ones((2, 2))})
    with pytest.raises(InvalidSpectralImage, match="bad.exr") as info:
        read_spectral_exr(path)
    assert repr(bad) in str(info.value)


def test_no_spectral_channels(tmp_path):
    path = write_exr(tmp_path / "rgb.exr", {c: np.ones((2, 2)) for c in "RGB"})
    with pytest.raises(InvalidSpectralImage, match="rgb.exr.*no spectral channels"):
        read_spectral_exr(path)


def test_missing_file(tmp_path):
    path = tmp_path / "nothing.exr"
    with pytest.raises(SpectralEXRFileNotFound, match="nothing.exr") as info:
        read_spectral_exr(path)
    assert isinstance(info.value, ValueError) and isinstance(info.value, FileNotFoundError)
    with pytest.raises(InvalidSpectralImage, match="not a regular file"):
        read_spectral_exr(tmp_path)


@pytest.mark.parametrize("content", [b"", b"hello, not an image\n", b"\x76\x2f\x31\x01"])
def test_not_an_exr(tmp_path, content):
    path = tmp_path / "fake.exr"
    path.write_bytes(content)
    with pytest.raises(InvalidSpectralImage, match="fake.exr"):
        read_spectral_exr(path)


@pytest.fixture(scope="module")
def small_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sexr") / "small.exr"
    write_spectral_exr(path, [400.0, 450.0, 500.0, 550.0, 600.0], _values((4, 3), np.ones(5)),
                       attributes={"owner": "fuzz"})
    return path


def test_truncated(tmp_path, small_file):
    raw = small_file.read_bytes()
    for cut in (3, 8, 40, len(raw) // 2, len(raw) - 60, len(raw) - 1):
        path = tmp_path / f"cut{cut}.exr"
        path.write_bytes(raw[:cut])
        with pytest.raises(InvalidSpectralImage, match=f"cut{cut}.exr"):
            read_spectral_exr(path)


def test_header_size_checked_before_pixels(tmp_path, small_file):
    raw = bytearray(small_file.read_bytes())
    key = b"dataWindow\x00box2i\x00"
    at = raw.index(key) + len(key) + 4  # after the int32 attribute size
    raw[at + 8: at + 16] = np.array([99_999, 99_999], "<i4").tobytes()  # xMax, yMax
    path = tmp_path / "huge.exr"
    path.write_bytes(bytes(raw))
    with pytest.raises(InvalidSpectralImage, match=r"huge.exr.*100000×100000.*over the"):
        read_spectral_exr(path)


def test_defects_counted(tmp_path):
    values = _values()
    values[0, 0, 0] = np.nan
    values[1, 1, 1] = np.inf
    values[2, 2, :2] = -0.5
    path = write_spectral_exr(tmp_path / "bad.exr", WL, values, allow_invalid=True,
                              kind="emissive")
    image = read_spectral_exr(path)
    assert image.defects == {"nan": 1, "inf": 1, "negative": 2}
    assert np.isnan(image.values[0, 0, 0])  # kept by default
    clamped = read_spectral_exr(path, on_invalid="clamp")
    assert clamped.defects == image.defects and np.isfinite(clamped.values).all()
    assert clamped.values.min() == 0.0
    with pytest.raises(InvalidSpectralImage, match="1 NaN, 1 inf and 2 negative"):
        read_spectral_exr(path, on_invalid="raise")


@pytest.mark.parametrize("name, wavelength", [("T.5E14nm", "5e\\+14"), ("T.5nm", "5"),
                                              ("T.0,5mm", "500000"), ("T.1Hz", "2.99792e\\+17")])
def test_wavelengths_outside_the_limits_refused(tmp_path, name, wavelength):
    plane = np.ones((2, 3), np.float32)
    path = write_exr(tmp_path / "far.exr", {"T.500nm": plane, name: plane})
    with pytest.raises(InvalidSpectralImage,
                       match=rf"far.exr: channel '{name}' gives wavelength {wavelength} nm, "
                             "outside 10–100000 nm"):
        read_spectral_exr(path)


def test_extreme_samples_refused_in_every_mode(tmp_path):
    values = _values()
    values[1, 2, 3] = 5e35
    values[0, 0, 0] = -2e31
    path = write_spectral_exr(tmp_path / "loud.exr", WL, values, allow_invalid=True)
    for mode in ("keep", "raise", "clamp"):
        with pytest.raises(InvalidSpectralImage,
                           match=r"loud.exr: 2 samples beyond ±1e\+30 \(largest magnitude 5e\+35"):
            read_spectral_exr(path, on_invalid=mode)
    values[1, 2, 3] = values[0, 0, 0] = 1e30  # the limit itself is accepted
    path = write_spectral_exr(tmp_path / "edge.exr", WL, values)
    assert read_spectral_exr(path).values.max() == np.float32(1e30)


def test_non_utf8_file_name_is_read(tmp_path):
    path = tmp_path / os.fsdecode(b"\xff\xfe spectral.exr")
    values = _values(seed=4)
    write_spectral_exr(path, WL, values)
    image = read_spectral_exr(path)
    np.testing.assert_array_equal(image.values, values)
    np.testing.assert_array_equal(image.wavelengths, WL)


def test_compressed_bomb_refused_before_decoding(tmp_path):
    path = BOMBS["spectral_exr_bomb"].make(tmp_path)
    with pytest.raises(InvalidSpectralImage,
                       match=r"spectral_exr_bomb.exr: declares 1,073,741,824 bytes of "
                             r"compressed pixels in a [\d,]+-byte file \(1,012:1; at most 256:1"):
        read_spectral_exr(path)


def test_uncompressed_pixels_must_be_in_the_file(tmp_path):
    plane = np.ones((16, 16), np.float32)
    header = {"compression": OpenEXR.NO_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"T.500nm": plane, "T.600nm": plane}) as handle:
        handle.write(str(tmp_path / "raw.exr"))
    raw = bytearray((tmp_path / "raw.exr").read_bytes())
    key = b"dataWindow\x00box2i\x00"
    at = raw.index(key) + len(key) + 4
    raw[at + 8: at + 16] = np.array([2047, 2047], "<i4").tobytes()
    path = tmp_path / "forged.exr"
    path.write_bytes(bytes(raw))
    with pytest.raises(InvalidSpectralImage, match=r"forged.exr: its uncompressed pixels need "
                                                   r"33,554,432 bytes; the file has"):
        read_spectral_exr(path)


def test_writer_refusals(tmp_path):
    path = tmp_path / "w.exr"
    v = _values(wl=np.ones(3))
    with pytest.raises(ValueError, match="strictly increasing"):
        write_spectral_exr(path, [500, 400, 600], v)
    with pytest.raises(ValueError, match="strictly increasing"):
        write_spectral_exr(path, [400, 500, 500], v)
    with pytest.raises(ValueError, match="positive"):
        write_spectral_exr(path, [-1, 500, 600], v)
    with pytest.raises(ValueError, match="values must be"):
        write_spectral_exr(path, [400, 500], v)
    with pytest.raises(ValueError, match="set by the layout"):
        write_spectral_exr(path, [400, 500, 600], v, attributes={"spectralLayoutVersion": "2"})
    with pytest.raises(ValueError, match="unitless"):
        write_spectral_exr(path, [400, 500, 600], v, units="W")
    with pytest.raises(ValueError, match="kind"):
        write_spectral_exr(path, [400, 500, 600], v, kind="bispectral")
    bad = v.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        write_spectral_exr(path, [400, 500, 600], bad)
    with pytest.raises(ValueError, match="non-finite"):
        write_spectral_exr(path, [400, 500, 600], v * 1e39)  # float32 overflow
    with pytest.raises(ValueError, match=r"samples beyond ±1e\+30"):
        write_spectral_exr(path, [400, 500, 600], v * 1e32)
    with pytest.raises(ValueError, match="within 10–100000 nm"):
        write_spectral_exr(path, [5, 500, 600], v)
    with pytest.raises(ValueError, match="within 10–100000 nm"):
        write_spectral_exr(path, [400, 500, 2e5], v)
    assert not path.exists() and not list(tmp_path.iterdir())


# --------------------------------------------------------------------------- fuzz

_FUZZ = textwrap.dedent("""
    import json, random, sys
    from pathlib import Path
    from spectral_materials.core.formats.spectral_exr import InvalidSpectralImage, read_spectral_exr
    raw = Path(sys.argv[1]).read_bytes()
    case = Path(sys.argv[2])
    outcome = {"ok": 0, "invalid": 0}
    for seed in range(int(sys.argv[3])):
        r = random.Random(seed)
        data = bytearray(raw)
        op = r.choice(["flip", "byte", "trunc", "multi", "insert", "delete"])
        if op == "trunc":
            data = data[: r.randrange(len(data))]
        elif op == "insert":
            at = r.randrange(len(data))
            data[at:at] = bytes(r.randrange(256) for _ in range(r.randint(1, 8)))
        elif op == "delete":
            at = r.randrange(len(data))
            del data[at: at + r.randint(1, 8)]
        else:
            for _ in range(r.randint(2, 20) if op == "multi" else 1):
                at = r.randrange(len(data))
                data[at] = data[at] ^ (1 << r.randrange(8)) if op == "flip" else r.randrange(256)
        case.write_bytes(bytes(data))
        print(seed, op, flush=True)  # the last seed printed names a case that crashed
        try:
            read_spectral_exr(case)
            outcome["ok"] += 1
        except InvalidSpectralImage as exc:
            assert str(case) in str(exc), exc
            outcome["invalid"] += 1
    print(json.dumps(outcome))
""")


def test_fuzz_mutations_never_crash(tmp_path, small_file):
    """200 byte-level mutations / truncations: the reader succeeds or raises its own error.

    Run in a child process so that an abort inside the C++ library would show as a
    failed exit status (with the seed of the case) instead of killing pytest.
    """
    cases = 200
    proc = subprocess.run(
        [sys.executable, "-c", _FUZZ, str(small_file), str(tmp_path / "case.exr"), str(cases)],
        capture_output=True, text=True, timeout=120)
    lines = proc.stdout.strip().splitlines()
    assert proc.returncode == 0, (f"reader crashed or raised a foreign error (exit "
                                  f"{proc.returncode}) after case {lines[-1:]}:\n"
                                  f"{proc.stderr[-2000:]}")
    outcome = json.loads(lines[-1])
    assert outcome["ok"] + outcome["invalid"] == cases
    assert outcome["invalid"] > cases // 4  # most mutations must be caught


def test_module_constants():
    assert sx.LAYOUT_VERSION == "1.0" and sx.EMISSIVE_UNITS == "W.m^-2.sr^-1"
