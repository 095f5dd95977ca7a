"""Spectral OpenEXR images in the layout of Fichet, Pacanowski and Wilkie (JCGT 2021).

Reference: A. Fichet, R. Pacanowski, A. Wilkie, "An OpenEXR Layout for Spectral
Images", Journal of Computer Graphics Techniques 10(3), 2021, and its reference
code github.com/afichet/spectral-exr (``lib/EXRSpectralImage.cpp``,
``lib/include/EXRSpectralImage.h``, ``lib/Util.h``). Details checked there:

Channels
    One channel per wavelength, ``<layer>.<value><prefix><unit>``:

    * layer ``S0`` .. ``S3``: emissive spectra, one layer per Stokes component
      (``S0`` alone when the image is not polarised); ``T``: reflective /
      transmissive (attenuation, unitless) spectra;
    * value: a positive decimal written with a **comma** as decimal separator
      (OpenEXR reserves ``.`` for layers), optionally an exponent
      ``[Ee][+-]?digits``;
    * an optional SI prefix (``Y Z E P T G M k h da d c m u n p``) and the unit,
      ``m`` (wavelength) or ``Hz`` (frequency; λ = c / ν).

    The reference writer formats nm with C++ ``std::to_string`` (``%f``), e.g.
    ``S0.550,000000nm`` and ``T.412,500000nm``; this module writes the same.
    Bi-spectral (fluorescent) re-radiation channels are
    ``T.<λin><unit>.<λout><unit>``; they are recognised and skipped here.
Header attributes
    ``spectralLayoutVersion`` = ``"1.0"`` (string), ``emissiveUnits`` (string,
    emissive images only; the reference writes and expects ``"W.m^-2.sr^-1"``,
    meaning spectral radiance per band), ``polarisationHandedness``
    (``"left"``/``"right"``, polarised images only), ``EV`` (float, exposure
    compensation applied to the RGB preview), and optionally ``lensTransmission``,
    ``cameraResponse`` and per-``S0``-channel sensitivities, strings of
    ``<λ><unit>:<value>;`` pairs (kept verbatim in :attr:`SpectralImage.attributes`).
    The reference header also declares a ``spectrumType`` attribute name but never
    writes or reads it: the spectrum type is given by the channel layers alone, so
    this module does not write it either.
RGB preview
    The reference writer always stores ``R``, ``G``, ``B`` beside the spectral
    channels: CIE 1931 2° XYZ (1 nm CMF steps, the spectrum linearly
    interpolated, only over the spectrum's own range; emissive: ∫L·x̄ dλ without
    the 683 lm/W factor; reflective: under D65, divided by ∫D65·ȳ dλ) to linear
    sRGB (D65), negatives clamped to 0, times 2^EV. :func:`write_spectral_exr`
    does the same through colour-science.

Conventions of this module
--------------------------
* Samples are written as 32-bit float: half floats overflow above 65504 (easily
  reached by radiance in W·m⁻²·sr⁻¹·nm⁻¹ of bright sources) and keep 11 bits.
* Arrays are ``(H, W, L)`` with row 0 at the **bottom**, as in
  :mod:`spectral_materials.core.formats.exr`; files store the top row first.
* OpenEXR stores channels sorted by name (``T.1000,000000nm`` before
  ``T.400,000000nm``), so file order says nothing about wavelength order: the
  reader sorts by wavelength and refuses two channels of one layer that give the
  same wavelength (e.g. ``T.550nm`` and ``T.0,55um``).
* Negative samples: ``S0`` is a radiance and ``T`` an attenuation, both
  non-negative physically (only ``S1``–``S3`` may be negative, and they are not
  read). Negative, NaN and inf samples are counted in
  :attr:`SpectralImage.defects` and kept (``on_invalid="keep"``, default: a reader
  should not alter measured data silently), refused (``"raise"``) or set to 0
  (``"clamp"``).

Reading validates the file before reading any pixel: the magic number, the bytes
the pixels declare against the file's size (:func:`.exr.check_decoded_size`: an
uncompressed part cannot hold more than the file, compressed pixels at most
:data:`.exr.MAX_COMPRESSION_RATIO` times it), then the header alone
(``OpenEXR.File(..., header_only=True)``): part type, channel names, sampling,
wavelengths within :data:`WAVELENGTH_LIMITS_NM`, and ``width × height ×
channels`` against :data:`MAX_SAMPLES`. After decoding, finite samples beyond
±:data:`MAX_SAMPLE` are refused whatever ``on_invalid`` says: they are no
measurement, and arithmetic on them overflows far from the file. Every sort of
damage becomes :class:`InvalidSpectralImage` (a ``ValueError``) naming the file.

The package's modules: :mod:`.layout` (limits, names, :class:`SpectralImage`),
:mod:`.rgb_preview` (XYZ, sRGB), :mod:`.writer` and :mod:`.reader`; every name is
re-exported here.
"""

from __future__ import annotations

from ...sample_limits import MAX_SAMPLE, WAVELENGTH_LIMITS_NM
from .layout import (  # noqa: F401  (KINDS: not in __all__, importable as before)
    EMISSIVE_UNITS,
    KINDS,
    LAYOUT_VERSION,
    MAX_CHANNELS,
    MAX_SAMPLES,
    InvalidSpectralImage,
    SpectralEXRFileNotFound,
    SpectralImage,
    channel_name,
    parse_channel_name,
)
from .reader import read_spectral_exr
from .rgb_preview import spectral_image_to_rgb, spectral_image_to_xyz
from .writer import write_spectral_exr

__all__ = [
    "EMISSIVE_UNITS",
    "LAYOUT_VERSION",
    "MAX_CHANNELS",
    "MAX_SAMPLE",
    "MAX_SAMPLES",
    "WAVELENGTH_LIMITS_NM",
    "InvalidSpectralImage",
    "SpectralEXRFileNotFound",
    "SpectralImage",
    "channel_name",
    "parse_channel_name",
    "read_spectral_exr",
    "spectral_image_to_rgb",
    "spectral_image_to_xyz",
    "write_spectral_exr",
]
