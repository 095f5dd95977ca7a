"""The scene's spectral basis: leave out what the scene does not need.

Peercy's linear model (:mod:`.basis`) is built from exactly the spectra one
scene needs, its materials' reflectance spectra and its lights' SPD × CMF
products, and then cut to the smallest size ``m`` whose colours are
indistinguishable from the 5 nm point-sampled ones for *every* light ×
material pair of the scene (Schwenk et al. 2010, §3.5).

Colour through the basis is the factor-pack paper's coefficient dot product
(eq. 9): ``XYZ = (Ψᵀ R) · (Ψᵀ W)`` with ``W`` the protocol-normalised light ×
CMF weights (:func:`.colour_pipeline.xyz_weights`); the reference is the full
``XYZ = Σ_λ R·W``. The error is ΔE94 in CIELAB relative to the white
Lambertian under that light (:func:`.colour_pipeline.white_xyz`), as
``shared/PROTOCOL.md`` measures it.

Since the SVD bases are nested (the size-``m`` basis is the first ``m``
columns of any larger one), one SVD serves every size, and the colours of all
sizes follow from one cumulative sum over the coefficient products.

References
----------
Peercy, M. S. (1993). Linear color representations for full speed spectral
rendering. SIGGRAPH '93, 191–198.
Schwenk, K., Kuijper, A., Bockholt, U. (2010). Modeling wavelength-dependent
BRDFs as factored tensors for real-time spectral rendering. GRAPP 2010, §3.5.
CIE 116-1995 (CIE94 colour difference).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from colour.difference import delta_E_CIE1994

from ..progress import ProgressCallback, report
from . import pipeline as colour_pipeline, spectra
from .basis import LinearModelBasis, light_cmf_spectra, linear_model_basis

#: The fixed basis size the factor-pack paper uses for every scene (Schwenk et
#: al. 2010, §3.5 and §4.2: "we didn't need more than 8 coefficients").
DEFAULT_SIZE = 8

#: Default ΔE94 tolerance: far below the protocol's "invisible" 1.
DEFAULT_TOLERANCE_DE94 = 0.05

#: Default largest basis size tried.
DEFAULT_MAX_SIZE = 16

#: Upper bound on the number of XYZ values (spectra × sizes) held at once.
_CHUNK_VALUES = 1 << 18


@dataclass
class SceneBasisChoice:
    """The spectral basis chosen for a scene, with its error curve.

    Attributes
    ----------
    basis : LinearModelBasis
        The chosen basis, ``size`` orthonormal vectors.
    size : int
        ``m``, the number of coefficients per spectrum.
    full_size : int
        The size a fixed default would use: :data:`DEFAULT_SIZE` (8, the
        factor-pack paper's size for every scene), or fewer where the scene has
        fewer independent spectra. (The other fixed rule, the count reaching a
        1e-3 relative projection error, is close to full rank for any real
        scene, e.g. 31 of 33 for the ColorChecker under D65, FL2 and A.)
    max_de94 : float
        The worst ΔE94 at ``size`` over every light × material pair and every
        spectrum of the material.
    worst_pair : tuple[str, str]
        ``(light name, material name)`` giving ``max_de94``.
    per_size : list of dict
        For every size tried, ``m = 1 .. min(max_size, available)``:
        ``{"size": m, "max_de94": ..., "mean_de94": ...}``, max and mean over
        all lights × spectra. Not necessarily monotone (see
        :func:`choose_scene_basis`).
    pairs : list of dict
        At ``size``, one per (light, material), lights outermost:
        ``{"light", "material", "spectra", "max_de94", "mean_de94"}``.
    met : bool
        Whether ``max_de94 <= tolerance_de94``. When even the largest size
        tried misses, ``size`` is that largest size and ``met`` is False.
    """

    basis: LinearModelBasis
    size: int
    full_size: int
    max_de94: float
    worst_pair: tuple[str, str]
    per_size: list[dict]
    pairs: list[dict]
    met: bool


def lambertian_spectra(albedo: np.ndarray) -> np.ndarray:
    """``f·cosθi`` of Lambertian surfaces of albedo ``albedo (..., L)`` at normal incidence: ρ/π.

    The form in which :func:`choose_scene_basis` takes a material known only by
    its albedo (the protocol's white Lambertian, ρ = 1, then reflects Y = 1).
    """
    return np.asarray(albedo, dtype=np.float64) / np.pi


def _name(key) -> str:
    return key if isinstance(key, str) else str(key)


def _check_materials(materials: Mapping, size: int) -> tuple[list[str], list[np.ndarray]]:
    if not isinstance(materials, Mapping):
        raise TypeError(f"materials must be a mapping name → spectra, "
                        f"got {type(materials).__name__}")
    if len(materials) == 0:
        raise ValueError("no materials")
    names, blocks = [], []
    for key, value in materials.items():
        name = _name(key)
        values = np.asarray(value, dtype=np.float64)
        if values.ndim == 1:
            values = values[None, :]
        if values.ndim != 2:
            raise ValueError(f"material {name!r}: spectra must be (K, L) or (L,), got shape "
                             f"{values.shape}; reshape n-dimensional tables to (-1, L)")
        if values.shape[1] != size:
            raise ValueError(f"material {name!r}: spectra have {values.shape[1]} samples, "
                             f"the wavelength grid {size}")
        if values.shape[0] == 0:
            raise ValueError(f"material {name!r} has no spectra")
        bad = int((~np.isfinite(values)).sum())
        if bad:
            raise ValueError(f"material {name!r} has {bad} non-finite (NaN or inf) values")
        if np.any(values < 0):
            raise ValueError(f"material {name!r} has negative reflectance values "
                             f"(min {values.min():.3g})")
        names.append(name)
        blocks.append(values)
    if len(set(names)) != len(names):
        raise ValueError("material names must be distinct as strings")
    return names, blocks


def _check_lights(lights: Mapping, wl: np.ndarray) -> tuple[list[str], list[np.ndarray]]:
    if not isinstance(lights, Mapping):
        raise TypeError(f"lights must be a mapping name → SPD, got {type(lights).__name__}")
    if len(lights) == 0:
        raise ValueError("no lights")
    names, spds = [], []
    for key, value in lights.items():
        name = _name(key)
        if isinstance(value, str):
            try:
                spd = spectra.illuminant(value, wl)
            except ValueError as error:
                raise ValueError(f"light {name!r}: {error}") from None
        else:
            spd = np.asarray(value, dtype=np.float64)
            if spd.shape != wl.shape:
                raise ValueError(f"light {name!r}: SPD has shape {spd.shape}, expected "
                                 f"{wl.shape} (one value per wavelength)")
            bad = int((~np.isfinite(spd)).sum())
            if bad:
                raise ValueError(f"light {name!r}: SPD has {bad} non-finite (NaN or inf) values")
            if np.any(spd < 0):
                raise ValueError(f"light {name!r}: SPD has negative values (min {spd.min():.3g})")
        names.append(name)
        spds.append(spd)
    if len(set(names)) != len(names):
        raise ValueError("light names must be distinct as strings")
    return names, spds


def _light_weights(light_names: list[str], spds: list[np.ndarray], wl: np.ndarray,
                   observer: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """Each light's XYZ weights (J, L, 3) and white point, naming the light at fault."""
    weights, whites = [], []
    for name, spd in zip(light_names, spds, strict=True):
        try:
            weights.append(colour_pipeline.xyz_weights(spd, wl, observer=observer))
        except ValueError as error:
            raise ValueError(f"light {name!r}: {error}") from None
        whites.append(colour_pipeline.white_xyz(spd, wl, observer=observer))
    return np.stack(weights), whites


def _pair_errors(coefficients: np.ndarray, light_coefficients: np.ndarray,
                 reference_lab: np.ndarray, whites: list[np.ndarray],
                 material_index: np.ndarray, n_materials: int, top: int,
                 callback: ProgressCallback | None) -> tuple[np.ndarray, np.ndarray]:
    """Max and sum of ΔE94 per (light, material, basis size), over spectra in chunks of
    about :data:`_CHUNK_VALUES` values (chunks may span material boundaries)."""
    n_lights = light_coefficients.shape[0]
    pair_max = np.zeros((n_lights, n_materials, top))
    pair_sum = np.zeros((n_lights, n_materials, top))
    total = coefficients.shape[0]
    chunk = max(1, _CHUNK_VALUES // top)
    for start in range(0, total, chunk):
        stop = min(total, start + chunk)
        ids = material_index[start:stop]
        segments = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
        present = ids[segments]
        a = coefficients[start:stop]
        for j in range(n_lights):
            # XYZ at every size m: the partial sums of the eq. 9 products, (n, M, 3).
            xyz = np.cumsum(a[:, :, None] * light_coefficients[j][None], axis=1)
            lab = colour_pipeline.xyz_to_lab(xyz, whites[j])
            de = delta_E_CIE1994(np.broadcast_to(reference_lab[j, start:stop, None, :],
                                                 lab.shape), lab)           # (n, M)
            pair_max[j, present] = np.maximum(pair_max[j, present],
                                              np.maximum.reduceat(de, segments, axis=0))
            pair_sum[j, present] += np.add.reduceat(de, segments, axis=0)
        report(callback, 0.1 + 0.85 * stop / total,
               f"scene basis: ΔE94 of {stop} of {total} spectra")
    return pair_max, pair_sum


def choose_scene_basis(
    materials: Mapping[str, np.ndarray],
    lights: Mapping[str, np.ndarray | str],
    wavelengths: np.ndarray,
    *,
    tolerance_de94: float = DEFAULT_TOLERANCE_DE94,
    max_size: int = DEFAULT_MAX_SIZE,
    observer: str = spectra.OBSERVER,
    callback: ProgressCallback | None = None,
) -> SceneBasisChoice:
    """The smallest Peercy basis of the scene's own spectra that meets a ΔE94 tolerance.

    Parameters
    ----------
    materials : mapping name → ndarray (K, L) or (L,)
        Each material's reflectance spectra as ``f·cosθi`` (BRDF times cosine,
        so that a white Lambertian at normal incidence is 1/π): spectra sampled
        every 10° (:func:`.factor.sample_brdf_spectra`), or just its albedo ρ
        as :func:`lambertian_spectra` ``(ρ) = ρ/π``. Finite and non-negative.
    lights : mapping name → ndarray (L,) or str
        Each light's SPD on ``wavelengths`` (any scale; the protocol normalises
        it), or a CIE illuminant name (``"D65"``, ``"FL2"``, …).
    wavelengths : ndarray (L,)
        nm, the grid of every spectrum (the protocol's is 5 nm, 380–780 nm).
    tolerance_de94 : float
        Largest ΔE94 allowed for any light × spectrum, > 0.
    max_size : int
        Largest basis size tried, ≥ 1. Capped at the number of independent
        input spectra available (``min(L, nonzero spectra)``).
    observer : str
        Colour matching functions (see :func:`.spectra.cmfs`).
    callback : callable, optional
        ``callback(fraction, message) -> stop?``; a true return raises
        :class:`.errors.Cancelled`.

    Returns
    -------
    SceneBasisChoice

    Notes
    -----
    The basis is the SVD of all the scene's reflectance spectra and its
    lights × (x̄, ȳ, z̄), each scaled to unit norm (:func:`.basis.linear_model_basis`);
    the protocol's fixed light set does not enter. The chosen size is the
    smallest ``m`` with ``max ΔE94 <= tolerance_de94``.

    The per-spectrum XYZ error ``R (I − P_m) W = ((I − P_m) R) · ((I − P_m) W)``
    is bounded by ``‖(I − P_m) R‖ ‖(I − P_m) W‖``, which never grows with ``m``
    (nested subspaces), and vanishes once the basis spans every input. The
    error itself can grow from one size to the next (the discarded terms of
    the dot product can cancel), so ΔE94 over ``m`` is not guaranteed
    monotone; every size is evaluated and the smallest one meeting the
    tolerance is taken.

    References
    ----------
    Schwenk et al. (2010), §3.5, eq. 9; Peercy (1993).
    """
    wl = spectra.check_wavelengths(wavelengths)
    if not (np.isfinite(tolerance_de94) and tolerance_de94 > 0):
        raise ValueError(f"tolerance_de94 must be a finite number > 0, got {tolerance_de94}")
    if isinstance(max_size, bool) or not isinstance(max_size, int | np.integer) or max_size < 1:
        raise ValueError(f"max_size must be an integer >= 1, got {max_size!r}")
    observer = spectra.observer_name(observer)
    material_names, blocks = _check_materials(materials, wl.size)
    light_names, spds = _check_lights(lights, wl)
    report(callback, 0.0, "scene basis: spectra checked")

    reflectances = np.concatenate(blocks, axis=0)                      # (N, L)
    counts = np.array([b.shape[0] for b in blocks])
    weights, whites = _light_weights(light_names, spds, wl, observer)   # (J, L, 3), J × (3,)
    light_cmf = light_cmf_spectra(spds, wl, observer=observer)          # (3J, L)

    inputs = np.concatenate([reflectances, light_cmf], axis=0)
    available = min(wl.size, int(np.count_nonzero(np.linalg.norm(inputs, axis=1) > 0)))
    top = min(int(max_size), available)
    full = linear_model_basis(wl, reflectances, light_cmf, count=top)
    psi = full.vectors                                                 # (L, M)
    report(callback, 0.1, f"scene basis: SVD of {inputs.shape[0]} spectra")

    n_lights, n_materials = len(light_names), len(material_names)
    coefficients = reflectances @ psi                                  # (N, M)
    light_coefficients = psi.T @ weights                  # (J, M, 3): xyz_weights(..., basis=psi)
    reference = reflectances @ weights                    # (J, N, 3): the full 5 nm Σ_λ R·W
    reference_lab = np.stack([colour_pipeline.xyz_to_lab(reference[j], whites[j])
                              for j in range(n_lights)])
    material_index = np.repeat(np.arange(n_materials), counts)
    pair_max, pair_sum = _pair_errors(coefficients, light_coefficients, reference_lab, whites,
                                      material_index, n_materials, top, callback)
    total = reflectances.shape[0]

    size_max = pair_max.max(axis=(0, 1))                               # (M,)
    size_mean = pair_sum.sum(axis=(0, 1)) / (n_lights * total)
    meeting = np.flatnonzero(size_max <= tolerance_de94)
    met = meeting.size > 0
    index = int(meeting[0]) if met else top - 1
    worst = np.unravel_index(int(np.argmax(pair_max[:, :, index])), (n_lights, n_materials))
    pairs = [
        {"light": light_names[j], "material": material_names[i], "spectra": int(counts[i]),
         "max_de94": float(pair_max[j, i, index]),
         "mean_de94": float(pair_sum[j, i, index] / counts[i])}
        for j in range(n_lights) for i in range(n_materials)
    ]
    per_size = [{"size": k + 1, "max_de94": float(size_max[k]), "mean_de94": float(size_mean[k])}
                for k in range(top)]
    basis = LinearModelBasis(wavelengths=full.wavelengths, vectors=psi[:, :index + 1].copy(),
                             singular_values=full.singular_values)
    report(callback, 1.0, f"scene basis: {index + 1} coefficients")
    return SceneBasisChoice(
        basis=basis,
        size=index + 1,
        full_size=min(DEFAULT_SIZE, available),
        max_de94=float(size_max[index]),
        worst_pair=(light_names[worst[0]], material_names[worst[1]]),
        per_size=per_size,
        pairs=pairs,
        met=bool(met),
    )


def describe_choice(choice: SceneBasisChoice) -> str:
    """One line for a panel or log, e.g. ``"basis 5 of 8 coefficients, max ΔE94 0.031 (FL2 ×
    Paint)"``."""
    if choice.size <= choice.full_size:
        size = f"basis {choice.size} of {choice.full_size} coefficients"
    else:
        size = f"basis {choice.size} coefficients (default {choice.full_size})"
    light, material = choice.worst_pair
    line = f"{size}, max ΔE94 {choice.max_de94:.2g} ({light} × {material})"
    return line if choice.met else line + ", tolerance not met"
