"""Drivers that keep a node input or a light setting following another datablock's
property (the EEVEE path's lights): one variable, summed or scaled by a simple
expression, so that it evaluates with Python auto-run off."""

from __future__ import annotations


def follow(owner, path: str, source, data_path: str, scale: float = 1.0) -> None:
    """Drive ``owner.path`` by ``source.data_path`` (``source`` an ID: an object or a
    light), times ``scale``."""
    driver = owner.driver_add(path).driver
    driver.type = "SUM" if scale == 1.0 else "SCRIPTED"
    var = driver.variables.new()
    var.name = "v"
    var.type = "SINGLE_PROP"
    var.targets[0].id_type = source.id_type
    var.targets[0].id = source
    var.targets[0].data_path = data_path
    if scale != 1.0:
        driver.expression = f"v * {scale!r}"
