"""Offscreen drawing into RGBA32F and read-back into NumPy.

:func:`render_sphere` draws the protocol sphere (shared/PROTOCOL.md) through the
same shaders as the viewport; ``draw.render_view`` draws a scene from a camera.
Images are (height, width, 4) float32 with row 0 at the bottom (OpenGL order).
"""

from __future__ import annotations

import numpy as np

from ...core.brdf.factored import FactoredBRDF
from ...core.brdf.shading import protocol_sun
from ...core.lights import SpectralLight
from ..brdf.gpu_material import DisplaySettings, GPUMaterial
from .context import ensure_gpu
from .shaders import get_shader
from .state import spectral_draw_state

MAX_SIZE = 8192
_QUAD = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]], dtype=np.float32)


def check_size(width: int, height: int) -> None:
    if not (1 <= width <= MAX_SIZE and 1 <= height <= MAX_SIZE):
        raise ValueError(f"image size must be 1..{MAX_SIZE} pixels a side, got {width}×{height}")


def read_back(framebuffer, width: int, height: int) -> np.ndarray:
    buffer = framebuffer.read_color(0, 0, width, height, 4, 0, "FLOAT")
    buffer.dimensions = width * height * 4
    return np.asarray(buffer, dtype=np.float32).reshape(height, width, 4).copy()


class Target:
    """An RGBA32F offscreen with depth, cleared to transparent black; use as a context.

    Inside, the pipeline state is :func:`gpu_state.spectral_draw_state`'s, whatever an
    earlier draw left set."""

    def __init__(self, width: int, height: int):
        import gpu

        check_size(width, height)
        ensure_gpu()
        self.width, self.height = int(width), int(height)
        self.offscreen = gpu.types.GPUOffScreen(self.width, self.height, format="RGBA32F")
        self._bound = None

    def __enter__(self):
        import gpu

        self._bound = self.offscreen.bind()
        self._bound.__enter__()
        self._state = spectral_draw_state()
        self._state.__enter__()
        framebuffer = gpu.state.active_framebuffer_get()
        framebuffer.clear(color=(0.0, 0.0, 0.0, 0.0), depth=1.0)
        self.framebuffer = framebuffer
        return self

    def read(self) -> np.ndarray:
        return read_back(self.framebuffer, self.width, self.height)

    def __exit__(self, *exc) -> None:
        self._state.__exit__(*exc)
        self._bound.__exit__(*exc)
        self.offscreen.free()


def render_sphere(model: FactoredBRDF, incidence_deg: float = 0.0,
                  illuminant: str | np.ndarray = "D65", size: int = 256, *,
                  lights: list[SpectralLight] | None = None, output: str = "XYZ",
                  packs: int | None = None, precontract: bool = True,
                  display: DisplaySettings | None = None) -> np.ndarray:
    """The protocol sphere drawn on the GPU: (size, size, 4) float32, row 0 at the bottom.

    XYZ output is linear CIE XYZ, protocol-normalised; alpha is 1 on the sphere and 0
    off it. ``lights`` replaces the protocol's sun at ``incidence_deg``. ``packs`` draws
    the model's first packs (``FactoredBRDF.truncated``).
    """
    from gpu_extras.batch import batch_for_shader

    if lights is None:
        lights = [protocol_sun(incidence_deg, illuminant, model.wavelengths)]
    if packs is not None:
        model = model.truncated(packs)
    material = GPUMaterial(model)
    shader = get_shader(material.key(lights, precontract=precontract, output=output,
                                     sphere=True))
    batch = batch_for_shader(shader, "TRI_STRIP", {"corner": _QUAD})
    light_texture = material.light_texture(lights, precontract)
    with Target(size, size) as target:
        params = material.params(display or DisplaySettings(), target_size=(size, size))
        material.bind(shader, light_texture, params)
        batch.draw(shader)
        return target.read()
