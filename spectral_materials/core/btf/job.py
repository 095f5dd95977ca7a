"""One BTF material job: load or generate the BTF, fit reflectance fields, make it drawable.

Pure Python (no ``bpy``): the Fit BTF operator runs :func:`run_btf_job` in a worker
thread, scripts call it directly. The result carries the :class:`DrawableBTF` and the
figures the panel and the report show (ε after the BTF paper's eq. 2, fit seconds,
GPU bytes).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..progress import report
from . import fit as btf_fit, generate as btf_generate, render as btf_render
from .container import BTF, btf_from_ubo, reflectance_spectra

SOURCES = ("corduroy", "knit", "stones", "ubo2003", "ubo2014")
MODELS = ("RFP", "RFNL")
#: Largest generated tile side: 81 × 81 directions × 16 bands × 48² texels ≈ 0.9 GiB.
MAX_GENERATED = 48


@dataclass(frozen=True)
class BTFJob:
    """What to fit: ``source`` one of :data:`SOURCES`; ``texels`` the generated tile's
    side or, for files, the side of the window cropped from the corner (0 = all)."""

    source: str
    filepath: str = ""
    texels: int = 32
    model: str = "RFNL"
    lobes: int = 2
    basis_size: int = 6
    name: str = "BTF"

    def validate(self) -> None:
        if self.source not in SOURCES:
            raise ValueError(f"unknown BTF source {self.source!r}; valid: {SOURCES}")
        if self.model not in MODELS:
            raise ValueError(f"unknown reflectance-field model {self.model!r}; valid: {MODELS}")
        if self.source in btf_generate.MATERIALS and not 1 <= self.texels <= MAX_GENERATED:
            raise ValueError(f"generated BTFs have 1..{MAX_GENERATED} texels per side (81 × 81 "
                             f"directions × 16 bands stay under 1 GiB), got {self.texels}")
        if self.model == "RFNL" and not 1 <= self.lobes <= 3:
            raise ValueError(f"RFNL draws 1..3 lobes, got {self.lobes}")


@dataclass
class BTFJobResult:
    drawable: btf_render.DrawableBTF
    figures: dict = field(default_factory=dict)


def load_source(job: BTFJob, callback=None) -> BTF:
    """The BTF a job names: generated, or read from a UBO file (linear values)."""
    job.validate()
    if job.source in btf_generate.MATERIALS:
        return btf_generate.generate_btf(job.source, texels=job.texels, name=job.name,
                                         callback=callback)
    from ..formats import ubo_btf

    window = (slice(0, job.texels), slice(0, job.texels)) if job.texels > 0 else None
    if job.source == "ubo2003":
        return btf_from_ubo(ubo_btf.read_ubo2003(job.filepath, linear=True), texels=window,
                            name=job.name)
    return btf_from_ubo(ubo_btf.read_ubo2014(job.filepath), texels=window, name=job.name)


def albedo_coefficients(albedo: np.ndarray, wavelengths: np.ndarray | None,
                        basis_size: int) -> tuple[np.ndarray, np.ndarray]:
    """(basis, coefficients) of per-texel albedo (H, W, C) on the reference grid: spectral
    albedo interpolated (end values held), RGB albedo uplifted with Smits (1999)."""
    spectra = reflectance_spectra(np.maximum(albedo, 0.0), wavelengths,
                                  btf_render.WAVELENGTHS)
    return btf_render.albedo_basis(spectra, basis_size)


def drawable_from_fit(model, albedo: np.ndarray, wavelengths, *, basis_size: int = 6,
                      name: str = "BTF") -> btf_render.DrawableBTF:
    """A fitted RFP/RFNL model and its albedo as a :class:`DrawableBTF`."""
    basis, coefficients = albedo_coefficients(albedo, wavelengths, basis_size)
    params = np.asarray(model.params, np.float32)
    if model.kind == "RFP" and params.shape[-1] == 6:
        params = np.concatenate([params, np.zeros((*params.shape[:-1], 2), np.float32)], -1)
    return btf_render.DrawableBTF(model.kind, int(getattr(model, "lobes", 0) or 0),
                                  np.asarray(model.views), params, coefficients, basis,
                                  name=name)


def run_btf_job(job: BTFJob, callback=None) -> BTFJobResult:
    """Load or generate, fit, measure ε, and make drawable. Progress: loading 0–0.3,
    fitting 0.3–0.9, error 0.9–1."""
    job.validate()

    def part(lo, hi):
        if callback is None:
            return None
        return lambda f, message: callback(lo + (hi - lo) * f, message)

    report(callback, 0.0, f"loading {job.source}")
    data = load_source(job, part(0.0, 0.3))
    start = time.perf_counter()
    if job.model == "RFP":
        model = btf_fit.fit_rfp(data, callback=part(0.3, 0.9))
    else:
        model = btf_fit.fit_rfnl(data, lobes=job.lobes, callback=part(0.3, 0.9))
    seconds = time.perf_counter() - start
    report(callback, 0.9, "measuring ε")
    eps = btf_fit.epsilon(data, model)
    drawable = drawable_from_fit(model, model.albedo, data.wavelengths,
                                 basis_size=job.basis_size, name=job.name)
    figures = {"model": job.model, "lobes": job.lobes if job.model == "RFNL" else 0,
               "source": job.source, "epsilon_avg": float(eps["avg"]),
               "epsilon_min": float(eps["min"]), "epsilon_max": float(eps["max"]),
               "fit_seconds": seconds, "gpu_bytes": drawable.nbytes,
               "views": len(drawable.views), "lights": len(data.lights),
               "texels": list(drawable.texels),
               "dropped_views": list(map(int, getattr(model, "dropped_views", [])))}
    report(callback, 1.0, "done")
    return BTFJobResult(drawable, figures)
