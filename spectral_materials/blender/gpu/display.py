"""The display pipeline's uniforms, shared by every drawer (factor packs, PRT, BTF).

:class:`DisplaySettings` is what the scene asks of the display (adaptation white,
exposure, tone map); :func:`display_matrices` turns its white into the std140 mat4s the
shaders' colour pipeline (glsl/common/colour_pipeline.glsl) reads.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...core.colour import pipeline as colour_pipeline


@dataclass
class DisplaySettings:
    """The display pipeline's uniforms: scene white (XYZ), exposure, tone-map white."""

    scene_white: tuple = tuple(colour_pipeline.DISPLAY_WHITE_XYZ)
    exposure: float = 1.0
    tone_white: float = 4.0


def std140_mat4(matrix) -> np.ndarray:
    """A 3 × 3 or 4 × 4 matrix as a std140 mat4 (float32, column-major, padded with the
    identity)."""
    m = np.eye(4)
    a = np.asarray(matrix, dtype=np.float64)
    m[: a.shape[0], : a.shape[1]] = a
    return m.T.astype(np.float32)


@functools.lru_cache(maxsize=16)
def display_matrices(scene_white: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """std140 mat4s of the display pipeline for a scene white: Bradford (white → D65),
    XYZ → linear sRGB and its inverse. Cached: every draw of every material asks, and
    colour-science's Bradford costs a fraction of a millisecond each time."""
    to_rgb = colour_pipeline.xyz_to_linear_srgb_matrix()
    out = (std140_mat4(colour_pipeline.bradford_matrix(np.asarray(scene_white))),
           std140_mat4(to_rgb), std140_mat4(np.linalg.inv(to_rgb)))
    for matrix in out:
        matrix.setflags(write=False)
    return out
