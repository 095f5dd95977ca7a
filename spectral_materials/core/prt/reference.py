"""Monte Carlo reference for spectral PRT: the measurement protocol's ground truth.

Spectral PRT (Schwenk et al., eq. 2–3) approximates, for a diffuse, self-shadowed surface
under distant light,

    L_o(λ) = albedo(λ)/π ∫_H(n) L(ω, λ) V(ω) cos θ dω,     M = Σ_λ L_o(λ) m̄(λ) Δλ,

by truncating the light and the transfer to a few SH bands and the spectra to a few basis
vectors. The reference here keeps everything the approximation drops: the 5 nm grid, the
**true** environment (a callable radiance, not its SH projection), the same visibility
the transfer was baked from, and many rays:

* the continuous radiance is integrated by cosine-weighted hemisphere sampling, jittered
  on a stratified grid per vertex (pdf cos θ/π, so the estimator is ``π/R Σ L V``);
* sun discs are far too small to be hit by random rays: each is a directional light,
  ``E_sun(λ) max(n·s, 0) V(s)``, with one shadow ray;
* XYZ is divided by the Y of a white, unoccluded Lambertian facing world up (``up``,
  +z unless the environment was turned into another frame) under the same environment
  (as :func:`prt.vertex_xyz` does), that white computed deterministically
  (a dense Gauss–Legendre rule over the upper hemisphere plus the suns, or the exact sum
  an equirectangular map provides), so that it carries no Monte Carlo noise.

References
----------
Schwenk, K., Franke, T., Drevensek, T., Kuijper, A., Bockholt, U., Fellner, D. W. (2010).
Adapting precomputed radiance transfer to real-time spectral rendering. Eurographics 2010
short papers; eq. (2)–(3), and §4's reference (5 nm point sampling).
Pharr, M., Jakob, W., Humphreys, G. (2016). Physically Based Rendering, 3rd ed., §13.6.3
(cosine-weighted hemisphere sampling, Malley's method) and §7.3 (stratified sampling).
Duff, T. et al. (2017). Building an orthonormal basis, revisited. JCGT 6(1).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..colour import spectra
from . import transfer as prt

#: Rays traced per block (bounds the (rays, L) float64 radiance temporaries to ~20 MB).
RAYS_PER_BLOCK = 1 << 15
#: Gauss–Legendre nodes in cos θ of the white's hemisphere rule (2× as many azimuths).
WHITE_QUADRATURE = 128

Visibility = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class ReferenceEnvironment:
    """A distant light as the reference sees it: continuous radiance plus sun discs.

    Attributes
    ----------
    wavelengths : ndarray (L,)
        nm.
    radiance : callable
        ``radiance(directions (N, 3) unit, world frame) -> (N, L)`` spectral radiance of
        the continuous part (sky, map), non-negative.
    suns : tuple of (direction (3,), irradiance (L,))
        Directional lights: unit direction towards the sun and the spectral irradiance on
        a surface facing it.
    source : str
    up_irradiance : ndarray (L,) or None
        ``∫_{up·ω>0} radiance(ω) (up·ω) dω`` when the source knows it exactly (an
        equirectangular map sums it pixel by pixel); None lets :func:`white_irradiance`
        integrate ``radiance`` with a dense quadrature. Suns excluded.
    up : ndarray (3,)
        World up in this environment's frame: +z until :meth:`rotated` turns it. The
        white faces it, so a turned environment keeps the world's white.
    """

    wavelengths: np.ndarray
    radiance: Callable[[np.ndarray], np.ndarray]
    suns: tuple = ()
    source: str = "reference"
    up_irradiance: np.ndarray | None = field(default=None)
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        wl = spectra.check_wavelengths(self.wavelengths)
        self.wavelengths = wl
        suns = []
        for i, sun in enumerate(self.suns):
            try:
                direction, irradiance = sun
            except (TypeError, ValueError):
                raise ValueError(f"sun {i} must be a (direction, irradiance) pair") from None
            direction = np.asarray(direction, dtype=np.float64)
            irradiance = np.asarray(irradiance, dtype=np.float64)
            norm = np.linalg.norm(direction) if direction.shape == (3,) else 0.0
            if not (np.isfinite(direction).all() and np.isfinite(norm) and norm > 0):
                raise ValueError(f"sun {i}: direction must be a finite, non-zero 3-vector, "
                                 f"got {direction}")
            if irradiance.shape != wl.shape or not np.isfinite(irradiance).all() or \
                    np.any(irradiance < 0):
                raise ValueError(f"sun {i}: irradiance must be {wl.size} finite, non-negative "
                                 f"values, got shape {irradiance.shape}")
            suns.append((direction / norm, irradiance))
        self.suns = tuple(suns)
        if self.up_irradiance is not None:
            up = np.asarray(self.up_irradiance, dtype=np.float64)
            if up.shape != wl.shape or not np.isfinite(up).all():
                raise ValueError(f"up_irradiance must be {wl.size} finite values, got shape "
                                 f"{up.shape}")
            self.up_irradiance = up
        up = np.asarray(self.up, dtype=np.float64)
        if up.shape != (3,) or not np.isfinite(up).all() or \
                not abs(float(np.linalg.norm(up)) - 1.0) < 1e-9:
            raise ValueError(f"up must be a finite unit 3-vector, got {self.up!r}")
        self.up = up

    def rotated(self, rotation: np.ndarray) -> ReferenceEnvironment:
        """The same light in a frame turned by ``rotation`` (3 × 3), as
        ``SpectralEnvironment.rotated``: ``L'(ω) = L(Rᵀω)``, suns at ``R s``, world up at
        ``R up`` — so the white (and ``up_irradiance``, the light about up) is unchanged."""
        rotation = np.asarray(rotation, dtype=np.float64)
        if rotation.shape != (3, 3) or not np.isfinite(rotation).all() or \
                not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-9) or \
                not np.linalg.det(rotation) > 0:
            raise ValueError(f"rotation must be a proper 3 × 3 rotation matrix, got {rotation}")
        radiance = self.radiance

        def turned(directions: np.ndarray) -> np.ndarray:
            return radiance(np.asarray(directions, dtype=np.float64) @ rotation)   # Rᵀ ω

        return ReferenceEnvironment(self.wavelengths, turned,
                                    tuple((rotation @ d, e) for d, e in self.suns),
                                    self.source + " (rotated)", self.up_irradiance,
                                    rotation @ self.up)


def _radiance(environment: ReferenceEnvironment, directions: np.ndarray) -> np.ndarray:
    """The environment's radiance (N, L) at unit ``directions``, checked."""
    values = np.asarray(environment.radiance(directions), dtype=np.float64)
    expected = (len(directions), environment.wavelengths.size)
    if values.shape != expected:
        raise ValueError(f"environment radiance returned shape {values.shape}, expected "
                         f"{expected}")
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise ValueError(f"environment radiance has {bad} non-finite values")
    return values


def white_irradiance(environment: ReferenceEnvironment,
                     order: int = WHITE_QUADRATURE) -> np.ndarray:
    """Spectral irradiance (L,) on an unoccluded surface facing world up
    (``environment.up``, +z unless turned): the white's light.

    ``environment.up_irradiance`` when given, else ``∫_0^1 ∫_0^{2π} L(ω) z dφ dz`` by
    Gauss–Legendre in ``z = cos θ`` about up (``order`` nodes) × the midpoint rule in φ
    (``2·order`` azimuths) — deterministic, and very accurate for smooth skies — plus
    ``E_sun max(s·up, 0)`` per sun.
    """
    total = np.zeros(environment.wavelengths.size)
    if environment.up_irradiance is not None:
        total += environment.up_irradiance
    else:
        order = int(order)
        if not 1 <= order <= 4096:
            raise ValueError(f"quadrature order must be 1..4096, got {order}")
        nodes, weights = np.polynomial.legendre.leggauss(order)
        z = 0.5 * (nodes + 1.0)                       # [-1, 1] → [0, 1]
        wz = 0.5 * weights * z                        # the cosine factor
        phi = (np.arange(2 * order) + 0.5) * (np.pi / order)
        rows_per_block = max(1, RAYS_PER_BLOCK // (2 * order))
        # The hemisphere about world up; for up = +z this frame is the identity.
        tangent, bitangent = _frames(environment.up[None])
        frame = np.concatenate([tangent, bitangent, environment.up[None]])
        for begin in range(0, order, rows_per_block):
            zs = z[begin: begin + rows_per_block]
            r = np.sqrt(np.clip(1.0 - zs * zs, 0.0, None))
            dirs = np.stack(np.broadcast_arrays(r[:, None] * np.cos(phi), r[:, None] *
                                                np.sin(phi), zs[:, None]), axis=-1)
            values = _radiance(environment, dirs.reshape(-1, 3) @ frame)
            w = np.repeat(wz[begin: begin + rows_per_block] * (np.pi / order), 2 * order)
            total += w @ values
    for direction, irradiance in environment.suns:
        total += irradiance * max(float(direction @ environment.up), 0.0)
    return total


def _frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangents (V, 3), bitangents (V, 3) completing unit ``normals`` (Duff et al. 2017)."""
    x, y, z = normals.T
    sign = np.where(z >= 0, 1.0, -1.0)
    a = -1.0 / (sign + z)
    b = x * y * a
    tangent = np.stack([1.0 + sign * x * x * a, sign * b, -sign * x], axis=-1)
    bitangent = np.stack([b, sign + y * y * a, -y], axis=-1)
    return tangent, bitangent


def _cosine_samples(jitter: np.ndarray) -> np.ndarray:
    """Local cosine-distributed directions (n, R, 3) from ``jitter`` (n, R, 2) in [0, 1):
    the first ``a·b`` rays jittered in an ``a × b`` stratification of the unit square
    (a = ⌊√R⌋), the rest uniform; Malley's method maps the square to the hemisphere
    (equal areas to equal cosine-weighted solid angle, so strata stay equal-probability)."""
    rays = jitter.shape[1]
    a = max(1, int(np.sqrt(rays)))
    b = rays // a
    grid = a * b
    u = jitter.copy()
    index = np.arange(grid)
    u[:, :grid, 0] = (index // b + jitter[:, :grid, 0]) / a
    u[:, :grid, 1] = (index % b + jitter[:, :grid, 1]) / b
    r = np.sqrt(u[..., 0])
    phi = 2.0 * np.pi * u[..., 1]
    return np.stack([r * np.cos(phi), r * np.sin(phi),
                     np.sqrt(np.clip(1.0 - u[..., 0], 0.0, None))], axis=-1)


def _visible(visible: Visibility | None, origins: np.ndarray,
             directions: np.ndarray) -> np.ndarray:
    if visible is None:
        return np.ones(len(directions), dtype=bool)
    result = np.asarray(visible(origins, directions))
    if result.shape != (len(directions),):
        raise ValueError(f"visible() returned shape {result.shape}, expected "
                         f"({len(directions)},)")
    return result.astype(bool)


def _check_geometry(points, normals) -> tuple[np.ndarray, np.ndarray]:
    points = np.asarray(points, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must be (V, 3), got {points.shape}")
    if normals.shape != points.shape:
        raise ValueError(f"normals must be {points.shape} like the points, got {normals.shape}")
    for name, array in (("points", points), ("normals", normals)):
        bad = int(np.count_nonzero(~np.isfinite(array)))
        if bad:
            raise ValueError(f"{name} have {bad} non-finite (NaN/inf) values")
    length = np.linalg.norm(normals, axis=1)
    zero = int(np.count_nonzero(~(length > 0)))
    if zero:
        raise ValueError(f"{zero} normals have zero length")
    return points, normals / length[:, None]


def reference_irradiance(points: np.ndarray, normals: np.ndarray,
                         environment: ReferenceEnvironment, visible: Visibility | None = None,
                         *, rays: int = 4096, seed: int = 0,
                         offset: float = 1e-4) -> np.ndarray:
    """Spectral irradiance (V, L) ``∫ L(ω) V(ω) cos θ dω + Σ_suns E_s max(n·s, 0) V(s)``.

    Parameters are as :func:`reference_vertex_xyz`. Each vertex draws its own jittered
    samples from one seeded stream in vertex order, so a vertex's value does not depend on
    how the vertices are chunked (nor on the vertices after it).
    """
    points, normals = _check_geometry(points, normals)
    if isinstance(rays, bool) or not isinstance(rays, int | np.integer) or \
            not 1 <= rays <= prt.MAX_RAYS:
        raise ValueError(f"rays must be an integer in 1..{prt.MAX_RAYS}, got {rays!r}")
    rays = int(rays)
    if not (np.isfinite(offset) and offset >= 0):
        raise ValueError(f"offset must be finite and ≥ 0, got {offset}")
    if not isinstance(environment, ReferenceEnvironment):
        raise ValueError(f"environment must be a ReferenceEnvironment, got "
                         f"{type(environment).__name__}")
    rng = np.random.default_rng(seed)
    count, wl = len(points), environment.wavelengths
    origins = points + offset * normals
    tangent, bitangent = _frames(normals)
    out = np.zeros((count, wl.size))
    per_chunk = max(1, RAYS_PER_BLOCK // rays)
    rays_per_step = min(rays, RAYS_PER_BLOCK)
    for v0 in range(0, count, per_chunk):
        chunk = slice(v0, min(v0 + per_chunk, count))
        n = chunk.stop - chunk.start
        local = _cosine_samples(rng.random((n, rays, 2)))                      # (n, R, 3)
        frame = np.stack([tangent[chunk], bitangent[chunk], normals[chunk]], axis=1)
        world = np.einsum("nrk,nkc->nrc", local, frame)                        # (n, R, 3)
        world /= np.linalg.norm(world, axis=-1, keepdims=True)
        for r0 in range(0, rays, rays_per_step):
            dirs = world[:, r0: r0 + rays_per_step]
            k = dirs.shape[1]
            flat = dirs.reshape(-1, 3)
            starts = np.repeat(origins[chunk], k, axis=0)
            seen = _visible(visible, starts, flat)
            radiance = np.zeros((flat.shape[0], wl.size))
            if seen.any():
                radiance[seen] = _radiance(environment, flat[seen])
            out[chunk] += radiance.reshape(n, k, wl.size).sum(axis=1)
    out *= np.pi / rays                                # pdf cos θ / π
    for direction, irradiance in environment.suns:
        cosine = normals @ direction
        lit = np.nonzero(cosine > 0)[0]
        if lit.size:
            seen = _visible(visible, origins[lit], np.broadcast_to(direction, (lit.size, 3)))
            out[lit] += (cosine[lit] * seen)[:, None] * irradiance[None, :]
    return out


def reference_vertex_xyz(points: np.ndarray, normals: np.ndarray, albedo: np.ndarray,
                         environment: ReferenceEnvironment, visible: Visibility | None = None,
                         *, rays: int = 4096, seed: int = 0, offset: float = 1e-4
                         ) -> np.ndarray:
    """Linear XYZ (V, 3) of diffuse vertices by Monte Carlo: the PRT measurement reference.

    ``L_o(λ) = albedo(λ)/π [∫_H L(ω, λ) V(ω) cos θ dω + Σ_suns E_s(λ) max(n·s, 0) V(s)]``,
    ``XYZ = Σ_λ L_o(λ) m̄(λ) Δλ`` (``spectra.sample_weights``), divided by the Y of a white,
    unoccluded Lambertian facing world up (``environment.up``) under the same environment
    (:func:`white_irradiance`),
    so that it compares directly with :func:`prt.vertex_xyz`.

    Parameters
    ----------
    points, normals : array (V, 3)
        Positions and normals (normalised here) in the environment's frame.
    albedo : array (L,) or (V, L)
        Diffuse albedo on ``environment.wavelengths``, finite and non-negative.
    environment : ReferenceEnvironment
        e.g. ``environment.sky_reference`` or ``environment.equirect_reference``.
    visible : callable or None
        ``visible(origins (N, 3), directions (N, 3)) -> bool (N,)``, the same occlusion
        the transfer was baked with; None: nothing occludes.
    rays : int
        Cosine-weighted rays per vertex (1..``prt.MAX_RAYS``), stratified on a
        ``⌊√R⌋ × ⌊R/⌊√R⌋⌋`` grid, jittered per vertex; the remainder uniform.
    seed : int
        Seeds ``numpy.random.default_rng``: the same seed gives the same result.
    offset : float
        Ray origins are ``points + offset · normal`` (avoids self-intersection).

    Returns
    -------
    ndarray (V, 3)
        Linear CIE 1931 XYZ, white Y = 1.

    Notes
    -----
    The estimator is unbiased; its noise falls as ~R^(-1/2) (faster for smooth light,
    thanks to stratification). Bright small features of a map (an HDR sun in the pixels)
    are sampled by chance like the rest: a sky given by ``sky_reference`` carries its sun
    separately and has no such noise.
    """
    wl = environment.wavelengths if isinstance(environment, ReferenceEnvironment) else None
    if wl is None:
        raise ValueError(f"environment must be a ReferenceEnvironment, got "
                         f"{type(environment).__name__}")
    albedo = np.asarray(albedo, dtype=np.float64)
    count = len(np.asarray(points)) if np.ndim(points) == 2 else -1
    if albedo.shape not in (wl.shape, (count, wl.size)):
        raise ValueError(f"albedo must be ({wl.size},) or (V, {wl.size}) with V = {count} "
                         f"points, got {albedo.shape}")
    bad = int(np.count_nonzero(~np.isfinite(albedo)))
    if bad:
        raise ValueError(f"albedo has {bad} non-finite (NaN/inf) values")
    negative = int(np.count_nonzero(albedo < 0))
    if negative:
        raise ValueError(f"albedo has {negative} negative values")
    irradiance = reference_irradiance(points, normals, environment, visible, rays=rays,
                                      seed=seed, offset=offset)
    return irradiance_xyz(irradiance, albedo, environment)


def irradiance_xyz(irradiance: np.ndarray, albedo: np.ndarray,
                   environment: ReferenceEnvironment) -> np.ndarray:
    """XYZ (N, 3) of diffuse surfaces with spectral ``irradiance`` (N, L) and ``albedo``
    ((L,) or (N, L)): ``Σ_λ E(λ) albedo(λ) m̄(λ) Δλ / π`` (``prt.albedo_weights``, the PRT's
    own R) over the Y of the white facing world up under ``environment``."""
    wl = environment.wavelengths
    weights = prt.albedo_weights(np.ones(wl.size), wl)                        # (L, 3)
    white_y = float(white_irradiance(environment) @ weights[:, 1])
    if not white_y > 0:
        raise ValueError("the environment sends no light onto an upward surface; it has no "
                         "white to normalise by")
    return (np.asarray(irradiance) * albedo) @ weights / white_y
