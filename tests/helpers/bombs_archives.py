"""Hostile files for the archive and image readers (EXR, spectral EXR, .npz, UBO BTFs).

Each :class:`Bomb` crafts one file deterministically in well under a second, without
materialising what the file claims to hold: compressed streams of zeros are built from one
compressed block repeated, declared sizes are patched into headers. ``setup`` and ``call``
are code strings for :func:`peak_memory.peak_run` (``PATH`` is the crafted file), and
``decoded_bytes`` is the decoded size of the data the file can really hold: for a file
that the reader must refuse before decoding (a claim its bytes cannot back), that is the
file's own size, rounded up.

Plain Python (no pytest), so that a script can reuse the registry::

    from bombs_archives import BOMBS
    for name, bomb in BOMBS.items():
        path = bomb.make(directory)
"""

from __future__ import annotations

import io
import json
import struct
import zlib
from pathlib import Path

import numpy as np
from peak_memory import MB, Bomb

KB = 1 << 10


# --------------------------------------------------------------------------- zip


def _zip(members: list[tuple[str, int, bytes, int, int, int]]) -> bytes:
    """A zip archive from ``(name, method, stored data, crc, compress_size, file_size)``;
    the sizes are written as given (they may lie about ``stored data``)."""
    out = io.BytesIO()
    central = io.BytesIO()
    for name, method, data, crc, csize, usize in members:
        raw = name.encode()
        offset = out.tell()
        out.write(struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, method, 0, 0x21, crc,
                              csize, usize, len(raw), 0) + raw + data)
        central.write(struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, method, 0,
                                  0x21, crc, csize, usize, len(raw), 0, 0, 0, 0, 0, offset)
                      + raw)
    start, size = out.tell(), central.tell()
    out.write(central.getvalue())
    out.write(struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, len(members), len(members), size,
                          start, 0))
    return out.getvalue()


def _deflated_zeros(prefix: bytes, zeros: int) -> tuple[bytes, int]:
    """(raw deflate stream, CRC-32) of ``prefix`` followed by ``zeros`` zero bytes.

    Every full flush resets the compressor's history, so one flushed MiB of zeros is the
    same block wherever it stands and the stream is that block repeated.
    """
    block = bytes(MB)
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    head = compressor.compress(prefix) + compressor.flush(zlib.Z_FULL_FLUSH)
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    repeated = compressor.compress(block) + compressor.flush(zlib.Z_FULL_FLUSH)
    whole, rest = divmod(zeros, MB)
    compressor = zlib.compressobj(9, zlib.DEFLATED, -15)
    tail = compressor.compress(bytes(rest)) + compressor.flush(zlib.Z_FINISH)
    crc = zlib.crc32(prefix)
    for _ in range(whole):
        crc = zlib.crc32(block, crc)
    crc = zlib.crc32(bytes(rest), crc)
    return head + repeated * whole + tail, crc


def _npy_header(shape: tuple[int, ...], descr: str = "<f4") -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue()


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, array, allow_pickle=False)
    return buffer.getvalue()


def _stored(name: str, data: bytes) -> tuple[str, int, bytes, int, int, int]:
    return name, 0, data, zlib.crc32(data), len(data), len(data)


# --------------------------------------------------------------------------- EXR

_FLOAT = 2
_NO_COMPRESSION, _ZIP_COMPRESSION = 0, 3


def _attribute(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def _exr_header(channels: list[str], width: int, height: int, compression: int) -> bytes:
    chlist = b"".join(name.encode() + b"\0" + struct.pack("<iB3xii", _FLOAT, 0, 1, 1)
                      for name in sorted(channels)) + b"\0"
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    return (b"\x76\x2f\x31\x01" + struct.pack("<I", 2)
            + _attribute("channels", "chlist", chlist)
            + _attribute("compression", "compression", bytes([compression]))
            + _attribute("dataWindow", "box2i", window)
            + _attribute("displayWindow", "box2i", window)
            + _attribute("lineOrder", "lineOrder", b"\0")
            + _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
            + _attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
            + _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0))
            + b"\0")


def _exr_zip_chunk(raw: bytes) -> bytes:
    """OpenEXR's ZIP chunk coding: bytes split into even/odd halves, a byte-difference
    predictor, then zlib (ImfZip.cpp)."""
    data = np.frombuffer(raw, dtype=np.uint8)
    split = np.concatenate([data[0::2], data[1::2]]).astype(np.int16)
    predicted = split.copy()
    predicted[1:] = (split[1:] - split[:-1] + 384) & 0xFF
    return zlib.compress(predicted.astype(np.uint8).tobytes(), 9)


def _exr_zeros(channels: list[str], width: int, height: int) -> bytes:
    """A valid ZIP-compressed float EXR of zeros: one compressed chunk of 16 rows, repeated."""
    header = _exr_header(channels, width, height, _ZIP_COMPRESSION)
    row = width * 4 * len(channels)
    full = _exr_zip_chunk(bytes(16 * row))
    blocks = [full] * (height // 16)
    if height % 16:
        blocks.append(_exr_zip_chunk(bytes(height % 16 * row)))
    offsets, position = [], len(header) + 8 * len(blocks)
    for block in blocks:
        offsets.append(position)
        position += 8 + len(block)
    table = struct.pack(f"<{len(blocks)}Q", *offsets)
    body = b"".join(struct.pack("<ii", 16 * i, len(block)) + block
                    for i, block in enumerate(blocks))
    return header + table + body


def make_exr_zip_bomb(directory: Path) -> Path:
    """8192×8192 RGB float32 zeros (805 MB decoded) in 0.8 MB of ZIP chunks."""
    path = Path(directory) / "exr_zip_bomb.exr"
    path.write_bytes(_exr_zeros(["R", "G", "B"], 8192, 8192))
    return path


def make_exr_huge_window(directory: Path) -> Path:
    """An uncompressed one-channel EXR whose dataWindow is 16384×16384 (exactly the pixel
    limit: 1 GiB of float32) but whose file stops after the chunk table: no pixel is there."""
    path = Path(directory) / "exr_huge_window.exr"
    width = height = 16384
    header = _exr_header(["Y"], width, height, _NO_COMPRESSION)
    start = len(header) + 8 * height
    table = struct.pack(f"<{height}Q", *(start + y * (8 + 4 * width) for y in range(height)))
    path.write_bytes(header + table)
    return path


def make_spectral_exr_bomb(directory: Path) -> Path:
    """A reflective spectral EXR of 8192×8192 × 4 wavelengths (2^28 samples, the reader's
    limit: 1 GiB float32) of zeros in 1 MB of ZIP chunks."""
    path = Path(directory) / "spectral_exr_bomb.exr"
    names = [f"T.{w},000000nm" for w in (400, 500, 600, 700)]
    path.write_bytes(_exr_zeros(names, 8192, 8192))
    return path


# --------------------------------------------------------------------------- .npz

_RESOLUTION = (90, 180, 90)


def _npz_meta() -> bytes:
    meta = {"format": "spectral_materials.tabulated_brdf", "version": 1,
            "parameterization": "io_iso", "resolution": list(_RESOLUTION), "description": ""}
    return _npy(np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8))


def make_npz_declared_size(directory: Path) -> Path:
    """A stored ``values`` member whose .npy header and zip sizes both declare 3.9 GB
    (1,458,000 cells × 668 wavelengths float32) while the archive holds 4 KiB of it."""
    path = Path(directory) / "npz_declared_size.npz"
    wl = np.linspace(200.0, 2000.0, 668)
    header = _npy_header(_RESOLUTION + (wl.size,))
    declared = len(header) + int(np.prod(_RESOLUTION)) * wl.size * 4
    present = header + bytes(4 * KB)
    values = ("values.npy", 0, present, zlib.crc32(present), declared, declared)
    path.write_bytes(_zip([_stored("meta.npy", _npz_meta()),
                           _stored("wavelengths.npy", _npy(wl)), values]))
    return path


def make_npz_deflate_bomb(directory: Path) -> Path:
    """A deflated ``values`` member: 1.1 GB of float32 zeros (1,458,000 cells × 190
    wavelengths, a valid BRDF of 0) in 1.1 MB."""
    path = Path(directory) / "npz_deflate_bomb.npz"
    wl = np.linspace(200.0, 2000.0, 190)
    header = _npy_header(_RESOLUTION + (wl.size,))
    zeros = int(np.prod(_RESOLUTION)) * wl.size * 4
    stream, crc = _deflated_zeros(header, zeros)
    values = ("values.npy", 8, stream, crc, len(stream), len(header) + zeros)
    path.write_bytes(_zip([_stored("meta.npy", _npz_meta()),
                           _stored("wavelengths.npy", _npy(wl)), values]))
    return path


# --------------------------------------------------------------------------- UBO2003


def _jpeg(size: tuple[int, int], value=(128, 64, 32)) -> bytes:
    from PIL import Image

    buffer = io.BytesIO()
    Image.new("RGB", size, value).save(buffer, format="JPEG", quality=90)
    return buffer.getvalue()


def _ubo_name(tl: int, pl: int, tv: int, pv: int) -> str:
    return f"tl{tl:03d} pl{pl:03d} tv{tv:03d} pv{pv:03d}.jpg"


def make_ubo2003_size_claim(directory: Path) -> Path:
    """11 members of one view: 8×8 JPEGs, the first patched to claim 4096×4096 (the whole
    (1, 11, 4096, 4096, 3) float32 array would be 2.2 GB) in 8 KB."""
    path = Path(directory) / "ubo2003_size_claim.zip"
    small = _jpeg((8, 8))
    claim = bytearray(small)
    sof = claim.index(b"\xff\xc0")
    claim[sof + 5: sof + 9] = struct.pack(">HH", 4096, 4096)
    members = [_stored(_ubo_name(5 * i, 0, 0, 0), bytes(claim) if i == 0 else small)
               for i in range(11)]
    path.write_bytes(_zip(members))
    return path


def make_ubo2003_fake_claims(directory: Path) -> Path:
    """11 stored members whose 8×8 JPEGs claim 2048×2048 and are padded to the 8 KiB such
    a claim needs at 512 pixels per byte: every header passes, no image decodes, and the
    (1, 11, 2048, 2048, 3) float32 array would be 553 MB for a 93 KB archive."""
    path = Path(directory) / "ubo2003_fake_claims.zip"
    claim = bytearray(_jpeg((8, 8)))
    sof = claim.index(b"\xff\xc0")
    claim[sof + 5: sof + 9] = struct.pack(">HH", 2048, 2048)
    padded = bytes(claim) + bytes(2048 * 2048 // 512 - len(claim) + 16)
    members = [_stored(_ubo_name(5 * i, 0, 0, 0), padded) for i in range(11)]
    path.write_bytes(_zip(members))
    return path


def make_ubo2003_diagonal(directory: Path) -> Path:
    """300 members, view i with light i only: a 300 × 300 set of 24×24 images of which
    300 are present (the dense float32 array would be 622 MB for 2 MB of images)."""
    path = Path(directory) / "ubo2003_diagonal.zip"
    image = _jpeg((24, 24))
    angles = [(t, p) for t in range(0, 91, 10) for p in range(0, 360, 12)][:300]
    members = [_stored(_ubo_name(t, p, t, p), image) for t, p in angles]
    path.write_bytes(_zip(members))
    return path


def make_ubo2003_zip_bomb(directory: Path) -> Path:
    """Four deflated members, each a valid 8×8 JPEG followed by zeros up to 64 MiB (the
    default per-member limit), 65 KB each compressed: the images are 3 KB decoded."""
    path = Path(directory) / "ubo2003_zip_bomb.zip"
    image = _jpeg((8, 8))
    stream, crc = _deflated_zeros(image, 64 * MB - len(image))
    members = [(_ubo_name(tl, 0, tv, 0), 8, stream, crc, len(stream), 64 * MB)
               for tl in (0, 30) for tv in (0, 30)]
    path.write_bytes(_zip(members))
    return path


# --------------------------------------------------------------------------- UBO2014


def make_ubo2014_declared_size(directory: Path) -> Path:
    """An FMF0 file of 151 × 151 directions at 512×512 texels whose factor block declares
    10^4 components (19 GB of float32 factors) in 183 KB."""
    from spectral_materials.core.formats.ubo_btf import write_ubo2014

    path = Path(directory) / "ubo2014_declared_size.btf"
    angles = np.radians(np.stack([np.linspace(0, 80, 151), np.zeros(151)], axis=1))
    write_ubo2014(path, view_angles=angles, light_angles=angles, width=1, height=1,
                  u=np.zeros((151 * 151 * 3, 1)), sxv=np.zeros((1, 1)))
    data = bytearray(path.read_bytes())
    block = len(data) - 4 * (1 + 151 * 151 * 3 + 1) - 17  # k0, size, k1, rows, cols
    k0, size, k1, rows, _ = struct.unpack_from("<IBIII", data, block)
    assert (k0, size, k1, rows) == (1, 4, 1, 151 * 151 * 3)
    struct.pack_into("<IBIII", data, block, 10_000, 4, 10_000, rows, 512 * 512)
    data[block - 8: block] = struct.pack("<II", 512, 512)
    path.write_bytes(bytes(data[: block + 17]))
    return path


_EXR = "from spectral_materials.core.formats import exr"
_SPECTRAL = "from spectral_materials.core.formats import spectral_exr"
_TABULATED = "from spectral_materials.core.formats import tabulated"
_UBO = "from spectral_materials.core.formats import ubo_btf"

BOMBS: dict[str, Bomb] = {
    "exr_zip_bomb": Bomb(make_exr_zip_bomb, _EXR, "exr.read_exr(PATH)", 1 * MB,
                         "refused up front: holds its 0.8 MB"),
    "exr_huge_window": Bomb(make_exr_huge_window, _EXR, "exr.read_exr(PATH)", 256 * KB,
                            "no pixel data at all: holds its 0.13 MB of header and table"),
    "spectral_exr_bomb": Bomb(make_spectral_exr_bomb, _SPECTRAL,
                              "spectral_exr.read_spectral_exr(PATH)", 2 * MB,
                              "refused up front: holds its 1.1 MB"),
    "npz_declared_size": Bomb(make_npz_declared_size, _TABULATED,
                              "tabulated.read_tabulated(PATH)", 16 * KB,
                              "4 KiB of the 3.9 GB declared are present"),
    "npz_deflate_bomb": Bomb(make_npz_deflate_bomb, _TABULATED,
                             "tabulated.read_tabulated(PATH)", 2 * MB,
                             "refused up front: holds its 1.1 MB"),
    "ubo2003_size_claim": Bomb(make_ubo2003_size_claim, _UBO, "ubo_btf.read_ubo2003(PATH)",
                               16 * KB, "the JPEGs hold 8×8 pixels each"),
    "ubo2003_fake_claims": Bomb(make_ubo2003_fake_claims, _UBO, "ubo_btf.read_ubo2003(PATH)",
                                128 * KB, "scans of 8×8 pixels, the rest padding: its 93 KB"),
    "ubo2003_diagonal": Bomb(make_ubo2003_diagonal, _UBO, "ubo_btf.read_ubo2003(PATH)",
                             300 * 24 * 24 * 3 * 4,
                             "300 present 24×24 images as float32 (2.1 MB)"),
    "ubo2003_zip_bomb": Bomb(make_ubo2003_zip_bomb, _UBO, "ubo_btf.read_ubo2003(PATH)",
                             512 * KB,
                             "four 8×8 images (3 KB); the zero padding is no image: its 0.27 MB"),
    "ubo2014_declared_size": Bomb(make_ubo2014_declared_size, _UBO,
                                  "ubo_btf.read_ubo2014(PATH)", 256 * KB,
                                  "refused up front: holds its 0.18 MB"),
}
