"""Snapshot what a material or light describes into plain data, and build BRDFs from it.

Jobs run in a worker thread, which must not touch ``bpy``: the main thread calls
:func:`material_inputs` / :func:`light_spd` first, which read every property, load
every file and validate everything, raising :class:`SourceError` with a message that
names the material or light and the problem. What they return is plain Python
and NumPy, hashed by :func:`input_hash` to tell whether stored factors are current.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...core.brdf import factor, models
from ...core.brdf.job import AUTOMATIC_RULES
from ...core.brdf.lobe import INVISIBLE_REST, LOBE_FAMILIES
from ...core.brdf.params import get_parameterization
from ...core.colour import spectra
from ...core.formats.brdf_files import looked_up_in_cells, read_brdf_file
from ..lights.spd import (
    WAVELENGTHS,
    SourceError,
    abspath as _abspath,
    finite as _finite,
    light_spd,
    typed_or_csv as _typed_or_csv,
)
from .properties import MODEL_KEYS, PARAMETERIZATION_KEYS

# SourceError, WAVELENGTHS and light_spd live in lights.spd (the lights layer must not
# import this one) and are served from here too.
__all__ = ["WAVELENGTHS", "MaterialInputs", "SourceError", "input_hash", "light_spd",
           "material_inputs", "resolve_auto", "resolution_for", "sampled_spectra",
           "spectrum_from_source", "spectrum_label"]

#: Exponents beyond this underflow every sample but the peak on any grid we can store.
MAX_EXPONENT = 1e6
MAX_THETA_CELLS = 180
MAX_PACKS = 64
MAX_PACK_SIZE = 16

# Which spectra each model takes, in the property group's names (core name → property).
MODEL_SPECTRA = {
    "lambert": {"albedo": "diffuse"},
    "oren_nayar": {"albedo": "diffuse"},
    "ashikhmin_shirley": {"diffuse": "diffuse", "specular": "specular"},
    "ward": {"diffuse": "diffuse", "specular": "specular"},
    "ggx": {"ior_n": "ior_n", "ior_k": "ior_k", "diffuse": "diffuse"},
}
MODEL_SCALARS = {
    "lambert": (),
    "oren_nayar": ("sigma",),
    "ashikhmin_shirley": ("nu", "nv"),
    "ward": ("alpha_x", "alpha_y"),
    "ggx": ("alpha_x", "alpha_y"),
}
#: Models with a specular lobe. "Automatic" factors them, when anisotropic, in
#: half/difference angles, which align the lobe with the grid (the paper's case (c));
#: isotropic ones stay in the 3-axis input/output layout, which measured better here.
GLOSSY_MODELS = ("ashikhmin_shirley", "ward", "ggx")
AUTO_GLOSSY = "auto_glossy"
# Range the spectra of each role must lie in (checked before the model sees them).
_SPECTRUM_RANGE = {"albedo": (0.0, 1.0), "diffuse": (0.0, 1.0), "specular": (0.0, 1.0),
                   "ior_n": (1e-6, 100.0), "ior_k": (0.0, 100.0)}


@dataclass
class MaterialInputs:
    """Everything a factorisation of one material depends on, as plain data."""

    name: str
    source: str                               # "analytic" or "file"
    model: str | None = None                  # core registry name
    scalars: dict = field(default_factory=dict)
    spectra: dict = field(default_factory=dict)   # core parameter → (L,) on WAVELENGTHS
    filepath: str | None = None
    file_sha256: str | None = None
    parameterization: str = "io"
    theta_cells: int = 32
    packs: int = 4
    target_de94: float | None = None
    pack_size: int = 4
    smoothing: int = 0
    lobe: str = "off"                         # core/brdf/job.py LOBE_SETTINGS
    automatic: bool = False                   # the parameterisation is "Automatic"
    cells: str = "auto"                       # core/brdf/job.py CELL_SETTINGS

    def brdf(self):
        """The BRDF callable (may run in a worker thread)."""
        if self.source == "file":
            return read_brdf_file(self.filepath)
        params = dict(self.scalars)
        params.update({k: (WAVELENGTHS, v) for k, v in self.spectra.items()})
        return models.make_model(self.model, **params)

    def hash_payload(self) -> dict:
        return {
            "source": self.source, "model": self.model, "scalars": self.scalars,
            "spectra": {k: np.asarray(v, np.float64).tobytes().hex()
                        for k, v in sorted(self.spectra.items())},
            "file": self.file_sha256, "parameterization": self.parameterization,
            "theta_cells": self.theta_cells, "packs": self.packs,
            "target_de94": self.target_de94, "pack_size": self.pack_size,
            "smoothing": self.smoothing, "lobe": self.lobe, "automatic": self.automatic,
            # What "auto" chooses among: a material factored before a family existed is
            # factored again (Oren–Nayar's term changed what Automatic does for rough
            # diffuse materials).
            **({"lobe_families": list(LOBE_FAMILIES)} if self.lobe == "auto" else {}),
            # Beside a lobe the packs factor the rest that shows (lobe.INVISIBLE_REST):
            # a material factored before that rule is factored again.
            **({"invisible_rest": INVISIBLE_REST} if self.lobe != "off" else {}),
            # What Automatic chooses changed: a material it chose for is factored again.
            **({"automatic_rules": AUTOMATIC_RULES} if self.automatic else {}),
            # Only where it can change the result (a file looked up in cells), so that other
            # materials keep their hash.
            **({"cells": self.cells} if self.source == "file"
               and looked_up_in_cells(self.filepath or "") else {}),
        }


def input_hash(inputs: MaterialInputs, basis: np.ndarray | None) -> str:
    """SHA-256 over the inputs and the basis the factors are expressed on."""
    digest = hashlib.sha256(json.dumps(inputs.hash_payload(), sort_keys=True).encode())
    if basis is not None:
        digest.update(np.ascontiguousarray(basis, dtype=np.float32).tobytes())
    return digest.hexdigest()


def spectrum_label(material_settings, param: str, prop: str) -> str:
    """How the UI and messages name a model's spectrum ("Albedo" for the albedo role)."""
    return "Albedo" if param == "albedo" else \
        material_settings.bl_rna.properties[prop].name


def spectrum_from_source(group, owner: str, label: str) -> np.ndarray:
    """A spectrum property group → values on :data:`WAVELENGTHS`."""
    what = f"{owner}: {label} spectrum"
    try:
        if group.kind == "COLORCHECKER":
            return spectra.colorchecker(int(group.patch), WAVELENGTHS)
        if group.kind == "CONSTANT":
            return np.full(WAVELENGTHS.shape, _finite(f"{what} value", group.constant))
        return _typed_or_csv(group)
    except SourceError as exc:
        raise SourceError(f"{what}: {exc}") from None
    except (ValueError, OSError) as exc:
        raise SourceError(f"{what}: {exc}") from None


def resolve_auto(parameterization: str, isotropic: bool, lobe: str = "off") -> str:
    """The parameterisation "Automatic" stands for, once isotropy is known: with a specular
    lobe the packs hold the smooth rest, which input/output angles separate best
    (docs/bench_colour_targets.md); without one, anisotropic glossy models take
    half/difference angles."""
    if parameterization == AUTO_GLOSSY:
        return "io" if isotropic or lobe != "off" else "hd"
    return parameterization


def resolution_for(parameterization: str, isotropic: bool, theta_cells: int) -> tuple[int, ...]:
    """Scale the parameterisation's default grid so that θ has ``theta_cells`` cells per 90°."""
    return get_parameterization(parameterization, isotropic).theta_resolution(theta_cells)


def _check_settings(name: str, settings) -> None:
    if not 2 <= settings.theta_cells <= MAX_THETA_CELLS:
        raise SourceError(f"{name}: θ cells must be in 2..{MAX_THETA_CELLS}, "
                          f"got {settings.theta_cells}")
    if not 1 <= settings.packs <= MAX_PACKS:
        raise SourceError(f"{name}: packs must be in 1..{MAX_PACKS}, got {settings.packs}")
    if not 1 <= settings.pack_size <= MAX_PACK_SIZE:
        raise SourceError(f"{name}: pack size must be in 1..{MAX_PACK_SIZE}, "
                          f"got {settings.pack_size}")
    if not 0 <= settings.smoothing <= 31:
        raise SourceError(f"{name}: smoothing must be in 0..31, got {settings.smoothing}")
    if settings.use_target:
        target = _finite(f"{name}: target ΔE94", settings.target_de94)
        if not 0 < target <= 100:
            raise SourceError(f"{name}: target ΔE94 must be in (0, 100], got {target}")


def _check_scalars(name: str, model: str, scalars: dict, labels: dict) -> None:
    for key, value in scalars.items():
        _finite(f"{name}: {labels[key]}", value)
    if model == "oren_nayar" and not 0 <= scalars["sigma"] <= math.pi / 2:
        raise SourceError(f"{name}: Oren–Nayar σ must be in [0, π/2] radians, "
                          f"got {scalars['sigma']}")
    if model == "ashikhmin_shirley":
        for key in ("nu", "nv"):
            if not 1 <= scalars[key] <= MAX_EXPONENT:
                raise SourceError(
                    f"{name}: Ashikhmin–Shirley exponent {key} must be in [1, {MAX_EXPONENT:g}]"
                    f" (below 1 the lobe is flat, above it narrower than any stored grid "
                    f"resolves), got {scalars[key]:g}")


def material_inputs(material) -> MaterialInputs:
    """Read and validate a material's spectral description (main thread only)."""
    s = material.spectral
    name = f"Material '{material.name}'"
    _check_settings(name, s)
    parameterization = PARAMETERIZATION_KEYS[s.parameterization]
    if s.parameterization == "AUTO" and s.source == "ANALYTIC" and \
            MODEL_KEYS[s.model] in GLOSSY_MODELS:
        parameterization = AUTO_GLOSSY
    common = dict(name=material.name, parameterization=parameterization,
                  theta_cells=int(s.theta_cells), packs=int(s.packs),
                  target_de94=float(s.target_de94) if s.use_target else None,
                  pack_size=int(s.pack_size), smoothing=int(s.smoothing),
                  lobe=s.specular_lobe.lower(), automatic=s.parameterization == "AUTO",
                  # The setting is shown, and has a meaning, for data files only.
                  cells=s.measured_cells.lower() if s.source == "FILE" else "auto")
    if s.source == "FILE":
        path = _abspath(s.filepath)
        if not path:
            raise SourceError(f"{name}: no data file chosen")
        if not Path(path).is_file():
            raise SourceError(f"{name}: data file {path} does not exist")
        try:
            read_brdf_file(path)     # validates header, sizes and samples now
        except ValueError as exc:
            raise SourceError(f"{name}: {exc}") from None
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        return MaterialInputs(source="file", filepath=path, file_sha256=digest, **common)
    model = MODEL_KEYS[s.model]
    scalars = {key: float(getattr(s, key)) for key in MODEL_SCALARS[model]}
    labels = {key: f"{s.bl_rna.properties[key].name} ({key})" for key in scalars}
    _check_scalars(name, model, scalars, labels)
    values = {}
    for param, prop in MODEL_SPECTRA[model].items():
        label = spectrum_label(s, param, prop).lower()
        spectrum = spectrum_from_source(getattr(s, prop), name, label)
        lo, hi = _SPECTRUM_RANGE[param]
        bad = (spectrum < lo) | (spectrum > hi) | ~np.isfinite(spectrum)
        if bad.any():
            first = int(np.argmax(bad))
            raise SourceError(f"{name}: {label} spectrum has {int(bad.sum())} values outside "
                              f"[{lo:g}, {hi:g}], first {spectrum[first]:g} at "
                              f"{WAVELENGTHS[first]:g} nm")
        values[param] = spectrum
    inputs = MaterialInputs(source="analytic", model=model, scalars=scalars, spectra=values,
                            **common)
    try:
        inputs.brdf()
    except ValueError as exc:
        raise SourceError(f"{name}: {exc}") from None
    return inputs


def sampled_spectra(brdf, isotropic: bool) -> np.ndarray:
    """A BRDF's f·cosθi spectra every 10° (the spectra the scene basis must represent)."""
    values = factor.sample_brdf_spectra(brdf, WAVELENGTHS, isotropic)
    keep = np.abs(values).max(axis=1) > 0
    return values[keep] if keep.any() else values[:1]
