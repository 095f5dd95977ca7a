"""The project's tabulated spectral BRDF file (``.npz``) and a callable reading it.

File format (``spectral_materials.tabulated_brdf``, version 1)
-------------------------------------------------------------
A NumPy ``.npz`` archive (zip; stored or deflated members) with three arrays:

``values``
    float32, shape ``(*resolution, L)``: the BRDF ``f`` in sr⁻¹ (*not*
    multiplied by cos θi) at the cell centres of a grid over the axes of the
    parameterisation: axis ``k`` with ``n`` cells is sampled at
    ``Axis.centres(n)`` = ``from_unit((i + 0.5) / n)`` (see
    :mod:`spectral_materials.core.brdf.params`; θh of ``hd``/``hd_iso`` is
    square-root warped). C order: the last angular axis varies fastest, then
    wavelength is the innermost axis. Grid points that map to no physical
    configuration (below the horizon, outside the unit discs of ``gs``) hold 0.
``wavelengths``
    float64, shape ``(L,)``: strictly increasing, in nm (200–2000).
``meta``
    uint8, the UTF-8 bytes of a JSON object::

        {"format": "spectral_materials.tabulated_brdf", "version": 1,
         "parameterization": "io_iso",      # a key of params.PARAMETERIZATIONS
         "resolution": [90, 180, 90],       # == values.shape[:-1]
         "description": "free text"}

Every sample must be finite and non-negative.

Reading
-------
:func:`read_tabulated` validates ``meta`` and the ``.npy`` headers of the
members (shape, dtype, and that the member's size matches the header) before it
allocates anything, refuses more than :data:`MAX_ENTRIES` samples, and turns
every sort of damage (truncation, flipped bytes caught by the zip CRCs, missing
entries, a file that is not a zip) into :class:`InvalidBRDFData` (a
``ValueError``) naming the file and the problem. Declared sizes are checked
against the bytes present: a stored member must hold its declared bytes inside
the archive, a compressed one may declare at most :data:`MAX_DEFLATE_RATIO`
times its compressed size, and members are inflated step by step under a
running cap at their declared size, so memory stays in proportion to the file.
Non-finite or negative samples raise by default; ``on_invalid="clamp"`` sets
them to 0 and records their counts in :attr:`TabulatedBRDF.defects`.

Evaluating
----------
:class:`TabulatedBRDF` is a BRDF callable ``f(wi, wo, wavelengths) -> (N, L)``:
multilinear interpolation over the grid (φ axes wrap, θ ends extrapolate
linearly, as :func:`tabulate.interpolate` with ``edge="linear"``), then linear
interpolation in wavelength (held constant outside the file's range); negative
values from the extrapolation are clamped to 0, and the result is 0 wherever
either direction is at or below the horizon.

The package's modules: :mod:`.limits`, :mod:`.table` (:class:`TabulatedBRDF`),
:mod:`.writer`, :mod:`.reader` and :mod:`.sample_scan`; every name is re-exported here.
"""

from __future__ import annotations

from .limits import (  # noqa: F401  (not in __all__: importable from here as before)
    _MAX_MEMBER_BYTES,
    _SCAN_ENTRIES,
    CHUNK_POINTS,
    FORMAT,
    FORMAT_VERSION,
    MAX_DEFLATE_RATIO,
    MAX_ENTRIES,
    MAX_META_BYTES,
    MAX_WAVELENGTHS,
)
from .reader import read_tabulated
from .table import TabulatedBRDF
from .writer import tabulate_to_file, write_tabulated

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "MAX_ENTRIES",
    "TabulatedBRDF",
    "read_tabulated",
    "tabulate_to_file",
    "write_tabulated",
]
