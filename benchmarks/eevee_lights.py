"""The EEVEE benchmark's spectral-lights sweep (issue 18: "each of up to N lights through
the factor packs ... measure the cost against the Principled baseline").

After the packs sweep of ``benchmarks.eevee``, a second sun (FL2, 50° from the view axis,
at azimuth 120°) joins the scene, and the io_iso sphere is measured at a few pack counts
with the key light alone spectral (the second sun reaching the fitted Principled BSDF)
and with both suns spectral, each without and with the spectral lights' EEVEE shadows
(twin lights read through a refraction probe each: blender/eevee/shadow_nodes.py).
Every render of a row alternates with the Principled baseline lit by both suns, as in
the packs sweep.
"""

from __future__ import annotations

import bpy

from spectral_materials.blender.eevee import render as eevee_render

from .eevee_report import fmt, to_ms

LIGHT_PACKS = (4, 16)
QUICK_LIGHT_PACKS = (4,)
#: The second sun: incidence from the view axis (°), azimuth (°), illuminant.
SECOND_SUN = (50.0, 120.0, "FL2")
LAYOUT = "io_iso"


def add_second_sun(scene):
    """Link the second sun (strength 1) into ``scene``; returns its object."""
    incidence, azimuth, illuminant = SECOND_SUN
    sun = eevee_render.new_sun("Bench sun 2", incidence, illuminant, azimuth)
    scene.collection.objects.link(sun)
    return sun


def sweep_lights(bench, packs: list[int], log) -> list[dict]:
    """1 and 2 spectral lights at each of ``packs`` (io_iso); the second sun is removed
    afterwards."""
    if not packs:
        return []
    sun = add_second_sun(bench.scene)
    rows = []
    try:
        for count in packs:
            for lights, shadows in ((1, False), (1, True), (2, False), (2, True)):
                row = bench.measure(LAYOUT, count, lights=lights, shadows=shadows)
                rows.append(row)
                log(f"  {LAYOUT} {count:2d} packs, {lights} spectral light(s), shadows "
                    f"{'on' if row['shadows'] else 'off'}: "
                    f"{row.get('nodes', 0)} nodes, later {fmt(row.get('later_median'))} s, "
                    f"/P {fmt(row.get('over_principled'))}  {row['status']}")
    finally:
        data = sun.data
        bpy.data.objects.remove(sun)
        bpy.data.lights.remove(data)
    return rows


def lights_lines(results: dict) -> list[str]:
    """The sweep's table, or nothing when it did not run."""
    rows = results.get("light_rows") or []
    if not rows:
        return []
    incidence, azimuth, illuminant = SECOND_SUN
    lines = ["## Spectral lights", "",
             f"The same scene with a second sun ({illuminant}, {incidence:g}° from the view "
             f"axis at azimuth {azimuth:g}°), the {LAYOUT} sphere with the key light alone "
             "spectral (the second sun lights the fitted Principled BSDF) and with both "
             "suns spectral (each its own chain of nodes); *shadows*: the spectral lights' "
             "EEVEE shadows read through their twin lights (a refraction probe and Shader "
             "to RGB per light), or none. *render / Principled*: against the Principled "
             "BSDF lit by both suns, renders interleaved as above.", "",
             "| packs | spectral lights | shadows | group nodes | image nodes | "
             "first render s | later render s | render / Principled | ms per extra sample "
             "| status |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['packs']} | {r['spectral_lights']} | "
            f"{'on' if r.get('shadows', False) else 'off'} | {r.get('nodes', '–')} | "
            f"{r.get('image_nodes', '–')} | {fmt(r.get('first_seconds'))} | "
            f"{fmt(r.get('later_median'))} | {fmt(r.get('over_principled'))} | "
            f"{fmt(to_ms(r.get('per_sample_seconds')), '.0f')} | {r['status']} |")
    lines.append("")
    return lines
