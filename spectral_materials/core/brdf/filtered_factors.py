"""The fast draw path's factor texture, and its float64 mirror: 16-bit texels, hardware filter.

The exact path (glsl/brdf/factor_packs.glsl) reads float32 factors with two
``texelFetch`` per axis and pack, and interpolates in the shader. The fast paths let
the texture unit interpolate a 16-bit texture: one fetch of 8 bytes instead of two
of 16. On an H100 this cost 0.41× per pack (issue 19's patched replays, RGBA16F).
Two encodings:

- ``"half"``: RGBA16F, 11-bit significand, relative precision everywhere.
- ``"unorm16"``: RGBA16 holding (a + 1)/2, so steps of 2/65535 of the
  column's peak. A CP model's terms can cancel (sums 60–90× smaller than their
  parts near grazing in a 4-pack Oren–Nayar). There, half's relative error
  grows to ΔE94 0.6 while unorm16's stays below 0.02 (``benchmarks/draw_variants.py``).

Rules that keep either equal to the exact path to its precision:

- **Padding texels carry the edge rule.** Each axis row gets one texel before its
  first cell and one after its last. A periodic axis wraps (the pad is the other
  end's cell). A linear end extrapolates (pad = 2A₀ − A₁, so the filter between pad
  and A₀ continues the line to the axis end). A held end repeats its cell. This
  covers ``axes.EDGE_RULES``; the horizon rule's scale stays ALU. The lookup
  coordinate is x + 1 (x from ``axes.cell_x``). It never leaves [0.5, n + 0.5],
  so the filter reads no texel outside the row.
- **Balanced columns.** Each term's padded rows are scaled by a power of two to a
  peak |a| ∈ (0.5, 1], and the scales go into the spectral factor. The float32 light
  rows (K = Sᵀ Ĩ) carry them, so glossy factors fit both encodings.
- **Filter weights.** Hardware filters round the weight to 8 fractional bits
  (CUDA C Programming Guide, "Texture Fetching, Linear Filtering": "α … stored in
  9-bit fixed point format with 8 bits of fractional value"). ``weight_bits``
  models that; ``None`` models a filter with float weights, as llvmpipe's is.

:class:`FilteredFactorsBRDF` is a :class:`FactoredBRDF` whose lookups are those of
the texture, so ``shading.shade_xyz`` and ``shading.light_texels`` mirror the fast
path unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import metrics
from .axes import cell_x, holds_horizon
from .factored import FactoredBRDF

#: How the draw path stores and interpolates factors: ``"exact"`` float32 rows, two
#: fetches and a mix in the shader; ``"unorm16"`` the same on this module's 16-bit
#: padded rows; ``"<encoding>_filtered"`` one fetch, the texture unit interpolating.
FACTOR_PRECISIONS = ("exact", "unorm16", "unorm16_filtered", "half_filtered")
#: Per precision other than exact: (encoding, hardware filtered).
PRECISION_TEXELS = {"unorm16": ("unorm16", False), "unorm16_filtered": ("unorm16", True),
                    "half_filtered": ("half", True)}
#: The 16-bit encodings and their GPU texture formats.
TEXTURE_FORMATS = {"half": "RGBA16F", "unorm16": "RGBA16"}
#: Fractional bits of a hardware filter's weight (NVIDIA, AMD; see the module doc).
HARDWARE_WEIGHT_BITS = 8
#: Texels a row gains: one pad at each end.
PAD = 1
_UNORM_MAX = 65535.0


def edge_pads(table: np.ndarray, periodic: bool, low: str, high: str) -> np.ndarray:
    """``table`` (n, R) with a pad row before and after: wrapped (``periodic``), or per
    end ``"linear"`` (2A₀ − A₁) or ``"clamp"`` (A₀)."""
    table = np.asarray(table, dtype=np.float64)
    if periodic or len(table) == 1:
        before, after = (table[-1], table[0]) if periodic else (table[0], table[0])
    else:
        before = 2.0 * table[0] - table[1] if low == "linear" else table[0]
        after = 2.0 * table[-1] - table[-2] if high == "linear" else table[-1]
    return np.concatenate([before[None], table, after[None]])


def end_rules(edge: str, horizon: bool) -> tuple[str, str]:
    """(low end, high end) of a non-periodic axis under ``edge``, as ``axes.axis_lookup``;
    ``horizon``: the rule holds this axis's horizon (``axes.holds_horizon``)."""
    if edge == "clamp":
        return "clamp", "clamp"
    if horizon:
        return "linear", "clamp"
    return "linear", "linear"


def quantize(values: np.ndarray, encoding: str) -> np.ndarray:
    """``values`` (|v| ≤ 1) as the texture returns them after decoding, in float64."""
    values = np.asarray(values, dtype=np.float64)
    if encoding == "half":
        return values.astype(np.float16).astype(np.float64)
    if encoding == "unorm16":
        return encode_unorm16(values) * 2.0 - 1.0
    raise ValueError(f"encoding must be one of {tuple(TEXTURE_FORMATS)}, got {encoding!r}")


def encode_unorm16(values: np.ndarray) -> np.ndarray:
    """The unorm16 texel values k/65535 of (v + 1)/2; the GPU returns exactly these."""
    return np.round((np.asarray(values, dtype=np.float64) + 1.0) * 0.5 * _UNORM_MAX) / _UNORM_MAX


@dataclass
class FilteredFactorsBRDF(FactoredBRDF):
    """A CP model as a fast path draws it (module doc): ``padded[k]`` is axis k's row
    with its pads, (n_k + 2, R), decoded; ``weight_bits`` the filter's."""

    padded: list[np.ndarray] = field(default_factory=list)
    encoding: str = "half"
    weight_bits: int | None = HARDWARE_WEIGHT_BITS
    #: The texture unit returns the filtered value rounded to half (``"half"`` only), as
    #: an NVIDIA H200 does: there ``half_filtered``'s XYZ image differs from llvmpipe's by
    #: 1.8e-4 (mean relative) against ``unorm16_filtered``'s 7.2e-5, and half layers with
    #: their rounding error in a second layer drew as plain half (docs/bench_gpu.md).
    half_output: bool = False

    def _angular_terms(self, coords: np.ndarray) -> np.ndarray:
        prod = np.ones((coords.shape[0], self.terms))
        for k, (axis, n) in enumerate(zip(self.grid.parameterization.axes, self.grid.shape)):
            p = cell_x(axis, n, coords[:, k]) + PAD
            i = np.clip(np.floor(p), 0, n).astype(np.int64)
            w = p - i
            if self.weight_bits is not None:
                steps = float(1 << int(self.weight_bits))
                w = np.floor(w * steps + 0.5) / steps
            table = self.padded[k]
            value = (1.0 - w)[:, None] * table[i] + w[:, None] * table[i + 1]
            if self.half_output and self.encoding == "half":
                value = value.astype(np.float16).astype(np.float64)
            prod *= value
        return prod

    def truncated(self, packs: int) -> FactoredBRDF:
        # The padded rows are derived data: truncate the model, then pad it again.
        raise ValueError("truncate the model before making its 16-bit rows "
                         "(filtered_factors(model.truncated(packs), ...))")

    @property
    def texture_format(self) -> str:
        return TEXTURE_FORMATS[self.encoding]

    def texels(self) -> np.ndarray:
        """The texture's texels (axes · G, max n + 2, 4) float32, as uploaded: decoded
        values for ``"half"`` (exact in half), (a + 1)/2 for ``"unorm16"``. Texel
        (p, k·G + g) holds terms 4g … 4g+3 of axis k's padded row at p."""
        groups = -(-self.terms // 4)
        width = max(len(t) for t in self.padded)
        out = np.zeros((len(self.padded) * groups, width, 4), dtype=np.float32)
        if self.encoding == "unorm16":
            out[:] = encode_unorm16(np.zeros(1))[0]        # the step nearest 0
        for k, table in enumerate(self.padded):
            padded = np.zeros((len(table), groups * 4))
            padded[:, : self.terms] = table
            if self.encoding == "unorm16":
                padded = encode_unorm16(padded)
            out[k * groups:(k + 1) * groups, : len(table)] = \
                padded.reshape(len(table), groups, 4).transpose(1, 0, 2)
        return out


def filtered_factors(model: FactoredBRDF, encoding: str = "half",
                     weight_bits: int | None = HARDWARE_WEIGHT_BITS,
                     half_output: bool = False) -> FilteredFactorsBRDF:
    """``model`` as the fast path with ``encoding`` draws it: padded, balanced, quantised;
    ``half_output``: the filtered values rounded to half, as a texture unit returns them."""
    if model.form != "cp":
        raise ValueError("the fast draw path draws CP factor packs only")
    if encoding not in TEXTURE_FORMATS:
        raise ValueError(f"encoding must be one of {tuple(TEXTURE_FORMATS)}, got {encoding!r}")
    if weight_bits is not None and not 1 <= int(weight_bits) <= 23:
        raise ValueError(f"weight_bits must be 1..23 or None, got {weight_bits!r}")
    spectral = np.asarray(model.spectral, dtype=np.float64).copy()
    padded = []
    for axis, table in zip(model.grid.parameterization.axes, model.factors):
        rows = edge_pads(table, axis.periodic,
                         *end_rules(model.edge, holds_horizon(axis, model.edge)))
        peak = np.abs(rows).max(axis=0)
        if not np.isfinite(peak).all():
            raise ValueError("a factor is not finite")
        # A power of two: the rescaling itself is exact.
        scale = np.exp2(np.ceil(np.log2(np.where(peak > 0, peak, 1.0))))
        padded.append(quantize(rows / scale, encoding))
        spectral *= scale
    fields = {name: getattr(model, name) for name in FactoredBRDF.__dataclass_fields__}
    fields.update(factors=[rows[PAD:-PAD] for rows in padded], spectral=spectral)
    return FilteredFactorsBRDF(**fields, padded=padded, encoding=encoding,
                               weight_bits=weight_bits, half_output=half_output)



def drawn_model(model: FactoredBRDF, precision: str) -> FactoredBRDF:
    """What the draw path with ``precision`` (``FACTOR_PRECISIONS``) evaluates: ``model``
    itself when exact; else its 16-bit rows with shader weights (float) or the
    texture unit's (8-bit weights; a filtered half value returned as half)."""
    if precision == "exact":
        return model
    if precision not in PRECISION_TEXELS:
        raise ValueError(f"factor precision must be one of {FACTOR_PRECISIONS}, "
                         f"got {precision!r}")
    encoding, filtered = PRECISION_TEXELS[precision]
    return filtered_factors(model, encoding, HARDWARE_WEIGHT_BITS if filtered else None,
                            half_output=filtered)


#: The issue's bound on a fast path's colour error against the exact path (ΔE94).
AUTO_BOUND_DE94 = 0.05
#: Pairs and illuminants :func:`choose_precision` measures at (the protocol's seed).
AUTO_PAIRS = 4000
AUTO_ILLUMINANTS = ("D65", "FL11")
#: The order :func:`choose_precision` tries, fastest first (docs/bench_factor_precision.md:
#: one filtered fetch beats two; half and unorm16 fetch the same bytes).
SPEED_ORDER = ("unorm16_filtered", "half_filtered", "unorm16")


def choose_precision(model: FactoredBRDF, bound: float = AUTO_BOUND_DE94
                     ) -> tuple[str, dict]:
    """The fastest precision whose max ΔE94 against the exact path stays within ``bound``
    at :data:`AUTO_PAIRS` protocol pairs under each of :data:`AUTO_ILLUMINANTS` (8-bit
    filter weights for the filtered ones), else ``"exact"``; and each candidate's max.

    Which encoding wins depends on the material: unorm16 keeps terms that cancel
    (matte lobes near grazing), half keeps a glossy factor's dynamic range."""
    if model.form != "cp":
        return "exact", {}
    wi, wo = metrics.random_direction_pairs(AUTO_PAIRS)
    exact = {ill: model.xyz(wi, wo, ill) for ill in AUTO_ILLUMINANTS}
    measured = {}
    for precision in SPEED_ORDER:
        fast = drawn_model(model, precision)
        measured[precision] = max(
            metrics.delta_e94_stats(exact[ill], fast.xyz(wi, wo, ill), ill)["max"]
            for ill in AUTO_ILLUMINANTS)
        if measured[precision] <= bound:
            return precision, measured
    return "exact", measured
