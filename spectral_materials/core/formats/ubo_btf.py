"""Bonn BTF database files: UBO2003 (a zip of JPEGs) and UBO2014 (``.btf``, SVD-compressed).

A BTF (bidirectional texture function) is an image per (view, light) pair: ``BTF(x, l, v)``
with ``x`` a texel, ``l`` the light and ``v`` the view direction (Meseth, Müller, Klein,
"Reflectance field based real-time, high quality rendering of BTFs"). The measured values
include the foreshortening term ``n·l``. Directions are in the sample's local frame, z up
(the surface normal), φ measured from +x towards +y: ``(cos φ sin θ, sin φ sin θ, cos θ)``.

UBO2003 (``read_ubo2003`` / ``write_ubo2003``)
----------------------------------------------
A zip archive of 81 views × 81 lights = 6561 JPEG images of 256 × 256 texels, one member
per (light, view) pair named ``tl%03d pl%03d tv%03d pv%03d.jpg`` (θ and φ of the light, then
of the view, in integer degrees, zero-padded to three digits, separated by single spaces;
members may sit in a folder). Layout verified against btf-extractor
(2-propanol/BTF_extractor, ``btf_extractor/ubo2003.py``: the docstring of ``Ubo2003`` gives
``f"tl{tl:03} pl{pl:03} tv{tv:03} pv{pv:03}.jpg"`` and ``_filename_to_angles`` slices the
digits from the end of the member name, so a leading folder is allowed).

Colour encoding: the images are 8-bit, display-encoded (gamma-compressed) camera images,
*not* linear radiance; the database does not state the exact transfer curve. Renderers
that use them undo a display gamma first (elerac/btf-rendering, ``custom_bsdf/measuredbtf.py``,
``apply_inv_gamma`` on by default, ``x ** 2.2``). :func:`read_ubo2003` returns the encoded
values in [0, 1] (``encoding == "srgb"``) unless ``linear=True``, which applies the sRGB
EOTF (IEC 61966-2-1, colour-science's ``eotf_sRGB``) exactly per 8-bit code.

The reader checks the whole archive before it allocates any image, so that memory stays
in proportion to the bytes present:

* every member name against the pattern, and every member's declared (central directory)
  sizes against the archive: a stored member must hold its bytes inside the archive, a
  compressed one may declare at most :data:`MAX_MEMBER_RATIO` times its compressed size
  (JPEG data do not compress), each at most ``max_member_bytes``, all together at most
  ``max_bytes``;
* every member's JPEG header (read lazily, inflated under a running cap): one image size
  for all, RGB or greyscale, at most ``max_member_bytes`` as 8-bit RGB, and at most
  :data:`MAX_JPEG_PIXELS_PER_BYTE` pixels per byte of the member;
* the decoded array ``(views, lights, H, W, 3)`` float32 against ``max_bytes``, and, as
  missing pairs take memory too (NaN), against twice the present images plus
  :data:`MISSING_SLACK_BYTES`: a sparse set (300 images on the diagonal of 300 × 300
  pairs) is refused with a pointer to ``lazy=True`` and :meth:`UBOBTF.lookup`.

Views and lights are the sorted distinct (θ, φ) pairs found; a (view, light) pair with no
image is counted in ``defects["missing"]``, flagged ``False`` in :attr:`UBOBTF.present` and
filled with NaN, never invented.

UBO2014 (``read_ubo2014`` / ``write_ubo2014``)
----------------------------------------------
151 × 151 directions, 400 × 400 or 512 × 512 texels, stored as a truncated SVD.
Layout verified against btf-extractor's ``btf_extractor/c_ext/btf.hh`` (Zdravko Velinov's
free BTF library, MIT): ``LoadBTF`` (lines 485-959), its ``read_common`` lambda (507-621),
the ``DFMF`` branch (625-784), ``FMF0``/``FMF1`` (785-915), the evaluation
``BTFEvaluateMatrix`` (333-359) and ``BTFFetchSpectrum`` (210-272). All little-endian:

* ``!`` then the FourCC ``DFMF``, ``FMF0`` or ``FMF1``, then ``08FC``, ``6FC`` or ``2FCE``
  respectively; optionally an ``R`` (a rotation list follows the image size).
* Common header (its first field, ``Size``, is the byte count of the whole header from
  ``Size`` up to and including the channel names): ``u32 Size, u32 Version``,
  three ``char[80]`` (measurement setup, image sensor, light source), ``f32 PPMM``,
  ``f32[3]`` RGB scale; ``Version > 1``: ``u32`` cosine flag; ``> 2``: ``u32`` length +
  XML text; ``> 3``: ``u32`` channel count, then per channel ``u32`` length + name
  (otherwise R, G, B).
* ``u32`` view count; per view ``f32 θ, f32 φ`` (radians), ``u32`` light count and that
  many ``f32 θ, f32 φ`` (btf-extractor keeps the first view's list and only checks the
  counts of the others); then ``u32`` width, ``u32`` height; with ``R``: ``u32`` count
  and that many 3 × 3 ``f32`` matrices.
* ``DFMF``: ``u32`` components, ``u32`` colour model, ``f32[3]`` colour mean,
  ``f32[9]`` colour transform; then per channel: ``u8`` element size (2 half, 4 float,
  8 double), ``u32`` k, ``u32`` rows (= views × lights), ``u32`` columns (= W × H),
  k singular values, U (rows × k), S·V (columns × k).
* ``FMF0``/``FMF1``: (``FMF1`` only: ``u8`` extension version; ≥ 1: ``u32`` dynamic-range
  reduction flag; ≥ 2: ``u32`` width, ``u32`` height and a ``u16`` height map; ≥ 3 is
  unsupported) ``u32`` k₀, ``u8`` element size, ``u32`` k₁, k = min(k₀, k₁);
  ``u32`` rows (= views × lights × channels), ``u32`` columns (= W × H), k singular
  values, U (rows × k, rows ordered view, light, channel), S·V (columns × k, shared by the
  channels).
* The file ends right after S·V.

A value is ``Σₖ U[row, k] · SxV[texel, k]`` with ``row = view · L + light`` (times the
channel count plus the channel for FMF); the singular values are already folded into S·V.
Texels are stored bottom row first: ``texel = (H - 1 - y) · W + x`` for row ``y`` counted
from the top (btf-extractor flips the rows after loading). Colour model 11 is log-YUV
(``Y = exp(c₀) - 1e-5``, ``U, V = c₁,₂ · Y + 1e-5``, then YUV → RGB clamped to [0, 1], as
btf-extractor does); the FMF1 dynamic-range-reduction flag means ``exp(c) - 1e-5``.
The cosine flag is reported, not applied (btf-extractor leaves it a stub).

Differences from btf-extractor: rows must equal views × lights (it checks lights², the
same for the 151 × 151 files), a component count of 0 and colour models other than 0 and
11 are refused, every view's light list is read and differing lists are counted in
``defects``, every size is checked against the bytes left in the file (and
``max_bytes``) before anything is allocated, and factors whose values can overflow
float32 (``Σₖ |U[r, k]| · maxₜ |S·V[t, k]|`` over 3.4 × 10³⁸) are refused.

Errors
------
Every malformed, truncated or oversized input raises :class:`InvalidBTFData` (a
``ValueError``, subclass of :class:`~spectral_materials.core.errors.InvalidBRDFData`)
naming the file and the problem; a missing path raises :class:`BTFFileNotFound`, which is
both an :class:`InvalidBTFData` and a :class:`FileNotFoundError`.
"""

from __future__ import annotations

import io
import math
import re
import struct
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InvalidBRDFData
from ._files import atomic_write, check_zip_member, open_zip_member

#: Default limit on the declared uncompressed bytes of an archive's members, on the decoded
#: float32 array, and on the factor arrays of a UBO2014 file (8 GiB).
MAX_BYTES = 8 << 30
#: Default limit on one member's declared uncompressed size and on one decoded image.
MAX_MEMBER_BYTES = 64 << 20
#: Refuse archives with more members than this.
MAX_MEMBERS = 100_000
#: Refuse UBO2003 sets of more (view, light) pairs than this (the database has 81 × 81;
#: the pairs' presence mask alone takes a byte each).
MAX_PAIRS = 1 << 24
#: Refuse UBO2014 files with more channels than this.
MAX_CHANNELS = 64
#: Refuse a compressed UBO2003 member declaring more than this many times its compressed
#: size (beyond its first MiB): JPEG data deflate about 1.0–1.1:1, a JPEG of one flat
#: colour 6:1; zeros padding a JPEG deflate 1000:1.
MAX_MEMBER_RATIO = 64
#: Refuse a JPEG header claiming more pixels than this per byte its member takes in the
#: archive (compressed: padding that deflates away does not count). Baseline
#: Huffman coding spends at least 2 bits per 8×8 block and component (256 pixels per byte
#: for greyscale, 170 for 4:2:0 colour; Pillow's optimised coding of a flat 4096² image
#: measured 255 and 170); progressive DC scans can halve that. Photographs take 2–30.
MAX_JPEG_PIXELS_PER_BYTE = 512
#: Decoding all images may spend this much beyond twice the present images on the NaN
#: images of missing (view, light) pairs.
MISSING_SLACK_BYTES = 64 << 20
_FLOAT32_MAX = float(np.finfo(np.float32).max)
_LOG_FLOAT32_MAX = math.log(_FLOAT32_MAX)

#: UBO2003 member names: θ/φ of the light, then of the view, integer degrees.
NAME_FORMAT = "tl{:03d} pl{:03d} tv{:03d} pv{:03d}.jpg"
_NAME = re.compile(r"(?:^|/)tl(\d{3}) pl(\d{3}) tv(\d{3}) pv(\d{3})\.jpg$", re.IGNORECASE)
_LISTED = 5  # names quoted in an error message
_DRR_EPS = 1e-5

__all__ = [
    "BTFFileNotFound",
    "InvalidBTFData",
    "MAX_BYTES",
    "MAX_JPEG_PIXELS_PER_BYTE",
    "MAX_MEMBER_BYTES",
    "MAX_MEMBER_RATIO",
    "MISSING_SLACK_BYTES",
    "NAME_FORMAT",
    "UBO2014BTF",
    "UBOBTF",
    "directions_from_angles",
    "read_ubo2003",
    "read_ubo2014",
    "write_ubo2003",
    "write_ubo2014",
]


class InvalidBTFData(InvalidBRDFData):
    """A BTF file is malformed, truncated, oversized or unsupported; the message says which."""


class BTFFileNotFound(InvalidBTFData, FileNotFoundError):
    """The BTF path does not exist (also a :class:`FileNotFoundError`)."""


class _Invalid(Exception):
    """Internal: a problem found while parsing, turned into InvalidBTFData with the path."""


def directions_from_angles(theta: np.ndarray, phi: np.ndarray, *, degrees: bool = True
                           ) -> np.ndarray:
    """Unit vectors (N, 3) in the local frame (z up) from polar θ and azimuth φ."""
    theta = np.asarray(theta, dtype=np.float64)
    phi = np.asarray(phi, dtype=np.float64)
    if degrees:
        theta, phi = np.radians(theta), np.radians(phi)
    s = np.sin(theta)
    return np.stack([np.cos(phi) * s, np.sin(phi) * s, np.cos(theta)], axis=-1)


def _check_path(path: str | Path) -> Path:
    path = Path(path)
    if not path.exists():
        raise BTFFileNotFound(f"{path}: no such file")
    if not path.is_file():
        raise InvalidBTFData(f"{path}: not a regular file")
    if path.stat().st_size == 0:
        raise InvalidBTFData(f"{path}: empty file")
    return path


def _listing(names, limit: int = _LISTED) -> str:
    names = list(names)
    shown = ", ".join(repr(n) for n in names[:limit])
    return shown + (f" and {len(names) - limit} more" if len(names) > limit else "")




def _wrap(path: Path, function, *args, **kwargs):
    """Run a parser, turning every sort of damage into InvalidBTFData naming ``path``."""
    try:
        return function(*args, **kwargs)
    except InvalidBTFData:
        raise
    except _Invalid as exc:
        raise InvalidBTFData(f"{path}: {exc}") from None
    except zipfile.BadZipFile as exc:
        raise InvalidBTFData(f"{path}: not a valid zip archive or damaged ({exc})") from None
    except MemoryError:
        raise InvalidBTFData(f"{path}: not enough memory to load it") from None
    except PermissionError:
        raise
    except Exception as exc:  # any other damage must surface as InvalidBTFData too
        raise InvalidBTFData(f"{path}: unreadable or damaged ({type(exc).__name__}: {exc})") \
            from None


# --------------------------------------------------------------------------- UBO2003


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


class _Directions:
    """View and light counts and unit directions from ``view_angles``/``light_angles``
    (θ, φ) rows, in degrees or radians as the subclass's ``ANGLES_IN_DEGREES`` says."""

    ANGLES_IN_DEGREES = True
    view_angles: np.ndarray
    light_angles: np.ndarray

    @property
    def view_count(self) -> int:
        return int(self.view_angles.shape[0])

    @property
    def light_count(self) -> int:
        return int(self.light_angles.shape[0])

    @property
    def view_directions(self) -> np.ndarray:
        """(V, 3) unit vectors towards the camera, local frame z up."""
        return directions_from_angles(self.view_angles[:, 0], self.view_angles[:, 1],
                                      degrees=self.ANGLES_IN_DEGREES)

    @property
    def light_directions(self) -> np.ndarray:
        """(L, 3) unit vectors towards the light, local frame z up."""
        return directions_from_angles(self.light_angles[:, 0], self.light_angles[:, 1],
                                      degrees=self.ANGLES_IN_DEGREES)


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


# --------------------------------------------------------------------------- UBO2014

_SIGNATURES = {b"DFMF": b"08FC", b"FMF0": b"6FC", b"FMF1": b"2FCE"}
_DTYPES = {2: np.dtype("<f2"), 4: np.dtype("<f4"), 8: np.dtype("<f8")}
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


def _read_common(s: _Stream) -> dict:
    rotations_flag = s.read(1, "rotation flag") == b"R"
    if not rotations_flag:
        s.handle.seek(-1, io.SEEK_CUR)
        s.pos -= 1
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


def _read_ubo2014(path: Path, max_bytes: int) -> UBO2014BTF:
    with open(path, "rb") as handle:
        s = _Stream(handle, path.stat().st_size, max_bytes)
        if s.read(1, "magic") != b"!":
            raise _Invalid("not a UBO2014 BTF: it does not start with '!'")
        fourcc = s.read(4, "signature")
        if fourcc not in _SIGNATURES:
            raise _Invalid(f"signature {fourcc!r} is not DFMF, FMF0 or FMF1")
        tail = _SIGNATURES[fourcc]
        if s.read(len(tail), "signature tail") != tail:
            raise _Invalid(f"{fourcc.decode()} must be followed by {tail.decode()!r}")
        common = _read_common(s)
        channels = len(common["header"]["channels"])
        views, lights = common["view_angles"].shape[0], common["light_angles"].shape[0]
        texels = common["width"] * common["height"]
        extra: dict = {}
        if fourcc == b"DFMF":
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
        else:
            if fourcc == b"FMF1":
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
            svals = [sv] * channels
            us = [u[:, c, :] for c in range(channels)]
            sxvs = [sxv] * channels
        if s.left:
            raise _Invalid(f"{s.left:,} unexpected bytes after the factor block "
                           f"(offset {s.pos:,})")
    bad = sum(int((~np.isfinite(a)).sum()) for a in {id(a): a for a in us + sxvs}.values())
    common["defects"]["non_finite_factors"] = bad
    model = extra.get("color_model", 0)
    if model not in (0, 11) or (model == 11 and channels != 3):
        raise _Invalid(f"colour model {model} with {channels} channels is not supported "
                       "(0, or 11 = log-YUV with 3 channels)")
    bound = _value_bound(us, sxvs)
    if bound > _FLOAT32_MAX:
        raise _Invalid(f"its factors reach values up to {bound:.3g} (Σₖ |U|·max|S·V|), beyond "
                       f"float32's {_FLOAT32_MAX:.3g}: reconstructed texels would overflow")
    log_encoded = model == 11 or extra.get("dynamic_range_reduction", False)
    common["defects"]["may_overflow"] = bool(log_encoded and bound > _LOG_FLOAT32_MAX)
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


def _pack_text(text: str, size: int = 80) -> bytes:
    data = text.encode("latin-1")[: size - 1]
    return data + b"\0" * (size - len(data))


def write_ubo2014(path: str | Path, *, view_angles: np.ndarray, light_angles: np.ndarray,
                  width: int, height: int, u, sxv, singular_values=None,
                  signature: str = "FMF0", data_size: int = 4, version: int = 4,
                  channels=("R", "G", "B"), xml: str = "", cosine_flag: int = 0,
                  rotations: np.ndarray | None = None, color_model: int = 0,
                  dynamic_range_reduction: bool = False,
                  height_map: np.ndarray | None = None, measurement_setup: str = "",
                  image_sensor: str = "", light_source: str = "", ppmm: float = 0.0,
                  rgb_scale=(1.0, 1.0, 1.0)) -> Path:
    """Write a UBO2014-layout file (for tests and small synthetic BTFs).

    Angles are (θ, φ) radians, (V, 2) and (L, 2); every view gets the same light list.
    FMF0/FMF1: ``u`` is (V·L·C, k) (rows ordered view, light, channel) and ``sxv``
    (W·H, k), texels bottom row first; ``singular_values`` (k,) defaults to ones.
    DFMF: ``u`` and ``sxv`` are lists with one (V·L, kc) / (W·H, kc) array per channel and
    ``singular_values`` a list too. ``version`` (1..4) selects the optional header fields.
    FMF1 writes extension version 2 (a height map of 0×0 when ``height_map`` is None).
    """
    path = Path(path)
    if signature not in ("DFMF", "FMF0", "FMF1"):
        raise ValueError(f"signature {signature!r} is not DFMF, FMF0 or FMF1")
    dtype = _DTYPES.get(int(data_size))
    if dtype is None:
        raise ValueError(f"data_size {data_size} is not 2, 4 or 8")
    views = np.asarray(view_angles, dtype="<f4").reshape(-1, 2)
    lights = np.asarray(light_angles, dtype="<f4").reshape(-1, 2)
    channels = list(channels) if version > 3 else ["R", "G", "B"]
    out = io.BytesIO()
    out.write(b"!" + signature.encode() + _SIGNATURES[signature.encode()])
    if rotations is not None:
        out.write(b"R")
    body = io.BytesIO()
    body.write(struct.pack("<I", int(version)))
    for text in (measurement_setup, image_sensor, light_source):
        body.write(_pack_text(text))
    body.write(struct.pack("<4f", ppmm, *rgb_scale))
    if version > 1:
        body.write(struct.pack("<I", int(cosine_flag)))
    if version > 2:
        data = xml.encode("utf-8")
        body.write(struct.pack("<I", len(data)) + data)
    if version > 3:
        body.write(struct.pack("<I", len(channels)))
        for name in channels:
            data = name.encode("latin-1")
            body.write(struct.pack("<I", len(data)) + data)
    out.write(struct.pack("<I", 4 + body.tell()) + body.getvalue())
    out.write(struct.pack("<I", views.shape[0]))
    for view in views:
        out.write(view.tobytes() + struct.pack("<I", lights.shape[0]) + lights.tobytes())
    out.write(struct.pack("<II", int(width), int(height)))
    if rotations is not None:
        rot = np.asarray(rotations, dtype="<f4").reshape(-1, 3, 3)
        out.write(struct.pack("<I", rot.shape[0]) + rot.tobytes())
    if signature == "DFMF":
        us = [np.asarray(a) for a in u]
        sxvs = [np.asarray(a) for a in sxv]
        if len(us) != len(channels) or len(sxvs) != len(channels):
            raise ValueError("DFMF needs one U and one S·V array per channel")
        svs = singular_values or [np.ones(a.shape[1]) for a in us]
        out.write(struct.pack("<II", int(us[0].shape[1]), int(color_model)))
        out.write(np.zeros(3, "<f4").tobytes() + np.eye(3, dtype="<f4").tobytes())
        for uc, sc, sv in zip(us, sxvs, svs, strict=True):
            k = uc.shape[1]
            out.write(struct.pack("<BIII", int(data_size), k, uc.shape[0], sc.shape[0]))
            for block in (sv, uc, sc):
                out.write(np.ascontiguousarray(block, dtype=dtype).tobytes())
    else:
        if signature == "FMF1":
            out.write(struct.pack("<BI", 2, int(bool(dynamic_range_reduction))))
            hm = np.zeros((0, 0), "<u2") if height_map is None \
                else np.asarray(height_map, "<u2")
            out.write(struct.pack("<II", hm.shape[1], hm.shape[0]) + hm.tobytes())
        u = np.asarray(u).reshape(-1, np.shape(u)[-1])
        sxv = np.asarray(sxv)
        k = u.shape[1]
        sv = np.ones(k) if singular_values is None else np.asarray(singular_values)
        out.write(struct.pack("<IBI", k, int(data_size), k))
        out.write(struct.pack("<II", u.shape[0], sxv.shape[0]))
        for block in (sv, u, sxv):
            out.write(np.ascontiguousarray(block, dtype=dtype).tobytes())
    return atomic_write(path, lambda handle: handle.write(out.getvalue()))
