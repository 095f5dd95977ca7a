"""The Lafortune comparison model (paper §4.2, "LAF"): isotropic generalised cosine lobes
per texel over all views and lights."""

from __future__ import annotations

import time

import numpy as np

from ..progress import ProgressCallback, report
from . import lm as btf_lm
from .container import BTF
from .fit_models import (
    InsufficientBTFData,
    LafortuneModel,
    _base_fields,
    _sum_histories,
    spectral_albedo,
)
from .lm import A_MAX, A_MIN, N_MAX, N_MIN

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
