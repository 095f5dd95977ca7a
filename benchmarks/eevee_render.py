"""One EEVEE render and what the EEVEE benchmark reads from it: the console's errors
(captured at the file-descriptor level), the image on the sphere, the draw path's frame."""

from __future__ import annotations

import ctypes
import os
import re
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import bpy
import numpy as np

from spectral_materials.blender.viewport import draw
from spectral_materials.core.formats.exr import read_exr

from .synthetic import DISC_FRACTION

#: EEVEE's stand-in for a material that failed to compile: an emission of (1, 0, 1).
MAGENTA = np.array([1.0, 0.0, 1.0])
ERROR_PATTERN = re.compile(r"error", re.IGNORECASE)


def eevee_settings(scene) -> dict:
    out = {}
    for name in ("taa_render_samples", "use_shadows", "shadow_ray_count", "shadow_step_count",
                 "use_raytracing", "use_gtao", "use_volumetric_shadows", "use_fast_gi"):
        value = getattr(scene.eevee, name, None)
        if value is not None:
            out[name] = value
    out["film_filter_size"] = scene.render.filter_size
    system = bpy.context.preferences.system
    out["shader_compilation_method"] = getattr(system, "shader_compilation_method", None)
    return out


# ---------------------------------------------------------------------- timing


@contextmanager
def captured_console():
    """Capture what C code writes to stdout and stderr (fd 1, 2); echo it afterwards."""
    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    text: list[str] = []
    with tempfile.TemporaryFile() as sink:
        saved = os.dup(1), os.dup(2)
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield text
        finally:
            libc.fflush(None)
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            sink.seek(0)
            text.append(sink.read().decode("utf-8", errors="replace"))
            if text[0].strip():
                sys.stderr.write(text[0])
                sys.stderr.flush()


def render_once(scene, *, capture: bool = False) -> dict:
    """One EEVEE render: seconds, and the exception or the console's error lines."""
    start = time.perf_counter()
    error = None
    console = ""
    try:
        if capture:
            with captured_console() as text:
                bpy.ops.render.render(write_still=False, scene=scene.name)
        else:
            bpy.ops.render.render(write_still=False, scene=scene.name)
    except Exception as exc:           # noqa: BLE001 (recorded, not hidden)
        error = f"{type(exc).__name__}: {exc}"
    seconds = time.perf_counter() - start
    if capture:
        console = text[0] if text else ""
    lines = [line.strip() for line in console.splitlines()
             if ERROR_PATTERN.search(line) and "EGL" not in line]
    return {"seconds": seconds, "exception": error, "error_lines": lines}


def sphere_mask(size: int) -> np.ndarray:
    """Pixels well inside the sphere's projected disc."""
    centre = (np.arange(size) + 0.5) - 0.5 * size
    r2 = centre[:, None] ** 2 + centre[None, :] ** 2
    return r2 < (0.97 * DISC_FRACTION * size) ** 2


def inspect_render(scene, size: int) -> dict:
    """Facts about the last render's image on the sphere (saved as a 32-bit EXR)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "render.exr"
        bpy.data.images["Render Result"].save_render(str(path), scene=scene)
        channels, _ = read_exr(path)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
    on_sphere = rgb[sphere_mask(size)]
    magenta = np.all(np.abs(on_sphere - MAGENTA) < 1e-3, axis=-1)
    finite = np.isfinite(on_sphere).all(axis=-1)
    return {"magenta_share": float(magenta.mean()), "finite_share": float(finite.mean()),
            "mean_rgb": [float(v) for v in np.nanmean(np.where(finite[:, None], on_sphere,
                                                               np.nan), axis=0)],
            "nonzero_share": float((on_sphere.max(axis=-1) > 0).mean())}


def draw_seconds(scene, size: int) -> tuple[float, dict]:
    """One ``draw.render_camera`` call (offscreen draw + full read-back): (seconds, facts)."""
    start = time.perf_counter()
    image, stats = draw.render_camera(scene, width=size, height=size, output="DISPLAY")
    seconds = time.perf_counter() - start
    return seconds, {"covered_pixels": int(np.count_nonzero(image[..., 3] > 0)),
                     "finite": bool(np.isfinite(image).all()),
                     "triangles": stats.triangles}
