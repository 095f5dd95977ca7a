"""RGL ``.bsdf`` tensor files (Dupuy & Jakob 2018, EPFL material database) as BRDF callables.

Container (``tensor_file``)
---------------------------
Little-endian. 12 bytes of magic ``b"tensor_file\\0"``, two version bytes ``(1, 0)``, a
uint32 field count, then per field: uint16 name length, the name, uint16 ``ndim``, uint8
dtype code (1 u8, 2 i8, 3 u16, 4 i16, 5 u32, 6 i32, 7 u64, 8 i64, 9 f16, 10 f32, 11 f64),
uint64 absolute offset of the data, ``ndim`` × uint64 shape. Data are C-ordered.
(rgl-epfl/brdf-loader ``powitacq.inl`` ``Tensor::Tensor``, lines 722–795; Mitsuba 3
``src/core/tensor.cpp``.) The writers (Mitsuba 3 ``tensor_io.write``, :func:`write_tensor_file`)
put the table first, then each field's data in turn, aligned, one after another.

:func:`read_tensor_file` checks, *before* it reads (or allocates) any data: the magic, the
version, at most :data:`MAX_FIELDS` fields, every dtype code, that every field's offset +
size lies inside the file, that no two fields' data overlap and none overlaps the table
(so all fields together hold at most the file's bytes, and reading them costs no more
memory than the file's size), and that they stay below ``max_bytes``.

Material fields
---------------
``description`` u8[n]; ``jacobian`` u8[1]; ``theta_i``, ``phi_i`` f32 1-D (incident
directions, radians, increasing); ``ndf``, ``sigma`` f32 [nφ, nθ] (over the unit square
(u_θ, u_φ), θ the last axis); ``vndf``, ``luminance`` f32 [φi, θi, ny, nx]; spectral files
``wavelengths`` f32 [L] (nm) and ``spectra`` f32 [φi, θi, L, n, n]; RGB files ``rgb`` f32
[φi, θi, 3, n, n] instead. Shape rules as the reference's ``BRDF::BRDF`` (``powitacq.inl``
906–948; Mitsuba 3 ``measured.cpp``), plus: every grid ≥ 2 × 2 (the reference's
interpolants divide by ``size − 1``), strictly increasing ``theta_i``/``phi_i``/
``wavelengths``, each vndf slice with a positive integral.

The file is *isotropic* when ``phi_i`` has ≤ 2 entries (``powitacq.inl`` 952). Otherwise
its φi span gives the symmetry ``reduction = rint(2π / (φi[-1] − φi[0]))``: 1 (full circle;
the only one powitacq accepts, 955–961), 2 or 4, which Mitsuba 3 handles by folding wi and
wo into the measured range (``mulsign_neg``: reduction 2 rotates the pair by π when
wi.y ≥ 0, reduction 4 mirrors x and y separately). Other values are refused. Isotropic
files are not folded (powitacq has no folding; Mitsuba 3 leaves ``m_reduction``
uninitialised for them, ``measured.cpp`` 168–172, so its folding there depends on stale
memory — observed to act as reduction 4 in 3.9.1; both agree with this reader whenever
wi.x < 0 and wi.y < 0, where every folding is the identity).

Evaluation (``powitacq.inl`` ``BRDF::eval`` 1067–1102; Mitsuba 3 ``Measured::eval``)
--------------------------------------------------------------------------------
* 0 unless ``wi.z > 0`` and ``wo.z > 0``; inputs are normalised.
* wm = normalize(wi + wo); θ = 2·asin(|d − ẑ|/2) (``elevation``), φ = atan2(y, x);
  u = (√(2θ/π), (φ + π)/2π) (``theta2u``/``phi2u``, 865–879); for isotropic files the
  half vector's φ is taken relative to φi (φm − φi), wrapped into [0, 1).
* The VNDF warp is inverted at u_m (``Marginal2D::invert``, 431–518: a bilinear density
  per (φi, θi) slice with trapezoid CDFs, the slices interpolated linearly in φi and θi
  with weights clamped to [0, 1], ``find_interval`` 130–150), giving the unit-square
  position ``s`` where the spectra are looked up.
* ``spectra.eval(s, (φi, θi, λ))`` (``Marginal2D::eval`` 524–576, no normalisation):
  bilinear in s, linear in φi, θi and λ.
* If ``jacobian`` is set the value is multiplied by ``ndf.eval(u_m) / (4 σ.eval(u_wi))``.
  Mitsuba 3 does this only when the flag is set; powitacq's ``BRDF::eval`` always does
  (1098–1099). This reader follows Mitsuba (the flag is part of the format); the two agree
  for files with the flag set. No cosine factor is applied by either (Mitsuba's ``eval``
  returns the value without cos θo for this plugin), and none here.
* The result is the BRDF in sr⁻¹, not cosine-weighted.

Wavelengths
-----------
The reference evaluates at its own wavelengths (interpolating linearly between file
wavelengths, clamping outside). :meth:`RGLBSDF.__call__` evaluates at the file's grid and
resamples linearly to the requested ``wavelengths``, **zero outside** the file's range (so
no measured spectrum is extended beyond what was measured); inside the range this is the
reference's value exactly (the interpolation is linear in λ). Negative results (noise in
the measurements) are clamped to 0 by ``__call__``; :meth:`RGLBSDF.eval_native` and
:meth:`RGLBSDF.rgb` return the reference's values unclamped.

RGB files are evaluated per channel (``powitacq_rgb.inl``); ``__call__`` uplifts them to
spectra with Smits (1999) (:class:`spectral_materials.core.formats.merl.SmitsUplift`,
negative channels taken as 0).

Defects
-------
Non-finite samples raise :class:`InvalidBRDFData` (``on_invalid="raise"``) or are set to 0
and counted (``"clamp"``). Negative samples are counted; in the densities (``ndf``,
``sigma``, ``vndf``, ``luminance``) they are set to 0, in ``spectra``/``rgb`` they are
kept as the reference keeps them. Where σ(u_wi) is 0 the value is 0. A file whose
spectra are all zero is refused.

Values no measurement produces are refused whatever ``on_invalid`` says
(:mod:`spectral_materials.core.sample_limits`): a sample of magnitude above 10³⁰ in any of
the float tables, wavelengths outside 10 nm – 100 µm, ``theta_i`` outside [0, π/2] or
``phi_i`` outside [−2π, 2π] (both with 10⁻⁴ rad for float32 rounding), and a
``description`` longer than :data:`MAX_DESCRIPTION_BYTES`.

Memory
------
Fields are read straight into their arrays and cleaned in place; the tables derived from
them (the vndf warp's cumulative sums, one float32 per vndf sample: the marginal CDF shares
the conditional CDF's first column, which is always 0) are built in blocks of
:data:`CHUNK_ELEMENTS`. Reading a file so costs at most about twice its size.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..brdf.params import check_direction_pairs
from ..colour import spectra as _spectra
from ..colour.uplift import SmitsUplift
from ..errors import InvalidBRDFData
from ..sample_limits import WAVELENGTH_LIMITS_NM, describe_extreme
from ._files import atomic_write, read_errors

__all__ = [
    "DTYPE_CODES",
    "MAGIC",
    "MAX_DESCRIPTION_BYTES",
    "MAX_FIELDS",
    "MAX_TENSOR_BYTES",
    "RGLBSDF",
    "read_rgl_bsdf",
    "read_tensor_file",
    "write_tensor_file",
]

MAGIC = b"tensor_file\x00"
VERSION = (1, 0)
#: dtype code → NumPy dtype (little-endian), as the reference's ``Tensor::Type``.
DTYPE_CODES: dict[int, np.dtype] = {
    1: np.dtype("u1"), 2: np.dtype("i1"), 3: np.dtype("<u2"), 4: np.dtype("<i2"),
    5: np.dtype("<u4"), 6: np.dtype("<i4"), 7: np.dtype("<u8"), 8: np.dtype("<i8"),
    9: np.dtype("<f2"), 10: np.dtype("<f4"), 11: np.dtype("<f8"),
}
_CODE_OF = {dt.newbyteorder("<").str: code for code, dt in DTYPE_CODES.items()}
_CODE_NAMES = {1: "u8", 2: "i8", 3: "u16", 4: "i16", 5: "u32", 6: "i32", 7: "u64",
               8: "i64", 9: "f16", 10: "f32", 11: "f64"}
#: Refuse tensor files whose fields add up to more than this many bytes.
MAX_TENSOR_BYTES = 4 << 30
#: Largest ``ndim`` accepted for one field.
MAX_NDIM = 32
#: Most fields accepted in one file. Material files have about ten; each field costs the
#: reader a few hundred bytes of Python objects whatever its size, so without a cap a file
#: of empty fields would cost ten times its size.
MAX_FIELDS = 4096
#: Longest ``description`` accepted, in bytes (real ones are a line of text; decoded, a
#: description can take four times its bytes).
MAX_DESCRIPTION_BYTES = 1 << 20
#: Direction pairs evaluated per chunk.
CHUNK_POINTS = 1 << 14
#: Elements per block when the warp tables are built (float64 temporaries of a few MB).
CHUNK_ELEMENTS = 1 << 18
#: Slack on the incident-angle ranges for float32 rounding (radians).
_ANGLE_SLACK = 1e-4

_HEADER = 12 + 2 + 4
_FIELD_MIN = 2 + 2 + 1 + 8  # an entry with an empty name and ndim = 0


class _Invalid(ValueError):
    """Internal: a parsing problem, re-raised as InvalidBRDFData with the path (a ValueError
    so that an :class:`RGLBSDF` built from bad arrays by hand says what is wrong too)."""


# --------------------------------------------------------------------------- container


def _parse_table(stream, size: int, max_bytes: int) -> list[tuple[str, int, int, tuple]]:
    """Field table → [(name, dtype code, offset, shape)], checked against ``size``."""
    head = stream.read(_HEADER)
    if len(head) != _HEADER:
        raise _Invalid("the header could not be read in full")
    if head[:12] != MAGIC:
        raise _Invalid(f"bad magic {head[:12]!r}, expected {MAGIC!r}: not a tensor_file")
    version = (head[12], head[13])
    if version != VERSION:
        raise _Invalid(f"unsupported tensor_file version {version[0]}.{version[1]} "
                       f"(this reader knows {VERSION[0]}.{VERSION[1]})")
    (n_fields,) = struct.unpack_from("<I", head, 14)
    if n_fields > MAX_FIELDS:
        raise _Invalid(f"{n_fields:,} fields declared; at most {MAX_FIELDS:,} are accepted "
                       "(a material file has about ten)")
    if n_fields * _FIELD_MIN > size - _HEADER:
        raise _Invalid(f"{n_fields:,} fields declared, but only {size - _HEADER:,} bytes follow "
                       "the header: truncated or damaged")
    fields: list[tuple[str, int, int, tuple]] = []
    names: set[str] = set()
    total = 0

    def take(n: int, what: str) -> bytes:
        pos = stream.tell()
        out = stream.read(n) if pos + n <= size else b""
        if len(out) != n:
            raise _Invalid(f"field table ends early (reading {what} at byte {pos:,} of "
                           f"{size:,}): truncated")
        return out

    for i in range(n_fields):
        (name_len,) = struct.unpack("<H", take(2, f"the name length of field {i}"))
        raw = take(name_len, f"the name of field {i}")
        try:
            name = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise _Invalid(f"field {i} has a name that is not UTF-8: {raw[:40]!r}") from None
        ndim, code, offset = struct.unpack("<HBQ", take(11, f"the header of field {name!r}"))
        if code not in DTYPE_CODES:
            raise _Invalid(f"field {name!r} has unknown dtype code {code} (known: 1..11)")
        if ndim > MAX_NDIM:
            raise _Invalid(f"field {name!r} declares {ndim} dimensions (at most {MAX_NDIM})")
        shape = struct.unpack(f"<{ndim}Q", take(8 * ndim, f"the shape of field {name!r}"))
        if any(s > size for s in shape):  # also with a zero elsewhere: no such data
            raise _Invalid(f"field {name!r} declares shape {list(shape)}, a dimension larger "
                           f"than the {size:,}-byte file")
        if name in names:
            raise _Invalid(f"field {name!r} appears twice")
        names.add(name)
        nbytes = DTYPE_CODES[code].itemsize * math.prod(shape)
        # An empty field reads nothing: its offset does not matter (Mitsuba's writer
        # aligns it, which can put it just past the end).
        if nbytes and (offset > size or nbytes > size - offset):
            raise _Invalid(f"field {name!r} ({_CODE_NAMES[code]}{list(shape)}, {nbytes:,} bytes "
                           f"at offset {offset:,}) lies past the end of the {size:,}-byte file")
        total += nbytes
        if total > max_bytes:
            raise _Invalid(f"fields need {total:,} bytes, more than the limit of "
                           f"{max_bytes:,} (max_bytes)")
        fields.append((name, code, offset, tuple(int(s) for s in shape)))
    _check_layout(fields, stream.tell())
    return fields


def _check_layout(fields: list[tuple[str, int, int, tuple]], table_end: int) -> None:
    """No field's data may overlap the table or another field's data.

    The format lays fields out one after another; fields that share bytes would let a
    small file declare (and make the reader allocate) many times its size.
    """
    spans = sorted((offset, offset + DTYPE_CODES[code].itemsize * math.prod(shape), name)
                   for name, code, offset, shape in fields
                   if DTYPE_CODES[code].itemsize * math.prod(shape))
    previous_end, previous = table_end, "the field table"
    for begin, end, name in spans:
        if begin < previous_end:
            raise _Invalid(f"field {name!r} (bytes {begin:,}..{end:,}) overlaps {previous} "
                           f"(which ends at byte {previous_end:,}): fields must not share bytes")
        previous_end, previous = end, f"field {name!r}"


def _read_tensor(path: Path, max_bytes: int) -> dict[str, np.ndarray]:
    size = path.stat().st_size
    if size < _HEADER:
        raise _Invalid(f"{size} bytes: too short for the {_HEADER}-byte tensor_file header")
    with open(path, "rb") as stream:
        table = _parse_table(stream, size, max_bytes)
        out: dict[str, np.ndarray] = {}
        for name, code, offset, shape in table:
            dtype = DTYPE_CODES[code]
            count = math.prod(shape)
            # Straight into the array: no bytes object beside it.
            arr = np.empty(0, dtype) if count == 0 else _read_array(stream, offset, dtype, count)
            if arr.size != count:
                raise _Invalid(f"field {name!r} could not be read in full (file shrank?)")
            out[name] = arr.astype(dtype.newbyteorder("="), copy=False).reshape(shape)
    return out


def _read_array(stream, offset: int, dtype: np.dtype, count: int) -> np.ndarray:
    stream.seek(offset)
    return np.fromfile(stream, dtype=dtype, count=count)


def read_tensor_file(path, *, max_bytes: int = MAX_TENSOR_BYTES) -> dict[str, np.ndarray]:
    """Read every field of a ``tensor_file`` into ``{name: array}`` (native byte order).

    Raises :class:`InvalidBRDFData` naming the file for a wrong magic or version, more than
    :data:`MAX_FIELDS` fields, an unknown dtype code, a truncated field table, a field
    reaching past the end of the file, fields whose data overlap (each other or the table),
    or fields adding up to more than ``max_bytes`` (all checked before anything is read);
    OSError when the file cannot be opened. Memory: the fields' arrays, at most the file's
    size.
    """
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file")
        raise IsADirectoryError(f"{path}: not a regular file")
    with read_errors(path, _Invalid, "fields"):
        return _read_tensor(path, int(max_bytes))


def write_tensor_file(path, fields: Mapping[str, np.ndarray], *,
                      version: tuple[int, int] = VERSION) -> Path:
    """Write ``fields`` (name → array of one of the 11 dtypes) as a ``tensor_file``.

    Data are written little-endian, each field 8-byte aligned, after the table. Written to
    a temporary name and renamed. ``version`` other than (1, 0) is for testing readers.
    """
    path = Path(path)
    arrays = []
    for name, value in fields.items():
        arr = np.asarray(value)
        if arr.dtype == np.bool_:
            arr = arr.astype(np.uint8)
        key = arr.dtype.newbyteorder("<").str
        if key not in _CODE_OF:
            raise ValueError(f"field {name!r}: dtype {arr.dtype} has no tensor_file code")
        arrays.append((name.encode("utf-8"), _CODE_OF[key],
                       np.require(arr.astype(arr.dtype.newbyteorder("<")), requirements="C")))
    table_bytes = _HEADER + sum(2 + len(n) + 11 + 8 * a.ndim for n, _, a in arrays)
    offset = (table_bytes + 7) // 8 * 8
    table = [MAGIC, bytes(version), struct.pack("<I", len(arrays))]
    blobs = []
    for name, code, arr in arrays:
        table.append(struct.pack("<H", len(name)) + name)
        table.append(struct.pack("<HBQ", arr.ndim, code, offset))
        table.append(struct.pack(f"<{arr.ndim}Q", *arr.shape))
        pad = (-arr.nbytes) % 8
        blobs.append(arr.tobytes() + b"\x00" * pad)
        offset += arr.nbytes + pad
    head = b"".join(table)
    head += b"\x00" * ((-len(head)) % 8)
    def write(handle) -> None:
        handle.write(head)
        for blob in blobs:
            handle.write(blob)

    return atomic_write(path, write)


# --------------------------------------------------------------------------- interpolants


def _theta2u(theta):
    return np.sqrt(np.maximum(theta, 0.0) * (2.0 / math.pi))


def _phi2u(phi):
    return (phi + math.pi) / (2.0 * math.pi)


def _elevation(d: np.ndarray) -> np.ndarray:
    """acos(d.z), robustly: 2·asin(|d − ẑ| / 2) as the reference."""
    dist = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2 + (d[:, 2] - 1.0) ** 2)
    return 2.0 * np.arcsin(np.clip(0.5 * dist, -1.0, 1.0))


def _param_weights(values: np.ndarray, q: np.ndarray):
    """Lower index, upper index and weight of the upper one (``find_interval`` + clamp)."""
    n = values.size
    if n == 1:
        zero = np.zeros(q.shape, dtype=np.int64)
        return zero, zero, np.zeros(q.shape)
    i = np.clip(np.searchsorted(values, q, side="right") - 1, 0, n - 2)
    p0 = values[i]
    p1 = values[i + 1]
    w = np.clip((q - p0) / (p1 - p0), 0.0, 1.0)
    return i, i + 1, w


def _corners(phi_grid, theta_grid, phi, theta):
    """The 4 (φi, θi) slice corners: list of (iφ, iθ, weight)."""
    a0, a1, wa = _param_weights(phi_grid, phi)
    b0, b1, wb = _param_weights(theta_grid, theta)
    return [(a0, b0, (1 - wa) * (1 - wb)), (a0, b1, (1 - wa) * wb),
            (a1, b0, wa * (1 - wb)), (a1, b1, wa * wb)]


def _cell(u: np.ndarray, n: int):
    """Cell index (clamped to n − 2) and fraction of unit-square coordinates on n nodes."""
    s = u * (n - 1)
    i = np.minimum(np.floor(s), n - 2).astype(np.int64)
    i = np.maximum(i, 0)
    return i, s - i


def _bilinear(table: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``Marginal2D<0>::eval`` without normalisation: table [ny, nx], u (N, 2) = (x, y)."""
    ny, nx = table.shape
    ix, fx = _cell(u[:, 0], nx)
    iy, fy = _cell(u[:, 1], ny)
    return ((1 - fy) * ((1 - fx) * table[iy, ix] + fx * table[iy, ix + 1])
            + fy * ((1 - fx) * table[iy + 1, ix] + fx * table[iy + 1, ix + 1]))


def _cumulative_trapezoid(src: np.ndarray, out: np.ndarray,
                          block: int = CHUNK_ELEMENTS) -> None:
    """``out[:, j] = Σ_{k<j} ½ (src[:, k] + src[:, k + 1])`` for 2-D ``src`` and ``out``.

    Summed in float64 over blocks of at most ``block`` elements, carrying each row's
    running sum across column blocks, so that no temporary grows with the table (one
    slice, or one row, may be the whole of it).
    """
    m, n = src.shape
    cols = min(n, max(1, block))
    rows = max(1, block // cols)
    for r0 in range(0, m, rows):
        r1 = min(m, r0 + rows)
        carry = np.zeros((r1 - r0, 1))
        last = None  # the previous block's last column
        for c0 in range(0, n, cols):
            piece = src[r0:r1, c0 : c0 + cols].astype(np.float64)
            if last is None:
                steps = 0.5 * (piece[:, 1:] + piece[:, :-1])
                part = np.concatenate([np.zeros((r1 - r0, 1)), np.cumsum(steps, axis=1)], 1)
            else:
                ext = np.concatenate([last, piece], axis=1)
                part = np.cumsum(0.5 * (ext[:, 1:] + ext[:, :-1]), axis=1)
            part += carry
            out[r0:r1, c0 : c0 + cols] = part
            carry, last = part[:, -1:], piece[:, -1:]


@dataclass
class _Warp:
    """``Marginal2D<2>`` (build_cdf) per (φi, θi) slice, in one float32 table beside the data.

    ``cumulative[..., y, x]`` for x ≥ 1 is the conditional CDF along x of row y (at x = 0
    it is 0, so that column is free) and ``cumulative[..., y, 0]`` the marginal CDF along
    y: one float32 per vndf sample in all. Neither is normalised: 1 / ``totals`` (each
    slice's integral) rides on the corner weights, so ``data`` is the vndf itself, not a
    normalised copy. float32 as the references store these tables (powitacq's and
    Mitsuba's ``Marginal2D`` hold ``float``); the sums are taken in float64.
    """

    data: np.ndarray  # [φ, θ, ny, nx], the vndf
    cumulative: np.ndarray  # [φ, θ, ny, nx] float32
    totals: np.ndarray  # [φ, θ] float64

    @classmethod
    def build(cls, vndf: np.ndarray) -> _Warp:
        """Raises a ValueError for a grid under 2 × 2 or a slice without a positive finite
        integral (its warp would be undefined)."""
        phis, thetas, ny, nx = vndf.shape
        if ny < 2 or nx < 2:
            raise _Invalid(f"vndf has a grid of {[ny, nx]}: at least 2 × 2 needed")
        cumulative = np.empty(vndf.shape, np.float32)
        _cumulative_trapezoid(vndf.reshape(-1, nx), cumulative.reshape(-1, nx))
        slices = cumulative.reshape(-1, ny, nx)
        _cumulative_trapezoid(slices[:, :, nx - 1], slices[:, :, 0])
        totals = slices[:, ny - 1, 0].astype(np.float64).reshape(phis, thetas)
        bad = ~(totals > 0) | ~np.isfinite(totals)
        if bad.any():
            j, k = np.argwhere(bad)[0]
            raise _Invalid(f"vndf slice (phi_i[{j}], theta_i[{k}]) has no positive finite "
                           "integral: its warp is undefined")
        return cls(vndf, cumulative, totals)

    def invert(self, u: np.ndarray, corners) -> np.ndarray:
        """``Marginal2D::invert``: density-space u (N, 2) → unit-square sample (N, 2)."""
        ny, nx = self.data.shape[2:]
        ix, fx = _cell(u[:, 0], nx)
        iy, fy = _cell(u[:, 1], ny)
        normalised = [(a, b, w / self.totals[a, b]) for a, b, w in corners]

        def look(arr, y, x):
            return sum(w * arr[a, b, y, x] for a, b, w in normalised)

        cum = self.cumulative
        v00, v10 = look(self.data, iy, ix), look(self.data, iy, ix + 1)
        v01, v11 = look(self.data, iy + 1, ix), look(self.data, iy + 1, ix + 1)
        c0 = (1 - fy) * v00 + fy * v01
        c1 = (1 - fy) * v10 + fy * v11
        x = fx * (c0 + 0.5 * fx * (c1 - c0))
        before = (1 - fy) * look(cum, iy, ix) + fy * look(cum, iy + 1, ix)
        x += np.where(ix > 0, before, 0.0)  # column 0 holds the marginal, not the CDF's 0
        r0 = look(cum, iy, nx - 1)
        r1 = look(cum, iy + 1, nx - 1)
        with np.errstate(divide="ignore", invalid="ignore"):
            x = x / ((1 - fy) * r0 + fy * r1)
        y = fy * (r0 + 0.5 * fy * (r1 - r0))
        y += look(cum, iy, 0)
        out = np.stack([x, y], axis=-1)
        return np.clip(np.nan_to_num(out, nan=0.0, posinf=1.0, neginf=0.0), 0.0, 1.0)


# --------------------------------------------------------------------------- callable


@dataclass
class RGLBSDF:
    """An RGL ``.bsdf`` material as a BRDF callable ``f(wi, wo, wavelengths) -> (N, L)``.

    Attributes
    ----------
    theta_i, phi_i : ndarray
        Incident-direction grid (radians).
    ndf, sigma : ndarray [nφ, nθ]
    vndf, luminance : ndarray [φi, θi, ny, nx]
    values : ndarray [φi, θi, C, n, n]
        ``spectra`` (C = L) or ``rgb`` (C = 3).
    wavelengths : ndarray (L,) or None
        The file's grid in nm; None for RGB files.
    jacobian : bool
    description : str
    defects : dict
        ``nan``, ``inf``, ``negative`` totals and ``fields``: the counts per field.
    """

    theta_i: np.ndarray
    phi_i: np.ndarray
    ndf: np.ndarray
    sigma: np.ndarray
    vndf: np.ndarray
    luminance: np.ndarray
    values: np.ndarray
    wavelengths: np.ndarray | None = None
    jacobian: bool = True
    description: str = ""
    defects: dict = field(default_factory=dict)
    path: Path | None = None

    def __post_init__(self) -> None:
        self.theta_i = np.asarray(self.theta_i, dtype=np.float64)
        self.phi_i = np.asarray(self.phi_i, dtype=np.float64)
        # float32 tables stay float32: lookups promote them to float64 exactly, and a copy
        # would double what they cost.
        self.ndf = _float_table(self.ndf)
        self.sigma = _float_table(self.sigma)
        self.values = np.asarray(self.values, dtype=np.float32)
        self._warp = _Warp.build(np.ascontiguousarray(self.vndf))
        self._resamplers: dict[tuple, np.ndarray] = {}
        self._uplift = SmitsUplift()
        self.reduction = 1
        if not self.isotropic:
            self.reduction = int(np.rint(2 * math.pi / (self.phi_i[-1] - self.phi_i[0])))

    @property
    def isotropic(self) -> bool:
        """As the reference: ``phi_i`` has at most 2 entries."""
        return self.phi_i.size <= 2

    @property
    def is_rgb(self) -> bool:
        return self.wavelengths is None

    @property
    def channels(self) -> int:
        return int(self.values.shape[2])

    # ----------------------------------------------------------------- evaluation

    def _fold(self, wi: np.ndarray, wo: np.ndarray) -> None:
        """Mitsuba's symmetry folding for reduction 2/4 (in place)."""
        if self.reduction < 2:
            return
        sy = wi[:, 1].copy()
        sx = wi[:, 0].copy() if self.reduction == 4 else sy
        mx = np.where(np.signbit(sx), 1.0, -1.0)  # mulsign_neg(v, s) = v·(−sign s)
        my = np.where(np.signbit(sy), 1.0, -1.0)
        for v in (wi, wo):
            v[:, 0] *= mx
            v[:, 1] *= my

    def _native(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Values at the file's channels for lit (N, 3) unit pairs: (N, C)."""
        wi = wi.copy()
        wo = wo.copy()
        self._fold(wi, wo)
        wm = wi + wo
        wm /= np.linalg.norm(wm, axis=1, keepdims=True)
        theta_i = _elevation(wi)
        phi_i = np.arctan2(wi[:, 1], wi[:, 0])
        theta_m = _elevation(wm)
        phi_m = np.arctan2(wm[:, 1], wm[:, 0])
        u_wi = np.stack([_theta2u(theta_i), _phi2u(phi_i)], axis=-1)
        um_y = _phi2u(phi_m - phi_i if self.isotropic else phi_m)
        u_m = np.stack([_theta2u(theta_m), um_y - np.floor(um_y)], axis=-1)

        corners = _corners(self.phi_i, self.theta_i, phi_i, theta_i)
        sample = self._warp.invert(u_m, corners)
        n = self.values.shape[3]
        ix, fx = _cell(sample[:, 0], self.values.shape[4])
        iy, fy = _cell(sample[:, 1], n)
        out = np.zeros((wi.shape[0], self.channels))
        for a, b, w in corners:
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    out += (w * wy * wx)[:, None] * self.values[a, b, :, iy + dy, ix + dx]
        if self.jacobian:
            ndf = _bilinear(self.ndf, u_m)
            sigma = _bilinear(self.sigma, u_wi)
            with np.errstate(divide="ignore", invalid="ignore"):
                scale = np.where(sigma > 0, ndf / (4.0 * sigma), 0.0)
            out *= scale[:, None]
        out[~np.isfinite(out)] = 0.0
        return out

    def eval_native(self, wi, wo) -> np.ndarray:
        """The reference's ``BRDF::eval`` (N, C) at the file's wavelengths (or R, G, B).

        Not clamped; 0 where either direction is at or below the horizon.
        """
        wi, wo = _directions(wi, wo)
        out = np.zeros((wi.shape[0], self.channels))
        lit = np.nonzero((wi[:, 2] > 0) & (wo[:, 2] > 0))[0]
        for begin in range(0, lit.size, CHUNK_POINTS):
            rows = lit[begin : begin + CHUNK_POINTS]
            out[rows] = self._native(wi[rows], wo[rows])
        return out

    def rgb(self, wi, wo) -> np.ndarray:
        """RGB BRDF (N, 3) of an RGB file (unclamped, as the reference)."""
        if not self.is_rgb:
            raise TypeError("rgb() is for RGB files; this one is spectral (call it with "
                            "wavelengths)")
        return self.eval_native(wi, wo)

    def _resampler(self, wl: np.ndarray) -> np.ndarray:
        key = tuple(wl.tolist())
        if key not in self._resamplers:
            own = self.wavelengths
            eye = np.eye(own.size)
            matrix = np.stack([np.interp(wl, own, row, left=0.0, right=0.0) for row in eye])
            if len(self._resamplers) >= 16:
                self._resamplers.pop(next(iter(self._resamplers)))
            self._resamplers[key] = matrix
        return self._resamplers[key]

    def __call__(self, wi, wo, wavelengths) -> np.ndarray:
        """The spectral BRDF (N, L) at ``wavelengths`` (nm), ≥ 0; see the module notes."""
        wl = _spectra.check_wavelengths(wavelengths)
        native = self.eval_native(wi, wo)
        if self.is_rgb:
            return self._uplift(native, wl)
        return np.maximum(native @ self._resampler(wl), 0.0)

    def describe(self) -> dict:
        """JSON-serialisable summary (no samples)."""
        return {
            "format": "rgl_bsdf",
            "path": None if self.path is None else str(self.path),
            "kind": "rgb" if self.is_rgb else "spectral",
            "isotropic": self.isotropic,
            "reduction": self.reduction,
            "jacobian": bool(self.jacobian),
            "theta_i": int(self.theta_i.size),
            "phi_i": int(self.phi_i.size),
            "resolution": list(self.values.shape[3:]),
            "wavelengths": None if self.is_rgb else [
                float(self.wavelengths[0]), float(self.wavelengths[-1]),
                int(self.wavelengths.size)],
            "description": self.description,
            "defects": dict(self.defects),
        }


def _float_table(table) -> np.ndarray:
    arr = np.asarray(table)
    return arr if arr.dtype in (np.float32, np.float64) else arr.astype(np.float64)


def _directions(wi, wo) -> tuple[np.ndarray, np.ndarray]:
    """Checked (params.check_direction_pairs) and normalised; zero vectors refused."""
    wi, wo = check_direction_pairs(wi, wo)
    ni = np.linalg.norm(wi, axis=1, keepdims=True)
    no = np.linalg.norm(wo, axis=1, keepdims=True)
    if np.any(ni == 0) or np.any(no == 0):
        raise ValueError("wi/wo contain zero vectors")
    return wi / ni, wo / no


# --------------------------------------------------------------------------- reading


_DENSITIES = ("ndf", "sigma", "vndf", "luminance")


def _field(fields, name, ndim, dtype=np.float32) -> np.ndarray:
    if name not in fields:
        raise _Invalid(f"required field {name!r} is missing (fields: {sorted(fields)})")
    arr = fields[name]
    if arr.dtype != np.dtype(dtype):
        raise _Invalid(f"field {name!r} has dtype {arr.dtype}, the format needs "
                       f"{np.dtype(dtype)}")
    if arr.ndim != ndim:
        raise _Invalid(f"field {name!r} has {arr.ndim} dimensions {list(arr.shape)}, "
                       f"the format needs {ndim}")
    return arr


def _axis(arr: np.ndarray, name: str) -> np.ndarray:
    if arr.size == 0:
        raise _Invalid(f"{name} is empty")
    if not np.isfinite(arr).all():
        raise _Invalid(f"{name} holds NaN/inf")
    # Compared in the file's float32: the same order as in float64, without a copy.
    if arr.size > 1 and np.any(arr[1:] <= arr[:-1]):
        raise _Invalid(f"{name} is not strictly increasing: {arr[:8].tolist()}...")
    return arr


def _within(axis: np.ndarray, name: str, low: float, high: float, unit: str) -> np.ndarray:
    """An increasing axis whose ends lie in [low, high]."""
    if axis[0] < low or axis[-1] > high:
        raise _Invalid(f"{name} runs from {float(axis[0]):g} to {float(axis[-1]):g} {unit}, "
                       f"outside {low:g}..{high:g} {unit}: not a plausible measurement")
    return axis


def _description(fields) -> str:
    raw = _field(fields, "description", 1, np.uint8)
    if raw.size > MAX_DESCRIPTION_BYTES:
        raise _Invalid(f"field 'description' holds {raw.size:,} bytes, more than the "
                       f"{MAX_DESCRIPTION_BYTES:,} accepted for a line of text")
    return raw.tobytes().decode("utf-8", errors="replace")


def _incident_axes(fields) -> tuple[np.ndarray, np.ndarray]:
    theta_i = _axis(_field(fields, "theta_i", 1), "theta_i")
    phi_i = _axis(_field(fields, "phi_i", 1), "phi_i")
    _within(theta_i, "theta_i", -_ANGLE_SLACK, 0.5 * math.pi + _ANGLE_SLACK, "rad")
    _within(phi_i, "phi_i", -2 * math.pi - _ANGLE_SLACK, 2 * math.pi + _ANGLE_SLACK, "rad")
    return theta_i, phi_i


def _wavelengths(fields) -> np.ndarray:
    wavelengths = _axis(_field(fields, "wavelengths", 1), "wavelengths")
    return _within(wavelengths, "wavelengths", *WAVELENGTH_LIMITS_NM, "nm")


def _check_shapes(phi_i, theta_i, ndf, sigma, vndf, lum, values, vname, n_channels) -> None:
    npi, nti = phi_i.size, theta_i.size
    for name, arr in (("vndf", vndf), ("luminance", lum), (vname, values)):
        if arr.shape[:2] != (npi, nti):
            raise _Invalid(f"field {name!r} has shape {list(arr.shape)}; its first axes must "
                           f"be (phi_i, theta_i) = ({npi}, {nti})")
    if values.shape[2] != n_channels:
        raise _Invalid(f"field {vname!r} has {values.shape[2]} channels on axis 2, expected "
                       f"{n_channels}" + (" (the size of 'wavelengths')"
                                          if vname == "spectra" else ""))
    if values.shape[3] != values.shape[4] or lum.shape[2:] != values.shape[3:]:
        raise _Invalid(f"{vname!r} {list(values.shape)} and 'luminance' {list(lum.shape)} "
                       "need the same square n × n grid on their last two axes")
    for name, shp in (("ndf", ndf.shape), ("sigma", sigma.shape), ("vndf", vndf.shape[2:]),
                      (vname, values.shape[3:])):
        if min(shp) < 2:
            raise _Invalid(f"field {name!r} has a grid of {list(shp)}: at least 2 × 2 needed")
    if not (npi <= 2):
        red = int(np.rint(2 * math.pi / (float(phi_i[-1]) - float(phi_i[0]))))
        if red not in (1, 2, 4):
            raise _Invalid(f"phi_i spans {float(phi_i[-1] - phi_i[0]):.4g} rad: symmetry "
                           f"reduction {red} is not 1, 2 or 4")


def _clean(arrays: dict[str, np.ndarray], on_invalid: str) -> dict:
    """Count and repair defects *in place* (the arrays are the reader's own): no copies."""
    counts = {"nan": 0, "inf": 0, "negative": 0}
    per: dict[str, dict] = {}
    for name, arr in arrays.items():
        nan = int(np.isnan(arr).sum())
        inf = int(np.isinf(arr).sum())
        neg = int((arr < 0).sum())
        if nan or inf or neg:
            per[name] = {"nan": nan, "inf": inf, "negative": neg}
            counts["nan"] += nan
            counts["inf"] += inf
            counts["negative"] += neg
        if (nan or inf) and on_invalid != "clamp":
            raise _Invalid(f"field {name!r} holds {nan} NaN and {inf} inf samples of "
                           f"{arr.size:,} (read with on_invalid='clamp' to set them to 0)")
        extreme = describe_extreme(arr, f"field {name!r}")
        if extreme:
            raise _Invalid(extreme)
        if nan or inf:
            arr[~np.isfinite(arr)] = 0.0
        if neg and name in _DENSITIES:
            arr[arr < 0] = 0.0
    defects: dict = dict(counts)
    defects["fields"] = per
    return defects


def _build(fields: dict[str, np.ndarray], on_invalid: str) -> dict:
    description = _description(fields)
    jacobian = _field(fields, "jacobian", 1, np.uint8)
    if jacobian.shape != (1,):
        raise _Invalid(f"field 'jacobian' has shape {list(jacobian.shape)}, expected [1]")
    theta_i, phi_i = _incident_axes(fields)
    spectral = "wavelengths" in fields or "spectra" in fields or "rgb" not in fields
    if spectral:
        wavelengths = _wavelengths(fields)
        values = _field(fields, "spectra", 5)
        n_channels, vname = wavelengths.size, "spectra"
    else:
        wavelengths = None
        values = _field(fields, "rgb", 5)
        n_channels, vname = 3, "rgb"
    ndf = _field(fields, "ndf", 2)
    sigma = _field(fields, "sigma", 2)
    vndf = _field(fields, "vndf", 4)
    lum = _field(fields, "luminance", 4)
    _check_shapes(phi_i, theta_i, ndf, sigma, vndf, lum, values, vname, n_channels)
    arrays = {"ndf": ndf, "sigma": sigma, "vndf": vndf, "luminance": lum, vname: values}
    defects = _clean(arrays, on_invalid)
    if not np.any(values):
        raise _Invalid(f"field {vname!r} is all zero: no measurement")
    return {
        "theta_i": theta_i, "phi_i": phi_i, "ndf": ndf, "sigma": sigma, "vndf": vndf,
        "luminance": lum, "values": values,
        "wavelengths": None if wavelengths is None else wavelengths.astype(np.float64),
        "jacobian": bool(jacobian[0]), "description": description, "defects": defects,
    }


def read_rgl_bsdf(path, *, on_invalid: str = "raise",
                  max_bytes: int = MAX_TENSOR_BYTES) -> RGLBSDF:
    """Read an RGL ``.bsdf`` file (spectral or RGB), validating it; see the module notes.

    Parameters
    ----------
    on_invalid : {"raise", "clamp"}
        NaN/inf samples: raise :class:`InvalidBRDFData` naming the field and counts, or
        set them to 0 and count them in ``defects``.
    max_bytes : int
        Refuse files whose fields add up to more than this (checked before reading).

    Raises
    ------
    InvalidBRDFData
        (a ``ValueError``) naming the file, for any damage to the container (fields past
        the end, overlapping or too many), a missing / mis-shaped / mis-typed field,
        non-monotonic axes, angles or wavelengths out of range, non-finite samples (unless
        clamped), samples beyond ±10³⁰, all-zero spectra or degenerate vndf slices.
    """
    if on_invalid not in ("raise", "clamp"):
        raise ValueError(f"on_invalid must be 'raise' or 'clamp', got {on_invalid!r}")
    path = Path(path)
    fields = read_tensor_file(path, max_bytes=max_bytes)
    try:
        with np.errstate(all="ignore"):
            parts = _build(fields, on_invalid)
            return RGLBSDF(**parts, path=path)
    except _Invalid as exc:
        raise InvalidBRDFData(f"{path}: {exc}") from None
    except MemoryError:
        raise InvalidBRDFData(f"{path}: not enough memory to prepare its tables") from None
