"""Per-pixel evaluation of drawn PRT objects: the Python side of GPU-vs-Python images.

:func:`pixel_geometry` draws the scene's PRT objects from the camera with the debug
outputs (world position, UV, primitive index) and recovers, for every covered pixel, the
triangle's three mesh vertices and the barycentric weights the rasteriser interpolated
with (from the interpolated position: perspective-correct interpolation is linear on
the triangle in object space). :func:`interpolate` then evaluates any per-vertex quantity
(Ê, a reference irradiance spectrum) at the pixels, so that images can be computed in
float64 exactly as the GPU computes them, or with a 5 nm reference instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..viewport import draw
from . import drawer as prt_gpu, scene as prt


@dataclass
class PixelGeometry:
    """Covered pixels of one PRT object drawn from the camera (row 0 at the bottom)."""

    covered: np.ndarray          # (H, W) bool
    vertices: np.ndarray         # (P, 3) mesh vertex indices of each pixel's triangle
    barycentric: np.ndarray      # (P, 3)
    uv: np.ndarray               # (P, 2)

    def image(self, values: np.ndarray, fill: float = np.nan) -> np.ndarray:
        """Scatter per-pixel values (P, …) back into an (H, W, …) image."""
        out = np.full(self.covered.shape + values.shape[1:], fill, dtype=np.float64)
        out[self.covered] = values
        return out


def pixel_geometry(scene, obj, *, width: int | None = None,
                   height: int | None = None) -> PixelGeometry:
    """Draw the debug outputs of ``obj`` (the scene's only drawn object) and read them."""
    images = {out: draw.render_camera(scene, output=out, width=width, height=height)[0]
              for out in ("POSITION", "COORDINATES", "PRIMITIVE")}
    covered = images["POSITION"][..., 3] > 0.5
    if not covered.any():
        raise prt.PRTError(f"Object '{obj.name}' covers no pixel of the camera's "
                           f"{covered.shape[1]}×{covered.shape[0]} view")
    arrays = prt_gpu._OBJECTS[obj.name]["arrays"]
    prim = images["PRIMITIVE"][..., 0][covered].round().astype(int)
    corners = arrays.triangles[prim]
    world = images["POSITION"][..., :3][covered].astype(np.float64)
    inverse = np.linalg.inv(np.array(obj.matrix_world))
    local = world @ inverse[:3, :3].T + inverse[:3, 3]
    tri = arrays.positions[corners].astype(np.float64)
    e1, e2, p = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], local - tri[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    p1, p2 = (p * e1).sum(1), (p * e2).sum(1)
    den = d11 * d22 - d12 * d12
    den = np.where(np.abs(den) > 1e-30, den, 1e-30)          # degenerate triangles
    b1, b2 = (d22 * p1 - d12 * p2) / den, (d11 * p2 - d12 * p1) / den
    bary = np.stack([1.0 - b1 - b2, b1, b2], axis=1)
    vertices = arrays.vertex_index.astype(np.int64)[corners]
    uv = images["COORDINATES"][..., :2][covered].astype(np.float64)
    return PixelGeometry(covered, vertices, bary, uv)


def interpolate(geometry: PixelGeometry, per_vertex: np.ndarray) -> np.ndarray:
    """Per-vertex values (V, …) at the covered pixels (P, …), as the rasteriser does."""
    values = np.asarray(per_vertex, dtype=np.float64)[geometry.vertices]     # (P, 3, …)
    return np.einsum("pk,pk...->p...", geometry.barycentric, values)
