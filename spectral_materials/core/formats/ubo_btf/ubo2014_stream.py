"""UBO2014 files as a bounds-checked stream: every count and size is checked against the
bytes left before it is read, and the common header, the view and light angles and the
rotations that every signature shares."""

from __future__ import annotations

import io
import math
import struct

import numpy as np

from .common import MAX_CHANNELS, _Invalid

_SIGNATURES = {b"DFMF": b"08FC", b"FMF0": b"6FC", b"FMF1": b"2FCE"}
_DTYPES = {2: np.dtype("<f2"), 4: np.dtype("<f4"), 8: np.dtype("<f8")}

class _Stream:
    """Bounds-checked little-endian reads from a file of known size."""

    def __init__(self, handle, size: int, max_bytes: int) -> None:
        self.handle = handle
        self.size = size
        self.pos = 0
        self.budget = max_bytes

    @property
    def left(self) -> int:
        return self.size - self.pos

    def read(self, n: int, what: str) -> bytes:
        if n < 0 or n > self.left:
            raise _Invalid(f"truncated: {what} needs {n:,} bytes at offset {self.pos:,}, "
                           f"{self.left:,} left")
        data = self.handle.read(n)
        if len(data) != n:
            raise _Invalid(f"truncated while reading {what} at offset {self.pos:,}")
        self.pos += n
        return data

    def u8(self, what: str) -> int:
        return self.read(1, what)[0]

    def u32(self, what: str) -> int:
        return struct.unpack("<I", self.read(4, what))[0]

    def f32(self, n: int, what: str) -> np.ndarray:
        return np.frombuffer(self.read(4 * n, what), dtype="<f4").astype(np.float64)

    def text(self, n: int, what: str) -> str:
        return self.read(n, what).split(b"\0", 1)[0].decode("latin-1")

    def array(self, dtype: np.dtype, shape: tuple[int, ...], what: str) -> np.ndarray:
        count = math.prod(shape)
        nbytes = count * dtype.itemsize
        if nbytes > self.left:
            raise _Invalid(f"truncated: {what} {shape} of {dtype.itemsize}-byte elements needs "
                           f"{nbytes:,} bytes at offset {self.pos:,}, {self.left:,} left")
        if nbytes > self.budget:
            raise _Invalid(f"{what} {shape} needs {nbytes:,} bytes, over the remaining "
                           f"{self.budget:,} of the max_bytes limit")
        self.budget -= nbytes
        out = np.empty(count, dtype=dtype)
        if self.handle.readinto(memoryview(out).cast("B")) != nbytes:
            raise _Invalid(f"truncated while reading {what} at offset {self.pos:,}")
        self.pos += nbytes
        return out.reshape(shape)


def _read_header(s: _Stream) -> dict:
    """The common header, whose size field must match the fields its version has."""
    start = s.pos
    size = s.u32("header size")
    version = s.u32("header version")
    header = {
        "size": size,
        "version": version,
        "measurement_setup": s.text(80, "measurement setup"),
        "image_sensor": s.text(80, "image sensor"),
        "light_source": s.text(80, "light source"),
        "ppmm": float(s.f32(1, "PPMM")[0]),
        "rgb_scale": [float(v) for v in s.f32(3, "RGB scale")],
        "cosine_flag": s.u32("cosine flag") if version > 1 else 0,
        "xml": "",
        "channels": ["R", "G", "B"],
    }
    if version > 2:
        length = s.u32("XML length")
        header["xml"] = s.read(length, "XML").decode("utf-8", errors="replace")
    if version > 3:
        count = s.u32("channel count")
        if not 1 <= count <= MAX_CHANNELS:
            raise _Invalid(f"channel count {count} is not 1..{MAX_CHANNELS}")
        header["channels"] = [s.text(s.u32("channel name length"), "channel name")
                              for _ in range(count)]
    if s.pos - start != size:
        raise _Invalid(f"the header's size field says {size:,} bytes but its fields "
                       f"(version {version}) take {s.pos - start:,}")
    return header


def _read_directions(s: _Stream) -> tuple[np.ndarray, np.ndarray, int]:
    """(view angles, the first view's light angles, how many views' light lists differ)."""
    views = s.u32("view count")
    if views < 1 or views * 12 > s.left:
        raise _Invalid(f"view count {views:,} is impossible for the {s.left:,} bytes left")
    view_angles = np.empty((views, 2))
    light_angles = None
    differ = 0
    for v in range(views):
        view_angles[v] = s.f32(2, f"view {v} angles")
        count = s.u32(f"view {v} light count")
        if count < 1 or count * 8 > s.left:
            raise _Invalid(f"view {v} declares {count:,} lights, impossible for the "
                           f"{s.left:,} bytes left")
        if light_angles is not None and count != light_angles.shape[0]:
            raise _Invalid(f"view {v} has {count} lights, view 0 has {light_angles.shape[0]}")
        lights = s.f32(2 * count, f"view {v} light angles").reshape(count, 2)
        if light_angles is None:
            light_angles = lights
        elif not np.array_equal(lights, light_angles):
            differ += 1
    for label, angles in (("view", view_angles), ("light", light_angles)):
        if not np.isfinite(angles).all() or (angles[:, 0] < -1e-3).any() \
                or (angles[:, 0] > np.pi / 2 + 1e-3).any():
            raise _Invalid(f"{label} angles must be finite with θ in [0, π/2] radians")
    return view_angles, light_angles, differ


def _read_common(s: _Stream) -> dict:
    """Everything before the factor block: header, angles, image size, rotations."""
    rotations_flag = s.read(1, "rotation flag") == b"R"
    if not rotations_flag:
        s.handle.seek(-1, io.SEEK_CUR)
        s.pos -= 1
    header = _read_header(s)
    view_angles, light_angles, differ = _read_directions(s)
    width = s.u32("width")
    height = s.u32("height")
    if width < 1 or height < 1:
        raise _Invalid(f"image size {width}×{height} is empty")
    rotations = None
    if rotations_flag:
        count = s.u32("rotation count")
        if count * 36 > s.left:
            raise _Invalid(f"{count:,} rotations do not fit in the {s.left:,} bytes left")
        rotations = s.f32(9 * count, "rotations").reshape(count, 3, 3)
    return {"header": header, "view_angles": view_angles, "light_angles": light_angles,
            "width": width, "height": height, "rotations": rotations,
            "defects": {"light_lists_differ": differ}}


def _element_size(value: int) -> np.dtype:
    if value not in _DTYPES:
        raise _Invalid(f"factor element size {value} is not 2 (half), 4 (float) or 8 (double)")
    return _DTYPES[value]
