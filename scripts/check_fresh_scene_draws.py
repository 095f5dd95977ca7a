#!/usr/bin/env python3
"""How often a freshly loaded scene's first spectral draw covers no pixel.

Each trial loads the factory start-up file (which frees every cached shader variant,
``draw.reset``), builds a PRT plane facing the camera, bakes it and draws it offscreen;
a trial is blank when no pixel is covered. ``--without-unbind`` makes
``gpu.shader.unbind`` do nothing, which restores the behaviour before
``blender/gpu/state.py``: the context keeps the freed variant's address as "bound", and a
new variant allocated there is never really bound. Prints ``blank N of TRIALS``; exits 1
when any trial was blank.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import bpy
import gpu

from benchmarks.scenes import factory_scene
from spectral_materials import blender as addon
from spectral_materials.blender.prt import scene as prt
from spectral_materials.blender.viewport import draw


def fresh_plane_scene():
    """The factory scene with only its camera, looking down at a PRT plane."""
    scene = factory_scene()
    scene.camera.location, scene.camera.rotation_euler = (0.0, 0.0, 6.0), (0.0, 0.0, 0.0)
    scene.render.resolution_x = scene.render.resolution_y = 32
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    plane.spectral_prt.rays = 8
    env = scene.spectral.environment
    env.source, env.sky, env.bands, env.basis_size = "SKY", "UNIFORM", 3, 4
    prt.bake_prt(plane, scene)
    return scene


def blank_trials(trials: int) -> int:
    blank = 0
    for _ in range(trials):
        image = draw.render_camera(fresh_plane_scene(), output="POSITION")[0]
        blank += int(not (image[..., 3] > 0.5).any())
    return blank


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--without-unbind", action="store_true")
    args = parser.parse_args()
    if args.without_unbind:
        gpu.shader.unbind = lambda: None
    addon.register()
    blank = blank_trials(args.trials)
    print(f"blank {blank} of {args.trials}"
          + (" (gpu.shader.unbind disabled)" if args.without_unbind else ""))
    return 1 if blank else 0


if __name__ == "__main__":
    from spectral_materials.blender.gpu.context import exit_process

    exit_process(main())
