"""What the benchmarks record about the machine they ran on."""

from __future__ import annotations

import os
import platform

import numpy as np


def gpu_machine() -> dict:
    """The GPU (renderer, vendor, version, backend), the load, CPUs and versions."""
    import bpy
    import gpu

    return {"renderer": gpu.platform.renderer_get(), "vendor": gpu.platform.vendor_get(),
            "version": gpu.platform.version_get(), "backend": gpu.platform.backend_type_get(),
            "load_start": os.getloadavg()[0],
            "cpu_count": os.cpu_count(), "blender": bpy.app.version_string,
            "python": platform.python_version(), "numpy": np.__version__}
