"""An RGL ``.bsdf`` material as a BRDF callable (evaluation notes in :mod:`.rgl_bsdf`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...brdf.params import check_direction_pairs
from ...colour import spectra as _spectra
from ...colour.uplift import SmitsUplift
from .warp import _bilinear, _cell, _corners, _elevation, _phi2u, _theta2u, _Warp

#: Direction pairs evaluated per chunk.
CHUNK_POINTS = 1 << 14

@dataclass
class RGLBSDF:
    """An RGL ``.bsdf`` material as a BRDF callable ``f(wi, wo, wavelengths) -> (N, L)``.

    Attributes
    ----------
    theta_i, phi_i : ndarray
        Incident-direction grid (radians).
    ndf, sigma : ndarray [nφ, nθ]
    vndf, luminance : ndarray [φi, θi, ny, nx]
    values : ndarray [φi, θi, C, n, n]
        ``spectra`` (C = L) or ``rgb`` (C = 3).
    wavelengths : ndarray (L,) or None
        The file's grid in nm; None for RGB files.
    jacobian : bool
    description : str
    defects : dict
        ``nan``, ``inf``, ``negative`` totals and ``fields``: the counts per field.
    """

    theta_i: np.ndarray
    phi_i: np.ndarray
    ndf: np.ndarray
    sigma: np.ndarray
    vndf: np.ndarray
    luminance: np.ndarray
    values: np.ndarray
    wavelengths: np.ndarray | None = None
    jacobian: bool = True
    description: str = ""
    defects: dict = field(default_factory=dict)
    path: Path | None = None

    def __post_init__(self) -> None:
        self.theta_i = np.asarray(self.theta_i, dtype=np.float64)
        self.phi_i = np.asarray(self.phi_i, dtype=np.float64)
        # float32 tables stay float32: lookups promote them to float64 exactly, and a copy
        # would double what they cost.
        self.ndf = _float_table(self.ndf)
        self.sigma = _float_table(self.sigma)
        self.values = np.asarray(self.values, dtype=np.float32)
        self._warp = _Warp.build(np.ascontiguousarray(self.vndf))
        self._resamplers: dict[tuple, np.ndarray] = {}
        self._uplift = SmitsUplift()
        self.reduction = 1
        if not self.isotropic:
            self.reduction = int(np.rint(2 * math.pi / (self.phi_i[-1] - self.phi_i[0])))

    @property
    def isotropic(self) -> bool:
        """As the reference: ``phi_i`` has at most 2 entries."""
        return self.phi_i.size <= 2

    @property
    def is_rgb(self) -> bool:
        return self.wavelengths is None

    @property
    def channels(self) -> int:
        return int(self.values.shape[2])

    # ----------------------------------------------------------------- evaluation

    def _fold(self, wi: np.ndarray, wo: np.ndarray) -> None:
        """Mitsuba's symmetry folding for reduction 2/4 (in place)."""
        if self.reduction < 2:
            return
        sy = wi[:, 1].copy()
        sx = wi[:, 0].copy() if self.reduction == 4 else sy
        mx = np.where(np.signbit(sx), 1.0, -1.0)  # mulsign_neg(v, s) = v·(−sign s)
        my = np.where(np.signbit(sy), 1.0, -1.0)
        for v in (wi, wo):
            v[:, 0] *= mx
            v[:, 1] *= my

    def _native(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Values at the file's channels for lit (N, 3) unit pairs: (N, C)."""
        wi = wi.copy()
        wo = wo.copy()
        self._fold(wi, wo)
        wm = wi + wo
        wm /= np.linalg.norm(wm, axis=1, keepdims=True)
        theta_i = _elevation(wi)
        phi_i = np.arctan2(wi[:, 1], wi[:, 0])
        theta_m = _elevation(wm)
        phi_m = np.arctan2(wm[:, 1], wm[:, 0])
        u_wi = np.stack([_theta2u(theta_i), _phi2u(phi_i)], axis=-1)
        um_y = _phi2u(phi_m - phi_i if self.isotropic else phi_m)
        u_m = np.stack([_theta2u(theta_m), um_y - np.floor(um_y)], axis=-1)

        corners = _corners(self.phi_i, self.theta_i, phi_i, theta_i)
        sample = self._warp.invert(u_m, corners)
        n = self.values.shape[3]
        ix, fx = _cell(sample[:, 0], self.values.shape[4])
        iy, fy = _cell(sample[:, 1], n)
        out = np.zeros((wi.shape[0], self.channels))
        for a, b, w in corners:
            for dy, wy in ((0, 1 - fy), (1, fy)):
                for dx, wx in ((0, 1 - fx), (1, fx)):
                    out += (w * wy * wx)[:, None] * self.values[a, b, :, iy + dy, ix + dx]
        if self.jacobian:
            ndf = _bilinear(self.ndf, u_m)
            sigma = _bilinear(self.sigma, u_wi)
            with np.errstate(divide="ignore", invalid="ignore"):
                scale = np.where(sigma > 0, ndf / (4.0 * sigma), 0.0)
            out *= scale[:, None]
        out[~np.isfinite(out)] = 0.0
        return out

    def eval_native(self, wi, wo) -> np.ndarray:
        """The reference's ``BRDF::eval`` (N, C) at the file's wavelengths (or R, G, B).

        Not clamped; 0 where either direction is at or below the horizon.
        """
        wi, wo = _directions(wi, wo)
        out = np.zeros((wi.shape[0], self.channels))
        lit = np.nonzero((wi[:, 2] > 0) & (wo[:, 2] > 0))[0]
        for begin in range(0, lit.size, CHUNK_POINTS):
            rows = lit[begin : begin + CHUNK_POINTS]
            out[rows] = self._native(wi[rows], wo[rows])
        return out

    def rgb(self, wi, wo) -> np.ndarray:
        """RGB BRDF (N, 3) of an RGB file (unclamped, as the reference)."""
        if not self.is_rgb:
            raise TypeError("rgb() is for RGB files; this one is spectral (call it with "
                            "wavelengths)")
        return self.eval_native(wi, wo)

    def _resampler(self, wl: np.ndarray) -> np.ndarray:
        key = tuple(wl.tolist())
        if key not in self._resamplers:
            own = self.wavelengths
            eye = np.eye(own.size)
            matrix = np.stack([np.interp(wl, own, row, left=0.0, right=0.0) for row in eye])
            if len(self._resamplers) >= 16:
                self._resamplers.pop(next(iter(self._resamplers)))
            self._resamplers[key] = matrix
        return self._resamplers[key]

    def __call__(self, wi, wo, wavelengths) -> np.ndarray:
        """The spectral BRDF (N, L) at ``wavelengths`` (nm), ≥ 0; see the module notes."""
        wl = _spectra.check_wavelengths(wavelengths)
        native = self.eval_native(wi, wo)
        if self.is_rgb:
            return self._uplift(native, wl)
        return np.maximum(native @ self._resampler(wl), 0.0)

    def describe(self) -> dict:
        """JSON-serialisable summary (no samples)."""
        return {
            "format": "rgl_bsdf",
            "path": None if self.path is None else str(self.path),
            "kind": "rgb" if self.is_rgb else "spectral",
            "isotropic": self.isotropic,
            "reduction": self.reduction,
            "jacobian": bool(self.jacobian),
            "theta_i": int(self.theta_i.size),
            "phi_i": int(self.phi_i.size),
            "resolution": list(self.values.shape[3:]),
            "wavelengths": None if self.is_rgb else [
                float(self.wavelengths[0]), float(self.wavelengths[-1]),
                int(self.wavelengths.size)],
            "description": self.description,
            "defects": dict(self.defects),
        }


def _float_table(table) -> np.ndarray:
    arr = np.asarray(table)
    return arr if arr.dtype in (np.float32, np.float64) else arr.astype(np.float64)


def _directions(wi, wo) -> tuple[np.ndarray, np.ndarray]:
    """Checked (params.check_direction_pairs) and normalised; zero vectors refused."""
    wi, wo = check_direction_pairs(wi, wo)
    ni = np.linalg.norm(wi, axis=1, keepdims=True)
    no = np.linalg.norm(wo, axis=1, keepdims=True)
    if np.any(ni == 0) or np.any(no == 0):
        raise ValueError("wi/wo contain zero vectors")
    return wi / ni, wo / no
