"""CP factor packs of the whole BTF tensor (texels, views, lights, channels), with the
missing images filled from the RFP fit first."""

from __future__ import annotations

import time

import numpy as np

from ..decomposition import cp
from ..progress import ProgressCallback, report, scaled
from .container import BTF
from .fit_models import CPModel, InsufficientBTFData, _base_fields
from .fit_rf import fit_rfp

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
