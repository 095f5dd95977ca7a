"""UBO2003 members: one JPEG each, opened lazily, checked against the pixels its bytes can
encode, and decoded to float32 through an 8-bit lookup table."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from .._files import open_zip_member
from .common import MAX_JPEG_PIXELS_PER_BYTE, MAX_MEMBER_RATIO, InvalidBTFData, _Invalid


def _srgb_lut(linear: bool) -> np.ndarray:
    """float32 value of each 8-bit code: code / 255, or its sRGB EOTF when ``linear``."""
    codes = np.arange(256, dtype=np.float64) / 255.0
    if linear:
        import colour

        codes = np.asarray(colour.models.eotf_sRGB(codes), dtype=np.float64)
    return codes.astype(np.float32)


def _jpeg(source, member: str):
    """An opened (not yet decoded) JPEG from a binary stream."""
    from PIL import Image

    try:
        image = Image.open(source, formats=["JPEG"])
    except InvalidBTFData:
        raise
    except Exception as exc:
        raise _Invalid(f"member {member!r} is not a readable JPEG ({type(exc).__name__}: "
                       f"{exc})") from None
    return image


def _member(archive: zipfile.ZipFile, path: Path, info: zipfile.ZipInfo,
            max_member_bytes: int):
    """The member's bytes as a stream, inflated under a running cap (sizes checked first)."""
    return open_zip_member(archive, info, path=path, max_bytes=max_member_bytes,
                           max_ratio=MAX_MEMBER_RATIO, error=InvalidBTFData)


def _check_image(info: zipfile.ZipInfo, image, shape: tuple[int, int] | None,
                 max_member_bytes: int) -> tuple[int, int]:
    """(H, W) of a lazily opened JPEG, checked against the first image's ``shape``, the
    per-image limit and the pixels its member's bytes can encode."""
    width, height = image.size
    if width < 1 or height < 1 or height * width * 3 > max_member_bytes:
        raise _Invalid(f"member {info.filename!r} declares {width}×{height} pixels, over the "
                       f"{max_member_bytes:,}-byte limit per image")
    if shape is not None and (height, width) != shape:
        raise _Invalid(f"member {info.filename!r} is {width}×{height}; the first image is "
                       f"{shape[1]}×{shape[0]}")
    if width * height > MAX_JPEG_PIXELS_PER_BYTE * info.compress_size:
        raise _Invalid(f"member {info.filename!r} claims {width}×{height} pixels in "
                       f"{info.compress_size:,} bytes; a JPEG encodes at most "
                       f"{MAX_JPEG_PIXELS_PER_BYTE} pixels per byte")
    if image.mode not in ("RGB", "L"):
        raise _Invalid(f"member {info.filename!r} has colour mode {image.mode}; RGB or L "
                       "expected")
    return height, width


def _image_shape(archive: zipfile.ZipFile, path: Path, entries: dict,
                 max_member_bytes: int) -> tuple[int, int]:
    """(H, W) shared by every member, from their JPEG headers alone (no pixel decoded)."""
    shape = None
    for key in sorted(entries):
        info = entries[key]
        with _member(archive, path, info, max_member_bytes) as stream:
            shape = _check_image(info, _jpeg(stream, info.filename), shape, max_member_bytes)
    return shape


def _entropy_bytes(data: bytes) -> int:
    """Bytes of entropy-coded data in a JPEG's scans: what its pixels are decoded from.

    Headers, tables, restart markers and anything after the end-of-image marker do not
    count, so padding cannot make a header's claim look backed by data.
    """
    at, total, end = 2, 0, len(data)
    while at + 4 <= end and data[at] == 0xFF:
        marker = data[at + 1]
        if marker == 0xD9:  # end of image
            break
        if marker == 0xFF or marker == 0x01 or 0xD0 <= marker <= 0xD7:  # fill, no length
            at += 1 if marker == 0xFF else 2
            continue
        at += 2 + (data[at + 2] << 8 | data[at + 3])
        if marker != 0xDA:  # not a start of scan
            continue
        start, restarts = at, 0
        while (at := data.find(b"\xff", at)) >= 0 and at + 1 < end:
            following = data[at + 1]
            if following != 0 and not 0xD0 <= following <= 0xD7:
                break
            restarts += following != 0
            at += 2
        at = end if at < 0 else at
        total += at - start - 2 * restarts
    return total


def _decode_member(archive: zipfile.ZipFile, path: Path, info: zipfile.ZipInfo,
                   shape: tuple[int, int], lut: np.ndarray, max_member_bytes: int
                   ) -> np.ndarray:
    """The (H, W, 3) float32 image of one member, checked against ``shape`` (H, W)."""
    with _member(archive, path, info, max_member_bytes) as stream:
        data = stream.read()  # the whole member, so that its CRC is checked
    image = _jpeg(io.BytesIO(data), info.filename)
    height, width = _check_image(info, image, shape, max_member_bytes)
    # The decoder fills what a truncated scan lacks with grey, without an error: the
    # claim must be backed by scan data, not by the member's size.
    coded = _entropy_bytes(data)
    if width * height > MAX_JPEG_PIXELS_PER_BYTE * coded:
        raise _Invalid(f"member {info.filename!r} claims {width}×{height} pixels from "
                       f"{coded:,} bytes of scan data; a JPEG encodes at most "
                       f"{MAX_JPEG_PIXELS_PER_BYTE} pixels per byte")
    try:
        image.load()
        if image.mode != "RGB":
            image = image.convert("RGB")
        codes = np.asarray(image, dtype=np.uint8)
    except Exception as exc:
        raise _Invalid(f"member {info.filename!r} is a damaged JPEG ({type(exc).__name__}: "
                       f"{exc})") from None
    if codes.shape != shape + (3,):
        raise _Invalid(f"member {info.filename!r} decoded to shape {codes.shape}")
    return lut[codes]
