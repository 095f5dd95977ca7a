"""Grid axes of the parameterisations (:mod:`.params`): cell centres, warps, and the
texture lookup :func:`axis_lookup` (with :func:`horizon_scale`) that the GLSL
``axis_lookup.glsl`` and the EEVEE node group mirror.

Edge rules (what a lookup does between the end centres and the ends of a non-periodic
axis): ``"linear"`` extrapolates from the two nearest centres, ``"clamp"`` holds the end
value, and ``"horizon"`` is ``"linear"`` except on a *horizon axis* (θi, whose upper end
is the light's horizon): there a cosine-weighted table ``f·cosθi``, which is 0 at the
horizon, falls linearly from the last centre to 0 at ``hi``. The fall is a scale of the
whole lookup (:func:`horizon_scale`), since every stored form is linear in each axis's
interpolated value; it is exact for the cosine's own zero, which linear extrapolation
misses by up to half a cell's slope (issue 18: ΔE94 up to 26 on Oren–Nayar at θi > 89.9°).
``"horizons"`` does the same on the view's θo axis too (a *view-horizon axis*), for
tables that also vanish as the view reaches its horizon: a layered surface's diffuse
term, the rest beside a glossy lobe. Oren–Nayar's does not (its retro-reflection stays),
so the rule is chosen per material by measuring (``grazing.choose_edge``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_WARPS = ("linear", "sqrt")
#: Edge rules of :func:`axis_lookup` (see the module docstring).
EDGE_RULES = ("linear", "clamp", "horizon", "horizons")


@dataclass(frozen=True)
class Axis:
    """One coordinate axis of a parameterisation.

    Attributes
    ----------
    name : str
        e.g. ``"theta_i"``.
    lo, hi : float
        Coordinate range. For periodic axes ``hi − lo`` is one period.
    periodic : bool
        Azimuths: values are wrapped into [lo, hi) and lookups wrap around.
    warp : str
        ``"linear"``: u = (v − lo)/(hi − lo); ``"sqrt"``: u = ((v − lo)/(hi − lo))^½
        (MERL-style θh spacing: cells are denser near ``lo``).
    horizon : bool
        ``hi`` is the light's horizon (θi axes): the ``"horizon"`` and ``"horizons"`` edge
        rules take a cosine-weighted table to 0 there.
    view_horizon : bool
        ``hi`` is the view's horizon (θo axes): the ``"horizons"`` edge rule takes the
        table to 0 there.
    """

    name: str
    lo: float
    hi: float
    periodic: bool
    warp: str = "linear"
    horizon: bool = False
    view_horizon: bool = False

    def __post_init__(self) -> None:
        if not self.hi > self.lo:
            raise ValueError(f"axis {self.name}: hi ({self.hi}) must exceed lo ({self.lo})")
        if self.warp not in _WARPS:
            raise ValueError(f"axis {self.name}: warp must be one of {_WARPS}, got {self.warp!r}")
        if (self.horizon or self.view_horizon) and self.periodic:
            raise ValueError(f"axis {self.name}: a periodic axis has no horizon")

    @property
    def span(self) -> float:
        """hi − lo (the period of a periodic axis)."""
        return float(self.hi - self.lo)

    def wrap(self, v: np.ndarray) -> np.ndarray:
        """Periodic axes: values wrapped into [lo, hi). Others: clipped into [lo, hi]."""
        v = np.asarray(v, dtype=np.float64)
        if self.periodic:
            r = np.mod(v - self.lo, self.span)
            r = np.where(r >= self.span, 0.0, r)
            return self.lo + r
        return np.clip(v, self.lo, self.hi)

    def to_unit(self, v: np.ndarray) -> np.ndarray:
        """Value → u ∈ [0, 1] (after the warp).

        Periodic values are wrapped into [lo, hi) first, so u ∈ [0, 1) up to
        rounding; non-periodic values are clamped into [lo, hi].
        """
        t = (self.wrap(v) - self.lo) / self.span
        t = np.clip(t, 0.0, 1.0)
        if self.warp == "sqrt":
            t = np.sqrt(t)
        return t

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """u ∈ [0, 1] → value (inverse of :meth:`to_unit`; u is not clipped)."""
        u = np.asarray(u, dtype=np.float64)
        t = u * u if self.warp == "sqrt" else u
        return self.lo + t * self.span

    def centres(self, n: int) -> np.ndarray:
        """The ``n`` cell-centre sample values ``from_unit((i + 0.5) / n)``."""
        n = int(n)
        if n < 1:
            raise ValueError(f"axis {self.name}: need at least one cell, got {n}")
        return self.from_unit((np.arange(n, dtype=np.float64) + 0.5) / n)


def holds_horizon(axis: Axis, edge: str) -> bool:
    """Whether ``edge`` takes lookups on ``axis`` to 0 at its ``hi``."""
    return ((axis.horizon and edge in ("horizon", "horizons"))
            or (axis.view_horizon and edge == "horizons"))


def axis_lookup(
    axis: Axis, n: int, values: np.ndarray, edge: str = "linear"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear-interpolation indices and weights on the ``n`` cell centres of ``axis``.

    ``value ≈ (1 − w)·table[i0] + w·table[i1]``. Interpolation is linear in the
    warped unit coordinate u (where the centres are evenly spaced at
    (i + 0.5)/n), which is what a GPU texture fetch does.

    Periodic axes wrap: a value between the last centre and ``hi`` (or between
    ``lo`` and the first centre) interpolates between cells n − 1 and 0.
    Non-periodic axes: values are clamped into [lo, hi] first; between ``lo``
    and the first centre, or the last centre and ``hi``, ``edge="linear"``
    extrapolates from the two nearest centres (w ∈ [−0.5, 1.5]) and
    ``edge="clamp"`` holds the end value (w clipped to [0, 1]); ``edge="horizon"``
    (``"horizons"``) holds the value beyond the last centre of an axis
    :func:`holds_horizon` (w ≤ 1), where :func:`horizon_scale` takes it to 0, and is
    ``"linear"`` everywhere else. With
    ``n == 1``, i0 = i1 = 0 and w = 0. NaN values count as ``lo``, ±inf as ``hi``/``lo``.

    Returns
    -------
    i0, i1 : int64 arrays shaped like ``values``
    w : float64 array shaped like ``values``
    """
    if edge not in EDGE_RULES:
        raise ValueError(f"edge must be one of {EDGE_RULES}, got {edge!r}")
    n = int(n)
    x = cell_x(axis, n, values)
    if n == 1:
        zeros = np.zeros(x.shape, dtype=np.int64)
        return zeros, zeros.copy(), np.zeros(x.shape, dtype=np.float64)
    f = np.floor(x)
    if axis.periodic:
        w = x - f
        i0 = np.mod(f.astype(np.int64), n)
        i1 = np.mod(i0 + 1, n)
        return i0, i1, w
    i0 = np.clip(f, 0, n - 2).astype(np.int64)
    w = x - i0
    if edge == "clamp":
        w = np.clip(w, 0.0, 1.0)
    elif holds_horizon(axis, edge):
        w = np.minimum(w, 1.0)
    return i0, i0 + 1, w


def horizon_scale(axis: Axis, n: int, values: np.ndarray, edge: str = "horizon"
                  ) -> np.ndarray:
    """The ``"horizon"`` (or ``"horizons"``) edge rule's scale: 1 up to the last cell
    centre of an axis :func:`holds_horizon`, then linear in the warped coordinate down
    to 0 at ``hi``; 1 on other axes.

    Multiplying a lookup held at the last centre by this scale interpolates between the
    last centre's value and 0 at the horizon. NaN counts as ``lo`` (scale 1), as in
    :func:`axis_lookup`; +inf as ``hi`` (scale 0).
    """
    n = int(n)
    x = cell_x(axis, n, values)
    if not holds_horizon(axis, edge):
        return np.ones(x.shape, dtype=np.float64)
    return np.clip(2.0 * (n - 0.5 - x), 0.0, 1.0)


def cell_x(axis: Axis, n: int, values: np.ndarray) -> np.ndarray:
    """x = u·n − 0.5 (u the warped unit coordinate): cell centres at integers, as the
    GLSL's ``sm_axis_x``. NaN counts as ``lo``, ±inf as ``hi``/``lo``."""
    if n < 1:
        raise ValueError(f"need at least one cell, got {n}")
    v = np.nan_to_num(
        np.asarray(values, dtype=np.float64), nan=axis.lo, posinf=axis.hi, neginf=axis.lo
    )
    return axis.to_unit(v) * n - 0.5
