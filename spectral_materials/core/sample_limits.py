"""Bounds on the numbers a reader accepts from a file (BRDF samples, spectra, wavelengths).

A reader refuses a value outside these bounds at once, naming the file, instead of handing
it on to arithmetic that would overflow far from where the value came from.

:data:`MAX_SAMPLE` = 10³⁰ bounds the magnitude of any measured sample: a BRDF value (sr⁻¹),
a radiance, a reflectance, a relative power. Real data stay far below it: the sharpest
measured specular lobes peak around 10⁴–10⁶ sr⁻¹, spectra and SPDs are O(1) once
normalised. At 10³⁰ a value still fits float32 (≤ 3.4 × 10³⁸, the tables' and GPU
textures' type) with eight orders of magnitude left for light intensities and scale
factors, and in float64 its square (10⁶⁰), sums of squares over any table (≤ 10¹² samples:
10⁷²) and products with other bounded quantities (BRDF × light × basis ≤ 10⁹⁰) stay more
than 200 orders of magnitude below overflow (1.8 × 10³⁰⁸).

:data:`WAVELENGTH_LIMITS_NM` = 10 nm – 100 µm covers every optical measurement from the
extreme ultraviolet to the far infrared (spectrophotometers: 200–2500 nm; FTIR: to about
25 µm). A wavelength outside it is a wrong column or a wrong unit, not a measurement.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MAX_SAMPLE", "WAVELENGTH_LIMITS_NM", "describe_extreme", "extreme_mask"]

#: Largest magnitude accepted for a sample read from a file (see the module notes).
MAX_SAMPLE = 1.0e30
#: Wavelengths a file may hold, in nm (see the module notes).
WAVELENGTH_LIMITS_NM = (10.0, 1.0e5)


def extreme_mask(values: np.ndarray) -> np.ndarray:
    """True where a finite value's magnitude exceeds :data:`MAX_SAMPLE` (NaN/inf: False,
    readers count those separately). Boolean temporaries only: no float copy of a table."""
    values = np.asarray(values)
    with np.errstate(invalid="ignore"):
        mask = values > MAX_SAMPLE
        mask |= values < -MAX_SAMPLE
    mask &= np.isfinite(values)
    return mask


def describe_extreme(values: np.ndarray, what: str) -> str | None:
    """A message about ``values`` beyond :data:`MAX_SAMPLE` (how many, the first one and
    where), or None when there are none."""
    values = np.asarray(values)
    bad = extreme_mask(values)
    if not bad.any():
        return None
    first = np.unravel_index(int(np.argmax(bad)), values.shape)
    at = ", ".join(str(int(i)) for i in first)
    return (f"{what} holds {int(bad.sum()):,} values beyond ±{MAX_SAMPLE:g} (the first is "
            f"{float(values[first]):g} at [{at}]); not a plausible measurement")
