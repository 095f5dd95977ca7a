"""Enum items that the property groups of several capabilities share.

The CIE illuminants name a light's SPD, the PRT sky and the scene's adaptation white; the
observer and the tone map are scene-wide options read by factoring and by every drawer.
"""

from __future__ import annotations

from ...core.colour import spectra

ILLUMINANT_ITEMS = [(name, name, f"CIE standard illuminant {name}")
                    for name in spectra.ILLUMINANT_NAMES]
OBSERVER_ITEMS = [
    ("CIE_1931_2", "CIE 1931 2°", "The 2° standard observer (the measurement protocol's)"),
    ("CIE_1964_10", "CIE 1964 10°", "The 10° supplementary standard observer"),
]
#: Observer enum identifier → the colour-matching functions' name in ``colour``.
OBSERVER_NAMES = {"CIE_1931_2": "CIE 1931 2 Degree Standard Observer",
                  "CIE_1964_10": "CIE 1964 10 Degree Standard Observer"}
TONE_MAP_ITEMS = [
    ("SIGMOID", "Sigmoid", "Extended Reinhard curve; values up to 'White' map to display white"),
    ("CLIP", "Clip", "No tone mapping: linear sRGB clipped to [0, 1]"),
]
