"""Tileable height-field materials for :mod:`.generate`: the :class:`HeightFieldMaterial`
(heights, region labels, per-region reflectance and gloss), the corduroy, knit and stones
generators, and the periodic bilinear lookups the renderer marches over."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..colour import spectra

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
