"""Bonn BTF database files: UBO2003 (a zip of JPEGs) and UBO2014 (``.btf``, SVD-compressed).

A BTF (bidirectional texture function) is an image per (view, light) pair: ``BTF(x, l, v)``
with ``x`` a texel, ``l`` the light and ``v`` the view direction (Meseth, Müller, Klein,
"Reflectance field based real-time, high quality rendering of BTFs"). The measured values
include the foreshortening term ``n·l``. Directions are in the sample's local frame, z up
(the surface normal), φ measured from +x towards +y: ``(cos φ sin θ, sin φ sin θ, cos θ)``.

UBO2003 (``read_ubo2003`` / ``write_ubo2003``)
----------------------------------------------
A zip archive of 81 views × 81 lights = 6561 JPEG images of 256 × 256 texels, one member
per (light, view) pair named ``tl%03d pl%03d tv%03d pv%03d.jpg`` (θ and φ of the light, then
of the view, in integer degrees, zero-padded to three digits, separated by single spaces;
members may sit in a folder). Layout verified against btf-extractor
(2-propanol/BTF_extractor, ``btf_extractor/ubo2003.py``: the docstring of ``Ubo2003`` gives
``f"tl{tl:03} pl{pl:03} tv{tv:03} pv{pv:03}.jpg"`` and ``_filename_to_angles`` slices the
digits from the end of the member name, so a leading folder is allowed).

Colour encoding: the images are 8-bit, display-encoded (gamma-compressed) camera images,
*not* linear radiance; the database does not state the exact transfer curve. Renderers
that use them undo a display gamma first (elerac/btf-rendering, ``custom_bsdf/measuredbtf.py``,
``apply_inv_gamma`` on by default, ``x ** 2.2``). :func:`read_ubo2003` returns the encoded
values in [0, 1] (``encoding == "srgb"``) unless ``linear=True``, which applies the sRGB
EOTF (IEC 61966-2-1, colour-science's ``eotf_sRGB``) exactly per 8-bit code.

The reader checks the whole archive before it allocates any image, so that memory stays
in proportion to the bytes present:

* every member name against the pattern, and every member's declared (central directory)
  sizes against the archive: a stored member must hold its bytes inside the archive, a
  compressed one may declare at most :data:`MAX_MEMBER_RATIO` times its compressed size
  (JPEG data do not compress), each at most ``max_member_bytes``, all together at most
  ``max_bytes``;
* every member's JPEG header (read lazily, inflated under a running cap): one image size
  for all, RGB or greyscale, at most ``max_member_bytes`` as 8-bit RGB, and at most
  :data:`MAX_JPEG_PIXELS_PER_BYTE` pixels per byte of the member;
* the decoded array ``(views, lights, H, W, 3)`` float32 against ``max_bytes``, and, as
  missing pairs take memory too (NaN), against twice the present images plus
  :data:`MISSING_SLACK_BYTES`: a sparse set (300 images on the diagonal of 300 × 300
  pairs) is refused with a pointer to ``lazy=True`` and :meth:`UBOBTF.lookup`.

Views and lights are the sorted distinct (θ, φ) pairs found; a (view, light) pair with no
image is counted in ``defects["missing"]``, flagged ``False`` in :attr:`UBOBTF.present` and
filled with NaN, never invented.

UBO2014 (``read_ubo2014`` / ``write_ubo2014``)
----------------------------------------------
151 × 151 directions, 400 × 400 or 512 × 512 texels, stored as a truncated SVD.
Layout verified against btf-extractor's ``btf_extractor/c_ext/btf.hh`` (Zdravko Velinov's
free BTF library, MIT): ``LoadBTF`` (lines 485-959), its ``read_common`` lambda (507-621),
the ``DFMF`` branch (625-784), ``FMF0``/``FMF1`` (785-915), the evaluation
``BTFEvaluateMatrix`` (333-359) and ``BTFFetchSpectrum`` (210-272). All little-endian:

* ``!`` then the FourCC ``DFMF``, ``FMF0`` or ``FMF1``, then ``08FC``, ``6FC`` or ``2FCE``
  respectively; optionally an ``R`` (a rotation list follows the image size).
* Common header (its first field, ``Size``, is the byte count of the whole header from
  ``Size`` up to and including the channel names): ``u32 Size, u32 Version``,
  three ``char[80]`` (measurement setup, image sensor, light source), ``f32 PPMM``,
  ``f32[3]`` RGB scale; ``Version > 1``: ``u32`` cosine flag; ``> 2``: ``u32`` length +
  XML text; ``> 3``: ``u32`` channel count, then per channel ``u32`` length + name
  (otherwise R, G, B).
* ``u32`` view count; per view ``f32 θ, f32 φ`` (radians), ``u32`` light count and that
  many ``f32 θ, f32 φ`` (btf-extractor keeps the first view's list and only checks the
  counts of the others); then ``u32`` width, ``u32`` height; with ``R``: ``u32`` count
  and that many 3 × 3 ``f32`` matrices.
* ``DFMF``: ``u32`` components, ``u32`` colour model, ``f32[3]`` colour mean,
  ``f32[9]`` colour transform; then per channel: ``u8`` element size (2 half, 4 float,
  8 double), ``u32`` k, ``u32`` rows (= views × lights), ``u32`` columns (= W × H),
  k singular values, U (rows × k), S·V (columns × k).
* ``FMF0``/``FMF1``: (``FMF1`` only: ``u8`` extension version; ≥ 1: ``u32`` dynamic-range
  reduction flag; ≥ 2: ``u32`` width, ``u32`` height and a ``u16`` height map; ≥ 3 is
  unsupported) ``u32`` k₀, ``u8`` element size, ``u32`` k₁, k = min(k₀, k₁);
  ``u32`` rows (= views × lights × channels), ``u32`` columns (= W × H), k singular
  values, U (rows × k, rows ordered view, light, channel), S·V (columns × k, shared by the
  channels).
* The file ends right after S·V.

A value is ``Σₖ U[row, k] · SxV[texel, k]`` with ``row = view · L + light`` (times the
channel count plus the channel for FMF); the singular values are already folded into S·V.
Texels are stored bottom row first: ``texel = (H - 1 - y) · W + x`` for row ``y`` counted
from the top (btf-extractor flips the rows after loading). Colour model 11 is log-YUV
(``Y = exp(c₀) - 1e-5``, ``U, V = c₁,₂ · Y + 1e-5``, then YUV → RGB clamped to [0, 1], as
btf-extractor does); the FMF1 dynamic-range-reduction flag means ``exp(c) - 1e-5``.
The cosine flag is reported, not applied (btf-extractor leaves it a stub).

Differences from btf-extractor: rows must equal views × lights (it checks lights², the
same for the 151 × 151 files), a component count of 0 and colour models other than 0 and
11 are refused, every view's light list is read and differing lists are counted in
``defects``, every size is checked against the bytes left in the file (and
``max_bytes``) before anything is allocated, and factors whose values can overflow
float32 (``Σₖ |U[r, k]| · maxₜ |S·V[t, k]|`` over 3.4 × 10³⁸) are refused.

Errors
------
Every malformed, truncated or oversized input raises :class:`InvalidBTFData` (a
``ValueError``, subclass of :class:`~spectral_materials.core.errors.InvalidBRDFData`)
naming the file and the problem; a missing path raises :class:`BTFFileNotFound`, which is
both an :class:`InvalidBTFData` and a :class:`FileNotFoundError`.
"""

from __future__ import annotations

from .common import (
    MAX_BYTES,
    MAX_JPEG_PIXELS_PER_BYTE,
    MAX_MEMBER_BYTES,
    MAX_MEMBER_RATIO,
    MISSING_SLACK_BYTES,
    NAME_FORMAT,
    BTFFileNotFound,
    InvalidBTFData,
    directions_from_angles,
)
from .ubo2003 import UBOBTF, read_ubo2003, write_ubo2003
from .ubo2014 import UBO2014BTF, read_ubo2014
from .ubo2014_write import write_ubo2014

__all__ = [
    "BTFFileNotFound",
    "InvalidBTFData",
    "MAX_BYTES",
    "MAX_JPEG_PIXELS_PER_BYTE",
    "MAX_MEMBER_BYTES",
    "MAX_MEMBER_RATIO",
    "MISSING_SLACK_BYTES",
    "NAME_FORMAT",
    "UBO2014BTF",
    "UBOBTF",
    "directions_from_angles",
    "read_ubo2003",
    "read_ubo2014",
    "write_ubo2003",
    "write_ubo2014",
]
