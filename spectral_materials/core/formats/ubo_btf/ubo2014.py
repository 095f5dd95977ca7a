"""UBO2014: a ``.btf`` file holding a BTF as truncated SVD factors (DFMF per channel,
FMF0/FMF1 shared), read into :class:`UBO2014BTF`, which reconstructs values on demand."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .common import (
    _DRR_EPS,
    _FLOAT32_MAX,
    _LOG_FLOAT32_MAX,
    MAX_BYTES,
    _check_path,
    _Directions,
    _Invalid,
    _wrap,
)
from .ubo2014_stream import _SIGNATURES, _element_size, _read_common, _Stream

_YUV_TO_RGB = np.array([[1.0, 0.0, 1.13983],
                        [1.0, -0.39465, -0.5806],
                        [1.0, 2.03211, 0.0]])

@dataclass
class UBO2014BTF(_Directions):
    """A UBO2014 BTF held as its SVD factors; values are reconstructed on demand.

    Attributes
    ----------
    signature : str
        ``"DFMF"``, ``"FMF0"`` or ``"FMF1"``.
    header : dict
        ``size``, ``version``, ``measurement_setup``, ``image_sensor``, ``light_source``,
        ``ppmm``, ``rgb_scale``, ``cosine_flag``, ``xml``, ``channels``.
    view_angles, light_angles : ndarray (V, 2), (L, 2) float64
        (θ, φ) in radians, in file order (the view and light indices).
    width, height : int
        Texels.
    data_size : int
        Bytes per stored factor element (2, 4 or 8).
    singular_values : list of ndarray
        One (k,) array per channel (FMF: the same array for every channel).
    u : list of ndarray
        Per channel, (V·L, k): row ``view · L + light``.
    sxv : list of ndarray
        Per channel, (W·H, k), texels stored bottom row first (FMF: shared).
    color_model : int
        0 (plain) or 11 (log-YUV).
    dynamic_range_reduction : bool
        Values are ``log(x + 1e-5)``.
    rotations : ndarray (n, 3, 3) or None
    height_map : ndarray (h, w) uint16 or None
    defects : dict
        ``{"light_lists_differ": n, "non_finite_factors": n, "may_overflow": bool}``: views
        whose light list differs from the first's; NaN/inf factor elements (kept; they make
        the values that use them non-finite); and, for log-encoded values (colour model 11
        or dynamic-range reduction), whether the factors allow a value whose ``exp`` is
        beyond float32 (such texels decode to inf). Factors allowing raw values beyond
        float32 are refused by the reader.
    """

    ANGLES_IN_DEGREES = False

    path: Path | None
    signature: str
    header: dict
    view_angles: np.ndarray
    light_angles: np.ndarray
    width: int
    height: int
    data_size: int
    singular_values: list
    u: list
    sxv: list
    color_model: int = 0
    color_mean: np.ndarray = field(default_factory=lambda: np.zeros(3))
    color_transform: np.ndarray = field(default_factory=lambda: np.eye(3))
    dynamic_range_reduction: bool = False
    rotations: np.ndarray | None = None
    height_map: np.ndarray | None = None
    defects: dict = field(default_factory=dict)

    @property
    def channels(self) -> list[str]:
        return list(self.header["channels"])

    def _finish(self, raw: np.ndarray) -> np.ndarray:
        """Colour model and dynamic-range decoding on the last (channel) axis."""
        with np.errstate(over="ignore", invalid="ignore"):
            if raw.shape[-1] != 3:
                return raw.astype(np.float32)
            out = raw.astype(np.float64)
            if self.color_model == 11:
                y = np.exp(out[..., 0]) - _DRR_EPS
                yuv = np.stack([y, out[..., 1] * y + _DRR_EPS, out[..., 2] * y + _DRR_EPS], -1)
                out = np.clip(yuv @ _YUV_TO_RGB.T, 0.0, 1.0)
            if self.dynamic_range_reduction:
                out = np.exp(out) - _DRR_EPS
            return out.astype(np.float32)

    def _stored_texel(self, x: int, y: int) -> int:
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise IndexError(f"texel ({x}, {y}) outside {self.width}×{self.height}")
        return (self.height - 1 - int(y)) * self.width + int(x)

    def texel(self, x: int, y: int, *, raw: bool = False) -> np.ndarray:
        """(V, L, C) float32 values of texel column ``x``, row ``y`` (row 0 at the top)."""
        t = self._stored_texel(x, y)
        with np.errstate(over="ignore", invalid="ignore"):
            values = np.stack([u.astype(np.float64) @ s[t].astype(np.float64)
                               for u, s in zip(self.u, self.sxv)], axis=-1)
            values = values.reshape(self.view_count, self.light_count, -1)
            return values.astype(np.float32) if raw else self._finish(values)

    def lookup(self, view_index: int, light_index: int, *, raw: bool = False) -> np.ndarray:
        """(H, W, C) float32 image for one (view, light) pair, row 0 at the top."""
        v, l = int(view_index), int(light_index)
        if not (0 <= v < self.view_count and 0 <= l < self.light_count):
            raise IndexError(f"view {view_index} / light {light_index} out of range "
                             f"({self.view_count} views, {self.light_count} lights)")
        row = v * self.light_count + l
        with np.errstate(over="ignore", invalid="ignore"):
            values = np.stack([s.astype(np.float64) @ u[row].astype(np.float64)
                               for u, s in zip(self.u, self.sxv)], axis=-1)
            image = values.reshape(self.height, self.width, -1)[::-1]
            image = image.astype(np.float32) if raw else self._finish(image)
        return np.ascontiguousarray(image)

    def describe(self) -> dict:
        return {
            "format": "UBO2014",
            "signature": self.signature,
            "path": None if self.path is None else str(self.path),
            "views": self.view_count,
            "lights": self.light_count,
            "width": self.width,
            "height": self.height,
            "channels": self.channels,
            "components": [int(u.shape[1]) for u in self.u],
            "data_size": self.data_size,
            "color_model": self.color_model,
            "dynamic_range_reduction": self.dynamic_range_reduction,
            "cosine_flag": self.header["cosine_flag"],
            "defects": dict(self.defects),
        }


def _finite_abs(block: np.ndarray) -> np.ndarray:
    """|block| in float64 with NaN/inf as 0 (they are counted apart)."""
    block = block.astype(np.float64)
    return np.where(np.isfinite(block), np.abs(block), 0.0)


def _value_bound(us: list, sxvs: list, rows: int = 1 << 12) -> float:
    """The largest magnitude ``Σₖ U[r, k] · SxV[t, k]`` can reach from the finite factors:
    exact over the rows r, by the largest |SxV| of each component over the texels t.
    Computed in blocks of rows, so no float64 copy of a factor matrix is made."""
    bound = 0.0
    scales: dict[int, np.ndarray] = {}
    with np.errstate(over="ignore", invalid="ignore"):
        for u, sxv in zip(us, sxvs, strict=True):
            if id(sxv) not in scales:  # FMF shares one S·V between the channels
                scales[id(sxv)] = np.max([_finite_abs(sxv[i: i + rows]).max(axis=0)
                                          for i in range(0, sxv.shape[0], rows)], axis=0)
            scale = scales[id(sxv)]
            for i in range(0, u.shape[0], rows):
                bound = max(bound, float((_finite_abs(u[i: i + rows]) @ scale).max()))
    return bound if math.isfinite(bound) else math.inf


def _read_signature(s: _Stream) -> bytes:
    """The FourCC after ``!``, checked with the tail that must follow it."""
    if s.read(1, "magic") != b"!":
        raise _Invalid("not a UBO2014 BTF: it does not start with '!'")
    fourcc = s.read(4, "signature")
    if fourcc not in _SIGNATURES:
        raise _Invalid(f"signature {fourcc!r} is not DFMF, FMF0 or FMF1")
    tail = _SIGNATURES[fourcc]
    if s.read(len(tail), "signature tail") != tail:
        raise _Invalid(f"{fourcc.decode()} must be followed by {tail.decode()!r}")
    return fourcc


def _read_dfmf_factors(s: _Stream, common: dict, extra: dict) -> tuple[int, list, list, list]:
    """DFMF: the colour model, then one factor block per channel (sizes checked first).
    Returns (element size, singular values, U, S·V), one array per channel each."""
    channels = len(common["header"]["channels"])
    views, lights = common["view_angles"].shape[0], common["light_angles"].shape[0]
    texels = common["width"] * common["height"]
    s.u32("component count")
    extra["color_model"] = s.u32("colour model")
    extra["color_mean"] = s.f32(3, "colour mean")
    extra["color_transform"] = s.f32(9, "colour transform").reshape(3, 3)
    data_size = 0
    svals, us, sxvs = [], [], []
    for c in range(channels):
        size = s.u8(f"channel {c} element size")
        dtype = _element_size(size)
        if data_size and size != data_size:
            raise _Invalid(f"channel {c} has {size}-byte elements, channel 0 has "
                           f"{data_size}")
        data_size = size
        k = s.u32(f"channel {c} component count")
        rows, cols = s.u32(f"channel {c} rows"), s.u32(f"channel {c} columns")
        if k < 1:
            raise _Invalid(f"channel {c} has 0 components")
        if rows != views * lights:
            raise _Invalid(f"channel {c} has {rows:,} rows; {views} views × {lights} "
                           f"lights need {views * lights:,}")
        if cols != texels:
            raise _Invalid(f"channel {c} has {cols:,} columns; the "
                           f"{common['width']}×{common['height']} image needs "
                           f"{texels:,}")
        needed = (1 + rows + cols) * k * size
        if needed > s.left:
            raise _Invalid(f"truncated: channel {c}'s factors ({k} components) need "
                           f"{needed:,} bytes, {s.left:,} left")
        svals.append(s.array(dtype, (k,), f"channel {c} singular values"))
        us.append(s.array(dtype, (rows, k), f"channel {c} U"))
        sxvs.append(s.array(dtype, (cols, k), f"channel {c} S·V"))
    return data_size, svals, us, sxvs


def _read_fmf1_extension(s: _Stream, extra: dict) -> None:
    """FMF1's extension header: the dynamic-range flag and a height map (versions 0..2)."""
    ext = s.u8("extension header version")
    if ext >= 3:
        raise _Invalid(f"FMF1 extension header version {ext} is not supported "
                       "(0..2)")
    if ext >= 1:
        extra["dynamic_range_reduction"] = bool(s.u32("dynamic range flag"))
    if ext >= 2:
        hw, hh = s.u32("height map width"), s.u32("height map height")
        if hw and hh:
            extra["height_map"] = s.array(np.dtype("<u2"), (hh, hw), "height map")


def _read_fmf_factors(s: _Stream, fourcc: bytes, common: dict, extra: dict
                      ) -> tuple[int, list, list, list]:
    """FMF0/FMF1: one factor block whose U rows interleave the channels and whose S·V
    all channels share. Returns (element size, singular values, U, S·V) per channel."""
    channels = len(common["header"]["channels"])
    views, lights = common["view_angles"].shape[0], common["light_angles"].shape[0]
    texels = common["width"] * common["height"]
    if fourcc == b"FMF1":
        _read_fmf1_extension(s, extra)
    k0 = s.u32("component count")
    data_size = s.u8("element size")
    dtype = _element_size(data_size)
    k1 = s.u32("component count (2nd)")
    k = min(k0, k1)
    if k < 1:
        raise _Invalid("the factor block has 0 components")
    rows, cols = s.u32("rows"), s.u32("columns")
    if rows != views * lights * channels:
        raise _Invalid(f"{rows:,} rows; {views} views × {lights} lights × {channels} "
                       f"channels need {views * lights * channels:,}")
    if cols != texels:
        raise _Invalid(f"{cols:,} columns; the {common['width']}×{common['height']} "
                       f"image needs {texels:,}")
    needed = (1 + rows + cols) * k * data_size
    if needed > s.left:
        raise _Invalid(f"truncated: the factors ({k} components) need {needed:,} "
                       f"bytes, {s.left:,} left")
    sv = s.array(dtype, (k,), "singular values")
    u = s.array(dtype, (rows, k), "U").reshape(views * lights, channels, k)
    sxv = s.array(dtype, (cols, k), "S·V")
    return data_size, [sv] * channels, [u[:, c, :] for c in range(channels)], [sxv] * channels


def _check_values(us: list, sxvs: list, channels: int, extra: dict, defects: dict) -> None:
    """Count non-finite factors, refuse unsupported colour models and factors whose values
    overflow float32, and flag log-encoded values whose ``exp`` may overflow."""
    bad = sum(int((~np.isfinite(a)).sum()) for a in {id(a): a for a in us + sxvs}.values())
    defects["non_finite_factors"] = bad
    model = extra.get("color_model", 0)
    if model not in (0, 11) or (model == 11 and channels != 3):
        raise _Invalid(f"colour model {model} with {channels} channels is not supported "
                       "(0, or 11 = log-YUV with 3 channels)")
    bound = _value_bound(us, sxvs)
    if bound > _FLOAT32_MAX:
        raise _Invalid(f"its factors reach values up to {bound:.3g} (Σₖ |U|·max|S·V|), beyond "
                       f"float32's {_FLOAT32_MAX:.3g}: reconstructed texels would overflow")
    log_encoded = model == 11 or extra.get("dynamic_range_reduction", False)
    defects["may_overflow"] = bool(log_encoded and bound > _LOG_FLOAT32_MAX)


def _read_ubo2014(path: Path, max_bytes: int) -> UBO2014BTF:
    with open(path, "rb") as handle:
        s = _Stream(handle, path.stat().st_size, max_bytes)
        fourcc = _read_signature(s)
        common = _read_common(s)
        extra: dict = {}
        if fourcc == b"DFMF":
            data_size, svals, us, sxvs = _read_dfmf_factors(s, common, extra)
        else:
            data_size, svals, us, sxvs = _read_fmf_factors(s, fourcc, common, extra)
        if s.left:
            raise _Invalid(f"{s.left:,} unexpected bytes after the factor block "
                           f"(offset {s.pos:,})")
    _check_values(us, sxvs, len(common["header"]["channels"]), extra, common["defects"])
    return UBO2014BTF(path=path, signature=fourcc.decode(), header=common["header"],
                      view_angles=common["view_angles"], light_angles=common["light_angles"],
                      width=common["width"], height=common["height"], data_size=data_size,
                      singular_values=svals, u=us, sxv=sxvs, rotations=common["rotations"],
                      defects=common["defects"], **extra)


def read_ubo2014(path: str | Path, *, max_bytes: int = MAX_BYTES) -> UBO2014BTF:
    """Read a UBO2014 ``.btf`` file (``!DFMF``, ``!FMF0`` or ``!FMF1``).

    Every count and size is checked against the bytes left in the file, and the factor
    arrays against ``max_bytes``, before anything is allocated; the file must end exactly
    after the factor block. Raises :class:`InvalidBTFData` naming the file and the problem,
    or :class:`BTFFileNotFound`.
    """
    path = _check_path(path)
    if max_bytes < 1:
        raise ValueError("max_bytes must be positive")
    return _wrap(path, _read_ubo2014, path, int(max_bytes))
