"""Offscreen drawing into RGBA32F and read-back into NumPy.

:class:`Target` is the offscreen every image is drawn into: the protocol sphere
(``brdf.sphere.render_sphere``) and a scene from its camera
(``viewport.draw.render_camera``).
Images are (height, width, 4) float32 with row 0 at the bottom (OpenGL order).

Until the next release ``offscreen.render_sphere`` still imports, with a DeprecationWarning:
it moved to the factor-pack package, which this lower layer must not import.
"""

from __future__ import annotations

import numpy as np

from ..._moved import forward_names
from .context import ensure_gpu
from .state import spectral_draw_state

MAX_SIZE = 8192
#: Names that left this module: name → (module relative to this package's parent).
# render_sphere moved to the brdf package, served from here for one release.
__getattr__ = forward_names(__name__, {"render_sphere": "blender.brdf.sphere"})


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
