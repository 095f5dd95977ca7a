"""Which albedo texture spectral PRT draws: the fastest form within a colour bound.

Three forms hold an object's R̃ layers (:mod:`.albedo`), ``3m`` values per texel:

- ``"unorm16"``: the layers packed four values to a texel (``⌈3m/4⌉`` RGBA layers,
  :func:`.albedo.layers_to_rgba`) as 16-bit unsigned normalized integers over each
  layer component's own range (RGBA16), filtered by the texture unit and decoded in the
  shader (``low + span · t``, :func:`unorm16_texels`): ``⌈3m/4⌉`` fetches of 8 bytes and
  ``3m`` multiply-adds per pixel.
- ``"basis"``: ``r`` weights per texel in the texture's own basis (:mod:`.albedo_basis`),
  RGBA32F filtered by the texture unit, and ``3·r·m`` multiply-adds per pixel.
- ``"exact"``: the packed float32 layers filtered by hand (four ``texelFetch`` a layer).

On an NVIDIA H200 at m = 8 (512², the ColorChecker chart) the packed layers drew at
1.07 × RGB PRT as RGBA16 filtered by the texture unit, 1.88 × as RGBA32F filtered by it,
2.47 × filtered by hand; the basis at 1.73 × (``docs/bench_gpu.md``): the texture unit
filters a 16-byte texel at a fraction of an 8-byte one's rate, and the basis's
multiply-adds cost more than the fetches they save. ``"auto"`` takes the first form of
:data:`SPEED_ORDER` whose colours stay within ΔE94
:data:`.albedo_colour.COLOUR_BOUND_DE94` of the exact layers under D65, FL11, A and the
scene's own light (:func:`.albedo_colour.layers_colour_error`).

Why not half floats. RGBA16F draws as fast, but its 11 significant bits move a value by
up to 2⁻¹¹ of itself, and a* and b* weigh X/Y and Z/Y differences by 500/3 and 200/3:
the chart's texels moved by more than ΔE94 0.04 under each of D65, FL11, A, FL2 and FL4
(tests/core/prt/test_albedo_forms.py), against at most 0.01 as RGBA16. Storing the
first layer's rounding error in one more half layer fixed that on llvmpipe, but not on
the H200, whose texture unit returns filtered half texels at half precision: a smooth RGB
image drawn that way was ΔE94 0.028 / 0.065 / 0.31 (mean / p95 / max) from the exact
layers, against 0.0017 / 0.0047 / 0.107 as RGBA16 (the max is the exact layers' own, at
silhouettes; ``docs/bench_gpu.md``, "Albedo precisions"). 16 bits over each component's
range step by 1/65535 of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .albedo import AlbedoLayers, layers_to_rgba, rgba_to_layers, wrap_padded
from .albedo_basis import AlbedoBasis, choose_albedo_basis
from .albedo_colour import COLOUR_BOUND_DE94, layers_colour_error

ALBEDO_FORMS = ("auto", "unorm16", "basis", "exact")
#: Fastest first on a GPU (docs/bench_gpu.md): what ``"auto"`` tries in turn.
SPEED_ORDER = ("unorm16", "basis", "exact")
_UNORM_MAX = 65535.0


@dataclass
class Unorm16Layers:
    """The packed layers as a texture unit reads RGBA16: ``value = low + span · texel``.

    Attributes
    ----------
    texels : ndarray (⌈3m/4⌉, H, W, 4) float32
        ``k / 65535`` for integers ``k``: exact in unorm16, so the upload's conversion
        cannot round them differently from the mirror.
    low, span : ndarray (⌈3m/4⌉, 4) float32
        Per layer and component: the smallest value, and the range (1 where constant).
    """

    texels: np.ndarray
    low: np.ndarray
    span: np.ndarray

    def decoded(self) -> np.ndarray:
        """(⌈3m/4⌉, H, W, 4) float32: the values the shader forms from the texels."""
        return (self.low[:, None, None].astype(np.float64) + self.span[:, None, None]
                * self.texels.astype(np.float64)).astype(np.float32)

    def range_texels(self) -> np.ndarray:
        """(2·⌈3m/4⌉, 4) float32 for the uniform buffer ``sm_range``: texel ``2l`` is layer
        l's low, ``2l + 1`` its span (glsl/prt/prt_frag.glsl)."""
        return np.ascontiguousarray(np.stack([self.low, self.span], axis=1).reshape(-1, 4))


def unorm16_texels(layers: np.ndarray) -> Unorm16Layers:
    """The packed ``layers`` (m, H, W, 3) as RGBA16 over each layer component's range.

    Raises
    ------
    ValueError
        Non-finite values (with their count).
    """
    packed = layers_to_rgba(np.asarray(layers, dtype=np.float32)).astype(np.float64)
    bad = int(np.count_nonzero(~np.isfinite(packed)))
    if bad:
        raise ValueError(f"albedo layers hold {bad} non-finite (NaN/inf) values")
    low = packed.min(axis=(1, 2)).astype(np.float32)
    span = packed.max(axis=(1, 2)) - low
    if np.abs(span).max() > np.finfo(np.float32).max:
        raise ValueError("albedo layers span more than float32 holds")
    span = np.where(span > 0.0, span, 1.0).astype(np.float32)
    codes = np.rint((packed - low[:, None, None]) / span[:, None, None] * _UNORM_MAX)
    texels = (np.clip(codes, 0.0, _UNORM_MAX) / _UNORM_MAX).astype(np.float32)
    return Unorm16Layers(np.ascontiguousarray(texels), low, span)


@dataclass
class DrawnAlbedo:
    """The albedo texture a PRT object draws, and what it costs in colour.

    Attributes
    ----------
    form : str
        ``"unorm16"``, ``"basis"`` or ``"exact"``.
    layers : ndarray (m, H, W, 3) float32
        The R̃ values the texture holds, decoded, before filtering.
    basis : AlbedoBasis or None
        For ``"basis"``.
    unorm16 : Unorm16Layers or None
        For ``"unorm16"``.
    delta_e94 : float
        Largest ΔE94 over the texels against the exact layers (0 for ``"exact"``).
    """

    form: str
    layers: np.ndarray
    basis: AlbedoBasis | None = None
    unorm16: Unorm16Layers | None = None
    delta_e94: float = 0.0

    @property
    def filtered(self) -> bool:
        """Whether the texture unit filters the texture (wrap-padded, linear)."""
        return self.form != "exact"

    @property
    def texture_format(self) -> str:
        return "RGBA16" if self.form == "unorm16" else "RGBA32F"

    def texels(self) -> np.ndarray:
        """The texture array's (layers, H', W', 4) float32 texels, wrap-padded where the
        texture unit filters them (:func:`.albedo.wrap_padded`)."""
        if self.form == "basis":
            return self.basis.weights_padded()
        if self.form == "unorm16":
            return wrap_padded(self.unorm16.texels)
        return layers_to_rgba(self.layers)


def drawn_albedo(albedo: AlbedoLayers, form: str = "auto",
                 bound: float = COLOUR_BOUND_DE94,
                 lights: tuple[np.ndarray, ...] = ()) -> DrawnAlbedo:
    """The form ``albedo`` is drawn in.

    Parameters
    ----------
    albedo : AlbedoLayers
        Finite layers.
    form : str
        One of :data:`ALBEDO_FORMS`. ``"auto"``: the first of :data:`SPEED_ORDER` within
        ``bound``. ``"unorm16"`` is drawn whatever its error (stated in ``delta_e94``);
        ``"basis"`` falls back to the exact layers where no basis that reads fewer
        layers meets ``bound`` (:func:`.albedo_basis.choose_albedo_basis`).
    bound : float
        ΔE94 against the exact layers, per texel, under D65, FL11, A and ``lights``: the
        texels' values, not the texture unit's 8-bit filter weights (which move sharp
        edges by up to 1/256 of a texel on any filtered form).
    lights : tuple of ndarray (m,)
        More lights on the layers' spectral basis: the scene's own (the environment's
        mean radiance), whose spectrum decides how the coefficients' errors add up.

    Raises
    ------
    ValueError
        An unknown form, or non-finite layers.
    """
    if form not in ALBEDO_FORMS:
        raise ValueError(f"unknown albedo form {form!r}; expected one of {ALBEDO_FORMS}")
    if form == "exact":
        return DrawnAlbedo("exact", albedo.layers)
    if form in ("auto", "unorm16"):
        encoded = unorm16_texels(albedo.layers)
        drawn = rgba_to_layers(encoded.decoded(), albedo.count)
        error = layers_colour_error(albedo, drawn, lights=lights)
        if form == "unorm16" or error <= bound:
            return DrawnAlbedo("unorm16", np.ascontiguousarray(drawn), unorm16=encoded,
                               delta_e94=error)
    basis = choose_albedo_basis(albedo, bound=bound, lights=lights)
    if basis is None:
        return DrawnAlbedo("exact", albedo.layers)
    return DrawnAlbedo("basis", basis.layers(), basis, delta_e94=float(basis.delta_e94))
