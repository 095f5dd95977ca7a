"""A model drawn in a measured table's cells (``core.brdf.measured_cells``), in nodes, as
``glsl/brdf/measured_cells.glsl``: each spectral light's pair is moved to the centre of its
(θh, θd, φd) cell before the coordinates, and the packs' f·cosθi there is scaled to the
pair's own cosθi.

One difference from the shader: a cell whose centre is below the horizon is drawn at the
pair itself (smooth) rather than as the mean of its face neighbours, which would take six
more chains of pack nodes per light. Such cells lie within a cell of the horizon.
"""

from __future__ import annotations

import math

from ...core.brdf.measured_cells import MIN_CENTRE_COSINE


def _cell(g, value, cells: int, scale: float, column: int, warp: bool, label: str):
    """clamp(⌊t·cells⌋, 0, cells − 1) with t = value·scale (√ first for θh)."""
    t = g.math("MULTIPLY", value, scale, column=column)
    if warp:
        t = g.math("SQRT", g.math("MAXIMUM", t, 0.0, column=column), column=column + 1)
    index = g.math("FLOOR", g.math("MULTIPLY", t, float(cells), column=column + 1),
                   column=column + 2)
    return g.math("MINIMUM", g.math("MAXIMUM", index, 0.0, column=column + 2),
                  float(cells - 1), column=column + 3, label=label)


def _unit_vector(g, theta, phi, column: int, label: str):
    """(sin θ cos φ, sin θ sin φ, cos θ)."""
    sin_theta = g.math("SINE", theta, column=column)
    return g.combine(g.math("MULTIPLY", sin_theta, g.math("COSINE", phi, column=column),
                            column=column + 1),
                     g.math("MULTIPLY", sin_theta, g.math("SINE", phi, column=column),
                            column=column + 1),
                     g.math("COSINE", theta, column=column), column=column + 2, label=label)


def cell_centre_pair(g, coords: list, wi, wo, cells: tuple, column: int) -> tuple:
    """(wi, wo, cosine ratio) at the centre of the pair's cell; ``coords`` are the pair's
    (θh, φh, θd, φd) sockets. Where the centre is below the horizon: the pair itself and 1.
    The ratio cosθi / max(cos θi,centre, MIN_CENTRE_COSINE) turns the packs' f·cosθi at the
    centre into the pair's."""
    th, ph, td, pd = coords
    n_h, n_d, n_p = (int(n) for n in cells)
    half_pi = 0.5 * math.pi
    upper = g.math("GREATER_THAN", pd, math.pi, column=column, label="φd > π")
    folded = g.math("MULTIPLY_ADD", upper, -math.pi, pd, column=column + 1)
    ih = _cell(g, th, n_h, 1.0 / half_pi, column, True, "θh cell")
    idd = _cell(g, td, n_d, 1.0 / half_pi, column, False, "θd cell")
    ip = _cell(g, folded, n_p, 1.0 / math.pi, column + 1, False, "φd cell")
    u = g.math("DIVIDE", g.math("ADD", ih, 0.5, column=column + 4), float(n_h), column=column + 4)
    th_c = g.math("MULTIPLY", g.math("MULTIPLY", u, u, column=column + 5), half_pi,
                  column=column + 5, label="θh centre")
    td_c = g.math("MULTIPLY", g.math("ADD", idd, 0.5, column=column + 4), half_pi / n_d,
                  column=column + 5, label="θd centre")
    pd_c = g.math("MULTIPLY_ADD", upper, math.pi, g.math(
        "MULTIPLY", g.math("ADD", ip, 0.5, column=column + 4), math.pi / n_p,
        column=column + 5), column=column + 6, label="φd centre")
    # d from (θd, φd), then wi = Rz(φh) Ry(θh) d and wo = 2 (wi·h) h − wi.
    d = _unit_vector(g, td_c, pd_c, column + 6, "d")
    rotate_y = g.node("ShaderNodeVectorRotate", column + 9, "Ry(θh)", rotation_type="Y_AXIS")
    g.feed(rotate_y.inputs["Vector"], d)
    g.feed(rotate_y.inputs["Angle"], th_c)
    rotate_z = g.node("ShaderNodeVectorRotate", column + 10, "Rz(φh)", rotation_type="Z_AXIS")
    g.feed(rotate_z.inputs["Vector"], rotate_y.outputs[0])
    g.feed(rotate_z.inputs["Angle"], ph)
    wi_c = rotate_z.outputs[0]
    h = _unit_vector(g, th_c, ph, column + 9, "h")
    twice = g.math("MULTIPLY", g.vmath("DOT_PRODUCT", wi_c, h, column=column + 11), 2.0,
                   column=column + 12)
    wo_c = g.vmath("SUBTRACT", g.vmath("SCALE", h, scale=twice, column=column + 12), wi_c,
                   column=column + 13, label="wo centre")
    _, _, ci = g.separate(wi_c, column=column + 11)
    _, _, co = g.separate(wo_c, column=column + 14)
    valid = g.math("MULTIPLY", g.math("GREATER_THAN", ci, 0.0, column=column + 12),
                   g.math("GREATER_THAN", co, 0.0, column=column + 15), column=column + 15,
                   label="centre above the horizon")
    _, _, cos_i = g.separate(wi, column=column + 12)
    ratio = g.math("DIVIDE", cos_i, g.math("MAXIMUM", ci, MIN_CENTRE_COSINE,
                                            column=column + 13), column=column + 14)
    return (g.select(valid, wi_c, wi, column=column + 16, vector=True, label="wi in cells"),
            g.select(valid, wo_c, wo, column=column + 16, vector=True, label="wo in cells"),
            g.select(valid, ratio, 1.0, column=column + 16, label="cosθi ratio"))
