"""The fitted BTF models (RFP, RFNL, LAF, CP: parameter layouts in :mod:`.fit`), how each
evaluates and counts its GPU bytes, the per-texel albedo of the luminance fits, and the
helpers every fitter shares."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from . import lm as btf_lm
from .container import BTF, HemisphereTriangulation, InvalidBTF
from .lm import N_MAX, N_MIN

#: Bytes of one float32 RGBA texel.
TEXEL_BYTES = 16


class InsufficientBTFData(InvalidBTF):
    """Too few present samples to fit a model (every view dropped, or fewer samples than
    unknowns)."""


# ------------------------------------------------------------------------- albedo


def spectral_albedo(btf: BTF) -> np.ndarray:
    """Per-texel colour ``(H, W, C)`` float32 of the luminance-fit scheme (PTM §3.3).

    ``albedo = Σ_{v,l present} values / Σ_{v,l present} Y`` with ``Y = values · w``, so
    ``albedo · w = 1``. A texel that is black everywhere gets the flat grey ``1/Σw`` (also
    of luminance 1): its fitted luminance is ~0, and any finite colour reconstructs 0.
    Accumulated view by view in float64 (memory: one view at a time).
    """
    h, w = btf.texels
    weights = btf.channel_weights()
    total = np.zeros((h, w, btf.values.shape[-1]))
    for v in range(len(btf.views)):
        present = btf.present[v]
        if present.any():
            total += btf.values[v, present].sum(axis=0, dtype=np.float64)
    lum = total @ weights                                   # = Σ Y by linearity
    grey = np.full(total.shape[-1], 1.0 / weights.sum())
    ok = lum > 1e-30
    albedo = np.where(ok[..., None], total / np.where(ok, lum, 1.0)[..., None], grey)
    return albedo.astype(np.float32)


def rfp_basis(lights: np.ndarray) -> np.ndarray:
    """(N, 6) biquadratic basis ``[lu², lv², lu·lv, lu, lv, 1]`` of light directions,
    ``(lu, lv) = (l_x, l_y)`` (Malzbender et al. 2001, eq. 2)."""
    d = np.asarray(lights, dtype=np.float64).reshape(-1, 3)
    lu, lv = d[:, 0], d[:, 1]
    return np.stack([lu * lu, lv * lv, lu * lv, lu, lv, np.ones_like(lu)], axis=1)


# ------------------------------------------------------------------------- models


@dataclass(kw_only=True)
class BTFModel:
    """What every fitted model shares (see the module docstring for the layouts).

    Attributes
    ----------
    kind : str
        ``"RFP"``, ``"RFNL"``, ``"LAF"`` or ``"CP"``.
    views : ndarray (V', 3)
        Modelled view directions.
    view_indices : ndarray (V',) int
        Their indices in the fitted BTF.
    lights : ndarray (L, 3)
        The fitted BTF's light directions (where :meth:`reconstruct` evaluates).
    channel_weights : ndarray (C,)
        Luminance weights of the fitted BTF.
    texels : tuple[int, int]
        (H, W).
    albedo : ndarray (H, W, C) float32 or None
        Per-texel colour of luminance-fit models (None for CP).
    dropped_views : tuple[int, ...]
        BTF view indices left out for lack of present lights.
    fit_seconds : float
        Wall time of the fit.
    history : ndarray or None
        Solver history (LM: total ½Σr² per iteration; CP: squared error per pack).
    """

    kind: str
    views: np.ndarray
    view_indices: np.ndarray
    lights: np.ndarray
    channel_weights: np.ndarray
    texels: tuple[int, int]
    albedo: np.ndarray | None = None
    dropped_views: tuple[int, ...] = ()
    fit_seconds: float = 0.0
    history: np.ndarray | None = None

    @property
    def channels(self) -> int:
        return len(self.channel_weights)

    # -- evaluation ------------------------------------------------------------
    def _luminance(self, position: int, lights: np.ndarray) -> np.ndarray:
        """(N, H·W) float64 luminance of the view at ``position`` for unit lights."""
        raise NotImplementedError

    def luminance_at(self, view_index: int, lights: np.ndarray) -> np.ndarray:
        """Luminance ``(N, H, W)`` float32 of modelled view ``view_index`` (a position in
        :attr:`views`) for any light directions ``(N, 3)`` (normalised here)."""
        position = self._position(view_index)
        d = np.asarray(lights, dtype=np.float64).reshape(-1, 3)
        d = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
        return _to_float32(self._luminance(position, d)).reshape(len(d), *self.texels)

    def reconstruct_view(self, view_index: int) -> np.ndarray:
        """``(L, H, W, C)`` float32 at the fitted BTF's lights, for modelled view
        ``view_index`` (a position in :attr:`views`)."""
        y = self.luminance_at(view_index, self.lights)
        return (y[..., None] * self.albedo[None]).astype(np.float32)

    def reconstruct(self, view_indices: Iterable[int] | None = None) -> np.ndarray:
        """``(V', L, H, W, C)`` float32 at the fitted BTF's lights; ``view_indices`` are
        positions in :attr:`views` (default: all)."""
        positions = range(len(self.views)) if view_indices is None else list(view_indices)
        return np.stack([self.reconstruct_view(p) for p in positions], axis=0)

    def _position(self, view_index: int) -> int:
        p = int(view_index)
        if not 0 <= p < len(self.views):
            raise IndexError(f"{self.kind} model has {len(self.views)} views; got view "
                             f"position {view_index}")
        return p

    # -- memory ----------------------------------------------------------------
    def _albedo_bytes(self) -> int:
        h, w = self.texels
        return 0 if self.albedo is None else h * w * -(-self.channels // 4) * TEXEL_BYTES

    @property
    def nbytes_gpu(self) -> int:
        """Bytes as float32 RGBA textures (see the module docstring)."""
        raise NotImplementedError


@dataclass(kw_only=True)
class RFPModel(BTFModel):
    """Biquadratic reflectance fields: ``params (V', H, W, 6)`` float32 (see module)."""

    params: np.ndarray

    def _luminance(self, position, lights):
        coef = self.params[position].reshape(-1, 6).astype(np.float64)
        return rfp_basis(lights) @ coef.T

    @property
    def nbytes_gpu(self) -> int:
        h, w = self.texels
        return len(self.views) * h * w * 2 * TEXEL_BYTES + self._albedo_bytes()


@dataclass(kw_only=True)
class RFNLModel(BTFModel):
    """Non-linear reflectance fields, eq. (1) in the stable form: ``params (V', H, W,
    4·(h + k))`` float32 (layout in the module docstring)."""

    params: np.ndarray
    lobes: int
    solver: str = "batched"

    @property
    def header_texels(self) -> int:
        return -(-(1 + self.lobes) // 4)

    def lobe_parameters(self, view_index: int | None = None) -> dict[str, np.ndarray]:
        """``rho_d (…, H, W)``, ``a (…, H, W, k)``, ``axes (…, H, W, k, 3)``, ``n (…, H, W,
        k)`` of one view position or all (leading V' axis), as float32 views."""
        p = self.params if view_index is None else self.params[self._position(view_index)]
        k, h = self.lobes, self.header_texels
        lobes = p[..., 4 * h:].reshape(*p.shape[:-1], k, 4)
        return {"rho_d": p[..., 0], "a": p[..., 1:1 + k], "axes": lobes[..., :3],
                "n": lobes[..., 3]}

    def _luminance(self, position, lights):
        lp = self.lobe_parameters(position)
        rho_d = lp["rho_d"].reshape(-1).astype(np.float64)
        a = lp["a"].reshape(-1, self.lobes).astype(np.float64)
        axes = lp["axes"].reshape(-1, self.lobes, 3).astype(np.float64)
        n = lp["n"].reshape(-1, self.lobes).astype(np.float64)
        return rfnl_evaluate(rho_d, a, axes, n, lights).T

    @property
    def nbytes_gpu(self) -> int:
        h, w = self.texels
        per = self.header_texels + self.lobes
        return len(self.views) * h * w * per * TEXEL_BYTES + self._albedo_bytes()


def rfnl_evaluate(rho_d: np.ndarray, a: np.ndarray, axes: np.ndarray, n: np.ndarray,
                  lights: np.ndarray) -> np.ndarray:
    """``ρd + Σ_j a_j max(t̂_j·l, 0)^{n_j}`` → (texels, N) float64 (what the shader does).

    With unit t̂ and clamped a, n no term exceeds a_j ≤ A_MAX."""
    s = np.einsum("tkc,nc->tkn", axes, lights)
    pos = s > 0.0
    log_s = np.log(np.where(pos, s, 1.0))
    lobe = np.where(pos, np.exp(n[:, :, None] * log_s), 0.0)
    return rho_d[:, None] + np.einsum("tk,tkn->tn", a, lobe)


@dataclass(kw_only=True)
class LafortuneModel(BTFModel):
    """Per-texel Lafortune lobes over all views: ``params (H, W, 1 + 3·lobes)`` float32
    ``[ρd, C_xy,1, C_z,1, n_1, …]``; ``Y = (ρd + Σ max(C_xy (l_x v_x + l_y v_y) +
    C_z l_z v_z, 0)^n) · l_z``."""

    params: np.ndarray
    lobes: int

    def _lafortune_luminance(self, lights: np.ndarray, views: np.ndarray) -> np.ndarray:
        """(pairs, H·W) luminance for paired unit ``lights`` and ``views`` (M, 3)."""
        geometry = btf_lm.LafortuneGeometry.of(lights, views)
        p = self.params.reshape(-1, 1 + 3 * self.lobes).astype(np.float64)
        solver_rows = p.copy()
        solver_rows[:, 3::3] = np.log(np.clip(p[:, 3::3], N_MIN, N_MAX))
        _, _, _, value = btf_lm.lafortune_lobes(solver_rows, geometry)
        return ((p[:, :1] + value.sum(axis=1)) * geometry.lz[None, :]).T

    def _luminance(self, position, lights):
        views = np.broadcast_to(self.views[position], lights.shape)
        return self._lafortune_luminance(lights, views)

    def evaluate(self, lights: np.ndarray, views: np.ndarray) -> np.ndarray:
        """Colour ``(M, N, H, W, C)`` float32 for any ``views (M, 3)`` × ``lights (N, 3)``."""
        lights, views = _unit(lights), _unit(views)
        out = np.empty((len(views), len(lights), *self.texels, self.channels), np.float32)
        for i, v in enumerate(views):
            y = self._lafortune_luminance(lights, np.broadcast_to(v, lights.shape))
            out[i] = _to_float32(y).reshape(len(lights), *self.texels)[..., None] * self.albedo
        return out

    @property
    def nbytes_gpu(self) -> int:
        h, w = self.texels
        return h * w * -(-(1 + 3 * self.lobes) // 4) * TEXEL_BYTES + self._albedo_bytes()


@dataclass(kw_only=True)
class CPModel(BTFModel):
    """CP factor packs of the (texels, views, lights, channels) tensor.

    ``factors = [texels (H·W, R), views (V, R), lights (L, R), channels (C, R)]`` float32.
    """

    factors: list[np.ndarray]
    packs: int
    filled_images: int = 0
    _tri: dict = field(default_factory=dict, repr=False, compare=False, init=False)

    @property
    def params(self) -> list[np.ndarray]:
        return self.factors

    def reconstruct_view(self, view_index):
        position = self._position(view_index)
        tex, views, lights, chans = (f.astype(np.float64) for f in self.factors)
        right = (tex[:, None, :] * chans[None, :, :]).reshape(-1, tex.shape[1])
        out = (lights * views[position]) @ right.T
        return _to_float32(out).reshape(len(lights), *self.texels, self.channels)

    def _interpolated(self, which: int, directions: np.ndarray) -> np.ndarray:
        """Factor rows (N, R) at any directions: barycentric over the hemisphere between
        the measured directions (:class:`HemisphereTriangulation`), nearest sample when
        fewer than 3 were measured."""
        samples = self.views if which == 1 else self.lights
        factor = self.factors[which].astype(np.float64)
        if len(samples) < 3:
            nearest = np.argmax(directions @ samples.T, axis=1)
            return factor[nearest]
        if which not in self._tri:
            self._tri[which] = HemisphereTriangulation(samples)
        index, weight = self._tri[which].weights(directions)
        return np.einsum("nk,nkr->nr", weight, factor[index])

    def evaluate(self, lights: np.ndarray, views: np.ndarray) -> np.ndarray:
        """Colour ``(M, N, H, W, C)`` float32 for any ``views (M, 3)`` × ``lights (N, 3)``,
        interpolating the light and view factors."""
        lights, views = _unit(lights), _unit(views)
        fl, fv = self._interpolated(2, lights), self._interpolated(1, views)
        tex, chans = self.factors[0].astype(np.float64), self.factors[3].astype(np.float64)
        right = (tex[:, None, :] * chans[None, :, :]).reshape(-1, tex.shape[1])
        out = np.empty((len(views), len(lights), *self.texels, self.channels), np.float32)
        for i in range(len(views)):
            out[i] = _to_float32((fl * fv[i]) @ right.T).reshape(out.shape[1:])
        return out

    def _luminance(self, position, lights):
        colour = self.evaluate(lights, self.views[position:position + 1])[0]
        return (colour.astype(np.float64) @ self.channel_weights).reshape(len(lights), -1)

    @property
    def nbytes_gpu(self) -> int:
        return int(sum(f.size for f in self.factors)) * 4


def _unit(d) -> np.ndarray:
    d = np.asarray(d, dtype=np.float64).reshape(-1, 3)
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)


def _to_float32(x: np.ndarray) -> np.ndarray:
    """Cast to float32 without overflow (values beyond float32 saturate)."""
    big = float(np.finfo(np.float32).max)
    return np.clip(x, -big, big).astype(np.float32)


def _base_fields(btf: BTF, kept: list[int], dropped: list[int]) -> dict:
    if not kept:
        raise InsufficientBTFData(f"{btf.name}: every view has too few present lights to "
                                  f"fit the model (dropped views {dropped})")
    return {"views": btf.views[kept].copy(), "view_indices": np.asarray(kept, np.int64),
            "lights": btf.lights.copy(), "channel_weights": btf.channel_weights(),
            "texels": btf.texels, "dropped_views": tuple(int(v) for v in dropped)}


def _sum_histories(histories: list[np.ndarray]) -> np.ndarray:
    """Total cost per iteration over blocks that each stopped at their own iteration
    (a finished block keeps contributing its last value)."""
    length = max(len(hh) for hh in histories)
    return np.sum([np.pad(hh, (0, length - len(hh)), mode="edge") for hh in histories],
                  axis=0)
