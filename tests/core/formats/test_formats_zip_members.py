"""Zip members read with their declared sizes checked and inflated under a running cap
(formats/_files.py: check_zip_member, open_zip_member)."""

from __future__ import annotations

import os
import struct
import zipfile
import zlib

import numpy as np
import pytest

from spectral_materials.core.errors import InvalidBRDFData
from spectral_materials.core.formats._files import (
    RATIO_FREE_BYTES,
    check_zip_member,
    open_zip_member,
)

METHODS = [zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED]
#: zipfile inflates these in one call as large as the member: refused.
UNBOUNDED = {zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "LZMA"}


class ZipError(ValueError):
    """A reader's own error type, to check that the helper raises the one it is given."""


def _data() -> dict[str, bytes]:
    rng = np.random.default_rng(5)
    return {"noise": rng.bytes(200_000), "text": b"spectral " * 30_000, "empty": b""}


def _archive(path, members: dict[str, bytes], method=zipfile.ZIP_DEFLATED):
    with zipfile.ZipFile(path, "w", compression=method) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return path


def _open(path, name, *, max_bytes=1 << 30, max_ratio=1e9, error=ZipError):
    # Closing the archive with a member open leaves the file open until the member closes.
    with zipfile.ZipFile(path) as archive:
        return open_zip_member(archive, archive.getinfo(name), path=path, max_bytes=max_bytes,
                               max_ratio=max_ratio, error=error)


def _patch_central(path, field: int, value: int, size: str = "<I") -> None:
    """Overwrite one field of the first central-directory record (offset from 'PK\\1\\2')."""
    raw = bytearray(path.read_bytes())
    at = raw.index(b"PK\x01\x02") + field
    raw[at: at + struct.calcsize(size)] = struct.pack(size, value)
    path.write_bytes(bytes(raw))


@pytest.mark.parametrize("method", METHODS)
def test_every_method_reads_and_seeks(tmp_path, method):
    members = _data()
    path = _archive(tmp_path / "a.zip", members, method)
    for name, data in members.items():
        with _open(path, name) as stream:
            assert stream.read() == data
            stream.seek(1234)
            assert stream.read(7) == data[1234:1241]
            stream.seek(3)
            assert stream.read(2) == data[3:5] and stream.tell() == min(5, len(data))
            # Forward over several steps, from the end and back again.
            assert stream.seek(150_000) == min(150_000, len(data))
            assert stream.read(5) == data[150_000:150_005]
            tail = min(10, len(data))
            assert stream.seek(-tail, 2) == len(data) - tail
            assert stream.read() == data[len(data) - tail:]
            assert stream.seek(len(data) + 5) == len(data) and stream.read() == b""
            stream.seek(0)
            assert stream.read() == data


@pytest.mark.parametrize("method", UNBOUNDED)
def test_bzip2_and_lzma_refused(tmp_path, method):
    path = _archive(tmp_path / "b.zip", {"m": b"spectral " * 1000}, method)
    with pytest.raises(ZipError, match=rf"b.zip: member 'm' is compressed with "
                                       rf"{UNBOUNDED[method]}; only stored or deflate "
                                       rf"members are read"):
        _open(path, "m")


def test_no_call_inflates_more_than_a_step(tmp_path, monkeypatch):
    data = np.random.default_rng(7).bytes(1 << 20)
    path = _archive(tmp_path / "big.zip", {"m": data})
    asked = []
    read = zipfile.ZipExtFile.read

    def spy(self, n=-1):
        asked.append(n)
        return read(self, n)

    monkeypatch.setattr(zipfile.ZipExtFile, "read", spy)
    with _open(path, "m") as stream:
        assert stream.read() == data
        stream.seek(900_000)  # rewinds, then reads forward (ZipExtFile's own seek: 16 MiB)
        assert stream.read(10) == data[900_000:900_010]
    assert asked and all(0 <= n <= 1 << 16 for n in asked)


@pytest.mark.skipif(not os.path.isdir("/proc/self/fd"), reason="needs /proc/self/fd")
def test_files_are_closed(tmp_path):
    path = _archive(tmp_path / "f.zip", {"m": b"spectral " * 1000})
    before = len(os.listdir("/proc/self/fd"))
    with _open(path, "m") as stream:
        stream.read()
    _patch_central(path, 42, 1)  # the member's local header offset
    with pytest.raises(ZipError, match=r"f.zip: member 'm' is damaged \(BadZipFile: Bad magic "
                                       r"number for file header\)"):
        _open(path, "m")
    assert len(os.listdir("/proc/self/fd")) == before


def test_stored_member_must_hold_its_declared_bytes(tmp_path):
    path = _archive(tmp_path / "s.zip", {"m": bytes(1000)}, zipfile.ZIP_STORED)
    _patch_central(path, 20, 900)  # compressed size
    with pytest.raises(ZipError, match=r"s.zip: member 'm' is stored but declares 1,000 bytes "
                                       r"in 900"):
        _open(path, "m")
    path = _archive(tmp_path / "t.zip", {"m": bytes(1000)}, zipfile.ZIP_STORED)
    _patch_central(path, 20, 10**9)
    _patch_central(path, 24, 10**9)
    with pytest.raises(ZipError, match=r"t.zip: member 'm' declares 1,000,000,000 bytes of data "
                                       r"from offset 0, past the end of the [\d,]+-byte archive"):
        _open(path, "m")


def test_declared_size_limit_and_ratio(tmp_path):
    path = _archive(tmp_path / "z.zip", {"zeros": bytes(8 << 20), "small": bytes(RATIO_FREE_BYTES)})
    with pytest.raises(ZipError, match=r"z.zip: member 'zeros' declares 8,388,608 uncompressed "
                                       r"bytes, over the 1,000-byte limit"):
        _open(path, "zeros", max_bytes=1000)
    with pytest.raises(ZipError, match=r"z.zip: member 'zeros' declares 8,388,608 bytes from "
                                       r"[\d,]+ compressed \([\d,]+:1; at most 64:1"):
        _open(path, "zeros", max_ratio=64)
    with _open(path, "small", max_ratio=64) as stream:  # the first MiB is free of the rule
        assert stream.read() == bytes(RATIO_FREE_BYTES)


def test_encrypted_and_unknown_methods_refused(tmp_path):
    path = _archive(tmp_path / "e.zip", {"m": b"x" * 100})
    _patch_central(path, 8, 0x1, "<H")
    with pytest.raises(ZipError, match="member 'm' is encrypted"):
        _open(path, "m")
    path = _archive(tmp_path / "u.zip", {"m": b"x" * 100})
    _patch_central(path, 10, 99, "<H")
    with pytest.raises(ZipError, match="compression method 99"):
        _open(path, "m")


def test_running_cap_and_crc(tmp_path):
    data = np.random.default_rng(6).bytes(300_000)
    # The central directory says fewer bytes than the stream inflates to: zipfile stops at
    # the declared size, where the CRC of what it gave cannot match.
    path = _archive(tmp_path / "long.zip", {"m": data})
    _patch_central(path, 24, 100_000)
    with pytest.raises(ZipError, match=r"long.zip: member 'm' is damaged \(BadZipFile: Bad "
                                       r"CRC-32 for file 'm'\)"), _open(path, "m") as stream:
        stream.read()
    # ... or more than it holds.
    path = _archive(tmp_path / "short.zip", {"m": data})
    _patch_central(path, 24, 400_000)
    with pytest.raises(ZipError, match=r"short.zip: member 'm' ends after 300,000 of its "
                                       r"declared 400,000 bytes"), _open(path, "m") as stream:
        stream.read()
    path = _archive(tmp_path / "crc.zip", {"m": data})
    _patch_central(path, 16, zlib.crc32(data) ^ 1)
    with pytest.raises(ZipError, match=r"crc.zip: member 'm' is damaged \(BadZipFile: Bad "
                                       r"CRC-32 for file 'm'\)"), _open(path, "m") as stream:
        stream.read()


def test_damaged_stream_is_the_callers_error(tmp_path):
    path = _archive(tmp_path / "d.zip", {"m": b"spectral materials " * 5000})
    raw = bytearray(path.read_bytes())
    raw[40:60] = bytes(20)
    path.write_bytes(bytes(raw))
    with pytest.raises(InvalidBRDFData, match=r"d.zip: member 'm' is damaged \(error: "), \
            _open(path, "m", error=InvalidBRDFData) as stream:
        stream.read()


def test_check_needs_no_reading(tmp_path):
    path = _archive(tmp_path / "c.zip", {"m": b"abc"})
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("m")
    check_zip_member(path, info, path.stat().st_size, max_bytes=3, max_ratio=1)
    with pytest.raises(InvalidBRDFData, match="c.zip: member 'm' declares 3 uncompressed"):
        check_zip_member(path, info, path.stat().st_size, max_bytes=2, max_ratio=1)
