"""Colour from spectral images: CIE XYZ and the sRGB preview the writer stores."""

from __future__ import annotations

import numpy as np

from .layout import SpectralImage

_CMF_GRID = np.arange(360.0, 831.0, 1.0)

def _interp_on_cmf_grid(wavelengths: np.ndarray, values: np.ndarray) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    """(mask of the 1 nm CMF grid inside the spectrum's range, values (N, k) there)."""
    inside = (_CMF_GRID >= wavelengths[0]) & (_CMF_GRID <= wavelengths[-1])
    grid = _CMF_GRID[inside]
    flat = values.reshape(-1, values.shape[-1]).astype(np.float64)
    if grid.size == 0 or wavelengths.size < 2:
        return inside, np.zeros((flat.shape[0], 0))
    # Linear interpolation of every pixel: weights of the two bracketing samples.
    upper = np.clip(np.searchsorted(wavelengths, grid, side="right"), 1, wavelengths.size - 1)
    lower = upper - 1
    t = (grid - wavelengths[lower]) / (wavelengths[upper] - wavelengths[lower])
    out = flat[:, lower] * (1.0 - t) + flat[:, upper] * t
    return inside, out


def spectral_image_to_xyz(image: SpectralImage, illuminant=None) -> np.ndarray:
    """CIE 1931 2° XYZ (H, W, 3) of a spectral image, as the reference's preview.

    The spectrum is linearly interpolated onto 1 nm steps over 360–830 nm, within
    its own wavelength range only (zero outside; a single-wavelength image gives
    0). Emissive images: ``XYZ = Σ L(λ) x̄(λ) Δλ`` (no 683 lm/W factor, like the
    reference), ``illuminant`` must be None. Reflective images: lit by
    ``illuminant`` (a CIE name known to :func:`spectra.illuminant`, or any
    :data:`spectra.SpectrumLike`; default ``"D65"``) and divided by
    ``Σ E(λ) ȳ(λ) Δλ`` over the same range, so a perfect white has Y = 1.
    """
    from ...colour import spectra

    wl = np.asarray(image.wavelengths, dtype=np.float64)
    values = np.asarray(image.values)
    if values.ndim != 3 or values.shape[-1] != wl.size:
        raise ValueError(f"values of shape {values.shape} do not match {wl.size} wavelengths")
    inside, samples = _interp_on_cmf_grid(wl, values)
    cmf = np.asarray(spectra.cmfs(_CMF_GRID))[inside]
    if image.kind == "emissive":
        if illuminant is not None:
            raise ValueError("an emissive image is not lit: illuminant must be None")
        xyz = samples @ cmf if samples.shape[1] else np.zeros((samples.shape[0], 3))
    elif image.kind == "reflective":
        source = "D65" if illuminant is None else illuminant
        if isinstance(source, str):
            light = spectra.illuminant(source, _CMF_GRID)
        else:
            light = spectra.spectrum_values(source, _CMF_GRID)
        light = light[inside]
        if samples.shape[1] == 0:
            xyz = np.zeros((samples.shape[0], 3))
        else:
            white = float(light @ cmf[:, 1])
            if not white > 0:
                raise ValueError("the illuminant has no luminance over the image's wavelengths")
            xyz = (samples * light) @ cmf / white
    else:
        raise ValueError(f"unknown kind {image.kind!r}")
    return xyz.reshape(values.shape[:2] + (3,))


def spectral_image_to_rgb(image: SpectralImage, illuminant=None, ev: float = 0.0
                          ) -> np.ndarray:
    """Linear sRGB (D65) preview (H, W, 3): :func:`spectral_image_to_xyz`, the sRGB
    matrix of colour-science, negatives clamped to 0, times 2^ev (as the reference)."""
    import colour

    xyz = spectral_image_to_xyz(image, illuminant)
    matrix = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_XYZ_to_RGB)
    rgb = np.maximum(xyz @ matrix.T, 0.0) * 2.0 ** float(ev)
    return rgb
