"""The GPU state every spectral draw sets for itself.

Blender's ``gpu`` state belongs to the GPU context, not to a framebuffer, a scene or a
file: whatever the last draw left is still set when an offscreen is bound or another
.blend is loaded. Two pieces of it bite:

* **The bound shader.** The context remembers the last bound shader by its address, and
  ``shader.bind()`` does nothing when asked for the shader it believes is bound. Our
  variants are freed on every file load (``draw.reset``); a variant compiled afterwards
  can be allocated at the freed one's address, and its ``bind()`` then binds nothing:
  the draw runs the deleted program and covers no pixel. This is what killed the demo's
  main job on a clean machine (the Metacow plane, after earlier sections had loaded
  files in the same process); ``scripts/check_fresh_scene_draws.py`` counts how often.
  Every draw therefore starts with no shader bound, and ``shaders.clear_cache`` unbinds
  before it frees.
* **The pipeline state** (face culling, winding, blending, colour mask, scissor): with
  back-face culling and the winding flipped left behind, a plane facing the camera draws
  nothing either. Every draw states all of it, and puts back what it can read.

``tests/blender/gpu/test_gpu_state.py`` recreates both.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator


@contextlib.contextmanager
def spectral_draw_state() -> Iterator[None]:
    """No shader bound; depth-tested, opaque, two-sided drawing into the whole bound
    framebuffer.

    Both faces draw (mirrored objects and open meshes are shaded from either side, as
    the shaders flip normals themselves), counter-clockwise is front, no blending, all
    colour channels written, no scissor. On exit the depth test, depth writes and blend
    mode go back to what they were; culling and winding, which ``gpu.state`` cannot
    read, go back to Blender's defaults (none, counter-clockwise).
    """
    import gpu

    gpu.shader.unbind()
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
