"""Making Blender's ``gpu`` module usable, also headless.

In the UI the GPU context exists. In background mode (``blender --background``,
the ``bpy`` module) every ``gpu`` call fails until a render has initialised the
GPU (EGL, Mesa llvmpipe where there is no GPU): :func:`ensure_gpu` renders one
4 × 4 EEVEE frame of a throw-away scene, which it then removes, so the user's
scene is not touched. The first such render compiles EEVEE's shaders (~30 s on
llvmpipe); later calls return at once.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from typing import NoReturn

import bpy

from .. import compat

_READY = False


class GPUUnavailable(RuntimeError):
    """No GPU context could be made (e.g. EGL is missing); the message says what to install."""


def _probe() -> bool:
    import gpu

    try:
        gpu.types.GPUOffScreen(1, 1).free()
    except (SystemError, RuntimeError, ValueError):
        return False
    return True


def _tiny_render() -> None:
    scene = bpy.data.scenes.new("SM gpu init")
    camera_data = bpy.data.cameras.new("SM gpu init")
    camera = bpy.data.objects.new("SM gpu init", camera_data)
    try:
        scene.collection.objects.link(camera)
        scene.camera = camera
        scene.render.engine = compat.EEVEE_ENGINE
        scene.render.resolution_x = scene.render.resolution_y = 4
        scene.render.resolution_percentage = 100
        bpy.ops.render.render(scene=scene.name)
    finally:
        bpy.data.objects.remove(camera)
        bpy.data.cameras.remove(camera_data)
        bpy.data.scenes.remove(scene)


#: Lines Blender prints while it looks for an EGL configuration that works. Each failed
#: attempt says "EGL_BAD_MATCH" before a later one succeeds; they mean nothing to a user
#: whose drawing then works, so they are shown only if the GPU cannot be initialised.
_EGL_PROBING = ("EGL Error (0x3009): EGL_BAD_MATCH",)


@contextlib.contextmanager
def _native_stderr_captured(captured: list[str]) -> Iterator[None]:
    """Collect what C code writes to file descriptor 2 (Blender's own messages) into
    ``captured``; lines not in ``_EGL_PROBING`` are written back to stderr afterwards."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 2)
        try:
            yield
        finally:
            sys.stderr.flush()
            os.dup2(saved, 2)
            os.close(saved)
            sink.seek(0)
            captured.extend(sink.read().decode("utf-8", "replace").splitlines())
    others = [line for line in captured if not line.startswith(_EGL_PROBING)]
    if others:
        print("\n".join(others), file=sys.stderr)


def exit_process(code: int | None) -> NoReturn:
    """End a process that used Blender: flush, then leave without Blender's exit handler.

    With bpy 5.3 on Vulkan (Mesa lavapipe), a process that rendered with EEVEE and drew
    offscreen crashes now and then in that handler after its work is done (exit 134 or
    139; docs/vulkan.md), which a caller would take for a failure. The results are written
    and closed when a script calls this, so nothing is lost by skipping it. A process that
    never imported ``bpy`` exits normally.
    """
    code = 0 if code is None else int(code)
    if "bpy" not in sys.modules:
        sys.exit(code)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


def ensure_gpu() -> None:
    """Make ``gpu`` usable; raises :class:`GPUUnavailable` with what to do if it cannot."""
    global _READY
    if _READY:
        return
    if not _probe():
        messages: list[str] = []
        try:
            with _native_stderr_captured(messages):
                _tiny_render()
        except RuntimeError as exc:
            raise GPUUnavailable(f"could not initialise the GPU through an EEVEE render: {exc}"
                                 + "".join(f"\n  {line}" for line in messages)) from exc
        if not _probe():
            raise GPUUnavailable(
                "the GPU is not available: headless drawing needs EGL (on Debian/Ubuntu: "
                "apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1)"
                + "".join(f"\n  {line}" for line in messages))
    _READY = True
