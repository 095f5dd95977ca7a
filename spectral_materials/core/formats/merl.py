"""MERL BRDF database files (``.binary``, Matusik et al. 2003) and a spectral BRDF callable.

File format
-----------
Little-endian. A 12-byte header of three int32 dimensions, which must be
``(90, 90, 180)`` (θh, θd, φd), then ``3 × 1,458,000`` float64 samples, planar:
all red, then all green, then all blue; 34,992,012 bytes in all. Within a
channel the flat index is ``φd_idx + θd_idx·180 + θh_idx·180·90``. Stored
values are multiplied by the channel scales ``(1, 1.15, 1.66) / 1500`` to give
the BRDF in sr⁻¹ (not cosine-weighted). Negative values (−1) mark cells that
were not measured (below the horizon).

Lookup (as the reference readers do; checked against wdas/brdf
``src/shaderTemplates/measured.func`` + ``src/brdf/BRDFMeasuredMERL.cpp`` and
Matusik's ``BRDFRead.cpp``)
-----------------------------------------------------------------------------
* (θh, θd, φd) are Rusinkiewicz's half/difference angles, computed by
  :func:`spectral_materials.core.brdf.params._hd_forward` (rotate wi by −φh about
  n, then by −θh about the binormal: the same frame as the reference's
  rotations and as wdas' Gram–Schmidt form).
* θh index = ⌊√(θh / (π/2)) · 90⌋ (square-root spacing, 0 for θh ≤ 0);
  θd index = ⌊θd / (π/2) · 90⌋; both clamped to [0, 89].
* φd is folded by reciprocity: φd ∈ (π, 2π) → φd − π (the reference adds π to
  a negative ``atan2``); index = ⌊φd / π · 180⌋ clamped to [0, 179].
* **Nearest cell, no interpolation** — the reference returns the sample of the
  cell the angles fall in, and so does :class:`MERLBRDF`. (The wdas shader
  snaps θh below 1e-3 rad to 0 as a float32 safeguard; this float64 reader,
  like Matusik's original code, does not.)
* Either direction at or below the horizon gives 0.
* Cells marked −1 (below-horizon centres) are filled from their valid
  neighbours (below). Near grazing, a pair of directions above the horizon can
  fall into such a cell (about 0.5 % of uniformly drawn pairs): the nearest-cell
  reference has no value there (it returns −1 × scale); this reader returns the
  filled value, or 0 with ``fill="zero"``.

Reading
-------
:func:`read_merl` checks the size of the file and the header before it
allocates anything, then reads the three channels; damage becomes
:class:`InvalidBRDFData` naming the file and the problem. Negative samples
(the −1 markers) are part of the format: they are counted in
``defects["negative"]`` (``defects["below_horizon_marker"]`` those exactly −1)
and filled. NaN/inf samples raise by default; ``on_invalid="clamp"`` counts them
and fills them too.

The fill (``fill="neighbours"``, default; the rule in :mod:`.merl_fill`): per
channel, pass after pass, each invalid sample takes the mean of its valid face
neighbours (θh, θd clamped; φd wraps, π-periodic by reciprocity); valid samples
are never changed. ``fill="zero"`` sets them to 0 (the behaviour before). A
file with no valid sample at all is refused either way, and
so is one with a finite sample beyond ±10³⁰ sr⁻¹ once scaled, negative or not (no
measurement or marker looks like that, and later arithmetic would overflow; see
:mod:`spectral_materials.core.sample_limits`). The body is read one channel at a
time: reading costs about the file's size once more.

Spectral uplift
---------------
MERL holds linear (sRGB-primaries) RGB. :class:`MERLBRDF` turns looked-up RGB
into spectra with ``"smits1999"`` (Smits 1999, linear basis) or ``"jakob2019"``
(Jakob & Hanika 2019 through a cached colour-science LUT), or any callable
``uplift(rgb (N, 3), wavelengths) -> (N, L)``: see
:mod:`spectral_materials.core.colour.uplift`, where they live. Their old names here
(``merl.SmitsUplift``, ``merl.jakob2019_lut``, …) still work for one release, with a
``DeprecationWarning``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..._moved import forward_names
from ..brdf import measured_cells
from ..brdf.params import PARAMETERIZATIONS, _hd_forward
from ..colour import spectra, uplift as _uplift
from ..errors import InvalidBRDFData
from ..sample_limits import MAX_SAMPLE, extreme_mask
from ._files import atomic_write, read_errors
from .merl_fill import apply_fill, check_fill

__all__ = [
    "CHANNEL_SCALES",
    "FILE_BYTES",
    "MERL_SHAPE",
    "MERLBRDF",
    "cell_centres",
    "merl_indices",
    "merl_table_from_brdf",
    "read_merl",
    "write_merl",
]

#: (θh, θd, φd) cells of a MERL file.
MERL_SHAPE = measured_cells.MERL_SHAPE
#: Multipliers from stored values to the BRDF (sr⁻¹), per channel R, G, B.
CHANNEL_SCALES = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
HEADER_BYTES = 12
#: Size of a valid file: header + 3 planar float64 channels.
FILE_BYTES = HEADER_BYTES + 3 * 8 * math.prod(MERL_SHAPE)
#: Direction pairs uplifted per chunk.
CHUNK_POINTS = 1 << 16


# The uplift names that moved to core.colour.uplift in issue 17 (old name → new home), still
# served from here, with a DeprecationWarning, for one release.
__getattr__ = forward_names(__name__, {
    "UPLIFTS": "core.colour.uplift",
    "JAKOB2019_LUT_SIZE": "core.colour.uplift",
    "SmitsUplift": "core.colour.uplift",
    "Jakob2019Uplift": "core.colour.uplift",
    "jakob2019_lut": "core.colour.uplift",
    "_make_uplift": "core.colour.uplift:make_uplift",
    "_cache_dir": "core.colour.uplift",
    "_LUTS": "core.colour.uplift",
})


# --------------------------------------------------------------------------- indexing


def merl_indices(theta_h: np.ndarray, theta_d: np.ndarray, phi_d: np.ndarray,
                 shape: tuple[int, int, int] = MERL_SHAPE) -> np.ndarray:
    """Flat cell index ``φd_i + θd_i·n_φ + θh_i·n_φ·n_θd`` of (θh, θd, φd) in radians.

    φd may be anywhere in [0, 2π) (values above π are folded by reciprocity) or
    (−π, π] as ``atan2`` gives it. Non-finite angles count as 0.
    """
    _, n_d, n_p = shape
    ih, idd, ip = measured_cells.cell_indices(theta_h, theta_d, phi_d, shape)
    return ip + n_p * (idd + n_d * ih)


def cell_centres(shape: tuple[int, int, int] = MERL_SHAPE) -> np.ndarray:
    """(θh, θd, φd) at every cell centre, ``(prod(shape), 3)`` in the file's order.

    θh = ((i + ½)/n)² · π/2, θd = (j + ½)/n · π/2, φd = (k + ½)/n · π.
    """
    th, td, pd = measured_cells.centre_angles(*(np.arange(n) for n in shape), shape)
    mesh = np.meshgrid(th, td, pd, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=-1)


def _directions(wi, wo) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """Broadcast ``(..., 3)`` direction arrays and flatten them to ``(N, 3)``."""
    wi = np.asarray(wi, dtype=np.float64)
    wo = np.asarray(wo, dtype=np.float64)
    if wi.shape[-1:] != (3,) or wo.shape[-1:] != (3,):
        raise ValueError(f"wi and wo must have shape (..., 3), got {wi.shape} and {wo.shape}")
    try:
        wi, wo = np.broadcast_arrays(wi, wo)
    except ValueError:
        raise ValueError(f"wi {wi.shape} and wo {wo.shape} do not broadcast") from None
    if not (np.isfinite(wi).all() and np.isfinite(wo).all()):
        raise ValueError("wi/wo contain NaN or inf")
    lead = wi.shape[:-1]
    return wi.reshape(-1, 3), wo.reshape(-1, 3), lead


# --------------------------------------------------------------------------- callable


@dataclass
class MERLBRDF:
    """A MERL table as a spectral BRDF callable ``f(wi, wo, wavelengths) -> (..., L)``.

    Attributes
    ----------
    table : ndarray (90, 90, 180, 3) float32
        BRDF in sr⁻¹ per (θh, θd, φd) cell and R, G, B (channel scales applied;
        invalid samples filled from their neighbours, or 0 with ``fill="zero"``).
    defects : dict
        ``nan``, ``inf``, ``negative`` (of which ``below_horizon_marker``: exactly
        −1 in the file) sample counts, ``invalid_cells`` (cells with any of them),
        ``first``: where the first non-finite one was; ``fill`` (the rule) and
        ``filled_samples``, ``filled_cells``, ``fill_passes``.
    uplift : callable
        ``uplift(rgb (N, 3), wavelengths) -> (N, L)`` (:class:`~..colour.uplift.SmitsUplift`, ...).
    path : Path or None
    """

    table: np.ndarray
    defects: dict = field(default_factory=dict)
    uplift: Callable = field(default_factory=_uplift.SmitsUplift)
    path: Path | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.table)
        if t.ndim != 4 or t.shape[-1] != 3 or min(t.shape) < 1:
            raise ValueError(f"table must have shape (n_θh, n_θd, n_φd, 3), got {t.shape}")
        self.table = np.ascontiguousarray(t, dtype=np.float32)
        self._flat = self.table.reshape(-1, 3)

    @property
    def shape(self) -> tuple[int, int, int]:
        return tuple(self.table.shape[:3])

    @property
    def isotropic(self) -> bool:
        return True

    @property
    def lookup_cells(self) -> tuple[int, int, int]:
        """The (θh, θd, φd) cells this reader looks pairs up in (nearest cell): a model of
        the table is drawn in them by default (``core/brdf/measured_cells.py``)."""
        return self.shape

    @property
    def meta(self) -> dict:
        """Table metadata (no samples)."""
        return self.describe()

    def cell_index(self, wi, wo) -> np.ndarray:
        """Flat cell index of each direction pair (any leading shape; no horizon test)."""
        wi, wo, lead = _directions(wi, wo)
        if wi.shape[0] == 0:
            return np.zeros(lead, dtype=np.int64)
        wi = wi / np.maximum(np.linalg.norm(wi, axis=1, keepdims=True), 1e-300)
        wo = wo / np.maximum(np.linalg.norm(wo, axis=1, keepdims=True), 1e-300)
        th, _, td, pd = _hd_forward(wi, wo)
        return merl_indices(th, td, pd, self.shape).reshape(lead)

    def rgb(self, wi, wo) -> np.ndarray:
        """RGB BRDF ``(..., 3)`` (nearest cell); 0 where a direction is at/below the horizon."""
        wi, wo, lead = _directions(wi, wo)
        out = np.zeros((wi.shape[0], 3))
        lit = np.nonzero((wi[:, 2] > 0) & (wo[:, 2] > 0))[0]
        if lit.size:
            idx = self.cell_index(wi[lit], wo[lit])
            out[lit] = self._flat[idx]
        return out.reshape(lead + (3,))

    def __call__(self, wi, wo, wavelengths) -> np.ndarray:
        """The spectral BRDF ``(..., L)`` at ``wavelengths`` (nm), uplifted from :meth:`rgb`."""
        wl = spectra.check_wavelengths(wavelengths)
        wi, wo, lead = _directions(wi, wo)
        out = np.zeros((wi.shape[0], wl.size))
        lit = np.nonzero((wi[:, 2] > 0) & (wo[:, 2] > 0))[0]
        for begin in range(0, lit.size, CHUNK_POINTS):
            rows = lit[begin : begin + CHUNK_POINTS]
            idx = self.cell_index(wi[rows], wo[rows])
            out[rows] = self.uplift(self._flat[idx].astype(np.float64), wl)
        return out.reshape(lead + (wl.size,))

    def spectral_table(self, wavelengths) -> np.ndarray:
        """The whole table uplifted: ``(*shape, L)`` float32."""
        wl = spectra.check_wavelengths(wavelengths)
        out = np.empty((self._flat.shape[0], wl.size), dtype=np.float32)
        for begin in range(0, self._flat.shape[0], CHUNK_POINTS):
            rgb = self._flat[begin : begin + CHUNK_POINTS].astype(np.float64)
            out[begin : begin + CHUNK_POINTS] = self.uplift(rgb, wl)
        return out.reshape(self.shape + (wl.size,))

    def describe(self) -> dict:
        """JSON-serialisable summary."""
        return {
            "format": "merl_binary",
            "path": None if self.path is None else str(self.path),
            "shape": list(self.shape),
            "channel_scales": list(CHANNEL_SCALES),
            "uplift": getattr(self.uplift, "name", type(self.uplift).__name__),
            "lookup": "nearest cell (as the MERL reference code)",
            "defects": dict(self.defects),
        }


# --------------------------------------------------------------------------- reading


class _Invalid(Exception):
    """Internal: a problem found while parsing, turned into InvalidBRDFData with the path."""


def _describe_cell(flat_index: int, channel: int, shape) -> str:
    i, j, k = np.unravel_index(int(flat_index), shape)
    th, td, pd = cell_centres(shape)[int(flat_index)]
    return (f"cell θh[{i}]={math.degrees(th):.2f}°, θd[{j}]={math.degrees(td):.2f}°, "
            f"φd[{k}]={math.degrees(pd):.2f}°, channel {'RGB'[channel]}")


def _refuse_extreme(values: np.ndarray, channel: int, shape) -> None:
    """Refuse samples (BRDF, sr⁻¹) beyond ±MAX_SAMPLE, negative ones included: neither a
    measurement nor the below-horizon marker looks like that (see
    :mod:`spectral_materials.core.sample_limits`)."""
    big = extreme_mask(values)
    if big.any():
        first = int(np.argmax(big))
        raise _Invalid(f"{int(big.sum()):,} samples of channel {'RGB'[channel]} lie beyond "
                       f"±{MAX_SAMPLE:g} sr⁻¹ (the first, {values[first]:g}, at "
                       f"{_describe_cell(first, channel, shape)}); not a plausible measurement")


def _read_body(path: Path, shape: tuple[int, int, int], on_invalid: str
               ) -> tuple[np.ndarray, dict, np.ndarray]:
    """The table (invalid samples set to 0), the defects and the (…, 3) mask of invalid samples."""
    n = math.prod(shape)
    table = np.empty((n, 3), dtype=np.float32)
    counts = {"nan": 0, "inf": 0, "negative": 0, "below_horizon_marker": 0}
    first = ""
    bad = np.zeros((n, 3), dtype=bool)
    with open(path, "rb") as stream:
        stream.seek(HEADER_BYTES)
        for c, scale in enumerate(CHANNEL_SCALES):
            raw = np.fromfile(stream, dtype="<f8", count=n)
            if raw.size != n:  # the size check makes this unreachable unless the file shrank
                raise _Invalid(f"channel {'RGB'[c]} ends after {raw.size:,} of {n:,} samples")
            nan = np.isnan(raw)
            inf = np.isinf(raw)
            neg = raw < 0
            counts["nan"] += int(nan.sum())
            counts["inf"] += int(inf.sum())
            counts["negative"] += int(neg.sum())
            counts["below_horizon_marker"] += int((raw == -1.0).sum())
            nonfinite = nan | inf
            if not first and nonfinite.any():
                first = _describe_cell(int(np.argmax(nonfinite)), c, shape)
            bad[:, c] = nonfinite | neg
            values = raw * scale
            _refuse_extreme(values, c, shape)
            values[bad[:, c]] = 0.0
            table[:, c] = values
    defects: dict = dict(counts)
    bad_cells = bad.any(axis=1)
    defects["invalid_cells"] = int(bad_cells.sum())
    if bad_cells.all():
        raise _Invalid(f"all {n:,} cells hold invalid samples ({counts['nan']} NaN, "
                       f"{counts['inf']} inf, {counts['negative']} negative): no measurement")
    if counts["nan"] or counts["inf"]:
        if on_invalid != "clamp":
            raise _Invalid(f"{counts['nan']} NaN and {counts['inf']} inf samples of {3 * n:,}; "
                           f"first at {first} (read with on_invalid='clamp' to replace them)")
        defects["first"] = first
    return table.reshape(shape + (3,)), defects, bad.reshape(shape + (3,))


def _read_merl(path, *, uplift="smits1999", on_invalid: str = "raise", jakob_lut=None,
               shape: tuple[int, int, int] = MERL_SHAPE, fill: str = "neighbours") -> MERLBRDF:
    """:func:`read_merl` for a given expected ``shape`` (small files, for tests)."""
    if on_invalid not in ("raise", "clamp"):
        raise ValueError(f"on_invalid must be 'raise' or 'clamp', got {on_invalid!r}")
    check_fill(fill)
    method = _uplift.make_uplift(uplift, jakob_lut)
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such file")
        raise IsADirectoryError(f"{path}: not a regular file")
    expected = HEADER_BYTES + 3 * 8 * math.prod(shape)
    with read_errors(path, _Invalid):
        size = path.stat().st_size
        if size == 0:
            raise _Invalid("empty file, not a MERL BRDF (.binary)")
        if size < HEADER_BYTES:
            raise _Invalid(f"{size} bytes: too short for the {HEADER_BYTES}-byte header")
        with open(path, "rb") as stream:
            header = stream.read(HEADER_BYTES)
        if len(header) != HEADER_BYTES:
            raise _Invalid("the header could not be read in full")
        dims = tuple(int(d) for d in np.frombuffer(header, dtype="<i4"))
        if dims != tuple(shape):
            hint = ""
            if tuple(int(d) for d in np.frombuffer(header, dtype=">i4")) == tuple(shape):
                hint = " (the header is big-endian; MERL files are little-endian)"
            elif sorted(dims) == sorted(shape):
                hint = " (dimensions in the wrong order)"
            raise _Invalid(f"header dimensions {dims} are not (θh, θd, φd) = {tuple(shape)}"
                           f"{hint}; not a MERL BRDF file or damaged")
        if size != expected:
            what = "truncated" if size < expected else "has trailing bytes"
            raise _Invalid(f"{what}: {size:,} bytes, a MERL file of {tuple(shape)} cells has "
                           f"{expected:,}")
        table, defects, bad = _read_body(path, tuple(shape), on_invalid)
    defects.update(apply_fill(table, bad, fill))
    return MERLBRDF(table=table, defects=defects, uplift=method, path=path)


def read_merl(path, *, uplift="smits1999", on_invalid: str = "raise",
              fill: str = "neighbours", jakob_lut=None) -> MERLBRDF:
    """Read a MERL ``.binary`` BRDF, validating it before loading the samples.

    Parameters
    ----------
    uplift : {"smits1999", "jakob2019"} or callable
        RGB → spectrum method of the returned callable (or any
        ``uplift(rgb (N, 3), wavelengths) -> (N, L)``).
    on_invalid : {"raise", "clamp"}
        NaN/inf samples: raise :class:`InvalidBRDFData` with their counts and the
        first location, or replace them by the ``fill`` rule and count them in
        ``defects``. Negative samples (the format's below-horizon marker −1) are
        always replaced by the ``fill`` rule and counted.
    fill : {"neighbours", "zero"}
        What replaces them: the mean of valid grid neighbours (the rule of
        :mod:`.merl_fill`; counts in ``defects["filled_cells"]`` etc.) or 0.
    jakob_lut : LUT3D_Jakob2019, optional
        For ``"jakob2019"``; default :func:`jakob2019_lut` (size 8, cached).

    Raises
    ------
    InvalidBRDFData
        (a ``ValueError``) for a wrong header (dimensions other than 90, 90, 180),
        a wrong size (truncated or trailing bytes; checked before anything is
        allocated), non-finite samples (unless clamped), samples beyond ±10³⁰ sr⁻¹,
        or a file without a single valid sample; the message names the file.
    OSError
        If the file cannot be opened at all (missing, a directory, no permission).
    """
    return _read_merl(path, uplift=uplift, on_invalid=on_invalid, jakob_lut=jakob_lut,
                      shape=MERL_SHAPE, fill=fill)


# --------------------------------------------------------------------------- writing


def _write_merl(path, rgb_table, shape, allow_invalid: bool) -> Path:
    path = Path(path)
    table = np.asarray(rgb_table, dtype=np.float64)
    if table.shape == (math.prod(shape), 3):
        table = table.reshape(tuple(shape) + (3,))
    if table.shape != tuple(shape) + (3,):
        raise ValueError(f"rgb_table must have shape {tuple(shape) + (3,)}, got {table.shape}")
    if not allow_invalid and not np.isfinite(table).all():
        raise InvalidBRDFData(f"{path}: refusing to write {int((~np.isfinite(table)).sum())} "
                              "NaN/inf samples")
    header = np.asarray(shape, dtype="<i4").tobytes()
    def write(handle) -> None:
        handle.write(header)
        for c, scale in enumerate(CHANNEL_SCALES):
            v = table[..., c].ravel()
            raw = np.where(v < 0, -1.0, v / scale)  # negative: the below-horizon marker
            handle.write(raw.astype("<f8").tobytes())

    atomic_write(path, write)
    return path


def write_merl(path, rgb_table, *, allow_invalid: bool = False) -> Path:
    """Write a MERL ``.binary`` file from an RGB BRDF table.

    Parameters
    ----------
    rgb_table : array (90, 90, 180, 3) or (1458000, 3)
        BRDF in sr⁻¹ (channel scales not applied: this divides by them). Negative
        entries are written as the format's below-horizon marker −1.
    allow_invalid : bool
        Write NaN/inf as they are (for testing readers) instead of raising.

    Written to a temporary name beside ``path`` and renamed, so a failed write
    never leaves a partial file.
    """
    return _write_merl(path, rgb_table, MERL_SHAPE, allow_invalid)


def merl_table_from_brdf(brdf_rgb: Callable, *, shape: tuple[int, int, int] = MERL_SHAPE,
                         chunk: int = CHUNK_POINTS) -> np.ndarray:
    """Sample an RGB BRDF ``brdf_rgb(wi (N, 3), wo (N, 3)) -> (N, 3)`` at the MERL cell centres.

    Directions come from the Rusinkiewicz inverse (``hd_iso``, φh = 0) of
    :func:`cell_centres`. Cells with either direction at or below the horizon
    are set to −1, as in measured files. Returns ``(*shape, 3)`` float64.
    """
    coords = cell_centres(shape)
    wi, wo, _ = PARAMETERIZATIONS["hd_iso"].inverse(coords)
    above = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    out = np.full((coords.shape[0], 3), -1.0)
    rows = np.nonzero(above)[0]
    for begin in range(0, rows.size, chunk):
        r = rows[begin : begin + chunk]
        values = np.asarray(brdf_rgb(wi[r], wo[r]), dtype=np.float64)
        if values.shape != (r.size, 3):
            raise ValueError(f"brdf_rgb returned shape {values.shape}, expected ({r.size}, 3)")
        out[r] = values
    return out.reshape(tuple(shape) + (3,))
