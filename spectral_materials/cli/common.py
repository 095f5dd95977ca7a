"""What every command shares: the program name, exit statuses, the one-line usage error, the
progress bar on stderr and the check of an output path."""

from __future__ import annotations

from pathlib import Path
from typing import TextIO

from ..core.progress import STAGE_STYLE, TerminalProgress

PROG = "python -m spectral_materials"
EXIT_ERROR = 2
EXIT_CANCELLED = 130


class UsageError(ValueError):
    """A command-line mistake: reported on one line, exit status 2."""


class Progress(TerminalProgress):
    """The ``callback(fraction, message) -> stop?`` the core calls, drawing on stderr.

    On a terminal: a ``\\r`` progress bar, redrawn at most 10 times a second.
    Otherwise: one line each time the message changes (:data:`~..core.progress.STAGE_STYLE`).
    ``interrupted`` is set by the Ctrl-C handler (:func:`~..core.progress.ctrl_c_cancels`);
    the callback then returns True and the core raises
    :class:`~spectral_materials.core.errors.Cancelled`.
    """

    def __init__(self, quiet: bool, stream: TextIO | None = None):
        super().__init__(stream, quiet=quiet, style=STAGE_STYLE)


def check_output_path(option: str, path: Path | None) -> None:
    """Refuse an output ``path`` whose directory is missing or that is a directory itself,
    before any work is done."""
    if path is None:
        return
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{option} {path}: directory {parent} does not exist")
    if path.is_dir():
        raise UsageError(f"{option} {path} is a directory")
