"""Fitting compact models to a BTF: reflectance fields (RFP, RFNL), Lafortune lobes, CP.

Meseth, Müller and Klein (2003) render a BTF by interpolating between per-view
*reflectance fields* ``RF_v(x, l) = BTF(x, l, v)`` (§3.1), each fitted per texel by a
compact function of the light direction (§4), and compare the fits by the mean absolute
error ε of eq. (2) (Table 1). This module fits, stores and evaluates four models of a
:class:`~.btf.BTF` (``values = π f cos θ_l``: foreshortening included, NaN for missing
(view, light) images):

``RFP`` (:func:`fit_rfp`)
    Per view and texel the biquadratic polynomial of Malzbender et al. (2001)
    ``Y ≈ a0 lu² + a1 lv² + a2 lu lv + a3 lu + a4 lv + a5`` in ``(lu, lv) = (l_x, l_y)``;
    linear least squares.
``RFNL`` (:func:`fit_rfnl`)
    Per view and texel the paper's eq. (1) ``Y ≈ ρd + Σ_j a_j max(t̂_j · l, 0)^{n_j}`` in a
    *stable parameterisation* (below), fitted by Levenberg–Marquardt from a high-pass
    initialisation of the lobe axes (§4.1).
``LAF`` (:func:`fit_lafortune`)
    Per texel over all views and lights, isotropic generalised cosine lobes (Lafortune et
    al. 1997; McAllister et al. 2002) times the foreshortening that the data include —
    the comparison model of Table 1.
``CP`` (:func:`fit_cp`)
    The whole (texels, views, lights, channels) tensor as CP factor packs
    (:func:`.cp.fit_packs`).

Colour (RFP, RFNL, LAF)
    "Since we apply the function for luminance data only, the final color is computed as
    in [PTM]" (§4.1): every model fits the luminance ``Y = values · w`` (``w`` =
    :meth:`BTF.channel_weights`), and each texel gets one spectral (or RGB) albedo
    ``albedo(x) = Σ_{v,l present} values / Σ_{v,l present} Y`` (:func:`spectral_albedo`),
    so ``albedo · w = 1`` and the reconstruction is ``Y_fit(x, l, v) · albedo(x)``. A texel
    whose spectrum is a constant times its luminance is therefore reproduced exactly
    wherever its luminance is. CP factors the spectral data directly (no albedo).

Stable RFNL parameterisation (the paper's white pixels)
    The paper stores ``ρs`` and a lobe vector ``t`` of any length and evaluates
    ``ρs (t·l)^n`` on the GPU; with ``|t| > 1`` and large n that overflows — "disturbing
    white pixels … more frequently" in 16-bit floats (§5.3). Since
    ``ρs (t·l)^n = ρs |t|^n (t̂·l)^n``, we store the unit axis t̂ and the amplitude
    ``a = ρs |t|^n`` separately, clamp ``a ∈ [0, A_MAX]`` (A_MAX = 60000 < 65504, the
    float16 maximum) and ``n ∈ [0.5, 10000]``. Then ``(t̂·l)^n ≤ 1`` and every lobe value is
    ``≤ a``: nothing overflows in float32 or float16. :func:`paper_overflows` shows the
    paper form overflowing, :func:`lobes_from_paper` converts paper parameters in log space.

Parameter layouts (float32; the GPU reads each group of 4 as one RGBA texel)
    RFP ``params (V', H, W, 6)``: ``[a0, a1, a2, a3, a4, a5]``; GPU: 2 RGBA texels per
    view and texel, ``(a0, a1, a2, a3)`` and ``(a4, a5, 0, 0)``.
    RFNL ``params (V', H, W, 4·(h + k))`` with ``h = ceil((1 + k)/4)`` header texels
    (h = 1 for k ≤ 3, so the width is ``4·(1 + k)``):
    ``[ρd, a_1, …, a_k, 0 …]`` padded with zeros to 4·h, then per lobe j (sorted by
    decreasing a_j) ``(t̂x, t̂y, t̂z, n)``. A lobe with ``a_j = 0`` is absent (its axis is
    (0, 0, 1), n = 1). GPU: h + k RGBA texels per view and texel.
    LAF ``params (H, W, 1 + 3·lobes)``: ``[ρd, C_xy,1, C_z,1, n_1, C_xy,2, …]``; GPU:
    ``ceil((1 + 3·lobes)/4)`` RGBA texels per texel (zero padded).
    CP ``factors``: ``[texels (H·W, R), views (V, R), lights (L, R), channels (C, R)]``,
    R = 4·packs; GPU: every factor float once (one RGBA texel per pack and row).
    RF and LAF models also store ``albedo (H, W, C)``: ``ceil(C/4)`` RGBA texels per texel.
    :attr:`BTFModel.nbytes_gpu` counts exactly these (float32) bytes.

Views
    An RF model has one fit per *modelled* view: ``model.views (V', 3)`` and
    ``model.view_indices (V',)`` (their indices in the fitted BTF). A view with fewer
    present lights than the model has unknowns is left out and listed in
    ``model.dropped_views`` (view interpolation then spans its neighbours).
    ``reconstruct``/``luminance_at`` take *positions* in ``model.views``. LAF and CP model
    all views.

References
----------
Meseth, J., Müller, G., Klein, R. (2003). Reflectance field based real-time, high quality
rendering of bidirectional texture functions. Computers & Graphics 28(1), 105–112.
Malzbender, T., Gelb, D., Wolters, H. (2001). Polynomial texture maps. SIGGRAPH 2001.
Lafortune, E. P. F., Foo, S.-C., Torrance, K. E., Greenberg, D. P. (1997). Non-linear
approximation of reflectance functions. SIGGRAPH '97.
McAllister, D. K., Lastra, A., Heidrich, W. (2002). Efficient rendering of spatial
bi-directional reflectance distribution functions. Graphics Hardware 2002.
Kolda, T. G., Bader, B. W. (2009). Tensor decompositions and applications. SIAM Review.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ..decomposition import cp
from ..progress import ProgressCallback, report, scaled
from . import lm as btf_lm
from .container import BTF, HemisphereTriangulation, InvalidBTF
from .lm import A_MAX, A_MIN, LOG_A_MIN, N_MAX, N_MIN

__all__ = [
    "A_MAX", "N_MIN", "N_MAX", "METHODS", "RFNL_SOLVERS", "InsufficientBTFData", "BTFModel",
    "RFPModel", "RFNLModel", "LafortuneModel", "CPModel", "spectral_albedo", "rfp_basis",
    "fit_rfp", "fit_rfnl", "fit_lafortune", "fit_cp", "lobes_from_paper", "paper_overflows",
    "epsilon", "error_table",
]

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


# -------------------------------------------------------------------------- RFP


def fit_rfp(btf: BTF, *, callback: ProgressCallback | None = None, seed: int = 0
            ) -> RFPModel:
    """Biquadratic reflectance fields (Malzbender et al. 2001; paper §4.1, "RFP").

    One linear least-squares solve per view with all texels as right-hand sides, over the
    view's present lights. A view with fewer than 6 present lights is dropped. When the
    present lights do not determine all six coefficients (e.g. all on one ring, where
    ``lu² + lv²`` is constant), ``lstsq`` returns the minimum-norm fit — still the best fit
    of the samples. ``seed`` is unused (the fit is deterministic); it is accepted so that
    every entry of :data:`METHODS` takes the same arguments.
    """
    del seed
    start = time.perf_counter()
    lum = btf.luminance()
    h, w = btf.texels
    basis = rfp_basis(btf.lights)
    kept, dropped, params = [], [], []
    for v in range(len(btf.views)):
        report(callback, v / len(btf.views), f"RFP view {v + 1}/{len(btf.views)}")
        present = btf.present[v]
        if present.sum() < 6:
            dropped.append(v)
            continue
        rhs = lum[v, present].reshape(int(present.sum()), -1).astype(np.float64)
        coef = np.linalg.lstsq(basis[present], rhs, rcond=None)[0]
        kept.append(v)
        params.append(coef.T.reshape(h, w, 6).astype(np.float32))
    fields = _base_fields(btf, kept, dropped)
    report(callback, 1.0, "RFP done")
    return RFPModel(kind="RFP", params=np.stack(params), albedo=spectral_albedo(btf),
                    fit_seconds=time.perf_counter() - start, **fields)


# -------------------------------------------------------------------------- RFNL


def lobes_from_paper(rho_s, t, n) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Convert the paper's lobe ``ρs (t·l)^n`` (t of any length) to the stable ``(a, t̂, n)``.

    ``a = ρs |t|^n`` is formed in log space, ``exp(min(n log|t| + log ρs, log A_MAX))``, so
    it never overflows (|t| = 3, n = 500 gives 3^500 ≈ 1e238 in the paper's form; here
    a = A_MAX). A lobe with ``ρs ≤ 0`` or ``t = 0`` gets ``a = 0``. ``n`` is clamped to
    ``[N_MIN, N_MAX]`` *after* a is formed from the given n (a is the lobe's peak value).

    Returns
    -------
    a : ndarray (...)
    t_hat : ndarray (..., 3)
        Unit axes (+z for t = 0).
    n : ndarray (...)
    """
    rho_s = np.asarray(rho_s, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    norm = np.linalg.norm(t, axis=-1)
    valid = (norm > 0.0) & (rho_s > 0.0)
    log_a = n * np.log(np.where(valid, norm, 1.0)) + np.log(np.where(valid, rho_s, 1.0))
    # exp(log A_MAX) rounds above A_MAX: clamp after the exponential too.
    a = np.where(valid, np.minimum(np.exp(np.minimum(log_a, np.log(A_MAX))), A_MAX), 0.0)
    return a, btf_lm.normalise(t), np.clip(n, N_MIN, N_MAX)


def paper_overflows(rho_s, t, n, dtype=np.float32) -> np.ndarray:
    """Whether the paper's lobe overflows at its peak when evaluated in ``dtype``.

    Evaluates ``ρs · (t · l)^n`` as a shader would, in ``dtype``, at ``l = t̂`` (the lobe's
    maximum, ``t·l = |t|``); True where the result is inf or NaN (the white pixels of §5.3).
    """
    dtype = np.dtype(dtype)
    t = np.asarray(t, dtype=dtype)
    l_peak = btf_lm.normalise(t.astype(np.float64)).astype(dtype)
    with np.errstate(over="ignore", invalid="ignore"):
        dot = np.sum(t * l_peak, axis=-1, dtype=dtype)
        value = np.asarray(rho_s, dtype=dtype) * np.power(dot, np.asarray(n, dtype=dtype))
    return ~np.isfinite(value)


#: Exponents tried for each lobe at the start (a coarse, geometric "peak width" scan).
RFNL_EXPONENT_GRID = (1.5, 4.0, 12.0, 40.0, 150.0, 600.0)


def _rfnl_init(lights: np.ndarray, y: np.ndarray, lobes: int, separation_deg: float,
               initial_exponent: float | None) -> np.ndarray:
    """Start states ``[ρd, log a, t̂, log n]`` (n, 1 + 5k) for luminance ``y (P, n)`` over
    present ``lights (P, 3)``.

    Axes — the paper's principal-direction detection (§4.1): high-pass = data − its
    biquadratic (RFP) low-pass over the lights; lobe 1's axis is the light with the largest
    high-pass value, each further lobe's the largest among lights more than
    ``separation_deg`` from the earlier axes. Because the data include the foreshortening
    (a broad lobe about the normal that a high-pass filter removes), three more axis sets
    are tried: lobe 1 at the brightest light instead, and each of the two with its last
    lobe on the normal (0, 0, 1).

    Candidates — the paper-style start (:func:`_rfnl_paper_start`: peak heights, peak
    widths, ρd at a low percentile) on the high-pass axes; and for each axis set, each
    lobe's exponent chosen from :data:`RFNL_EXPONENT_GRID` by one coordinate-descent pass
    (or fixed at ``initial_exponent``), every candidate scored after solving (ρd, a_j) by
    linear least squares (amplitudes clipped at 0). The cheapest candidate per texel (by
    its cost before LM) is returned.

    Why not the paper's start alone: on synthetic diffuse + specular texels LM from the
    high-pass axes alone stops in local minima ~100× costlier than from the best of these
    candidates; the scan costs about as much as a few LM iterations.
    """
    p_count, n = y.shape
    k = lobes
    basis = rfp_basis(lights)
    high = y - basis @ np.linalg.lstsq(basis, y, rcond=None)[0]
    cos_light = np.clip(lights @ lights.T, -1.0, 1.0)
    cos_sep = np.cos(np.radians(separation_deg))
    scale = np.maximum(np.abs(y).max(axis=0), 1e-12)
    best_state = best_cost = None

    def peak_axes(first_raw: bool) -> tuple[np.ndarray, np.ndarray]:
        blocked = np.zeros((p_count, n), dtype=bool)
        axes = np.zeros((n, k, 3))
        peaks = np.zeros((n, k), dtype=np.int64)
        for j in range(k):
            source = y if (j == 0 and first_raw) else high
            score = np.where(blocked, -np.inf, source)
            score = np.where(blocked.all(axis=0)[None], source, score)  # too few lights
            peaks[:, j] = np.argmax(score, axis=0)
            axes[:, j] = lights[peaks[:, j]]
            blocked |= cos_light[peaks[:, j]].T > cos_sep
        return axes, peaks

    axis_sets = []
    for first_raw in (False, True):
        axes, peaks = peak_axes(first_raw)
        if not first_raw:
            best_state, best_cost = _rfnl_paper_start(y, lights, cos_light, peaks, cos_sep,
                                                      initial_exponent)
        axis_sets.append(axes)
        normal = axes.copy()
        normal[:, -1] = (0.0, 0.0, 1.0)
        axis_sets.append(normal)
    grid = RFNL_EXPONENT_GRID if initial_exponent is None else ()
    start_n = 8.0 if initial_exponent is None else float(np.clip(initial_exponent, N_MIN, N_MAX))
    for axes in axis_sets:
        shapes_of = np.einsum("nkc,pc->npk", axes, lights)                # (n, P, k)
        expo = np.full((n, k), start_n)
        current = _rfnl_linear(y, shapes_of, expo)
        for j in range(k):
            for g in grid:
                trial_n = expo.copy()
                trial_n[:, j] = g
                trial = _rfnl_linear(y, shapes_of, trial_n)
                better = trial[2] < current[2]
                expo = np.where(better[:, None], trial_n, expo)
                current = (np.where(better, trial[0], current[0]),
                           np.where(better[:, None], trial[1], current[1]),
                           np.where(better, trial[2], current[2]))
        rho, amp, cost = current
        # A lobe the linear fit did not want starts small but alive (LM may revive it).
        amp = np.clip(np.where(amp > 0, amp, 1e-3 * scale[:, None]), A_MIN, A_MAX)
        state = btf_lm.rfnl_join(rho, np.log(amp), axes, np.log(expo))
        better = cost < best_cost
        best_state = np.where(better[:, None], state, best_state)
        best_cost = np.minimum(cost, best_cost)
    return best_state


def _rfnl_paper_start(y, lights, cos_light, peaks, cos_sep, initial_exponent):
    """The paper-style start for the high-pass axes ``lights[peaks]`` and its cost:
    ρd = 10th percentile of the data; lobe by lobe, a = the peak's height above ρd and the
    earlier lobes, n from the peak's width (least squares of ``log(y/peak) = n log cos δ``
    over the lights within the separation angle; 8 where that is undetermined)."""
    n, k = peaks.shape
    col = np.arange(n)
    scale = np.maximum(np.abs(y).max(axis=0), 1e-12)
    rho0 = np.clip(np.percentile(y, 10.0, axis=0), 0.0, A_MAX)
    remaining = y - rho0
    amp, expo = np.zeros((n, k)), np.zeros((n, k))
    for j in range(k):
        c = cos_light[peaks[:, j]].T                                  # (P, n)
        peak = remaining[peaks[:, j], col]
        if initial_exponent is None:
            near = (c > cos_sep) & (c < 1.0 - 1e-9)
            ratio = np.clip(remaining / np.where(peak > 0, peak, 1.0)[None], 1e-6, 1.0)
            log_c = np.log(np.where(near, c, 1.0))
            den = np.sum(log_c * log_c, axis=0)
            width = np.sum(np.where(near, np.log(ratio) * log_c, 0.0), axis=0) / \
                np.where(den > 0, den, 1.0)
            expo[:, j] = np.clip(np.where((den > 0) & (peak > 0), width, 8.0), 1.0, 1000.0)
        else:
            expo[:, j] = np.clip(initial_exponent, N_MIN, N_MAX)
        amp[:, j] = np.clip(np.where(peak > 0, peak, 1e-3 * scale), A_MIN, A_MAX)
        remaining = remaining - amp[:, j] * _lobe_shape(c, expo[:, j])
    cost = 0.5 * np.sum(remaining * remaining, axis=0)
    return btf_lm.rfnl_join(rho0, np.log(amp), lights[peaks], np.log(expo)), cost


def _rfnl_linear(y: np.ndarray, cosines: np.ndarray, expo: np.ndarray):
    """``(ρd (n,), a (n, k), cost (n,))``: least squares for (ρd, a) with fixed lobe shapes
    ``max(cos, 0)^n`` (batched normal equations), negative amplitudes clipped to 0 and ρd
    re-fitted (≥ 0) for the clipped lobes."""
    n, p_count, k = cosines.shape
    shapes = _lobe_shape(cosines, expo[:, None, :])
    design = np.concatenate([np.ones((n, p_count, 1)), shapes], axis=2)
    gram = np.matmul(design.transpose(0, 2, 1), design)
    gram += 1e-10 * np.trace(gram, axis1=1, axis2=2)[:, None, None] * np.eye(1 + k)
    rhs = np.einsum("npq,pn->nq", design, y)
    coef = np.linalg.solve(gram, rhs[:, :, None])[:, :, 0]
    amp = np.clip(coef[:, 1:], 0.0, A_MAX)
    lobes = np.einsum("npk,nk->np", shapes, amp)
    rho = np.clip((y.T - lobes).mean(axis=1), 0.0, A_MAX)
    r = rho[:, None] + lobes - y.T
    return rho, amp, 0.5 * np.sum(r * r, axis=1)


def _lobe_shape(c: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``max(c, 0)^n`` without warnings."""
    pos = c > 0
    return np.where(pos, np.exp(n * np.log(np.where(pos, c, 1.0))), 0.0)


def _solve_batched(states, lights, data, mask, lobes, *, iterations, ftol):
    result = btf_lm.rfnl_lm(states, lights, data, mask, lobes, iterations=iterations,
                            ftol=ftol)
    return result.x, result.cost, result.history


def _solve_scipy(states, lights, data, mask, lobes, *, iterations, ftol):
    states = btf_lm.rfnl_project(states, lobes)
    start = btf_lm.rfnl_cost(states, lights, data, mask, lobes)
    x, cost = btf_lm.rfnl_scipy(states, lights, data, mask, lobes, ftol=ftol, xtol=ftol)
    # MINPACK ignores the bounds; where clamping its answer made it worse than the start,
    # keep the start (as LM never accepts a step that raises the cost).
    worse = ~(cost <= start)
    x = np.where(worse[:, None], states, x)
    cost = np.where(worse, start, cost)
    return x, cost, np.array([start.sum(), cost.sum()])


#: RFNL solvers: ``solver(states, lights, data, mask, lobes, *, iterations, ftol) ->
#: (states, cost, history)``. "batched": :func:`.btf_lm.rfnl_lm` (all texels at once);
#: "scipy": :func:`scipy.optimize.least_squares` (MINPACK LM) per texel — the reference.
RFNL_SOLVERS: dict[str, Callable] = {"batched": _solve_batched, "scipy": _solve_scipy}


def _row_blocks(n_views: int, per_view: int, chunk: int):
    """Blocks of at most ``chunk`` (view, texel) rows, view-major, as lists of
    ``(view_position, texel_start, texel_stop)`` segments."""
    total = n_views * per_view
    for r0 in range(0, total, chunk):
        r1 = min(r0 + chunk, total)
        segments = []
        for p in range(r0 // per_view, (r1 - 1) // per_view + 1):
            segments.append((p, max(r0, p * per_view) - p * per_view,
                             min(r1, (p + 1) * per_view) - p * per_view))
        yield segments


def fit_rfnl(btf: BTF, *, lobes: int = 2, solver: str = "batched", iterations: int = 60,
             ftol: float = 1e-10, separation_deg: float = 25.0,
             initial_exponent: float | None = None, chunk_size: int = 4096,
             callback: ProgressCallback | None = None, seed: int = 0) -> RFNLModel:
    """Non-linear reflectance fields, eq. (1) in the stable form (paper §4.1, "RFNL").

    Per view and texel ``Y(l) ≈ ρd + Σ_{j ≤ k} a_j max(t̂_j·l, 0)^{n_j}`` over the view's
    present lights; unknowns ``ρd, log a_j, two tangent-plane angles of t̂_j, log n_j``
    (1 + 4k), clamped to ``ρd ∈ [0, A_MAX]``, ``a ∈ [A_MIN, A_MAX]``, ``n ∈ [N_MIN,
    N_MAX]``. Start: :func:`_rfnl_init` (high-pass principal directions). Solver: see
    :data:`RFNL_SOLVERS`.

    Parameters
    ----------
    lobes : int
        k ≥ 1.
    solver : str
        Key of :data:`RFNL_SOLVERS`.
    iterations : int
        LM iteration limit of the batched solver (SciPy uses MINPACK's own limit).
    ftol : float
        Relative cost decrease below which a problem counts as converged.
    separation_deg : float
        Minimum angle between initial lobe axes.
    initial_exponent : float, optional
        Start every n here instead of estimating it from the peak width.
    chunk_size : int
        (view, texel) problems solved together (memory ≈ chunk · L · (1 + 4k) · 8 B).
    seed : int
        Unused (deterministic); accepted for a uniform interface.

    Returns
    -------
    RFNLModel
        ``history``: total ``½ Σ r²`` over all fitted (view, texel) problems per iteration
        (non-increasing). A problem whose fit is non-finite or worse than the safe state
        ``ρd = mean, no lobes`` stores the safe state instead.
    """
    del seed
    if lobes < 1:
        raise ValueError(f"lobes must be ≥ 1, got {lobes}")
    if solver not in RFNL_SOLVERS:
        raise ValueError(f"unknown RFNL solver {solver!r}; choose from {sorted(RFNL_SOLVERS)}")
    start = time.perf_counter()
    k = lobes
    lum = btf.luminance()
    h, w = btf.texels
    hw = h * w
    unknowns = btf_lm.rfnl_step_size(k)
    counts = btf.present.sum(axis=1)
    kept = [v for v in range(len(btf.views)) if counts[v] >= unknowns]
    dropped = [v for v in range(len(btf.views)) if counts[v] < unknowns]
    fields = _base_fields(btf, kept, dropped)
    lum_rows = lum.reshape(lum.shape[0], lum.shape[1], hw)
    header = -(-(1 + k) // 4)
    params = np.zeros((len(kept), hw, 4 * (header + k)), np.float32)
    histories = []
    blocks = list(_row_blocks(len(kept), hw, max(1, int(chunk_size))))
    for b, segments in enumerate(blocks):
        report(callback, b / len(blocks), f"RFNL block {b + 1}/{len(blocks)}")
        states, data, masks = [], [], []
        for pos, t0, t1 in segments:
            v = kept[pos]
            present = btf.present[v]
            y = lum_rows[v, :, t0:t1].astype(np.float64)          # (L, n)
            states.append(_rfnl_init(btf.lights[present], y[present], k, separation_deg,
                                     initial_exponent))
            data.append(np.nan_to_num(y.T))
            masks.append(np.broadcast_to(present, (t1 - t0, len(present))))
        states, data, mask = np.concatenate(states), np.concatenate(data), \
            np.concatenate(masks)
        mask = None if mask.all() else mask
        x, cost, history = RFNL_SOLVERS[solver](states, btf.lights, data, mask, k,
                                                iterations=iterations, ftol=ftol)
        x, cost = _rfnl_safe(x, cost, data, mask, k)
        histories.append(np.append(history, cost.sum()))
        packed = _rfnl_pack(x, k, header)
        r = 0
        for pos, t0, t1 in segments:
            params[pos, t0:t1] = packed[r:r + t1 - t0]
            r += t1 - t0
    report(callback, 1.0, "RFNL done")
    return RFNLModel(kind="RFNL", params=params.reshape(len(kept), h, w, -1), lobes=k,
                     solver=solver, albedo=spectral_albedo(btf), history=_sum_histories(
                         histories), fit_seconds=time.perf_counter() - start, **fields)


def _rfnl_safe(x, cost, data, mask, lobes):
    """Replace non-finite fits, or fits worse than ``ρd = mean, no lobes``, by that state
    (a = A_MIN there; :func:`_rfnl_pack` stores it as 0)."""
    weight = np.ones_like(data) if mask is None else mask.astype(np.float64)
    count = np.maximum(weight.sum(axis=1), 1.0)
    mean = (data * weight).sum(axis=1) / count
    safe_cost = 0.5 * (((data - mean[:, None]) ** 2) * weight).sum(axis=1)
    bad = ~np.isfinite(x).all(axis=1) | ~np.isfinite(cost) | (cost > safe_cost)
    if np.any(bad):
        n = int(bad.sum())
        axes = np.zeros((n, lobes, 3))
        axes[..., 2] = 1.0
        x = x.copy()
        x[bad] = btf_lm.rfnl_join(np.clip(mean[bad], 0.0, A_MAX),
                                  np.full((n, lobes), LOG_A_MIN), axes, np.zeros((n, lobes)))
        cost = np.where(bad, safe_cost, cost)
    return x, cost


def _rfnl_pack(x: np.ndarray, lobes: int, header: int) -> np.ndarray:
    """Solver states → the float32 RGBA layout (lobes sorted by decreasing a; a lobe at the
    amplitude floor is stored as a = 0, axis +z, n = 1)."""
    rho_d, log_a, axes, log_n = btf_lm.rfnl_split(x, lobes)
    absent = log_a <= LOG_A_MIN + 1e-6
    a = np.where(absent, 0.0, np.minimum(np.exp(np.minimum(log_a, np.log(A_MAX))), A_MAX))
    n = np.where(absent, 1.0, np.clip(np.exp(log_n), N_MIN, N_MAX))
    axes = np.where(absent[..., None], [0.0, 0.0, 1.0], axes)
    order = np.argsort(-a, axis=1, kind="stable")
    a = np.take_along_axis(a, order, axis=1)
    n = np.take_along_axis(n, order, axis=1)
    axes = np.take_along_axis(axes, order[..., None], axis=1)
    out = np.zeros((len(x), 4 * (header + lobes)), np.float32)
    out[:, 0] = np.clip(rho_d, 0.0, A_MAX)
    out[:, 1:1 + lobes] = a
    lobe_block = out[:, 4 * header:].reshape(len(x), lobes, 4)
    lobe_block[..., :3] = axes
    lobe_block[..., 3] = n
    return out


def _sum_histories(histories: list[np.ndarray]) -> np.ndarray:
    """Total cost per iteration over blocks that each stopped at their own iteration
    (a finished block keeps contributing its last value)."""
    length = max(len(hh) for hh in histories)
    return np.sum([np.pad(hh, (0, length - len(hh)), mode="edge") for hh in histories],
                  axis=0)


# ---------------------------------------------------------------------- Lafortune

#: Start shapes (C_xy, C_z, n) of Lafortune lobes: a sharp and a broad forward
#: (specular-direction) lobe, a retro-reflective lobe, a near-normal lobe; cycled with
#: doubled exponents beyond four lobes.
LAF_TEMPLATES = ((-1.0, 1.0, 20.0), (-1.0, 1.0, 3.0), (1.0, 1.0, 6.0), (0.0, 1.0, 2.0))


def fit_lafortune(btf: BTF, *, lobes: int = 4, iterations: int = 60, ftol: float = 1e-10,
                  chunk_bytes: int = 48 * 2**20, callback: ProgressCallback | None = None,
                  seed: int = 0) -> LafortuneModel:
    """Per-texel Lafortune model over all views and lights (paper §4.2, "LAF").

    ``Y(l, v) = (ρd + Σ_j max(C_xy,j (l_x v_x + l_y v_y) + C_z,j l_z v_z, 0)^{n_j}) · l_z``
    — isotropic generalised cosine lobes, times ``l_z`` because the BTF includes the
    foreshortening. Start: the lobes of :data:`LAF_TEMPLATES` with (ρd, amplitudes) from
    one linear least-squares solve for all texels (amplitude m enters as C ← C·m^{1/n});
    then :func:`.btf_lm.lafortune_lm` with unknowns ``ρd, C_xy,j, C_z,j, log n_j`` and
    ``‖C_j‖ ≤ A_MAX^{1/n_j}`` (no lobe exceeds A_MAX). Missing (view, light) images are
    left out. A texel whose fit is worse than ``ρd`` alone keeps ``ρd`` alone.
    ``seed`` is unused (deterministic).
    """
    del seed
    if lobes < 1:
        raise ValueError(f"lobes must be ≥ 1, got {lobes}")
    start = time.perf_counter()
    lum = btf.luminance()
    h, w = btf.texels
    hw = h * w
    vi, li = np.nonzero(btf.present)
    n_par = 1 + 3 * lobes
    if len(vi) < n_par:
        raise InsufficientBTFData(f"{btf.name}: {len(vi)} present (view, light) images, "
                                  f"fewer than the {n_par} Lafortune unknowns")
    geometry = btf_lm.LafortuneGeometry.of(btf.lights[li], btf.views[vi])
    templates = [(cxy, cz, ex * 2.0 ** (j // len(LAF_TEMPLATES)))
                 for j, (cxy, cz, ex) in
                 ((j, LAF_TEMPLATES[j % len(LAF_TEMPLATES)]) for j in range(lobes))]
    shape_rows = np.array([[0.0] + [c for t in templates for c in (t[0], t[1], np.log(t[2]))]])
    _, _, _, shapes = btf_lm.lafortune_lobes(shape_rows, geometry)         # (1, k, M)
    design = np.concatenate([geometry.lz[:, None], (shapes[0] * geometry.lz).T], axis=1)
    lum_rows = lum.reshape(lum.shape[0], lum.shape[1], hw)
    step = max(1, int(chunk_bytes // (len(vi) * n_par * 8 * 3)))
    params = np.zeros((hw, n_par), np.float32)
    histories = []
    blocks = [slice(t, min(t + step, hw)) for t in range(0, hw, step)]
    for b, sl in enumerate(blocks):
        report(callback, b / len(blocks), f"LAF block {b + 1}/{len(blocks)}")
        data = lum_rows[vi, li, sl].T.astype(np.float64)                     # (n, M)
        coef = np.linalg.lstsq(design, data.T, rcond=None)[0].T               # (n, 1 + k)
        typical = np.maximum(data.mean(axis=1) / max(geometry.lz.mean(), 1e-6), 1e-6)
        x0 = np.zeros((len(data), n_par))
        x0[:, 0] = np.clip(coef[:, 0], 0.0, A_MAX)
        for j, (cxy, cz, ex) in enumerate(templates):
            m = np.where(coef[:, 1 + j] > 0, coef[:, 1 + j], 1e-3 * typical)
            scale = np.clip(m, A_MIN, A_MAX) ** (1.0 / ex)
            x0[:, 1 + 3 * j:4 + 3 * j] = np.stack(
                [cxy * scale, cz * scale, np.full(len(data), np.log(ex))], axis=1)
        result = btf_lm.lafortune_lm(x0, geometry, data, iterations=iterations, ftol=ftol)
        x, cost = result.x, result.cost
        # Safe state: ρd alone, least squares of ρd·l_z.
        lz = geometry.lz
        rho = np.clip(data @ lz / max(float(lz @ lz), 1e-300), 0.0, A_MAX)
        safe_cost = 0.5 * np.sum((rho[:, None] * lz - data) ** 2, axis=1)
        bad = ~np.isfinite(x).all(axis=1) | ~np.isfinite(cost) | (cost > safe_cost)
        x = x.copy()
        x[bad] = 0.0
        x[bad, 0] = rho[bad]
        cost = np.where(bad, safe_cost, cost)
        histories.append(np.append(result.history, cost.sum()))
        out = x.copy()
        out[:, 3::3] = np.clip(np.exp(x[:, 3::3]), N_MIN, N_MAX)
        params[sl] = out
    report(callback, 1.0, "LAF done")
    return LafortuneModel(kind="LAF", params=params.reshape(h, w, n_par), lobes=lobes,
                          albedo=spectral_albedo(btf), history=_sum_histories(histories),
                          fit_seconds=time.perf_counter() - start,
                          **_base_fields(btf, list(range(len(btf.views))), []))


# -------------------------------------------------------------------------- CP


def _cp_tensor(btf: BTF) -> tuple[np.ndarray, int]:
    """The (H·W, V, L, C) float32 tensor with missing images filled; returns it and the
    number of filled (view, light) images.

    Fill (CP needs a complete tensor; filled values are a guess, not data, and ε never
    counts them): the RFP reconstruction (clipped at 0) of the image's view; for a view RFP
    dropped, each texel's mean over the view's present lights; for a view with no present
    light at all, the texel's mean over every present sample.
    """
    v_count, l_count, h, w, c = btf.shape
    hw = h * w
    tensor = np.ascontiguousarray(
        np.transpose(btf.values.reshape(v_count, l_count, hw, c), (2, 0, 1, 3)))
    missing = ~btf.present
    if not missing.any():
        return tensor, 0
    try:
        rfp = fit_rfp(btf)
        positions = {int(v): p for p, v in enumerate(rfp.view_indices)}
    except InsufficientBTFData:
        rfp, positions = None, {}
    overall = np.nanmean(tensor, axis=(1, 2))                           # (hw, c)
    for v in np.nonzero(missing.any(axis=1))[0]:
        gone = missing[v]
        if rfp is not None and int(v) in positions:
            y = np.maximum(rfp.luminance_at(positions[int(v)], btf.lights[gone]), 0.0)
            fill = y.reshape(int(gone.sum()), hw)[..., None] * rfp.albedo.reshape(hw, c)
            tensor[:, v, gone] = np.transpose(fill, (1, 0, 2))
        elif (~gone).any():
            tensor[:, v, gone] = tensor[:, v, ~gone].mean(axis=1)[:, None]
        else:
            tensor[:, v, gone] = overall[:, None]
    return tensor, int(missing.sum())


def fit_cp(btf: BTF, *, packs: int = 4, method: str = "joint",
           settings: cp.ALSSettings | None = None, callback: ProgressCallback | None = None,
           seed: int = 0) -> CPModel:
    """CP factor packs of the whole BTF tensor (texels, views, lights, channels).

    :func:`.cp.fit_packs` (pack size 4, ``method``, ``seed``) on the spectral data — no
    luminance/albedo split. Missing images are filled first (:func:`_cp_tensor`).
    ``history`` holds ``‖T − X‖²`` after each pack.
    """
    start = time.perf_counter()
    tensor, filled = _cp_tensor(btf)
    report(callback, 0.05, "CP tensor ready")
    factors, hist = cp.fit_packs(tensor, packs, pack_size=4, method=method,
                                 settings=settings, seed=seed,
                                 callback=scaled(callback, 0.05, 1.0))
    if factors[0].shape[1] == 0:        # an all-zero BTF: one zero pack
        factors = [np.zeros((n, 4)) for n in tensor.shape]
    report(callback, 1.0, "CP done")
    return CPModel(kind="CP", factors=[f.astype(np.float32) for f in factors],
                   packs=factors[0].shape[1] // 4, filled_images=filled,
                   history=np.asarray(hist.error_sq), fit_seconds=time.perf_counter() - start,
                   **_base_fields(btf, list(range(len(btf.views))), []))


#: Fitters by the names of Table 1. Each is ``fit(btf, *, callback=None, seed=0, …)``.
METHODS: dict[str, Callable[..., BTFModel]] = {
    "RFP": fit_rfp, "RFNL": fit_rfnl, "LAF": fit_lafortune, "CP": fit_cp}


# -------------------------------------------------------------------------- error


def epsilon(btf: BTF, model: BTFModel) -> dict:
    """The paper's error, eq. (2), per texel and its average, minimum and maximum.

    ``ε(x) = mean over present (v, l) of the modelled views and over channels of
    |BTF(x, v, l) − M(x, v, l)|``; ``avg``/``min``/``max`` over texels. Computed view by
    view. Views the model dropped have no reconstruction and are not counted
    (``views`` says how many were). ``btf`` must share the model's directions and texels
    (it may be different data, e.g. the noise-free truth of a noisy fit).

    Returns
    -------
    dict
        ``avg``, ``min``, ``max`` (float), ``per_texel`` (H, W) float64, ``samples`` (number
        of (view, light) images counted) and ``views`` (number of views counted).
    """
    if btf.texels != model.texels or btf.values.shape[-1] != model.channels:
        raise ValueError(f"BTF texels/channels {btf.texels}/{btf.values.shape[-1]} differ "
                         f"from the model's {model.texels}/{model.channels}")
    if btf.lights.shape != model.lights.shape or not np.allclose(btf.lights, model.lights,
                                                                  atol=1e-6):
        raise ValueError("the BTF's light directions differ from those the model was fitted to")
    if int(np.max(model.view_indices)) >= len(btf.views) or not np.allclose(
            btf.views[model.view_indices], model.views, atol=1e-6):
        raise ValueError("the BTF's view directions differ from those the model was fitted to")
    total = np.zeros(btf.texels)
    images = 0
    views = 0
    for position, v in enumerate(model.view_indices):
        present = btf.present[v]
        if not present.any():
            continue
        recon = model.reconstruct_view(position)[present]
        diff = np.abs(btf.values[v, present].astype(np.float64) - recon)
        total += diff.sum(axis=(0, 3))
        images += int(present.sum())
        views += 1
    if images == 0:
        raise InsufficientBTFData(f"{btf.name}: no present sample in the modelled views")
    per_texel = total / (images * btf.values.shape[-1])
    return {"avg": float(per_texel.mean()), "min": float(per_texel.min()),
            "max": float(per_texel.max()), "per_texel": per_texel, "samples": images,
            "views": views}


def error_table(btf: BTF, models: Mapping[str, BTFModel] | Iterable[BTFModel]) -> list[dict]:
    """Rows ``{method, avg, min, max, fit_seconds, gpu_bytes}`` like the paper's Table 1
    (plus fit time and GPU memory); ``models`` is a name → model mapping or a sequence
    (named by ``kind``)."""
    items = models.items() if isinstance(models, Mapping) else ((m.kind, m) for m in models)
    rows = []
    for name, model in items:
        e = epsilon(btf, model)
        rows.append({"method": name, "avg": e["avg"], "min": e["min"], "max": e["max"],
                     "fit_seconds": float(model.fit_seconds), "gpu_bytes": model.nbytes_gpu})
    return rows
