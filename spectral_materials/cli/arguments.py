"""Argument types for argparse: each refuses a bad value with a message argparse prints
(exit status 2)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np


def basis_arg(text: str) -> int | float | None:
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


def positive_float(text: str) -> float:
    """A finite number above 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (np.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def int_in(lo: int, hi: int) -> Callable[[str], int]:
    """The type of an integer in ``lo..hi``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"expected {lo}..{hi}, got {value}")
        return value
    return parse
