"""Plain OpenEXR images (formats/exr.py): round trip, header layout, size rules, damage."""

from __future__ import annotations

import json
import os
import struct
import subprocess
import sys
import textwrap

import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR")

from bombs_archives import BOMBS

from spectral_materials.core.formats import exr
from spectral_materials.core.formats.exr import (
    EXRFileNotFound,
    InvalidEXRFile,
    read_exr,
    read_layout,
    write_exr,
)


def _rgb(shape=(20, 24), seed=0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {c: rng.random(shape).astype(np.float32) for c in "RGB"}


def _write(path, channels, compression=None) -> None:
    """Channels as given (any dtype) through OpenEXR itself, rows as stored."""
    header = {"compression": OpenEXR.ZIP_COMPRESSION if compression is None else compression,
              "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as handle:
        handle.write(str(path))


def test_round_trip_bottom_row_first(tmp_path):
    channels = _rgb()
    path = write_exr(tmp_path / "a.exr", channels, {"owner": "test"})
    read, header = read_exr(path)
    assert sorted(read) == ["B", "G", "R"] and header["owner"] == "test"
    for name, values in channels.items():
        np.testing.assert_array_equal(read[name], values)
        assert read[name].dtype == np.float32
    with OpenEXR.File(str(path), separate_channels=True) as raw:
        np.testing.assert_array_equal(raw.channels()["R"].pixels, channels["R"][::-1])


def test_layout_matches_what_openexr_decodes(tmp_path):
    rng = np.random.default_rng(1)
    path = tmp_path / "mixed.exr"
    stored = {"H": rng.random((7, 9)).astype(np.float16),
              "F": rng.random((7, 9)).astype(np.float32),
              "U": rng.integers(0, 9, (7, 9)).astype(np.uint32)}
    _write(path, dict(stored))  # the binding turns the dict's arrays into Channels
    [part] = read_layout(path)
    assert (part.width, part.height) == (9, 7)
    assert sorted((name, kind) for name, kind, _, _ in part.channels) == [
        ("F", 2), ("H", 1), ("U", 0)]
    with OpenEXR.File(str(path), separate_channels=True) as raw:
        decoded = sum(c.pixels.nbytes for c in raw.channels().values())
    assert part.stored_bytes == decoded == 7 * 9 * (2 + 4 + 4)
    channels, _ = read_exr(path)
    for name, values in stored.items():
        assert channels[name].dtype == np.float32
        np.testing.assert_array_equal(channels[name][::-1], values.astype(np.float32))


def test_multi_part_counts_every_part(tmp_path):
    path = tmp_path / "parts.exr"
    first = OpenEXR.Part({"type": OpenEXR.scanlineimage}, {"Z": np.ones((4, 6), "f")}, "a")
    second = OpenEXR.Part({"type": OpenEXR.scanlineimage},
                          {"Y": np.zeros((4, 6), "f"), "X": np.zeros((4, 6), "e")}, "b")
    with OpenEXR.File([first, second]) as handle:
        handle.write(str(path))
    parts = read_layout(path)
    assert [p.stored_bytes for p in parts] == [4 * 6 * 4, 4 * 6 * (4 + 2)]
    channels, _ = read_exr(path)
    assert list(channels) == ["Z"] and channels["Z"].shape == (4, 6)


def test_non_utf8_file_name_is_read(tmp_path):
    name = tmp_path / os.fsdecode(b"\xff\xfe image.exr")
    channels = _rgb((5, 4), seed=2)
    write_exr(name, channels)
    assert os.path.exists(os.fsencode(name))
    read, _ = read_exr(name)
    np.testing.assert_array_equal(read["G"], channels["G"])


def test_missing_and_not_a_file(tmp_path):
    with pytest.raises(EXRFileNotFound, match="none.exr") as info:
        read_exr(tmp_path / "none.exr")
    assert isinstance(info.value, ValueError) and isinstance(info.value, FileNotFoundError)
    with pytest.raises(InvalidEXRFile, match="not a regular file"):
        read_exr(tmp_path)


@pytest.mark.parametrize("content", [b"", b"v/1", b"hello, not an image\n", b"\x76\x2f\x31\x01"])
def test_not_an_exr(tmp_path, content):
    path = tmp_path / "fake.exr"
    path.write_bytes(content)
    with pytest.raises(InvalidEXRFile, match="fake.exr"):
        read_exr(path)


def test_library_errors_are_translated(tmp_path):
    path = write_exr(tmp_path / "ok.exr", _rgb(), {"owner": "abcdef"})
    raw = path.read_bytes()
    # A damaged string attribute: OpenEXR's binding raises UnicodeDecodeError.
    at = raw.index(b"abcdef")
    bad = tmp_path / "attribute.exr"
    bad.write_bytes(raw[:at] + b"\xff\xfe\xfd\xfc\xfb\xfa" + raw[at + 6:])
    with pytest.raises(InvalidEXRFile, match="attribute.exr.*UnicodeDecodeError"):
        read_exr(bad)
    # Pixel data cut short: the binding drops the part and raises "Invalid part index".
    cut = tmp_path / "cut.exr"
    cut.write_bytes(raw[:-40])
    with pytest.raises(InvalidEXRFile, match="cut.exr") as info:
        read_exr(cut)
    assert type(info.value) is InvalidEXRFile


def test_uncompressed_pixels_must_be_in_the_file(tmp_path):
    path = tmp_path / "raw.exr"
    _write(path, {"Y": np.ones((16, 16), np.float32)}, OpenEXR.NO_COMPRESSION)
    raw = bytearray(path.read_bytes())
    key = b"dataWindow\x00box2i\x00"
    at = raw.index(key) + len(key) + 4
    raw[at + 8: at + 16] = struct.pack("<ii", 4095, 4095)  # 4096² pixels, 64 MiB of floats
    forged = tmp_path / "forged.exr"
    forged.write_bytes(bytes(raw))
    with pytest.raises(InvalidEXRFile, match=r"forged.exr.*need 67,108,864 bytes; the file"):
        read_exr(forged)


def test_compression_ratio_rule(tmp_path):
    bomb = BOMBS["exr_zip_bomb"].make(tmp_path)
    with pytest.raises(InvalidEXRFile, match=r"exr_zip_bomb.exr.*1,006:1; at most 256:1"):
        read_exr(bomb)
    # Under RATIO_FREE_BYTES any ratio is fine: a flat 1024² frame compresses ~1000:1.
    flat = write_exr(tmp_path / "flat.exr", {c: np.zeros((1024, 1024)) for c in "RGBA"})
    assert 4 * 1024 * 1024 * 4 > exr.MAX_COMPRESSION_RATIO * flat.stat().st_size
    channels, _ = read_exr(flat)
    assert channels["A"].shape == (1024, 1024) and not channels["A"].any()


def test_pixel_limit(tmp_path, monkeypatch):
    path = write_exr(tmp_path / "big.exr", _rgb((40, 50)))
    monkeypatch.setattr(exr, "MAX_PIXELS", 1999)
    with pytest.raises(InvalidEXRFile, match=r"big.exr: image of 50×40 pixels, over the"):
        exr.check_decoded_size(path, read_layout(path), max_pixels=exr.MAX_PIXELS)


_FUZZ = textwrap.dedent("""
    import json, random, sys
    from pathlib import Path
    from spectral_materials.core.formats.exr import InvalidEXRFile, read_exr
    raw = Path(sys.argv[1]).read_bytes()
    case = Path(sys.argv[2])
    outcome = {"ok": 0, "invalid": 0}
    for seed in range(int(sys.argv[3])):
        r = random.Random(seed)
        data = bytearray(raw)
        op = r.choice(["flip", "byte", "trunc", "multi"])
        if op == "trunc":
            data = data[: r.randrange(len(data))]
        else:
            for _ in range(r.randint(2, 20) if op == "multi" else 1):
                at = r.randrange(len(data))
                data[at] = data[at] ^ (1 << r.randrange(8)) if op == "flip" else r.randrange(256)
        case.write_bytes(bytes(data))
        print("case", seed, op, file=sys.stderr, flush=True)  # the last names a crash
        try:
            read_exr(case)
            outcome["ok"] += 1
        except InvalidEXRFile as exc:  # a bare ValueError or UnicodeDecodeError fails here
            assert type(exc) is InvalidEXRFile and str(case) in str(exc), repr(exc)
            outcome["invalid"] += 1
    print(json.dumps(outcome))
""")


def test_fuzz_truncations_and_flips(tmp_path):
    """400 seeded truncations and byte flips of a valid RGB EXR: each reads or raises
    InvalidEXRFile naming the file. A child process, so that an abort in the C++ library
    shows as a failed exit status (with the case) instead of killing pytest."""
    cases = 400
    base = write_exr(tmp_path / "base.exr", _rgb(), {"owner": "fuzz"})
    done = subprocess.run(
        [sys.executable, "-c", _FUZZ, str(base), str(tmp_path / "case.exr"), str(cases)],
        capture_output=True, text=True, timeout=120)
    lines = [line for line in done.stdout.splitlines() if line.startswith("{")]
    assert done.returncode == 0 and lines, (f"exit {done.returncode}; "
                                            f"{done.stderr[-2000:]}")
    outcome = json.loads(lines[-1])
    assert outcome["ok"] + outcome["invalid"] == cases
    assert outcome["invalid"] > cases // 5
