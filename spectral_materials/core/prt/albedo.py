"""Spectral albedo textures for spectral PRT: ``m`` layers of R̃ (X, Y, Z channels each).

The spectral PRT paper (Schwenk et al., §3.4) premultiplies a diffuse albedo by the colour
matching functions, ``R(λ) = f_r(λ) m̄(λ)`` with ``f_r = albedo/π``, projects it on an
orthonormal spectral basis ψ (Peercy's linear model, §3.2) and stores the ``m``
coefficients of each of x̄, ȳ, z̄ in the RGB channels of an ``m``-layer texture array:

    R̃_j = Σ_λ ψ_j(λ) · albedo(λ) · m̄(λ) · Δλ / π        (j = 1..m; X, Y, Z per texel).

Per texel that is exactly :func:`prt.albedo_weights`; this module evaluates it for whole
images (from spectra, from linear RGB uplifted with Smits (1999), or from a reflective
spectral OpenEXR), filters the layers bilinearly as the fragment shader does, and builds
the spectral basis the PRT scene needs (:func:`prt_basis`).

Texture conventions (OpenGL's): arrays are ``(H, W, ...)`` with row 0 at the **bottom**
(``v`` near 0), as :mod:`formats.exr`, :mod:`formats.spectral_exr` and Blender's image
pixels; texel ``(i, j)`` has its centre at ``u = (i + ½)/W``, ``v = (j + ½)/H``.

References
----------
Schwenk, K., Franke, T., Drevensek, T., Kuijper, A., Bockholt, U., Fellner, D. W. (2010).
Adapting precomputed radiance transfer to real-time spectral rendering. Eurographics 2010
short papers; §3.2 (the basis), §3.4 (the albedo texture array R̃).
Peercy, M. S. (1993). Linear color representations for full speed spectral rendering.
SIGGRAPH '93, 191–198.
Smits, B. (1999). An RGB-to-spectrum conversion for reflectances. J. Graphics Tools 4(4).
Segal, M., Akeley, K. The OpenGL Graphics System, version 4.6 (core profile), §8.14.2
"Coordinate wrapping and texel selection" (REPEAT, texel centres, LINEAR weights).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..colour import spectra
from . import transfer as prt

#: Texels converted per block (bounds the float64 temporaries to a few tens of MB).
TEXELS_PER_BLOCK = 1 << 16


@dataclass
class AlbedoLayers:
    """R̃ layers of an albedo texture, ready to upload as a texture array.

    Attributes
    ----------
    layers : ndarray (m, H, W, 3) float32
        Layer ``j`` holds R̃_j for x̄, ȳ, z̄ in its channels; row 0 is the bottom.
    wavelengths : ndarray (L,)
        nm, the grid the albedo was integrated on.
    basis : ndarray (L, m) or None
        The orthonormal spectral basis; None means the wavelength samples themselves
        (``m = L``).
    source : str
        Where the albedo came from, for messages.
    """

    layers: np.ndarray
    wavelengths: np.ndarray
    basis: np.ndarray | None
    source: str = "spectra"

    def __post_init__(self) -> None:
        layers = np.asarray(self.layers, dtype=np.float32)
        self.layers = layers
        wl = spectra.check_wavelengths(self.wavelengths)
        m = wl.size if self.basis is None else np.shape(self.basis)[1]
        if layers.ndim != 4 or layers.shape[0] != m or layers.shape[3] != 3:
            raise ValueError(f"albedo layers must be ({m}, H, W, 3), got {layers.shape}")
        if self.basis is not None and np.shape(self.basis)[0] != wl.size:
            raise ValueError(f"basis has {np.shape(self.basis)[0]} rows for {wl.size} "
                             "wavelengths")

    @property
    def count(self) -> int:
        """m, the number of layers."""
        return int(self.layers.shape[0])

    @property
    def nbytes(self) -> int:
        """Bytes of :attr:`layers` (the texture array's size on the GPU, RGB float32)."""
        return int(self.layers.nbytes)


# ------------------------------------------------------------------------------- kernels


def _kernel(wavelengths: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
    """K (L, m, 3) with R̃ = Σ_λ albedo(λ) K[λ]: :func:`prt.albedo_weights` of every unit
    impulse. The map albedo ↦ R̃ is linear, so this *is* that function, evaluated once
    per wavelength instead of once per texel (one source of truth for the definition)."""
    wl = spectra.check_wavelengths(wavelengths)
    if basis is not None:
        basis = np.asarray(basis, dtype=np.float64)
        if basis.ndim != 2 or basis.shape[0] != wl.size or basis.shape[1] < 1:
            raise ValueError(f"basis must be ({wl.size}, m), got {basis.shape}")
        if not np.isfinite(basis).all():
            raise ValueError(f"basis has {int((~np.isfinite(basis)).sum())} non-finite values")
    impulses = np.eye(wl.size)
    return np.stack([prt.albedo_weights(e, wl, basis) for e in impulses])


def _check_reflectance(values: np.ndarray, what: str) -> None:
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise ValueError(f"{what} has {bad} non-finite (NaN/inf) values")
    negative = int(np.count_nonzero(values < 0))
    if negative:
        raise ValueError(f"{what} has {negative} negative values; a reflectance is ≥ 0")


def _apply(values: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """``values`` (H, W, K) through ``kernel`` (K, m, 3) → layers (m, H, W, 3) float32."""
    height, width, k = values.shape
    m = kernel.shape[1]
    flat = values.reshape(-1, k)
    matrix = kernel.reshape(k, m * 3)
    out = np.empty((flat.shape[0], m * 3), dtype=np.float32)
    for begin in range(0, flat.shape[0], TEXELS_PER_BLOCK):
        block = slice(begin, begin + TEXELS_PER_BLOCK)
        out[block] = flat[block].astype(np.float64) @ matrix
    return np.ascontiguousarray(out.reshape(height, width, m, 3).transpose(2, 0, 1, 3))


def _as_image(values: np.ndarray, channels: int, what: str) -> np.ndarray:
    """(H, W, channels) from (H, W, channels) or a single (channels,) texel."""
    values = np.asarray(values)
    shape = values.shape
    if values.ndim == 1:
        values = values[None, None, :]
    if values.ndim != 3 or values.shape[2] != channels or 0 in values.shape:
        raise ValueError(f"{what} must be (H, W, {channels}) or ({channels},), got {shape}")
    if values.dtype.kind not in "fiu":
        raise ValueError(f"{what} must be numeric, got dtype {values.dtype}")
    return values


# ------------------------------------------------------------------------------ builders


def albedo_layers_from_spectra(reflectance: np.ndarray, wavelengths: np.ndarray,
                               basis: np.ndarray | None = None, *,
                               source: str = "spectra") -> AlbedoLayers:
    """R̃ layers of a reflectance texture.

    Parameters
    ----------
    reflectance : array (H, W, L) or (L,)
        Diffuse albedo spectra on ``wavelengths``, row 0 at the bottom; a single
        spectrum (L,) gives a 1 × 1 texture. Finite and non-negative.
    wavelengths : array (L,)
        nm.
    basis : array (L, m), optional
        Orthonormal spectral basis (e.g. :func:`prt_basis`); None keeps the L samples.
    source : str
        A label kept in :attr:`AlbedoLayers.source`.

    Returns
    -------
    AlbedoLayers
        Per texel exactly ``prt.albedo_weights(reflectance[j, i], wavelengths, basis)``
        (in float32).

    Raises
    ------
    ValueError
        Wrong shape, NaN/inf or negative values (with their count).
    """
    wl = spectra.check_wavelengths(wavelengths)
    values = _as_image(reflectance, wl.size, "reflectance")
    _check_reflectance(values, "reflectance")
    basis_array = None if basis is None else np.asarray(basis, dtype=np.float64)
    layers = _apply(values, _kernel(wl, basis_array))
    return AlbedoLayers(layers, wl.copy(), basis_array, source)


def albedo_layers_from_rgb(rgb: np.ndarray, wavelengths: np.ndarray,
                           basis: np.ndarray | None = None, *,
                           source: str = "RGB (Smits 1999)") -> AlbedoLayers:
    """R̃ layers of a linear Rec.709 reflectance texture, uplifted to spectra with Smits
    (1999) (``formats.merl.SmitsUplift``, colour-science's basis spectra).

    Parameters
    ----------
    rgb : array (H, W, 3) or (3,)
        Linear (not sRGB-encoded) Rec.709 reflectance, row 0 at the bottom. Negative
        channels (out-of-gamut colours) are taken as 0, as the uplift does; values must be
        finite.
    wavelengths, basis, source
        As :func:`albedo_layers_from_spectra`.

    Notes
    -----
    Smits' spectra cover 380–720 nm; beyond, their end values are held. The uplift is
    linear per ordering of the channels, so the spectra are built texel by texel (in
    blocks) before the CMF weighting.
    """
    from ..colour.uplift import SmitsUplift

    wl = spectra.check_wavelengths(wavelengths)
    values = _as_image(rgb, 3, "rgb")
    bad = int(np.count_nonzero(~np.isfinite(values)))
    if bad:
        raise ValueError(f"rgb has {bad} non-finite (NaN/inf) values")
    basis_array = None if basis is None else np.asarray(basis, dtype=np.float64)
    kernel = _kernel(wl, basis_array).reshape(wl.size, -1)
    uplift = SmitsUplift()
    height, width = values.shape[:2]
    flat = values.reshape(-1, 3)
    out = np.empty((flat.shape[0], kernel.shape[1]), dtype=np.float32)
    for begin in range(0, flat.shape[0], TEXELS_PER_BLOCK):
        block = slice(begin, begin + TEXELS_PER_BLOCK)
        out[block] = uplift(flat[block], wl) @ kernel
    layers = np.ascontiguousarray(out.reshape(height, width, -1, 3).transpose(2, 0, 1, 3))
    return AlbedoLayers(layers, wl.copy(), basis_array, source)


def _resampling_matrix(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """M (len(source), len(target)): ``values @ M`` is ``np.interp(target, source, values)``
    for every row (np.interp is linear in the values, so its impulse responses are M)."""
    return np.stack([np.interp(target, source, e) for e in np.eye(source.size)])


def _read_reflective(path: str | Path):
    """The reflective layer of a spectral OpenEXR, checked (see read_reflectance_exr)."""
    from ..formats.spectral_exr import (
        InvalidSpectralImage,
        SpectralEXRFileNotFound,
        read_spectral_exr,
    )

    try:
        image = read_spectral_exr(path, kind="reflective")
    except SpectralEXRFileNotFound:
        raise
    except InvalidSpectralImage as exc:
        raise InvalidSpectralImage(f"{exc} (an albedo texture is read from the reflective "
                                   "layer, T.<λ> channels)") from None
    _check_reflectance(image.values, f"{path}: reflective layer")
    return image


def read_reflectance_exr(path: str | Path, wavelengths: np.ndarray) -> np.ndarray:
    """Reflectance spectra (H, W, L) float32 of a spectral OpenEXR's reflective layer,
    resampled to ``wavelengths``, row 0 at the bottom.

    Each pixel is resampled by linear interpolation (``np.interp``). Outside the file's
    wavelength range the **end values are held**: a reflectance does not drop to zero
    beyond the measured range, and zeros there would darken and tint every texel wherever
    the CMFs are non-zero (a 400–700 nm file read onto 380–780 nm). A single-wavelength
    file is a constant spectrum.

    Raises
    ------
    ValueError
        (``formats.spectral_exr.InvalidSpectralImage``) for a file without a reflective
        layer (``T.<λ>`` channels), an unreadable or truncated file, or NaN/inf/negative
        samples (with their count); a missing file raises ``SpectralEXRFileNotFound``
        (a ValueError and a FileNotFoundError).
    """
    wl = spectra.check_wavelengths(wavelengths)
    image = _read_reflective(path)
    matrix = _resampling_matrix(np.asarray(image.wavelengths, dtype=np.float64), wl)
    height, width, count = image.values.shape
    flat = image.values.reshape(-1, count)
    out = np.empty((flat.shape[0], wl.size), dtype=np.float32)
    for begin in range(0, flat.shape[0], TEXELS_PER_BLOCK):
        block = slice(begin, begin + TEXELS_PER_BLOCK)
        out[block] = flat[block].astype(np.float64) @ matrix
    return out.reshape(height, width, wl.size)


def albedo_layers_from_spectral_exr(path: str | Path, wavelengths: np.ndarray,
                                    basis: np.ndarray | None = None) -> AlbedoLayers:
    """R̃ layers of a reflective spectral OpenEXR (Fichet et al. 2021 layout), its spectra
    resampled to ``wavelengths`` as :func:`read_reflectance_exr` does (end values held
    outside the file's range, never zero).

    The resampling and the CMF weighting are both linear, so they are applied as one
    matrix to the file's samples, without materialising the resampled spectra.
    """
    wl = spectra.check_wavelengths(wavelengths)
    basis_array = None if basis is None else np.asarray(basis, dtype=np.float64)
    kernel = _kernel(wl, basis_array)                                   # (L, m, 3)
    image = _read_reflective(path)
    matrix = _resampling_matrix(np.asarray(image.wavelengths, dtype=np.float64), wl)
    file_kernel = np.tensordot(matrix, kernel, axes=([1], [0]))        # (L_file, m, 3)
    layers = _apply(image.values, file_kernel)
    return AlbedoLayers(layers, wl.copy(), basis_array, f"spectral EXR {Path(path).name}")


# ----------------------------------------------------------------------------- sampling


def sample_layers(layers: np.ndarray, uv: np.ndarray,
                  weight_bits: int | None = None) -> np.ndarray:
    """Bilinearly filtered R̃ (N, m, 3) at texture coordinates ``uv`` (N, 2), in float64.

    The same arithmetic as a fragment shader filtering by hand with ``texelFetch``
    (``glsl/prt/prt_frag.glsl``): ``s = u·W − ½``, ``t = v·H − ½``; the four texels around
    ``(⌊s⌋, ⌊t⌋)`` wrapped with REPEAT in both directions, weighted by the fractions.
    ``weight_bits`` rounds the fractions to that many bits, as a texture unit filtering
    in hardware does (``brdf.filtered_factors.HARDWARE_WEIGHT_BITS`` says which; None:
    exact, as llvmpipe and the hand filter).
    Texel ``(i, j)`` has its centre at ``((i + ½)/W, (j + ½)/H)``; row ``j = 0`` is ``v``
    near 0 (OpenGL: the first row uploaded is the bottom).

    Parameters
    ----------
    layers : array (m, H, W, 3)
        e.g. :attr:`AlbedoLayers.layers`.
    uv : array (N, 2) (or (..., 2), giving (..., m, 3))
        Finite texture coordinates; any real values (REPEAT wraps them).

    Raises
    ------
    ValueError
        Wrong shapes or non-finite ``uv`` (with their count).
    """
    layers = np.asarray(layers)
    if layers.ndim != 4 or layers.shape[3] != 3 or 0 in layers.shape:
        raise ValueError(f"layers must be (m, H, W, 3), got {layers.shape}")
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim < 1 or uv.shape[-1] != 2:
        raise ValueError(f"uv must be (N, 2), got {uv.shape}")
    bad = int(np.count_nonzero(~np.isfinite(uv)))
    if bad:
        raise ValueError(f"uv has {bad} non-finite (NaN/inf) values")
    _, height, width, _ = layers.shape
    flat = uv.reshape(-1, 2)
    s = flat[:, 0] * width - 0.5
    t = flat[:, 1] * height - 0.5
    s0, t0 = np.floor(s), np.floor(t)
    fs, ft = (s - s0)[:, None, None], (t - t0)[:, None, None]
    if weight_bits is not None:
        if isinstance(weight_bits, bool) or not 1 <= int(weight_bits) <= 23:
            raise ValueError(f"weight_bits must be 1..23 or None, got {weight_bits!r}")
        steps = float(1 << int(weight_bits))
        fs, ft = np.floor(fs * steps + 0.5) / steps, np.floor(ft * steps + 0.5) / steps
    # Wrap in floating point first so that huge coordinates cannot overflow an integer.
    i0 = np.mod(s0, width).astype(np.int64) % width
    j0 = np.mod(t0, height).astype(np.int64) % height
    i1, j1 = (i0 + 1) % width, (j0 + 1) % height

    def texel(j, i):
        return layers[:, j, i, :].transpose(1, 0, 2).astype(np.float64)     # (N, m, 3)

    out = ((1.0 - fs) * (1.0 - ft) * texel(j0, i0) + fs * (1.0 - ft) * texel(j0, i1)
           + (1.0 - fs) * ft * texel(j1, i0) + fs * ft * texel(j1, i1))
    return out.reshape(uv.shape[:-1] + out.shape[1:])


def packed_layer_count(m: int) -> int:
    """RGBA layers that hold m coefficients' X, Y, Z packed four to a texel: ⌈3m/4⌉
    (:func:`layers_to_rgba`)."""
    return -(-3 * int(m) // 4)


def layers_to_rgba(layers: np.ndarray) -> np.ndarray:
    """The albedo layers packed four values to a texel: (⌈3m/4⌉, H, W, 4) float32.

    A texel's 3m values R̃_j (m coefficients × X, Y, Z) are laid out in order,
    ``q = 3j + c``, value q going to component ``q % 4`` of layer ``q // 4``; the last
    layer is padded with zeros. The shader then filters ⌈3m/4⌉ layers instead of m RGB
    layers each padded to RGBA (``glsl/prt/prt_frag.glsl``): 24 texel fetches per pixel
    instead of 32 at m = 8 (issue 19). :func:`rgba_to_layers` undoes it.

    Parameters
    ----------
    layers : array (m, H, W, 3)
        e.g. :attr:`AlbedoLayers.layers`.
    """
    layers = np.asarray(layers)
    if layers.ndim != 4 or layers.shape[3] != 3 or 0 in layers.shape:
        raise ValueError(f"layers must be (m, H, W, 3), got {layers.shape}")
    m, height, width, _ = layers.shape
    count = packed_layer_count(m)
    flat = np.zeros((height, width, 4 * count), dtype=np.float32)
    flat[..., : 3 * m] = layers.transpose(1, 2, 0, 3).reshape(height, width, 3 * m)
    return np.ascontiguousarray(flat.reshape(height, width, count, 4).transpose(2, 0, 1, 3))


def wrap_padded(rgba: np.ndarray) -> np.ndarray:
    """(L, H + 2, W + 2, 4): texels (L, H, W, 4) with one texel of wrap padding on every
    side (the opposite edge's texels), so that a texture unit filtering with clamped
    coordinates blends across the wrap exactly as REPEAT does, with no sampler setting
    (Blender 4.5 and 5.0 have none). The shader maps ``uv`` to
    ``(fract(uv)·(W, H) + 1) / (W + 2, H + 2)`` (``glsl/prt/prt_frag.glsl``)."""
    rgba = np.asarray(rgba)
    if rgba.ndim != 4 or 0 in rgba.shape:
        raise ValueError(f"texels must be (layers, H, W, 4), got {rgba.shape}")
    return np.ascontiguousarray(np.pad(rgba, ((0, 0), (1, 1), (1, 1), (0, 0)), mode="wrap"))


def rgba_to_layers(packed: np.ndarray, m: int) -> np.ndarray:
    """(m, H, W, 3) from :func:`layers_to_rgba`'s (⌈3m/4⌉, H, W, 4)."""
    packed = np.asarray(packed)
    count, height, width, depth = packed.shape
    if depth != 4 or count != packed_layer_count(m):
        raise ValueError(f"{packed.shape} is not {m} packed layers")
    flat = packed.transpose(1, 2, 0, 3).reshape(height, width, 4 * count)[..., : 3 * m]
    return flat.reshape(height, width, m, 3).transpose(2, 0, 1, 3)


# -------------------------------------------------------------------------------- basis


def prt_basis(albedos: np.ndarray, illuminants: Sequence[str | np.ndarray],
              wavelengths: np.ndarray, count: int) -> np.ndarray:
    """The spectral basis (L, count) of a spectral PRT scene: Peercy's linear model.

    What enters, and why: spectral PRT evaluates ``∫ R(λ) L(λ) dλ`` as ``Σ_j R̂_j L̂_j`` with
    ``R = albedo · m̄ · Δλ / π`` (three spectra per albedo, one per CMF: exactly the
    vectors :func:`prt.albedo_weights` projects) and ``L`` the environment's radiance
    spectra. With an orthonormal basis Ψ and the projector ``P = ΨΨᵀ``,
    ``⟨PR, PL⟩ = ⟨R, PL⟩ = ⟨PR, L⟩``: the sum is exact as soon as **either** factor lies
    in the span. So the SVD (:func:`basis.linear_model_basis`, every spectrum scaled to
    unit norm) runs over the albedo × CMF products and the illuminant SPDs together, as
    the paper builds its basis from "all spectral reflectance maps and all potential
    environment maps".

    Parameters
    ----------
    albedos : array (A, L) or (L,)
        Representative reflectance spectra of the scene (e.g. a subsample of each
        texture), finite and non-negative.
    illuminants : sequence of str or array (L,)
        CIE illuminant names or SPDs on ``wavelengths`` (e.g. spectra of the environment
        map); may be empty.
    wavelengths : array (L,)
    count : int
        ≥ 1. ``count ≥ L`` returns the identity (an orthonormal basis of the whole space:
        exact); when the inputs span fewer than ``count`` dimensions, Peercy's vectors
        come first and an orthonormal complement fills the rest.

    Returns
    -------
    ndarray (L, min(count, L))
        Orthonormal columns (``Ψᵀ Ψ = I``).
    """
    from ..colour import basis as linear_basis
    from ..colour.pipeline import illuminant_spd

    wl = spectra.check_wavelengths(wavelengths)
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise ValueError(f"basis count must be an integer ≥ 1, got {count!r}")
    albedos = np.asarray(albedos, dtype=np.float64)
    if albedos.ndim == 1:
        albedos = albedos[None]
    if albedos.ndim != 2 or albedos.shape[1] != wl.size:
        raise ValueError(f"albedos must be (A, {wl.size}), got {albedos.shape}")
    _check_reflectance(albedos, "albedos")
    products = [prt.albedo_weights(a, wl).T for a in albedos]          # 3 rows per albedo
    rows = np.concatenate(products) if products else np.zeros((0, wl.size))
    lights = np.array([illuminant_spd(light, wl) for light in illuminants]).reshape(-1, wl.size)
    if count >= wl.size:
        return np.eye(wl.size)
    if not np.any(rows) and not np.any(lights):
        raise ValueError("the albedos and illuminants are all zero: no spectra to build a "
                         "basis from")
    # linear_model_basis returns at most min(L, non-zero input spectra) vectors.
    nonzero = int(np.count_nonzero(np.linalg.norm(rows, axis=1) > 0)) + \
        int(np.count_nonzero(np.linalg.norm(lights, axis=1) > 0))
    model = linear_basis.linear_model_basis(wl, rows, lights if len(lights) else None,
                                            count=min(int(count), nonzero, wl.size))
    vectors = model.vectors
    if vectors.shape[1] < count:
        # Complete with an orthonormal complement: the extra vectors cannot hurt exactness.
        q, _ = np.linalg.qr(np.concatenate([vectors, np.eye(wl.size)], axis=1))
        extra = q[:, vectors.shape[1]:count]
        vectors = np.concatenate([vectors, extra], axis=1)
    return vectors

