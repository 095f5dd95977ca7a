"""What both Bonn BTF readers share: the size limits, the errors, directions from angles,
the path check and the wrapper that turns any damage into :class:`InvalidBTFData`."""

from __future__ import annotations

import math
import re
import zipfile
from pathlib import Path

import numpy as np

from ...errors import InvalidBRDFData

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
