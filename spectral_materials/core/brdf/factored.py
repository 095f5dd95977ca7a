"""``FactoredBRDF``: factor packs (or a separable form) with their axes and basis.

A CP model stores, per angular axis k, a factor ``A_k`` of shape (n_k, R) and a
spectral factor of shape (S, R); ``R = packs · pack_size``. A Kautz–McCool
separable model stores ``g (n_x, K)`` over the row axes and ``h (n_y·S, K)`` over
the column axes and the spectral axis. The spectral axis holds wavelength
samples (``basis is None``) or coefficients on an orthonormal basis Ψ (L, m).

Evaluation interpolates each factor linearly along its axes (φ wraps, θ ends
extrapolate), which is exactly what a GPU's linear texture filter does with the
same arrays. A model may carry an analytic specular lobe (:mod:`.lobe`) whose value
is added to the packs'; the packs then hold the residual. A model of a measured table
may be drawn in the table's cells (``cells``, :mod:`.measured_cells`), as its readers look
it up.

File format (``save``/``load``): an uncompressed ``.npz`` whose ``meta`` entry
is a JSON document; see README §"Factor file format" for every array.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..colour import pipeline as colour_pipeline, spectra
from . import measured_cells
from .axes import EDGE_RULES
from .lobe import SpecularLobe
from .params import check_direction_pairs, get_parameterization
from .tabulate import Grid, multilinear

FORMAT = "spectral_materials.factored_brdf"
#: 2: the file carries an analytic lobe (``meta["lobe"]``, ``lobe_spectral``), which a
#: reader of version 1 would drop, taking the residual packs for the whole BRDF; files
#: without one stay version 1. 3: the model is drawn in a measured table's cells
#: (``meta["cells"]``), which a reader of version 2 would draw smooth.
FORMAT_VERSION = 3
READABLE_VERSIONS = (1, 2, 3)


@dataclass
class FactoredBRDF:
    """A factorised spectral BRDF; see the module docstring."""

    parameterization: str
    resolution: tuple[int, ...]
    wavelengths: np.ndarray
    basis: np.ndarray | None
    cosine_weighted: bool
    form: str = "cp"                       # "cp" or "separable"
    factors: list[np.ndarray] = field(default_factory=list)   # cp: per angular axis (n_k, R)
    spectral: np.ndarray | None = None     # cp: (S, R)
    pack_size: int = 4
    split: tuple[tuple[int, ...], tuple[int, ...]] | None = None  # separable
    g: np.ndarray | None = None            # separable: (prod row shape, K)
    h: np.ndarray | None = None            # separable: (prod col shape · S, K)
    edge: str = "linear"
    report: dict = field(default_factory=dict)
    #: An analytic lobe added to the packs (which then hold the residual), or None.
    lobe: SpecularLobe | None = None
    #: (θh, θd, φd) cells of the measured table the model is drawn in, as its readers
    #: look it up (:mod:`.measured_cells`), or None: drawn smooth.
    cells: tuple[int, int, int] | None = None

    # ------------------------------------------------------------------ shape

    @property
    def grid(self) -> Grid:
        return Grid(get_parameterization(self.parameterization), tuple(self.resolution))

    @property
    def spectral_size(self) -> int:
        return int(self.wavelengths.size if self.basis is None else self.basis.shape[1])

    @property
    def terms(self) -> int:
        return int(self.spectral.shape[1] if self.form == "cp" else self.g.shape[1])

    @property
    def packs(self) -> int:
        """Packs of ``pack_size`` terms (a partial last pack counts as one)."""
        return -(-self.terms // self.pack_size) if self.form == "cp" else self.terms

    @property
    def nbytes(self) -> int:
        """Bytes of the stored factor arrays (float32), basis included."""
        arrays = self.factors + [self.spectral] if self.form == "cp" else [self.g, self.h]
        total = sum(a.size * 4 for a in arrays) + (0 if self.lobe is None else self.lobe.nbytes)
        return int(total + (0 if self.basis is None else self.basis.size * 4))

    # ------------------------------------------------------------- evaluation

    def coefficients(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Spectral-axis values (N, S) of the stored quantity (``f·cosθi`` when cosine-weighted)."""
        wi, wo = check_direction_pairs(wi, wo)
        if self.cells is None:
            out = self._stored(wi, wo)
        else:
            out = measured_cells.in_cells(self._stored, wi, wo, self.cosine_weighted,
                                          self.cells)
        lit = (wi[:, 2] > 0) & (wo[:, 2] > 0)
        out[~lit] = 0.0
        return out

    def _stored(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The stored quantity at the pairs themselves (packs, edge scale and lobe)."""
        grid = self.grid
        coords = grid.parameterization.forward(wi, wo)
        scale = grid.edge_scale(coords, self.edge)
        if self.form == "cp":
            out = _contract(self._angular_terms(coords), self.spectral)
        else:
            out = self._separable_coefficients(grid.lookup(coords, self.edge))
        if scale is not None:
            out *= scale[:, None]
        if self.lobe is not None:
            out += self.lobe.coefficients(wi, wo, self.cosine_weighted)
        return out

    def _angular_terms(self, coords: np.ndarray) -> np.ndarray:
        """(N, R): per term, the product over the axes of each factor interpolated at
        ``coords`` (``filtered_factors.FilteredFactorsBRDF`` looks up its GPU rows instead)."""
        prod = np.ones((coords.shape[0], self.terms))
        for (i0, i1, w), f in zip(self.grid.lookup(coords, self.edge), self.factors):
            f = f.astype(np.float64)
            prod *= (1.0 - w)[:, None] * f[i0] + w[:, None] * f[i1]
        return prod

    def _separable_coefficients(self, lookups: list[tuple]) -> np.ndarray:
        rows, cols = self.split
        shape = self.grid.shape
        s = self.spectral_size
        g = self._group_interpolate(self.g, [lookups[k] for k in rows], [shape[k] for k in rows], 1)
        h = self._group_interpolate(self.h, [lookups[k] for k in cols], [shape[k] for k in cols], s)
        return np.einsum("nk,nsk->ns", g[:, 0, :], h)

    @staticmethod
    def _group_interpolate(array, lookups, shape, depth):
        """Multilinear lookup in a factor stored as (prod(shape)·depth, K) → (N, depth, K)."""
        table = array.astype(np.float64).reshape(int(np.prod(shape)), depth, array.shape[1])
        return multilinear(table, shape, lookups)

    def _to_wavelengths(self, coefficients: np.ndarray) -> np.ndarray:
        return coefficients if self.basis is None else _contract(coefficients, self.basis)

    def evaluate_cosine_weighted(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """``f·cosθi`` (N, L) at ``.wavelengths``; 0 below the horizon, clamped at 0.

        A sum of rank-one terms can dip slightly below zero where the BRDF is ~0;
        a reflectance cannot, so spectra are clamped (``xyz`` clamps its XYZ instead,
        as the shaders do).
        """
        values = self._to_wavelengths(self.coefficients(wi, wo))
        if not self.cosine_weighted:
            values = values * np.clip(np.asarray(wi)[:, 2:3], 0.0, None)
        return np.maximum(values, 0.0)

    def evaluate(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """The BRDF ``f`` (N, L) at ``.wavelengths`` (nm), without the cosine, clamped at 0.

        A cosine-weighted model divides by ``max(cosθi, 1e-4)``: within 0.006° of
        the horizon the value is that of the last representable angle.
        """
        values = np.maximum(self._to_wavelengths(self.coefficients(wi, wo)), 0.0)
        if self.cosine_weighted:
            values = values / np.maximum(np.asarray(wi)[:, 2:3],
                                         measured_cells.MIN_CENTRE_COSINE)
        return values

    def xyz(self, wi: np.ndarray, wo: np.ndarray,
            illuminant: str | np.ndarray = "D65") -> np.ndarray:
        """Linear CIE XYZ (N, 3) reflected toward ``wo`` from a directional light at ``wi``.

        Normalised as shared/PROTOCOL.md says (white Lambertian at normal
        incidence → Y = 1). With a basis this is the paper's coefficient dot
        product ``Σ_j R̃_j Ĩ_j``; otherwise a Riemann sum over ``.wavelengths``.
        Clamped at 0 per component (:meth:`reflected_xyz`).
        """
        return self.reflected_xyz(
            wi, wo, colour_pipeline.xyz_weights(illuminant, self.wavelengths, self.basis))

    def reflected_xyz(self, wi: np.ndarray, wo: np.ndarray, weights: np.ndarray, *,
                      clamped: bool = True) -> np.ndarray:
        """XYZ (N, 3) per unit irradiance under a light whose XYZ weights on the model's
        spectral axis are ``weights`` (S, 3): ``f·cosθi`` contracted with them.

        Clamped at 0 per component, as the shaders clamp each light's XYZ: no reflection
        has a negative tristimulus value, yet the packs' signed rest can dip below 0
        beside a black reference near the horizon. ``clamped=False``: as drawn before
        issue 18 (the benchmarks' earlier stage).
        """
        coeffs = self.coefficients(wi, wo)
        if not self.cosine_weighted:
            coeffs = coeffs * np.clip(np.asarray(wi)[:, 2:3], 0.0, None)
        xyz = coeffs @ weights
        return np.maximum(xyz, 0.0) if clamped else xyz

    # ---------------------------------------------------------------- packs

    def truncated(self, packs: int) -> FactoredBRDF:
        """The first ``packs`` packs (a greedy fit's prefix is its own best fit)."""
        if self.form != "cp":
            raise ValueError("truncation applies to CP factor packs")
        if packs < 1:
            raise ValueError(f"keep at least one pack, got {packs}")
        n = min(self.terms, packs * self.pack_size)
        return replace(self, factors=[f[:, :n] for f in self.factors],
                       spectral=self.spectral[:, :n], report=dict(self.report))

    def pack_textures(self) -> list[np.ndarray]:
        """Per axis (and the spectral axis last): (n_k, packs, pack_size) float32 texels.

        One pack is one RGBA texel per sample, as the factor-pack paper stores it;
        a partial last pack is zero-padded.
        """
        if self.form != "cp":
            raise ValueError("pack textures apply to CP factor packs")
        padded = self.packs * self.pack_size
        out = []
        for f in self.factors + [self.spectral]:
            full = np.zeros((f.shape[0], padded), dtype=np.float32)
            full[:, : f.shape[1]] = f
            out.append(full.reshape(f.shape[0], self.packs, self.pack_size))
        return out

    # ---------------------------------------------------------------- storage

    def _meta(self) -> dict:
        grid = self.grid
        return {
            "format": FORMAT,
            "version": 3 if self.cells is not None else 2 if self.lobe is not None else 1,
            "form": self.form,
            "grid": grid.describe(),
            "pack_size": self.pack_size,
            "cosine_weighted": self.cosine_weighted,
            "edge": self.edge,
            "split": None if self.split is None else [list(s) for s in self.split],
            "lobe": None if self.lobe is None else {
                "family": self.lobe.family, "nu": self.lobe.nu, "nv": self.lobe.nv},
            "cells": None if self.cells is None else list(self.cells),
            "spectral_axis": "wavelength" if self.basis is None else "basis",
            "units": {"wavelengths": "nm", "factors": "1/sr (product of all factors)"},
            "report": self.report,
        }

    def save(self, path: str | Path) -> Path:
        """Write a self-describing ``.npz`` (see README, "Factor file format")."""
        path = Path(path)
        arrays = {"wavelengths": self.wavelengths.astype(np.float64)}
        if self.basis is not None:
            arrays["basis"] = self.basis.astype(np.float32)
        if self.form == "cp":
            for k, f in enumerate(self.factors):
                arrays[f"factor_{k}"] = f.astype(np.float32)
            arrays["spectral"] = self.spectral.astype(np.float32)
        else:
            arrays["g"] = self.g.astype(np.float32)
            arrays["h"] = self.h.astype(np.float32)
        if self.lobe is not None:
            arrays["lobe_spectral"] = np.asarray(self.lobe.spectral, dtype=np.float32)
        arrays["meta"] = np.frombuffer(json.dumps(self._meta(), default=json_default).encode(),
                                       dtype=np.uint8)
        with open(path, "wb") as handle:
            np.savez(handle, **arrays)
        return path

    @classmethod
    def load(cls, path: str | Path) -> FactoredBRDF:
        """Read a file written by :meth:`save`; raises ValueError on anything else."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
            raise ValueError(f"{path}: not a readable .npz file ({exc})") from exc
        if "meta" not in arrays:
            raise ValueError(f"{path}: no 'meta' entry; not a FactoredBRDF file")
        try:
            meta = json.loads(arrays["meta"].tobytes().decode())
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ValueError(f"{path}: corrupt 'meta' entry ({exc})") from exc
        if not isinstance(meta, dict) or meta.get("format") != FORMAT \
                or meta.get("version") not in READABLE_VERSIONS:
            found = (f"{meta.get('format')} v{meta.get('version')}" if isinstance(meta, dict)
                     else type(meta).__name__)
            raise ValueError(f"{path}: format {found} is not {FORMAT} v1 or v{FORMAT_VERSION}")
        try:
            model = cls._from_meta(meta, arrays)
            model.validate()
        except (KeyError, TypeError, IndexError) as exc:
            raise ValueError(f"{path}: incomplete or malformed factor file ({exc!r})") from exc
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from exc
        return model

    @classmethod
    def _from_meta(cls, meta: dict, arrays: dict) -> FactoredBRDF:
        if meta["form"] not in ("cp", "separable"):
            raise ValueError(f"unknown form {meta['form']!r}")
        if meta["edge"] not in EDGE_RULES:
            raise ValueError(f"unknown edge rule {meta['edge']!r}")
        if int(meta["pack_size"]) < 1:
            raise ValueError(f"pack_size must be ≥ 1, got {meta['pack_size']}")
        grid = meta["grid"]
        resolution = tuple(int(n) for n in grid["resolution"])
        kwargs = dict(
            parameterization=grid["parameterization"], resolution=resolution,
            wavelengths=spectra.check_wavelengths(arrays["wavelengths"]),
            basis=arrays.get("basis"), cosine_weighted=bool(meta["cosine_weighted"]),
            form=meta["form"], pack_size=int(meta["pack_size"]), edge=meta["edge"],
            report=meta.get("report", {}),
        )
        if meta.get("cells") is not None:
            cells = meta["cells"]
            if not isinstance(cells, list) or not all(
                    isinstance(n, int) and not isinstance(n, bool) for n in cells):
                raise ValueError(f"cells must be a list of integer counts, got {cells!r}")
            kwargs["cells"] = tuple(cells)
        lobe = meta.get("lobe")
        if lobe is not None:
            kwargs["lobe"] = SpecularLobe(str(lobe["family"]), float(lobe["nu"]),
                                          float(lobe["nv"]), arrays["lobe_spectral"])
        if meta["form"] == "cp":
            kwargs["factors"] = [arrays[f"factor_{k}"] for k in range(len(resolution))]
            kwargs["spectral"] = arrays["spectral"]
        else:
            kwargs["split"] = tuple(tuple(s) for s in meta["split"])
            kwargs["g"], kwargs["h"] = arrays["g"], arrays["h"]
        return cls(**kwargs)

    def validate(self) -> None:
        """Check array shapes and finiteness against the grid, and the edge rule; ValueError
        naming what is wrong."""
        if self.edge not in EDGE_RULES:
            raise ValueError(f"unknown edge rule {self.edge!r}; one of {', '.join(EDGE_RULES)}")
        shape = self.grid.shape
        if self.basis is not None and (self.basis.ndim != 2 or not np.isfinite(self.basis).all()):
            raise ValueError("basis must be a finite 2-D array")
        s = self.spectral_size
        if self.basis is not None and self.basis.shape[0] != self.wavelengths.size:
            raise ValueError(f"basis has {self.basis.shape[0]} rows for {self.wavelengths.size} "
                             "wavelengths")
        if self.form == "cp":
            arrays = {f"factor_{k}": f for k, f in enumerate(self.factors)}
            arrays["spectral"] = self.spectral
            if len(self.factors) != len(shape):
                raise ValueError(f"{len(self.factors)} factors for {len(shape)} axes")
            expected = [(n,) for n in shape] + [(s,)]
            terms = {a.shape[1] for a in arrays.values()}
            if len(terms) != 1:
                raise ValueError(f"factors disagree on the term count: {sorted(terms)}")
            for (name, a), first in zip(arrays.items(), expected):
                if a.shape[0] != first[0]:
                    raise ValueError(f"{name} has {a.shape[0]} rows, the grid needs {first[0]}")
        else:
            rows, cols = self.split
            arrays = {"g": self.g, "h": self.h}
            if self.g.shape[0] != np.prod([shape[k] for k in rows]):
                raise ValueError(f"g has {self.g.shape[0]} rows for row axes {rows} of {shape}")
            if self.h.shape[0] != np.prod([shape[k] for k in cols]) * s:
                raise ValueError(f"h has {self.h.shape[0]} rows for column axes {cols} of {shape}")
        for name, a in arrays.items():
            if not np.isfinite(a).all():
                raise ValueError(f"{name} has {int((~np.isfinite(a)).sum())} non-finite values")
        if self.cells is not None and (len(self.cells) != 3 or not all(
                isinstance(n, int) and 1 <= n <= measured_cells.MAX_CELLS for n in self.cells)):
            raise ValueError(f"cells must be 3 counts in [1, {measured_cells.MAX_CELLS}], "
                             f"got {self.cells}")
        if self.lobe is not None:
            self.lobe.validate()
            if self.lobe.spectral.shape[0] != s:
                raise ValueError(f"the lobe has {self.lobe.spectral.shape[0]} spectral "
                                 f"values, the model {s}")


def _contract(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b.T`` for a (N, R) and b (S, R), summed term by term in a fixed order.

    A BLAS product may sum in an order that depends on threads and memory
    alignment, so the same factors could evaluate differently in the last bit
    from one process to the next; stored factors must reload bit-identical.
    """
    b = np.asarray(b, dtype=np.float64)
    out = np.zeros((a.shape[0], b.shape[0]))
    for r in range(a.shape[1]):
        out += a[:, r, None] * b[None, :, r]
    return out


def json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON-serialisable: {type(value).__name__}")


def fit_seconds(model: FactoredBRDF) -> float:
    """Seconds the series ending at ``model`` cost: its tabulation, its factoring up to
    ``model``'s pack count, and what Automatic spent settling it (``settle_seconds``: its
    edge rule, and in cells the check and the pack counts fitted past the one kept)."""
    return sum(float(model.report.get(key, 0.0))
               for key in ("tabulate_seconds", "factor_seconds", "settle_seconds"))
