"""The ColorChecker chart as an albedo texture, for the PRT albedo tests."""

from __future__ import annotations

import numpy as np

from spectral_materials.core.colour import spectra


def chart_texture(wavelengths: np.ndarray, patch: int) -> np.ndarray:
    """(4·patch, 6·patch, L) reflectances: the 24 patches, ``patch`` texels square each."""
    patches = np.stack([spectra.colorchecker(i, wavelengths) for i in range(1, 25)])
    return np.repeat(np.repeat(patches.reshape(4, 6, -1), patch, 0), patch, 1)
