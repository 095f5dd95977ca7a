"""How big the demo's work is: the full run that writes docs/demo/report.md, and the quick
run (``scripts/demo --quick``) that the test command runs to prove the main job still
runs to the end. Quick figures are smaller and coarser, never reported as results."""

from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class DemoSizes:
    """Every size a demo section uses; sections take one of these, never a global."""

    label: str
    theta_cells: int                  # θ cells per 90° for every factored material
    max_packs: int | None             # cap on each material's packs (None: the table's)
    sphere_px: int                    # sphere figures and the GPU / EEVEE sphere tables
    scene_px: tuple[int, int]         # the GPU scene figure (and EEVEE's comparison)
    frame_px: tuple[int, int]         # the frame-time measurement
    frames: int                       # frames per timing, and timings per figure below
    repeats: int
    prt_px: int                       # PRT scenes' image height (Metacow is twice as wide)
    prt_subdivisions: int             # Suzanne's subdivision levels in the FL4 scene
    prt_bake_rays: int                # rays per vertex of the FL4 scene's bake
    prt_reference_rays: int           # rays per vertex of its Monte Carlo reference
    btf_px: tuple[int, int]           # the cushion's image
    btf_texels: int                   # generated corduroy's texels a side


FULL = DemoSizes(label="full", theta_cells=64, max_packs=None, sphere_px=128,
                 scene_px=(640, 360), frame_px=(1280, 720), frames=3, repeats=3,
                 prt_px=160, prt_subdivisions=2, prt_bake_rays=512, prt_reference_rays=4096,
                 btf_px=(240, 160), btf_texels=16)

QUICK = DemoSizes(label="quick", theta_cells=12, max_packs=2, sphere_px=24,
                  scene_px=(160, 90), frame_px=(320, 180), frames=1, repeats=1,
                  prt_px=48, prt_subdivisions=0, prt_bake_rays=32, prt_reference_rays=128,
                  btf_px=(96, 64), btf_texels=8)


def sizes_for(quick: bool, theta_cells: int | None = None) -> DemoSizes:
    """The quick or full sizes, with the θ cells of the command line if given."""
    sizes = QUICK if quick else FULL
    return sizes if theta_cells is None else replace(sizes, theta_cells=theta_cells)
