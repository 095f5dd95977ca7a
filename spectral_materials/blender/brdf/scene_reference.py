"""The 5 nm reference image of a scene, pixel for pixel with the GPU draw path.

For each factored material the GPU writes its own geometry (world position, the
normal facing the viewer, the raw tangent) with every other material drawn as an
occluder; the exact BRDF is then evaluated at those pixels with 5 nm Riemann
sums (``core.shading.reference_shade_xyz``), lit by the same lights. The GPU
image, the float64 mirror of the shaders and this reference therefore see the
same pixels, and only the maths differs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import bpy
import numpy as np

from ...core.brdf import shading
from ...core.colour import pipeline as colour_pipeline
from ..lights import scene_lights
from ..viewport import draw
from . import sources, storage


@dataclass
class SceneComparison:
    """Per-pixel XYZ (height, width, 3) and the material index map (−1: nothing)."""

    gpu: np.ndarray
    mirror: np.ndarray
    reference: np.ndarray
    material_map: np.ndarray
    materials: list[str] = field(default_factory=list)

    def white(self, scene) -> np.ndarray:
        """CIELAB white: the adaptation white at the brightest reference pixel's luminance."""
        white = colour_pipeline.white_xyz(scene.spectral.adaptation_white, sources.WAVELENGTHS)
        return white * max(float(self.reference[..., 1].max()), 1e-12)

    def delta_e94(self, scene, test: np.ndarray | None = None) -> np.ndarray:
        """ΔE94 map (NaN off the materials) of ``test`` (default: the GPU) against the reference."""
        test = self.gpu if test is None else test
        covered = self.material_map >= 0
        out = np.full(covered.shape, np.nan)
        out[covered] = colour_pipeline.delta_e94(self.reference[covered], test[covered],
                                                 self.white(scene))
        return out


def compare_scene(scene, width: int, height: int) -> SceneComparison:
    """GPU, float64 mirror and 5 nm reference XYZ of ``scene`` from its camera."""
    gpu, stats = draw.render_camera(scene, width=width, height=height)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    _, view = draw.camera_view(scene.camera, width, height, depsgraph)
    lights, _ = scene_lights.drawn_lights(scene, np.asarray(view.origin))
    shape = (height, width, 3)
    mirror, reference = np.zeros(shape), np.zeros(shape)
    material_map = np.full((height, width), -1, dtype=np.int32)
    for index, name in enumerate(stats.materials):
        material = bpy.data.materials[name]
        buffers = {out: draw.render_camera(scene, width=width, height=height, output=out,
                                           only={name})[0]
                   for out in ("POSITION", "NORMAL", "TANGENT")}
        covered = buffers["POSITION"][..., 3] > 0
        material_map[covered] = index
        points, normals, tangents = (buffers[k][covered, :3]
                                     for k in ("POSITION", "NORMAL", "TANGENT"))
        mirror[covered] = shading.shade_xyz(storage.load_factored(material), points, normals,
                                            tangents, view, lights)
        brdf = sources.material_inputs(material).brdf()
        reference[covered] = shading.reference_shade_xyz(brdf, points, normals, tangents,
                                                         view, lights)
    return SceneComparison(gpu[..., :3].astype(np.float64), mirror, reference, material_map,
                           list(stats.materials))
