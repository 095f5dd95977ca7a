"""The BTF container: ``BTF(x, l, v, λ)`` sampled on texels, light and view directions.

A bidirectional texture function is an image per (view, light) pair (Meseth, Müller,
Klein 2003, §3). :class:`BTF` holds one as a float32 array ``values (V, L, H, W, C)``:
V view directions, L light directions, H × W texels, C channels (wavelengths in nm for
a spectral BTF, linear Rec.709 R, G, B for an RGB one). Directions are unit vectors in
the sample's local frame, z the surface normal, x the primary tangent, both pointing
away from the surface (``PROTOCOL.md``: ``wi`` toward the light, ``wo`` toward the
viewer).

Units: a value is the *reflectance factor including foreshortening*,
``π · f(x, l, v, λ) · cos θ_l`` (with self-shadowing and masking folded in), so that a
flat white Lambertian texel lit at normal incidence reads 1, and the reflected XYZ under
a light of irradiance E is ``E · Σ_λ value/π · W(λ)`` with the protocol's weights
``W`` (:func:`colour_pipeline.xyz_weights`). Measured BTFs (UBO) include ``n·l`` in the
same way (paper, Fig. 1).

Missing samples are NaN and flagged ``False`` in :attr:`BTF.present` (V, L); nothing is
invented for them. :func:`resample` moves a BTF onto another direction set by
barycentric interpolation over the hemisphere (:class:`HemisphereTriangulation`), which
is also how renderers interpolate between the measured views.

References
----------
Meseth, J., Müller, G., Klein, R. (2003). Reflectance field based real-time, high
quality rendering of bidirectional texture functions. Computers & Graphics 28(1).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..colour import spectra
from ..errors import InvalidBRDFData

#: The UBO2003 direction set: polar angles and the number of azimuths on each ring
#: (81 directions; Sattler, Sarlette, Klein 2003).
UBO81_RINGS = ((0.0, 1), (15.0, 6), (30.0, 12), (45.0, 18), (60.0, 20), (75.0, 24))

#: Rec.709 / sRGB luminance weights of linear R, G, B.
REC709_Y = np.array([0.2126, 0.7152, 0.0722])


class InvalidBTF(InvalidBRDFData):
    """A BTF's arrays are inconsistent or hold impossible values; the message says which."""


def ring_directions(rings=UBO81_RINGS) -> np.ndarray:
    """Unit directions (N, 3) on rings of constant polar angle ``(θ°, count)``, azimuths
    evenly spaced from φ = 0; :data:`UBO81_RINGS` gives the UBO2003 81-direction set."""
    out = []
    for theta, count in rings:
        t = np.radians(theta)
        phi = np.arange(int(count)) * (2.0 * np.pi / int(count))
        out.append(np.stack([np.sin(t) * np.cos(phi), np.sin(t) * np.sin(phi),
                             np.full(int(count), np.cos(t))], axis=-1))
    return np.concatenate(out, axis=0)


def _unit_directions(directions, what: str) -> np.ndarray:
    d = np.asarray(directions, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != 3 or d.shape[0] == 0:
        raise InvalidBTF(f"{what} directions must be a non-empty (N, 3) array, got shape "
                         f"{d.shape}")
    if not np.all(np.isfinite(d)):
        raise InvalidBTF(f"{what} directions hold NaN or inf")
    norm = np.linalg.norm(d, axis=1)
    if np.any(norm < 1e-12):
        raise InvalidBTF(f"{what} directions include a zero vector")
    d = d / norm[:, None]
    if np.any(d[:, 2] < -1e-9):
        raise InvalidBTF(f"{what} directions must lie on the upper hemisphere (z ≥ 0); "
                         f"{int(np.sum(d[:, 2] < -1e-9))} point below the surface")
    return d


@dataclass
class BTF:
    """A sampled BTF (see the module docstring for layout and units).

    Attributes
    ----------
    values : ndarray (V, L, H, W, C) float32
        Reflectance factor × cos θ_l; NaN where a (view, light) image is missing.
    views, lights : ndarray (V, 3), (L, 3)
        Unit directions toward the viewer and toward the light, local frame z up.
    wavelengths : ndarray (C,) or None
        nm for a spectral BTF; None for linear Rec.709 RGB (C = 3).
    name : str
    """

    values: np.ndarray
    views: np.ndarray
    lights: np.ndarray
    wavelengths: np.ndarray | None = None
    name: str = "BTF"
    present: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        values = np.asarray(self.values)
        if values.ndim != 5:
            raise InvalidBTF(f"{self.name}: values must be (views, lights, H, W, channels), "
                             f"got shape {values.shape}")
        self.values = values.astype(np.float32, copy=False)
        self.views = _unit_directions(self.views, f"{self.name}: view")
        self.lights = _unit_directions(self.lights, f"{self.name}: light")
        v, lc, h, w, c = self.values.shape
        if (v, lc) != (len(self.views), len(self.lights)):
            raise InvalidBTF(f"{self.name}: values hold {v} views × {lc} lights but "
                             f"{len(self.views)} view and {len(self.lights)} light directions "
                             "are given")
        if min(h, w, c) < 1:
            raise InvalidBTF(f"{self.name}: empty texel or channel axis ({self.values.shape})")
        if self.wavelengths is None:
            if c != 3:
                raise InvalidBTF(f"{self.name}: an RGB BTF needs 3 channels, got {c}")
        else:
            self.wavelengths = spectra.check_wavelengths(self.wavelengths)
            if len(self.wavelengths) != c:
                raise InvalidBTF(f"{self.name}: {c} channels but {len(self.wavelengths)} "
                                 "wavelengths")
        finite = np.isfinite(self.values)
        if np.any(np.isinf(self.values)):
            raise InvalidBTF(f"{self.name}: {int(np.isinf(self.values).sum())} infinite "
                             "samples")
        self.present = finite.reshape(v, lc, -1).all(axis=2)
        partial = finite.reshape(v, lc, -1).any(axis=2) & ~self.present
        if np.any(partial):
            raise InvalidBTF(f"{self.name}: {int(partial.sum())} (view, light) images are "
                             "partly NaN; a missing image must be NaN throughout")
        if not self.present.any():
            raise InvalidBTF(f"{self.name}: no (view, light) image holds data")
        negative = np.nanmin(self.values) if self.present.any() else 0.0
        if negative < 0.0:
            raise InvalidBTF(f"{self.name}: negative samples (minimum {negative:.4g}); a "
                             "reflectance factor cannot be negative")

    # ------------------------------------------------------------------ shape
    @property
    def spectral(self) -> bool:
        return self.wavelengths is not None

    @property
    def shape(self) -> tuple[int, int, int, int, int]:
        return tuple(self.values.shape)  # type: ignore[return-value]

    @property
    def texels(self) -> tuple[int, int]:
        return self.values.shape[2], self.values.shape[3]

    @property
    def nbytes(self) -> int:
        return int(self.values.nbytes)

    def channel_weights(self) -> np.ndarray:
        """(C,) weights giving luminance: ȳ·Δλ normalised to sum 1 (so a grey of
        reflectance r reads r), or Rec.709's Y row for RGB."""
        if not self.spectral:
            return REC709_Y.copy()
        y = spectra.cmfs(self.wavelengths)[:, 1] * spectra.sample_weights(self.wavelengths)
        return y / y.sum()

    def luminance(self) -> np.ndarray:
        """(V, L, H, W) float32 luminance of every sample (NaN where missing)."""
        return (self.values @ self.channel_weights().astype(np.float32)).astype(np.float32)

    def spectral_reflectance(self, wavelengths: np.ndarray | None = None) -> np.ndarray:
        """``values`` as reflectance spectra (:func:`reflectance_spectra`) on
        ``wavelengths`` (default: the reference 5 nm grid)."""
        return reflectance_spectra(self.values, self.wavelengths, wavelengths)

    def subset(self, *, views=None, lights=None, texels: tuple[slice, slice] | None = None
               ) -> BTF:
        """A copy restricted to view and light indices and a texel window."""
        vi = np.arange(len(self.views)) if views is None else np.asarray(views)
        li = np.arange(len(self.lights)) if lights is None else np.asarray(lights)
        ys, xs = texels or (slice(None), slice(None))
        values = self.values[vi][:, li][:, :, ys, xs]
        return BTF(np.ascontiguousarray(values), self.views[vi], self.lights[li],
                   self.wavelengths, self.name)


def reflectance_spectra(values: np.ndarray, wavelengths: np.ndarray | None,
                        target: np.ndarray | None = None) -> np.ndarray:
    """Samples (…, C) as reflectance spectra (…, len(target)) on ``target`` (default: the
    reference 5 nm grid): linear interpolation when ``wavelengths`` (C,) are given (end
    values held, not zero), the Smits (1999) uplift of linear Rec.709 RGB when None.
    Samples with NaN stay NaN."""
    wl = spectra.WAVELENGTHS_REFERENCE if target is None else spectra.check_wavelengths(target)
    values = np.asarray(values)
    flat = values.reshape(-1, values.shape[-1]).astype(np.float64)
    if wavelengths is not None:
        out = flat @ _interpolation_matrix(np.asarray(wavelengths, np.float64), wl)
    else:
        from ..colour.uplift import SmitsUplift

        uplift = SmitsUplift()
        out = np.full((len(flat), len(wl)), np.nan)
        ok = np.isfinite(flat).all(axis=1)
        out[ok] = uplift.weights(flat[ok]) @ uplift.basis(wl)
    return out.reshape(*values.shape[:-1], len(wl))


def _interpolation_matrix(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(len(source), len(target)) linear interpolation (end values held)."""
    eye = np.eye(len(source))
    return np.stack([np.interp(target, source, row) for row in eye], axis=0)


def btf_from_ubo(ubo, *, texels: tuple[slice, slice] | None = None,
                 name: str | None = None) -> BTF:
    """A :class:`BTF` from a UBO2003 (:class:`~formats.ubo_btf.UBOBTF`, linear images
    expected: read it with ``linear=True``) or UBO2014 archive, optionally cropped to a
    texel window (UBO2014 images are decoded one (view, light) pair at a time)."""
    ys, xs = texels or (slice(None), slice(None))
    if hasattr(ubo, "images"):
        if getattr(ubo, "encoding", "linear") != "linear":
            raise InvalidBTF(f"{ubo.path}: the images are display-encoded; read the archive "
                             "with linear=True so that values are proportional to radiance")
        values = np.ascontiguousarray(ubo.images[:, :, ys, xs])
    else:
        first = ubo.lookup(0, 0)[ys, xs]
        values = np.empty((ubo.view_count, ubo.light_count, *first.shape), np.float32)
        for v in range(ubo.view_count):
            for li in range(ubo.light_count):
                values[v, li] = ubo.lookup(v, li)[ys, xs]
    if values.shape[-1] != 3:
        raise InvalidBTF(f"{ubo.path}: {values.shape[-1]} channels; only RGB UBO data is "
                         "supported")
    return BTF(np.maximum(values, 0.0, where=np.isfinite(values), out=values),
               ubo.view_directions, ubo.light_directions, None,
               name or getattr(ubo.path, "stem", "UBO BTF"))


# ----------------------------------------------------------------- triangulation


def hemisphere_plane(directions: np.ndarray) -> np.ndarray:
    """Azimuthal equidistant projection of unit directions to the unit disc:
    ``θ/(π/2) · (cos φ, sin φ)``. The pole maps to the centre, the horizon to the
    circle; its Delaunay triangulation gives the hemisphere's triangle topology."""
    d = np.asarray(directions, dtype=np.float64)
    rho = np.hypot(d[..., 0], d[..., 1])
    theta = np.arctan2(rho, d[..., 2])
    scale = np.where(rho > 1e-15, theta / (0.5 * np.pi) / np.maximum(rho, 1e-300), 0.0)
    return np.stack([d[..., 0] * scale, d[..., 1] * scale], axis=-1)


@dataclass
class HemisphereTriangulation:
    """Barycentric interpolation between direction samples on the hemisphere.

    Topology: Delaunay triangles of the directions' :func:`hemisphere_plane` images.
    Weights: for a triangle of unit vectors (a, b, c) and a direction d, ``w = M⁻¹ d``
    with ``M = [a b c]``, normalised to sum 1 — the barycentric coordinates of the point
    where the ray d meets the triangle's plane (the spherical triangle's gnomonic
    barycentrics), so a measured direction gets weight 1 exactly.

    Finding the triangle: the disc is cut into ``grid × grid`` cells, each listing the
    triangles whose planar image overlaps it (a point's own triangle is always among its
    cell's; the one holding the cell's centre first). The first candidate whose weights
    are all ≥ −``EPS`` is taken; outside the samples' hull (for instance a view beyond
    the last ring), the candidate with the largest smallest weight is taken and its
    negative weights are clamped to 0 and renormalised. The GLSL mirror
    (``glsl/btf/btf_views.glsl``) does exactly this with the tables :meth:`cell_table` and
    :meth:`triangle_table`.
    """

    directions: np.ndarray
    grid: int = 32
    triangles: np.ndarray = field(init=False)        # (T, 3) int
    inverses: np.ndarray = field(init=False)         # (T, 3, 3)
    cell_start: np.ndarray = field(init=False)       # (grid, grid) int: into candidates
    cell_count: np.ndarray = field(init=False)       # (grid, grid) int
    candidates: np.ndarray = field(init=False)       # (K,) int triangle indices

    EPS = 1e-6
    #: Candidate-list texture width (glsl/btf/btf_views.glsl reads entry i at (i % W, i / W)).
    LIST_WIDTH = 1024

    def __post_init__(self) -> None:
        from scipy.spatial import Delaunay

        d = _unit_directions(self.directions, "interpolated")
        self.directions = d
        if len(d) < 3:
            raise InvalidBTF(f"need at least 3 directions to interpolate between, got {len(d)}")
        plane = hemisphere_plane(d)
        try:
            tri = Delaunay(plane)
        except Exception as exc:  # QhullError: collinear or duplicate directions
            raise InvalidBTF(f"the {len(d)} directions do not span the hemisphere "
                             f"(they are collinear or repeated): {exc}") from None
        triangles = tri.simplices.astype(np.int64)
        m = np.transpose(d[triangles], (0, 2, 1))          # columns a, b, c
        det = np.linalg.det(m)
        keep = np.abs(det) > 1e-12                          # drop slivers on great circles
        self.triangles = triangles[keep]
        self.inverses = np.linalg.inv(m[keep])
        self._cell_candidates(plane)

    def _cell_candidates(self, plane: np.ndarray) -> None:
        g = self.grid
        corners = plane[self.triangles]                      # (T, 3, 2)
        lo = np.clip(np.floor((corners.min(axis=1) + 1.0) * 0.5 * g).astype(int), 0, g - 1)
        hi = np.clip(np.floor((corners.max(axis=1) + 1.0) * 0.5 * g).astype(int), 0, g - 1)
        centres = (np.arange(g) + 0.5) / g * 2.0 - 1.0
        lists: dict[tuple[int, int], list] = {}
        for t in range(len(self.triangles)):
            for iy in range(lo[t, 1], hi[t, 1] + 1):
                for ix in range(lo[t, 0], hi[t, 0] + 1):
                    if _triangle_meets_cell(corners[t], centres[ix], centres[iy], 1.0 / g):
                        inside = _planar_inside(corners[t], centres[ix], centres[iy])
                        lists.setdefault((iy, ix), []).append((0 if inside else 1, t))
        # Cells outside the hull (near the horizon): the nearest triangles by centroid.
        centroid = corners.mean(axis=1)
        for iy in range(g):
            for ix in range(g):
                if (iy, ix) not in lists:
                    dist = np.linalg.norm(centroid - [centres[ix], centres[iy]], axis=1)
                    lists[(iy, ix)] = [(0, int(t)) for t in np.argsort(dist)[:4]]
        self.cell_start = np.zeros((g, g), np.int64)
        self.cell_count = np.zeros((g, g), np.int64)
        flat = []
        for iy in range(g):
            for ix in range(g):
                entries = [t for _, t in sorted(lists[(iy, ix)])]
                self.cell_start[iy, ix] = len(flat)
                self.cell_count[iy, ix] = len(entries)
                flat += entries
        self.candidates = np.asarray(flat, np.int64)

    def cell_of(self, directions: np.ndarray) -> np.ndarray:
        """(N, 2) integer (ix, iy) lookup cells of directions."""
        p = hemisphere_plane(directions)
        return np.clip(np.floor((p + 1.0) * 0.5 * self.grid), 0, self.grid - 1).astype(int)

    def weights(self, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(indices (N, 3) int, weights (N, 3)) of the samples interpolating each direction.

        Directions below the horizon are lifted onto it first (z clamped to 0).
        Weights are ≥ 0 and sum to 1.
        """
        d = np.asarray(directions, dtype=np.float64).reshape(-1, 3).copy()
        d[:, 2] = np.maximum(d[:, 2], 0.0)
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        d = np.where(norm > 1e-12, d / np.maximum(norm, 1e-300), [0.0, 0.0, 1.0])
        cell = self.cell_of(d)
        start = self.cell_start[cell[:, 1], cell[:, 0]]
        count = self.cell_count[cell[:, 1], cell[:, 0]]
        best_w = np.zeros((len(d), 3))
        best_t = np.zeros(len(d), dtype=np.int64)
        best_score = np.full(len(d), -np.inf)
        done = np.zeros(len(d), dtype=bool)
        for k in range(int(count.max(initial=0))):
            valid = (k < count) & ~done
            tk = self.candidates[np.where(valid, start + k, 0)]
            w = np.einsum("nij,nj->ni", self.inverses[tk], d)
            s = w.sum(axis=1, keepdims=True)
            w = w / np.where(np.abs(s) > 1e-300, s, 1.0)
            score = np.where(s[:, 0] > 0, w.min(axis=1), -np.inf)
            better = valid & (score > best_score)
            best_w[better], best_t[better], best_score[better] = w[better], tk[better], \
                score[better]
            done |= valid & (score >= -self.EPS)
        w = np.maximum(best_w, 0.0)
        w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
        return self.triangles[best_t], w

    # ------------------------------------------------------------ GPU tables
    def cell_table(self) -> np.ndarray:
        """(grid, grid, 4) float32: (first entry in the candidate list, entry count, 0, 0)
        of each cell (exact as float below 2²⁴)."""
        out = np.zeros((self.grid, self.grid, 4), np.float32)
        out[..., 0] = self.cell_start
        out[..., 1] = self.cell_count
        return out

    def candidate_table(self) -> np.ndarray:
        """(rows, LIST_WIDTH, 4) float32: candidate triangle indices in x, entry i at texel
        (i % LIST_WIDTH, i // LIST_WIDTH)."""
        n = len(self.candidates)
        out = np.zeros((-(-n // self.LIST_WIDTH) * self.LIST_WIDTH, 4), np.float32)
        out[:n, 0] = self.candidates
        return out.reshape(-1, self.LIST_WIDTH, 4)

    def triangle_table(self) -> np.ndarray:
        """(T, 3, 4) float32: row r of M⁻¹ in xyz and the triangle's r-th sample in w."""
        out = np.empty((len(self.triangles), 3, 4), dtype=np.float32)
        out[:, :, :3] = self.inverses
        out[:, :, 3] = self.triangles
        return out


def _planar_inside(tri: np.ndarray, x: float, y: float) -> bool:
    a, b, c = tri
    m = np.array([[b[0] - a[0], c[0] - a[0]], [b[1] - a[1], c[1] - a[1]]])
    if abs(np.linalg.det(m)) < 1e-15:
        return False
    u, v = np.linalg.solve(m, [x - a[0], y - a[1]])
    return u >= -1e-9 and v >= -1e-9 and u + v <= 1 + 1e-9


def _triangle_meets_cell(tri: np.ndarray, cx: float, cy: float, half: float) -> bool:
    """Separating-axis test of a triangle against an axis-aligned square (slightly
    enlarged, so that points on shared edges find both neighbours)."""
    half = half * (1.0 + 1e-6) + 1e-9
    lo = np.array([cx - half, cy - half])
    hi = np.array([cx + half, cy + half])
    if np.any(tri.max(axis=0) < lo) or np.any(tri.min(axis=0) > hi):
        return False
    box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
    for i in range(3):
        e = tri[(i + 1) % 3] - tri[i]
        axis = np.array([-e[1], e[0]])
        pt = tri @ axis
        pb = box @ axis
        if pt.max() < pb.min() or pt.min() > pb.max():
            return False
    return True


def resample(btf: BTF, *, views: np.ndarray | None = None, lights: np.ndarray | None = None,
             grid: int = 32) -> BTF:
    """``btf`` on new view and/or light directions, barycentric over the hemisphere
    (:class:`HemisphereTriangulation`) in each. Samples of a missing (view, light) image
    are left out of the interpolation (the other weights renormalised; where all weighted
    samples are missing, the triangle's present samples are averaged); an output image
    with no data to draw on stays NaN."""
    out = btf
    for axis, target in ((0, views), (1, lights)):
        if target is None:
            continue
        source = out.views if axis == 0 else out.lights
        tri = HemisphereTriangulation(source, grid=grid)
        index, weight = tri.weights(_unit_directions(target, "target"))
        values = np.moveaxis(out.values, axis, 0)              # (S, other, H, W, C)
        present = np.isfinite(values.reshape(values.shape[0], values.shape[1], -1)[..., 0])
        filled = np.nan_to_num(values)
        result = np.zeros((len(index), *values.shape[1:]), np.float32)
        mass = np.zeros((len(index), values.shape[1]), np.float64)
        for k in range(3):
            w = weight[:, k][:, None] * present[index[:, k]]             # (N, other)
            result += (w[:, :, None, None, None] * filled[index[:, k]]).astype(np.float32)
            mass += w
        # Where the interpolating samples with weight are all missing (a missing sample
        # at the target itself), the triangle's present samples share equally.
        fallback = mass <= 1e-12
        if np.any(fallback):
            for k in range(3):
                w = fallback * present[index[:, k]]
                result += (w[:, :, None, None, None] * filled[index[:, k]]).astype(np.float32)
                mass += w
        ok = mass > 1e-12
        result /= np.where(ok, mass, 1.0)[:, :, None, None, None].astype(np.float32)
        result[~ok] = np.nan
        result = np.moveaxis(result, 0, axis)
        new_views = target if axis == 0 else out.views
        new_lights = target if axis == 1 else out.lights
        out = BTF(np.ascontiguousarray(result), new_views, new_lights, out.wavelengths,
                  out.name)
    return out
