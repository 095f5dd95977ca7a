"""RGB → spectrum uplift: Smits (1999) and Jakob & Hanika (2019), with the Jakob LUT cache.

Measured RGB data (MERL files, RGB RGL files, RGB BTFs, environment maps, albedo
textures) becomes spectral through one of these callables
``uplift(rgb (N, 3), wavelengths) -> (N, L)``:

``"smits1999"``
    Smits (1999) via colour-science's basis spectra ``SDS_SMITS1999``. Smits'
    construction is ``min·white + (mid − min)·(cyan|magenta|yellow) +
    (max − mid)·(red|green|blue)``: positively homogeneous (``S(k·rgb) =
    k·S(rgb)``, k ≥ 0) and piecewise linear, so values above 1 need no special
    care. The seven basis spectra are resampled once per wavelength grid (linear,
    constant outside 380–720 nm, as colour-science's own distributions) and
    combined per sample, vectorised. Identical to
    ``colour.recovery.RGB_to_sd_Smits1999`` (tested). About 0.3 s for a
    whole MERL table on 61 wavelengths.
``"jakob2019"``
    Jakob & Hanika (2019) sigmoid-polynomial spectra via colour-science's
    ``LUT3D_Jakob2019`` (sRGB, D65, CIE 1931 2°). Generating a LUT is an
    optimisation per node (≈ size³ · 0.08 s: about 45 s for size 8, the default), so
    it is built once, kept in memory and cached on disk (see
    :func:`jakob2019_lut`); a LUT read from a published ``.coeff`` file (size
    64) can be passed instead. The Jakob model is *not* linear in brightness
    and holds reflectances in [0, 1]: the RGB of a BRDF value is uplifted as the
    reflectance-equivalent ``π·f`` (the albedo of a Lambertian surface with that
    value), scaled down to a maximum channel of 1 where brighter, and the
    spectrum is scaled back. Black samples give 0. About 2–3 s for a MERL table.

The Jakob LUTs are kept in memory per size and on disk under
``$SPECTRAL_MATERIALS_CACHE``, else ``$XDG_CACHE_HOME/spectral_materials``, else
``~/.cache/spectral_materials`` (:func:`jakob2019_lut`).
"""

from __future__ import annotations

import contextlib
import io
import math
import os
from pathlib import Path

import numpy as np

from . import spectra

__all__ = [
    "JAKOB2019_LUT_SIZE",
    "UPLIFTS",
    "Jakob2019Uplift",
    "SmitsUplift",
    "jakob2019_lut",
    "make_uplift",
]

#: Spectral uplift methods understood by :func:`make_uplift` (and ``merl.read_merl``).
UPLIFTS = ("smits1999", "jakob2019")
#: Default size of the generated Jakob 2019 LUT (nodes per side of the cube).
JAKOB2019_LUT_SIZE = 8


class SmitsUplift:
    """RGB → spectrum after Smits (1999), vectorised over samples (see the module notes)."""

    name = "smits1999"
    _ORDER = ("white", "cyan", "magenta", "yellow", "red", "green", "blue")

    def __init__(self) -> None:
        from colour.recovery import SDS_SMITS1999

        self._sds = [SDS_SMITS1999[k] for k in self._ORDER]
        self._cache: dict[tuple, np.ndarray] = {}

    def basis(self, wavelengths: np.ndarray) -> np.ndarray:
        """The 7 basis spectra (white, cyan, magenta, yellow, red, green, blue) → (7, L)."""
        wl = spectra.check_wavelengths(wavelengths)
        key = tuple(wl.tolist())
        if key not in self._cache:
            out = np.stack([np.interp(wl, sd.wavelengths, sd.values) for sd in self._sds])
            out.setflags(write=False)
            if len(self._cache) >= 16:
                self._cache.pop(next(iter(self._cache)))
            self._cache[key] = out
        return self._cache[key]

    @staticmethod
    def weights(rgb: np.ndarray) -> np.ndarray:
        """Basis weights ``(N, 7)`` of ``rgb (N, 3)``: min·white + (mid − min)·secondary +
        (max − mid)·primary, the secondary being the complement of the smallest channel."""
        rgb = np.asarray(rgb, dtype=np.float64)
        n = rgb.shape[0]
        lo_i = np.argmin(rgb, axis=1)
        hi_i = np.argmax(rgb, axis=1)
        lo = rgb[np.arange(n), lo_i]
        hi = rgb[np.arange(n), hi_i]
        mid = rgb.sum(axis=1) - lo - hi
        w = np.zeros((n, 7))
        w[:, 0] = lo
        rows = np.arange(n)
        w[rows, 1 + lo_i] = mid - lo  # cyan if R is smallest, magenta if G, yellow if B
        w[rows, 4 + hi_i] += hi - mid  # red, green or blue for the largest channel
        return w

    def __call__(self, rgb: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
        """Spectra ``(N, L)`` of ``rgb (N, 3)`` (negative channels are taken as 0)."""
        rgb = np.maximum(np.asarray(rgb, dtype=np.float64).reshape(-1, 3), 0.0)
        return self.weights(rgb) @ self.basis(wavelengths)


_LUTS: dict[int, object] = {}


def _cache_dir() -> Path:
    base = os.environ.get("SPECTRAL_MATERIALS_CACHE")
    if base:
        return Path(base)
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(xdg) / "spectral_materials"


def jakob2019_lut(size: int = JAKOB2019_LUT_SIZE, cache_dir: str | Path | None = None,
                  *, use_disk: bool = True):
    """A ``colour.recovery.LUT3D_Jakob2019`` for linear sRGB (D65, CIE 1931 2°).

    Kept in memory per size; with ``use_disk`` also read from / written to
    ``cache_dir/jakob2019_srgb_<size>.coeff`` (default directory:
    ``$SPECTRAL_MATERIALS_CACHE``, else ``$XDG_CACHE_HOME/spectral_materials``,
    else ``~/.cache/spectral_materials``). Generating costs about
    ``size³ · 0.08 s`` single-threaded (size 3: 2 s, 6: 18 s, 8: ≈ 45 s).
    """
    from colour.models import RGB_COLOURSPACE_sRGB
    from colour.recovery import LUT3D_Jakob2019

    size = int(size)
    if size < 2:
        raise ValueError(f"Jakob 2019 LUT size must be >= 2, got {size}")
    if size in _LUTS:
        return _LUTS[size]
    path = Path(cache_dir or _cache_dir()) / f"jakob2019_srgb_{size}.coeff"
    lut = LUT3D_Jakob2019()
    loaded = False
    if use_disk and path.is_file():
        try:
            lut.read(path)
            loaded = lut.size == size
        except Exception:  # a damaged cache file is regenerated
            loaded = False
    if not loaded:
        lut = LUT3D_Jakob2019()
        with contextlib.redirect_stderr(io.StringIO()):  # silence tqdm
            lut.generate(RGB_COLOURSPACE_sRGB, size=size, print_callable=lambda *a, **k: None)
        if use_disk:
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
                lut.write(tmp)
                os.replace(tmp, path)
            except OSError:
                pass
    _LUTS[size] = lut
    return lut


class Jakob2019Uplift:
    """RGB → spectrum after Jakob & Hanika (2019) through a coefficient LUT.

    ``lut`` is a ``LUT3D_Jakob2019`` (generated or read); ``None`` uses
    :func:`jakob2019_lut` with its defaults, built on first use.
    """

    name = "jakob2019"

    def __init__(self, lut=None) -> None:
        self._lut = lut

    @property
    def lut(self):
        if self._lut is None:
            self._lut = jakob2019_lut()
        return self._lut

    def coefficients(self, reflectance_rgb: np.ndarray) -> np.ndarray:
        """Coefficients ``(N, 3)`` (c0 λ² + c1 λ + c2, λ in nm) of RGB in [0, 1]."""
        rgb = np.asarray(reflectance_rgb, dtype=np.float64).reshape(-1, 3)
        if rgb.shape[0] == 0:
            return np.zeros((0, 3))
        return np.asarray(self.lut.RGB_to_coefficients(rgb), dtype=np.float64).reshape(-1, 3)

    def __call__(self, rgb: np.ndarray, wavelengths: np.ndarray) -> np.ndarray:
        """Spectra ``(N, L)`` of BRDF values ``rgb (N, 3)`` (sr⁻¹; see the module notes)."""
        wl = spectra.check_wavelengths(wavelengths)
        rgb = np.maximum(np.asarray(rgb, dtype=np.float64).reshape(-1, 3), 0.0)
        refl = math.pi * rgb
        peak = refl.max(axis=1)
        scale = np.maximum(peak, 1.0)
        c = self.coefficients(refl / scale[:, None])
        u = (c[:, 0:1] * wl + c[:, 1:2]) * wl + c[:, 2:3]
        r = 0.5 + u / (2.0 * np.sqrt(1.0 + u * u))
        r *= (scale / math.pi)[:, None]
        r[peak <= 0.0] = 0.0
        return r


def make_uplift(uplift, jakob_lut=None):
    """The uplift named ``uplift`` (``"smits1999"`` or ``"jakob2019"``), or ``uplift`` itself
    when it is already a callable ``uplift(rgb (N, 3), wavelengths) -> (N, L)``."""
    if callable(uplift) and not isinstance(uplift, str):
        return uplift
    key = str(uplift).strip().lower()
    if key == "smits1999":
        return SmitsUplift()
    if key == "jakob2019":
        return Jakob2019Uplift(jakob_lut)
    raise ValueError(f"unknown uplift {uplift!r}; choose one of {', '.join(UPLIFTS)}")
