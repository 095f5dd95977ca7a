"""The EEVEE node group that reconstructs a material's factor packs for its spectral lights.

``build_group(material, model, image, lights, ...)`` writes a shader node group ``SM
EEVEE <material>`` that does, in nodes, what ``glsl/brdf/surface_frag.glsl`` does for
each of a few lights (the key light first), stage by stage in labelled frames:

1. *Shading frame*: n (Geometry normal), t (UV tangent, or the generated field
   normalize(ŷ × n), x̂ at its poles), Gram–Schmidt; per light, wi toward it (its
   position or direction come from drivers on the light object), wo = Incoming.
2. *Coordinates*: the parameterisation (io, io_iso, ea, hd, hd_iso) from local wi, wo.
3. *Axis lookups*: indices and weight per axis, as ``axes.axis_lookup``.
4. *Packs*: per pack and axis, two texels of the factor image (``Closest``, so the
   interpolation is the one written here, as in the GLSL), lerped and multiplied.
5. *Colour*: each pack's 4 terms times their RGB weights for that light (the
   spectral factor folded with the light's SPD × CMFs, ``core.prefilter``), summed,
   times the light's irradiance / π: scene-linear radiance.
6. *Specular lobe* (models that carry one, ``core.brdf.lobe``): the lobe's two terms
   from local wi, wo as ``glsl/brdf/specular_lobe.glsl``, times their RGB weights,
   added to the packs' radiance outside the horizon rule's scale.

A model drawn in a measured table's cells first moves each light's pair to its cell's
centre (:mod:`.cell_nodes`).

Outputs: ``Spectral lights`` (the sum of those radiances, for an Emission shader) and
``Base Color``, ``Roughness``, ``IOR`` (a Lambert + GGX fit of the factors under the
other lights' irradiance-weighted spectrum, ``core.prefilter.fit_principled``, for a
Principled BSDF that the other lights and the world light). EEVEE gives nodes no
per-light data, so each spectral light has its own driven chain of nodes; an emission
casts no shadow, so each light's radiance is multiplied by its visibility read through
its twin lights (:mod:`.shadow_nodes`). The apply step keeps the spectral lights from
also lighting the Principled BSDF.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from ...core.brdf.axes import holds_horizon
from ...core.brdf.factored import FactoredBRDF
from .cell_nodes import cell_centre_pair
from .light_nodes import KeyLight, light_incidence, shading_frame
from .lobe_nodes import lobe_rgb
from .shadow_nodes import light_visibility

GROUP_PREFIX = "SM EEVEE "
#: Spectral lights a group evaluates at most: each adds its own chain of nodes (and node
#: constants, which EEVEE caps at 64 KiB: ``uniform_bytes``).
MAX_SPECTRAL_LIGHTS = 4
SUPPORTED = ("io", "io_iso", "ea", "hd", "hd_iso")
#: Below this |v.xy| an azimuth is taken as 0 (as glsl/brdf/parameterization.glsl).
POLE_RHO = 1e-5
COLUMN = 190
ROW = 150


class Graph:
    """A node tree with column layout, frames and socket-or-number inputs."""

    def __init__(self, tree):
        self.tree = tree
        self.rows: dict[int, int] = {}
        self.frame = None

    def begin(self, label: str):
        frame = self.tree.nodes.new("NodeFrame")
        frame.label = label
        frame.label_size = 16
        self.frame = frame
        return frame

    def node(self, kind: str, column: int, label: str = "", **props):
        node = self.tree.nodes.new(kind)
        for key, value in props.items():
            setattr(node, key, value)
        if label:
            node.label = label
        row = self.rows.get(column, 0)
        self.rows[column] = row + 1
        node.location = (column * COLUMN, -row * ROW)
        if self.frame is not None:
            node.parent = self.frame
        return node

    def feed(self, socket, value) -> None:
        if isinstance(value, bpy.types.NodeSocket):
            self.tree.links.new(value, socket)
        elif isinstance(value, tuple | list | np.ndarray):
            socket.default_value = tuple(float(v) for v in value)
        else:
            socket.default_value = float(value)

    def math(self, op: str, a, b=0.0, c=0.0, *, column: int, label: str = ""):
        node = self.node("ShaderNodeMath", column, label, operation=op)
        node.use_clamp = False
        for socket, value in zip(node.inputs, (a, b, c)):
            self.feed(socket, value)
        return node.outputs[0]

    def vmath(self, op: str, a, b=(0.0, 0.0, 0.0), *, scale=None, column: int, label: str = ""):
        node = self.node("ShaderNodeVectorMath", column, label, operation=op)
        self.feed(node.inputs[0], a)
        self.feed(node.inputs[1], b)
        if scale is not None:
            self.feed(node.inputs["Scale"], scale)
        return node.outputs[1 if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else 0]

    def combine(self, x, y, z, *, column: int, label: str = ""):
        node = self.node("ShaderNodeCombineXYZ", column, label)
        for socket, value in zip(node.inputs, (x, y, z)):
            self.feed(socket, value)
        return node.outputs[0]

    def separate(self, vector, *, column: int, label: str = ""):
        node = self.node("ShaderNodeSeparateXYZ", column, label)
        self.feed(node.inputs[0], vector)
        return node.outputs[0], node.outputs[1], node.outputs[2]

    def select(self, condition, a, b, *, column: int, vector: bool = False, label: str = ""):
        """``a`` where condition (0/1) is 1, else ``b``."""
        return self._mix(b, a, condition, clamp=True, column=column, vector=vector,
                         label=label)

    def lerp(self, a, b, w, *, column: int, vector: bool, label: str = ""):
        """a + (b − a)·w with w unclamped (linear extrapolation at θ ends)."""
        return self._mix(a, b, w, clamp=False, column=column, vector=vector, label=label)

    def _mix(self, a, b, factor, *, clamp: bool, column: int, vector: bool, label: str):
        """A Mix node (float or vector) returning a + (b − a)·factor."""
        node = self.node("ShaderNodeMix", column, label,
                         data_type="VECTOR" if vector else "FLOAT")
        node.clamp_factor = clamp
        kind = "VECTOR" if vector else "VALUE"
        inputs = [s for s in node.inputs if s.enabled]
        self.feed(inputs[0], factor)
        self.feed([s for s in inputs if s.name == "A" and s.type == kind][0], a)
        self.feed([s for s in inputs if s.name == "B" and s.type == kind][0], b)
        return [s for s in node.outputs if s.enabled and s.type == kind][0]


def group_name(material) -> str:
    return GROUP_PREFIX + material.name


def _spherical(g: Graph, v, column: int, name: str):
    """(θ, φ) of a local unit vector: θ = atan2(|xy|, z), φ wrapped into [0, 2π), 0 at poles."""
    x, y, z = g.separate(v, column=column, label=f"{name} xyz")
    rho = g.vmath("LENGTH", g.combine(x, y, 0.0, column=column + 1), column=column + 2,
                  label=f"|{name}.xy|")
    theta = g.math("ARCTAN2", rho, z, column=column + 3, label=f"θ {name}")
    phi = g.math("FLOORED_MODULO", g.math("ARCTAN2", y, x, column=column + 3),
                 2.0 * math.pi, column=column + 4)
    off_pole = g.math("GREATER_THAN", rho, POLE_RHO, column=column + 4)
    phi = g.math("MULTIPLY", phi, off_pole, column=column + 5, label=f"φ {name}")
    return theta, phi


def _coordinates(g: Graph, parameterization: str, wi, wo, column: int) -> list:
    if parameterization in ("io", "io_iso", "ea"):
        ti, pi = _spherical(g, wi, column, "wi")
        to, po = _spherical(g, wo, column, "wo")
        if parameterization == "io":
            return [ti, pi, to, po]
        if parameterization == "ea":
            return [ti, to, pi, po]
        dphi = g.math("FLOORED_MODULO", g.math("SUBTRACT", po, pi, column=column + 6),
                      2.0 * math.pi, column=column + 7, label="Δφ")
        return [ti, dphi, to]
    # Rusinkiewicz: h = norm(wi + wo) (n where undefined), d = Ry(−θh) Rz(−φh) wi.
    total = g.vmath("ADD", wi, wo, column=column)
    length = g.vmath("LENGTH", total, column=column + 1)
    h = g.select(g.math("GREATER_THAN", length, 1e-7, column=column + 1),
                 g.vmath("NORMALIZE", total, column=column + 1), (0.0, 0.0, 1.0),
                 column=column + 2, vector=True, label="h")
    th, ph = _spherical(g, h, column + 2, "h")
    rotate_z = g.node("ShaderNodeVectorRotate", column + 8, "Rz(−φh)", rotation_type="Z_AXIS")
    g.feed(rotate_z.inputs["Vector"], wi)
    g.feed(rotate_z.inputs["Angle"], g.math("MULTIPLY", ph, -1.0, column=column + 7))
    rotate_y = g.node("ShaderNodeVectorRotate", column + 9, "Ry(−θh)", rotation_type="Y_AXIS")
    g.feed(rotate_y.inputs["Vector"], rotate_z.outputs[0])
    g.feed(rotate_y.inputs["Angle"], g.math("MULTIPLY", th, -1.0, column=column + 8))
    td, pd = _spherical(g, rotate_y.outputs[0], column + 10, "d")
    return [th, ph, td, pd] if parameterization == "hd" else [th, td, pd]


def _axis_x(g: Graph, value, axis, cells: int, column: int, k: int):
    """x = u·cells − 0.5 (u the warped unit coordinate), as axes.axis_lookup computes it."""
    span = float(axis.span)
    if axis.periodic:
        t = g.math("DIVIDE", g.math("FLOORED_MODULO", g.math("SUBTRACT", value, axis.lo,
                                                             column=column), span,
                                    column=column + 1), span, column=column + 2)
    else:
        t = g.math("DIVIDE", g.math("SUBTRACT", g.math("MINIMUM", g.math(
            "MAXIMUM", value, axis.lo, column=column), axis.lo + span, column=column + 1),
            axis.lo, column=column + 2), span, column=column + 2)
    t = g.math("MINIMUM", g.math("MAXIMUM", t, 0.0, column=column + 3), 1.0, column=column + 3)
    if axis.warp == "sqrt":
        t = g.math("SQRT", t, column=column + 4)
    return g.math("MULTIPLY_ADD", t, float(cells), -0.5, column=column + 4,
                  label=f"axis {k}: x")


def _axis_lookup(g: Graph, x, axis, cells: int, edge: str, column: int, k: int):
    """(i0, i1, w) sockets from :func:`_axis_x`, as axes.axis_lookup (cells > 1)."""
    f = g.math("FLOOR", x, column=column + 5)
    if axis.periodic:
        w = g.math("SUBTRACT", x, f, column=column + 6, label=f"axis {k}: w")
        i0 = g.math("FLOORED_MODULO", f, float(cells), column=column + 6, label=f"axis {k}: i0")
        i1 = g.math("FLOORED_MODULO", g.math("ADD", i0, 1.0, column=column + 7), float(cells),
                    column=column + 7, label=f"axis {k}: i1")
        return i0, i1, w
    i0 = g.math("MINIMUM", g.math("MAXIMUM", f, 0.0, column=column + 6), float(cells - 2),
                column=column + 6, label=f"axis {k}: i0")
    i1 = g.math("ADD", i0, 1.0, column=column + 7, label=f"axis {k}: i1")
    w = g.math("SUBTRACT", x, i0, column=column + 7, label=f"axis {k}: w")
    if edge == "clamp":
        w = g.math("MINIMUM", g.math("MAXIMUM", w, 0.0, column=column + 8), 1.0,
                   column=column + 8)
    elif holds_horizon(axis, edge):
        w = g.math("MINIMUM", w, 1.0, column=column + 8)
    return i0, i1, w


def _horizon_scale(g: Graph, x, cells: int, column: int, k: int):
    """axes.horizon_scale from :func:`_axis_x`: clamp(2·(cells − 0.5 − x), 0, 1)."""
    ramp = g.math("MULTIPLY_ADD", x, -2.0, 2.0 * cells - 1.0, column=column + 8)
    return g.math("MINIMUM", g.math("MAXIMUM", ramp, 0.0, column=column + 9), 1.0,
                  column=column + 9, label=f"axis {k}: horizon scale")


def _empty_group(name: str):
    """The node group ``name``, created or emptied, with the four outputs."""
    group = bpy.data.node_groups.get(name)
    if group is None:
        group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.nodes.clear()
    group.interface.clear()
    group.interface.new_socket("Spectral lights", in_out="OUTPUT",
                               socket_type="NodeSocketColor")
    group.interface.new_socket("Base Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    group.interface.new_socket("Roughness", in_out="OUTPUT", socket_type="NodeSocketFloat")
    group.interface.new_socket("IOR", in_out="OUTPUT", socket_type="NodeSocketFloat")
    return group


def _axis_lookups(g: Graph, model: FactoredBRDF, coords, base: int) -> tuple[list, object]:
    """(lower texel, upper texel, weight) of each angular axis (constants on 1-cell axes),
    and the horizon edge rule's scale socket (None under other rules)."""
    lookups, scale = [], None
    g.begin("Axis lookups")
    for k, (axis, cells) in enumerate(zip(model.grid.parameterization.axes, model.grid.shape)):
        horizon = holds_horizon(axis, model.edge)
        if cells == 1 and not horizon:
            lookups.append((0.0, 0.0, 0.0))
            continue
        x = _axis_x(g, coords[k], axis, cells, base, k)
        if horizon:
            fall = _horizon_scale(g, x, cells, base, k)
            scale = fall if scale is None else g.math("MULTIPLY", scale, fall, column=base + 9)
        if cells == 1:
            lookups.append((0.0, 0.0, 0.0))
        else:
            lookups.append(_axis_lookup(g, x, axis, cells, model.edge, base, k))
    return lookups, scale


def _pack_rgb(g: Graph, image, lookups: list, pack: int, groups: int, weights: np.ndarray,
              base: int):
    """One pack's four terms: the product of its axis texels, weighted into key-light RGB."""
    width, height = image.size
    colour = alpha = None
    for k, (i0, i1, w) in enumerate(lookups):
        v = (k * groups + pack + 0.5) / height
        texels = []
        for index in (i0, i1):
            u = g.math("DIVIDE", g.math("ADD", index, 0.5, column=base), float(width),
                       column=base + 1)
            node = g.node("ShaderNodeTexImage", base + 2, f"axis {k} texel",
                          interpolation="Closest", extension="EXTEND")
            node.image = image
            g.feed(node.inputs["Vector"], g.combine(u, v, 0.0, column=base + 1))
            texels.append(node)
        c = g.lerp(texels[0].outputs["Color"], texels[1].outputs["Color"], w,
                   column=base + 3, vector=True)
        a = g.lerp(texels[0].outputs["Alpha"], texels[1].outputs["Alpha"], w,
                   column=base + 3, vector=False)
        colour = c if colour is None else g.vmath("MULTIPLY", colour, c, column=base + 4)
        alpha = a if alpha is None else g.math("MULTIPLY", alpha, a, column=base + 4)
    r, gg, bb = g.separate(colour, column=base + 5)
    pack_rgb = None
    for term, amount in enumerate((r, gg, bb, alpha)):
        scaled = g.vmath("SCALE", tuple(weights[4 * pack + term]), scale=amount,
                         column=base + 6)
        pack_rgb = scaled if pack_rgb is None else g.vmath("ADD", pack_rgb, scaled,
                                                           column=base + 7)
    return pack_rgb


def _fitted_outputs(g: Graph, group, output, fit: dict, base: int) -> None:
    """The Principled inputs fitted under the other lights' spectrum (for them)."""
    colour = g.node("ShaderNodeRGB", base + 11, "diffuse colour (fit)")
    colour.outputs[0].default_value = (*map(float, fit["base_color"]), 1.0)
    group.links.new(colour.outputs[0], output.inputs["Base Color"])
    # Principled's dielectric F0 = ((n − 1)/(n + 1))²: the IOR that gives the fitted F0.
    root = math.sqrt(min(max(fit["specular"], 1e-6), 0.8))
    for socket, label, value in (("Roughness", "roughness (fit)", fit["roughness"]),
                                 ("IOR", "IOR of the fitted F0", (1.0 + root) / (1.0 - root))):
        node = g.node("ShaderNodeValue", base + 11, label)
        node.outputs[0].default_value = float(value)
        group.links.new(node.outputs[0], output.inputs[socket])


def build_group(material, model: FactoredBRDF, image, lights: list[KeyLight], fit: dict, *,
                to_rgb: np.ndarray, use_uv_tangent: bool = False, name: str | None = None,
                shadows: bool = False):
    """(Re)write the node group ``name`` (default: the material's); returns it.

    ``lights``: the spectral lights, the key light first; each gets its own incidence,
    lookups, packs and lobe frames, summed into the ``Spectral lights`` output. ``fit``
    (``core.prefilter.fit_principled``) feeds the Principled outputs. ``shadows``: each
    light's radiance times its EEVEE shadow, read through its twin lights
    (:mod:`.shadow_nodes`; the caller makes the twins). ``to_rgb``: the 3 × 3 the
    lights' RGB weights were made with (``prefilter.scene_linear_matrix``), through which
    each light's XYZ is clamped at 0, as ``FactoredBRDF.xyz`` and the GLSL clamp it. Raises
    ValueError for what the EEVEE path cannot reconstruct.
    """
    parameterization = model.grid.parameterization.name
    if parameterization not in SUPPORTED:
        raise ValueError(f"Material '{material.name}': the EEVEE path supports the "
                         f"{', '.join(SUPPORTED)} parameterisations, not {parameterization}; "
                         "refactor with one of them")
    if model.form != "cp":
        raise ValueError(f"Material '{material.name}': only CP factor packs have an EEVEE path")
    if not lights:
        raise ValueError(f"Material '{material.name}': the EEVEE path needs a spectral light")
    if model.lobe is not None and any(light.lobe_weights is None for light in lights):
        raise ValueError(f"Material '{material.name}': a spectral light has no weights "
                         "for the material's specular lobe")
    group = _empty_group(name or group_name(material))
    g = Graph(group)
    frame = shading_frame(g, use_uv_tangent)
    base = 14
    total = None
    for index, light in enumerate(lights):
        label = "key light" if index == 0 else f"light {index + 1}"
        radiance = _light_radiance(g, model, image, light, frame, label, base, shadows,
                                   to_rgb)
        g.frame = None  # the sum belongs to no light's frame
        total = radiance if total is None else g.vmath("ADD", total, radiance,
                                                       column=base + 34, label="Σ lights")
    g.begin("Other lights: Lambert + GGX fitted under their spectrum")
    output = g.node("NodeGroupOutput", base + 35)
    group.links.new(total, output.inputs["Spectral lights"])
    _fitted_outputs(g, group, output, fit, base + 23)
    return group


#: The frame holding each light's clamp (its label's end).
CLAMP_FRAME = "XYZ clamped at 0"


def _clamped_in_xyz(g: Graph, rgb, to_rgb: np.ndarray, column: int, label: str):
    """``rgb`` with its XYZ clamped at 0: to XYZ by ``to_rgb``'s inverse, the maximum with
    0, and back. Not in RGB: a colour outside the working space's gamut has a negative
    RGB component and is right; no reflection has a negative XYZ."""
    rows = np.asarray(to_rgb, dtype=np.float64)
    xyz = g.combine(*(g.vmath("DOT_PRODUCT", rgb, tuple(r), column=column)
                      for r in np.linalg.inv(rows)), column=column + 1)
    xyz = g.vmath("MAXIMUM", xyz, (0.0, 0.0, 0.0), column=column + 1, label="XYZ ≥ 0")
    return g.combine(*(g.vmath("DOT_PRODUCT", xyz, tuple(r), column=column + 2)
                       for r in rows), column=column + 2, label=label)


def _light_radiance(g: Graph, model: FactoredBRDF, image, key: KeyLight, frame, label: str,
                    base: int, shadowed: bool, to_rgb: np.ndarray):
    """One spectral light's reflected radiance (scene-linear RGB), its frames labelled
    ``label``: incidence, coordinates, axis lookups, packs and the lobe; ``shadowed``:
    times its visibility through its twin lights (:mod:`.shadow_nodes`)."""
    parameterization = model.grid.parameterization.name
    wi, wo, irradiance, lit, wi_world = light_incidence(g, key, frame, f"{label}: incidence")
    ratio = None
    if model.cells is not None:
        g.begin(f"{label}: the centre of the measured cell")
        hd = _coordinates(g, "hd", wi, wo, base)
        wi, wo, ratio = cell_centre_pair(g, hd, wi, wo, model.cells, base + 12)
        base += 30
    g.begin(f"{label}: coordinates ({parameterization})")
    coords = _coordinates(g, parameterization, wi, wo, base)
    base += 12
    lookups, horizon = _axis_lookups(g, model, coords, base)
    base += 10
    groups = -(-model.terms // 4)
    weights = np.zeros((groups * 4, 3))
    weights[: model.terms] = key.weights
    total = None
    for pack in range(groups):
        g.begin(f"{label}: pack {pack + 1}")
        pack_rgb = _pack_rgb(g, image, lookups, pack, groups, weights, base)
        total = pack_rgb if total is None else g.vmath("ADD", total, pack_rgb, column=base + 8)
    g.begin(f"{label}: radiance")
    lit_scale = g.math("MULTIPLY", g.math("MULTIPLY", irradiance, lit, column=base + 9),
                       1.0 / math.pi, column=base + 10, label="E · lit / π")
    if ratio is not None:
        lit_scale = g.math("MULTIPLY", lit_scale, ratio, column=base + 10, label="× cell cosθi")
    scale = lit_scale
    if horizon is not None:
        scale = g.math("MULTIPLY", scale, horizon, column=base + 10, label="× horizon")
    radiance = g.vmath("SCALE", total, scale=scale, column=base + 11, label=label)
    if model.lobe is not None:
        g.begin(f"{label}: specular lobe")
        lobe = lobe_rgb(g, model, wi, wo, np.asarray(key.lobe_weights, np.float64), base)
        radiance = g.vmath("ADD", radiance, g.vmath("SCALE", lobe, scale=lit_scale,
                                                    column=base + 11),
                           column=base + 11, label=f"{label} with lobe")
    g.begin(f"{label}: {CLAMP_FRAME}")
    radiance = _clamped_in_xyz(g, radiance, to_rgb, base + 19, f"{label}, XYZ ≥ 0")
    if shadowed:
        visibility = light_visibility(g, wi_world, frame[0].outputs["Incoming"], base + 12,
                                      label)
        radiance = g.vmath("SCALE", radiance, scale=visibility, column=base + 22,
                           label=f"{label}, shadowed")
    return radiance


#: EEVEE keeps every unlinked node input in one uniform block, which drivers cap at
#: 64 KiB (GL_MAX_UNIFORM_BLOCK_SIZE on Mesa and NVIDIA). Its size is this factor times
#: the inputs' own sizes (float 4 B, vector/colour 16 B, hidden ones included), measured
#: on Blender 5.0.1 + Mesa 22.3: hd failed to link at 39 packs with a 65 552 B block,
#: 1.504 × 43 600 B (docs/bench_eevee.md).
UNIFORM_BLOCK_FACTOR = 1.504
UNIFORM_BLOCK_LIMIT = 65536


def uniform_bytes(group, skip_frames: str | None = None) -> int:
    """The predicted size of EEVEE's node-constant uniform block for this group (without
    the nodes in frames whose label ends with ``skip_frames``)."""
    total = 0
    for node in group.nodes:
        if skip_frames and node.parent is not None and node.parent.label.endswith(skip_frames):
            continue
        for socket in node.inputs:
            if socket.is_linked or not hasattr(socket, "default_value"):
                continue
            if socket.type in ("VALUE", "INT"):
                total += 4
            elif socket.type in ("VECTOR", "RGBA"):
                total += 16
    return int(UNIFORM_BLOCK_FACTOR * total)


def node_count(group) -> dict:
    """Nodes in the group (frames excluded) and image-texture nodes."""
    nodes = [n for n in group.nodes if n.bl_idname != "NodeFrame"]
    images = [n for n in nodes if n.bl_idname == "ShaderNodeTexImage"]
    return {"nodes": len(nodes), "image_nodes": len(images),
            "images": len({n.image.name for n in images if n.image is not None}),
            "uniform_bytes": uniform_bytes(group)}
