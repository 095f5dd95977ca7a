"""A PRT object's albedo: a spectrum, the ColorChecker chart, an RGB image or a spectral EXR,
read once (cached by its inputs), and its spectra at texture coordinates."""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ...core.colour import spectra
from ...core.prt import albedo as core_albedo
from ..brdf import sources
from .inputs import BASIS_SAMPLES, WAVELENGTHS, PRTError, cached, digest, file_key, image_rgb

#: ColorChecker chart texture: pixels per patch side (bilinear filtering blends only the
#: outermost texel ring of each patch).
CHART_PATCH_PIXELS = 8

def chart_spectra(patch_pixels: int = CHART_PATCH_PIXELS) -> np.ndarray:
    """The 24 ColorChecker patches as a (4·p, 6·p, L) texture, row 0 at the bottom, patch 1
    in the top-left corner (as the chart is printed)."""
    patches = np.stack([spectra.colorchecker(i, WAVELENGTHS) for i in range(1, 25)])
    grid = patches.reshape(4, 6, -1)[::-1]              # chart row 0 is the top
    return np.repeat(np.repeat(grid, patch_pixels, axis=0), patch_pixels, axis=1)


def albedo_inputs(obj) -> tuple[tuple, dict]:
    p = obj.spectral_prt
    what = f"Object '{obj.name}': PRT albedo"
    if p.albedo_kind == "SPECTRUM":
        values = sources.spectrum_from_source(p.albedo, obj.name, "PRT albedo")
        return ("SPECTRUM", digest(values)), {"spectra": values[None, None]}
    if p.albedo_kind == "CHART":
        return ("CHART", CHART_PATCH_PIXELS), {"spectra": None}
    if p.albedo_kind == "IMAGE":
        if p.image is None:
            raise PRTError(f"{what}: choose an image")
        return ("IMAGE", p.image.name, tuple(p.image.size), p.image.filepath,
                p.image.is_dirty), {"image": p.image}
    if not p.filepath:
        raise PRTError(f"{what}: choose a spectral EXR file")
    return ("SPECTRAL_EXR",) + file_key(p.filepath), {"path": bpy.path.abspath(p.filepath)}


@dataclass
class AlbedoSource:
    """An object's albedo as spectra (H, W, L) or linear RGB (H, W, 3), row 0 at the bottom."""

    key: tuple
    values: np.ndarray
    rgb: bool

    def spectra(self) -> np.ndarray:
        if not self.rgb:
            return self.values
        from ...core.colour.uplift import SmitsUplift

        h, w = self.values.shape[:2]
        return SmitsUplift()(self.values.reshape(-1, 3), WAVELENGTHS).reshape(h, w, -1)

    def basis_spectra(self) -> np.ndarray:
        h, w = self.values.shape[:2]
        step = max(1, int(np.sqrt(h * w / BASIS_SAMPLES)))
        sub = AlbedoSource(self.key, self.values[::step, ::step], self.rgb)
        return sub.spectra().reshape(-1, WAVELENGTHS.size)


def albedo_source(obj) -> AlbedoSource:
    """The object's albedo source, read once (cached by its inputs)."""
    key, inputs = albedo_inputs(obj)

    def build() -> AlbedoSource:
        what = f"Object '{obj.name}': PRT albedo"
        if key[0] == "SPECTRUM":
            return AlbedoSource(key, inputs["spectra"], False)
        if key[0] == "CHART":
            return AlbedoSource(key, chart_spectra(), False)
        if key[0] == "IMAGE":
            return AlbedoSource(key, image_rgb(inputs["image"], what), True)
        try:
            values = core_albedo.read_reflectance_exr(inputs["path"], WAVELENGTHS)
        except (ValueError, OSError) as exc:
            raise PRTError(f"{what}: {exc}") from None
        return AlbedoSource(key, values, False)

    return cached(f"albedo_source:{obj.name}", key, build)


def vertex_albedo_spectra(obj, uv: np.ndarray) -> np.ndarray:
    """The albedo spectra (V, L) at texture coordinates ``uv``, filtered as the layers are
    (bilinear, repeat): the reference's albedo at the vertices."""
    values = albedo_source(obj).spectra()                         # (H, W, L)
    h, w, count = values.shape
    pad = -(-count // 3) * 3
    stack = np.zeros((h, w, pad))
    stack[..., :count] = values
    # sample_layers filters three channels per layer; spectra go through as L/3 layers.
    layers = stack.reshape(h, w, pad // 3, 3).transpose(2, 0, 1, 3)
    return core_albedo.sample_layers(layers, uv).reshape(len(uv), pad)[:, :count]

