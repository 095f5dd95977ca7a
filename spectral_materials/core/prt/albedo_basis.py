"""A texture basis for the spectral albedo layers: fewer values per texel, same colours.

The fragment stage of spectral PRT computes ``XYZ_c = Σ_j Ê_j R̃_jc(uv)`` over the ``3m``
values of R̃ per texel (:mod:`.albedo`). Most textures span far fewer dimensions than
``3m``: an RGB image uplifted with Smits (1999) is a mix of 7 spectra, so its texels lie
in a 7-dimensional subspace exactly, and measured reflectances are smooth (the 24
ColorChecker patches keep 12 singular values above 1e-4 of the first). With
``R̃(texel) = Σ_k w_k(texel) M_k`` (``r`` weights per texel and an ``r × m × 3`` mixing
array), the sum becomes

    XYZ_c = Σ_k w_k(uv) G_kc,   G_kc = Σ_j Ê_j M_kjc,

so the pixel reads ``⌈r/4⌉`` RGBA texels of weights instead of filtering ``⌈3m/4⌉``
layers of R̃ (3 instead of 6 at m = 8 for the chart, 2 for an RGB image). The texture
unit filters the weights (:meth:`AlbedoBasis.weights_padded`); its 8-bit filter weights
are what ``albedo.sample_layers(..., weight_bits=8)`` models.

The basis is the principal subspace of the texels' R̃ vectors (the eigenvectors of their
``3m × 3m`` Gram matrix, so memory stays one texel block at a time), truncated where
the discarded energy falls below ``tolerance`` of the whole (relative Frobenius norm).
:func:`choose_albedo_basis` then checks the colours: it adds layers of weights until no
texel moves by more than ΔE94 0.05 against the layers under D65, FL11 and A.
Bilinear filtering commutes with the change of basis, so filtering the weights equals
filtering the reconstructed layers.

References
----------
Schwenk, K. et al. (2010). Adapting precomputed radiance transfer to real-time spectral
rendering. Eurographics 2010 short papers, §3.4 (the albedo texture array).
Smits, B. (1999). An RGB-to-spectrum conversion for reflectances. J. Graphics Tools 4(4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .albedo import TEXELS_PER_BLOCK, AlbedoLayers, packed_layer_count, wrap_padded
from .albedo_colour import COLOUR_BOUND_DE94, layers_colour_error

#: Relative Frobenius error of the truncated layers against the full ones. At m = 8 it
#: keeps 12 of the ColorChecker chart's 24 values per texel and all 7 dimensions of a
#: Smits-uplifted image (benchmarks/prt.py states the colour error).
DEFAULT_TOLERANCE = 1e-4
#: Most weights per texel the shader reads (four RGBA layers).
MAX_RANK = 16


@dataclass
class AlbedoBasis:
    """Albedo layers as ``r`` weights per texel and a mixing array.

    Attributes
    ----------
    weights : ndarray (r, H, W) float32
        The texels' coordinates in the basis; row 0 is the bottom, as the layers'.
    mixing : ndarray (r, m, 3) float32
        ``R̃_jc(texel) = Σ_k weights[k, texel] · mixing[k, j, c]``.
    error : float
        Largest ``|R̃ − reconstruction|`` over the texels and values, relative to the
        largest ``|R̃|``.
    delta_e94 : float or None
        Largest ΔE94 against the layers (:func:`colour_error`), where it was measured.
    """

    weights: np.ndarray
    mixing: np.ndarray
    error: float
    delta_e94: float | None = None

    @property
    def rank(self) -> int:
        return int(self.weights.shape[0])

    @property
    def weight_layers(self) -> int:
        """RGBA layers of the weights texture: four weights to a texel."""
        return -(-self.rank // 4)

    def layers(self) -> np.ndarray:
        """The R̃ layers (m, H, W, 3) the basis draws: the weights times the mixing."""
        r, h, w = self.weights.shape
        flat = self.weights.reshape(r, -1).T.astype(np.float64)
        out = flat @ self.mixing.reshape(r, -1).astype(np.float64)
        m = self.mixing.shape[1]
        return out.reshape(h, w, m, 3).transpose(2, 0, 1, 3).astype(np.float32)

    def weights_rgba(self) -> np.ndarray:
        """(⌈r/4⌉, H, W, 4) texels: weight ``k`` is component ``k % 4`` of layer ``k // 4``;
        the padding weights are 0."""
        r, h, w = self.weights.shape
        out = np.zeros((self.weight_layers * 4, h, w), dtype=np.float32)
        out[:r] = self.weights
        return np.ascontiguousarray(out.reshape(self.weight_layers, 4, h, w)
                                    .transpose(0, 2, 3, 1))

    def weights_padded(self) -> np.ndarray:
        """(⌈r/4⌉, H + 2, W + 2, 4): :meth:`weights_rgba` wrap-padded for the texture unit
        (:func:`.albedo.wrap_padded`)."""
        return wrap_padded(self.weights_rgba())


@dataclass
class _PrincipalAxes:
    """A texture's R̃ vectors as rows (texels, 3m) and the eigen-decomposition of their
    Gram matrix, largest first: computed once, truncated at any rank."""

    flat: np.ndarray
    shape: tuple[int, int, int]        # m, H, W
    energy: np.ndarray
    vectors: np.ndarray


def _principal_axes(layers: np.ndarray) -> _PrincipalAxes:
    layers = np.asarray(layers)
    if layers.ndim != 4 or layers.shape[3] != 3 or min(layers.shape) < 1:
        raise ValueError(f"albedo layers must be (m, H, W, 3), got {layers.shape}")
    m, h, w, _ = layers.shape
    flat = layers.transpose(1, 2, 0, 3).reshape(h * w, 3 * m)
    if not np.isfinite(flat).all():
        raise ValueError("albedo layers hold non-finite (NaN/inf) values")
    gram = np.zeros((3 * m, 3 * m))
    for begin in range(0, h * w, TEXELS_PER_BLOCK):
        block = flat[begin:begin + TEXELS_PER_BLOCK].astype(np.float64)
        gram += block.T @ block
    energy, vectors = np.linalg.eigh(gram)
    return _PrincipalAxes(flat, (m, h, w), np.clip(energy[::-1], 0.0, None), vectors[:, ::-1])


def _truncated(axes: _PrincipalAxes, tolerance: float, rank: int | None) -> AlbedoBasis:
    """The basis of ``axes`` in the fewest RGBA layers within ``tolerance`` and holding at
    least ``rank`` weights (:func:`albedo_to_basis`)."""
    tolerance = float(tolerance)
    if not 0.0 <= tolerance < 1.0:
        raise ValueError(f"tolerance must be in [0, 1), got {tolerance!r}")
    m, h, w = axes.shape
    if rank is not None and (isinstance(rank, bool) or not 1 <= int(rank) <= 3 * m):
        raise ValueError(f"rank must be 1..{3 * m}, got {rank!r}")
    least = 1 if rank is None else int(rank)
    total = float(axes.energy.sum())
    if total == 0.0:
        rank = 1
    else:
        # tail[i]: the share of the norm (√ of the energy's) left out by the first i + 1.
        tail = np.sqrt(np.clip(1.0 - np.cumsum(axes.energy) / total, 0.0, None))
        floor = max(tolerance, 64 * np.finfo(np.float32).eps)
        rank = int(np.argmax(tail <= floor)) + 1
    # The shader reads four weights per fetch: the rest of the last layer costs nothing.
    rank = min(-(-max(rank, least) // 4) * 4, 3 * m)
    basis = axes.vectors[:, :rank]
    # A deterministic sign: each vector's largest component positive.
    basis = basis * np.where(basis[np.abs(basis).argmax(axis=0), range(rank)] < 0, -1.0, 1.0)
    drawn = basis.astype(np.float32).astype(np.float64)      # the mixing as stored
    weights = np.empty((h * w, rank), dtype=np.float32)
    worst = 0.0
    for begin in range(0, h * w, TEXELS_PER_BLOCK):
        block = axes.flat[begin:begin + TEXELS_PER_BLOCK].astype(np.float64)
        coords = block @ basis
        weights[begin:begin + TEXELS_PER_BLOCK] = coords
        rebuilt = coords.astype(np.float32).astype(np.float64) @ drawn.T
        worst = max(worst, float(np.abs(rebuilt - block).max()))
    scale = float(np.abs(axes.flat).max())
    return AlbedoBasis(
        weights=np.ascontiguousarray(weights.T.reshape(rank, h, w)),
        mixing=np.ascontiguousarray(drawn.T.reshape(rank, m, 3).astype(np.float32)),
        error=worst / scale if scale > 0 else 0.0)


def albedo_to_basis(layers: np.ndarray, tolerance: float = DEFAULT_TOLERANCE,
                    rank: int | None = None) -> AlbedoBasis:
    """The texture basis of ``layers`` (m, H, W, 3) in the fewest RGBA layers of weights
    within ``tolerance``; the last layer is filled with the next vectors, at no cost.

    Parameters
    ----------
    layers : array (m, H, W, 3)
        R̃ layers (``AlbedoLayers.layers``), finite.
    tolerance : float
        In [0, 1): the discarded share of the layers' Frobenius norm. 0 keeps the
        numerical rank (float32 rounding).
    rank : int, optional
        At least this many weights (1 … 3m), whatever the tolerance.

    Returns
    -------
    AlbedoBasis
        With at least one weight; ``error`` states the largest value error it makes.
    """
    return _truncated(_principal_axes(layers), tolerance, rank)


def saves_fetches(basis: AlbedoBasis, coefficients: int) -> bool:
    """Whether drawing ``basis`` reads fewer albedo layers per pixel than the packed R̃
    layers of ``coefficients`` spectral coefficients, within :data:`MAX_RANK`."""
    return basis.rank <= MAX_RANK and basis.weight_layers < packed_layer_count(coefficients)


def colour_error(albedo: AlbedoLayers, basis: AlbedoBasis,
                 lights: tuple[np.ndarray, ...] = ()) -> float:
    """Largest ΔE94 over the texels between ``albedo``'s layers and the layers ``basis``
    draws, under D65, FL11, A and ``lights`` (:func:`.albedo_colour.layers_colour_error`)."""
    return layers_colour_error(albedo, basis.layers(), lights=lights)


def choose_albedo_basis(albedo: AlbedoLayers, bound: float = COLOUR_BOUND_DE94,
                        tolerance: float = DEFAULT_TOLERANCE,
                        lights: tuple[np.ndarray, ...] = ()) -> AlbedoBasis | None:
    """The basis the draw uses for ``albedo``: :func:`albedo_to_basis` at ``tolerance``,
    grown a layer of weights at a time until its :func:`colour_error` (under ``lights``
    too) is within ``bound``; None where no basis that reads fewer layers than the packed
    R̃ is."""
    m = albedo.count
    axes = _principal_axes(albedo.layers)      # one pass over the texels for every rank
    basis = _truncated(axes, tolerance, None)
    while saves_fetches(basis, m):
        basis.delta_e94 = colour_error(albedo, basis, lights)
        if basis.delta_e94 <= bound:
            return basis
        basis = _truncated(axes, tolerance, min(basis.rank + 4, 3 * m))
    return None
