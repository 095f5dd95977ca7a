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

Modules
-------
``app``
    The parser with every command, and :func:`main` (exit statuses, one-line errors).
``factor``, ``render_sphere``
    One per command: its options and its ``cmd_*`` function; ``factor_input`` (what
    ``factor`` factors, the ``SPEC`` syntax) and ``factor_report`` (the error table,
    the notes, the JSON report) serve ``factor``.
``common``, ``arguments``
    What the commands share: exit statuses, :class:`UsageError`, the progress bar on
    stderr (``core.progress.TerminalProgress``), and the argparse types.
"""

from .app import build_parser, main
from .common import EXIT_CANCELLED, EXIT_ERROR, PROG, Progress, UsageError
from .factor import DEFAULT_ILLUMINANTS, PARAMETERIZATION_CHOICES, cmd_factor
from .factor_input import SPECTRAL_KEYS, load_input, parse_spectrum, read_spectrum_csv
from .factor_report import format_table
from .render_sphere import cmd_render_sphere

__all__ = [
    "DEFAULT_ILLUMINANTS",
    "EXIT_CANCELLED",
    "EXIT_ERROR",
    "PARAMETERIZATION_CHOICES",
    "PROG",
    "SPECTRAL_KEYS",
    "Progress",
    "UsageError",
    "build_parser",
    "cmd_factor",
    "cmd_render_sphere",
    "format_table",
    "load_input",
    "main",
    "parse_spectrum",
    "read_spectrum_csv",
]
