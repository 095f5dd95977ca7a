"""The tabulated format's name, version and limits."""

from __future__ import annotations

FORMAT = "spectral_materials.tabulated_brdf"
FORMAT_VERSION = 1
#: Refuse files with more samples than this (angular cells × wavelengths).
MAX_ENTRIES = 2_000_000_000
#: Refuse ``meta`` entries longer than this many bytes.
MAX_META_BYTES = 1 << 20
#: Refuse wavelength axes longer than this.
MAX_WAVELENGTHS = 100_000
#: Direction pairs evaluated per chunk in :meth:`TabulatedBRDF.__call__`.
CHUNK_POINTS = 16384
#: Refuse a compressed member that declares more than this many times its compressed
#: bytes (beyond its first MiB, :data:`._files.RATIO_FREE_BYTES`). Measured with
#: ``np.savez_compressed`` on tables of this module: Oren–Nayar 2.6:1, GGX on a metal
#: 31:1, spectrally flat GGX 82:1, spectrally flat tables with large zero regions (Lambert
#: in ``gs``, a no-diffuse Ashikhmin–Shirley lobe of exponent 10⁴) 295–317:1. Deflate
#: cannot exceed about 1030:1, which a table of zeros reaches: that is how a 1 MB file
#: claims a gigabyte. (This module's writer stores members uncompressed: 1:1.)
MAX_DEFLATE_RATIO = 512
#: Samples scanned per chunk for NaN/inf/negatives.
_SCAN_ENTRIES = 1 << 22
#: The most any member can declare: MAX_ENTRIES float64 samples and a .npy header.
_MAX_MEMBER_BYTES = MAX_ENTRIES * 8 + (1 << 16)
