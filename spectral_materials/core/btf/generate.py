"""Procedural BTFs whose truth is known: tileable height fields rendered with shadows and masking.

Tests and demos of the BTF code need data with known answers: what a texel must read for a
given light and view, which parts are shadowed or hidden, what spectrum comes back. This
module makes such BTFs from periodic height fields (corduroy, knitted wool, cobbles: the
depth-varying materials of Meseth, Müller, Klein 2003), rendered like a measurement rig
would see them.

Geometry and units
------------------
A :class:`HeightFieldMaterial` covers one tile, the unit square ``0 ≤ x, y < 1``, repeated
periodically. ``height[i, j]`` is the surface height at ``(x, y) = (j / R, i / R)`` (row
``i`` = y, column ``j`` = x), in the same units as x and y (a height of 0.1 is a tenth of
the tile's width); between samples the height is bilinear. Heights are measured from the
reference plane ``z = 0`` onto which the BTF images are rectified; the generators put the
mean height there, so that parallax between views is smallest on average. ``labels[i, j]``
says which region (reflectance, gloss) the sample belongs to.

Rendering (:func:`generate_btf`)
--------------------------------
The tile is cut into ``texels × texels`` texels: texel ``(i, j)`` covers
``x ∈ [j/texels, (j+1)/texels)``, ``y ∈ [i/texels, (i+1)/texels)``, so row 0 holds the
smallest y and column 0 the smallest x. Each texel is sampled at ``supersample²`` regular
points ``p`` of the reference plane (centres of a regular sub-grid, so that shifting the
height field by whole texels shifts the images exactly). For a view ``v`` the orthographic
camera's ray through ``p`` comes down along ``−v`` and is marched over the height field to
its *first* hit (masking: whatever lies behind a ridge is not seen). At the hit point, with
normal ``n`` from the height-field gradient, region ``k`` (nearest sample's label) and
``s = 1`` if the point sees the light ``l`` (self-shadowing) else 0, the sample reads::

    value(λ) = s · [ρ_k(λ) · max(n·l, 0)  +  π · f_spec,k(n, l, v) · max(n·l, 0)]

i.e. ``π · f · (n·l) · s`` with ``f = ρ_k/π + f_spec,k``, and a texel's value is the mean
over its points. These are the units of :class:`~btf.BTF`: a flat white Lambertian surface
(ρ = 1) reads ``cos θ_l`` for every view. ``f_spec`` is a white GGX (Trowbridge–Reitz)
microfacet lobe with height-correlated Smith masking and constant Fresnel
(:func:`_glossy`): ``f_spec = specular_k · D(h) G₂(l, v) / (4 (n·l)(n·v))`` with
``α = roughness_k``; its directional albedo is at most ``specular_k`` (less at grazing
angles), so ``ρ_k + specular_k ≤ 1`` keeps a region energy conserving, and a highlight
peaks near ``specular_k / (4 α² cos θ_v)``.

Shadows depend on the surface point and the light only, so they are computed once per
light on the height-field grid (a ray marched toward the light from every sample, in steps
of half a sample, :func:`_shadow_masks`) and looked up bilinearly at each hit point.

References
----------
Meseth, J., Müller, G., Klein, R. (2003). Reflectance field based real-time, high quality
rendering of bidirectional texture functions. Computers & Graphics 28(1).
Walter, B., Marschner, S. R., Li, H., Torrance, K. E. (2007). Microfacet models for
refraction through rough surfaces. EGSR 2007 (GGX).
Heitz, E. (2014). Understanding the masking-shadowing function in microfacet-based BRDFs.
JCGT 3(2) (height-correlated Smith G₂).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..colour import spectra
from ..progress import ProgressCallback, report
from .container import BTF, ring_directions

__all__ = [
    "DEFAULT_WAVELENGTHS",
    "MATERIALS",
    "HeightFieldMaterial",
    "add_noise",
    "corduroy",
    "drop_samples",
    "generate_btf",
    "knit",
    "stones",
    "visible_surface",
]

#: Default bands of :func:`generate_btf`: 400, 420, …, 700 nm (16 bands).
DEFAULT_WAVELENGTHS = np.arange(400.0, 701.0, 20.0)

#: Largest output :func:`generate_btf` agrees to allocate (bytes of float32 values).
MAX_OUTPUT_BYTES = 2**30

#: Steepest view accepted, degrees from the normal: a view at the horizon sees the reference
#: plane edge-on (no rectified image), and the march's length grows as tan θ_v.
MAX_VIEW_THETA = 85.0

#: Elements per (points × lights) block while shading and marching shadows: bounds the
#: temporaries to a few tens of MB whatever the texel count.
_BLOCK = 1 << 20

#: Bisection steps refining a view ray's hit inside its half-sample bracket (2⁻¹⁰ of it).
_REFINE = 10

#: Longest horizontal shadow ray, in tiles: only lights within a few degrees of the horizon
#: reach it; a ray still unoccluded after two tile widths is taken as lit.
_SHADOW_REACH = 2.0

#: Lift of a shadow ray's start above its sample, in sample spacings: keeps a lit slope
#: from shadowing itself through rounding (a slope facing away is dark through n·l anyway).
_SHADOW_BIAS = 0.02

#: Smallest GGX α accepted: below it the lobe is a near-delta no direction grid resolves.
_MIN_ROUGHNESS = 1e-3


# --------------------------------------------------------------------------- material


@dataclass
class HeightFieldMaterial:
    """A periodic height field with regions of known reflectance (module docstring: units).

    Attributes
    ----------
    name : str
    height : ndarray (R, R) float64
        Height at ``(x, y) = (j/R, i/R)`` in tile units (the tile is 1 × 1 in x, y; heights
        in the same units), measured from the reference plane z = 0; periodic.
    labels : ndarray (R, R) int
        Region ``0 … K−1`` of each sample.
    reflectances : ndarray (K, len(spectra.WAVELENGTHS_REFERENCE))
        Diffuse (Lambertian) reflectance spectrum of each region on the 5 nm reference grid.
    specular : ndarray (K,)
        Weight of each region's white GGX lobe (its albedo at normal incidence); 0 = matte.
    roughness : ndarray (K,)
        GGX α of each region's lobe (unused where ``specular`` is 0).
    region_names : tuple of str
        What each region is (documentation only; may be empty).
    """

    name: str
    height: np.ndarray
    labels: np.ndarray
    reflectances: np.ndarray
    specular: np.ndarray
    roughness: np.ndarray
    region_names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        self.height = np.asarray(self.height, dtype=np.float64)
        self.labels = np.asarray(self.labels)
        self.reflectances = np.atleast_2d(np.asarray(self.reflectances, dtype=np.float64))
        self.specular = np.atleast_1d(np.asarray(self.specular, dtype=np.float64))
        self.roughness = np.atleast_1d(np.asarray(self.roughness, dtype=np.float64))
        self.validate()

    @property
    def resolution(self) -> int:
        return int(self.height.shape[0])

    @property
    def regions(self) -> int:
        return int(self.reflectances.shape[0])

    def validate(self) -> None:
        """Raise ValueError naming the first inconsistent or impossible field."""
        h = self.height
        if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] < 2:
            raise ValueError(f"{self.name}: height must be a square (R, R) array with R ≥ 2, "
                             f"got shape {h.shape}")
        if not np.all(np.isfinite(h)):
            raise ValueError(f"{self.name}: height holds {int((~np.isfinite(h)).sum())} "
                             "non-finite values (NaN or inf)")
        if self.labels.shape != h.shape:
            raise ValueError(f"{self.name}: labels shape {self.labels.shape} differs from "
                             f"height shape {h.shape}")
        if not np.issubdtype(self.labels.dtype, np.integer):
            raise ValueError(f"{self.name}: labels must be integers, got {self.labels.dtype}")
        k = self.reflectances.shape[0]
        if self.reflectances.shape != (k, len(spectra.WAVELENGTHS_REFERENCE)):
            raise ValueError(f"{self.name}: reflectances must be (K, "
                             f"{len(spectra.WAVELENGTHS_REFERENCE)}) on the reference grid, "
                             f"got shape {self.reflectances.shape}")
        if self.labels.min() < 0 or self.labels.max() >= k:
            raise ValueError(f"{self.name}: labels span {self.labels.min()}..{self.labels.max()}"
                             f" but there are {k} regions")
        if not np.all(np.isfinite(self.reflectances)) or self.reflectances.min() < 0.0:
            raise ValueError(f"{self.name}: reflectances must be finite and ≥ 0")
        for what, values in (("specular", self.specular), ("roughness", self.roughness)):
            if values.shape != (k,):
                raise ValueError(f"{self.name}: {what} must have one value per region ({k}), "
                                 f"got shape {values.shape}")
            if not np.all(np.isfinite(values)):
                raise ValueError(f"{self.name}: {what} holds non-finite values")
        if self.specular.min() < 0.0:
            raise ValueError(f"{self.name}: specular weights must be ≥ 0")
        if self.roughness.min() < _MIN_ROUGHNESS:
            raise ValueError(f"{self.name}: roughness (GGX α) must be ≥ {_MIN_ROUGHNESS}")


# ------------------------------------------------------------------ generators


def _check_resolution(resolution: int) -> int:
    if not isinstance(resolution, int | np.integer) or not 16 <= resolution <= 4096:
        raise ValueError(f"resolution must be an integer in 16..4096, got {resolution!r}")
    return int(resolution)


def _tile_coordinates(r: int) -> tuple[np.ndarray, np.ndarray]:
    """(y, x) of the samples, each (R, R): row i at y = i/R, column j at x = j/R."""
    c = np.arange(r) / r
    return np.meshgrid(c, c, indexing="ij")


def _periodic_noise(r: int, rng: np.random.Generator, cutoff: float) -> np.ndarray:
    """Smooth periodic noise of unit standard deviation: random Fourier coefficients at
    integer frequencies up to ``cutoff`` cycles per tile (falling as 1/f), so that it tiles
    exactly."""
    f = np.fft.fftfreq(r, 1.0 / r)
    radius = np.hypot(*np.meshgrid(f, f, indexing="ij"))
    amplitude = np.where((radius > 0) & (radius <= cutoff), 1.0 / np.maximum(radius, 1.0), 0.0)
    coefficients = amplitude * (rng.standard_normal((r, r)) + 1j * rng.standard_normal((r, r)))
    noise = np.fft.ifft2(coefficients).real
    return noise / max(float(noise.std()), 1e-300)


def _centred(height: np.ndarray) -> np.ndarray:
    """Put the mean height on the reference plane z = 0."""
    return height - height.mean()


def corduroy(resolution: int = 128, *, seed: int = 0) -> HeightFieldMaterial:
    """Corduroy: four wales (rounded ridges running along y) per tile with deep grooves.

    Each wale is a half-ellipse 0.8 of the 0.25 period wide and about 0.09 high (walls
    vertical at its foot), so grazing light across the wales (along x) leaves the grooves
    and the wales' far sides dark; pile texture (fine periodic noise) and a few per cent of
    height variation between wales come from ``seed``. Regions: 0 ridge tops, dyed with the
    ColorChecker *red*; 1 groove fibres, the darker *dark skin* brown at 60 %. Matte.

    Parameters
    ----------
    resolution : int
        Height-field samples per tile side (16..4096).
    seed : int
        Seed of the random detail.

    Returns
    -------
    HeightFieldMaterial
    """
    r = _check_resolution(resolution)
    rng = np.random.default_rng(seed)
    y, x = _tile_coordinates(r)
    wales, depth, width = 4, 0.09, 0.8
    phase = x * wales
    wale = np.floor(phase).astype(np.int64) % wales
    across = (phase - np.floor(phase) - 0.5) / (0.5 * width)     # −1..1 over the wale
    profile = np.sqrt(np.clip(1.0 - across**2, 0.0, 1.0))
    scale = 1.0 + 0.05 * rng.standard_normal(wales)
    pile = 0.0025 * _periodic_noise(r, rng, cutoff=r / 6)
    height = depth * scale[wale] * profile + pile
    labels = np.where(profile > 0.35, 0, 1).astype(np.int64)
    reflectances = np.stack([spectra.colorchecker(15), 0.6 * spectra.colorchecker(1)])
    return HeightFieldMaterial("corduroy", _centred(height), labels, reflectances,
                               specular=np.zeros(2), roughness=np.ones(2),
                               region_names=("ridge (red dye)", "groove (dark fibres)"))


def knit(resolution: int = 128, *, seed: int = 0) -> HeightFieldMaterial:
    """Knitted wool (stockinette): 4 × 5 stitches per tile, each a V of two yarn legs.

    A leg is an ellipsoidal bump (semi-axes 0.62 of the stitch height along the yarn, 0.24
    of its width across, about 0.065 high) tilted 24° from the y axis, the two legs of a
    stitch leaning apart so that the stitches read as columns of V's; legs reach into the
    neighbouring rows as interlocked loops do. The ply twist is a shallow diagonal ripple
    on each leg. ``seed`` varies each stitch's height (±10 %), tilt (±3°) and position, and
    the fibre fuzz. Regions: 0 yarn (cream wool: half ColorChecker *light skin*, half
    *neutral 8*); 1 the gaps between loops, the same wool at 45 % (deeper fibres). Matte.

    Parameters
    ----------
    resolution : int
        Height-field samples per tile side (16..4096).
    seed : int
        Seed of the random detail.

    Returns
    -------
    HeightFieldMaterial
    """
    r = _check_resolution(resolution)
    rng = np.random.default_rng(seed)
    y, x = _tile_coordinates(r)
    cols, rows, amp = 4, 5, 0.065
    w, h = 1.0 / cols, 1.0 / rows
    amps = amp * (1.0 + 0.1 * rng.standard_normal((rows, cols)))
    tilts = np.radians(24.0 + 3.0 * rng.standard_normal((rows, cols)))
    shifts = 0.03 * rng.standard_normal((2, rows, cols)) * np.array([w, h])[:, None, None]
    col0 = np.floor(x / w).astype(np.int64)
    row0 = np.floor(y / h).astype(np.int64)
    height = np.zeros((r, r))
    # A leg may reach into the neighbouring cells; cells beyond the tile's edge are the
    # wrapped ones (jitter indexed modulo the counts), which keeps the field periodic.
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            c, rr = col0 + dc, row0 + dr
            cm, rm = c % cols, rr % rows
            cx = (c + 0.5) * w + shifts[0, rm, cm]
            cy = (rr + 0.5) * h + shifts[1, rm, cm]
            for side in (-1.0, 1.0):
                ax, ay = side * np.sin(tilts[rm, cm]), np.cos(tilts[rm, cm])
                dx, dy = x - (cx + side * 0.22 * w), y - cy
                along, across = dx * ax + dy * ay, dy * ax - dx * ay
                r2 = (along / (0.62 * h)) ** 2 + (across / (0.24 * w)) ** 2
                ripple = 1.0 + 0.06 * np.cos(2.0 * np.pi * (along / (0.2 * h)
                                                             + across / (0.12 * w)))
                leg = amps[rm, cm] * np.sqrt(np.clip(1.0 - r2, 0.0, 1.0)) * ripple
                height = np.maximum(height, leg)
    height = height + 0.002 * _periodic_noise(r, rng, cutoff=r / 6)
    labels = np.where(height > 0.3 * amp, 0, 1).astype(np.int64)
    wool = 0.5 * spectra.colorchecker(2) + 0.5 * spectra.colorchecker(20)
    return HeightFieldMaterial("knit", _centred(height), labels, np.stack([wool, 0.45 * wool]),
                               specular=np.zeros(2), roughness=np.ones(2),
                               region_names=("yarn (cream wool)", "gaps (deep fibres)"))


#: ColorChecker patches the cobbles are drawn from: dark skin and light skin (browns),
#: foliage (green), neutral 6.5 and neutral 5 (greys).
_STONE_PATCHES = (1, 2, 4, 21, 22)


def stones(resolution: int = 128, *, seed: int = 0) -> HeightFieldMaterial:
    """Cobbles: 14 domed stones (periodic Voronoi cells) set in a mortar bed.

    Sites are spread by rejection (at least 0.14 apart, minimum-image distances, so the
    cells tile). With ``e`` the distance to the cell's nearest edge (the bisector of the
    two nearest sites), a stone rises from the mortar gap (``e < 0.012``) as a quarter
    ellipse ``sqrt(t (2 − t))``, ``t = min((e − gap)/0.03, 1)`` (a vertical wall at its
    rim), times a dome about its site (1 at the site, 0.55 at its farthest point), times
    its ``top``, 0.045–0.075; the mortar is a rough bed at the bottom. Each stone has
    its own reflectance (a patch of :data:`_STONE_PATCHES` scaled 0.75–1.1 and mixed up
    to 40 % with neutral 5) and a glossy GGX lobe (specular 0.04–0.08, α 0.14–0.25:
    stone shows strong specularities); the mortar (last region, ColorChecker neutral 8
    at 80 %) is matte.

    Parameters
    ----------
    resolution : int
        Height-field samples per tile side (16..4096).
    seed : int
        Seed of the stones' layout, heights, colours and gloss.

    Returns
    -------
    HeightFieldMaterial
    """
    r = _check_resolution(resolution)
    rng = np.random.default_rng(seed)
    count, spacing, gap, rim = 14, 0.14, 0.012, 0.03
    sites: list[np.ndarray] = []
    while len(sites) < count:                      # dart throwing; 14 fit easily
        s = rng.random(2)
        if all(np.hypot(*(d - np.round(d))) >= spacing for d in (s - t for t in sites)):
            sites.append(s)
    site = np.array(sites)                                       # (N, 2) as (x, y)
    y, x = _tile_coordinates(r)
    delta = np.stack([x, y], axis=-1)[:, :, None, :] - site      # (R, R, N, 2)
    delta -= np.round(delta)                                     # minimum image: periodic
    dist2 = np.sum(delta**2, axis=-1)
    order = np.argsort(dist2, axis=-1)
    nearest, second = order[..., 0], order[..., 1]
    d1 = np.take_along_axis(delta, nearest[..., None, None], axis=2)[:, :, 0]
    d2 = np.take_along_axis(delta, second[..., None, None], axis=2)[:, :, 0]
    # Distance from the point to the bisector of its two nearest sites.
    edge = (np.sum(d2**2, -1) - np.sum(d1**2, -1)) / (2.0 * np.linalg.norm(d2 - d1, axis=-1))
    # Dome: an elliptic cap about the site, reaching 55 % of the top at the stone's
    # farthest point; rim: a quarter ellipse over the last ``rim`` before the edge. Their
    # product is smooth inside the stone (no creases along the cell's medial axis).
    radius = np.zeros(count)
    np.maximum.at(radius, nearest.ravel(), np.sqrt(dist2.min(axis=-1)).ravel())
    d = np.sqrt(np.sum(d1**2, axis=-1)) / (1.02 * radius[nearest])
    dome = 0.55 + 0.45 * np.clip(1.0 - d**2, 0.0, 1.0)
    t = np.clip((edge - gap) / rim, 0.0, 1.0)
    tops = rng.uniform(0.045, 0.075, count)
    height = tops[nearest] * dome * np.sqrt(t * (2.0 - t))
    height = height + 0.0015 * _periodic_noise(r, rng, cutoff=r / 5)
    labels = np.where(edge > gap, nearest, count).astype(np.int64)
    patches = rng.choice(_STONE_PATCHES, count)
    brightness = rng.uniform(0.75, 1.1, count)
    grey = rng.uniform(0.0, 0.4, count)
    neutral = spectra.colorchecker(22)
    stone = np.stack([(1 - g) * b * spectra.colorchecker(int(p)) + g * neutral
                      for p, b, g in zip(patches, brightness, grey)])
    reflectances = np.clip(np.vstack([stone, 0.8 * spectra.colorchecker(20)]), 0.0, 1.0)
    specular = np.append(rng.uniform(0.04, 0.08, count), 0.0)
    roughness = np.append(rng.uniform(0.14, 0.25, count), 1.0)
    names = tuple(f"stone {i} ({spectra.colorchecker_names()[p - 1]})"
                  for i, p in enumerate(patches)) + ("mortar",)
    return HeightFieldMaterial("stones", _centred(height), labels, reflectances, specular,
                               roughness, region_names=names)


#: The generators by name, for :func:`generate_btf`'s ``material`` argument.
MATERIALS: dict[str, Callable[..., HeightFieldMaterial]] = {
    "corduroy": corduroy, "knit": knit, "stones": stones}


# ------------------------------------------------------------- periodic lookups


class _Surface:
    """A material's height field prepared for periodic bilinear lookups.

    Tables are padded to (R+1) × (R+1) with the wrapped first row and column, so that a
    cell's four corners are ``idx, idx+1, idx+R+1, idx+R+2`` with no wrap at lookup time.
    Positions are in sample units: ``u = x·R``, ``w = y·R``.
    """

    def __init__(self, material: HeightFieldMaterial):
        h = material.height
        r = h.shape[0]
        self.r = r
        self.height = _pad(h)
        # Central differences (per tile unit), interpolated bilinearly: smooth normals
        # where the bilinear surface's own gradient would jump at every cell edge.
        gx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) * (0.5 * r)
        gy = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) * (0.5 * r)
        self.gradient = _pad(np.stack([gx, gy], axis=-1))
        self.labels = material.labels.ravel()
        self.lowest, self.highest = float(h.min()), float(h.max())

    def cell(self, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Padded-table index of the cell holding (u, w), and the fractions within it."""
        iu, iw = np.floor(u), np.floor(w)
        index = (iw.astype(np.int64) % self.r) * (self.r + 1) + iu.astype(np.int64) % self.r
        return index, u - iu, w - iw

    def lerp(self, table: np.ndarray, index: np.ndarray, fu: np.ndarray,
             fw: np.ndarray) -> np.ndarray:
        """Bilinear lookup; exact for a constant table (no weights summing to 1 ± ε).
        Integer tables (the 0/1 shadow masks, stored as bytes) are read as float32."""
        if table.ndim > 1:
            fu, fw = fu[:, None], fw[:, None]
        a, b = table[index], table[index + 1]
        c, d = table[index + self.r + 1], table[index + self.r + 2]
        if not np.issubdtype(table.dtype, np.floating):      # 0/1 shadow tables: no wrap
            a, b, c, d = (x.astype(np.float32) for x in (a, b, c, d))
        top = a + fu * (b - a)
        return top + fw * (c + fu * (d - c) - top)

    def height_at(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        return self.lerp(self.height, *self.cell(u, w))

    def label_at(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Region of the nearest sample."""
        iu = np.floor(u + 0.5).astype(np.int64) % self.r
        iw = np.floor(w + 0.5).astype(np.int64) % self.r
        return self.labels[iw * self.r + iu]


def _pad(table: np.ndarray) -> np.ndarray:
    """(R, R, …) → ((R+1)², …) with row R = row 0 and column R = column 0."""
    padded = np.concatenate([table, table[:1]], axis=0)
    padded = np.concatenate([padded, padded[:, :1]], axis=1)
    return np.ascontiguousarray(padded.reshape(-1, *table.shape[2:]))


# ------------------------------------------------------------------ ray marching


def _trace_view(surface: _Surface, view: np.ndarray, u: np.ndarray, w: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the rays coming down along −view through reference points (u, w) (sample
    units, on z = 0) first meet the surface: (u, w, z) of the hits, on the rays.

    The ray through p is at ``p + z · v_xy / v_z`` when at height z. It is marched down
    from the highest height to the lowest in steps moving it at most half a sample
    sideways, the first step at or below the surface brackets the first hit (masking),
    and bisection narrows the bracket to 2⁻¹⁰ of a step.
    """
    r = surface.r
    su, sw = view[0] / view[2] * r, view[1] / view[2] * r       # samples per unit height
    top, bottom = surface.highest, surface.lowest
    if su == 0.0 and sw == 0.0:                                  # straight down
        return u, w, surface.height_at(u, w)
    reach = (top - bottom) * math.hypot(su, sw)                  # sideways travel, samples
    steps = int(math.ceil(2.0 * reach))
    if steps == 0:                                               # flat field
        return u + top * su, w + top * sw, np.full(u.shape, top)
    dz = (top - bottom) / steps
    first = np.full(u.shape, steps, dtype=np.int64)              # step of the first hit
    active = np.arange(u.size)
    for k in range(steps + 1):
        z = top - k * dz if k < steps else bottom                # the last step at the floor
        ua, wa = u[active], w[active]
        hit = surface.height_at(ua + z * su, wa + z * sw) >= z
        first[active[hit]] = k
        active = active[~hit]
        if active.size == 0:
            break
    below = np.where(first < steps, top - first * dz, bottom)    # on or under the surface
    above = np.where(first > 0, top - (first - 1) * dz, below)   # above it (or = at k 0)
    for _ in range(_REFINE):
        mid = 0.5 * (above + below)
        under = surface.height_at(u + mid * su, w + mid * sw) >= mid
        below = np.where(under, mid, below)
        above = np.where(under, above, mid)
    z = 0.5 * (above + below)
    return u + z * su, w + z * sw, z


def _shadow_masks(surface: _Surface, lights: np.ndarray) -> np.ndarray:
    """((R+1)², L) uint8 padded table: 1 where sample (i, j) sees light l, else 0.

    From each sample (lifted by :data:`_SHADOW_BIAS` of a sample spacing) a ray is marched
    toward the light in steps of half a sample sideways until it is above the highest
    height (lit), meets the surface (shadowed), or has run :data:`_SHADOW_REACH` tiles
    (lit: only near-horizon lights get there). The pole light shadows nothing. The
    (light, sample) rays go in blocks of :data:`_BLOCK`, all of a block's rays stepping
    together and leaving the block as soon as they are decided.
    """
    r = surface.r
    nodes = r * r
    base = surface.height.reshape(r + 1, r + 1)[:r, :r].ravel()  # unpadded heights (R²,)
    bias = _SHADOW_BIAS / r
    lit = np.ones((nodes, len(lights)), dtype=np.uint8)
    horizontal = np.hypot(lights[:, 0], lights[:, 1])
    oblique = np.flatnonzero(horizontal > 1e-12)
    # Per light: sideways step (half a sample) in u and w, and the rise per step.
    du = 0.5 * lights[oblique, 0] / horizontal[oblique]
    dw = 0.5 * lights[oblique, 1] / horizontal[oblique]
    rise = 0.5 / r * lights[oblique, 2] / horizontal[oblique]
    max_steps = int(math.ceil(2.0 * _SHADOW_REACH * r))
    for first in range(0, len(oblique) * nodes, _BLOCK):
        pair = np.arange(first, min(first + _BLOCK, len(oblique) * nodes))
        light_of, node = np.divmod(pair, nodes)
        # Steps until the ray is above the highest point (capped; a horizon light's
        # ray never climbs).
        climb = rise[light_of]
        need = np.full(len(pair), max_steps, dtype=np.int64)
        up = climb > 0.0
        need[up] = np.minimum(max_steps, np.ceil(
            (surface.highest - base[node[up]] - bias) / climb[up]).astype(np.int64))
        live = need > 0
        light_of, node, need = light_of[live], node[live], need[live]
        row, col = np.divmod(node, r)
        k = 1
        while node.size:
            u = col + k * du[light_of]
            w = row + k * dw[light_of]
            z = base[node] + bias + k * rise[light_of]
            blocked = surface.height_at(u, w) > z
            lit[node[blocked], oblique[light_of[blocked]]] = 0
            going = ~blocked & (need > k)
            light_of, node, need = light_of[going], node[going], need[going]
            row, col = row[going], col[going]
            k += 1
    return _pad(lit.reshape(r, r, len(lights)))


# ----------------------------------------------------------------------- shading


def _glossy(n: np.ndarray, view: np.ndarray, lights: np.ndarray, alpha: np.ndarray,
            weight: np.ndarray) -> np.ndarray:
    """``π · f_spec · (n·l)`` (P, L) of a white GGX lobe with height-correlated Smith G₂
    and constant Fresnel ``weight``: ``weight · α² G₂ / (4 (n·v) ((n·h)²(α²−1) + 1)²)``
    (the π of D cancels the value's π, the n·l of f's denominator the foreshortening).
    Zero where n·l ≤ 0 or n·v ≤ 0."""
    half = lights + view
    half /= np.maximum(np.linalg.norm(half, axis=1, keepdims=True), 1e-300)
    nh = n @ half.T                                              # (P, L)
    nl = n @ lights.T
    nv = n @ view
    a2 = (alpha * alpha)[:, None]

    def smith_lambda(cosine: np.ndarray) -> np.ndarray:
        c2 = np.clip(cosine, 1e-6, 1.0) ** 2
        return 0.5 * (np.sqrt(1.0 + a2 * (1.0 - c2) / c2) - 1.0)

    g2 = 1.0 / (1.0 + smith_lambda(nv[:, None]) + smith_lambda(nl))
    denominator = (np.clip(nh, 0.0, 1.0) ** 2 * (a2 - 1.0) + 1.0) ** 2
    value = weight[:, None] * a2 * g2 / (4.0 * np.maximum(nv, 1e-6)[:, None] * denominator)
    return np.where((nl > 0.0) & (nv[:, None] > 0.0) & (nh > 0.0), value, 0.0)


def _shade_view(surface: _Surface, material: HeightFieldMaterial, u: np.ndarray,
                w: np.ndarray, view: np.ndarray, lights: np.ndarray, shadow: np.ndarray,
                albedo: np.ndarray, texels: int, per_texel: int) -> np.ndarray:
    """(L, texels, C) values of one view from the hit points (u, w) of ``texels`` texels,
    ``per_texel`` consecutive points each."""
    cell = surface.cell(u, w)
    gradient = surface.lerp(surface.gradient, *cell)
    n = np.column_stack([-gradient, np.ones(len(u))])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    label = surface.label_at(u, w)
    colour = albedo[label].reshape(texels, per_texel, -1)             # (T, S², C)
    glossy = np.flatnonzero(material.specular[label] > 0.0)
    out = np.empty((len(lights), texels, albedo.shape[1]), dtype=np.float32)
    chunk = max(1, _BLOCK // len(u))
    for start in range(0, len(lights), chunk):
        part = slice(start, start + chunk)
        seen = surface.lerp(shadow[:, part], *cell)                    # (P, Lc) in 0..1
        lambert = np.maximum(n @ lights[part].T, 0.0) * seen
        lc = lambert.shape[1]
        # Σ over a texel's points of weight × colour, as one small matmul per texel.
        grouped = lambert.reshape(texels, per_texel, lc).transpose(0, 2, 1)
        total = np.matmul(grouped, colour)                             # (T, Lc, C)
        if glossy.size:
            spec = np.zeros_like(lambert)
            spec[glossy] = seen[glossy] * _glossy(
                n[glossy], view, lights[part], material.roughness[label[glossy]],
                material.specular[label[glossy]])
            total += spec.reshape(texels, per_texel, lc).sum(axis=1)[:, :, None]
        out[part] = (total / per_texel).transpose(1, 0, 2)
    return out


# ------------------------------------------------------------------- public API


def _resolve(material: HeightFieldMaterial | str) -> HeightFieldMaterial:
    if isinstance(material, str):
        if material not in MATERIALS:
            raise ValueError(f"unknown material {material!r}; choose one of "
                             f"{', '.join(sorted(MATERIALS))}")
        return MATERIALS[material]()
    if not isinstance(material, HeightFieldMaterial):
        raise ValueError(f"material must be a HeightFieldMaterial or a name in MATERIALS, "
                         f"got {type(material).__name__}")
    material.validate()                                  # fields may have changed since
    return material


def _count(value: int, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{what} must be an integer ≥ 1, got {value!r}")
    return int(value)


def _directions(directions, what: str) -> np.ndarray:
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim == 1 and d.shape == (3,):
        d = d[None]
    if d.ndim != 2 or d.shape[1] != 3 or len(d) == 0:
        raise ValueError(f"{what} directions must be a non-empty (N, 3) array, got shape "
                         f"{d.shape}")
    if not np.all(np.isfinite(d)):
        raise ValueError(f"{what} directions hold NaN or inf")
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError(f"{what} directions include a zero vector")
    d = d / norm
    # The tolerance BTF applies; a direction a rounding error below the horizon is on it.
    if np.any(d[:, 2] < -1e-9):
        raise ValueError(f"{what} directions must lie on the upper hemisphere (z ≥ 0)")
    d[:, 2] = np.maximum(d[:, 2], 0.0)
    return d


def _views(directions) -> np.ndarray:
    views = _directions(directions, "view")
    steepest = float(np.degrees(np.arccos(np.clip(views[:, 2].min(), -1.0, 1.0))))
    if steepest > MAX_VIEW_THETA + 1e-9:
        raise ValueError(f"a view {steepest:.1f}° from the normal is beyond the "
                         f"{MAX_VIEW_THETA:.0f}° this renderer accepts (the reference plane "
                         "is seen edge-on)")
    return views


def _sample_points(texels: int, supersample: int, r: int, first_row: int = 0,
                   rows: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(u, w) in sample units of the regular sub-grid points of texel rows
    ``first_row …`` (default all), texel-major: point ``((i − first_row)·T + j)·S² + b·S + a``
    is sub-point (a, b) of texel (i, j)."""
    rows = texels - first_row if rows is None else rows
    sub = (np.arange(supersample) + 0.5) / supersample
    pos = (np.arange(texels)[:, None] + sub[None, :]) / texels * r       # (T, S)
    shape = (rows, texels, supersample, supersample)
    w = np.broadcast_to(pos[first_row:first_row + rows, None, :, None], shape)
    u = np.broadcast_to(pos[None, :, None, :], shape)
    return u.ravel().copy(), w.ravel().copy()


def visible_surface(material: HeightFieldMaterial | str, view, *, texels: int = 32,
                    supersample: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The surface points a view sees at each texel's sample points (masking included).

    Parameters
    ----------
    material : HeightFieldMaterial or str
        A material or a name in :data:`MATERIALS`.
    view : array_like (3,)
        Direction toward the viewer (z ≥ 0, at most :data:`MAX_VIEW_THETA` from z).
    texels, supersample : int
        As in :func:`generate_btf`.

    Returns
    -------
    points : ndarray (T, T, S², 3)
        x, y (tile units, not wrapped into the tile) and height of each first hit: on
        the view ray exactly, on the surface to 2⁻¹⁰ of the march's half-sample step.
    labels : ndarray (T, T, S²) int
        Region of each hit.
    """
    mat = _resolve(material)
    texels, supersample = _count(texels, "texels"), _count(supersample, "supersample")
    v = _views(view)[0]
    surface = _Surface(mat)
    u, w, z = _trace_view(surface, v, *_sample_points(texels, supersample, surface.r))
    shape = (texels, texels, supersample * supersample)
    points = np.stack([u / surface.r, w / surface.r, z], axis=-1).reshape(*shape, 3)
    return points, surface.label_at(u, w).reshape(shape)


def generate_btf(material: HeightFieldMaterial | str, *, texels: int = 32, views=None,
                 lights=None, wavelengths=None, supersample: int = 3,
                 name: str | None = None, callback: ProgressCallback | None = None,
                 shadows: bool = True) -> BTF:
    """Render a spectral BTF of a height-field material (module docstring: conventions).

    Parameters
    ----------
    material : HeightFieldMaterial or str
        A material, or the name of a generator in :data:`MATERIALS` (default arguments).
    texels : int
        Texels per tile side; the output images are ``texels × texels``.
    views, lights : array_like (V, 3), (L, 3), optional
        Directions toward viewer and light (z ≥ 0; views at most :data:`MAX_VIEW_THETA`
        from the normal); default :func:`btf.ring_directions` (UBO2003's 81).
    wavelengths : array_like (C,), optional
        Bands in nm; default :data:`DEFAULT_WAVELENGTHS`. Region reflectances are
        interpolated linearly (``np.interp``, end values held).
    supersample : int
        Sample points per texel side (regular sub-grid, averaged).
    name : str, optional
        The BTF's name; default the material's.
    callback : callable, optional
        ``callback(fraction, message) -> stop?``, called once per view; a true return
        raises :class:`~errors.Cancelled`.
    shadows : bool
        False leaves self-shadowing out (every point sees every light it faces): the same
        BTF without shadows, to show or test what they contribute. Masking stays.

    Returns
    -------
    BTF
        values (V, L, texels, texels, C) float32: ``π f (n·l)`` with shadowing and masking,
        averaged over each texel's points.

    Raises
    ------
    ValueError
        An unknown material name, an inconsistent material, counts < 1, directions off the
        hemisphere or views too grazing, or an output over :data:`MAX_OUTPUT_BYTES`.
    """
    mat = _resolve(material)
    texels, supersample = _count(texels, "texels"), _count(supersample, "supersample")
    views = _views(ring_directions() if views is None else views)
    lights = _directions(ring_directions() if lights is None else lights, "light")
    wl = spectra.check_wavelengths(DEFAULT_WAVELENGTHS if wavelengths is None else wavelengths)
    size = 4 * len(views) * len(lights) * texels * texels * len(wl)
    if size > MAX_OUTPUT_BYTES:
        raise ValueError(f"output of {len(views)} views × {len(lights)} lights × {texels}² "
                         f"texels × {len(wl)} bands is {size / 2**30:.1f} GiB, over the "
                         f"{MAX_OUTPUT_BYTES / 2**30:.0f} GiB limit (fewer texels or bands)")
    if (mat.resolution + 1) ** 2 * len(lights) > MAX_OUTPUT_BYTES:
        raise ValueError(f"shadow tables of {len(lights)} lights on a {mat.resolution}² "
                         "height field would pass 1 GiB (a coarser height field or fewer "
                         "lights)")
    if texels * supersample > 1 << 14:
        raise ValueError(f"{texels} texels × {supersample} supersample = "
                         f"{texels * supersample} points per side is absurd (limit 16384)")
    albedo = np.stack([np.interp(wl, spectra.WAVELENGTHS_REFERENCE, rho)
                       for rho in mat.reflectances])                     # (K, C)
    surface = _Surface(mat)
    report(callback, 0.0, f"{mat.name}: shadows of {len(lights)} lights")
    if shadows:
        shadow = _shadow_masks(surface, lights)
    else:
        shadow = np.ones(((surface.r + 1) ** 2, len(lights)), dtype=np.uint8)
    per_texel = supersample * supersample
    # Texel rows per block: at most _BLOCK points in flight, whatever the texel count.
    rows = max(1, min(texels, _BLOCK // (texels * per_texel)))
    blocks = [(top, min(rows, texels - top)) for top in range(0, texels, rows)]
    points = [_sample_points(texels, supersample, surface.r, top, n) for top, n in blocks] \
        if len(blocks) == 1 else None                   # one block: reuse it for every view
    values = np.empty((len(views), len(lights), texels, texels, len(wl)), dtype=np.float32)
    for index, view in enumerate(views):
        for b, (top, n) in enumerate(blocks):
            u, w = points[b] if points else _sample_points(texels, supersample, surface.r,
                                                           top, n)
            hu, hw, _ = _trace_view(surface, view, u, w)
            block = _shade_view(surface, mat, hu, hw, view, lights, shadow, albedo,
                                n * texels, per_texel)
            values[index, :, top:top + n] = block.reshape(len(lights), n, texels, -1)
        report(callback, (index + 1) / len(views),
               f"{mat.name}: view {index + 1}/{len(views)}")
    return BTF(values, views, lights, wl, name or mat.name)


# ------------------------------------------------------------ stiff test cases


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
