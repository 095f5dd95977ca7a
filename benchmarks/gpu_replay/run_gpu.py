"""Replay the exported benchmark draws on a GPU without Blender: frame times and checks.

Needs only numpy and moderngl (EGL). For each case of ``data/manifest.json`` (written by
``export_cases.py`` from the project's own draws) it

* builds the GLSL the way Blender 5.0's OpenGL backend assembles a create-info
  (``emulated``; see :func:`emulate_stage`) and, as a control, compiles the exact text
  Blender handed Mesa when the reference was drawn (``blender``, from Mesa's dump);
* uploads the recorded uniform-buffer bytes, textures (RGBA32F), push constants, the
  interleaved vertex buffer and the index buffer, sets the recorded GL state and draws
  into an RGBA32F colour + DEPTH32F_STENCIL8 framebuffer of the recorded size;
* times the draw with GL timer queries (GL_TIME_ELAPSED): warm-up frames, then the
  median, min and p90 of the timed frames (clear outside the query); also a clear+draw
  query and the wall time of back-to-back frames ended by glFinish;
* reads the image back and compares it with the project's own read-back (coverage
  mask at full resolution, strided subsample and crops: relative difference per pixel =
  max over RGB of |gpu − ref| / max(max over RGB of |ref|, 1e-4); NaN/Inf anywhere
  fails).

Prints a table last and writes everything to $OUT/gpu_results.json ($OUT unset:
./gpu_results.json).

Environment: GLCONTEXT_DEVICE_INDEX (EGL device), GLCONTEXT_LINUX_LIBGL /
GLCONTEXT_LINUX_LIBEGL (libraries; default: libGL.so.1 if it loads, else libOpenGL.so.0,
and libEGL.so.1), SM_GL_BACKEND (``egl`` default; ``default`` lets moderngl choose),
SM_REQUIRE_GPU=1 (reject llvmpipe/softpipe contexts), SM_DEPTH=moderngl (moderngl's
24-bit depth texture instead of DEPTH32F_STENCIL8 made through libOpenGL).
"""

from __future__ import annotations

import argparse
import ctypes
import fnmatch
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

GLSL_TYPES = {"FLOAT": "float", "VEC2": "vec2", "VEC3": "vec3", "VEC4": "vec4",
              "MAT3": "mat3", "MAT4": "mat4", "INT": "int", "IVEC2": "ivec2",
              "IVEC3": "ivec3", "IVEC4": "ivec4", "UINT": "uint", "UVEC2": "uvec2",
              "UVEC3": "uvec3", "UVEC4": "uvec4", "BOOL": "bool"}
SAMPLER_TYPES = {"FLOAT_1D": "sampler1D", "FLOAT_2D": "sampler2D", "FLOAT_3D": "sampler3D",
                 "FLOAT_CUBE": "samplerCube", "FLOAT_1D_ARRAY": "sampler1DArray",
                 "FLOAT_2D_ARRAY": "sampler2DArray", "FLOAT_BUFFER": "samplerBuffer",
                 "INT_2D": "isampler2D", "INT_2D_ARRAY": "isampler2DArray",
                 "UINT_2D": "usampler2D", "UINT_2D_ARRAY": "usampler2DArray"}
INTERPOLATION = {"smooth": "smooth", "flat": "flat", "no_perspective": "noperspective"}
DEPTH_FUNCS = {"LEQUAL": "<=", "LESS": "<", "GEQUAL": ">=", "GREATER": ">", "EQUAL": "==",
               "NOTEQUAL": "!=", "ALWAYS": "1", "NEVER": "0"}
#: A pixel's relative difference: max over RGB of |gpu − ref| over
#: max(max over RGB of |ref|, REL_FLOOR).
REL_FLOOR = 1e-4
BAD_REL = 1e-3


def log(message: str = "") -> None:
    print(message, flush=True)


# ------------------------------------------------------------------------ context


def _loadable(lib: str) -> bool:
    try:
        ctypes.CDLL(lib)
    except OSError:
        return False
    return True


def make_context():
    """An OpenGL ≥ 4.3 context through EGL: (context, how it was made).

    Tried in turn: EGL with libGL.so.1 (needs libX11 through GLVND's libGLX), EGL with
    GLVND's libOpenGL.so.0 (no X11), the same on EGL devices 1..3, moderngl's default.
    GLCONTEXT_LINUX_LIBGL / GLCONTEXT_LINUX_LIBEGL / GLCONTEXT_DEVICE_INDEX (glcontext's
    own variables) pin a choice; SM_REQUIRE_GPU=1 rejects software renderers.
    """
    import moderngl

    backend = os.environ.get("SM_GL_BACKEND", "egl")
    libegl = os.environ.get("GLCONTEXT_LINUX_LIBEGL", "libEGL.so.1")
    if os.environ.get("GLCONTEXT_LINUX_LIBGL"):
        libgls = [os.environ["GLCONTEXT_LINUX_LIBGL"]]
    else:
        libgls = [lib for lib in ("libGL.so.1", "libOpenGL.so.0") if _loadable(lib)] or \
            ["libGL.so.1"]
    tries = []
    if backend != "default":
        for libgl in libgls:
            tries.append({"standalone": True, "backend": backend, "libgl": libgl,
                          "libegl": libegl})
        if "GLCONTEXT_DEVICE_INDEX" not in os.environ:
            tries += [{"standalone": True, "backend": backend, "libgl": libgls[-1],
                       "libegl": libegl, "device_index": i} for i in (1, 2, 3)]
    tries.append({"standalone": True})
    attempts = []
    for kwargs in tries:
        try:
            ctx = moderngl.create_context(require=430, **kwargs)
        except Exception as exc:  # noqa: BLE001  (any backend failure: try the next)
            attempts.append(f"{kwargs}: {type(exc).__name__}: {exc}")
            continue
        renderer = ctx.info.get("GL_RENDERER", "")
        if os.environ.get("SM_REQUIRE_GPU") == "1" and any(
                s in renderer.lower() for s in ("llvmpipe", "softpipe", "swrast")):
            attempts.append(f"{kwargs}: software renderer {renderer!r}, trying the next")
            ctx.release()
            continue
        return ctx, {"kwargs": dict(kwargs), "failed_attempts": attempts}
    raise RuntimeError("no OpenGL 4.3 context: " + " | ".join(attempts))


class RawGL:
    """The few GL calls moderngl does not expose (a DEPTH32F_STENCIL8 attachment, as
    Blender's GPUOffScreen has), through GLVND's libOpenGL."""

    def __init__(self):
        self.gl = ctypes.CDLL(os.environ.get("SM_LIBOPENGL", "libOpenGL.so.0"))
        self.gl.glCheckFramebufferStatus.restype = ctypes.c_uint
        self.gl.glGetError.restype = ctypes.c_uint

    def framebuffer(self, color_glo: int, width: int, height: int) -> tuple[int, int]:
        gl = self.gl
        depth = ctypes.c_uint()
        gl.glGenTextures(1, ctypes.byref(depth))
        gl.glBindTexture(0x0DE1, depth)
        gl.glTexStorage2D(0x0DE1, 1, 0x8CAD, width, height)       # GL_DEPTH32F_STENCIL8
        gl.glBindTexture(0x0DE1, 0)
        fbo = ctypes.c_uint()
        gl.glGenFramebuffers(1, ctypes.byref(fbo))
        gl.glBindFramebuffer(0x8D40, fbo)
        gl.glFramebufferTexture2D(0x8D40, 0x8CE0, 0x0DE1, color_glo, 0)
        gl.glFramebufferTexture2D(0x8D40, 0x821A, 0x0DE1, depth.value, 0)
        status = gl.glCheckFramebufferStatus(0x8D40)
        gl.glBindFramebuffer(0x8D40, 0)
        if status != 0x8CD5:
            raise RuntimeError(f"framebuffer incomplete: 0x{status:x}")
        return fbo.value, depth.value

    def delete(self, fbo: int, depth: int) -> None:
        self.gl.glDeleteFramebuffers(1, ctypes.byref(ctypes.c_uint(fbo)))
        self.gl.glDeleteTextures(1, ctypes.byref(ctypes.c_uint(depth)))


class Target:
    """RGBA32F colour + depth, cleared to transparent black and depth 1."""

    def __init__(self, ctx, width: int, height: int, raw: RawGL | None):
        self.ctx, self.width, self.height = ctx, width, height
        self.color = ctx.texture((width, height), 4, dtype="f4")
        self.raw_ids = None
        self.depth = None
        if raw is not None:
            fbo_id, depth_id = raw.framebuffer(self.color.glo, width, height)
            self.raw_ids = (fbo_id, depth_id)
            self.fbo = ctx.detect_framebuffer(fbo_id)
            self.depth_format = "DEPTH32F_STENCIL8"
        else:
            self.depth = ctx.depth_texture((width, height))
            self.fbo = ctx.framebuffer(color_attachments=[self.color],
                                       depth_attachment=self.depth)
            self.depth_format = "DEPTH_COMPONENT24 (moderngl)"
        self.raw = raw

    def clear(self) -> None:
        self.fbo.use()
        self.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def read(self) -> np.ndarray:
        data = self.fbo.read(components=4, dtype="f4", attachment=0)
        return np.frombuffer(data, dtype=np.float32).reshape(self.height, self.width, 4).copy()

    def release(self) -> None:
        if self.raw_ids is not None:
            self.raw.delete(*self.raw_ids)
        else:
            self.fbo.release()
            self.depth.release()
        self.color.release()


# ---------------------------------------------------------------------- shaders


def emulate_stage(shader: dict, stage: str, version: str) -> str:
    """GLSL of one stage as Blender 5.0's OpenGL backend assembles a create-info
    (gl_shader.cc): version, stage and create-info #defines, the typedef source, then
    ``layout(binding = N, std140) uniform <name> { <Type> _<name>; };`` per uniform
    buffer, ``layout(binding = N) uniform <sampler> <name>;`` per sampler and
    ``#define <name> (_<name>)`` so that ``sm.axis_lo`` reads the struct member; push
    constants as plain uniforms; ``layout(location = N) in`` vertex inputs; unnamed
    interface blocks (``out``/``in <interface> { smooth ... };``); fragment outputs at
    their locations, and gl_FragDepth redeclared ``depth_unchanged``; then the source.
    Blender's compatibility macros are left out: the project's GLSL uses none of them."""
    vertex = stage == "vertex"
    lines = [version, f"#define GPU_{'VERTEX' if vertex else 'FRAGMENT'}_SHADER",
             "#define GPU_SHADER", "#define GPU_OPENGL"]
    lines += [f"#define {name} {value}" for name, value in shader["defines"]]
    lines += list(shader["typedef_source"])
    lines.append("/* Pass resources. */")
    for ubo in shader["uniform_bufs"]:
        lines.append(f"layout(binding = {ubo['slot']}, std140) uniform {ubo['name']} "
                     f"{{ {ubo['type_name']} _{ubo['name']}; }};")
    for s in shader["samplers"]:
        lines.append(f"layout(binding = {s['slot']}) uniform {SAMPLER_TYPES[s['type']]} "
                     f"{s['name']};")
    for ubo in shader["uniform_bufs"]:
        lines.append(f"#define {ubo['name']} (_{ubo['name']})")
    lines.append("/* Push constants. */")
    for p in shader["push_constants"]:
        array = f"[{p['size']}]" if p.get("size") else ""
        lines.append(f"uniform {GLSL_TYPES[p['type']]} {p['name']}{array};")
    if vertex:
        for v in shader["vertex_in"]:
            lines.append(f"layout(location = {v['slot']}) in {GLSL_TYPES[v['type']]} "
                         f"{v['name']};")
    for iface in shader["interfaces"]:
        lines.append(f"{'out' if vertex else 'in'} {iface['name']} {{")
        lines += [f"  {INTERPOLATION[q]} {GLSL_TYPES[t]} {n};" for q, t, n in iface["members"]]
        lines.append("};")
    if not vertex:
        lines.append("layout(depth_unchanged) out float gl_FragDepth;")
        for o in shader["fragment_out"]:
            lines.append(f"layout(location = {o['slot']}) out {GLSL_TYPES[o['type']]} "
                         f"{o['name']};")
    lines.append("#line 1")
    lines.append(shader["vertex_source" if vertex else "fragment_source"])
    return "\n".join(lines) + "\n"


def shader_sources(case: dict, data: Path, source: str, version: str) -> tuple[str, str]:
    shader = case["shader"]
    if source == "emulated":
        return emulate_stage(shader, "vertex", version), emulate_stage(shader, "fragment",
                                                                         version)
    files = shader.get("blender_glsl") or {}
    if not files.get("vertex") or not files.get("fragment"):
        raise FileNotFoundError("no Blender GLSL dump recorded for this case")
    return ((data / files["vertex"]).read_text(encoding="utf-8"),
            (data / files["fragment"]).read_text(encoding="utf-8"))


# ------------------------------------------------------------------------- scene


class Blobs:
    def __init__(self, data: Path):
        self.data = data
        self.cache: dict = {}

    def array(self, rel: str) -> np.ndarray:
        if rel not in self.cache:
            self.cache[rel] = np.load(self.data / rel, allow_pickle=False)
        return self.cache[rel]

    def raw(self, rel: str) -> bytes:
        if rel not in self.cache:
            self.cache[rel] = (self.data / rel).read_bytes()
        return self.cache[rel]


def texture_data(texels: np.ndarray, texture_format: str) -> tuple[np.ndarray, str]:
    """Texels as the format stores them, and moderngl's dtype. The recorded float32 values
    of the 16-bit formats are exact in them (the project writes them so)."""
    texels = np.asarray(texels, dtype=np.float32)
    if texture_format == "RGBA16F":
        return np.ascontiguousarray(texels.astype(np.float16)), "f2"
    if texture_format == "RGBA16":
        return np.ascontiguousarray(np.rint(np.clip(texels, 0.0, 1.0) * 65535.0)
                                    .astype(np.uint16)), "nu2"
    if texture_format != "RGBA32F":
        raise ValueError(f"no replay for texture format {texture_format!r}")
    return np.ascontiguousarray(texels), "f4"


class Drawable:
    """One case's program, buffers, textures and state in a context."""

    def __init__(self, ctx, case: dict, blobs: Blobs, vs: str, fs: str):
        import moderngl

        self.ctx, self.case = ctx, case
        self.objects = []
        t0 = time.perf_counter()
        self.program = ctx.program(vertex_shader=vs, fragment_shader=fs)
        self.compile_seconds = time.perf_counter() - t0
        self.objects.append(self.program)
        prog = self.program
        self.missing = []
        # uniform buffers
        self.ubos = []
        for name, u in case["uniform_buffers"].items():
            buf = ctx.buffer(blobs.raw(u["blob"]))
            self.objects.append(buf)
            member = prog.get(name, None)
            if member is None:
                self.missing.append(f"uniform block {name}")
            else:
                member.binding = u["slot"]
            self.ubos.append((buf, u["slot"]))
        # textures
        self.textures = []
        for name, s in case["samplers"].items():
            texels, dtype = texture_data(blobs.array(s["blob"]), s.get("format", "RGBA32F"))
            w, h = s["size"]
            if s["layers"]:
                tex = ctx.texture_array((w, h, s["layers"]), 4, texels.tobytes(), dtype=dtype)
            else:
                tex = ctx.texture((w, h), 4, texels.tobytes(), dtype=dtype)
            mode = moderngl.LINEAR if s.get("linear") else moderngl.NEAREST
            tex.filter = (mode, mode)
            tex.repeat_x = tex.repeat_y = bool(s.get("repeat"))
            self.objects.append(tex)
            member = prog.get(name, None)
            if member is None:
                self.missing.append(f"sampler {name}")
            else:
                member.value = s["slot"]
            self.textures.append((tex, s["slot"]))
        # push constants (plain uniforms on OpenGL)
        for name, p in case["push_constants"].items():
            member = prog.get(name, None)
            if member is None:
                self.missing.append(f"uniform {name}")
                continue
            dtype = np.float32 if p["kind"] == "float" else np.int32
            member.write(np.asarray(p["value"], dtype=dtype).tobytes())
        # geometry: one interleaved vertex buffer in the recorded format's order
        g = case["geometry"]
        arrays = [np.asarray(blobs.array(g["vertex_arrays"][a["name"]]), np.float32)
                  .reshape(g["vertex_count"], a["len"]) for a in g["vertex_format"]]
        for a in g["vertex_format"]:
            if a["comp_type"] != "F32" or a["fetch_mode"] != "FLOAT":
                raise ValueError(f"vertex attribute {a} is not F32/FLOAT")
        interleaved = np.ascontiguousarray(np.concatenate(arrays, axis=1), dtype=np.float32)
        vbo = ctx.buffer(interleaved.tobytes())
        self.objects.append(vbo)
        parts, names = [], []
        for a in g["vertex_format"]:
            member = prog.get(a["name"], None)
            if isinstance(member, moderngl.Attribute):
                parts.append(f"{a['len']}f")
                names.append(a["name"])
            else:
                parts.append(f"{4 * a['len']}x")
        size = g["index_element_size"]
        indices = np.asarray(blobs.array(g["index_blob"]))
        indices = indices.astype(np.uint16 if size == 2 else np.uint32)
        ibo = ctx.buffer(indices.tobytes())
        self.objects.append(ibo)
        self.index_count = int(g["index_count"])
        self.vao = ctx.vertex_array(prog, [(vbo, " ".join(parts), *names)],
                                    index_buffer=ibo, index_element_size=size)
        self.objects.append(self.vao)
        self.mode = {"TRIS": moderngl.TRIANGLES}[g["primitive"]]
        self.stride = interleaved.shape[1] * 4

    def bind(self) -> None:
        ctx = self.ctx
        gl = self.case["state"]["gl"]
        flags = 0
        if gl.get("depth_test"):
            import moderngl
            flags |= moderngl.DEPTH_TEST
            ctx.depth_func = DEPTH_FUNCS[gl["depth_func"]]
        if gl.get("cull_face"):
            import moderngl
            flags |= moderngl.CULL_FACE
            ctx.cull_face = {"BACK": "back", "FRONT": "front",
                             "FRONT_AND_BACK": "front_and_back"}[gl["cull_face_mode"]]
        ctx.front_face = {"CCW": "ccw", "CW": "cw"}[gl.get("front_face", "CCW")]
        ctx.enable_only(flags)
        for buf, slot in self.ubos:
            buf.bind_to_uniform_block(slot)
        for tex, slot in self.textures:
            tex.use(location=slot)

    def draw(self) -> None:
        self.vao.render(self.mode, vertices=self.index_count)

    def release(self) -> None:
        for obj in reversed(self.objects):
            try:
                obj.release()
            except Exception:  # noqa: BLE001
                pass


# --------------------------------------------------------------------- measuring


def glsl_version(raw: RawGL | None) -> str | None:
    if raw is None:
        return None
    try:
        raw.gl.glGetString.restype = ctypes.c_char_p
        value = raw.gl.glGetString(ctypes.c_uint(0x8B8C))     # GL_SHADING_LANGUAGE_VERSION
        return value.decode() if value else None
    except Exception:  # noqa: BLE001
        return None


def stats(values: list[float]) -> dict:
    a = np.asarray(values, dtype=np.float64)
    if not len(a):
        return {}
    return {"median": float(np.median(a)), "min": float(a.min()),
            "p90": float(np.percentile(a, 90)), "mean": float(a.mean()),
            "max": float(a.max()), "n": int(len(a))}


_QUERIES: dict = {}


def time_case(ctx, target: Target, drawable: Drawable, warmup: int, frames: int,
              clear_frames: int, wall_frames: int, keep: bool) -> dict:
    """GL_TIME_ELAPSED of the draw (the clear outside the query) over ``frames`` frames
    after ``warmup``; then of clear + draw over ``clear_frames``; then the wall time of
    ``wall_frames`` back-to-back frames ended by glFinish."""
    q = _QUERIES.get(id(ctx))
    if q is None:                       # moderngl queries have no release(): keep one
        q = _QUERIES[id(ctx)] = ctx.query(time=True)
    drawable.bind()
    for _ in range(warmup):
        target.clear()
        drawable.draw()
    ctx.finish()
    draw_ms, frame_ms = [], []
    for _ in range(frames):
        target.clear()
        with q:
            drawable.draw()
        draw_ms.append(q.elapsed / 1e6)
    for _ in range(clear_frames):
        with q:
            target.clear()
            drawable.draw()
        frame_ms.append(q.elapsed / 1e6)
    wall = None
    if wall_frames:
        ctx.finish()
        t0 = time.perf_counter()
        for _ in range(wall_frames):
            target.clear()
            drawable.draw()
        ctx.finish()
        wall = 1e3 * (time.perf_counter() - t0) / wall_frames
    out = {"draw_ms": stats(draw_ms), "clear_draw_ms": stats(frame_ms),
           "wall_ms_per_frame": wall, "warmup": warmup}
    if keep:
        out["draw_ms_all"] = draw_ms
    return out


def render_once(ctx, target: Target, drawable: Drawable) -> np.ndarray:
    drawable.bind()
    target.clear()
    drawable.draw()
    ctx.finish()
    return target.read()


def pixel_rel(dev: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(relative, absolute) difference per pixel: the largest RGB difference over the
    reference pixel's largest RGB magnitude (at least REL_FLOOR), so that a near-zero
    channel of a bright pixel is judged against the pixel, not against itself."""
    d = np.abs(dev[..., :3].astype(np.float64) - ref[..., :3]).max(axis=-1)
    scale = np.maximum(np.abs(ref[..., :3].astype(np.float64)).max(axis=-1), REL_FLOOR)
    return d / scale, d


def _dilate(mask: np.ndarray) -> np.ndarray:
    out = mask.copy()
    out[1:] |= mask[:-1]
    out[:-1] |= mask[1:]
    row = out.copy()
    out[:, 1:] |= row[:, :-1]
    out[:, :-1] |= row[:, 1:]
    return out


def sensitivity_mask(case: dict, data: Path) -> np.ndarray | None:
    """Full-resolution mask of the ill-conditioned pixels (``--make-sensitivity``), or None."""
    path = data / "sens" / f"{case['name']}.npz"
    if not path.exists():
        return None
    h, w = case["reference"]["height"], case["reference"]["width"]
    z = np.load(path, allow_pickle=False)
    return np.unpackbits(z["mask"])[: h * w].reshape(h, w).astype(bool)


def save_subsample(image: np.ndarray, case: dict, folder: Path) -> None:
    """The image at the reference's strided subsample (``<case>.npy``), for colour
    comparisons back home (patch_cases.py's albedo precisions)."""
    ref = case["reference"]
    s, o = ref["stride"], ref["offset"]
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / f"{case['name']}.npy", np.ascontiguousarray(image[o::s, o::s]))


def compare(image: np.ndarray, case: dict, data: Path) -> dict:
    """The image against the project's read-back on the stored pixels (strided subsample
    and crops, full-resolution coordinates), coverage at full resolution, NaN anywhere.

    Status: PASS, every compared pixel within 1e-3 relative and coverage identical;
    PASS-SENS, the pixels over 1e-3 and the coverage differences all lie on pixels that
    the sensitivity mask marks as ill-conditioned (they change by more than 1e-3 when the
    geometry moves by ~1e-3 px on the reference renderer: shader discontinuities such
    as BTF texel edges, near-black gamma-encoded pixels, silhouettes, depth ties) and the
    channel sums agree within 1e-4; PASS-NBR, at most 1 % of the pixels are over 1e-3 and
    all but 0.01 % of the compared pixels among those are either in the mask or have
    their reference value within the range of the GPU's own 3 × 3 neighbourhood (a
    sub-pixel shift of an edge), coverage differs only next to the silhouette, channel
    sums within 1e-4; FAIL otherwise (NaN/Inf: always FAIL). A wrong texture, buffer or
    interface moves most pixels (a factor texture off by 0.2 % already fails)."""
    ref = case["reference"]
    h, w = ref["height"], ref["width"]
    if image.shape[:2] != (h, w):
        return {"status": "FAIL", "reason": f"size {image.shape[:2]} != {(h, w)}"}
    z = np.load(data / ref["file"], allow_pickle=False)
    nonfinite = int((~np.isfinite(image)).sum())
    mask_ref = np.unpackbits(z["mask"])[: h * w].reshape(h, w).astype(bool)
    mask_dev = image[..., 3] > 0
    coverage_diff = mask_ref != mask_dev
    coverage_mismatch = int(np.count_nonzero(coverage_diff))
    sens = sensitivity_mask(case, data)
    # every stored reference pixel, with its full-resolution coordinates
    s, o = ref["stride"], ref["offset"]
    sub_ref = z["subsample"]
    ys, xs = np.meshgrid(o + s * np.arange(sub_ref.shape[0]), o + s * np.arange(sub_ref.shape[1]),
                         indexing="ij")
    coords = [np.stack([ys.ravel(), xs.ravel()], axis=1)]
    refs = [sub_ref.reshape(-1, 4)]
    c = int(ref.get("crop", 0))
    for (y0, x0), crop in zip(z["crop_origins"], z["crops"]):
        cy, cx = np.meshgrid(y0 + np.arange(crop.shape[0]), x0 + np.arange(crop.shape[1]),
                             indexing="ij")
        coords.append(np.stack([cy.ravel(), cx.ravel()], axis=1))
        refs.append(crop.reshape(-1, 4))
    del c
    coords = np.concatenate(coords)
    refv = np.concatenate(refs)
    devv = image[coords[:, 0], coords[:, 1]]
    both = (refv[:, 3] > 0) & (devv[:, 3] > 0)
    coords, refv, devv = coords[both], refv[both], devv[both]
    rel, ab = pixel_rel(devv, refv)
    n_sub = int(np.count_nonzero(both[: sub_ref.shape[0] * sub_ref.shape[1]]))
    bad_mask = rel > BAD_REL
    bad = int(np.count_nonzero(bad_mask))
    sums = image.astype(np.float64).sum(axis=(0, 1))
    ref_sums = np.asarray(ref["channel_sums"])
    sum_rel = np.abs(sums - ref_sums) / np.maximum(np.abs(ref_sums), 1e-30)
    in_sens = sens[coords[:, 0], coords[:, 1]] if sens is not None else np.zeros(len(rel), bool)
    bad_outside = int(np.count_nonzero(bad_mask & ~in_sens))
    # A differing pixel is explained by a sub-pixel shift of the picture when the
    # reference value lies (per channel, within 1e-3 relative) inside the range of the
    # GPU's own 3 × 3 neighbourhood around it (texel edges, silhouettes, depth ties).
    explained = np.ones(len(rel), bool)
    idx = np.nonzero(bad_mask)[0]
    if len(idx):
        y, x = coords[idx, 0], coords[idx, 1]
        ring = np.stack([image[np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1), :3]
                         for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
        r = refv[idx, :3].astype(np.float64)
        tol = BAD_REL * np.maximum(np.abs(r).max(axis=-1, keepdims=True), REL_FLOOR)
        explained[idx] = np.all((r >= ring.min(axis=0) - tol) & (r <= ring.max(axis=0) + tol),
                                axis=-1)
    bad_unexplained = int(np.count_nonzero(bad_mask & ~explained & ~in_sens))
    # coverage differences next to the reference's silhouette are rasterisation ties
    edge = _dilate(mask_ref) & _dilate(~mask_ref)
    cov_off_edge = int(np.count_nonzero(coverage_diff & ~edge))
    cov_outside = int(np.count_nonzero(coverage_diff & ~sens)) if sens is not None \
        else coverage_mismatch
    worst = []
    for i in np.argsort(-rel)[:12]:
        if rel[i] <= BAD_REL:
            break
        worst.append({"y": int(coords[i, 0]), "x": int(coords[i, 1]),
                      "ref": [float(v) for v in refv[i, :3]],
                      "gpu": [float(v) for v in devv[i, :3]],
                      "rel": float(rel[i]), "abs": float(ab[i]),
                      "sensitive": bool(in_sens[i]),
                      "in_gpu_neighbourhood": bool(explained[i])})
    out = {
        "pixels_compared": int(len(rel)), "pixels_compared_subsample": n_sub,
        "max_rel": float(rel.max()) if len(rel) else 0.0,
        "mean_rel": float(rel.mean()) if len(rel) else 0.0,
        "p99_rel": float(np.percentile(rel, 99)) if len(rel) else 0.0,
        "p999_rel": float(np.percentile(rel, 99.9)) if len(rel) else 0.0,
        "max_abs": float(ab.max()) if len(ab) else 0.0,
        "mean_abs": float(ab.mean()) if len(ab) else 0.0,
        "pixels_rel_gt_1e-3": bad, "pixels_rel_gt_1e-3_not_sensitive": bad_outside,
        "pixels_rel_gt_1e-3_unexplained": bad_unexplained,
        "coverage_mismatch_off_silhouette": cov_off_edge,
        "sensitivity_mask": None if sens is None else {
            "pixels": int(sens.sum()), "share_of_covered": float(sens.sum()) /
            max(ref["covered_pixels"], 1)},
        "coverage_mismatch_pixels": coverage_mismatch,
        "coverage_mismatch_not_sensitive": cov_outside,
        "covered_pixels": int(mask_dev.sum()), "covered_pixels_reference": ref["covered_pixels"],
        "nonfinite_values": nonfinite,
        "channel_sum_rel_diff": [float(v) for v in sum_rel],
        "worst_pixels": worst,
    }
    sums_ok = float(sum_rel[:3].max()) <= 1e-4
    if nonfinite:
        status = "FAIL"
    elif coverage_mismatch == 0 and out["max_rel"] <= BAD_REL:
        status = "PASS"
    elif sens is not None and bad_outside == 0 and cov_outside == 0 and sums_ok:
        status = "PASS-SENS"
    elif (bad_unexplained <= 1e-4 * len(rel) and cov_off_edge == 0 and sums_ok
          and bad <= 0.01 * max(len(rel), 1)):
        status = "PASS-NBR"
    else:
        status = "FAIL"
    out["status"] = status
    return out


# ------------------------------------------------------------------ sensitivity


def _rotation(axis, angle: float) -> np.ndarray:
    a = np.asarray(axis, dtype=np.float64)
    a /= np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    r = np.eye(4)
    r[:3, :3] = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)
    return r


def perturbations(eps: float) -> list[tuple[str, np.ndarray, bool]]:
    """(name, 4 × 4 matrix applied to the model matrix, whether the normal matrix turns
    with it): rotations by ±eps about x, y and z, and uniform scales by 1 ± eps."""
    out = []
    for axis, label in (((1, 0, 0), "x"), ((0, 1, 0), "y"), ((0, 0, 1), "z")):
        for sign in (1, -1):
            out.append((f"rotate{label}{'+' if sign > 0 else '-'}",
                        _rotation(axis, sign * eps), True))
    for sign in (1, -1):
        out.append((f"scale{'+' if sign > 0 else '-'}",
                    np.diag([1 + sign * eps] * 3 + [1.0]), False))
    return out


def perturbed(case: dict, matrix: np.ndarray, turn_normals: bool) -> dict:
    out = dict(case)
    pcs = {}
    for name, p in case["push_constants"].items():
        p = dict(p)
        if name in ("model_matrix", "normal_matrix") and len(p["value"]) == 16:
            m = np.asarray(p["value"], dtype=np.float64).reshape(4, 4).T   # column-major
            if name == "model_matrix" or turn_normals:
                m = matrix @ m
            p["value"] = [float(v) for v in m.T.ravel()]
        pcs[name] = p
    out["push_constants"] = pcs
    return out


def make_sensitivity(ctx, cases, data: Path, blobs, raw, version: str, eps: float) -> None:
    """For each case: the pixels whose value moves by more than 1e-3 (relative, as the
    check measures) or whose coverage flips when the model matrix is rotated (±x, ±y,
    ±z) or scaled by ``eps`` (~1e-3 px here), dilated by one pixel, and a band of two
    pixels either side of the silhouette. Written to data/sens/<case>.npz."""
    (data / "sens").mkdir(exist_ok=True)
    targets = {}
    for case in cases:
        key = (case["target"]["width"], case["target"]["height"])
        if key not in targets:
            targets[key] = Target(ctx, *key, raw)
        target = targets[key]
        vs, fs = shader_sources(case, data, "emulated", version)
        d = Drawable(ctx, case, blobs, vs, fs)
        base = render_once(ctx, target, d)
        d.release()
        mask = np.zeros(base.shape[:2], bool)
        for _name, matrix, turn in perturbations(eps):
            d = Drawable(ctx, perturbed(case, matrix, turn), blobs, vs, fs)
            img = render_once(ctx, target, d)
            d.release()
            cov = (img[..., 3] > 0) != (base[..., 3] > 0)
            both = (img[..., 3] > 0) & (base[..., 3] > 0)
            rel, _ = pixel_rel(img, base)
            mask |= cov | (both & (rel > BAD_REL))
        mask = _dilate(mask)
        # the silhouette: two pixels either side of the coverage edge
        covered = base[..., 3] > 0
        edge = _dilate(covered) & _dilate(~covered)
        mask |= _dilate(edge)
        np.savez_compressed(data / "sens" / f"{case['name']}.npz",
                            mask=np.packbits(mask.ravel()), eps=np.float64(eps))
        covered = max(case["reference"]["covered_pixels"], 1)
        log(f"{case['name']}: {int(mask.sum())} sensitive pixels "
            f"({100 * mask.sum() / covered:.3f} % of covered)")
    for t in targets.values():
        t.release()


def images_agree(a: np.ndarray, b: np.ndarray) -> dict:
    m = (a[..., 3] > 0) | (b[..., 3] > 0)
    rel, ab = pixel_rel(a[m], b[m])
    return {"identical": bool(np.array_equal(a, b)),
            "max_rel": float(rel.max()) if len(rel) else 0.0,
            "max_abs": float(ab.max()) if len(ab) else 0.0}


# ------------------------------------------------------------------------- main


def nvidia_smi() -> str | None:
    try:
        return subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,clocks.sm,clocks.max.sm,"
             "clocks.mem,power.draw,temperature.gpu,pstate", "--format=csv"],
            capture_output=True, text=True, timeout=20).stdout.strip()
    except Exception:  # noqa: BLE001
        return None


def ordered(cases: list[dict]) -> list[dict]:
    groups = []
    for c in cases:
        if c["group"] not in groups:
            groups.append(c["group"])
    return sorted(cases, key=lambda c: (groups.index(c["group"]), c["ratio_to"] is not None))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(HERE / "data"))
    parser.add_argument("--cases", default="*", help="comma-separated name patterns")
    parser.add_argument("--warmup", type=int, default=20)
    parser.add_argument("--frames", type=int, default=200,
                        help="timed frames (GL_TIME_ELAPSED of the draw) per case")
    parser.add_argument("--clear-frames", type=int, default=30,
                        help="timed frames of clear + draw per case")
    parser.add_argument("--wall-frames", type=int, default=30,
                        help="back-to-back frames ended by glFinish per case (wall time)")
    parser.add_argument("--source", choices=("emulated", "blender", "both"), default="both",
                        help="GLSL: the emulated create-info (timed in full), Blender's own "
                             "dump (checked, timed with --blender-frames after every case "
                             "has run emulated), or both (default)")
    parser.add_argument("--blender-frames", type=int, default=50,
                        help="timed frames of the Blender-GLSL control (with --source both)")
    parser.add_argument("--check-frames", type=int, default=20,
                        help="timed frames of the correctness twins (role 'check': the "
                             "factor-pack draws with linear XYZ output), after 5 warm-up")
    parser.add_argument("--version-line", default="#version 430 core")
    parser.add_argument("--gpu-warmup-seconds", type=float, default=2.0,
                        help="draw the first case this long before timing (clocks up)")
    parser.add_argument("--max-seconds", type=float, default=400.0,
                        help="start no case (or Blender-GLSL control) after this long")
    parser.add_argument("--out", default=None, help="JSON path (default $OUT/gpu_results.json)")
    parser.add_argument("--keep-frames", action="store_true", help="all frame times in JSON")
    parser.add_argument("--save-images", default=None, metavar="DIR",
                        help="write each case's Blender-GLSL image, subsampled as its "
                             "reference is, to DIR/<case>.npy")
    parser.add_argument("--probe", action="store_true",
                        help="only make the context and print the GL renderer")
    parser.add_argument("--make-sensitivity", type=float, default=None, metavar="EPS",
                        help="write data/sens/<case>.npz (ill-conditioned pixels under a "
                             "model-matrix rotation/scale of EPS, e.g. 4e-6) and stop; run on "
                             "the reference renderer (Mesa llvmpipe), before the GPU run")
    args = parser.parse_args()
    if args.probe:
        ctx, how = make_context()
        log(f"GL_RENDERER: {ctx.info.get('GL_RENDERER')}  GL_VENDOR: "
            f"{ctx.info.get('GL_VENDOR')}  GL_VERSION: {ctx.info.get('GL_VERSION')}  "
            f"context: {how['kwargs']}")
        for a in how["failed_attempts"]:
            log(f"  (context attempt failed: {a})")
        return
    started = time.perf_counter()
    data = Path(args.data)
    manifest = json.loads((data / "manifest.json").read_text())
    patterns = [p.strip() for p in args.cases.split(",") if p.strip()]
    cases = [c for c in ordered(manifest["cases"])
             if any(fnmatch.fnmatch(c["name"], p) for p in patterns)]
    out_path = Path(args.out) if args.out else Path(os.environ.get("OUT", ".")) / \
        "gpu_results.json"

    import moderngl

    ctx, how = make_context()
    if args.make_sensitivity is not None:
        raw = None if os.environ.get("SM_DEPTH") == "moderngl" else RawGL()
        log(f"GL_RENDERER: {ctx.info.get('GL_RENDERER')}: sensitivity masks, eps "
            f"{args.make_sensitivity:g}")
        make_sensitivity(ctx, cases, data, Blobs(data), raw, args.version_line,
                         args.make_sensitivity)
        return
    info = dict(ctx.info)
    renderer = info.get("GL_RENDERER", "?")
    log(f"GL_RENDERER: {renderer}")
    log(f"GL_VENDOR: {info.get('GL_VENDOR')}  GL_VERSION: {info.get('GL_VERSION')}  "
        f"context: {how['kwargs']}")
    for a in how["failed_attempts"]:
        log(f"  (context attempt failed: {a})")
    raw = None
    depth_note = None
    if os.environ.get("SM_DEPTH") != "moderngl":
        try:
            raw = RawGL()
            probe = Target(ctx, 8, 8, raw)
            probe.clear()
            probe.release()
        except Exception as exc:  # noqa: BLE001
            depth_note = f"DEPTH32F_STENCIL8 through libOpenGL failed ({exc}); moderngl depth"
            log(depth_note)
            raw = None
    results = {
        "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": {"gl_renderer": renderer, "gl_vendor": info.get("GL_VENDOR"),
                    "gl_version": info.get("GL_VERSION"),
                    "glsl_version": glsl_version(raw),
                    "context": how, "moderngl": moderngl.__version__,
                    "numpy": np.__version__, "python": platform.python_version(),
                    "nvidia_smi_start": nvidia_smi(), "hostname": platform.node()},
        "settings": {"warmup": args.warmup, "frames": args.frames,
                     "clear_frames": args.clear_frames, "wall_frames": args.wall_frames,
                     "blender_frames": args.blender_frames, "source": args.source,
                     "version_line": args.version_line, "rel_floor": REL_FLOOR,
                     "bad_rel": BAD_REL, "depth_note": depth_note,
                     "depth_format": "DEPTH32F_STENCIL8 (libOpenGL)" if raw is not None
                     else "DEPTH_COMPONENT24 (moderngl)"},
        "export": {k: manifest.get(k) for k in ("created", "project_commit", "machine")},
        "cases": [],
    }
    blobs = Blobs(data)
    sources = ["emulated", "blender"] if args.source == "both" else [args.source]
    targets: dict = {}

    def target_for(case):
        key = (case["target"]["width"], case["target"]["height"])
        if key not in targets:
            try:
                targets[key] = Target(ctx, *key, raw)
            except Exception as exc:  # noqa: BLE001
                note = f"{key}: DEPTH32F_STENCIL8 target failed ({exc}); moderngl depth"
                log(note)
                results["settings"].setdefault("target_notes", []).append(note)
                targets[key] = Target(ctx, *key, None)
        return targets[key]

    if args.gpu_warmup_seconds > 0 and cases:
        heavy = max(cases, key=lambda c: len(c["shader"]["fragment_source"]) *
                    (c["params"].get("packs", 1) or 1))
        try:
            vs, fs = shader_sources(heavy, data, "emulated", args.version_line)
            d = Drawable(ctx, heavy, blobs, vs, fs)
            t = target_for(heavy)
            d.bind()
            t0 = time.perf_counter()
            n = 0
            while time.perf_counter() - t0 < args.gpu_warmup_seconds:
                t.clear()
                d.draw()
                n += 1
                if n % 8 == 0:
                    ctx.finish()
            ctx.finish()
            d.release()
            log(f"GPU warm-up: {n} frames of {heavy['name']}")
        except Exception as exc:  # noqa: BLE001
            log(f"GPU warm-up failed: {exc}")

    def run_source(case, entry, source, frames, clear_frames, wall_frames, warmup=None):
        name = case["name"]
        run = {}
        entry["runs"][source] = run
        try:
            target = target_for(case)
            run["depth_format"] = target.depth_format
            vs, fs = shader_sources(case, data, source, args.version_line)
            drawable = Drawable(ctx, case, blobs, vs, fs)
        except Exception as exc:  # noqa: BLE001
            run["error"] = f"{type(exc).__name__}: {exc}"
            log(f"{name} [{source}]: ERROR {run['error'][:3000]}")
            return None
        image = None
        try:
            run["link_seconds"] = drawable.compile_seconds
            run["missing"] = drawable.missing
            t0 = time.perf_counter()
            render_once(ctx, target, drawable)          # drivers may compile at first use
            run["first_frame_seconds"] = time.perf_counter() - t0
            run.update(time_case(ctx, target, drawable,
                                 args.warmup if warmup is None else warmup, frames,
                                 clear_frames, wall_frames, args.keep_frames))
            image = render_once(ctx, target, drawable)
            run["check"] = compare(image, case, data)
            if args.save_images and source == "blender":
                save_subsample(image, case, Path(args.save_images))
        except Exception as exc:  # noqa: BLE001
            run["error"] = f"{type(exc).__name__}: {exc}"
            log(f"{name} [{source}]: ERROR {run['error']}")
        finally:
            drawable.release()
        if "draw_ms" in run and "check" in run:
            c = run["check"]
            wall = run["wall_ms_per_frame"]
            log(f"{name} [{source}]: draw {run['draw_ms']['median']:.3f} ms (min "
                f"{run['draw_ms']['min']:.3f}, p90 {run['draw_ms']['p90']:.3f}, n "
                f"{run['draw_ms']['n']}; wall {'—' if wall is None else f'{wall:.3f}'} ms); "
                f"check {c['status']} max rel {c['max_rel']:.2e} mean {c['mean_rel']:.2e} "
                f">1e-3: {c['pixels_rel_gt_1e-3']} (not sensitive "
                f"{c['pixels_rel_gt_1e-3_not_sensitive']}, unexplained "
                f"{c['pixels_rel_gt_1e-3_unexplained']}) coverage diff "
                f"{c['coverage_mismatch_pixels']} nonfinite {c['nonfinite_values']}")
        return image

    first = sources[0]
    images: dict = {}
    entries = []
    for case in cases:          # phase 1: every case with the first source, in full
        entry = {"name": case["name"], "family": case["family"], "group": case["group"],
                 "role": case.get("role", "timing"),
                 "ratio_to": case["ratio_to"], "params": case["params"],
                 "target": [case["target"]["width"], case["target"]["height"]],
                 "llvmpipe_docs": case.get("llvmpipe_docs"), "runs": {}}
        results["cases"].append(entry)
        entries.append((case, entry))
        if time.perf_counter() - started > args.max_seconds:
            entry["skipped"] = "time budget"
            log(f"{case['name']}: skipped (time budget)")
            continue
        if case.get("role") == "check":
            image = run_source(case, entry, first, args.check_frames, 0, 0, warmup=5)
        else:
            image = run_source(case, entry, first, args.frames, args.clear_frames,
                               args.wall_frames)
        if image is not None and len(sources) > 1:
            images[case["name"]] = image
        _save(results, out_path)
    for source in sources[1:]:  # phase 2: the control source, fewer frames
        for case, entry in entries:
            if entry.get("skipped"):
                continue
            if time.perf_counter() - started > args.max_seconds:
                entry["runs"][source] = {"skipped": "time budget"}
                continue
            check = case.get("role") == "check"
            image = run_source(case, entry, source,
                               args.check_frames if check else args.blender_frames, 0, 0,
                               warmup=5 if check else None)
            if image is not None and case["name"] in images:
                entry["emulated_vs_blender"] = images_agree(images.pop(case["name"]), image)
            _save(results, out_path)

    # ratios against the baseline with the same lights (same group, same target)
    by_name = {e["name"]: e for e in results["cases"]}
    for e in results["cases"]:
        for source, run in e["runs"].items():
            ms = run.get("draw_ms", {}).get("median")
            if ms:
                run["fps"] = 1e3 / ms
            base = by_name.get(e["ratio_to"]) if e["ratio_to"] else None
            bms = base and base["runs"].get(source, {}).get("draw_ms", {}).get("median")
            if ms and bms:
                run["ratio"] = ms / bms
                cd = run.get("clear_draw_ms", {}).get("median")
                bcd = base["runs"][source].get("clear_draw_ms", {}).get("median")
                if cd and bcd:
                    run["ratio_clear_draw"] = cd / bcd
                wall, bwall = run.get("wall_ms_per_frame"), \
                    base["runs"][source].get("wall_ms_per_frame")
                if wall and bwall:
                    run["ratio_wall"] = wall / bwall
    results["machine"]["nvidia_smi_end"] = nvidia_smi()
    results["seconds"] = time.perf_counter() - started
    _save(results, out_path)
    for t in targets.values():
        t.release()
    print_table(results)
    log(f"wrote {out_path} ({results['seconds']:.0f} s)")


def _save(results: dict, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(results, indent=1))


def print_table(results: dict) -> None:
    renderer = results["machine"]["gl_renderer"]
    log()
    log(f"GL_RENDERER: {renderer}  ({results['machine']['gl_version']})")
    head = (f"{'case':32s} {'target':>9s} {'ms med':>8s} {'min':>8s} {'p90':>8s} "
            f"{'ratio':>6s} {'FPS':>7s} {'wall ms':>8s} {'bl. ms':>8s} {'max rel':>8s} "
            f"{'mean rel':>8s} {'>1e-3':>5s} {'unexp':>5s} {'cov':>4s} {'check':>10s}")
    log(head)
    log("-" * len(head))
    for e in results["cases"]:
        size = f"{e['target'][0]}x{e['target'][1]}"
        run = e["runs"].get("emulated") or e["runs"].get("blender") or {}
        if e.get("skipped") or "draw_ms" not in run or "check" not in run:
            why = e.get("skipped") or run.get("error", "no run")
            log(f"{e['name']:32s} {size:>9s} {'—':>8s}  {why[:70]}")
            continue
        d = run["draw_ms"]
        c = run["check"]
        ratio = f"{run['ratio']:.2f}" if run.get("ratio") else (
            "check" if e.get("role") == "check" else "base")
        wall = run.get("wall_ms_per_frame")
        wall = f"{wall:.3f}" if wall else "—"
        b = e["runs"].get("blender", {})
        bms = f"{b['draw_ms']['median']:.3f}" if "draw_ms" in b else "—"
        bchk = b.get("check", {}).get("status")
        status = c["status"] + ("" if bchk is None else ("=" if bchk == c["status"]
                                                         else f"/{bchk}"))
        log(f"{e['name']:32s} {size:>9s} {d['median']:8.3f} {d['min']:8.3f} {d['p90']:8.3f} "
            f"{ratio:>6s} {run['fps']:7.1f} {wall:>8s} {bms:>8s} {c['max_rel']:8.1e} "
            f"{c['mean_rel']:8.1e} {c['pixels_rel_gt_1e-3']:5d} "
            f"{c['pixels_rel_gt_1e-3_unexplained']:5d} "
            f"{c['coverage_mismatch_pixels']:4d} {status:>10s}")
    log("ms: GL_TIME_ELAPSED of the draw alone (median/min/p90 of the timed frames); ratio: "
        "against the case's baseline (same lights, target and mesh; PRT: RGB PRT); wall: "
        "back-to-back clear+draw frames / glFinish; bl. ms: the same draw compiled from "
        "Blender's own GLSL text; max/mean rel: per pixel max over RGB |gpu-ref| / "
        "max(max over RGB |ref|, 1e-4) against the project's llvmpipe read-back; >1e-3: such "
        "pixels; unexp: those neither in the sensitivity mask (pixels that also move by "
        ">1e-3 on the reference renderer when the geometry moves ~1e-3 px) nor within the "
        "range of the GPU's own 3x3 neighbourhood; cov: coverage "
        "differences; check: emulated status, '=' when the Blender-GLSL run has the same. "
        "xyz_* rows: correctness twins of the draw_* factor-pack rows with linear XYZ "
        "output (the timed DISPLAY output clips to 1 from 4 packs on with these "
        "synthetic factors, so its image cannot show an error); their ms is from "
        "fewer frames.")
    if any(s in renderer.lower() for s in ("llvmpipe", "softpipe", "swrast")):
        log("NOTE: software renderer: GL timer queries do not capture llvmpipe's deferred "
            "rasterisation; only the wall column means anything here.")


if __name__ == "__main__":
    sys.exit(main())
