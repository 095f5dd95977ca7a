"""Scene analysis: which materials and lights a scene needs, read on the main thread.

A material is *used* when a visible, renderable object in the scene's view layer
has it in a slot and the material is spectral (``material.spectral.enabled``, or
it is the one the user asked for). A light *reaches* the scene when its object is
visible, renderable and has power > 0. What is not used is reported, not factored.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import bpy
import numpy as np

from ..lights.visibility import GEOMETRY_TYPES, renders as _renders, scene_lights
from ..ui.enums import OBSERVER_NAMES
from . import sources

# GEOMETRY_TYPES, _renders and scene_lights live in lights.visibility (the drawers below
# this layer ask the same question) and are served from here too.
__all__ = ["GEOMETRY_TYPES", "ScenePlan", "SceneError", "plan_scene", "scene_lights",
           "used_materials"]


@dataclass
class ScenePlan:
    """Plain-data snapshot of what a job needs from the scene (safe to hand to a thread)."""

    scene_name: str
    materials: dict[str, sources.MaterialInputs] = field(default_factory=dict)
    stored_hashes: dict[str, str] = field(default_factory=dict)
    lights: dict[str, np.ndarray] = field(default_factory=dict)
    targets: list[str] = field(default_factory=list)     # materials to factor if stale
    unused: list[str] = field(default_factory=list)      # spectral materials nobody renders
    hidden_lights: list[str] = field(default_factory=list)
    implicit_light: str | None = None                    # illuminant used when no light
    tolerance_de94: float = 0.05
    max_size: int = 16
    observer: str = OBSERVER_NAMES["CIE_1931_2"]
    force: bool = False


class SceneError(ValueError):
    """The scene has nothing to work on, or something in it is unusable."""


def used_materials(scene, view_layer=None) -> list:
    """Materials in the slots of visible, renderable objects, in a stable order."""
    view_layer = view_layer or scene.view_layers[0]
    seen: dict[str, object] = {}
    for obj in scene.objects:
        if obj.type not in GEOMETRY_TYPES or not _renders(obj, view_layer):
            continue
        for slot in obj.material_slots:
            if slot.material is not None and slot.material.name not in seen:
                seen[slot.material.name] = slot.material
    return [seen[name] for name in sorted(seen)]


def plan_scene(scene, *, only: list | None = None, force: bool = False,
               view_layer=None) -> ScenePlan:
    """Read what a scene job needs; raises :class:`SceneError` / ``SourceError``.

    ``only`` restricts the materials to factor (e.g. the active material); the basis
    is still chosen for everything the scene renders, so that it serves them all.
    """
    settings = scene.spectral
    plan = ScenePlan(scene_name=scene.name, tolerance_de94=float(settings.basis_tolerance),
                     max_size=int(settings.basis_max_size),
                     observer=OBSERVER_NAMES[settings.observer], force=force)
    if not (np.isfinite(plan.tolerance_de94) and plan.tolerance_de94 > 0):
        raise SceneError(f"Scene '{scene.name}': basis tolerance must be a positive ΔE94, "
                         f"got {plan.tolerance_de94}")
    if not 1 <= plan.max_size <= 64:
        raise SceneError(f"Scene '{scene.name}': max basis size must be in 1..64, "
                         f"got {plan.max_size}")
    used = [m for m in used_materials(scene, view_layer) if m.spectral.enabled]
    requested = list(only or [])
    for material in requested:
        if material.name not in {m.name for m in used}:
            used.append(material)
    if not used:
        raise SceneError(f"Scene '{scene.name}' has nothing to factor: no visible, renderable "
                         "object uses a spectral material (tick 'Spectral' in a material's "
                         "Spectral panel)")
    for material in used:
        plan.materials[material.name] = sources.material_inputs(material)
        plan.stored_hashes[material.name] = material.spectral.result.input_hash \
            if material.spectral.result.image is not None else ""
    plan.targets = [m.name for m in (requested or used)]
    used_names = {m.name for m in used}
    plan.unused = sorted(m.name for m in bpy.data.materials
                         if m.spectral.enabled and m.name not in used_names)
    lights, plan.hidden_lights = scene_lights(scene, view_layer)
    for obj in lights:
        plan.lights[obj.name] = sources.light_spd(obj.data)
    if not plan.lights:
        plan.implicit_light = settings.adaptation_white
        plan.lights[f"{settings.adaptation_white} (adaptation white)"] = \
            sources.spectra.illuminant(settings.adaptation_white, sources.WAVELENGTHS)
    return plan
