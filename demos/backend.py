"""Which GPU backend the demo's process asks Blender for, decided before ``import bpy``.

The ``bpy`` module picks its backend once, at the first GPU use, and only the Vulkan
loader's environment changes it (docs/vulkan.md). On a Linux machine with no GPU device
node the only Vulkan driver that loads is Mesa's lavapipe, which aborts a few per cent of
fresh Blender 5.3 processes (docs/vulkan.md, ``scripts/check_gpu_startup.py``); llvmpipe's
OpenGL never has. So ``auto`` takes OpenGL there and leaves every other machine to
Blender's own choice. The report names the backend that ran.
"""

from __future__ import annotations

import glob
import os
import sys
from collections.abc import MutableMapping, Sequence

CHOICES = ("auto", "opengl", "vulkan")
HIDE_VULKAN = "/nonexistent.json"
#: The Vulkan loader's driver lists: newer loaders read VK_DRIVER_FILES first, older ones
#: VK_ICD_FILENAMES; VK_ADD_DRIVER_FILES adds to either. Any of them set is the user's
#: choice under ``auto``.
DRIVER_VARIABLES = ("VK_DRIVER_FILES", "VK_ICD_FILENAMES")
USER_VARIABLES = (*DRIVER_VARIABLES, "VK_ADD_DRIVER_FILES")


def requested_backend(argv: Sequence[str]) -> str:
    """The ``--gpu-backend`` value in ``argv`` (``auto`` when absent); the argument
    parser in ``demos.main`` validates it again and documents it."""
    for i, arg in enumerate(argv):
        if arg.startswith("--gpu-backend="):
            return arg.split("=", 1)[1]
        if arg == "--gpu-backend" and i + 1 < len(argv):
            return argv[i + 1]
    return "auto"


def has_gpu_device_node() -> bool:
    """A DRM render node or NVIDIA's device: a hardware Vulkan driver may load."""
    return bool(glob.glob("/dev/dri/renderD*") or os.path.exists("/dev/nvidiactl"))


def choose_backend(argv: Sequence[str], environ: MutableMapping[str, str] | None = None,
                   platform: str = sys.platform,
                   gpu_device_node: bool | None = None) -> str:
    """Set the Vulkan loader's environment for the backend asked for; return what was
    decided: ``"opengl"``, ``"vulkan"`` or ``"blender"`` (Blender's own choice).

    An explicit driver list (:data:`USER_VARIABLES`) is the user's choice and is left
    alone under ``auto``.
    """
    environ = os.environ if environ is None else environ
    wanted = requested_backend(argv)
    if wanted not in CHOICES:
        return "blender"    # the argument parser reports the bad value
    if wanted == "opengl":
        _hide_vulkan(environ)
        return "opengl"
    if wanted == "vulkan":
        for name in DRIVER_VARIABLES:
            if environ.get(name) == HIDE_VULKAN:
                del environ[name]
        return "vulkan"
    if any(name in environ for name in USER_VARIABLES) or not platform.startswith("linux"):
        return "blender"
    if gpu_device_node is None:
        gpu_device_node = has_gpu_device_node()
    if gpu_device_node:
        return "blender"
    _hide_vulkan(environ)
    return "opengl"


def _hide_vulkan(environ: MutableMapping[str, str]) -> None:
    """No Vulkan driver for the loader, whichever list it reads: Blender takes OpenGL."""
    for name in DRIVER_VARIABLES:
        environ[name] = HIDE_VULKAN
    environ.pop("VK_ADD_DRIVER_FILES", None)
