"""BRDF parameterisations: forward and inverse maps between direction pairs and grid coordinates.

A parameterisation maps a pair of unit directions ``(wi, wo)`` to a coordinate
vector (``forward``) and back (``inverse``). BRDFs are tabulated on the
cell-centred grid of a parameterisation's axes and factored (Kautz & McCool
1999; Schwenk et al. 2010) after reshaping the table into a 2-D matrix whose
rows are indexed by the axes of ``split[0]`` and whose columns by ``split[1]``.
Factor textures are looked up with :func:`axis_lookup`.

Conventions
-----------
* Local frame: ``z`` = surface normal ``n``, ``x`` = primary tangent ``t``,
  ``y`` = ``s`` = ``z × x``.
* ``wi`` points toward the light, ``wo`` toward the viewer; both unit vectors
  of shape ``(N, 3)`` (any leading shape is accepted and kept).
* θ is the polar angle from ``z``; φ = atan2(y, x) wrapped into [0, 2π). At the
  poles φ = 0.
* Angles are in radians.

Parameterisations (registry keys of :data:`PARAMETERIZATIONS`)
-------------------------------------------------------------
``io``      (θi, φi, θo, φo), split ((0, 1), (2, 3)).
``io_iso``  (θi, Δφ = φo − φi, θo), split ((0,), (1, 2)); inverse puts wi at φi = 0.
``hd``      Rusinkiewicz (θh, φh, θd, φd), θh with "sqrt" warp, split ((0, 1), (2, 3)).
``hd_iso``  (θh, θd, φd), split ((0,), (1, 2)); inverse uses φh = 0.
``gs``      Kautz–McCool Gram–Schmidt half-vector form (h·t, h·s, wi·t', wi·s'),
            split ((0, 1), (2, 3)).
``ea``      (θi, θo, φi, φo): IO angles reordered; split ((0, 1), (2, 3)) pairs the
            elevations against the azimuths.

Numerical policy
----------------
``forward`` never produces NaN/inf (and raises no floating-point warnings) for
unit inputs, including poles, h ≈ n, grazing angles, ``wi == wo`` and
``wi == −wo``. Where the half vector is undefined (``|wi + wo|`` ≤ 1e-12) it
is taken to be ``n``. Directions below the horizon are not clipped: they give
θ > π/2, and :func:`axis_lookup` clamps such values into the axis range.

``inverse`` returns finite directions for every input (non-finite coordinates
are replaced by 0 and marked invalid) and a ``valid`` mask: every non-periodic
coordinate inside its axis range, both directions at or above the horizon
(``z >= -1e-12``, a tolerance for rounding; ``-1e-7`` for ``gs``, whose
square roots lose half the digits near the horizon), and, for ``gs``, both
``(hx, hy)`` and ``(du, dv)`` inside the unit disc. For valid coordinates,
``forward(*inverse(c)[:2])`` reproduces ``c`` (periodic axes modulo the
period; azimuths at a pole are arbitrary).

References
----------
Rusinkiewicz, S. (1998). A new change of variables for efficient BRDF
representation. Eurographics Workshop on Rendering, 11–22.
Kautz, J., McCool, M. D. (1999). Interactive rendering with arbitrary BRDFs
using separable approximations. Eurographics Workshop on Rendering, 247–260
(eqs. 4 and 6 for the Gram–Schmidt half-vector parameterisation).
Schwenk, K., Kuijper, A., Bockholt, U. (2010). Modeling wavelength-dependent
BRDFs as factored tensors for real-time spectral rendering. GRAPP 2010
(90 × 180 × 90 isotropic IO layout).
Matusik, W., Pfister, H., Brand, M., McMillan, L. (2003). A data-driven
reflectance model. SIGGRAPH 2003 (square-root θh spacing).
"""

from __future__ import annotations

import numpy as np

from .axes import Axis, axis_lookup, horizon_scale
from .directions import (  # HALF_VECTOR_EPS, POLE_RHO: read as params.* by callers
    HALF_PI,
    HALF_VECTOR_EPS,  # noqa: F401
    POLE_RHO,  # noqa: F401
    TWO_PI,
    _dot,
    _half_vector,
    _normalize,
    _wrap_2pi,
    check_direction_pairs,
    from_spherical,
    spherical,
)

__all__ = [
    "Axis",
    "Parameterization",
    "IOParameterization",
    "IOIsoParameterization",
    "HDParameterization",
    "HDIsoParameterization",
    "GSParameterization",
    "EAParameterization",
    "PARAMETERIZATIONS",
    "get_parameterization",
    "spherical",
    "check_direction_pairs",
    "from_spherical",
    "axis_lookup",
    "horizon_scale",
]

#: Tolerance of the validity tests of ``inverse`` (horizon, axis ranges, unit discs).
VALID_EPS = 1e-12
#: Horizon tolerance of ``gs``: hz and dz are square roots of 1 − (sum of squares),
#: so directions near the horizon carry errors of order √ε ≈ 1.5e-8.
GS_HORIZON_EPS = 1e-7


# --------------------------------------------------------------------------- base class


def _theta_axis(name: str, warp: str = "linear") -> Axis:
    return Axis(name, 0.0, HALF_PI, periodic=False, warp=warp, horizon=name == "theta_i",
                view_horizon=name == "theta_o")


def _phi_axis(name: str) -> Axis:
    return Axis(name, 0.0, TWO_PI, periodic=True)


class Parameterization:
    """Base class: a map (wi, wo) ↔ coordinates on ``axes``.

    Subclasses set the class attributes and implement ``_forward(wi, wo)`` on
    ``(N, 3)`` float64 arrays and ``_inverse(coords)`` on ``(N, d)`` finite
    float64 arrays returning ``(wi, wo, extra_valid)``.
    """

    name: str = ""
    axes: tuple[Axis, ...] = ()
    default_resolution: tuple[int, ...] = ()
    split: tuple[tuple[int, ...], tuple[int, ...]] = ((), ())
    isotropic: bool = False
    #: How the add-on's panel names it and says what it is for (isotropic variants are
    #: chosen by the BRDF, not listed there: empty).
    label: str = ""
    summary: str = ""
    #: ``inverse`` accepts directions with z >= -horizon_tolerance as above the horizon.
    horizon_tolerance: float = VALID_EPS
    #: Axes whose coordinate depends on ``wo`` alone: a shader drawing 2–4 lights with
    #: enough packs fetches their factors once per pack, not once per light
    #: (glsl/brdf/surface_frag.glsl, blender/gpu/shaders.shares_view_axes).
    view_axes: tuple[int, ...] = ()

    @property
    def ndim(self) -> int:
        """Number of coordinates d."""
        return len(self.axes)

    def __repr__(self) -> str:
        names = ", ".join(a.name for a in self.axes)
        return f"<{type(self).__name__} {self.name!r} ({names})>"

    # -- public API

    def forward(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Coordinates ``(N, d)`` of direction pairs ``wi, wo (N, 3)``.

        Inputs are renormalised (zero vectors are left as they are). Any
        leading shape is accepted: ``(..., 3) → (..., d)``.
        """
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        if wi.shape[-1:] != (3,) or wo.shape[-1:] != (3,):
            raise ValueError(f"directions must have shape (..., 3), got {wi.shape}, {wo.shape}")
        wi, wo = np.broadcast_arrays(wi, wo)
        lead = wi.shape[:-1]
        wi, _ = _normalize(wi.reshape(-1, 3))
        wo, _ = _normalize(wo.reshape(-1, 3))
        coords = self._forward(wi, wo)
        return coords.reshape(lead + (self.ndim,))

    def inverse(self, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions of coordinates ``(N, d)`` → ``wi (N, 3), wo (N, 3), valid (N,)``.

        ``valid``: the coordinates are finite, non-periodic ones lie in their
        axis range, and both directions are at or above the horizon (all up to
        :data:`VALID_EPS`; the horizon test uses ``horizon_tolerance``). Directions
        are finite everywhere, valid or not.
        """
        c = np.asarray(coords, dtype=np.float64)
        if c.shape[-1:] != (self.ndim,):
            raise ValueError(
                f"{self.name}: coordinates must have shape (..., {self.ndim}), got {c.shape}"
            )
        lead = c.shape[:-1]
        c = c.reshape(-1, self.ndim)
        finite = np.isfinite(c).all(axis=1)
        c = np.where(np.isfinite(c), c, 0.0)
        valid = finite.copy()
        for k, ax in enumerate(self.axes):
            if not ax.periodic:
                valid &= (c[:, k] >= ax.lo - VALID_EPS) & (c[:, k] <= ax.hi + VALID_EPS)
        wi, wo, extra = self._inverse(c)
        tol = self.horizon_tolerance
        valid &= extra & (wi[:, 2] >= -tol) & (wo[:, 2] >= -tol)
        return wi.reshape(lead + (3,)), wo.reshape(lead + (3,)), valid.reshape(lead)

    def theta_resolution(self, theta_cells: int) -> tuple[int, ...]:
        """The default grid scaled so that 90° of θ has ``theta_cells`` cells (at least 2
        per axis): the add-on's and the library's "θ cells" setting."""
        scale = int(theta_cells) / 90.0
        return tuple(max(2, int(round(n * scale))) for n in self.default_resolution)

    def grid(self, resolution: tuple[int, ...] | None = None) -> np.ndarray:
        """Cell-centre coordinates of the whole grid, ``(prod(resolution), d)``, C order
        (the last axis varies fastest), so that ``values.reshape(resolution)`` is the table."""
        res = self.default_resolution if resolution is None else tuple(int(r) for r in resolution)
        if len(res) != self.ndim:
            raise ValueError(f"{self.name}: resolution needs {self.ndim} entries, got {res}")
        centres = [ax.centres(r) for ax, r in zip(self.axes, res, strict=True)]
        mesh = np.meshgrid(*centres, indexing="ij")
        return np.stack([m.ravel() for m in mesh], axis=-1)

    # -- to implement

    def _forward(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _inverse(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError


# --------------------------------------------------------------------------- IO / EA


class IOParameterization(Parameterization):
    """Incoming/outgoing spherical angles (θi, φi, θo, φo)."""

    name = "io"
    view_axes = (2, 3)
    label = "Input/output angles"
    summary = "(θi, φi, θo, φo); (θi, φo−φi, θo) when isotropic"
    axes = (_theta_axis("theta_i"), _phi_axis("phi_i"), _theta_axis("theta_o"), _phi_axis("phi_o"))
    default_resolution = (90, 180, 90, 180)
    split = ((0, 1), (2, 3))

    def _forward(self, wi, wo):
        ti, pi = spherical(wi)
        to, po = spherical(wo)
        return np.stack([ti, pi, to, po], axis=-1)

    def _inverse(self, c):
        wi = from_spherical(c[:, 0], c[:, 1])
        wo = from_spherical(c[:, 2], c[:, 3])
        return wi, wo, np.ones(c.shape[0], dtype=bool)


class IOIsoParameterization(Parameterization):
    """Isotropic IO (θi, Δφ = φo − φi ∈ [0, 2π), θo): the 90 × 180 × 90 layout of
    Schwenk et al. 2010. The inverse puts wi at φi = 0. Split: θi against (Δφ, θo)."""

    name = "io_iso"
    view_axes = (2,)
    axes = (_theta_axis("theta_i"), _phi_axis("delta_phi"), _theta_axis("theta_o"))
    default_resolution = (90, 180, 90)
    split = ((0,), (1, 2))
    isotropic = True

    def _forward(self, wi, wo):
        ti, pi = spherical(wi)
        to, po = spherical(wo)
        return np.stack([ti, _wrap_2pi(po - pi), to], axis=-1)

    def _inverse(self, c):
        wi = from_spherical(c[:, 0], np.zeros(c.shape[0]))
        wo = from_spherical(c[:, 2], c[:, 1])
        return wi, wo, np.ones(c.shape[0], dtype=bool)


class EAParameterization(Parameterization):
    """Elevation/azimuth: the IO angles reordered (θi, θo, φi, φo), split elevations
    against azimuths."""

    name = "ea"
    view_axes = (1, 3)
    label = "Elevation/azimuth"
    summary = "Elevation/azimuth of both directions"
    axes = (_theta_axis("theta_i"), _theta_axis("theta_o"), _phi_axis("phi_i"), _phi_axis("phi_o"))
    default_resolution = (90, 90, 180, 180)
    split = ((0, 1), (2, 3))

    def _forward(self, wi, wo):
        ti, pi = spherical(wi)
        to, po = spherical(wo)
        return np.stack([ti, to, pi, po], axis=-1)

    def _inverse(self, c):
        wi = from_spherical(c[:, 0], c[:, 2])
        wo = from_spherical(c[:, 1], c[:, 3])
        return wi, wo, np.ones(c.shape[0], dtype=bool)


# --------------------------------------------------------------------------- HD


def _hd_forward(wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, ...]:
    """(θh, φh, θd, φd) after Rusinkiewicz 1998."""
    h = _half_vector(wi, wo)
    th, ph = spherical(h)
    ct, st = np.cos(th), np.sin(th)
    cp, sp = np.cos(ph), np.sin(ph)
    # d = Ry(−θh) · Rz(−φh) · wi
    x1 = cp * wi[:, 0] + sp * wi[:, 1]
    y1 = -sp * wi[:, 0] + cp * wi[:, 1]
    z1 = wi[:, 2]
    d = np.stack([ct * x1 - st * z1, y1, st * x1 + ct * z1], axis=-1)
    td, pd = spherical(d)
    return th, ph, td, pd


def _hd_inverse(th, ph, td, pd) -> tuple[np.ndarray, np.ndarray]:
    d = from_spherical(td, pd)
    ct, st = np.cos(th), np.sin(th)
    cp, sp = np.cos(ph), np.sin(ph)
    # wi = Rz(φh) · Ry(θh) · d
    x1 = ct * d[:, 0] + st * d[:, 2]
    y1 = d[:, 1]
    z1 = -st * d[:, 0] + ct * d[:, 2]
    wi = np.stack([cp * x1 - sp * y1, sp * x1 + cp * y1, z1], axis=-1)
    h = from_spherical(th, ph)
    wo = 2.0 * _dot(wi, h)[:, None] * h - wi
    return wi, wo


class HDParameterization(Parameterization):
    """Rusinkiewicz half/difference angles (θh, φh, θd, φd); θh is sqrt-warped."""

    name = "hd"
    label = "Half/difference"
    summary = "Rusinkiewicz (θh, φh, θd, φd), θh square-root warped; best for sharp highlights"
    axes = (
        _theta_axis("theta_h", warp="sqrt"),
        _phi_axis("phi_h"),
        _theta_axis("theta_d"),
        _phi_axis("phi_d"),
    )
    default_resolution = (90, 45, 90, 45)
    split = ((0, 1), (2, 3))

    def _forward(self, wi, wo):
        return np.stack(_hd_forward(wi, wo), axis=-1)

    def _inverse(self, c):
        wi, wo = _hd_inverse(c[:, 0], c[:, 1], c[:, 2], c[:, 3])
        return wi, wo, np.ones(c.shape[0], dtype=bool)


class HDIsoParameterization(Parameterization):
    """Isotropic half/difference angles (θh, θd, φd); the inverse uses φh = 0."""

    name = "hd_iso"
    axes = (_theta_axis("theta_h", warp="sqrt"), _theta_axis("theta_d"), _phi_axis("phi_d"))
    default_resolution = (90, 90, 180)
    split = ((0,), (1, 2))
    isotropic = True

    def _forward(self, wi, wo):
        th, _, td, pd = _hd_forward(wi, wo)
        return np.stack([th, td, pd], axis=-1)

    def _inverse(self, c):
        wi, wo = _hd_inverse(c[:, 0], np.zeros(c.shape[0]), c[:, 1], c[:, 2])
        return wi, wo, np.ones(c.shape[0], dtype=bool)


# --------------------------------------------------------------------------- GS


def _gs_frame(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """t' = norm(t − (t·h)h) and s' = h × t' for unit h (N, 3).

    Written as t' = (ρ, −hx·hy/ρ, −hx·hz/ρ) with ρ = √(hy² + hz²) = √(1 − hx²),
    which avoids the cancellation in 1 − hx². Where ρ = 0 (h = ±t: grazing
    retro-reflection) the frame is undefined; t' = (0, 0, −hx) is used, the
    limit approached from above the horizon, so s' = y there.
    """
    hx, hy, hz = h[:, 0], h[:, 1], h[:, 2]
    rho = np.hypot(hy, hz)
    small = rho <= 0.0
    safe = np.where(small, 1.0, rho)
    cb = np.where(small, 0.0, hy / safe)
    sb = np.where(small, 1.0, hz / safe)
    tp = np.stack([rho, -hx * cb, -hx * sb], axis=-1)
    tp, _ = _normalize(tp)
    sp = np.cross(h, tp)
    return tp, sp


class GSParameterization(Parameterization):
    """Kautz & McCool's Gram–Schmidt half-vector form (hx, hy, du, dv) ∈ [−1, 1]⁴.

    h = norm(wi + wo) (n where wi ≈ −wo), t' = norm(t − (t·h)h), s' = h × t',
    coordinates (h·t, h·s, wi·t', wi·s'). Inverse: hz = √(1 − hx² − hy²),
    dz = √(1 − du² − dv²), wi = du·t' + dv·s' + dz·h, wo = 2(wi·h)h − wi;
    valid additionally requires both (hx, hy) and (du, dv) inside the unit disc.
    """

    name = "gs"
    label = "Gram–Schmidt half vector"
    summary = "Kautz–McCool's half-vector frame"
    axes = (
        Axis("h_t", -1.0, 1.0, periodic=False),
        Axis("h_s", -1.0, 1.0, periodic=False),
        Axis("d_u", -1.0, 1.0, periodic=False),
        Axis("d_v", -1.0, 1.0, periodic=False),
    )
    default_resolution = (32, 32, 32, 32)
    split = ((0, 1), (2, 3))
    horizon_tolerance = GS_HORIZON_EPS

    def _forward(self, wi, wo):
        h = _half_vector(wi, wo)
        tp, sp = _gs_frame(h)
        return np.stack([h[:, 0], h[:, 1], _dot(wi, tp), _dot(wi, sp)], axis=-1)

    def _inverse(self, c):
        hx, hy, du, dv = c[:, 0], c[:, 1], c[:, 2], c[:, 3]
        rh = hx * hx + hy * hy
        rd = du * du + dv * dv
        hz = np.sqrt(np.maximum(0.0, 1.0 - rh))
        dz = np.sqrt(np.maximum(0.0, 1.0 - rd))
        h, _ = _normalize(np.stack([hx, hy, hz], axis=-1))
        tp, sp = _gs_frame(h)
        wi = du[:, None] * tp + dv[:, None] * sp + dz[:, None] * h
        wo = 2.0 * _dot(wi, h)[:, None] * h - wi
        extra = (rh <= 1.0 + VALID_EPS) & (rd <= 1.0 + VALID_EPS)
        return wi, wo, extra


# --------------------------------------------------------------------------- registry

PARAMETERIZATIONS: dict[str, Parameterization] = {
    p.name: p
    for p in (
        IOParameterization(),
        IOIsoParameterization(),
        HDParameterization(),
        HDIsoParameterization(),
        GSParameterization(),
        EAParameterization(),
    )
}


def get_parameterization(name: str, isotropic: bool = False) -> Parameterization:
    """The registered parameterisation ``name``; with ``isotropic``, its ``_iso`` variant.

    ``("io", True)`` → ``io_iso`` and ``("hd", True)`` → ``hd_iso``. ``gs`` and
    ``ea`` have no isotropic variant: ``("gs", True)`` and ``("ea", True)``
    return the anisotropic ones (an isotropic BRDF tabulated on them is simply
    constant along the redundant direction). A name that already ends in
    ``_iso`` is returned as is. Unknown names raise ``ValueError``.
    """
    key = str(name).strip().lower()
    if key not in PARAMETERIZATIONS:
        valid = ", ".join(sorted(PARAMETERIZATIONS))
        raise ValueError(f"unknown parameterisation {name!r}; valid: {valid}")
    if isotropic and f"{key}_iso" in PARAMETERIZATIONS:
        key = f"{key}_iso"
    return PARAMETERIZATIONS[key]
