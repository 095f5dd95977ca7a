"""The progress/cancel callback protocol: ``callback(fraction, message) -> stop?``."""

from __future__ import annotations

from collections.abc import Callable

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


class TerminalProgress:
    """A progress callback drawing a bar on a terminal (one line per 10 % when not a tty).

    ``Ctrl-C`` during a job sets :attr:`interrupted`, and the next call asks the job
    to stop, so the job unwinds through :class:`Cancelled` and leaves nothing half done.
    """

    def __init__(self, stream=None, width: int = 30):
        import sys

        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.interrupted = False
        self._last_decile = -1
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, fraction: float, message: str) -> bool:
        fraction = min(max(float(fraction), 0.0), 1.0)
        if self._tty:
            filled = int(round(self.width * fraction))
            bar = "#" * filled + "." * (self.width - filled)
            self.stream.write(f"\r[{bar}] {100 * fraction:5.1f}% {message[:60]:<60}")
            if fraction >= 1.0:
                self.stream.write("\n")
        else:
            decile = int(fraction * 10)
            if decile != self._last_decile:
                self._last_decile = decile
                self.stream.write(f"{100 * fraction:5.1f}% {message}\n")
        self.stream.flush()
        return self.interrupted
