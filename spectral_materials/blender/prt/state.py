"""The scene's PRT state: the spectral basis of every PRT object's albedo and the
environment, the environment projected on it (world frame, scene rotation applied) and
turned into each object's frame, and each object's albedo layers on the basis (stored in
a float image keyed by its source and the basis)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.prt import (
    albedo as core_albedo,
    environment as core_environment,
    sh,
    transfer as core_prt,
)
from ..brdf import storage
from .albedo import albedo_source
from .environment import environment_data, project, rotation_z
from .inputs import WAVELENGTHS, PRTError, cached, digest, prt_objects

ALBEDO_KEY = "sm_prt_albedo_key"

@dataclass
class SceneEnvironment:
    """The projected environment (world frame, scene rotation applied), its basis, and
    its white: the Y of a white Lambertian facing world up, what every PRT colour (the
    float64 mirror and the viewport) is divided by."""

    key: tuple
    environment: core_environment.SpectralEnvironment
    basis: np.ndarray
    white_y: float


def scene_environment(scene) -> SceneEnvironment:
    """The environment on SH × the scene's PRT basis (cached; rotation is cheap)."""
    env = scene.spectral.environment
    data = environment_data(scene)
    objects = prt_objects(scene)
    albedos = [albedo_source(o) for o in objects]
    basis_key = (data.key, tuple(sorted(a.key for a in albedos)), int(env.basis_size))
    projection_key = basis_key + (int(env.bands), env.window)

    def build_basis() -> np.ndarray:
        samples = [a.basis_spectra() for a in albedos] or [np.ones((1, WAVELENGTHS.size))]
        return core_albedo.prt_basis(np.concatenate(samples), list(data.basis_spectra()),
                                     WAVELENGTHS, int(env.basis_size))

    basis = cached("basis", basis_key, build_basis)
    projected = cached("projection", projection_key,
                        lambda: project(data, basis, int(env.bands), env.window.lower()))
    rotation = round(float(env.rotation), 9)
    key = projection_key + (rotation,)

    def build() -> SceneEnvironment:
        turned = projected.rotated(rotation_z(rotation)) if rotation else projected
        return SceneEnvironment(key, turned, basis, core_prt.white_y(turned))

    return cached("scene_environment", key, build)


def object_rotation(obj) -> np.ndarray:
    """The orthogonal factor ``Q`` of the object's world matrix ``M = Q P`` (the polar
    decomposition; ``P``, symmetric positive, is the scale and shear, dropped).

    ``det Q = −1`` for a mirrored object (an odd number of negative scales): its frame
    is a reflection of the world's, and the environment is reflected into it exactly (SH
    bands follow O(3)); the nearest proper rotation instead flips one more axis and
    lights parts of the object from the wrong side. ``M = R S`` with ``S`` diagonal (no
    parent shear) gives ``Q = R sign(S)``.
    """
    u, _, vt = np.linalg.svd(np.array(obj.matrix_world, dtype=np.float64)[:3, :3])
    return u @ vt


def scale_anisotropy(obj) -> float:
    """How far the object's world scale is from uniform: largest over smallest singular
    value of its world matrix, minus 1 (0 for any rotation × uniform scale × mirror).

    The transfer is baked in the object's unscaled frame and drawn with
    :func:`object_rotation` only. Uniform scale changes neither normals nor occlusion, so
    it is exact; non-uniform scale (or a parent's shear) tilts the normals and moves the
    shadows, which the transfer does not know: colours are then an approximation
    (docs/bench_prt_rotation.md measures it) until the scale is applied to the mesh and
    the object baked again. :func:`transfer_status` says so.
    """
    s = np.linalg.svd(np.array(obj.matrix_world, dtype=np.float64)[:3, :3], compute_uv=False)
    return float(s[0] / s[-1] - 1.0) if s[-1] > 0 else float("inf")


def object_environment(obj, scene) -> core_environment.SpectralEnvironment:
    """The scene environment in ``obj``'s frame, where its transfer was baked. Its ``up``
    is world up in that frame, so its white (``core.prt.white_y``) stays the scene's."""
    state = scene_environment(scene)
    return state.environment.rotated(object_rotation(obj).T)


def albedo_layers(obj, scene) -> core_albedo.AlbedoLayers:
    """R̃ layers of ``obj`` on the scene's PRT basis: the stored image when it is current,
    else computed from the source (cached)."""
    state = scene_environment(scene)
    source = albedo_source(obj)
    key = f"{digest(state.basis)}:{source.key}"

    def build() -> core_albedo.AlbedoLayers:
        stored = obj.spectral_prt.albedo_image
        if stored is not None and stored.get(ALBEDO_KEY) == key:
            return layers_from_image(stored, state.basis)
        values = source.values
        if source.rgb:
            return core_albedo.albedo_layers_from_rgb(values, WAVELENGTHS, state.basis)
        return core_albedo.albedo_layers_from_spectra(values, WAVELENGTHS, state.basis,
                                                      source=str(source.key[0]))

    layers = cached(f"albedo_layers:{obj.name}", key, build)
    layers.key = key
    return layers


def layers_from_image(image, basis: np.ndarray) -> core_albedo.AlbedoLayers:
    m = basis.shape[1]
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bad = int(np.count_nonzero(~np.isfinite(pixels)))
    if bad:
        raise PRTError(f"Stored PRT albedo image '{image.name}' holds {bad} non-finite "
                       "(NaN/inf) values: bake the object again")
    layers = pixels.reshape(m, height // m, width, 4)[..., :3]
    return core_albedo.AlbedoLayers(np.ascontiguousarray(layers), WAVELENGTHS, basis,
                                    "stored image")


def store_albedo(obj, scene) -> None:
    """Write the object's current R̃ layers to its float image (stacked, layer 0 first)."""
    layers = albedo_layers(obj, scene)
    old = obj.spectral_prt.albedo_image
    if old is not None and old.get(ALBEDO_KEY) == layers.key:
        return
    m, h, w, _ = layers.layers.shape
    pixels = np.zeros((m * h, w, 4), dtype=np.float32)
    pixels[..., :3] = layers.layers.reshape(m * h, w, 3)
    image = storage.new_float_image(f"SM PRT albedo {obj.name}", pixels)
    image[ALBEDO_KEY] = layers.key
    obj.spectral_prt.albedo_image = image
    if old is not None and old.users <= 1:
        storage.remove_image(old)


def environment_white_xyz(scene) -> np.ndarray:
    """XYZ of the white up-facing Lambertian under the environment (Y = 1): the white the
    display adapts from."""
    state = scene_environment(scene)
    env = state.environment
    up = sh.zonal_to_sh(sh.clamped_cosine_zonal(env.bands), np.array([0.0, 0.0, 1.0]))
    white = core_prt.albedo_weights(np.ones(WAVELENGTHS.size), WAVELENGTHS, env.basis)
    return (up @ env.coefficients) @ white / state.white_y

