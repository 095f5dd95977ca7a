"""OpenEXR images of named float channels, through the OpenEXR package.

Arrays are (height, width) per channel with row 0 at the **bottom** (the GPU's
and Blender's order); files store rows top first, so rows are flipped on the way
in and out. Channels are written as 32-bit float (half float would clip XYZ
above 65504 and round to 11 bits), ZIP-compressed. Extra header attributes are
strings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Refuse images larger than this many pixels before reading their channels.
MAX_PIXELS = 1 << 28


def write_exr(path: str | Path, channels: dict[str, np.ndarray],
              attributes: dict[str, str] | None = None) -> Path:
    """Write ``channels`` (name → (H, W) array) as a float32 scanline EXR."""
    import OpenEXR

    path = Path(path)
    if not channels:
        raise ValueError(f"{path}: no channels to write")
    shapes = {np.shape(a) for a in channels.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise ValueError(f"{path}: channels must share one (height, width) shape, got {shapes}")
    data = {name: np.ascontiguousarray(np.asarray(a, dtype=np.float32)[::-1])
            for name, a in channels.items()}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for key, value in (attributes or {}).items():
        header[key] = str(value)
    with OpenEXR.File(header, data) as handle:
        handle.write(str(path))
    return path


def read_exr(path: str | Path) -> tuple[dict[str, np.ndarray], dict]:
    """(channels name → (H, W) float32 with row 0 at the bottom, header) of an EXR file."""
    import OpenEXR

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as handle:
            header = dict(handle.header())
            window = header.get("dataWindow")
            if window is not None:
                (x0, y0), (x1, y1) = (tuple(map(int, w)) for w in window)
                if (x1 - x0 + 1) * (y1 - y0 + 1) > MAX_PIXELS:
                    raise ValueError(f"{path}: image of {(x1 - x0 + 1)}×{(y1 - y0 + 1)} pixels "
                                     "is larger than this reader accepts")
            channels = {name: np.asarray(c.pixels, dtype=np.float32)[::-1].copy()
                        for name, c in handle.channels().items()}
    except (RuntimeError, OSError, TypeError) as exc:
        raise ValueError(f"{path}: not a readable OpenEXR file ({exc})") from exc
    return channels, header
