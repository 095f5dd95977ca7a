"""Spectral PRT in a scene: the environment, the spectral basis, albedo layers, colours.

Objects with ``spectral_prt.enabled`` are diffuse, self-shadowed surfaces lit by the
scene's spectral environment (``scene.spectral.environment``) through precomputed
radiance transfer (the spectral PRT paper):

* the transfer ``T̃`` per vertex is baked by :mod:`.bake` (object space, stored as point
  attributes);
* the environment is projected on SH × a spectral basis (``core.environment``), turned by
  the scene's rotation about +Z and, per object, into the object's frame with SH
  rotation matrices — never projected again; colours are divided by the scene's white
  (world up), which turning into an object's frame leaves as it is;
* the spectral basis is Peercy's linear model of the scene's PRT spectra: every PRT
  object's albedo × CMF and the environment's spectra (``core.albedo.prt_basis``);
* each object's albedo becomes ``m`` layers of ``R̃`` (albedo × CMF on the basis), stored
  in a float image (``spectral_prt.albedo_image``) keyed by its source and the basis.

:func:`vertex_xyz` is the float64 evaluation tests and scripts use; ``prt.drawer`` draws
the same numbers. Everything derived is cached by a key of its inputs, so rotating the
environment costs one SH rotation per object and swapping it one projection.

This module is the public face: it serves the names of the modules each concern lives in
(:mod:`.inputs`, :mod:`.environment`, :mod:`.albedo`, :mod:`.state`, :mod:`.bake_plan`,
:mod:`.colours`, :mod:`.reference`), as ``blender/prt.py`` did before.
"""

from __future__ import annotations

from .albedo import (
    CHART_PATCH_PIXELS,
    AlbedoSource,
    albedo_source,
    chart_spectra,
    vertex_albedo_spectra,
)
from .bake_plan import (
    ANISOTROPY_TOLERANCE,
    BakePlan,
    bake_prt,
    clear_prt,
    commit_bake,
    plan_bake,
    run_bake,
    transfer_status,
)
from .colours import _evaluated_arrays, vertex_uvs, vertex_xyz
from .environment import EnvironmentData, environment_data, reference_environment
from .inputs import _CACHE, BASIS_SAMPLES, WAVELENGTHS, PRTError, clear_cache, prt_objects
from .reference import vertex_reference_irradiance, vertex_reference_xyz, world_geometry
from .state import (
    ALBEDO_KEY,
    SceneEnvironment,
    albedo_layers,
    environment_white_xyz,
    object_environment,
    object_rotation,
    scale_anisotropy,
    scene_environment,
    store_albedo,
)

__all__ = [
    "ALBEDO_KEY", "ANISOTROPY_TOLERANCE", "BASIS_SAMPLES", "CHART_PATCH_PIXELS", "WAVELENGTHS",
    "_CACHE", "_evaluated_arrays", "AlbedoSource", "BakePlan", "EnvironmentData", "PRTError",
    "SceneEnvironment", "albedo_layers", "albedo_source", "bake_prt", "chart_spectra",
    "clear_cache", "clear_prt", "commit_bake", "environment_data", "environment_white_xyz",
    "object_environment", "object_rotation", "plan_bake", "prt_objects",
    "reference_environment", "run_bake", "scale_anisotropy", "scene_environment",
    "store_albedo", "transfer_status", "vertex_albedo_spectra", "vertex_reference_irradiance",
    "vertex_reference_xyz", "vertex_uvs", "vertex_xyz", "world_geometry",
]
