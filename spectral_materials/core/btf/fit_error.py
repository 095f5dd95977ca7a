"""The paper's fit error ε, eq. (2), and the rows of its Table 1."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from .container import BTF
from .fit_models import BTFModel, InsufficientBTFData

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
