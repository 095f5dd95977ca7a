"""A small generated material library's sources: project .npz tables, a MERL .binary and
an RGL .bsdf, in folders that become catalogs (core/library tests)."""

from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

import numpy as np

from spectral_materials.core.brdf import models
from spectral_materials.core.colour import spectra
from spectral_materials.core.formats import merl, rgl_bsdf
from spectral_materials.core.formats.tabulated.writer import tabulate_to_file

WL = spectra.wavelength_grid(380.0, 780.0, 20.0)
#: (file stem, model, parameters, colour checker patch)
TABLES = (
    ("red clay", "oren_nayar", {"sigma": 0.5}, 15),
    ("blue felt", "oren_nayar", {"sigma": 0.3}, 13),
    ("yellow paint", "lambert", {}, 16),
    ("green plastic", "ggx", {"alpha_x": 0.3, "alpha_y": 0.3}, 14),
    ("orange gloss", "ashikhmin_shirley", {"nu": 16.0, "nv": 16.0}, 12),
    ("cyan matte", "oren_nayar", {"sigma": 0.2}, 18),
    ("magenta satin", "ward", {"alpha_x": 0.25, "alpha_y": 0.25}, 17),
    ("white card", "lambert", {}, 19),
)


def _brdf(model: str, params: dict, patch: int):
    colour = (spectra.WAVELENGTHS_REFERENCE, spectra.colorchecker(patch))
    role = "diffuse" if model in ("ashikhmin_shirley", "ward", "ggx") else "albedo"
    if model == "ggx":
        return models.make_model(model, **params, **{"diffuse": colour})
    return models.make_model(model, **params, **{role: colour})


def rgl_fields(seed: int = 0) -> dict:
    """A well-formed isotropic spectral RGL tensor file's fields (random values)."""
    rng = np.random.default_rng(seed)
    n, nti = 6, 4
    f32 = np.float32
    return {
        "description": np.frombuffer(b"generated fabric", np.uint8),
        "jacobian": np.array([1], np.uint8),
        "theta_i": np.linspace(0.0, math.radians(85.0), nti).astype(f32),
        "phi_i": np.arange(2, dtype=f32),
        "ndf": rng.uniform(0.5, 2.0, (9, 10)).astype(f32),
        "sigma": rng.uniform(0.5, 2.0, (9, 10)).astype(f32),
        "vndf": rng.uniform(0.2, 2.0, (2, nti, 7, 8)).astype(f32),
        "luminance": rng.uniform(0.2, 2.0, (2, nti, n, n)).astype(f32),
        "wavelengths": np.array([400.0, 500.0, 600.0, 700.0], f32),
        "spectra": rng.uniform(0.05, 0.5, (2, nti, 4, n, n)).astype(f32),
    }


def write_merl_file(path: Path) -> Path:
    """A MERL file of a reddish Ashikhmin–Shirley (RGB), sampled at the MERL cells."""
    one = models.AshikhminShirley(nu=16, nv=16, diffuse=1.0, specular=0.05)
    zero = models.AshikhminShirley(nu=16, nv=16, diffuse=0.0, specular=0.05)
    rd = np.array([0.6, 0.2, 0.1])

    def rgb(wi, wo):
        s = zero(wi, wo, np.array([550.0]))
        return (one(wi, wo, np.array([550.0])) - s) * rd + s

    return merl.write_merl(path, merl.merl_table_from_brdf(rgb))


def make_sources(root: Path, merl_file: Path | None = None) -> list[Path]:
    """Ten files under ``root``: studio/paints/*.npz (8), merl/red plastic.binary (a copy
    of ``merl_file`` when given), rgl/fabric.bsdf. Returns their paths."""
    paints = root / "studio" / "paints"
    paints.mkdir(parents=True)
    paths = []
    for stem, model, params, patch in TABLES:
        paths.append(tabulate_to_file(_brdf(model, params, patch), paints / f"{stem}.npz",
                                      "io_iso", (6, 12, 6), WL))
    (root / "merl").mkdir()
    target = root / "merl" / "red plastic.binary"
    if merl_file is not None:
        try:
            os.link(merl_file, target)      # 35 MB per test otherwise; nobody writes to it
        except OSError:
            shutil.copyfile(merl_file, target)
    else:
        write_merl_file(target)
    paths.append(target)
    (root / "rgl").mkdir()
    paths.append(rgl_bsdf.write_tensor_file(root / "rgl" / "fabric.bsdf", rgl_fields()))
    return paths
