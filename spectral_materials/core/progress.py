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
