"""``factor``: factor an analytic model or a tabulated ``.npz`` into CP factor packs and
print the protocol's error table (see :mod:`spectral_materials.cli`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..core.brdf.lobe import LOBE_FAMILIES
from ..core.brdf.params import PARAMETERIZATIONS
from .arguments import basis_arg, int_in, positive_float
from .common import Progress, UsageError, check_output_path
from .factor_input import load_input
from .factor_report import (
    FactorResult,
    format_table,
    json_document,
    json_text,
    measure_rows,
    result_notes,
)

DEFAULT_ILLUMINANTS = ("D65", "FL2")
#: ``--parameterization``: the keys of ``core.brdf.params.PARAMETERIZATIONS``, the
#: anisotropic ones first (the order the help lists them: io, hd, gs, ea, io_iso, hd_iso).
PARAMETERIZATION_CHOICES = tuple(sorted(PARAMETERIZATIONS,
                                        key=lambda name: PARAMETERIZATIONS[name].isotropic))


def _check_options(args) -> tuple[Path | None, Path | None, list[str]]:
    """Refuse what can be refused before any work → ``(out, json, illuminants)``."""
    from ..core.colour import spectra

    out_path = Path(args.out) if args.out else None
    json_path = Path(args.json) if args.json else None
    check_output_path("--out", out_path)
    check_output_path("--json", json_path)
    for illum in args.illuminants:
        if illum.upper() not in spectra.ILLUMINANT_NAMES:
            raise UsageError(f"unknown illuminant {illum!r}; choose from "
                             f"{', '.join(spectra.ILLUMINANT_NAMES)}")
    if args.method in ("svd", "nd") and args.target_de94 is not None:
        raise UsageError("--target-de94 applies to the CP methods (joint, greedy)")
    return out_path, json_path, [i.upper() for i in args.illuminants]


def _wavelengths(args, table_file):
    """``--wavelengths``, else a file's own, else the protocol's 380–780 nm in 5 nm steps."""
    from ..core.colour import spectra

    if args.wavelengths is not None:
        wavelengths = spectra.wavelength_grid(*args.wavelengths)
    elif table_file is not None:
        wavelengths = table_file.wavelengths
    else:
        wavelengths = spectra.WAVELENGTHS_REFERENCE
    wavelengths = spectra.check_wavelengths(wavelengths)
    if isinstance(args.basis, int) and args.basis > wavelengths.size:
        raise UsageError(f"--basis {args.basis} exceeds the {wavelengths.size} wavelengths")
    return wavelengths


def _resolve_parameterization(args, brdf, table_file, wavelengths):
    """(name, isotropic, resolution) for prepare_table, with the file's own as defaults."""
    from ..core.brdf.factor import resolve_parameterization

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


def _fit(args, brdf, table_file, wavelengths, progress: Progress):
    """Tabulate and factor → ``(table, fitted models, requested pack counts)``."""
    from ..core.brdf.factor import factor_brdf_series, prepare_table

    param, name, iso, resolution = _resolve_parameterization(args, brdf, table_file, wavelengths)
    label = args.input if table_file is None else str(table_file.path)
    progress.info(
        f"{label}: {param.name} {'x'.join(map(str, resolution))}, {wavelengths.size} wavelengths "
        f"{wavelengths[0]:g}-{wavelengths[-1]:g} nm, "
        f"{'no spectral basis' if args.basis is None else f'basis {args.basis}'}, "
        f"method {args.method}")
    progress.check()
    table = prepare_table(brdf, parameterization=name, isotropic=iso, resolution=resolution,
                          wavelengths=wavelengths, spectral_basis=args.basis,
                          lobe=None if args.lobe == "off" else args.lobe, callback=progress)
    counts = sorted(set(args.packs)) if args.packs else None
    series = factor_brdf_series(
        brdf, pack_counts=counts if counts and len(counts) > 1 else None, table=table,
        packs=counts[0] if counts and len(counts) == 1 else None,
        target_de94=args.target_de94, pack_size=args.pack_size, callback=progress,
        seed=args.seed, method=args.method)
    return table, series, counts


def cmd_factor(args, progress: Progress) -> int:
    """Run ``factor``: tabulate, factor, measure, print the table; save and report."""
    out_path, json_path, illuminants = _check_options(args)
    brdf, source, table_file = load_input(args, progress)
    wavelengths = _wavelengths(args, table_file)
    table, series, counts = _fit(args, brdf, table_file, wavelengths, progress)
    progress(1.0, "measuring colour error")
    progress.check()
    result = FactorResult(source, table, wavelengths, series, counts, illuminants)
    measure_rows(brdf, result, args.pairs, progress)
    progress.clear()

    print(format_table(result.rows, illuminants), flush=True)
    for note in result_notes(result, args.target_de94):
        progress.info(note)
    final = result.final
    if out_path is not None:
        final.save(out_path)
        progress.info(f"saved {out_path} ({final.packs} pack{'s' * (final.packs != 1)}, "
                      f"{final.nbytes:,} bytes)")
    if json_path is not None:
        json_path.write_text(json_text(json_document(args, result, out_path)), encoding="utf-8")
        progress.info(f"wrote {json_path}")
    return 0


def _add_input_options(p: argparse.ArgumentParser) -> None:
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


def _add_tabulation_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("tabulation")
    g.add_argument("--parameterization", choices=PARAMETERIZATION_CHOICES, default=None,
                   help="default: io (a file's own for a file); io/hd become io_iso/hd_iso for "
                        "an isotropic BRDF unless --isotropic no")
    g.add_argument("--isotropic", choices=("auto", "yes", "no"), default="auto",
                   help="use the isotropic layout (auto: test the BRDF)")
    g.add_argument("--resolution", type=int_in(1, 100_000), nargs="+", metavar="N",
                   help="cells per axis, e.g. 90 180 90 (default: the parameterisation's)")
    g.add_argument("--wavelengths", type=float, nargs=3, metavar=("START", "STOP", "STEP"),
                   help="tabulation grid in nm (default 380 780 5, or a file's own)")
    g.add_argument("--basis", type=basis_arg, default=None, metavar="N|TOL",
                   help="spectral basis: size (int) or projection tolerance (float < 1); "
                        "default none")


def _add_factoring_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("factoring")
    g.add_argument("--packs", type=int_in(1, 256), nargs="+", metavar="N",
                   help="pack count, or several for one row each (default 4; 64 max with "
                        "--target-de94)")
    g.add_argument("--target-de94", type=positive_float, default=None, metavar="X",
                   help="stop at the first pack count with mean dE94 (D65) <= X")
    g.add_argument("--pack-size", type=int_in(1, 64), default=4, metavar="N",
                   help="terms per pack (default 4 = one RGBA texel)")
    g.add_argument("--lobe", choices=("off", *LOBE_FAMILIES), default="off",
                   help="fit an analytic lobe (a specular highlight, or Oren-Nayar's "
                        "back-scatter) and factor the rest beside it (core/brdf/lobe.py); "
                        "the add-on's Automatic keeps it only where it measures better")
    g.add_argument("--method", choices=("joint", "greedy", "svd", "nd"), default="joint",
                   help="default joint")
    g.add_argument("--seed", type=int, default=0)


def _add_output_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("measuring and output")
    g.add_argument("--pairs", type=int_in(1, 10_000_000), default=20_000, metavar="N",
                   help="random direction pairs for dE94 (default 20000, the protocol's)")
    g.add_argument("--illuminants", nargs="+", default=list(DEFAULT_ILLUMINANTS),
                   metavar="NAME", help="dE94 columns (default D65 FL2)")
    g.add_argument("--out", metavar="FACTORS.npz", help="save the final model here")
    g.add_argument("--json", metavar="REPORT.json", help="write the table and report as JSON")
    g.add_argument("--quiet", action="store_true", help="no progress bar or messages on stderr")


def add_parser(sub) -> None:
    """The ``factor`` subcommand on ``sub`` (argparse's subparsers)."""
    p = sub.add_parser(
        "factor", help="factor a BRDF model or tabulated file into CP factor packs",
        description="Factor an analytic BRDF model or a tabulated .npz into factor packs and "
                    "print the error table (relative RMS; dE94 mean/p95/max at the protocol's "
                    "random direction pairs).")
    _add_input_options(p)
    _add_tabulation_options(p)
    _add_factoring_options(p)
    _add_output_options(p)
    p.set_defaults(handler=cmd_factor)
