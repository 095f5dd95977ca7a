"""The progress/cancel callback protocol ``callback(fraction, message) -> stop?``, the terminal
progress bar that the command line and the scripts draw, and their Ctrl-C handling.

A job reports through :func:`report`; a true return value from the callback asks it to stop,
and it unwinds through :class:`Cancelled`, leaving nothing half done. On a terminal,
:class:`TerminalProgress` is that callback, and :func:`ctrl_c_cancels` makes the first
Ctrl-C set its :attr:`~TerminalProgress.interrupted`; a second Ctrl-C interrupts at once.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Literal, TextIO

from .errors import Cancelled

ProgressCallback = Callable[[float, str], bool]


def report(callback: ProgressCallback | None, fraction: float, message: str) -> None:
    """Call ``callback``; raise :class:`Cancelled` if it returns a true value."""
    if callback is not None and callback(float(min(max(fraction, 0.0), 1.0)), message):
        raise Cancelled(message)


def scaled(callback: ProgressCallback | None, start: float, stop: float) -> ProgressCallback | None:
    """A callback mapping a sub-job's 0..1 onto ``start..stop`` of the parent's."""
    if callback is None:
        return None
    return lambda fraction, message: callback(start + (stop - start) * fraction, message)


# --------------------------------------------------------------------------- terminal bar


@dataclass(frozen=True)
class BarStyle:
    """How a :class:`TerminalProgress` writes.

    On a terminal it redraws one ``\\r`` line, ``[####......]  42.0% message``; elsewhere (a
    pipe, a log file) it writes whole lines, one per stage or one per tenth of the job.
    """

    #: Format spec of the percentage.
    percent: str = "5.1f"
    #: A terminal: cut and pad the message to this many characters (None: as it is, and the
    #: rest of a longer previous line blanked).
    message_width: int | None = 60
    #: A terminal: end the bar's line when the job reaches 100 %.
    end_line_at_100: bool = True
    #: A terminal: least seconds between two redraws of the same message (0: every call).
    redraw_interval: float = 0.0
    #: Not a terminal: a line ``message...`` each time the message changes ("message"), or a
    #: line `` 40.0% message`` each time the job passes a tenth ("decile").
    log_every: Literal["message", "decile"] = "decile"


#: The scripts' (factor_scene.py, the demos): a fixed-width bar; a log line per tenth.
DECILE_STYLE = BarStyle()
#: The command line's: redrawn at most 10 times a second, as wide as its message; a log line
#: per stage.
STAGE_STYLE = BarStyle(percent="3.0f", message_width=None, end_line_at_100=False,
                       redraw_interval=0.1, log_every="message")


class TerminalProgress:
    """A :data:`ProgressCallback` drawing a progress bar on ``stream`` (stderr by default).

    On a terminal a ``\\r`` bar; otherwise whole lines (see :class:`BarStyle`). ``quiet``
    draws nothing but still answers :attr:`interrupted`, which the Ctrl-C handler
    (:func:`ctrl_c_cancels`) sets: the next call then asks the job to stop.
    """

    def __init__(self, stream: TextIO | None = None, width: int = 30, *, quiet: bool = False,
                 style: BarStyle = DECILE_STYLE):
        self.stream = sys.stderr if stream is None else stream
        self.width = width
        self.quiet = quiet
        self.style = style
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interrupted = False
        self._drawn_at = 0.0
        self._message: str | None = None        # the last drawn, for redraw_interval
        self._logged: str | int | None = None   # the last log line's message or decile
        self._line_length = 0                   # of the bar's line now on the terminal

    def __call__(self, fraction: float, message: str) -> bool:
        if not self.quiet:
            self._draw(min(max(float(fraction), 0.0), 1.0), str(message))
        return self.interrupted

    def _draw(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if self.tty:
            if (message == self._message and fraction < 1.0
                    and now - self._drawn_at < self.style.redraw_interval):
                return
            self._draw_bar(fraction, message)
        else:
            self._log(fraction, message)
        self.stream.flush()
        self._message = message
        self._drawn_at = now

    def _draw_bar(self, fraction: float, message: str) -> None:
        filled = int(round(self.width * fraction))
        width = self.style.message_width
        text = message if width is None else f"{message[:width]:<{width}}"
        line = (f"[{'#' * filled}{'.' * (self.width - filled)}] "
                f"{100 * fraction:{self.style.percent}}% {text}")
        self.stream.write("\r" + line + " " * max(0, self._line_length - len(line)))
        self._line_length = len(line)
        if self.style.end_line_at_100 and fraction >= 1.0:
            self.stream.write("\n")
            self._line_length = 0

    def _log(self, fraction: float, message: str) -> None:
        if self.style.log_every == "message":
            key: str | int = message
            line = f"{message}...\n"
        else:
            key = int(fraction * 10)
            line = f"{100 * fraction:{self.style.percent}}% {message}\n"
        if key != self._logged:
            self._logged = key
            self.stream.write(line)

    def clear(self) -> None:
        """Blank the bar's line, so that other output starts at its beginning."""
        if self.tty and self._line_length:
            self.stream.write("\r" + " " * self._line_length + "\r")
            self.stream.flush()
        self._line_length = 0
        self._message = None
        self._logged = None

    def info(self, text: str) -> None:
        """Print a line of text (unless quiet), after clearing the bar."""
        if not self.quiet:
            self.clear()
            print(text, file=self.stream, flush=True)

    def check(self) -> None:
        """Raise :class:`Cancelled` if interrupted: for the stages a job does not report on."""
        if self.interrupted:
            raise Cancelled("interrupted")


@contextmanager
def ctrl_c_cancels(progress: TerminalProgress) -> Iterator[TerminalProgress]:
    """Within the block, the first Ctrl-C sets ``progress.interrupted`` (the job stops at its
    next report and raises :class:`Cancelled`); the second raises ``KeyboardInterrupt`` at
    once, for a job that stopped reporting. Outside the main thread Ctrl-C is left alone."""

    def first_ctrl_c(_signum, _frame) -> None:
        progress.interrupted = True
        signal.signal(signal.SIGINT, signal.default_int_handler)

    try:
        previous = signal.signal(signal.SIGINT, first_ctrl_c)
    except ValueError:  # not the main thread
        previous = None
    try:
        yield progress
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
