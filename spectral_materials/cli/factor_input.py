"""What ``factor`` factors: an analytic model built from ``--param`` and the spectrum options,
or a tabulated ``.npz`` file; and the ``SPEC`` syntax of a spectrum option."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np

from .common import Progress, UsageError

#: Model parameters that take a spectrum (a SPEC) rather than a number.
SPECTRAL_KEYS = ("albedo", "diffuse", "specular", "ior_n", "ior_k")

#: Spectrum option → the model parameters it may fill, the first one the model has.
_SPECTRUM_OPTIONS = {
    "albedo": ("albedo", "diffuse"),
    "diffuse": ("diffuse", "albedo"),
    "specular": ("specular",),
    "ior_n": ("ior_n",),
    "ior_k": ("ior_k",),
}


def parse_spectrum(text: str):
    """``patch:N`` (ColorChecker, 1-based, or a patch name), a number, or ``csv:PATH``.

    Returns a :data:`~spectral_materials.core.colour.spectra.SpectrumLike`.
    """
    from ..core.colour import spectra

    text = str(text).strip()
    kind, sep, rest = text.partition(":")
    if sep and kind.lower() == "patch":
        rest = rest.strip()
        try:
            patch: int | str = int(rest)
        except ValueError:
            patch = rest
        try:
            return spectra.colorchecker_spectrum(patch)
        except (ValueError, KeyError) as exc:
            raise UsageError(f"spectrum {text!r}: {exc}") from None
    if sep and kind.lower() == "csv":
        return read_spectrum_csv(rest)
    try:
        value = float(text)
    except ValueError:
        raise UsageError(f"spectrum {text!r}: expected patch:N (ColorChecker 1..24), a number "
                         "or csv:PATH") from None
    if not np.isfinite(value):
        raise UsageError(f"spectrum {text!r} is not finite")
    return value


def read_spectrum_csv(path: str) -> tuple[np.ndarray, np.ndarray]:
    """The add-on's reader (:func:`~..core.colour.spectrum_library.read_spectrum_csv`:
    two columns ``wavelength_nm,value``, headers, comments, decimal commas, UTF-16,
    reversed files, size and value limits), its errors as :class:`UsageError`."""
    from ..core.colour.spectrum_library import SpectrumFileError, read_spectrum_csv as read

    try:
        return read(path)
    except SpectrumFileError as exc:
        raise UsageError(f"csv spectrum: {exc}") from None


class _Keywords:
    """A model's constructor keywords gathered from several options, each key at most once."""

    def __init__(self, model: str):
        self.model = model
        self.values: dict = {}
        self.sources: dict = {}

    def put(self, key: str, value, source: str) -> None:
        if key in self.values:
            raise UsageError(f"{self.model}: {key} given twice ({self.sources[key]} and "
                             f"{source})")
        self.values[key] = value
        self.sources[key] = source


def _put_params(keywords: _Keywords, items: list[str], accepted: list[str]) -> None:
    """``--param KEY=VALUE``: a number, or a SPEC for the spectral keys."""
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip().lower().replace("-", "_")
        if not sep or not key:
            raise UsageError(f"--param {item!r}: expected KEY=VALUE")
        if key not in accepted:
            raise UsageError(f"{keywords.model} has no parameter {key!r}; its parameters: "
                             f"{', '.join(accepted)}")
        if key in SPECTRAL_KEYS:
            keywords.put(key, parse_spectrum(value), f"--param {key}")
            continue
        try:
            number = float(value)
        except ValueError:
            raise UsageError(f"--param {key}={value}: not a number") from None
        keywords.put(key, number, f"--param {key}")


def _put_spectrum_options(keywords: _Keywords, args, accepted: list[str]) -> None:
    """``--diffuse``, ``--specular``, ``--albedo``, ``--ior-n``, ``--ior-k``."""
    for option, targets in _SPECTRUM_OPTIONS.items():
        text = getattr(args, option, None)
        if text is None:
            continue
        flag = "--" + option.replace("_", "-")
        target = next((t for t in targets if t in accepted), None)
        if target is None:
            spectral = [k for k in accepted if k in SPECTRAL_KEYS]
            raise UsageError(f"{keywords.model} has no {option.replace('_', ' ')} spectrum "
                             f"({flag}); its spectra: {', '.join(spectral) or 'none'}")
        keywords.put(target, parse_spectrum(text), flag)


def model_kwargs(cls, args) -> dict:
    """Constructor keywords of a model class from --param and the spectrum options."""
    accepted = [name for name, p in inspect.signature(cls.__init__).parameters.items()
                if name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    keywords = _Keywords(cls.name)
    _put_params(keywords, args.param or [], accepted)
    _put_spectrum_options(keywords, args, accepted)
    return keywords.values


def load_input(args, progress: Progress):
    """The BRDF callable named by MODEL_OR_FILE → ``(brdf, description dict, file or None)``."""
    from ..core.brdf import models
    from ..core.formats.tabulated import read_tabulated

    source = args.input
    key = source.strip().lower()
    if key in models.MODELS:
        cls = models.MODELS[key]
        try:
            brdf = cls(**model_kwargs(cls, args))
        except TypeError as exc:
            raise UsageError(f"{key}: {exc}") from None
        return brdf, brdf.describe(), None
    path = Path(source)
    if not path.exists() and path.suffix.lower() != ".npz":
        raise UsageError(f"unknown model {source!r}: choose one of {', '.join(models.MODELS)}, "
                         "or give the path of a tabulated .npz")
    used = [flag for flag, value in (("--param", args.param), ("--diffuse", args.diffuse),
                                     ("--specular", args.specular), ("--albedo", args.albedo),
                                     ("--ior-n", args.ior_n), ("--ior-k", args.ior_k))
            if value]
    if used:
        raise UsageError(f"{', '.join(used)} only apply to analytic models, not to a file")
    table = read_tabulated(path, on_invalid=args.on_invalid)
    if any(table.defects.get(k, 0) for k in ("nan", "inf", "negative")):
        d = table.defects
        progress.info(f"warning: {path}: set {d['nan']} NaN, {d['inf']} inf and "
                      f"{d['negative']} negative samples to 0; first at {d.get('first')}")
    return table, table.describe(), table
