"""The parser with every command, and :func:`main`: the exit statuses and the one-line
errors (see :mod:`spectral_materials.cli`)."""

from __future__ import annotations

import argparse
import sys

from ..core.progress import ctrl_c_cancels
from . import factor, library, render_sphere
from .common import EXIT_CANCELLED, EXIT_ERROR, PROG, Progress


def build_parser() -> argparse.ArgumentParser:
    """``python -m spectral_materials`` and its subcommands."""
    parser = argparse.ArgumentParser(
        prog=PROG, description="Spectral Materials: spectral BRDFs as factor packs.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    factor.add_parser(sub)
    render_sphere.add_parser(sub)
    library.add_parser(sub)
    return parser


def _fail(progress: Progress, text: str) -> int:
    progress.clear()
    print(text, file=sys.stderr, flush=True)
    return EXIT_ERROR


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
    from ..core.errors import Cancelled

    try:
        with ctrl_c_cancels(progress):
            return args.handler(args, progress)
    except (Cancelled, KeyboardInterrupt):
        progress.clear()
        print("cancelled", file=sys.stderr, flush=True)
        return EXIT_CANCELLED
    except (ValueError, OSError) as exc:  # InvalidBRDFData and UsageError are ValueErrors
        message = " ".join(str(exc).split()) or type(exc).__name__
        return _fail(progress, f"{PROG} {args.command}: error: {message}")
    except MemoryError:
        return _fail(progress, f"{PROG} {args.command}: error: out of memory; lower "
                               "--resolution or use --basis")
