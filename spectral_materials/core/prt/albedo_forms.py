"""Which albedo texture spectral PRT draws: the fastest form within a colour bound.

Three forms hold an object's R̃ layers (:mod:`.albedo`), ``3m`` values per texel:

- ``"half"``: the layers packed four values to a texel (``⌈3m/4⌉`` RGBA layers,
  :func:`.albedo.layers_to_rgba`) as half floats (RGBA16F) filtered by the texture unit,
  and one more layer holding what half rounded off the first (:func:`half_texels`):
  ``⌈3m/4⌉ + 1`` fetches of 8 bytes and ``3m + 4`` additions per pixel.
- ``"basis"``: ``r`` weights per texel in the texture's own basis (:mod:`.albedo_basis`),
  RGBA32F filtered by the texture unit, and ``3·r·m`` multiply-adds per pixel.
- ``"exact"``: the packed float32 layers filtered by hand (four ``texelFetch`` a layer).

On an NVIDIA H200 at m = 8 (512², the ColorChecker chart) the packed layers drew at
1.03 × RGB PRT as RGBA16F filtered by the texture unit, 1.88 × as RGBA32F filtered by it,
2.47 × filtered by hand; the basis at 1.73 × (``docs/bench_gpu.md``): the texture unit
filters a 16-byte texel at a fraction of an 8-byte one's rate, and the basis's
multiply-adds cost more than the fetches they save. ``"auto"`` takes the first form of
:data:`SPEED_ORDER` whose colours stay within ΔE94
:data:`.albedo_colour.COLOUR_BOUND_DE94` of the exact layers under D65, FL11 and A
(:func:`.albedo_colour.layers_colour_error`).

Why the first layer twice. Half floats keep 11 significant bits: each value moves by up
to 2⁻¹¹ of itself. The first spectral coefficient carries most of a colour, and a* and b*
weigh X/Y and Z/Y differences by 500/3 and 200/3, so rounding its X, Y, Z alone moved the
chart's white patch by ΔE94 0.07 under A. With that rounding error stored as a second
half (``hi + lo``, 22 bits), the chart's largest ΔE94 is 0.013 and a random RGB image's
0.026, under D65, FL11 and A. Filtering is linear, so the texture unit filtering both and
the shader adding them equals filtering their sum (with the same 8-bit weights).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .albedo import AlbedoLayers, layers_to_rgba, rgba_to_layers, wrap_padded
from .albedo_basis import AlbedoBasis, choose_albedo_basis
from .albedo_colour import COLOUR_BOUND_DE94, layers_colour_error

ALBEDO_FORMS = ("auto", "half", "basis", "exact")
#: Fastest first on a GPU (docs/bench_gpu.md): what ``"auto"`` tries in turn.
SPEED_ORDER = ("half", "basis", "exact")
#: The largest finite half float.
HALF_MAX = 65504.0


@dataclass
class DrawnAlbedo:
    """The albedo texture a PRT object draws, and what it costs in colour.

    Attributes
    ----------
    form : str
        ``"half"``, ``"basis"`` or ``"exact"``.
    layers : ndarray (m, H, W, 3) float32
        The R̃ values the texture holds, before filtering: the albedo's layers rounded to
        half for ``"half"``, the basis's reconstruction for ``"basis"``.
    basis : AlbedoBasis or None
        For ``"basis"``.
    delta_e94 : float
        Largest ΔE94 over the texels against the exact layers (0 for ``"exact"``).
    """

    form: str
    layers: np.ndarray
    basis: AlbedoBasis | None = None
    delta_e94: float = 0.0
    #: For ``"half"``: the (⌈3m/4⌉ + 1, H, W, 4) texels of :func:`half_texels`.
    packed: np.ndarray | None = None

    @property
    def filtered(self) -> bool:
        """Whether the texture unit filters the texture (wrap-padded, linear)."""
        return self.form != "exact"

    @property
    def texture_format(self) -> str:
        return "RGBA16F" if self.form == "half" else "RGBA32F"

    def texels(self) -> np.ndarray:
        """The texture array's (layers, H', W', 4) float32 texels, wrap-padded where the
        texture unit filters them (:func:`.albedo.wrap_padded`); half values are exact in
        float32, so the upload's conversion cannot round them differently."""
        if self.form == "basis":
            return self.basis.weights_padded()
        if self.form == "half":
            return wrap_padded(self.packed)
        return layers_to_rgba(self.layers)


def half_texels(layers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The packed layers as half floats, and the R̃ values they draw.

    Returns
    -------
    texels : ndarray (⌈3m/4⌉ + 1, H, W, 4) float32
        :func:`.albedo.layers_to_rgba` rounded to the nearest half (ties to even), then
        the first layer's rounding error, rounded to half: the shader adds the last layer
        to the first. Every value is exact in half.
    drawn : ndarray (m, H, W, 3) float32
        The layers those texels hold (the first layer as its two halves' sum).

    Raises
    ------
    ValueError
        Non-finite values, or values beyond half's range (±65504), with their count.
    """
    layers = np.asarray(layers, dtype=np.float32)
    bad = int(np.count_nonzero(~np.isfinite(layers)))
    if bad:
        raise ValueError(f"albedo layers hold {bad} non-finite (NaN/inf) values")
    beyond = int(np.count_nonzero(np.abs(layers) > HALF_MAX))
    if beyond:
        raise ValueError(f"{beyond} albedo values exceed half float's range (±{HALF_MAX:g})")
    packed = layers_to_rgba(layers)
    high = packed.astype(np.float16).astype(np.float32)
    low = (packed[:1].astype(np.float64) - high[:1]).astype(np.float16).astype(np.float32)
    drawn = high.copy()
    drawn[0] = (high[0].astype(np.float64) + low[0]).astype(np.float32)
    texels = np.ascontiguousarray(np.concatenate([high, low]))
    return texels, rgba_to_layers(drawn, layers.shape[0]).astype(np.float32)


def drawn_albedo(albedo: AlbedoLayers, form: str = "auto",
                 bound: float = COLOUR_BOUND_DE94) -> DrawnAlbedo:
    """The form ``albedo`` is drawn in.

    Parameters
    ----------
    albedo : AlbedoLayers
        Finite layers.
    form : str
        One of :data:`ALBEDO_FORMS`. ``"auto"``: the first of :data:`SPEED_ORDER` within
        ``bound``. ``"half"`` is drawn whatever its error (stated in ``delta_e94``);
        ``"basis"`` falls back to the exact layers where no basis that reads fewer
        layers meets ``bound`` (:func:`.albedo_basis.choose_albedo_basis`).
    bound : float
        ΔE94 against the exact layers, per texel, under D65, FL11 and A.

    Raises
    ------
    ValueError
        An unknown form, or non-finite layers.
    """
    if form not in ALBEDO_FORMS:
        raise ValueError(f"unknown albedo form {form!r}; expected one of {ALBEDO_FORMS}")
    exact = DrawnAlbedo("exact", albedo.layers)
    if form == "exact":
        return exact
    if form in ("auto", "half"):
        try:
            texels, drawn = half_texels(albedo.layers)
        except ValueError:
            if form == "half":
                raise
        else:
            half = DrawnAlbedo("half", drawn, packed=texels)
            half.delta_e94 = layers_colour_error(albedo, half.layers)
            if form == "half" or half.delta_e94 <= bound:
                return half
    basis = choose_albedo_basis(albedo, bound=bound)
    if basis is None:
        return exact
    return DrawnAlbedo("basis", basis.layers(), basis, float(basis.delta_e94))
