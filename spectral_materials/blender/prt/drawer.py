"""Drawing PRT objects: the spectral PRT paper's two dot products on the GPU.

The vertex stage (glsl/prt/prt_vert.glsl) computes Ê = T̃ · L̃ per vertex, the fragment stage
(glsl/prt/prt_frag.glsl) XYZ = Σ_j Ê_j R̃_j(uv). The PRT shader variants are separate from
the factor-pack shaders and are compiled only when a scene has PRT objects.

Per object, on the GPU: a batch of mesh corners (position, UV, vertex index), the
transfer texture (RGBA32F, ``ceil(K/4)`` texels per vertex, :data:`TRANSFER_WIDTH`
texels a row), the environment texture (one row per SH coefficient, padded to a
multiple of 4, ``ceil(m/4)`` texels of spectral coefficients, already turned into the
object's frame by ``prt.object_rotation`` (a reflection for a mirrored object) and
divided by the scene's white Y, that of the world frame, as ``prt.vertex_xyz`` is) and
the albedo texture array in the form the object's *Albedo texture* chooses
(``core.prt.albedo_forms``): the ``3m`` values of R̃ packed four to a layer as 16-bit
unorm texels filtered by the texture unit with their ranges in the uniform buffer
``sm_range``, or as ``r`` weights per texel in a basis of the texture's own R̃ vectors
with the mixing array in the uniform buffer ``sm_basis``, or as float32 filtered by
hand. Each is rebuilt only when its inputs change.

``rgb=True`` draws classical RGB PRT (L̃ and the albedo reduced to linear sRGB, one
layer), the baseline of the frame-time and accuracy comparisons.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.prt import transfer as core_prt
from ...core.prt.albedo import packed_layer_count
from ...core.prt.albedo_basis import MAX_RANK, AlbedoBasis
from ...core.prt.albedo_forms import DrawnAlbedo, drawn_albedo
from ..gpu import batches as mesh_batches, shaders
from ..gpu.display import DisplaySettings, display_matrices, std140_mat4
from ..gpu.matrices import set_matrix
from ..gpu.mesh_arrays import (
    check_finite,
    corner_uvs,
    corner_vertices,
    evaluated_mesh,
    loop_triangles,
    vertex_positions,
)
from ..gpu.outputs import PRT_REQUESTS, output_defines
from ..gpu.shaders import glsl_source
from ..gpu.std140 import glsl_block
from ..gpu.textures import array_texture, float_texture
from ..viewport import registry
from . import bake, scene as prt

TRANSFER_WIDTH = 4096
#: Spectral coefficients the varyings carry (4 vec4).
MAX_COEFFICIENTS = 16
#: The output requests the PRT shader answers (blender/gpu/outputs.py).
PRT_OUTPUTS = PRT_REQUESTS
#: ``SmPrtParams`` as glsl/prt/prt_params.glsl declares it: the packer's one spec.
PARAMS = glsl_block("prt/prt_params.glsl", "SmPrtParams")
PARAMS_BYTES = PARAMS.size

_OBJECTS: dict[str, dict] = {}
#: PRT objects that could not be drawn: name → reason (shown in the panel).
FAILED: dict[str, str] = {}


@dataclass(frozen=True)
class PRTShaderKey:
    sh_coefficients: int
    coefficients: int           # spectral basis size (3 for RGB PRT)
    rgb: bool = False
    output: str = "DISPLAY"
    #: L̃ in the uniform buffer ``sm_env`` (:func:`environment_fits`), else the texture.
    environment_buffer: bool = True
    #: RGBA layers of albedo-basis weights (``core.prt.albedo_basis``); 0: the R̃ layers.
    albedo_basis_layers: int = 0
    #: The packed R̃ layers as unorm16 filtered by the texture unit, decoded with the
    #: ranges in ``sm_range`` (``core.prt.albedo_forms.unorm16_texels``).
    unorm_layers: bool = False

    @property
    def texels(self) -> int:
        return -(-self.sh_coefficients // 4)

    @property
    def vec4s(self) -> int:
        return -(-self.coefficients // 4)

    @property
    def environment_texels(self) -> int:
        """vec4s of L̃ (:func:`environment_texels`): 4⌈K/4⌉ rows of ⌈m/4⌉."""
        return 4 * self.texels * self.vec4s

    @property
    def albedo_layers(self) -> int:
        """Layers of the albedo texture: one RGB layer for RGB PRT, else the 3m values
        packed four to a texel (``albedo.layers_to_rgba``)."""
        if self.albedo_basis_layers:
            return self.albedo_basis_layers
        return 1 if self.rgb else packed_layer_count(self.coefficients)

    @property
    def albedo_basis_texels(self) -> int:
        """vec4s of the mixing array in ``sm_basis`` (:func:`albedo_basis_texels`)."""
        return 3 * self.albedo_basis_layers * 4 * self.vec4s

    def defines(self) -> dict[str, str]:
        return {"SM_PRT_TEXELS": str(self.texels), "SM_PRT_COEFFS": str(self.coefficients),
                "SM_PRT_VEC4": str(self.vec4s), "SM_PRT_RGB": "1" if self.rgb else "0",
                "SM_PRT_LAYERS": str(self.albedo_layers),
                "SM_PRT_ENV_BUFFER": "1" if self.environment_buffer else "0",
                "SM_PRT_BASIS_LAYERS": str(self.albedo_basis_layers),
                "SM_PRT_UNORM_LAYERS": "1" if self.unorm_layers else "0",
                **output_defines(PRT_OUTPUTS[self.output])}

    def validate(self) -> None:
        if not 1 <= self.coefficients <= MAX_COEFFICIENTS:
            raise ValueError(f"the PRT shader carries 1..{MAX_COEFFICIENTS} spectral "
                             f"coefficients, got {self.coefficients}")
        if self.output not in PRT_OUTPUTS:
            raise ValueError(f"unknown output {self.output!r}")
        if self.environment_buffer and not environment_fits(self.sh_coefficients,
                                                            self.coefficients):
            raise ValueError(f"L̃ of {self.sh_coefficients} SH × {self.coefficients} "
                             "coefficients exceeds the uniform buffer; use the texture")
        if self.albedo_basis_layers and (self.rgb or not 1 <= self.albedo_basis_layers
                                         <= -(-MAX_RANK // 4)):
            raise ValueError(f"no albedo basis of {self.albedo_basis_layers} layers "
                             f"{'for RGB PRT' if self.rgb else ''}")
        if self.unorm_layers and (self.rgb or self.albedo_basis_layers):
            raise ValueError("unorm16 albedo layers are for the spectral R̃ layers only")


def environment_fits(sh_coefficients: int, coefficients: int) -> bool:
    """Whether L̃ (per-draw constant data) fits the uniform buffer ``sm_env``: the 16 KiB
    every OpenGL allows, up to 16 bands at m = 16. Larger ones stay in a texture."""
    texels = 4 * -(-int(sh_coefficients) // 4) * -(-int(coefficients) // 4)
    return texels <= shaders.MAX_LIGHT_BUFFER_TEXELS


def create_info(key: PRTShaderKey):
    import gpu

    key.validate()
    info = gpu.types.GPUShaderCreateInfo()
    for name, value in key.defines().items():
        info.define(name, value)
    typedefs = glsl_source("prt/prt_params.glsl")
    if key.environment_buffer:
        # One struct per size: the array length is the variant's L̃.
        typedefs += (f"\nstruct SmPrtEnvironment {{\n  vec4 texels[{key.environment_texels}];"
                     "\n};\n")
    if key.albedo_basis_layers:
        typedefs += (f"\nstruct SmPrtAlbedoBasis {{\n  vec4 texels[{key.albedo_basis_texels}];"
                     "\n};\n")
    if key.unorm_layers:
        typedefs += (f"\nstruct SmPrtAlbedoRange {{\n  vec4 texels[{2 * key.albedo_layers}];"
                     "\n};\n")
    info.typedef_source(typedefs)
    info.uniform_buf(0, "SmPrtParams", "sm")
    if key.albedo_basis_layers:
        info.uniform_buf(2, "SmPrtAlbedoBasis", "sm_basis")
    elif key.unorm_layers:
        info.uniform_buf(2, "SmPrtAlbedoRange", "sm_range")
    info.sampler(0, "FLOAT_2D", "transfer_tex")
    if key.environment_buffer:
        info.uniform_buf(1, "SmPrtEnvironment", "sm_env")
    else:
        info.sampler(1, "FLOAT_2D", "environment_tex")
    info.sampler(2, "FLOAT_2D_ARRAY", "albedo_tex")
    info.push_constant("MAT4", "model_matrix")
    info.vertex_in(0, "VEC3", "position")
    info.vertex_in(1, "VEC2", "uv")
    info.vertex_in(2, "FLOAT", "vertex_index")
    interface = gpu.types.GPUStageInterfaceInfo("sm_prt_interface")
    for b in range(key.vec4s):
        interface.smooth("VEC4", f"prt_e{b}")
    interface.smooth("VEC3", "world_position")
    interface.smooth("VEC2", "tex_uv")
    info.vertex_out(interface)
    info.vertex_source(glsl_source("prt/prt_vert.glsl"))
    info.fragment_out(0, "VEC4", "frag_colour")
    info.fragment_source(glsl_source("common/colour_pipeline.glsl") + "\n" +
                         glsl_source("prt/prt_frag.glsl"))
    return info


def get_shader(key: PRTShaderKey):
    """The compiled PRT variant (cached with the other variants in ``shaders``)."""
    return shaders.get_shader(key, create_info)


def params_block(view_projection: np.ndarray, display: DisplaySettings,
                 transfer_width: int, albedo_size: tuple[int, int]) -> bytes:
    """The std140 bytes of ``SmPrtParams`` (glsl/prt/prt_params.glsl), matrices column-major."""
    adapt, to_rgb, to_xyz = display_matrices(tuple(display.scene_white))
    return PARAMS.pack(
        view_projection=std140_mat4(view_projection), adaptation=adapt, xyz_to_rgb=to_rgb,
        rgb_to_xyz=to_xyz, display=(display.exposure, display.tone_white, 0.0, 0.0),
        sizes=(transfer_width, albedo_size[0], albedo_size[1], 0))


# ----------------------------------------------------------------------- object data


@dataclass
class PRTMeshArrays:
    """Per-corner position, UV and vertex index, the triangles, and the transfer."""

    positions: np.ndarray       # (C, 3) float32
    uvs: np.ndarray             # (C, 2) float32
    vertex_index: np.ndarray    # (C,) float32 (exact below 2²⁴ vertices)
    triangles: np.ndarray       # (T, 3) int32, corner indices
    transfer: np.ndarray        # (V, K) float32

    @property
    def nbytes(self) -> int:
        return int(self.positions.nbytes + self.uvs.nbytes + self.vertex_index.nbytes
                   + self.triangles.nbytes + self.transfer.nbytes)


def prt_mesh_arrays(obj, mesh) -> PRTMeshArrays:
    transfer = bake.load_transfer(mesh)
    if transfer is None:
        raise prt.PRTError(f"Object '{obj.name}' has no current PRT transfer: bake it")
    if len(mesh.vertices) >= 1 << 24:
        raise prt.PRTError(f"Object '{obj.name}': PRT draws meshes below 2²⁴ vertices")
    tris = loop_triangles(mesh)
    co = vertex_positions(mesh)
    try:
        check_finite(mesh, co)
    except ValueError as exc:
        raise prt.PRTError(f"Object '{obj.name}': {exc}") from None
    index = corner_vertices(mesh)
    uvs = corner_uvs(mesh)
    # Corners that share a vertex and a UV are one GPU vertex: the vertex stage's T̃ · L̃
    # then runs about once per mesh vertex instead of once per corner (≈ 4× on quads).
    keys = np.concatenate([index[:, None].view(np.float32), uvs], axis=1)
    unique, first, inverse = np.unique(keys.view(np.dtype((np.void, 12))).ravel(),
                                       return_index=True, return_inverse=True)
    del unique
    positions = co[index[first]]
    return PRTMeshArrays(np.ascontiguousarray(positions), np.ascontiguousarray(uvs[first]),
                         index[first].astype(np.float32),
                         inverse.astype(np.int32)[tris].reshape(-1, 3), transfer)


def transfer_texels(transfer: np.ndarray, width: int = TRANSFER_WIDTH) -> np.ndarray:
    """(rows, width, 4) texels: vertex v's coefficients at texels v·⌈K/4⌉ …, zero padded."""
    v, k = transfer.shape
    per = -(-k // 4)
    flat = np.zeros((v, per * 4), dtype=np.float32)
    flat[:, :k] = transfer
    texels = flat.reshape(-1, 4)
    width = min(width, max(1, len(texels)))
    rows = -(-len(texels) // width)
    out = np.zeros((rows * width, 4), dtype=np.float32)
    out[: len(texels)] = texels
    return out.reshape(rows, width, 4)


def environment_texels(coefficients: np.ndarray) -> np.ndarray:
    """(4·⌈K/4⌉, ⌈m/4⌉, 4) texels of L̃ (K, m): row k holds coefficient k's spectrum."""
    k, m = coefficients.shape
    out = np.zeros((-(-k // 4) * 4, -(-m // 4) * 4), dtype=np.float32)
    out[:k, :m] = coefficients
    return out.reshape(out.shape[0], -1, 4)




def albedo_basis_texels(basis: AlbedoBasis, coefficients: int) -> np.ndarray:
    """(3·L·4⌈m/4⌉, 4) float32 texels of ``sm_basis``: texel ``(l·3 + c)·4⌈m/4⌉ + j`` holds
    ``mixing[4l:4l+4, j, c]``, the four weights of layer ``l`` (zero-padded), as
    glsl/prt/prt_frag.glsl reads it."""
    layers, m = basis.weight_layers, coefficients
    width = 4 * -(-m // 4)
    mix = np.zeros((4 * layers, width, 3), dtype=np.float32)
    mix[:basis.rank, :m] = basis.mixing
    return np.ascontiguousarray(mix.reshape(layers, 4, width, 3).transpose(0, 3, 2, 1)
                                .reshape(-1, 4))




def albedo_status(obj) -> str:
    """What the object's spectral albedo texture holds, for the panel: '' until it is
    drawn spectrally with the object's current *Albedo texture* setting."""
    key = _OBJECTS.get(obj.name, {}).get("albedo_key")
    if key is None or key[1] or key[2] != obj.spectral_prt.albedo_texture.lower():
        return ""
    entry = _OBJECTS[obj.name]
    m = entry["coefficients"]
    drawn: DrawnAlbedo = entry["albedo_drawn"]
    packed = packed_layer_count(m)
    if drawn.form == "unorm16":
        return (f"Albedo: {3 * m} 16-bit values per texel in {packed} layers, "
                f"ΔE94 ≤ {drawn.delta_e94:.3f}")
    if drawn.form == "basis":
        return (f"Albedo: {drawn.basis.rank} weights per texel in "
                f"{drawn.basis.weight_layers} layers (of {packed}), "
                f"ΔE94 ≤ {drawn.delta_e94:.3f}")
    return f"Albedo: {3 * m} values per texel in {packed} layers"


def _scene_light(state) -> np.ndarray:
    """The light Automatic's colour check adds for this scene: the environment's mean
    radiance on the PRT basis (its SH DC row, the same in every frame and rotation)."""
    return np.asarray(state.environment.coefficients[0], dtype=np.float64)


def _drawn_albedo(entry: dict, layers, form: str, light: np.ndarray) -> DrawnAlbedo:
    """The drawn form of the object's layers, kept across RGB/spectral switches (a colour
    check over every texel, or an eigen-decomposition, is not redone per switch)."""
    key = (layers.key, form, light.tobytes())
    kept = entry.get("albedo_drawn_of")
    if kept is not None and kept[0] == key:
        return kept[1]
    # Layers are finite: every source checks its values, a stored image included
    # (state.layers_from_image names it).
    drawn = drawn_albedo(layers, form, lights=(light,))
    entry["albedo_drawn_of"] = (key, drawn)
    return drawn


def _albedo_resources(entry: dict, obj, scene, state, rgb: bool):
    """The object's albedo texture (and its uniform buffer) in ``entry``, rebuilt when its
    layers, the mode, the form or the scene light Automatic checks under change; returns
    the layers."""
    import gpu

    layers = prt.albedo_layers(obj, scene)
    form = obj.spectral_prt.albedo_texture.lower()
    light = _scene_light(state)
    # RGB PRT draws one RGB layer whatever the form; spectral, the form checked under the
    # scene's light.
    albedo_key = (layers.key, True) if rgb else (layers.key, False, form, light.tobytes())
    if entry.get("albedo_key") != albedo_key:
        if rgb:
            source = prt.albedo_source(obj)
            data = core_prt.rgb_albedo(source.spectra(), prt.WAVELENGTHS)[None]
            entry["albedo_drawn"] = None
            entry["albedo"] = array_texture(data)
            entry["albedo_size"] = (data.shape[2], data.shape[1])
        else:
            drawn = entry["albedo_drawn"] = _drawn_albedo(entry, layers, form, light)
            if drawn.basis is not None:
                entry["albedo_buffer"] = gpu.types.GPUUniformBuf(
                    albedo_basis_texels(drawn.basis, layers.layers.shape[0]).tobytes())
            elif drawn.unorm16 is not None:
                entry["albedo_buffer"] = gpu.types.GPUUniformBuf(
                    drawn.unorm16.range_texels().tobytes())
            entry["albedo"] = array_texture(drawn.texels(), filtered=drawn.filtered,
                                            texture_format=drawn.texture_format)
            # The shader's sizes are the albedo's own, less any wrap padding.
            entry["albedo_size"] = (layers.layers.shape[2], layers.layers.shape[1])
        entry["albedo_key"] = albedo_key
    return layers


def _object_resources(obj, scene, depsgraph, rgb: bool) -> dict:
    """The object's batch and textures, rebuilt piecewise when their inputs change."""
    import gpu

    entry = _OBJECTS.setdefault(obj.name, {})
    mesh_key = (obj.data.name, mesh_batches.serial(obj.name))
    if entry.get("mesh_key") != mesh_key:
        with evaluated_mesh(obj, depsgraph) as mesh:
            arrays = prt_mesh_arrays(obj, mesh)
        fmt = gpu.types.GPUVertFormat()
        fmt.attr_add(id="position", comp_type="F32", len=3, fetch_mode="FLOAT")
        fmt.attr_add(id="uv", comp_type="F32", len=2, fetch_mode="FLOAT")
        fmt.attr_add(id="vertex_index", comp_type="F32", len=1, fetch_mode="FLOAT")
        vbo = gpu.types.GPUVertBuf(fmt, len(arrays.positions))
        vbo.attr_fill("position", arrays.positions)
        vbo.attr_fill("uv", np.ascontiguousarray(arrays.uvs))
        vbo.attr_fill("vertex_index", arrays.vertex_index)
        ibo = gpu.types.GPUIndexBuf(type="TRIS", seq=arrays.triangles)
        texels = transfer_texels(arrays.transfer)
        entry.clear()
        entry.update(mesh_key=mesh_key, arrays=arrays,
                     batch=gpu.types.GPUBatch(type="TRIS", buf=vbo, elem=ibo),
                     transfer=float_texture(texels), transfer_width=texels.shape[1])
    state = prt.scene_environment(scene)
    rotation = prt.object_rotation(obj)
    env_key = (state.key, rotation.round(9).tobytes(), rgb)
    if entry.get("env_key") != env_key:
        environment = state.environment.rotated(rotation.T)
        if environment.coefficients.shape[0] != entry["arrays"].transfer.shape[1]:
            raise prt.PRTError(f"Object '{obj.name}' was baked with "
                               f"{entry['arrays'].transfer.shape[1]} SH coefficients, the "
                               f"environment has {environment.coefficients.shape[0]}: bake "
                               "it again")
        coefficients = core_prt.rgb_environment(environment) if rgb else \
            environment.coefficients
        texels = environment_texels(coefficients / state.white_y)
        entry["environment"] = texels
        entry["environment_gpu"] = {}
        entry["env_key"] = env_key
    layers = _albedo_resources(entry, obj, scene, state, rgb)
    entry["coefficients"] = 3 if rgb else layers.layers.shape[0]
    return entry


def draw_prt_objects(scene, depsgraph, view_projection: np.ndarray, *,
                     output: str = "DISPLAY", display: DisplaySettings | None = None,
                     rgb: bool = False, objects=None) -> list[str]:
    """Draw the scene's PRT objects into the bound framebuffer; returns their names."""
    import gpu

    objects = prt.prt_objects(scene) if objects is None else objects
    if not objects:
        return []
    display = display or DisplaySettings()
    drawn = []
    FAILED.clear()
    for obj in objects:
        try:
            entry = _object_resources(obj, scene, depsgraph, rgb)
        except prt.PRTError as exc:
            # One object without a bake must not stop the others from drawing.
            FAILED[obj.name] = str(exc)
            _OBJECTS.pop(obj.name, None)
            continue
        sh_count = entry["arrays"].transfer.shape[1]
        albedo = entry["albedo_drawn"]
        basis = None if albedo is None else albedo.basis
        key = PRTShaderKey(sh_count, entry["coefficients"], rgb, output,
                           environment_fits(sh_count, entry["coefficients"]),
                           basis.weight_layers if basis is not None else 0,
                           albedo is not None and albedo.form == "unorm16")
        shader = get_shader(key)
        shader.bind()
        params = gpu.types.GPUUniformBuf(params_block(
            view_projection, display, entry["transfer_width"], entry["albedo_size"]))
        shader.uniform_block("sm", params)
        shader.uniform_sampler("transfer_tex", entry["transfer"])
        bind_environment(shader, key, entry)
        shader.uniform_sampler("albedo_tex", entry["albedo"])
        if key.albedo_basis_layers:
            shader.uniform_block("sm_basis", entry["albedo_buffer"])
        elif key.unorm_layers:
            shader.uniform_block("sm_range", entry["albedo_buffer"])
        set_matrix(shader, "model_matrix", np.array(obj.matrix_world))
        entry["batch"].draw(shader)
        drawn.append(obj.name)
    return drawn


def bind_environment(shader, key: PRTShaderKey, entry: dict) -> None:
    """L̃ as the variant reads it: the uniform buffer ``sm_env`` or the texture, each made
    once per environment (and object rotation) and kept in ``entry``."""
    import gpu

    kind = "buffer" if key.environment_buffer else "texture"
    made = entry["environment_gpu"]
    if kind not in made:
        texels = entry["environment"]
        made[kind] = (gpu.types.GPUUniformBuf(texels.astype(np.float32).tobytes())
                      if kind == "buffer" else float_texture(texels))
    if kind == "buffer":
        shader.uniform_block("sm_env", made[kind])
    else:
        shader.uniform_sampler("environment_tex", made[kind])


def _draw_registered(scene, depsgraph, objects: list, frame: registry.DrawFrame) -> list[str]:
    """The viewport's call: the frame's output where PRT has it, else XYZ."""
    output = frame.output if frame.output in PRT_OUTPUTS else "XYZ"
    return draw_prt_objects(scene, depsgraph, frame.view_projection, output=output,
                            display=frame.display, objects=objects)


def clear_cache() -> None:
    """The GPU resources and the scene's derived PRT data (environment, basis, layers)."""
    _OBJECTS.clear()
    FAILED.clear()
    prt.clear_cache()


DRAWER = registry.ObjectDrawer(
    name="PRT", order=50, objects=prt.prt_objects, draw=_draw_registered,
    clear_cache=clear_cache, failures=lambda: FAILED)
registry.register(DRAWER)
