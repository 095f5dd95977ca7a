"""Command line: ``python -m spectral_materials <command> ...``.

Commands
--------
``factor``
    Factor an analytic model or a tabulated ``.npz`` (see
    :mod:`spectral_materials.core.formats.tabulated`) into CP factor packs and
    print the protocol's error table: one row per pack count, and a final
    "table" row with the error of the tabulation itself (multilinear lookup of
    the grid, no factorisation), the floor no pack count can go below.

``render-sphere``
    Draw a saved :class:`~spectral_materials.core.brdf.factored.FactoredBRDF` on the
    protocol sphere (shared/PROTOCOL.md) through the GPU path (Blender's ``gpu``
    module, headless through EGL) and write linear CIE XYZ (channels X, Y, Z,
    float32), normalised as the protocol says, to an OpenEXR file; ``--png``
    also writes the display image (Bradford to D65, sRGB, sigmoid tone map).
    ``--engine eevee`` renders it with EEVEE through the material node group instead
    (Rec.2020 working space during the render), converted back to XYZ.

Exit status: 0 on success, 2 on a usage or data error (one line on stderr, no
traceback), 130 when interrupted with Ctrl-C (printed as "cancelled").

Progress goes to stderr: a ``\\r`` bar on a terminal, one line per stage
otherwise; ``--quiet`` turns it and the informational lines off. Ctrl-C makes
the progress callback return true, so the core stops at its next report and
raises ``Cancelled``; a second Ctrl-C interrupts at once.
"""

from __future__ import annotations

import argparse
import inspect
import json
import signal
import sys
import time
from pathlib import Path

import numpy as np

from .core.brdf.factored import json_default

PROG = "python -m spectral_materials"
EXIT_ERROR = 2
EXIT_CANCELLED = 130
DEFAULT_ILLUMINANTS = ("D65", "FL2")
SPECTRAL_KEYS = ("albedo", "diffuse", "specular", "ior_n", "ior_k")
PARAMETERIZATION_CHOICES = ("io", "hd", "gs", "ea", "io_iso", "hd_iso")
#: Direction pairs per chunk when measuring XYZ of a factored model.
_XYZ_CHUNK = 8192


class UsageError(ValueError):
    """A command-line mistake: reported on one line, exit status 2."""


# --------------------------------------------------------------------------- progress


class Progress:
    """The ``callback(fraction, message) -> stop?`` the core calls, drawing on stderr.

    On a terminal: a ``\\r`` progress bar, redrawn at most 10 times a second.
    Otherwise: one line each time the message changes. ``interrupted`` is set by
    the SIGINT handler; the callback then returns True and the core raises
    :class:`~spectral_materials.core.errors.Cancelled`.
    """

    WIDTH = 30

    def __init__(self, quiet: bool, stream=None):
        self.stream = sys.stderr if stream is None else stream
        self.quiet = quiet
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interrupted = False
        self._drawn_at = 0.0
        self._message = None
        self._line_length = 0

    def __call__(self, fraction: float, message: str) -> bool:
        if not self.quiet:
            self._draw(float(fraction), str(message))
        return self.interrupted

    def _draw(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if self.tty:
            if message == self._message and fraction < 1.0 and now - self._drawn_at < 0.1:
                return
            filled = int(round(self.WIDTH * min(max(fraction, 0.0), 1.0)))
            line = f"[{'#' * filled}{'.' * (self.WIDTH - filled)}] {100 * fraction:3.0f}% {message}"
            pad = max(0, self._line_length - len(line))
            self.stream.write("\r" + line + " " * pad)
            self._line_length = len(line)
        elif message != self._message:
            self.stream.write(f"{message}...\n")
        self.stream.flush()
        self._message = message
        self._drawn_at = now

    def clear(self) -> None:
        """End the bar's line (before other output)."""
        if self.tty and self._line_length:
            self.stream.write("\r" + " " * self._line_length + "\r")
            self.stream.flush()
        self._line_length = 0
        self._message = None

    def info(self, text: str) -> None:
        if not self.quiet:
            self.clear()
            print(text, file=self.stream, flush=True)

    def check(self) -> None:
        """Raise ``Cancelled`` between stages the core does not report on."""
        if self.interrupted:
            from .core.errors import Cancelled

            raise Cancelled("interrupted")


class _SigintHandler:
    """First Ctrl-C: ask the job to stop; the second one interrupts at once."""

    def __init__(self, progress: Progress):
        self.progress = progress
        self.previous = None

    def __enter__(self):
        try:
            self.previous = signal.signal(signal.SIGINT, self._handle)
        except ValueError:  # not the main thread: leave Ctrl-C alone
            self.previous = None
        return self

    def _handle(self, signum, frame):
        self.progress.interrupted = True
        signal.signal(signal.SIGINT, signal.default_int_handler)

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        return False


# --------------------------------------------------------------------------- parsing helpers


def parse_spectrum(text: str):
    """``patch:N`` (ColorChecker, 1-based, or a patch name), a number, or ``csv:PATH``.

    Returns a :data:`~spectral_materials.core.colour.spectra.SpectrumLike`.
    """
    from .core.colour import spectra

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
    """The add-on's reader (:func:`~.core.colour.spectrum_library.read_spectrum_csv`:
    two columns ``wavelength_nm,value``, headers, comments, decimal commas, UTF-16,
    reversed files, size and value limits), its errors as :class:`UsageError`."""
    from .core.colour.spectrum_library import SpectrumFileError
    from .core.colour.spectrum_library import read_spectrum_csv as read

    try:
        return read(path)
    except SpectrumFileError as exc:
        raise UsageError(f"csv spectrum: {exc}") from None


def _basis_arg(text: str):
    """``--basis``: an int (basis size), a float in (0, 1) (tolerance), or ``none``."""
    if text.strip().lower() in ("none", "off", "0"):
        return None
    try:
        size = int(text)
    except ValueError:
        pass
    else:
        if size < 1:
            raise argparse.ArgumentTypeError(f"basis size must be >= 1, got {size}")
        return size
    try:
        tol = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a basis size (int) or a tolerance in (0, 1), got {text!r}") from None
    if not 0.0 < tol < 1.0:
        raise argparse.ArgumentTypeError(f"basis tolerance must be in (0, 1), got {tol}")
    return tol


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _int_in(lo: int, hi: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"expected {lo}..{hi}, got {value}")
        return value
    return parse


# --------------------------------------------------------------------------- input


def _model_kwargs(cls, args) -> dict:
    """Constructor keywords of a model class from --param and the spectrum options."""
    accepted = [name for name, p in inspect.signature(cls.__init__).parameters.items()
                if name != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    name = cls.name
    kwargs: dict = {}
    sources: dict = {}

    def put(key: str, value, source: str) -> None:
        if key in kwargs:
            raise UsageError(f"{name}: {key} given twice ({sources[key]} and {source})")
        kwargs[key] = value
        sources[key] = source

    for item in args.param or []:
        key, sep, value = item.partition("=")
        key = key.strip().lower().replace("-", "_")
        if not sep or not key:
            raise UsageError(f"--param {item!r}: expected KEY=VALUE")
        if key not in accepted:
            raise UsageError(f"{name} has no parameter {key!r}; its parameters: "
                             f"{', '.join(accepted)}")
        if key in SPECTRAL_KEYS:
            put(key, parse_spectrum(value), f"--param {key}")
            continue
        try:
            number = float(value)
        except ValueError:
            raise UsageError(f"--param {key}={value}: not a number") from None
        put(key, number, f"--param {key}")

    aliases = {
        "albedo": ("albedo", "diffuse"),
        "diffuse": ("diffuse", "albedo"),
        "specular": ("specular",),
        "ior_n": ("ior_n",),
        "ior_k": ("ior_k",),
    }
    for option, targets in aliases.items():
        text = getattr(args, option, None)
        if text is None:
            continue
        flag = "--" + option.replace("_", "-")
        target = next((t for t in targets if t in accepted), None)
        if target is None:
            spectral = [k for k in accepted if k in SPECTRAL_KEYS]
            raise UsageError(f"{name} has no {option.replace('_', ' ')} spectrum ({flag}); its "
                             f"spectra: {', '.join(spectral) or 'none'}")
        put(target, parse_spectrum(text), flag)
    return kwargs


def load_input(args, progress: Progress):
    """The BRDF callable named by MODEL_OR_FILE → ``(brdf, description dict, file or None)``."""
    from .core.brdf import models
    from .core.formats.tabulated import read_tabulated

    source = args.input
    key = source.strip().lower()
    if key in models.MODELS:
        cls = models.MODELS[key]
        try:
            brdf = cls(**_model_kwargs(cls, args))
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


# --------------------------------------------------------------------------- measuring


def _model_xyz(model, wi: np.ndarray, wo: np.ndarray, illuminant: str) -> np.ndarray:
    out = np.empty((wi.shape[0], 3))
    for begin in range(0, wi.shape[0], _XYZ_CHUNK):
        sl = slice(begin, begin + _XYZ_CHUNK)
        out[sl] = model.xyz(wi[sl], wo[sl], illuminant)
    return out


def _stats(reference: dict, xyz_fn, wi, wo, illuminants) -> dict:
    from .core.brdf import metrics

    return {illum: {k: v for k, v in metrics.delta_e94_stats(
        reference[illum], xyz_fn(wi, wo, illum), illum).items() if k != "count"}
        for illum in illuminants}


# --------------------------------------------------------------------------- output


def format_table(rows: list[dict], illuminants) -> str:
    """The fixed-width error table (ASCII)."""
    head1 = f"{'':>5} {'':>6} {'':>9}"
    head2 = f"{'packs':>5} {'terms':>6} {'rel_rms':>9}"
    for illum in illuminants:
        head1 += f"  {('dE94 ' + illum):^26}"
        head2 += f"  {'mean':>8} {'p95':>8} {'max':>8}"
    head1 += f"  {'':>9} {'':>11}"
    head2 += f"  {'seconds':>9} {'bytes':>11}"
    lines = [head1.rstrip(), head2, "-" * len(head2)]
    for row in rows:
        if row["kind"] == "table_floor":
            packs, terms, seconds = "table", "-", row["tabulate_seconds"]
        else:
            packs = str(row["packs"]) + ("*" if row["packs_fitted"] < row["packs"] else "")
            terms, seconds = str(row["terms"]), row["factor_seconds"]
        line = f"{packs:>5} {terms:>6} {row['relative_rms']:9.2e}"
        for illum in illuminants:
            s = row["de94"][illum]
            line += f"  {s['mean']:8.4f} {s['p95']:8.4f} {s['max']:8.4f}"
        line += f"  {seconds:9.3f} {row['bytes']:11,d}"
        lines.append(line)
    return "\n".join(lines)


def _json_default(value):
    if isinstance(value, Path):
        return str(value)
    return json_default(value)


def _check_output_path(option: str, path: Path | None) -> None:
    if path is None:
        return
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{option} {path}: directory {parent} does not exist")
    if path.is_dir():
        raise UsageError(f"{option} {path} is a directory")


# --------------------------------------------------------------------------- factor


def _resolve_parameterization(args, brdf, table_file, wavelengths):
    """(name, isotropic, resolution) for prepare_table, with the file's own as defaults."""
    from .core.brdf.factor import resolve_parameterization

    if args.parameterization is None and table_file is not None:
        param = table_file.grid.parameterization
        name, iso = param.name, param.isotropic
        resolution = tuple(args.resolution) if args.resolution else table_file.grid.shape
        return param, name, iso, resolution
    name = args.parameterization or "io"
    requested = {"auto": None, "yes": True, "no": False}[args.isotropic]
    param, iso = resolve_parameterization(brdf, name, requested, wavelengths)
    if args.resolution:
        resolution = tuple(args.resolution)
        if len(resolution) != param.ndim:
            names = ", ".join(a.name for a in param.axes)
            hint = (" (the BRDF is isotropic, so the isotropic layout is used; add "
                    "--isotropic no for the full one)" if iso and args.isotropic == "auto"
                    and not name.endswith("_iso") else "")
            raise UsageError(f"--resolution has {len(resolution)} values; {param.name} has "
                             f"{param.ndim} axes ({names}){hint}")
    elif table_file is not None and param.name == table_file.grid.parameterization.name:
        resolution = table_file.grid.shape
    else:
        resolution = param.default_resolution
    return param, name, iso, resolution


def cmd_factor(args, progress: Progress) -> int:
    from .core.brdf import metrics
    from .core.brdf.factor import factor_brdf_series, prepare_table
    from .core.colour import spectra

    out_path = Path(args.out) if args.out else None
    json_path = Path(args.json) if args.json else None
    _check_output_path("--out", out_path)
    _check_output_path("--json", json_path)
    for illum in args.illuminants:
        if illum.upper() not in spectra.ILLUMINANT_NAMES:
            raise UsageError(f"unknown illuminant {illum!r}; choose from "
                             f"{', '.join(spectra.ILLUMINANT_NAMES)}")
    illuminants = [i.upper() for i in args.illuminants]
    if args.method in ("svd", "nd") and args.target_de94 is not None:
        raise UsageError("--target-de94 applies to the CP methods (joint, greedy)")

    brdf, source, table_file = load_input(args, progress)
    if args.wavelengths is not None:
        wavelengths = spectra.wavelength_grid(*args.wavelengths)
    elif table_file is not None:
        wavelengths = table_file.wavelengths
    else:
        wavelengths = spectra.WAVELENGTHS_REFERENCE
    wavelengths = spectra.check_wavelengths(wavelengths)
    if isinstance(args.basis, int) and args.basis > wavelengths.size:
        raise UsageError(f"--basis {args.basis} exceeds the {wavelengths.size} wavelengths")
    param, name, iso, resolution = _resolve_parameterization(args, brdf, table_file, wavelengths)
    label = args.input if table_file is None else str(table_file.path)
    progress.info(
        f"{label}: {param.name} {'x'.join(map(str, resolution))}, {wavelengths.size} wavelengths "
        f"{wavelengths[0]:g}-{wavelengths[-1]:g} nm, "
        f"{'no spectral basis' if args.basis is None else f'basis {args.basis}'}, "
        f"method {args.method}")

    progress.check()
    table = prepare_table(brdf, parameterization=name, isotropic=iso, resolution=resolution,
                          wavelengths=wavelengths, spectral_basis=args.basis, callback=progress)
    counts = sorted(set(args.packs)) if args.packs else None
    series = factor_brdf_series(
        brdf, pack_counts=counts if counts and len(counts) > 1 else None, table=table,
        packs=counts[0] if counts and len(counts) == 1 else None,
        target_de94=args.target_de94, pack_size=args.pack_size, callback=progress,
        seed=args.seed, method=args.method)
    progress(1.0, "measuring colour error")
    progress.check()

    wi, wo = metrics.random_direction_pairs(args.pairs)
    reference = {illum: metrics.reference_xyz(brdf, wi, wo, illum) for illum in illuminants}
    progress.check()
    rows = []
    for model in series:
        report = model.report
        requested = int(report.get("requested_packs", report["packs"]))
        rows.append({
            "kind": "factored",
            "packs": requested,
            "packs_fitted": int(report["packs"]),
            "terms": int(model.terms),
            "relative_rms": float(report["relative_rms"]),
            "de94": _stats(reference, lambda a, b, i, m=model: _model_xyz(m, a, b, i),
                           wi, wo, illuminants),
            "factor_seconds": float(report["factor_seconds"]),
            "bytes": int(model.nbytes),
        })
        progress.check()
    basis_bytes = 0 if table.basis is None else table.basis.vectors.size * 4
    rows.append({
        "kind": "table_floor",
        "packs": None,
        "packs_fitted": None,
        "terms": None,
        "relative_rms": float(series[-1].report.get("basis_relative_error", 0.0)),
        "de94": _stats(reference, table.xyz, wi, wo,
                       illuminants),
        "factor_seconds": None,
        "tabulate_seconds": float(table.seconds),
        "bytes": int(table.values.size * 4 + basis_bytes),
    })
    progress.clear()

    final = series[-1]
    fitted = {r["packs"] for r in rows if r["kind"] == "factored"}
    missing = [c for c in (counts or []) if c not in fitted] if len(counts or []) > 1 else []
    stopped = final.report.get("stopped")
    print(format_table(rows, illuminants), flush=True)
    short = [r for r in rows if r["kind"] == "factored" and r["packs_fitted"] < r["packs"]]
    notes = []
    if short or missing:
        fitted_packs = int(final.report["packs"])
        notes.append(f"* the fit stopped after {fitted_packs} pack{'s' * (fitted_packs != 1)} "
                     f"({stopped}); more packs would not lower the error")
    if missing:
        notes.append(f"no models for pack counts {', '.join(map(str, missing))}")
    if args.target_de94 is not None:
        notes.append(f"--target-de94 {args.target_de94:g}: stopped at {final.packs} "
                     f"pack{'s' * (final.packs != 1)} ({stopped})")
    notes.append("table: the tabulated grid looked up without factorising (the error floor); "
                 "its seconds are the tabulation's, its rel_rms the spectral basis loss")
    for note in notes:
        progress.info(note)

    if out_path is not None:
        final.save(out_path)
        progress.info(f"saved {out_path} ({final.packs} pack{'s' * (final.packs != 1)}, "
                      f"{final.nbytes:,} bytes)")
    if json_path is not None:
        document = {
            "command": "factor",
            "argv": list(args.argv),
            "input": source,
            "grid": table.grid.describe(),
            "wavelengths": {"start": float(wavelengths[0]), "stop": float(wavelengths[-1]),
                            "count": int(wavelengths.size)},
            "spectral_basis": None if table.basis is None else int(table.basis.size),
            "method": args.method,
            "pack_size": args.pack_size,
            "seed": args.seed,
            "target_de94": args.target_de94,
            "pairs": args.pairs,
            "illuminants": illuminants,
            "requested_packs": counts,
            "missing_packs": missing,
            "stopped": stopped,
            "rows": rows,
            "out": None if out_path is None else str(out_path),
            "report": final.report,
        }
        json_path.write_text(json.dumps(document, indent=2, default=_json_default) + "\n",
                             encoding="utf-8")
        progress.info(f"wrote {json_path}")
    return 0


def _add_factor_parser(sub) -> None:
    p = sub.add_parser(
        "factor", help="factor a BRDF model or tabulated file into CP factor packs",
        description="Factor an analytic BRDF model or a tabulated .npz into factor packs and "
                    "print the error table (relative RMS; dE94 mean/p95/max at the protocol's "
                    "random direction pairs).")
    p.add_argument("input", metavar="MODEL_OR_FILE",
                   help="lambert, oren_nayar, ashikhmin_shirley, ward, ggx, or a tabulated .npz")
    g = p.add_argument_group("model parameters")
    g.add_argument("--param", action="append", metavar="KEY=VALUE",
                   help="a model parameter, e.g. sigma=0.52, nu=32, alpha_x=0.2 (repeatable); "
                        "spectral ones take a SPEC")
    for flag, what in (("--diffuse", "diffuse reflectance (albedo for lambert/oren_nayar)"),
                       ("--specular", "specular reflectance"),
                       ("--albedo", "albedo (diffuse for ashikhmin_shirley/ward/ggx)"),
                       ("--ior-n", "real refractive index n (ggx)"),
                       ("--ior-k", "extinction coefficient k (ggx)")):
        g.add_argument(flag, metavar="SPEC",
                       help=f"{what}: patch:N (ColorChecker 1..24), a number, or csv:PATH")
    p.add_argument("--on-invalid", choices=("raise", "clamp"), default="raise",
                   help="a file's NaN/inf/negative samples: refuse (default) or set to 0")
    g = p.add_argument_group("tabulation")
    g.add_argument("--parameterization", choices=PARAMETERIZATION_CHOICES, default=None,
                   help="default: io (a file's own for a file); io/hd become io_iso/hd_iso for "
                        "an isotropic BRDF unless --isotropic no")
    g.add_argument("--isotropic", choices=("auto", "yes", "no"), default="auto",
                   help="use the isotropic layout (auto: test the BRDF)")
    g.add_argument("--resolution", type=_int_in(1, 100_000), nargs="+", metavar="N",
                   help="cells per axis, e.g. 90 180 90 (default: the parameterisation's)")
    g.add_argument("--wavelengths", type=float, nargs=3, metavar=("START", "STOP", "STEP"),
                   help="tabulation grid in nm (default 380 780 5, or a file's own)")
    g.add_argument("--basis", type=_basis_arg, default=None, metavar="N|TOL",
                   help="spectral basis: size (int) or projection tolerance (float < 1); "
                        "default none")
    g = p.add_argument_group("factoring")
    g.add_argument("--packs", type=_int_in(1, 256), nargs="+", metavar="N",
                   help="pack count, or several for one row each (default 4; 64 max with "
                        "--target-de94)")
    g.add_argument("--target-de94", type=_positive_float, default=None, metavar="X",
                   help="stop at the first pack count with mean dE94 (D65) <= X")
    g.add_argument("--pack-size", type=_int_in(1, 64), default=4, metavar="N",
                   help="terms per pack (default 4 = one RGBA texel)")
    g.add_argument("--method", choices=("joint", "greedy", "svd", "nd"), default="joint",
                   help="default joint")
    g.add_argument("--seed", type=int, default=0)
    g = p.add_argument_group("measuring and output")
    g.add_argument("--pairs", type=_int_in(1, 10_000_000), default=20_000, metavar="N",
                   help="random direction pairs for dE94 (default 20000, the protocol's)")
    g.add_argument("--illuminants", nargs="+", default=list(DEFAULT_ILLUMINANTS),
                   metavar="NAME", help="dE94 columns (default D65 FL2)")
    g.add_argument("--out", metavar="FACTORS.npz", help="save the final model here")
    g.add_argument("--json", metavar="REPORT.json", help="write the table and report as JSON")
    g.add_argument("--quiet", action="store_true", help="no progress bar or messages on stderr")
    p.set_defaults(handler=cmd_factor)


def cmd_render_sphere(args, progress: Progress) -> int:
    from .core.brdf.factored import FactoredBRDF
    from .core.colour import pipeline as colour_pipeline
    from .core.colour import spectra
    from .core.formats.exr import write_exr

    if args.illuminant not in spectra.ILLUMINANT_NAMES:
        raise UsageError(f"unknown illuminant {args.illuminant!r}; choose one of "
                         f"{', '.join(spectra.ILLUMINANT_NAMES)}")
    if not -90.0 < args.incidence < 90.0:
        raise UsageError(f"--incidence must be in (-90, 90) degrees, got {args.incidence}")
    out = Path(args.out)
    if out.suffix.lower() != ".exr":
        raise UsageError(f"--out must name an .exr file, got {out}")
    _check_output_path("--out", out)
    _check_output_path("--png", Path(args.png) if args.png else None)
    model = FactoredBRDF.load(args.factors)
    progress.info("initialising the GPU (the first headless draw compiles shaders)")
    import bpy

    from .blender.brdf.gpu_material import DisplaySettings
    from .blender.gpu.offscreen import render_sphere

    if args.engine == "eevee":
        from . import blender as addon
        from .blender.eevee import apply as eevee

        if not hasattr(bpy.types.Material, "spectral"):
            addon.register()      # the render stores the factors on a scratch material

        xyz, facts = eevee.render_sphere_eevee(
            model if args.packs is None else model.truncated(args.packs), args.incidence,
            args.illuminant, args.size)
        progress.info(f"EEVEE: {facts['nodes']} nodes, {facts['images']} texture(s), "
                      f"rendered in {facts['seconds']:.1f} s ({facts['working_space']})")
        image = np.concatenate([xyz, np.ones(xyz.shape[:2] + (1,))], axis=-1)
    else:
        image = render_sphere(model, args.incidence, args.illuminant, args.size,
                              packs=args.packs)
    xyz = image[..., :3]
    write_exr(out, {"X": xyz[..., 0], "Y": xyz[..., 1], "Z": xyz[..., 2]}, {
        "spectralMaterials": "linear CIE XYZ (1931 2°), sphere protocol: a white Lambertian "
                             "lit head-on reflects Y = 1",
        "illuminant": args.illuminant, "incidenceDegrees": f"{args.incidence:g}",
        "packs": str(model.packs if args.packs is None else min(args.packs, model.packs)),
        "engine": args.engine,
    })
    progress.info(f"wrote {out}")
    if args.png and args.engine == "eevee":
        white = colour_pipeline.white_xyz(args.illuminant, model.wavelengths)
        rgb = colour_pipeline.xyz_to_display(xyz, white)[::-1]
        import imageio.v3 as iio

        iio.imwrite(args.png, (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))
        progress.info(f"wrote {args.png}")
    elif args.png:
        white = colour_pipeline.white_xyz(args.illuminant, model.wavelengths)
        display = render_sphere(model, args.incidence, args.illuminant, args.size,
                                packs=args.packs, output="DISPLAY",
                                display=DisplaySettings(scene_white=tuple(white)))
        import imageio.v3 as iio

        rgba = np.concatenate([display[..., :3], image[..., 3:]], axis=-1)[::-1]
        iio.imwrite(args.png, (np.clip(rgba, 0, 1) * 255 + 0.5).astype(np.uint8))
        progress.info(f"wrote {args.png}")
    return 0


def _add_render_sphere_parser(sub) -> None:
    p = sub.add_parser(
        "render-sphere", help="draw saved factors on the protocol sphere through the GPU",
        description="Render a saved FactoredBRDF (.npz from 'factor --out') on the protocol "
                    "sphere with the GPU shaders and write linear CIE XYZ to OpenEXR.")
    p.add_argument("factors", metavar="FACTORS.npz")
    p.add_argument("--incidence", type=float, default=0.0, metavar="DEG",
                   help="light angle from the view direction in the x-z plane (default 0)")
    p.add_argument("--illuminant", default="D65", metavar="NAME",
                   help="CIE illuminant: A, D50, D65, FL1..FL12 (default D65)")
    p.add_argument("--out", required=True, metavar="FILE.exr")
    p.add_argument("--size", type=_int_in(1, 8192), default=256, metavar="N",
                   help="pixels a side (default 256, the protocol's)")
    p.add_argument("--packs", type=_int_in(1, 4096), default=None, metavar="N",
                   help="draw only the first N packs (default all)")
    p.add_argument("--png", metavar="FILE.png", help="also write the display image")
    p.add_argument("--engine", choices=("gpu", "eevee"), default="gpu",
                   help="gpu: the add-on's shaders (default); eevee: an EEVEE render through "
                        "the material node group")
    p.add_argument("--quiet", action="store_true", help="no messages on stderr")
    p.set_defaults(handler=cmd_render_sphere)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG, description="Spectral Materials: spectral BRDFs as factor packs.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_factor_parser(sub)
    _add_render_sphere_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)  # exits 2 on usage errors
    if args.command is None:
        parser.print_help(sys.stderr)
        return EXIT_ERROR
    args.argv = argv
    progress = Progress(quiet=getattr(args, "quiet", False))
    from .core.errors import Cancelled

    try:
        with _SigintHandler(progress):
            return args.handler(args, progress)
    except (Cancelled, KeyboardInterrupt):
        progress.clear()
        print("cancelled", file=sys.stderr, flush=True)
        return EXIT_CANCELLED
    except (ValueError, OSError) as exc:  # InvalidBRDFData and UsageError are ValueErrors
        progress.clear()
        message = " ".join(str(exc).split()) or type(exc).__name__
        print(f"{PROG} {args.command}: error: {message}", file=sys.stderr, flush=True)
        return EXIT_ERROR
    except MemoryError:
        progress.clear()
        print(f"{PROG} {args.command}: error: out of memory; lower --resolution or use --basis",
              file=sys.stderr, flush=True)
        return EXIT_ERROR
