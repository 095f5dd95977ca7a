"""The GPU pipeline state every spectral draw sets for itself.

Blender's ``gpu`` state (face culling, winding, blending, colour mask, scissor) belongs to
the GPU context, not to a framebuffer or a file: whatever the last draw left — EEVEE, an
overlay, another add-on — is still set when an offscreen is bound or another .blend is
loaded. The demo's main job died on a clean machine this way: with back-face culling and
the winding flipped left behind, a plane facing the camera drew no pixel
(``tests/blender/test_gpu_state.py`` recreates it). So every draw states all the state it
depends on, and puts back what it can read afterwards.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator


@contextlib.contextmanager
def spectral_draw_state() -> Iterator[None]:
    """Depth-tested, opaque, two-sided drawing into the whole bound framebuffer.

    Both faces draw (mirrored objects and open meshes are shaded from either side, as
    the shaders flip normals themselves), counter-clockwise is front, no blending, all
    colour channels written, no scissor. On exit the depth test, depth writes and blend
    mode go back to what they were; culling and winding, which ``gpu.state`` cannot
    read, go back to Blender's defaults (none, counter-clockwise).
    """
    import gpu

    state = gpu.state
    depth_test, depth_mask, blend = state.depth_test_get(), state.depth_mask_get(), \
        state.blend_get()
    state.depth_test_set("LESS_EQUAL")
    state.depth_mask_set(True)
    state.face_culling_set("NONE")
    state.front_facing_set(False)
    state.blend_set("NONE")
    state.color_mask_set(True, True, True, True)
    state.scissor_test_set(False)
    try:
        yield
    finally:
        state.depth_test_set(depth_test)
        state.depth_mask_set(depth_mask)
        state.blend_set(blend)
        state.face_culling_set("NONE")
        state.front_facing_set(False)
