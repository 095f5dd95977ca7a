"""RGL ``.bsdf`` tensor files (Dupuy & Jakob 2018, EPFL material database) as BRDF callables.

Container (``tensor_file``)
---------------------------
Little-endian. 12 bytes of magic ``b"tensor_file\\0"``, two version bytes ``(1, 0)``, a
uint32 field count, then per field: uint16 name length, the name, uint16 ``ndim``, uint8
dtype code (1 u8, 2 i8, 3 u16, 4 i16, 5 u32, 6 i32, 7 u64, 8 i64, 9 f16, 10 f32, 11 f64),
uint64 absolute offset of the data, ``ndim`` × uint64 shape. Data are C-ordered.
(rgl-epfl/brdf-loader ``powitacq.inl`` ``Tensor::Tensor``, lines 722–795; Mitsuba 3
``src/core/tensor.cpp``.) The writers (Mitsuba 3 ``tensor_io.write``, :func:`write_tensor_file`)
put the table first, then each field's data in turn, aligned, one after another.

:func:`read_tensor_file` checks, *before* it reads (or allocates) any data: the magic, the
version, at most :data:`MAX_FIELDS` fields, every dtype code, that every field's offset +
size lies inside the file, that no two fields' data overlap and none overlaps the table
(so all fields together hold at most the file's bytes, and reading them costs no more
memory than the file's size), and that they stay below ``max_bytes``.

Material fields
---------------
``description`` u8[n]; ``jacobian`` u8[1]; ``theta_i``, ``phi_i`` f32 1-D (incident
directions, radians, increasing); ``ndf``, ``sigma`` f32 [nφ, nθ] (over the unit square
(u_θ, u_φ), θ the last axis); ``vndf``, ``luminance`` f32 [φi, θi, ny, nx]; spectral files
``wavelengths`` f32 [L] (nm) and ``spectra`` f32 [φi, θi, L, n, n]; RGB files ``rgb`` f32
[φi, θi, 3, n, n] instead. Shape rules as the reference's ``BRDF::BRDF`` (``powitacq.inl``
906–948; Mitsuba 3 ``measured.cpp``), plus: every grid ≥ 2 × 2 (the reference's
interpolants divide by ``size − 1``), strictly increasing ``theta_i``/``phi_i``/
``wavelengths``, each vndf slice with a positive integral.

The file is *isotropic* when ``phi_i`` has ≤ 2 entries (``powitacq.inl`` 952). Otherwise
its φi span gives the symmetry ``reduction = rint(2π / (φi[-1] − φi[0]))``: 1 (full circle;
the only one powitacq accepts, 955–961), 2 or 4, which Mitsuba 3 handles by folding wi and
wo into the measured range (``mulsign_neg``: reduction 2 rotates the pair by π when
wi.y ≥ 0, reduction 4 mirrors x and y separately). Other values are refused. Isotropic
files are not folded (powitacq has no folding; Mitsuba 3 leaves ``m_reduction``
uninitialised for them, ``measured.cpp`` 168–172, so its folding there depends on stale
memory — observed to act as reduction 4 in 3.9.1; both agree with this reader whenever
wi.x < 0 and wi.y < 0, where every folding is the identity).

Evaluation (``powitacq.inl`` ``BRDF::eval`` 1067–1102; Mitsuba 3 ``Measured::eval``)
--------------------------------------------------------------------------------
* 0 unless ``wi.z > 0`` and ``wo.z > 0``; inputs are normalised.
* wm = normalize(wi + wo); θ = 2·asin(|d − ẑ|/2) (``elevation``), φ = atan2(y, x);
  u = (√(2θ/π), (φ + π)/2π) (``theta2u``/``phi2u``, 865–879); for isotropic files the
  half vector's φ is taken relative to φi (φm − φi), wrapped into [0, 1).
* The VNDF warp is inverted at u_m (``Marginal2D::invert``, 431–518: a bilinear density
  per (φi, θi) slice with trapezoid CDFs, the slices interpolated linearly in φi and θi
  with weights clamped to [0, 1], ``find_interval`` 130–150), giving the unit-square
  position ``s`` where the spectra are looked up.
* ``spectra.eval(s, (φi, θi, λ))`` (``Marginal2D::eval`` 524–576, no normalisation):
  bilinear in s, linear in φi, θi and λ.
* If ``jacobian`` is set the value is multiplied by ``ndf.eval(u_m) / (4 σ.eval(u_wi))``.
  Mitsuba 3 does this only when the flag is set; powitacq's ``BRDF::eval`` always does
  (1098–1099). This reader follows Mitsuba (the flag is part of the format); the two agree
  for files with the flag set. No cosine factor is applied by either (Mitsuba's ``eval``
  returns the value without cos θo for this plugin), and none here.
* The result is the BRDF in sr⁻¹, not cosine-weighted.

Wavelengths
-----------
The reference evaluates at its own wavelengths (interpolating linearly between file
wavelengths, clamping outside). :meth:`RGLBSDF.__call__` evaluates at the file's grid and
resamples linearly to the requested ``wavelengths``, **zero outside** the file's range (so
no measured spectrum is extended beyond what was measured); inside the range this is the
reference's value exactly (the interpolation is linear in λ). Negative results (noise in
the measurements) are clamped to 0 by ``__call__``; :meth:`RGLBSDF.eval_native` and
:meth:`RGLBSDF.rgb` return the reference's values unclamped.

RGB files are evaluated per channel (``powitacq_rgb.inl``); ``__call__`` uplifts them to
spectra with Smits (1999) (:class:`spectral_materials.core.colour.uplift.SmitsUplift`,
negative channels taken as 0).

Defects
-------
Non-finite samples raise :class:`InvalidBRDFData` (``on_invalid="raise"``) or are set to 0
and counted (``"clamp"``). Negative samples are counted; in the densities (``ndf``,
``sigma``, ``vndf``, ``luminance``) they are set to 0, in ``spectra``/``rgb`` they are
kept as the reference keeps them. Where σ(u_wi) is 0 the value is 0. A file whose
spectra are all zero is refused.

Values no measurement produces are refused whatever ``on_invalid`` says
(:mod:`spectral_materials.core.sample_limits`): a sample of magnitude above 10³⁰ in any of
the float tables, wavelengths outside 10 nm – 100 µm, ``theta_i`` outside [0, π/2] or
``phi_i`` outside [−2π, 2π] (both with 10⁻⁴ rad for float32 rounding), and a
``description`` longer than :data:`MAX_DESCRIPTION_BYTES`.

Memory
------
Fields are read straight into their arrays and cleaned in place; the tables derived from
them (the vndf warp's cumulative sums, one float32 per vndf sample: the marginal CDF shares
the conditional CDF's first column, which is always 0) are built in blocks of
:data:`CHUNK_ELEMENTS`. Reading a file so costs at most about twice its size.
"""

from __future__ import annotations

# The container, the interpolants, the callable and the reader live in the modules of this
# package; every name the single module had stays importable from here (``noqa: F401``:
# not in ``__all__``, kept for callers and tests).
from .bsdf import CHUNK_POINTS, RGLBSDF  # noqa: F401
from .reader import MAX_DESCRIPTION_BYTES, read_rgl_bsdf
from .tensor_file import (
    DTYPE_CODES,
    MAGIC,
    MAX_FIELDS,
    MAX_NDIM,  # noqa: F401
    MAX_TENSOR_BYTES,
    VERSION,  # noqa: F401
    read_tensor_file,
    write_tensor_file,
)
from .warp import CHUNK_ELEMENTS, _cell, _cumulative_trapezoid, _Warp  # noqa: F401

__all__ = [
    "DTYPE_CODES",
    "MAGIC",
    "MAX_DESCRIPTION_BYTES",
    "MAX_FIELDS",
    "MAX_TENSOR_BYTES",
    "RGLBSDF",
    "read_rgl_bsdf",
    "read_tensor_file",
    "write_tensor_file",
]
