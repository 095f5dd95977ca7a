"""UBO2003: a zip of one JPEG per (light, view) pair, read into :class:`UBOBTF` (the
member list and every header checked before any pixel is decoded) and written for tests."""

from __future__ import annotations

import io
import math
import zipfile
from pathlib import Path

import numpy as np

from .._files import atomic_write, check_zip_member
from .common import (
    _LISTED,
    _NAME,
    MAX_BYTES,
    MAX_MEMBER_BYTES,
    MAX_MEMBER_RATIO,
    MAX_MEMBERS,
    MAX_PAIRS,
    MISSING_SLACK_BYTES,
    NAME_FORMAT,
    InvalidBTFData,
    _check_path,
    _Directions,
    _Invalid,
    _listing,
    _wrap,
)
from .jpeg import _decode_member, _image_shape, _srgb_lut


class UBOBTF(_Directions):
    """A UBO2003 BTF: an RGB image per (view, light) pair.

    Attributes
    ----------
    view_angles, light_angles : ndarray (V, 2), (L, 2) int
        (θ, φ) in degrees, sorted by θ then φ; they define the view and light indices.
    present : ndarray (V, L) bool
        Whether the archive holds that pair's image.
    image_shape : tuple
        ``(H, W, 3)``.
    encoding : str
        ``"srgb"`` (the JPEG code values / 255) or ``"linear"`` (sRGB EOTF applied).
    defects : dict
        ``{"missing": n, "missing_pairs": [...], "skipped_members": [...]}``: the pairs
        with no image (up to 10 quoted as (θl, φl, θv, φv)) and the members skipped by
        ``strict=False``.
    path : Path
        The archive.

    ``images`` is the float32 array (V, L, H, W, 3) in [0, 1] (NaN where ``present`` is
    False); with ``lazy=True`` it is decoded on first access and :meth:`lookup` decodes one
    member at a time.
    """

    def __init__(self, *, path: Path, view_angles: np.ndarray, light_angles: np.ndarray,
                 present: np.ndarray, members: dict, image_shape: tuple[int, int, int],
                 encoding: str, defects: dict, max_bytes: int, max_member_bytes: int,
                 images: np.ndarray | None = None) -> None:
        self.path = path
        self.view_angles = view_angles
        self.light_angles = light_angles
        self.present = present
        self.image_shape = image_shape
        self.encoding = encoding
        self.defects = defects
        self._members = members  # (view, light) -> member name
        self._max_bytes = max_bytes
        self._max_member_bytes = max_member_bytes
        self._images = images

    @property
    def images(self) -> np.ndarray:
        if self._images is None:
            self._images = _wrap(self.path, self._decode_all)
        return self._images

    def _lut(self) -> np.ndarray:
        return _srgb_lut(self.encoding == "linear")

    def _decode_all(self) -> np.ndarray:
        shape = (self.view_count, self.light_count) + self.image_shape
        _check_dense(shape, int(self.present.sum()), self._max_bytes)
        # Untouched pages take no memory: images land in the array one by one, and the
        # missing pairs become NaN only once every member has decoded, so a member whose
        # header claims more than its data hold fails before the array is filled for it.
        images = np.empty(shape, dtype=np.float32)
        lut = self._lut()
        with zipfile.ZipFile(self.path) as archive:
            for (v, l), name in self._members.items():
                images[v, l] = _decode_member(archive, self.path, archive.getinfo(name),
                                              self.image_shape[:2], lut,
                                              self._max_member_bytes)
        images[~self.present] = np.nan
        return images

    def index(self, theta_l: int, phi_l: int, theta_v: int, phi_v: int) -> tuple[int, int]:
        """(view_index, light_index) of the angles in degrees; KeyError if not sampled."""
        views = {(int(t), int(p)): i for i, (t, p) in enumerate(self.view_angles)}
        lights = {(int(t), int(p)): i for i, (t, p) in enumerate(self.light_angles)}
        try:
            return views[(int(theta_v), int(phi_v))], lights[(int(theta_l), int(phi_l))]
        except KeyError:
            raise KeyError(f"{self.path}: no view ({theta_v}, {phi_v}) / light ({theta_l}, "
                           f"{phi_l}) in this BTF") from None

    def lookup(self, view_index: int, light_index: int) -> np.ndarray:
        """The (H, W, 3) float32 image for one (view, light) pair.

        Raises IndexError for an index out of range and KeyError for a pair the archive
        does not hold (see :attr:`present`).
        """
        v, l = int(view_index), int(light_index)
        if not (0 <= v < self.view_count and 0 <= l < self.light_count):
            raise IndexError(f"view {view_index} / light {light_index} out of range "
                             f"({self.view_count} views, {self.light_count} lights)")
        if not self.present[v, l]:
            raise KeyError(f"{self.path}: no image for view {tuple(self.view_angles[v])} "
                           f"and light {tuple(self.light_angles[l])} (missing in the archive)")
        if self._images is not None:
            return self._images[v, l]

        def decode() -> np.ndarray:
            with zipfile.ZipFile(self.path) as archive:
                info = archive.getinfo(self._members[(v, l)])
                return _decode_member(archive, self.path, info, self.image_shape[:2],
                                      self._lut(), self._max_member_bytes)

        return _wrap(self.path, decode)

    def describe(self) -> dict:
        """JSON-serialisable summary (no image data)."""
        return {
            "format": "UBO2003",
            "path": str(self.path),
            "views": self.view_count,
            "lights": self.light_count,
            "image_shape": list(self.image_shape),
            "encoding": self.encoding,
            "defects": dict(self.defects),
        }


def _first_missing(present: np.ndarray, count: int) -> list[tuple[int, int]]:
    """The first ``count`` (view, light) pairs without an image, row by row (no index
    arrays over the whole mask)."""
    found: list[tuple[int, int]] = []
    for v, row in enumerate(present):
        found += [(v, int(l)) for l in np.flatnonzero(~row)[: count - len(found)]]
        if len(found) == count:
            break
    return found


def _check_dense(shape: tuple[int, ...], present: int, max_bytes: int) -> None:
    """Refuse a decoded array over ``max_bytes``, or one mostly made of missing images."""
    nbytes = math.prod(shape) * 4
    if nbytes > max_bytes:
        raise _Invalid(f"decoding all images needs {nbytes:,} bytes ({shape} float32), "
                       f"over the {max_bytes:,}-byte limit (raise max_bytes, or read with "
                       "lazy=True and use lookup())")
    held = present * math.prod(shape[2:]) * 4
    if nbytes > 2 * held + MISSING_SLACK_BYTES:
        pairs = shape[0] * shape[1]
        raise _Invalid(f"only {present:,} of the {shape[0]} × {shape[1]} (view, light) pairs "
                       f"have an image: all images as one array would take {nbytes:,} bytes, "
                       f"{nbytes - held:,} of them NaN for the {pairs - present:,} missing "
                       "pairs (read with lazy=True and use lookup())")


def _scan_members(path: Path, archive: zipfile.ZipFile, strict: bool, max_bytes: int,
                  max_member_bytes: int) -> tuple[dict, list[str]]:
    """Validate the member list (names, angles, duplicates, sizes) before decoding anything."""
    infos = archive.infolist()
    if len(infos) > MAX_MEMBERS:
        raise _Invalid(f"{len(infos):,} members, over the {MAX_MEMBERS:,} limit")
    entries: dict[tuple[int, int, int, int], zipfile.ZipInfo] = {}
    unexpected: list[str] = []
    out_of_range: list[str] = []
    duplicates: dict[tuple[int, int, int, int], list[str]] = {}
    for info in infos:
        if info.is_dir():
            continue
        match = _NAME.search(info.filename)
        if match is None:
            unexpected.append(info.filename)
            continue
        tl, pl, tv, pv = (int(g) for g in match.groups())
        if not (tl <= 90 and tv <= 90 and pl < 360 and pv < 360):
            out_of_range.append(info.filename)
            continue
        key = (tl, pl, tv, pv)
        if key in entries:
            duplicates.setdefault(key, [entries[key].filename]).append(info.filename)
            continue
        entries[key] = info
    if unexpected and strict:
        raise _Invalid(f"{len(unexpected)} member(s) do not match the UBO2003 name pattern "
                       f"'tl%03d pl%03d tv%03d pv%03d.jpg': {_listing(unexpected)} (read with "
                       "strict=False to skip them)")
    if out_of_range:
        raise _Invalid(f"{len(out_of_range)} member(s) have angles out of range (θ must be "
                       f"0..90, φ 0..359 degrees): {_listing(out_of_range)}")
    if duplicates:
        shown = "; ".join(f"(θl, φl, θv, φv) = {key}: {_listing(names)}"
                          for key, names in list(duplicates.items())[:_LISTED])
        raise _Invalid(f"{len(duplicates)} duplicated angle combination(s): {shown}")
    if not entries:
        raise _Invalid("no 'tl%03d pl%03d tv%03d pv%03d.jpg' images in the archive")
    total = 0
    size = path.stat().st_size
    for info in entries.values():
        if info.file_size > max_member_bytes:
            raise _Invalid(f"member {info.filename!r} declares {info.file_size:,} uncompressed "
                           f"bytes, over the {max_member_bytes:,}-byte limit per member")
        check_zip_member(path, info, size, max_bytes=max_member_bytes,
                         max_ratio=MAX_MEMBER_RATIO, error=InvalidBTFData)
        total += info.file_size
    if total > max_bytes:
        raise _Invalid(f"the {len(entries)} images declare {total:,} uncompressed bytes in "
                       f"all, over the {max_bytes:,}-byte limit")
    return entries, unexpected


def _read_ubo2003(path: Path, *, linear: bool, lazy: bool, strict: bool, max_bytes: int,
                  max_member_bytes: int) -> UBOBTF:
    with zipfile.ZipFile(path) as archive:
        entries, skipped = _scan_members(path, archive, strict, max_bytes, max_member_bytes)
        views = sorted({(tv, pv) for (_, _, tv, pv) in entries})
        lights = sorted({(tl, pl) for (tl, pl, _, _) in entries})
        if len(views) * len(lights) > MAX_PAIRS:
            raise _Invalid(f"{len(views):,} views × {len(lights):,} lights from "
                           f"{len(entries):,} images: over the {MAX_PAIRS:,}-pair limit")
        # Every member's header, then the whole array, before decoding any pixel.
        height, width = _image_shape(archive, path, entries, max_member_bytes)
    if not lazy:
        _check_dense((len(views), len(lights), height, width, 3), len(entries), max_bytes)
    view_index = {a: i for i, a in enumerate(views)}
    light_index = {a: i for i, a in enumerate(lights)}
    present = np.zeros((len(views), len(lights)), dtype=bool)
    members: dict[tuple[int, int], str] = {}
    for (tl, pl, tv, pv), info in sorted(entries.items()):
        v, l = view_index[(tv, pv)], light_index[(tl, pl)]
        present[v, l] = True
        members[(v, l)] = info.filename
    defects = {
        "missing": int(present.size - len(entries)),
        "missing_pairs": [(*lights[l], *views[v]) for v, l in _first_missing(present, 10)],
        "skipped_members": list(skipped),
    }
    btf = UBOBTF(path=path, view_angles=np.array(views, dtype=np.int64).reshape(-1, 2),
                 light_angles=np.array(lights, dtype=np.int64).reshape(-1, 2),
                 present=present, members=members, image_shape=(height, width, 3),
                 encoding="linear" if linear else "srgb", defects=defects,
                 max_bytes=max_bytes, max_member_bytes=max_member_bytes)
    if not lazy:
        btf._images = btf._decode_all()
    return btf


def read_ubo2003(path: str | Path, *, linear: bool = False, lazy: bool = False,
                 strict: bool = True, max_bytes: int = MAX_BYTES,
                 max_member_bytes: int = MAX_MEMBER_BYTES) -> UBOBTF:
    """Read a UBO2003 BTF archive (zip of ``tl%03d pl%03d tv%03d pv%03d.jpg`` JPEGs).

    Parameters
    ----------
    linear : bool
        Undo the sRGB transfer curve (the images are display-encoded 8-bit JPEGs).
    lazy : bool
        Validate the archive but decode images only in :meth:`UBOBTF.lookup` (one at a
        time) or on first access to :attr:`UBOBTF.images`.
    strict : bool
        Refuse members whose names do not match the pattern (directories are always
        ignored); ``False`` skips them and lists them in ``defects["skipped_members"]``.
    max_bytes : int
        Limit on the declared uncompressed size of all images together and on the decoded
        float32 array.
    max_member_bytes : int
        Limit on one member's declared uncompressed size and one decoded 8-bit image.

    Raises
    ------
    InvalidBTFData
        (a ``ValueError``) naming the file and the problem: not a zip, truncated, bad or
        duplicated names, angles out of range, sizes over the limits, a damaged JPEG.
    BTFFileNotFound
        If ``path`` does not exist (an ``InvalidBTFData`` and a ``FileNotFoundError``).
    """
    path = _check_path(path)
    if max_bytes < 1 or max_member_bytes < 1:
        raise ValueError("max_bytes and max_member_bytes must be positive")
    return _wrap(path, _read_ubo2003, path, linear=linear, lazy=lazy, strict=strict,
                 max_bytes=int(max_bytes), max_member_bytes=int(max_member_bytes))


def _check_angles(angles, label: str, count: int | None = None) -> np.ndarray:
    array = np.asarray(angles)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 1:
        raise ValueError(f"{label} must be (N, 2) (θ, φ) degrees, got shape {array.shape}")
    if count is not None and array.shape[0] != count:
        raise ValueError(f"{label} has {array.shape[0]} rows, the images need {count}")
    if not np.array_equal(array, np.round(array)):
        raise ValueError(f"{label} must be integer degrees")
    array = array.astype(np.int64)
    if (array[:, 0] < 0).any() or (array[:, 0] > 90).any() or (array[:, 1] < 0).any() \
            or (array[:, 1] >= 360).any():
        raise ValueError(f"{label}: θ must be 0..90 and φ 0..359 degrees")
    if len({tuple(a) for a in array.tolist()}) != array.shape[0]:
        raise ValueError(f"{label} has repeated (θ, φ) pairs")
    return array


def write_ubo2003(path: str | Path, images: np.ndarray, light_angles: np.ndarray,
                  view_angles: np.ndarray, *, present: np.ndarray | None = None,
                  quality: int = 100, folder: str = "",
                  compression: int = zipfile.ZIP_STORED) -> Path:
    """Write a UBO2003-layout archive (for tests and small synthetic BTFs).

    ``images`` is (V, L, H, W, 3): uint8 codes, or floats in [0, 1] stored as
    ``round(255 · x)`` (no transfer curve is applied: pass display-encoded values).
    Angles are integer degrees (θ 0..90, φ 0..359). ``present`` (V, L) bool leaves pairs
    out. JPEG is lossy even at ``quality=100``: images are written with 4:4:4 chroma
    (``subsampling=0``), so a round trip differs by a few codes at most. Members are
    named ``folder + NAME_FORMAT.format(θl, φl, θv, φv)``. The archive is written to a
    temporary name beside ``path`` and renamed.
    """
    from PIL import Image

    path = Path(path)
    images = np.asarray(images)
    if images.ndim != 5 or images.shape[-1] != 3 or min(images.shape) < 1:
        raise ValueError(f"images must be (views, lights, H, W, 3), got {images.shape}")
    views = _check_angles(view_angles, "view_angles", images.shape[0])
    lights = _check_angles(light_angles, "light_angles", images.shape[1])
    if images.dtype == np.uint8:
        codes = images
    else:
        values = images.astype(np.float64)
        if not np.isfinite(values).all() or values.min() < 0 or values.max() > 1:
            raise ValueError("float images must be finite and within [0, 1]")
        codes = np.rint(values * 255.0).astype(np.uint8)
    if present is None:
        present = np.ones(images.shape[:2], dtype=bool)
    present = np.asarray(present, dtype=bool)
    if present.shape != images.shape[:2]:
        raise ValueError(f"present must be {images.shape[:2]}, got {present.shape}")
    if folder and not folder.endswith("/"):
        folder += "/"

    def write(handle) -> None:
        with zipfile.ZipFile(handle, "w", compression=compression) as archive:
            for v, (tv, pv) in enumerate(views):
                for l, (tl, pl) in enumerate(lights):
                    if not present[v, l]:
                        continue
                    buffer = io.BytesIO()
                    Image.fromarray(codes[v, l], mode="RGB").save(
                        buffer, format="JPEG", quality=int(quality), subsampling=0)
                    archive.writestr(folder + NAME_FORMAT.format(tl, pl, tv, pv),
                                     buffer.getvalue())

    return atomic_write(path, write)
