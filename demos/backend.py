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

    An explicit ``VK_ICD_FILENAMES`` is the user's choice and is left alone under ``auto``.
    """
    environ = os.environ if environ is None else environ
    wanted = requested_backend(argv)
    if wanted not in CHOICES:
        return "blender"    # the argument parser reports the bad value
    if wanted == "opengl":
        environ["VK_ICD_FILENAMES"] = HIDE_VULKAN
        return "opengl"
    if wanted == "vulkan":
        if environ.get("VK_ICD_FILENAMES") == HIDE_VULKAN:
            del environ["VK_ICD_FILENAMES"]
        return "vulkan"
    if "VK_ICD_FILENAMES" in environ or not platform.startswith("linux"):
        return "blender"
    if gpu_device_node is None:
        gpu_device_node = has_gpu_device_node()
    if gpu_device_node:
        return "blender"
    environ["VK_ICD_FILENAMES"] = HIDE_VULKAN
    return "opengl"
