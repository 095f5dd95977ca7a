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

The materials and their generators live in :mod:`.height_fields`, the noisy and gappy
copies (:func:`add_noise`, :func:`drop_samples`) in :mod:`.degrade`; both are re-exported
here.
"""

from __future__ import annotations

import math

import numpy as np

from ..colour import spectra
from ..progress import ProgressCallback, report
from .container import BTF, ring_directions
from .degrade import add_noise, drop_samples
from .height_fields import (
    MATERIALS,
    HeightFieldMaterial,
    _pad,
    _Surface,
    corduroy,
    knit,
    stones,
)

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
