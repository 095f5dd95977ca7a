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

:func:`vertex_xyz` is the float64 evaluation tests and scripts use; ``prt_gpu`` draws
the same numbers. Everything derived is cached by a key of its inputs, so rotating the
environment costs one SH rotation per object and swapping it one projection.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass

import bpy
import numpy as np

from ...core.colour import spectra
from ...core.prt import albedo as core_albedo
from ...core.prt import environment as core_environment
from ...core.prt import sh
from ...core.prt import transfer as core_prt
from ..brdf import sources, storage
from ..lights.visibility import renders as _renders
from . import bake

WAVELENGTHS = sources.WAVELENGTHS
#: ColorChecker chart texture: pixels per patch side (bilinear filtering blends only the
#: outermost texel ring of each patch).
CHART_PATCH_PIXELS = 8
#: Albedo spectra per object that enter the basis (a regular subsample of the texture).
BASIS_SAMPLES = 256
ALBEDO_KEY = "sm_prt_albedo_key"

_CACHE: dict[str, tuple] = {}


class PRTError(ValueError):
    """A PRT input that cannot be used, said plainly."""


def prt_objects(scene, view_layer=None) -> list:
    """Visible mesh objects marked for spectral PRT."""
    view_layer = view_layer or scene.view_layers[0]
    return [o for o in scene.objects if o.type == "MESH" and o.spectral_prt.enabled
            and _renders(o, view_layer)]


def _cached(name: str, key, build):
    entry = _CACHE.get(name)
    if entry is not None and entry[0] == key:
        return entry[1]
    value = build()
    _CACHE[name] = (key, value)
    return value


def clear_cache() -> None:
    _CACHE.clear()


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:16]


def _file_key(path: str) -> tuple:
    path = bpy.path.abspath(path)
    try:
        stat = os.stat(path)
    except OSError:
        raise PRTError(f"cannot read '{path}': no such file") from None
    return (path, stat.st_mtime_ns, stat.st_size)


# ------------------------------------------------------------------------- environment


def _sun_direction(env) -> np.ndarray:
    el, az = float(env.sun_elevation), float(env.sun_azimuth)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def _image_rgb(image, what: str) -> np.ndarray:
    """Linear RGB (H, W, 3) of an image datablock, row 0 at the bottom."""
    if image is None:
        raise PRTError(f"{what}: no image chosen")
    width, height = image.size
    if width == 0 or height == 0:
        raise PRTError(f"{what}: image '{image.name}' has no pixels (file missing?)")
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    rgb = pixels.reshape(height, width, image.channels)[..., :3].astype(np.float64)
    if image.channels < 3:
        rgb = np.repeat(pixels.reshape(height, width, image.channels)[..., :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        # Byte images come back encoded; the uplift wants linear reflectance/radiance.
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    bad = ~np.isfinite(rgb)
    if bad.any():
        raise PRTError(f"{what}: image '{image.name}' has {int(bad.sum())} non-finite values")
    return rgb


def _environment_inputs(scene) -> tuple[tuple, dict]:
    """(key, inputs) of the scene's environment source, without projecting anything."""
    env = scene.spectral.environment
    if env.source == "SKY":
        key = ("SKY", env.illuminant, env.sky, round(env.sun_fraction, 6),
               round(env.sun_elevation, 6), round(env.sun_azimuth, 6))
        sun = _sun_direction(env) if env.sun_fraction > 0 else None
        if sun is not None and sun[2] <= 0:
            raise PRTError("Environment: the sun is below the horizon; raise its elevation")
        return key, {"kind": "SKY", "illuminant": env.illuminant, "sky": env.sky.lower(),
                     "sun_direction": sun, "sun_fraction": float(env.sun_fraction)}
    if env.source == "IMAGE":
        image = env.image
        if image is None:
            raise PRTError("Environment: choose an HDR image")
        key = ("IMAGE", image.name, tuple(image.size), image.filepath, image.is_dirty)
        return key, {"kind": "IMAGE", "image": image}
    if not env.filepath:
        raise PRTError("Environment: choose a spectral EXR file")
    return ("SPECTRAL_EXR",) + _file_key(env.filepath), {"kind": "SPECTRAL_EXR",
                                                          "path": bpy.path.abspath(
                                                              env.filepath)}


@dataclass
class EnvironmentData:
    """The environment's radiance as samples the projections start from."""

    key: tuple
    kind: str
    spd: np.ndarray | None = None          # SKY: the illuminant on WAVELENGTHS
    values: np.ndarray | None = None       # maps: (H, W, C), row 0 at the top
    wavelengths: np.ndarray | None = None  # spectral maps: the file's wavelengths
    rgb: bool = False
    sky: dict | None = None

    def basis_spectra(self) -> np.ndarray:
        """Spectra (n, L) on WAVELENGTHS that the PRT basis must represent."""
        if self.kind == "SKY":
            return self.spd[None]
        h, w = self.values.shape[:2]
        step = max(1, int(np.sqrt(h * w / BASIS_SAMPLES)))
        block = np.clip(self.values[::step, ::step].reshape(-1, self.values.shape[2]), 0, None)
        if self.rgb:
            from ...core.colour.uplift import SmitsUplift

            block = SmitsUplift()(block, WAVELENGTHS)
        # Black pixels carry no spectrum (and would be refused as an illuminant).
        lit = block[block.sum(axis=1) > 0]
        return lit if len(lit) else np.ones((1, WAVELENGTHS.size))


def environment_data(scene) -> EnvironmentData:
    """The scene environment's samples (cached by its inputs)."""
    key, inputs = _environment_inputs(scene)

    def build() -> EnvironmentData:
        from ...core.colour.pipeline import illuminant_spd

        if inputs["kind"] == "SKY":
            return EnvironmentData(key, "SKY", spd=illuminant_spd(inputs["illuminant"],
                                                                  WAVELENGTHS),
                                   sky=inputs)
        if inputs["kind"] == "IMAGE":
            rgb = _image_rgb(inputs["image"], "Environment")[::-1]      # row 0 at the top
            return EnvironmentData(key, "IMAGE", values=np.ascontiguousarray(rgb), rgb=True)
        try:
            values, wl, rgb = core_environment.read_environment_map(inputs["path"])
        except (ValueError, OSError) as exc:
            raise PRTError(f"Environment: {exc}") from None
        if rgb:
            return EnvironmentData(key, "SPECTRAL_EXR", values=values, rgb=True)
        # Spectral maps are resampled once to the PRT wavelengths.
        resampled = np.stack([np.interp(WAVELENGTHS, wl, row) for row in
                              values.reshape(-1, values.shape[2])])
        return EnvironmentData(key, "SPECTRAL_EXR",
                               values=resampled.reshape(values.shape[:2] + (-1,)),
                               wavelengths=WAVELENGTHS)

    return _cached("environment_data", key, build)


def _project(data: EnvironmentData, basis: np.ndarray | None, bands: int,
             window: str) -> core_environment.SpectralEnvironment:
    if data.kind == "SKY":
        s = data.sky
        return core_environment.sky_environment(
            s["illuminant"], WAVELENGTHS, basis, sky=s["sky"], sun_direction=s["sun_direction"],
            sun_fraction=s["sun_fraction"], bands=bands, window=window)
    return core_environment.equirect_environment(data.values, WAVELENGTHS, basis, rgb=data.rgb,
                                                 bands=bands, window=window)


def _rotation_z(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# -------------------------------------------------------------------------------- albedo


def chart_spectra(patch_pixels: int = CHART_PATCH_PIXELS) -> np.ndarray:
    """The 24 ColorChecker patches as a (4·p, 6·p, L) texture, row 0 at the bottom, patch 1
    in the top-left corner (as the chart is printed)."""
    patches = np.stack([spectra.colorchecker(i, WAVELENGTHS) for i in range(1, 25)])
    grid = patches.reshape(4, 6, -1)[::-1]              # chart row 0 is the top
    return np.repeat(np.repeat(grid, patch_pixels, axis=0), patch_pixels, axis=1)


def _albedo_inputs(obj) -> tuple[tuple, dict]:
    p = obj.spectral_prt
    what = f"Object '{obj.name}': PRT albedo"
    if p.albedo_kind == "SPECTRUM":
        values = sources.spectrum_from_source(p.albedo, obj.name, "PRT albedo")
        return ("SPECTRUM", _digest(values)), {"spectra": values[None, None]}
    if p.albedo_kind == "CHART":
        return ("CHART", CHART_PATCH_PIXELS), {"spectra": None}
    if p.albedo_kind == "IMAGE":
        if p.image is None:
            raise PRTError(f"{what}: choose an image")
        return ("IMAGE", p.image.name, tuple(p.image.size), p.image.filepath,
                p.image.is_dirty), {"image": p.image}
    if not p.filepath:
        raise PRTError(f"{what}: choose a spectral EXR file")
    return ("SPECTRAL_EXR",) + _file_key(p.filepath), {"path": bpy.path.abspath(p.filepath)}


@dataclass
class AlbedoSource:
    """An object's albedo as spectra (H, W, L) or linear RGB (H, W, 3), row 0 at the bottom."""

    key: tuple
    values: np.ndarray
    rgb: bool

    def spectra(self) -> np.ndarray:
        if not self.rgb:
            return self.values
        from ...core.colour.uplift import SmitsUplift

        h, w = self.values.shape[:2]
        return SmitsUplift()(self.values.reshape(-1, 3), WAVELENGTHS).reshape(h, w, -1)

    def basis_spectra(self) -> np.ndarray:
        h, w = self.values.shape[:2]
        step = max(1, int(np.sqrt(h * w / BASIS_SAMPLES)))
        sub = AlbedoSource(self.key, self.values[::step, ::step], self.rgb)
        return sub.spectra().reshape(-1, WAVELENGTHS.size)


def albedo_source(obj) -> AlbedoSource:
    """The object's albedo source, read once (cached by its inputs)."""
    key, inputs = _albedo_inputs(obj)

    def build() -> AlbedoSource:
        what = f"Object '{obj.name}': PRT albedo"
        if key[0] == "SPECTRUM":
            return AlbedoSource(key, inputs["spectra"], False)
        if key[0] == "CHART":
            return AlbedoSource(key, chart_spectra(), False)
        if key[0] == "IMAGE":
            return AlbedoSource(key, _image_rgb(inputs["image"], what), True)
        try:
            values = core_albedo.read_reflectance_exr(inputs["path"], WAVELENGTHS)
        except (ValueError, OSError) as exc:
            raise PRTError(f"{what}: {exc}") from None
        return AlbedoSource(key, values, False)

    return _cached(f"albedo_source:{obj.name}", key, build)


# ------------------------------------------------------------------------ the PRT state


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

    basis = _cached("basis", basis_key, build_basis)
    projected = _cached("projection", projection_key,
                        lambda: _project(data, basis, int(env.bands), env.window.lower()))
    rotation = round(float(env.rotation), 9)
    key = projection_key + (rotation,)

    def build() -> SceneEnvironment:
        turned = projected.rotated(_rotation_z(rotation)) if rotation else projected
        return SceneEnvironment(key, turned, basis, core_prt.white_y(turned))

    return _cached("scene_environment", key, build)


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
    key = f"{_digest(state.basis)}:{source.key}"

    def build() -> core_albedo.AlbedoLayers:
        stored = obj.spectral_prt.albedo_image
        if stored is not None and stored.get(ALBEDO_KEY) == key:
            return _layers_from_image(stored, state.basis)
        values = source.values
        if source.rgb:
            return core_albedo.albedo_layers_from_rgb(values, WAVELENGTHS, state.basis)
        return core_albedo.albedo_layers_from_spectra(values, WAVELENGTHS, state.basis,
                                                      source=str(source.key[0]))

    layers = _cached(f"albedo_layers:{obj.name}", key, build)
    layers.key = key
    return layers


def _layers_from_image(image, basis: np.ndarray) -> core_albedo.AlbedoLayers:
    m = basis.shape[1]
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
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


# ---------------------------------------------------------------------------- the bake


@dataclass
class BakePlan:
    """What a transfer bake needs, read from the scene on the main thread (plain data: the
    tracing may run in a worker thread)."""

    object_name: str
    geometry: bake.MeshGeometry
    rays: int
    bands: int
    backend: str = "auto"


def plan_bake(obj, scene=None, *, backend: str = "auto", depsgraph=None) -> BakePlan:
    """Check ``obj`` and read its evaluated mesh for :func:`run_bake`."""
    scene = scene or bpy.context.scene
    if obj is None or obj.type != "MESH":
        raise PRTError(f"PRT bakes meshes; '{getattr(obj, 'name', obj)}' is not one")
    albedo_source(obj)                     # a bad albedo fails before the long part
    rays = int(obj.spectral_prt.rays)
    if not 1 <= rays <= core_prt.MAX_RAYS:
        raise PRTError(f"Object '{obj.name}': rays per vertex must be 1..{core_prt.MAX_RAYS}, "
                       f"got {rays}")
    try:
        geometry = bake.read_geometry(obj, depsgraph)
    except ValueError as exc:
        raise PRTError(str(exc)) from None
    if len(geometry.positions) != len(obj.data.vertices):
        raise PRTError(f"Object '{obj.name}': its modifiers change the vertex count "
                       f"({len(obj.data.vertices)} → {len(geometry.positions)}); PRT stores "
                       "the transfer per mesh vertex, so apply those modifiers first")
    if not np.isfinite(geometry.positions).all():
        raise PRTError(f"Object '{obj.name}' has non-finite vertex positions")
    return BakePlan(obj.name, geometry, rays, int(scene.spectral.environment.bands), backend)


def run_bake(plan: BakePlan, callback=None) -> bake.TransferBake:
    """Trace and project (never touches ``bpy`` data: safe in a worker thread)."""
    seen = bake.trace_geometry(plan.geometry, rays=plan.rays, callback=callback,
                               backend=plan.backend)
    return bake.project_transfer(seen, sh.sh_basis(seen.directions, plan.bands), callback)


def commit_bake(scene, plan: BakePlan, result: bake.TransferBake) -> None:
    """Store the transfer on the mesh and every PRT object's albedo layers (main thread).
    Refuses a result whose mesh changed while it was traced."""
    obj = bpy.data.objects.get(plan.object_name)
    if obj is None:
        raise PRTError(f"Object '{plan.object_name}' was removed during the bake")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        current = bake.geometry_key(mesh)
    finally:
        evaluated.to_mesh_clear()
    if current != result.key:
        raise PRTError(f"Object '{obj.name}' changed during the bake; bake it again")
    was_enabled = obj.spectral_prt.enabled
    obj.spectral_prt.enabled = True        # its albedo enters the scene's basis
    try:
        for other in prt_objects(scene):   # the basis may change for every object
            store_albedo(other, scene)
    except BaseException:
        obj.spectral_prt.enabled = was_enabled
        raise
    bake.store_transfer(obj.data, result)


def bake_prt(obj, scene=None, *, callback=None, backend: str = "auto", depsgraph=None
             ) -> bake.TransferBake:
    """Bake ``obj``'s transfer (the scene's SH bands, the object's ray count) and store it
    with the albedo layers: :func:`plan_bake`, :func:`run_bake`, :func:`commit_bake`.
    Nothing changes if it fails or is cancelled."""
    scene = scene or bpy.context.scene
    plan = plan_bake(obj, scene, backend=backend, depsgraph=depsgraph)
    result = run_bake(plan, callback)
    commit_bake(scene, plan, result)
    return result


def clear_prt(obj) -> None:
    """Remove the object's stored transfer and albedo layers."""
    bake.clear_transfer(obj.data)
    image = obj.spectral_prt.albedo_image
    obj.spectral_prt.albedo_image = None
    if image is not None and image.users == 1 and image.use_fake_user:
        storage.remove_image(image)
    _CACHE.pop(f"albedo_layers:{obj.name}", None)


# ----------------------------------------------------------------------- vertex colours


def _evaluated_arrays(obj, depsgraph):
    """(transfer (V, K), vertex UVs (V, 2)) of the evaluated mesh."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        transfer = bake.load_transfer(mesh)
        if transfer is None:
            raise PRTError(f"Object '{obj.name}' has no current PRT transfer: bake it "
                           "(the mesh changed or was never baked)")
        uv = vertex_uvs(mesh)
    finally:
        evaluated.to_mesh_clear()
    return transfer, uv


def vertex_uvs(mesh) -> np.ndarray:
    """Active-UV coordinates per vertex (V, 2): the mean over the vertex's corners (zeros
    without a UV map)."""
    count = len(mesh.vertices)
    if mesh.uv_layers.active is None or not len(mesh.loops):
        return np.zeros((count, 2))
    loops = len(mesh.loops)
    uv = np.empty(loops * 2, dtype=np.float32)
    mesh.uv_layers.active.uv.foreach_get("vector", uv)
    index = np.empty(loops, dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", index)
    total = np.zeros((count, 2))
    np.add.at(total, index, uv.reshape(-1, 2))
    counts = np.bincount(index, minlength=count)[:, None]
    return total / np.maximum(counts, 1)


def vertex_xyz(obj, scene=None, depsgraph=None) -> np.ndarray:
    """Linear CIE XYZ (n_vertices, 3) of the outgoing radiance at each vertex of ``obj``
    under the scene's current environment, normalised to the environment's white (a
    white, unoccluded Lambertian facing world up has Y = 1, however the object is turned:
    the scene's ``white_y``, which the viewport divides by too). Float64; the viewport
    draws the same numbers interpolated over the faces.

    The environment is turned into the object's frame by :func:`object_rotation`
    (mirrors included); scale is not baked: uniform scale is exact, non-uniform scale an
    approximation (:func:`scale_anisotropy`).
    """
    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    if obj is None or obj.type != "MESH":
        raise PRTError(f"'{getattr(obj, 'name', obj)}' is not a mesh")
    transfer, uv = _evaluated_arrays(obj, depsgraph)
    environment = object_environment(obj, scene)
    if transfer.shape[1] != environment.coefficients.shape[0]:
        raise PRTError(f"Object '{obj.name}' was baked with {transfer.shape[1]} SH "
                       f"coefficients, the environment has {environment.coefficients.shape[0]}"
                       " (SH bands changed): bake it again")
    weights = core_albedo.sample_layers(albedo_layers(obj, scene).layers, uv)
    return core_prt.vertex_xyz(transfer, environment, weights)


def environment_white_xyz(scene) -> np.ndarray:
    """XYZ of the white up-facing Lambertian under the environment (Y = 1): the white the
    display adapts from."""
    state = scene_environment(scene)
    env = state.environment
    up = sh.zonal_to_sh(sh.clamped_cosine_zonal(env.bands), np.array([0.0, 0.0, 1.0]))
    white = core_prt.albedo_weights(np.ones(WAVELENGTHS.size), WAVELENGTHS, env.basis)
    return (up @ env.coefficients) @ white / state.white_y


# ----------------------------------------------------------------- Monte Carlo reference


def reference_environment(scene):
    """The scene environment unprojected (``core.prt_reference.ReferenceEnvironment``),
    world frame, scene rotation applied: what the PRT colours are measured against."""
    data = environment_data(scene)
    rotation = float(scene.spectral.environment.rotation)
    if data.kind == "SKY":
        s = data.sky
        reference = core_environment.sky_reference(
            s["illuminant"], WAVELENGTHS, sky=s["sky"], sun_direction=s["sun_direction"],
            sun_fraction=s["sun_fraction"])
    else:
        reference = core_environment.equirect_reference(data.values, WAVELENGTHS, rgb=data.rgb)
    return reference.rotated(_rotation_z(rotation)) if rotation else reference


def vertex_albedo_spectra(obj, uv: np.ndarray) -> np.ndarray:
    """The albedo spectra (V, L) at texture coordinates ``uv``, filtered as the layers are
    (bilinear, repeat): the reference's albedo at the vertices."""
    values = albedo_source(obj).spectra()                         # (H, W, L)
    h, w, count = values.shape
    pad = -(-count // 3) * 3
    stack = np.zeros((h, w, pad))
    stack[..., :count] = values
    # sample_layers filters three channels per layer; spectra go through as L/3 layers.
    layers = stack.reshape(h, w, pad // 3, 3).transpose(2, 0, 1, 3)
    return core_albedo.sample_layers(layers, uv).reshape(len(uv), pad)[:, :count]


def world_geometry(obj, depsgraph) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(positions, normals, triangles, uvs) of the evaluated mesh in world space."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        co, normals = bake._mesh_arrays(mesh)
        triangles = bake._loop_triangles(mesh)
        uv = vertex_uvs(mesh)
    finally:
        evaluated.to_mesh_clear()
    matrix = np.array(obj.matrix_world)
    world = co @ matrix[:3, :3].T + matrix[:3, 3]
    return world, bake.unit_normals(normals @ np.linalg.inv(matrix[:3, :3])), triangles, uv


def _reference_inputs(obj, depsgraph):
    """(points, normals, vertex UVs, visibility function, ray offset) in world space."""
    from ...core.prt import raycast

    points, normals, triangles, uv = world_geometry(obj, depsgraph)
    occluder = raycast.Occluder(points, triangles)
    extent = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)) or 1.0)
    return (points, normals, uv, lambda o, d: ~occluder.occluded(o, d),
            bake.ORIGIN_OFFSET * extent)


def vertex_reference_irradiance(obj, scene=None, depsgraph=None, *, rays: int = 4096,
                                seed: int = 0) -> np.ndarray:
    """Monte Carlo spectral irradiance (V, L) at ``obj``'s vertices (world space, 5 nm, the
    true environment, the object's own triangles as occluders)."""
    from ...core.prt import reference as prt_reference

    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    points, normals, _, visible, offset = _reference_inputs(obj, depsgraph)
    return prt_reference.reference_irradiance(points, normals, reference_environment(scene),
                                              visible, rays=rays, seed=seed, offset=offset)


def vertex_reference_xyz(obj, scene=None, depsgraph=None, *, rays: int = 4096,
                         seed: int = 0) -> np.ndarray:
    """The Monte Carlo reference of :func:`vertex_xyz`: 5 nm, the true (unprojected)
    environment, the same self-visibility (the object's own triangles), ``rays``
    cosine-distributed rays per vertex."""
    from ...core.prt import reference as prt_reference

    scene = scene or bpy.context.scene
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    points, normals, uv, visible, offset = _reference_inputs(obj, depsgraph)
    return prt_reference.reference_vertex_xyz(
        points, normals, vertex_albedo_spectra(obj, uv), reference_environment(scene),
        visible, rays=rays, seed=seed, offset=offset)


#: Scale anisotropy (:func:`scale_anisotropy`) the panel lets pass as uniform (float32
#: matrices and typed-in scales carry ~1e-7).
ANISOTROPY_TOLERANCE = 1e-4


def transfer_status(obj) -> str:
    """One line for the panel: baked (how), stale, not baked, or baked but approximate
    (a non-uniform scale, which the bake does not include)."""
    mesh = obj.data
    state = bake.transfer_state(mesh)
    if state == "absent":
        return "Not baked"
    if state == "stale":
        return "Stale: the mesh changed since the bake; bake again"
    if scale_anisotropy(obj) > ANISOTROPY_TOLERANCE:
        return "Approximate: the object's scale is not uniform and the transfer was baked " \
            "without it; apply the scale and bake again"
    return f"Baked: {len(mesh.vertices)} vertices × {len(bake.transfer_names(mesh))} SH " \
        "coefficients"
