"""The EEVEE node group's *Specular lobe* frame: a material's analytic lobe
(``core.brdf.lobe``, either family) for one light, in nodes, as
``glsl/brdf/specular_lobe.glsl``.

``g`` is the group's ``nodes.Graph`` (passed in, not imported: ``nodes`` imports this).
"""

from __future__ import annotations

import math

import numpy as np

from ...core.brdf.factored import FactoredBRDF
from ...core.brdf.lobe import DENOMINATOR_FLOOR


def lobe_rgb(g, model: FactoredBRDF, wi, wo, weights: np.ndarray, base: int):
    """The analytic lobe's f·cosθi in the light's RGB per unit irradiance (mirrors
    ``glsl/brdf/specular_lobe.glsl``; the lit test is the caller's)."""
    if model.lobe.family == "oren_nayar":
        return _oren_nayar_rgb(g, wi, wo, weights, base)
    nu, nv = float(model.lobe.nu), float(model.lobe.nv)
    v = g.vmath("ADD", wi, wo, column=base)
    length = g.vmath("LENGTH", v, column=base + 1, label="|wi + wo|")
    hx, hy, hz = g.separate(g.vmath("NORMALIZE", v, column=base + 1, label="h"),
                            column=base + 2)
    h_dot_k = g.math("MINIMUM", g.math("MULTIPLY", length, 0.5, column=base + 2), 1.0,
                     column=base + 3, label="h·k")
    hx2 = g.math("MULTIPLY", hx, hx, column=base + 3)
    hy2 = g.math("MULTIPLY", hy, hy, column=base + 3)
    # Blender's Divide gives 0 for a zero divisor: the lobe's ratio at h = n.
    ratio = g.math("DIVIDE", hy2, g.math("ADD", hx2, hy2, column=base + 4), column=base + 5)
    exponent = g.math("MULTIPLY_ADD", ratio, nv - nu, nu, column=base + 6, label="E")
    peak = g.math("POWER", g.math("MAXIMUM", hz, 1e-30, column=base + 6), exponent,
                  column=base + 7, label="(n·h)^E")
    _, _, wi_z = g.separate(wi, column=base)
    _, _, wo_z = g.separate(wo, column=base)
    denominator = g.math("MAXIMUM", g.math("MULTIPLY", h_dot_k, g.math(
        "MAXIMUM", wi_z, wo_z, column=base + 4), column=base + 5), DENOMINATOR_FLOOR,
        column=base + 6)
    norm = math.sqrt((nu + 1.0) * (nv + 1.0)) / (8.0 * math.pi)
    a = g.math("DIVIDE", g.math("MULTIPLY", peak, norm, column=base + 8), denominator,
               column=base + 9)
    a_cos = g.math("MULTIPLY", a, wi_z, column=base + 10, label="a · cosθi")
    s = g.math("POWER", g.math("SUBTRACT", 1.0, h_dot_k, column=base + 4), 5.0,
               column=base + 5, label="Schlick (1 − h·k)⁵")
    grazing = g.math("MULTIPLY", a_cos, s, column=base + 11)
    normal = g.math("SUBTRACT", a_cos, grazing, column=base + 11)
    return g.vmath("ADD", g.vmath("SCALE", tuple(weights[0]), scale=normal, column=base + 12),
                   g.vmath("SCALE", tuple(weights[1]), scale=grazing, column=base + 12),
                   column=base + 13, label="lobe")


def _oren_nayar_rgb(g, wi, wo, weights: np.ndarray, base: int):
    """Oren–Nayar's back-scatter term ``max(0, xi·xo + yi·yo) / max(cosθi, cosθo)`` times
    cosθi and its one spectrum's RGB weights (``lobe.oren_nayar_terms``)."""
    wi_x, wi_y, wi_z = g.separate(wi, column=base)
    wo_x, wo_y, wo_z = g.separate(wo, column=base)
    projected = g.math("MULTIPLY_ADD", wi_y, wo_y, g.math("MULTIPLY", wi_x, wo_x,
                                                         column=base + 1), column=base + 2)
    nearer_normal = g.math("MAXIMUM", g.math("MAXIMUM", wi_z, wo_z, column=base + 1),
                           DENOMINATOR_FLOOR, column=base + 2)
    a = g.math("DIVIDE", g.math("MAXIMUM", projected, 0.0, column=base + 3), nearer_normal,
               column=base + 4, label="Oren–Nayar sin α tan β cos Δφ")
    a_cos = g.math("MULTIPLY", a, wi_z, column=base + 5, label="a · cosθi")
    return g.vmath("SCALE", tuple(weights[0]), scale=a_cos, column=base + 6,
                   label="lobe")
