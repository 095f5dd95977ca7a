"""Drawing a reflectance-field BTF: the GPU layout and its exact Python mirror.

Meseth, Müller, Klein (2003) §5.1: for a point with texture coordinate x, local light
direction l and local view direction v,

    L_r = Σ_lights E · Σ_{v' ∈ N(v)} w_{v'}(v) · RF_{v'}(x, l),

with N(v) the three measured views around v and w their barycentric weights
(:class:`~spectral_materials.core.btf.container.HemisphereTriangulation`). RF_{v'} is the fitted
luminance (``RFP`` biquadratic polynomial or ``RFNL`` lobes, see ``btf_fit``); colour
comes from a per-texel spectral albedo (luminance 1) as in the paper (after PTM). The
BTF's values include foreshortening, so no further ``n·l`` multiplies RF (the paper's
eq. 4 writes one for data without it). In XYZ, with the protocol's light weights W:

    XYZ = Σ_lights E · (Σ_{v'} w_{v'} RF_{v'}) / π · Σ_j c_j(x) Ĩ_j,    Ĩ = Ψᵀ W,

``c(x)`` the albedo's coefficients on an orthonormal basis Ψ (5 nm, 380–780 nm) fitted
to the texels' albedo spectra.

GPU layout (:class:`DrawableBTF`, ``glsl/btf/btf_frag.glsl``)
---------------------------------------------------------
One RGBA32F 2D-array texture of *records*: a record is one W × H RGBA image. Records
``0 … A−1`` hold the albedo coefficients (4 per record), then view ``v`` holds records
``A + v·R … A + v·R + R − 1`` (``R = P/4`` for P parameters per texel). When there are
more records than the GPU's array layers, several records share a layer as tiles:
``K = ⌈records / max_layers⌉`` tiles per layer in ``columns`` tile columns; record r lies
in layer ``r // K``, tile ``r % K`` at texel offset ``((t % columns)·W, (t // columns)·H)``.
Texels are fetched unfiltered (nearest, repeat): fitted parameters are not linear in the
appearance, so they are not interpolated.

Parameters per texel and view (float32, 4-aligned):

* ``RFP`` (P = 8): a0 … a5 of ``Y = a0 lu² + a1 lv² + a2 lu lv + a3 lu + a4 lv + a5``
  with (lu, lv) = (l.x, l.y), then 2 zeros.
* ``RFNL`` with k ≤ 3 lobes (P = 4 + 4k): (ρd, a_1 … a_k, 0 …), then per lobe
  (t̂_x, t̂_y, t̂_z, n): ``Y = ρd + Σ_j a_j · max(t̂_j·l, 0)^{n_j}``. With unit t̂ the power
  is ≤ 1 and ``a_j ≤`` :data:`AMPLITUDE_MAX`, so nothing overflows float32 or float16
  (the paper's white pixels came from ``(t·l)^n`` with long t and large n).

Y is clamped at 0 (a polynomial can dip below) and is 0 for lights below the surface.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..brdf.shading import light_rows, xyz_texels
from ..colour import spectra
from ..lights import SpectralLight
from .container import HemisphereTriangulation
from .fit import rfp_basis
from .lm import A_MAX, N_MAX, N_MIN  # noqa: F401  (re-exported bounds)

KINDS = ("RFP", "RFNL")
#: Width, in texels, of the band along each texel edge where a texel's shading blends with
#: its neighbour's (:meth:`DrawableBTF.texel_blend`): 0.5 at the edge, the texel alone
#: from this far inside. Nearest-texel picking jumps where a float32 UV sits on an edge,
#: so two GPUs (or the GPU and this mirror) could pick different texels there; the band
#: makes the picture continuous (issue 19) at the cost of shading two or four texels in
#: ``2ε − ε²`` of the texel's area per axis pair (about 23 % at 1/16).
EDGE_BLEND = 1.0 / 16.0
#: Largest lobe amplitude stored, and the lobe exponents' range: the fit's bounds
#: (``btf_lm``), so a fitted model is drawn as fitted.
AMPLITUDE_MAX = A_MAX
#: Spectral coefficients per texel at most (two records).
MAX_COEFFICIENTS = 8
#: Reference grid of the albedo spectra and of the light weights.
WAVELENGTHS = spectra.WAVELENGTHS_REFERENCE


def parameter_count(kind: str, lobes: int = 0) -> int:
    if kind == "RFP":
        return 8
    if kind == "RFNL":
        if not 1 <= lobes <= 3:
            raise ValueError(f"RFNL draws 1..3 lobes per view, got {lobes}")
        return 4 + 4 * lobes
    raise ValueError(f"unknown reflectance-field kind {kind!r}; valid: {KINDS}")


@dataclass(frozen=True)
class TileLayout:
    """Where record r lies in the array texture (see the module docstring)."""

    width: int
    height: int
    records: int
    tiles_per_layer: int
    columns: int

    @classmethod
    def plan(cls, width: int, height: int, records: int, *, max_layers: int = 2048,
             max_size: int = 16384) -> TileLayout:
        if width > max_size or height > max_size:
            raise ValueError(f"BTF texels {width} × {height} exceed the GPU's texture size "
                             f"{max_size}")
        k = -(-records // max_layers)
        columns = max(1, min(k, max_size // width))
        if -(-k // columns) * height > max_size:
            raise ValueError(f"{records} records of {width} × {height} texels do not fit "
                             f"the GPU's {max_layers} layers of {max_size}² texels; use "
                             "fewer views or texels")
        return cls(width, height, records, k, columns)

    @property
    def layers(self) -> int:
        return -(-self.records // self.tiles_per_layer)

    @property
    def rows(self) -> int:
        return -(-self.tiles_per_layer // self.columns)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of one layer."""
        return self.columns * self.width, self.rows * self.height

    def locate(self, record: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(layer, x offset, y offset) of records."""
        r = np.asarray(record)
        tile = r % self.tiles_per_layer
        return r // self.tiles_per_layer, (tile % self.columns) * self.width, \
            (tile // self.columns) * self.height


@dataclass
class DrawableBTF:
    """A reflectance-field BTF ready to draw.

    Attributes
    ----------
    kind : "RFP" or "RFNL"
    lobes : int
        RFNL lobes (0 for RFP).
    views : ndarray (V, 3)
        The fitted views' directions (local frame).
    params : ndarray (V, H, W, P) float32
        Per view and texel (layout in the module docstring); row 0 is v = 0 of the
        texture (the bottom, Blender's convention), column 0 is u = 0.
    coefficients : ndarray (H, W, m) float32
        The albedo on ``basis``.
    basis : ndarray (len(WAVELENGTHS), m)
        Orthonormal columns.
    name : str
    """

    kind: str
    lobes: int
    views: np.ndarray
    params: np.ndarray
    coefficients: np.ndarray
    basis: np.ndarray
    name: str = "BTF"
    triangulation: HemisphereTriangulation = field(init=False, repr=False)

    def __post_init__(self) -> None:
        p = parameter_count(self.kind, self.lobes)
        self.params = np.ascontiguousarray(self.params, dtype=np.float32)
        if self.params.ndim != 4 or self.params.shape[3] != p or \
                self.params.shape[0] != len(self.views):
            raise ValueError(f"{self.name}: {self.kind} params must be (views={len(self.views)}"
                             f", H, W, {p}), got {self.params.shape}")
        if not np.isfinite(self.params).all():
            raise ValueError(f"{self.name}: non-finite reflectance-field parameters")
        self.coefficients = np.ascontiguousarray(self.coefficients, dtype=np.float32)
        if self.coefficients.shape[:2] != self.params.shape[1:3]:
            raise ValueError(f"{self.name}: albedo texels {self.coefficients.shape[:2]} differ "
                             f"from the parameters' {self.params.shape[1:3]}")
        m = self.coefficients.shape[2]
        if not 1 <= m <= MAX_COEFFICIENTS or self.basis.shape != (len(WAVELENGTHS), m):
            raise ValueError(f"{self.name}: need 1..{MAX_COEFFICIENTS} albedo coefficients on a "
                             f"({len(WAVELENGTHS)}, m) basis, got {self.coefficients.shape} "
                             f"and {self.basis.shape}")
        self.triangulation = HemisphereTriangulation(self.views)

    @property
    def texels(self) -> tuple[int, int]:
        """(H, W)."""
        return self.params.shape[1], self.params.shape[2]

    @property
    def records_per_view(self) -> int:
        return self.params.shape[3] // 4

    @property
    def albedo_records(self) -> int:
        return -(-self.coefficients.shape[2] // 4)

    @property
    def records(self) -> int:
        return self.albedo_records + len(self.views) * self.records_per_view

    @property
    def nbytes(self) -> int:
        """Bytes of the parameter and albedo records on the GPU (float32 RGBA)."""
        h, w = self.texels
        return self.records * h * w * 16

    def record_images(self) -> np.ndarray:
        """(records, H, W, 4) float32: albedo records, then each view's records."""
        h, w = self.texels
        out = np.zeros((self.records, h, w, 4), np.float32)
        m = self.coefficients.shape[2]
        padded = np.zeros((h, w, self.albedo_records * 4), np.float32)
        padded[..., :m] = self.coefficients
        out[: self.albedo_records] = padded.reshape(h, w, -1, 4).transpose(2, 0, 1, 3)
        per_view = self.params.reshape(len(self.views), h, w, self.records_per_view, 4)
        out[self.albedo_records:] = per_view.transpose(0, 3, 1, 2, 4).reshape(-1, h, w, 4)
        return out

    def layer_images(self, layout: TileLayout) -> np.ndarray:
        """(layers, layer height, layer width, 4): the records tiled as ``layout`` says."""
        h, w = self.texels
        width, height = layout.size
        out = np.zeros((layout.layers, height, width, 4), np.float32)
        layer, x0, y0 = layout.locate(np.arange(self.records))
        for r, image in enumerate(self.record_images()):
            out[layer[r], y0[r]: y0[r] + h, x0[r]: x0[r] + w] = image
        return out

    # ---------------------------------------------------------------- evaluation
    def texel_of(self, uv: np.ndarray, scale=(1.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
        """(row, column) of the nearest texel under repeat wrap, in float32 as the shader
        computes it: ``floor(fract(uv · scale) · (W, H))``, the first texel of
        :meth:`texel_blend`."""
        rows, cols, _ = self.texel_blend(uv, scale)
        return rows[..., 0], cols[..., 0]

    def texel_blend(self, uv: np.ndarray, scale=(1.0, 1.0)
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns and weights (N, 4) of the texels a point's shading blends, computed
        in float32 as the shader does (glsl/btf/btf_frag.glsl ``sm_btf_texel_blend``).

        Per axis, with ``s = fract(uv · scale) · size`` and ``g = s − ⌊s⌋``: the texel
        ``⌊s⌋`` alone where ``ε ≤ g ≤ 1 − ε`` (ε = :data:`EDGE_BLEND`); within ε of an
        edge, that texel with weight ``½ + ½·g/ε`` (or ``½ + ½·(1 − g)/ε``) and its
        neighbour across the edge (repeat wrap) with the rest. The four entries are
        (self, self), (neighbour, self), (self, neighbour), (neighbour, neighbour) in
        (column, row); weights sum to 1 and vary continuously with ``uv``.
        """
        h, w = self.texels
        st = np.asarray(uv, np.float32) * np.asarray(scale, np.float32)
        f = st - np.floor(st)
        eps = np.float32(EDGE_BLEND)
        half = np.float32(0.5)
        axes = []
        for k, size in ((0, w), (1, h)):
            s = f[..., k] * np.float32(size)
            i = np.clip(np.floor(s), 0, size - 1)
            g = s - i
            low, high = g < eps, g > np.float32(1.0) - eps
            own = np.where(low, half + half * g / eps,
                           np.where(high, half + half * (np.float32(1.0) - g) / eps,
                                    np.float32(1.0))).astype(np.float32)
            step = np.where(low, -1, np.where(high, 1, 0))
            index = i.astype(np.int64)
            axes.append((index, np.mod(index + step, size), own))
        (c0, c1, wc), (r0, r1, wr) = axes
        one = np.float32(1.0)
        rows = np.stack([r0, r0, r1, r1], axis=-1)
        cols = np.stack([c0, c1, c0, c1], axis=-1)
        weights = np.stack([wc * wr, (one - wc) * wr, wc * (one - wr), (one - wc) * (one - wr)],
                           axis=-1)
        return rows, cols, weights.astype(np.float64)

    def luminance(self, view: np.ndarray, row: np.ndarray, col: np.ndarray,
                  lights: np.ndarray) -> np.ndarray:
        """RF_view(texel, l) for arrays of view indices, texels and local light
        directions (N, 3); 0 where l.z ≤ 0."""
        p = self.params[view, row, col].astype(np.float64)
        l = np.asarray(lights, dtype=np.float64)
        if self.kind == "RFP":
            y = np.einsum("nk,nk->n", rfp_basis(l), p.reshape(-1, p.shape[-1])[:, :6]) \
                .reshape(p.shape[:-1])
        else:
            y = p[..., 0].copy()
            for j in range(self.lobes):
                lobe = p[..., 4 + 4 * j: 8 + 4 * j]
                c = np.maximum(np.einsum("...i,...i->...", lobe[..., :3], l), 0.0)
                y += p[..., 1 + j] * np.power(c, lobe[..., 3])
        return np.where(l[..., 2] > 0.0, np.maximum(y, 0.0), 0.0)

    def interpolated_luminance(self, row, col, lights: np.ndarray, views: np.ndarray
                               ) -> np.ndarray:
        """Σ_{v'} w_{v'}(v) RF_{v'}(texel, l): the view-interpolated luminance."""
        index, weight = self.triangulation.weights(np.asarray(views).reshape(-1, 3))
        out = np.zeros(len(index))
        for k in range(3):
            out += weight[:, k] * self.luminance(index[:, k], row, col, lights)
        return out

    def views_used(self, local_views: np.ndarray) -> np.ndarray:
        """Sorted indices of the measured views that get weight for these local view
        directions (N, 3): the records a scene seen only from there needs."""
        index, weight = self.triangulation.weights(np.asarray(local_views).reshape(-1, 3))
        return np.unique(index[weight > 0])

    def light_texels(self, lights: list[SpectralLight]) -> np.ndarray:
        """The light texture (lights, LIGHT_HEADER + m, 4): ``glsl/common/lights.glsl``'s header,
        then the light's XYZ weights Ĩ_j on the albedo basis."""
        return light_rows(lights, lambda light: xyz_texels(light.weights(WAVELENGTHS,
                                                                         self.basis)))

    def shade_xyz(self, uv: np.ndarray, frames: np.ndarray, points: np.ndarray,
                  toward_viewer: np.ndarray, lights: list[SpectralLight], *,
                  scale=(1.0, 1.0)) -> np.ndarray:
        """XYZ (N, 3) at surface points: ``frames`` (N, 3, 3) rows t, b, n (world), the
        world ``points`` (N, 3), unit ``toward_viewer`` (N, 3). Mirrors the shader."""
        rows, cols, blend = self.texel_blend(uv, scale)
        views = np.einsum("nij,nj->ni", frames, toward_viewer)
        xyz = np.zeros((len(rows), 3))
        for light in lights:
            wi, irradiance = light.incidence(points)
            local = np.einsum("nij,nj->ni", frames, wi)
            weights = light.weights(WAVELENGTHS, self.basis)              # (m, 3)
            for t in range(4):
                used = blend[:, t] > 0
                if not used.any():
                    continue
                row, col = rows[used, t], cols[used, t]
                coeff = self.coefficients[row, col].astype(np.float64)    # (n, m)
                y = self.interpolated_luminance(row, col, local[used], views[used])
                xyz[used] += (blend[used, t] * irradiance[used] * y / np.pi)[:, None] \
                    * (coeff @ weights)
        return xyz


def albedo_basis(albedo: np.ndarray, size: int = 6, *, tolerance: float = 1e-4
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(basis (L, m), coefficients (…, m)) of albedo spectra (…, L) on
    :data:`WAVELENGTHS`: the leading right singular vectors, as few as reach a relative
    residual of ``tolerance`` (at most ``size``)."""
    a = np.asarray(albedo, dtype=np.float64)
    flat = a.reshape(-1, a.shape[-1])
    if flat.shape[1] != len(WAVELENGTHS):
        raise ValueError(f"albedo spectra must be on the {len(WAVELENGTHS)}-sample reference "
                         f"grid, got {flat.shape[1]}")
    if not np.isfinite(flat).all():
        raise ValueError("albedo spectra hold NaN or inf")
    size = max(1, min(int(size), MAX_COEFFICIENTS, *flat.shape))
    _, s, vt = np.linalg.svd(flat, full_matrices=False)
    energy = np.cumsum(s[::-1] ** 2)[::-1]          # residual energy after keeping k - 1
    total = max(energy[0], 1e-300)
    m = size
    for k in range(1, size + 1):
        rest = energy[k] if k < len(energy) else 0.0
        if rest <= tolerance**2 * total:
            m = k
            break
    basis = vt[:m].T
    return basis, (flat @ basis).reshape(*a.shape[:-1], m)
