"""Stiff test cases for the BTF fits: a BTF with multiplicative noise, or with random
(view, light) images missing."""

from __future__ import annotations

import math

import numpy as np

from .container import BTF


def add_noise(btf: BTF, relative_sigma: float, *, seed: int = 0) -> BTF:
    """A copy of ``btf`` with multiplicative Gaussian noise: ``value · (1 + σ N(0, 1))``,
    clipped at 0 (missing samples stay NaN).

    Parameters
    ----------
    btf : BTF
    relative_sigma : float
        σ ≥ 0, relative to each value.
    seed : int

    Returns
    -------
    BTF
    """
    sigma = float(relative_sigma)
    if not math.isfinite(sigma) or sigma < 0.0:
        raise ValueError(f"relative_sigma must be finite and ≥ 0, got {relative_sigma!r}")
    rng = np.random.default_rng(seed)
    factor = 1.0 + sigma * rng.standard_normal(btf.values.shape, dtype=np.float32)
    values = btf.values * factor
    np.maximum(values, 0.0, out=values, where=np.isfinite(values))
    return BTF(values, btf.views, btf.lights, btf.wavelengths, btf.name)


def drop_samples(btf: BTF, fraction: float, *, seed: int = 0) -> BTF:
    """A copy of ``btf`` with ``round(fraction · V · L)`` random (view, light) images set
    to NaN (missing), never every image of a view: one random light per view is kept.

    Images already missing count as candidates too (dropping one again changes nothing),
    so the result may hold fewer new gaps when ``btf`` had some.

    Parameters
    ----------
    btf : BTF
    fraction : float
        In ``[0, 1 − 1/L]``, L the number of lights.
    seed : int

    Returns
    -------
    BTF
    """
    v, lc = btf.present.shape
    fraction = float(fraction)
    if not math.isfinite(fraction) or fraction < 0.0:
        raise ValueError(f"fraction must be finite and ≥ 0, got {fraction!r}")
    count = int(round(fraction * v * lc))
    if count > v * (lc - 1):
        raise ValueError(f"cannot drop {count} of {v * lc} images and keep one light per "
                         f"view (fraction at most {1.0 - 1.0 / lc:.3g})")
    rng = np.random.default_rng(seed)
    # Each view's guaranteed light, drawn among its present images (any, if none is).
    draw = rng.random((v, lc)) + np.where(btf.present, 1.0, 0.0)
    keep = np.argmax(draw, axis=1)
    candidates = np.ones((v, lc), dtype=bool)
    candidates[np.arange(v), keep] = False
    flat = np.flatnonzero(candidates)
    drop = rng.choice(flat, size=count, replace=False)
    values = btf.values.copy()
    vi, li = np.divmod(drop, lc)
    values[vi, li] = np.nan
    return BTF(values, btf.views, btf.lights, btf.wavelengths, btf.name)
