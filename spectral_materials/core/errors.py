"""Exceptions shared by the core."""

from __future__ import annotations


class Cancelled(RuntimeError):
    """A long job was stopped because its progress callback asked it to."""


class InvalidBRDFData(ValueError):
    """BRDF samples are unusable (NaN, inf, wrong shape); the message says where."""
