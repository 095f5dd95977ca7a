"""Spectral PRT on turned objects: ``prt.vertex_xyz`` against the Monte Carlo reference.

The transfer is baked once in the object's frame; the environment is turned into that
frame at draw time. This measures how far ``prt.vertex_xyz`` is from
``prt.vertex_reference_xyz`` (5 nm, the true sky, 4096 cosine-distributed rays per
vertex, world space) as the object turns about every axis, is mirrored, or is scaled
unevenly (which is not re-baked):

* a UV sphere (convex: nothing shadows it, so the exact answer is known) under a uniform
  D65 sky (upper hemisphere) and under a clear D65 sky with a sun carrying half of the
  horizontal irradiance; a self-shadowing ledge (a floor with a box on it, one mesh)
  under the overcast D65 sky; 5 SH bands, window NONE, spectral basis 8;
* albedo: ColorChecker patch 13 (blue); 1024 bake rays per vertex;
* per transform: ΔE94 mean / p95 / max over the vertices (white = the environment's
  white, ``prt.environment_white_xyz``, as shared/PROTOCOL.md asks), the mean ratio of
  Y to the reference's Y, and for the sphere under the uniform sky the worst
  |Y − Y_exact| / Y_albedo against the closed form ``Y_exact = Y_albedo (1 + n_z)/2``
  (n the world normal; the horizon cuts the cosine lobe), which needs neither PRT nor
  Monte Carlo.

Writes ``docs/bench_prt_rotation.md`` and ``.json`` (``--out DIR`` elsewhere) and prints
the table. ``--before FILE`` adds the figures of an earlier run (its JSON) as "before"
columns: run the script on a checkout of the old code first (``git worktree add``).

Usage::

    python -m benchmarks.prt_rotation                        # ~30 s on 2 cores
    python -m benchmarks.prt_rotation --out /tmp/before      # e.g. on the old code
    python -m benchmarks.prt_rotation --before /tmp/before/bench_prt_rotation.json
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import bpy
import numpy as np

from spectral_materials import blender as addon
from spectral_materials.blender.prt import scene as prt
from spectral_materials.core.colour import pipeline as colour_pipeline, spectra

from . import harness
from .scenes import factory_scene

PATCH = 13
REFERENCE_RAYS = 4096
BAKE_RAYS = 1024
LIGHTS = {
    "uniform sky": {"sky": "UNIFORM", "sun_fraction": 0.0},
    "clear sky + sun": {"sky": "CLEAR", "sun_fraction": 0.5},
}
#: (label, XYZ Euler angles in degrees, scale).
TRANSFORMS = [
    ("none", (0, 0, 0), (1, 1, 1)),
    ("70° about z", (0, 0, 70), (1, 1, 1)),
    ("57° about x", (57, 0, 0), (1, 1, 1)),
    ("143° about x", (143, 0, 0), (1, 1, 1)),
    ("57° about y", (0, 57, 0), (1, 1, 1)),
    ("(57°, −31°, 143°)", (57, -31, 143), (1, 1, 1)),
    ("mirrored x, (57°, −31°, 143°)", (57, -31, 143), (-1, 1, 1)),
    ("scale (1, 1, 0.5), 57° about x", (57, 0, 0), (1, 1, 0.5)),
]
LEDGE_LIGHTS = {"overcast sky": {"sky": "OVERCAST", "sun_fraction": 0.0}}
LEDGE_TRANSFORMS = [
    ("none", (0, 0, 0), (1, 1, 1)),
    ("143° about x", (143, 0, 0), (1, 1, 1)),
    ("(57°, −31°, 143°)", (57, -31, 143), (1, 1, 1)),
    ("mirrored x, (57°, −31°, 143°)", (57, -31, 143), (-1, 1, 1)),
    ("scale (1, 1, 0.5)", (0, 0, 0), (1, 1, 0.5)),
    ("scale (1, 1, 2)", (0, 0, 0), (1, 1, 2)),
    ("scale (2, 1, 1), (57°, −31°, 143°)", (57, -31, 143), (2, 1, 1)),
]


def _fresh_scene():
    """The factory scene with only its camera, and a D65 sky of 5 bands."""
    scene = factory_scene()
    env = scene.spectral.environment
    env.source, env.illuminant, env.bands, env.window = "SKY", "D65", 5, "NONE"
    env.sun_elevation, env.sun_azimuth = 0.6, 0.5
    return scene


def _bake(scene, obj, name: str):
    """Patch 13 over ``obj``, baked once (the transform is set per row afterwards: the
    bake does not depend on it)."""
    obj.name = name
    obj.spectral_prt.albedo_kind = "SPECTRUM"
    obj.spectral_prt.albedo.kind = "COLORCHECKER"
    obj.spectral_prt.albedo.patch = str(PATCH)
    obj.spectral_prt.rays = BAKE_RAYS
    prt.bake_prt(obj, scene)
    return scene, obj


def sphere_scene():
    """A UV sphere (convex: nothing shadows it)."""
    scene = _fresh_scene()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
    return _bake(scene, bpy.context.active_object, "Sphere")


def ledge_scene():
    """A 12 × 12 floor grid with a box standing on it, one mesh (the box shadows the
    floor, as in tests/blender/prt/test_prt_scene.py)."""
    scene = _fresh_scene()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=12, y_subdivisions=12, size=4.0)
    floor = bpy.context.active_object
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.3, 0.2, 0.55))
    box = bpy.context.active_object
    bpy.ops.object.select_all(action="DESELECT")
    floor.select_set(True)
    box.select_set(True)
    bpy.context.view_layer.objects.active = floor
    bpy.ops.object.join()
    return _bake(scene, bpy.context.active_object, "Ledge")


def albedo_y() -> float:
    """Y of the albedo relative to the white under D65: a surface facing up reflects it."""
    wl = spectra.WAVELENGTHS_REFERENCE
    weights = colour_pipeline.xyz_weights("D65", wl)[:, 1]
    return float(spectra.colorchecker(PATCH, wl) @ weights / weights.sum())


def measure(scene, obj, light: str) -> dict:
    depsgraph = bpy.context.evaluated_depsgraph_get()
    xyz = prt.vertex_xyz(obj, scene, depsgraph)
    reference = prt.vertex_reference_xyz(obj, scene, depsgraph, rays=REFERENCE_RAYS)
    white = prt.environment_white_xyz(scene)
    de = colour_pipeline.delta_e94(reference, xyz, white)
    lit = reference[:, 1] > 1e-3
    row = {"mean": float(de.mean()), "p95": float(np.percentile(de, 95)),
           "max": float(de.max()),
           "y_ratio": float(np.mean(xyz[lit, 1] / reference[lit, 1]))}
    if light == "uniform sky":
        _, normals, _, _ = prt.world_geometry(obj, depsgraph)
        exact = albedo_y() * (1.0 + normals[:, 2]) / 2.0
        row["exact_max"] = float(np.abs(xyz[:, 1] - exact).max()) / albedo_y()
        row["reference_exact_max"] = float(np.abs(reference[:, 1] - exact).max()) / \
            albedo_y()
    return row


def _rows(scene, obj, name: str, lights: dict, transforms: list) -> list[dict]:
    rows = []
    for light, settings in lights.items():
        env = scene.spectral.environment
        env.sky, env.sun_fraction = settings["sky"], settings["sun_fraction"]
        for label, euler, scale in transforms:
            obj.rotation_euler = tuple(np.radians(euler))
            obj.scale = scale
            bpy.context.view_layer.update()
            start = time.perf_counter()
            row = measure(scene, obj, light if name == "sphere" else "")
            row.update(object=name, light=light, transform=label,
                       seconds=time.perf_counter() - start)
            rows.append(row)
            print(f"{name:7s} {light:16s} {label:32s} mean {row['mean']:7.3f} p95 "
                  f"{row['p95']:7.3f} max {row['max']:7.3f} Y/Yref {row['y_ratio']:.4f}",
                  flush=True)
    return rows


def run() -> dict:
    scene, sphere = sphere_scene()
    vertices = {"sphere": len(sphere.data.vertices)}
    rows = _rows(scene, sphere, "sphere", LIGHTS, TRANSFORMS)
    scene, ledge = ledge_scene()
    vertices["ledge"] = len(ledge.data.vertices)
    rows += _rows(scene, ledge, "ledge", LEDGE_LIGHTS, LEDGE_TRANSFORMS)
    return {"rows": rows, "vertices": vertices, "albedo_y": albedo_y()}


def _cell(row: dict | None, key: str, digits: int = 2) -> str:
    if row is None or key not in row:
        return "–"
    return f"{row[key]:.{digits}f}"


def table(result: dict, before: dict | None) -> str:
    """The Markdown table, with "before" columns when an earlier run is given."""
    old = {(r.get("object", "sphere"), r["light"], r["transform"]): r
           for r in (before or {}).get("rows", [])}
    head = ["object", "light", "transform", "ΔE94 mean", "p95", "max", "Y / Y_ref", "exact err"]
    if before:
        head += ["before: ΔE94 mean", "p95", "max", "Y / Y_ref", "exact err"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in result["rows"]:
        cells = [row["object"], row["light"], row["transform"], _cell(row, "mean"),
                 _cell(row, "p95"), _cell(row, "max"), _cell(row, "y_ratio", 4),
                 _cell(row, "exact_max", 4)]
        if before:
            prev = old.get((row["object"], row["light"], row["transform"]))
            cells += [_cell(prev, "mean"), _cell(prev, "p95"), _cell(prev, "max"),
                      _cell(prev, "y_ratio", 4), _cell(prev, "exact_max", 4)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def report(result: dict, before: dict | None) -> str:
    rows = result["rows"]
    reference_exact = max(r["reference_exact_max"] for r in rows if "reference_exact_max" in r)
    lines = [
        "# Spectral PRT on turned objects",
        "",
        f"`python scripts/bench_prt_rotation.py` at commit {result['commit']}, "
        f"{result['date']}" + (f"; \"before\" columns from commit {before['commit']} "
                               f"({before['date']})" if before else "") + ".",
        "",
        f"A UV sphere (32 × 16, {result['vertices']['sphere']} vertices) and a "
        f"self-shadowing ledge (a 12 × 12 floor with a box on it, one mesh, "
        f"{result['vertices']['ledge']} vertices), ColorChecker patch {PATCH} "
        f"(Y = {result['albedo_y']:.4f} under D65), each baked once with {BAKE_RAYS} rays "
        "per vertex in its own frame, then turned, mirrored or scaled. 5 SH bands, window "
        "NONE, "
        "spectral basis 8. ΔE94 per vertex of `prt.vertex_xyz` against "
        f"`prt.vertex_reference_xyz` ({REFERENCE_RAYS} rays, 5 nm, the true sky), white = "
        "`prt.environment_white_xyz`. Y / Y_ref: the mean over lit vertices. exact err "
        "(uniform sky): max |Y − Y_exact| / Y_albedo over the vertices, Y_exact = "
        "`Y_albedo (1 + n_z)/2`, n the world normal (closed form: the horizon cuts the "
        "cosine lobe); the reference's own is at most "
        f"{reference_exact:.4f}.",
        "",
        table(result, before),
        "",
        "Scale is not baked (the transfer knows the unscaled mesh, drawn with the "
        "rotation part of the object's matrix; `prt.transfer_status` calls such objects "
        "approximate): non-uniform scale tilts the normals and, on the ledge, moves the "
        "shadows. On a convex object under the uniform sky the "
        "normal used and the true one are at most θ = atan((k − 1)/(2√k)) apart, k the "
        "largest over the smallest scale, so exact err ≤ sin(θ/2): "
        f"{np.sin(np.arctan(1.0 / (2.0 * np.sqrt(2.0))) / 2.0):.4f} for k = 2.",
        "",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = harness.parser(__doc__)
    parser.add_argument("--out", type=Path, default=harness.DOCS)
    parser.add_argument("--before", type=Path, help="JSON of an earlier run")
    args = parser.parse_args(argv)
    import spectral_materials

    print(f"spectral_materials from {Path(spectral_materials.__file__).parent}", flush=True)
    addon.register()
    try:
        result = run()
    finally:
        addon.unregister()
    result.update(commit=harness.commit_of(), date=harness.date_stamp(day_only=True))
    before = json.loads(args.before.read_text()) if args.before else None
    harness.write_json(args.out / "bench_prt_rotation.json", result)
    text = report(result, before)
    harness.write_markdown(args.out / "bench_prt_rotation.md", text)
    print(text)


if __name__ == "__main__":
    main()
