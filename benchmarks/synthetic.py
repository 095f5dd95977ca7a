"""Synthetic factor packs for the speed benchmarks (draw, EEVEE): speed and cost do not
depend on the values, so random positive factors in the factor-pack paper's layouts."""

from __future__ import annotations

import numpy as np

from spectral_materials.core.brdf.factored import FactoredBRDF
from spectral_materials.core.colour import spectra

#: The factor-pack paper's layouts: io_iso 90×180×90 and hd 90×45×90×45.
LAYOUTS = {"io_iso": (90, 180, 90), "hd": (90, 45, 90, 45)}
BASIS_SIZE = 8
PACK_SIZE = 4
#: The benchmarks' UV sphere.
SEGMENTS, RINGS = 128, 64
#: The sphere's projected radius per pixel of target side: 565 px on 1200 → π·565² ≈ 1.0 M.
DISC_FRACTION = 565.0 / 1200.0


def synthetic_model(layout: str, packs: int) -> FactoredBRDF:
    """Factor packs of random positive values, seeded by layout and pack count."""
    rng = np.random.default_rng(1000 * list(LAYOUTS).index(layout) + packs)
    wl = spectra.WAVELENGTHS_REFERENCE
    terms = PACK_SIZE * packs
    basis = np.linalg.qr(rng.standard_normal((wl.size, BASIS_SIZE)))[0]
    return FactoredBRDF(
        parameterization=layout, resolution=LAYOUTS[layout], wavelengths=wl, basis=basis,
        cosine_weighted=True, pack_size=PACK_SIZE, edge="horizon",   # as new packs are
        factors=[rng.uniform(0.5, 1.5, (n, terms)).astype(np.float32)
                 for n in LAYOUTS[layout]],
        spectral=rng.uniform(0.5, 1.5, (BASIS_SIZE, terms)).astype(np.float32))
