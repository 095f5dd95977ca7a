"""Export the project's benchmark draws so that a machine without Blender can replay them.

The project's adapted copy of ../shared/gpu-replay/export_cases.py (README.md here says
what changed). Runs with the project's Python 3.11 + bpy 5.0.1 venv, from its root::

    .venvs/5.0/bin/python benchmarks/gpu_replay/export_cases.py --project . --out .replay/data

Nothing in the project is re-implemented. The project's benchmark code draws each case
through its own path (``bench_draw.Bench.measure``, ``bench_btf.frame_times``,
``bench_prt.FrameBench``), while thin recording proxies stand in for the ``gpu.types``
constructors, ``gpu.shader.create_from_info`` and ``gpu.state`` setters. Each proxy
forwards to the real Blender object and notes what went through it:

* the create-info calls (defines, typedef, uniform buffers, samplers, push constants,
  vertex inputs, interfaces, outputs, the vertex and fragment source text);
* the exact GLSL Blender handed to the driver, taken from Mesa's shader dump
  (``MESA_SHADER_DUMP_PATH``), matched to each shader by its sources and defines;
* the uniform-buffer bytes, the textures' float32 texels, the push-constant values;
* the vertex format, per-attribute arrays and the index buffer of the batch drawn;
* the GL state at the draw (queried from the driver through libOpenGL), the target;
* the image the project read back after the draw (``offscreen.Target.read``): stored as
  a full-resolution coverage mask, a strided subsample and a few full-resolution crops,
  with full-image statistics (the whole image would not fit the payload).

Writes ``OUT/manifest.json``, ``OUT/blobs/*`` (content-addressed, shared between cases),
``OUT/refs/<case>.npz`` and ``OUT/glsl/*`` (the Mesa dumps).
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import hashlib
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# Mesa reads this when a shader is compiled: every GLSL source Blender hands the driver
# is written to this folder as <stage>_<sha1>.glsl.
DUMP_DIR = Path(tempfile.mkdtemp(prefix="sm_mesa_dump_"))
os.environ["MESA_SHADER_DUMP_PATH"] = str(DUMP_DIR)

PARSER = argparse.ArgumentParser(description=__doc__.splitlines()[0])
PARSER.add_argument("--project", default=".", help="the project's checkout")
PARSER.add_argument("--out", default=str(Path(__file__).resolve().parent / "data"))
PARSER.add_argument("--families", default="draw,precision,btf,prt",
                    help="comma-separated subset of draw,precision,btf,prt,variants")
PARSER.add_argument("--draw-size", type=int, default=None,
                    help="override bench_draw's 1200 px target (testing only)")
PARSER.add_argument("--stride", type=int, default=3,
                    help="reference subsample stride in pixels (each axis)")
PARSER.add_argument("--check-stride", type=int, default=4,
                    help="subsample stride of the XYZ correctness twins")
PARSER.add_argument("--crop", type=int, default=48, help="side of the full-resolution crops")
PARSER.add_argument("--prt-rays", type=int, default=None,
                    help="rays per vertex of the PRT bake (default: bench_prt's MAIN_RAYS)")
ARGS = PARSER.parse_args()

ROOT = Path(ARGS.project).resolve()
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bpy  # noqa: E402,F401
import gpu  # noqa: E402

from spectral_materials.blender.gpu import offscreen  # noqa: E402
from spectral_materials.blender.gpu.context import ensure_gpu  # noqa: E402

OUT = Path(ARGS.out).resolve()


def log(message: str) -> None:
    print(message, flush=True)


# ------------------------------------------------------------------ GL state queries

_GL = None


def _gl():
    global _GL
    if _GL is None:
        _GL = ctypes.CDLL("libOpenGL.so.0")
        _GL.glIsEnabled.restype = ctypes.c_ubyte
    return _GL


GL_NAMES = {0x0200: "NEVER", 0x0201: "LESS", 0x0202: "EQUAL", 0x0203: "LEQUAL",
            0x0204: "GREATER", 0x0205: "NOTEQUAL", 0x0206: "GEQUAL", 0x0207: "ALWAYS",
            0x0404: "FRONT", 0x0405: "BACK", 0x0408: "FRONT_AND_BACK", 0x0900: "CW",
            0x0901: "CCW", 0x8CA1: "LOWER_LEFT", 0x8CA2: "UPPER_LEFT",
            0x935E: "NEGATIVE_ONE_TO_ONE", 0x935F: "ZERO_TO_ONE"}


def gl_state() -> dict:
    """The driver's state at the draw (Blender's context is current on this thread)."""
    gl = _gl()

    def geti(pname: int, n: int = 1):
        a = (ctypes.c_int * n)()
        gl.glGetIntegerv(ctypes.c_uint(pname), a)
        return list(a) if n > 1 else int(a[0])

    def on(cap: int) -> bool:
        return bool(gl.glIsEnabled(ctypes.c_uint(cap)))

    state = {
        "depth_test": on(0x0B71), "depth_func": GL_NAMES.get(geti(0x0B74), geti(0x0B74)),
        "depth_mask": bool(geti(0x0B72)), "depth_clamp": on(0x864F),
        "cull_face": on(0x0B44), "cull_face_mode": GL_NAMES.get(geti(0x0B45)),
        "front_face": GL_NAMES.get(geti(0x0B46)), "blend": on(0x0BE2),
        "clip_origin": GL_NAMES.get(geti(0x935C)), "clip_depth_mode": GL_NAMES.get(geti(0x935D)),
        "framebuffer_srgb": on(0x8DB9), "scissor_test": on(0x0C11),
        "primitive_restart": on(0x8F9D), "primitive_restart_fixed_index": on(0x8D69),
        "viewport": geti(0x0BA2, 4), "color_writemask": None,
    }
    mask = (ctypes.c_ubyte * 4)()
    gl.glGetBooleanv(ctypes.c_uint(0x0C23), mask)
    state["color_writemask"] = [bool(m) for m in mask]
    depth_range = (ctypes.c_float * 2)()
    gl.glGetFloatv(ctypes.c_uint(0x0B70), depth_range)
    state["depth_range"] = [float(v) for v in depth_range]
    # The element buffer of the bound vertex array: its size gives the index type.
    ebo = geti(0x8895)
    if ebo:
        size = ctypes.c_int()
        gl.glGetBufferParameteriv(ctypes.c_uint(0x8893), ctypes.c_uint(0x8764),
                                  ctypes.byref(size))
        state["element_buffer_bytes"] = int(size.value)
    attribs = []
    for i in range(16):
        enabled = ctypes.c_int()
        gl.glGetVertexAttribiv(ctypes.c_uint(i), ctypes.c_uint(0x8622), ctypes.byref(enabled))
        if not enabled.value:
            continue
        vals = {}
        for pname, key in ((0x8623, "size"), (0x8624, "stride"), (0x8625, "type")):
            v = ctypes.c_int()
            gl.glGetVertexAttribiv(ctypes.c_uint(i), ctypes.c_uint(pname), ctypes.byref(v))
            vals[key] = int(v.value)
        ptr = ctypes.c_void_p()
        gl.glGetVertexAttribPointerv(ctypes.c_uint(i), ctypes.c_uint(0x8645), ctypes.byref(ptr))
        vals["offset"] = int(ptr.value or 0)
        attribs.append({"location": i, **vals})
    state["vertex_attribs"] = attribs
    # The draw framebuffer's attachments.
    v = ctypes.c_int()
    attach = {}
    for point, name in ((0x8CE0, "color0"), (0x8D00, "depth"), (0x8D20, "stencil")):
        gl.glGetFramebufferAttachmentParameteriv(ctypes.c_uint(0x8CA9), ctypes.c_uint(point),
                                                 ctypes.c_uint(0x8CD0), ctypes.byref(v))
        if not v.value:
            continue
        bits = {}
        for pname, key in ((0x8212, "red"), (0x8215, "alpha"), (0x8216, "depth"),
                           (0x8217, "stencil"), (0x8211, "component_type")):
            gl.glGetFramebufferAttachmentParameteriv(ctypes.c_uint(0x8CA9),
                                                     ctypes.c_uint(point), ctypes.c_uint(pname),
                                                     ctypes.byref(v))
            bits[key] = int(v.value)
        attach[name] = bits
    state["framebuffer"] = attach
    return state


# ------------------------------------------------------------------- recording proxies

REAL = {name: getattr(gpu.types, name) for name in (
    "GPUShaderCreateInfo", "GPUStageInterfaceInfo", "GPUUniformBuf", "GPUTexture",
    "GPUVertFormat", "GPUVertBuf", "GPUIndexBuf", "GPUBatch")}
REAL_CREATE = gpu.shader.create_from_info
REAL_STATE = {name: getattr(gpu.state, name) for name in (
    "depth_test_set", "depth_mask_set", "face_culling_set", "front_facing_set", "blend_set",
    "color_mask_set")}

EVENTS: list[dict] = []          # one per batch draw
READS: list[dict] = []           # one per Target.read: the image and the draw before it
STATE: dict = {}                 # the last value given to each gpu.state setter


def _unwrap(obj):
    return getattr(obj, "_real", obj)


class RecInterface:
    def __init__(self, name: str):
        self._real = REAL["GPUStageInterfaceInfo"](name)
        self.rec = {"name": name, "members": []}

    def _add(self, qualifier, type_, name):
        self.rec["members"].append([qualifier, type_, name])
        getattr(self._real, qualifier)(type_, name)

    def smooth(self, type_, name):
        self._add("smooth", type_, name)

    def flat(self, type_, name):
        self._add("flat", type_, name)

    def no_perspective(self, type_, name):
        self._add("no_perspective", type_, name)


class RecCreateInfo:
    def __init__(self):
        self._real = REAL["GPUShaderCreateInfo"]()
        self.rec = {"defines": [], "typedef_source": [], "uniform_bufs": [], "samplers": [],
                    "images": [], "push_constants": [], "vertex_in": [], "interfaces": [],
                    "fragment_out": [], "vertex_source": None, "fragment_source": None}

    def define(self, name, value=""):
        self.rec["defines"].append([name, value])
        self._real.define(name, value)

    def typedef_source(self, source):
        self.rec["typedef_source"].append(source)
        self._real.typedef_source(source)

    def uniform_buf(self, slot, type_name, name):
        self.rec["uniform_bufs"].append({"slot": slot, "type_name": type_name, "name": name})
        self._real.uniform_buf(slot, type_name, name)

    def sampler(self, slot, type_, name):
        self.rec["samplers"].append({"slot": slot, "type": type_, "name": name})
        self._real.sampler(slot, type_, name)

    def push_constant(self, type_, name, size=0):
        self.rec["push_constants"].append({"type": type_, "name": name, "size": size})
        self._real.push_constant(type_, name, size)

    def vertex_in(self, slot, type_, name):
        self.rec["vertex_in"].append({"slot": slot, "type": type_, "name": name})
        self._real.vertex_in(slot, type_, name)

    def vertex_out(self, interface):
        self.rec["interfaces"].append(interface.rec)
        self._real.vertex_out(_unwrap(interface))

    def vertex_source(self, source):
        self.rec["vertex_source"] = source
        self._real.vertex_source(source)

    def fragment_out(self, slot, type_, name, blend="NONE"):
        self.rec["fragment_out"].append({"slot": slot, "type": type_, "name": name,
                                         "blend": blend})
        self._real.fragment_out(slot, type_, name, blend=blend)

    def fragment_source(self, source):
        self.rec["fragment_source"] = source
        self._real.fragment_source(source)

    def __getattr__(self, name):
        raise AttributeError(f"export_cases: create-info method {name!r} is not recorded; "
                             "add it to RecCreateInfo")


_COMMENTS = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)


#: Empty macros Blender's GLSL preprocessor wraps around out/inout parameters
#: (gpu_shader_compat_glsl.glsl defines them as nothing).
_MARKERS = re.compile(r"\b_(?:in|out|inout|shared)_(?:sta|end)\b")


def normalized_glsl(text: str) -> str:
    """GLSL without comments, without Blender's empty parameter markers and with
    whitespace collapsed: Blender's preprocessor strips comments (blank lines stay) and
    adds the markers, so sources are compared this way."""
    collapsed = " ".join(_MARKERS.sub(" ", _COMMENTS.sub(" ", text)).split())
    return re.sub(r" ?([^\w ]) ?", r"\1", collapsed)


def _dumped_source(rec: dict, stage: str) -> str | None:
    """The Mesa dump of this shader's ``stage`` ("VS"/"FS"): the file whose text after
    Blender's last ``#line 1 ""`` (dumped as ``//ine``) is the stage's source (comments
    aside) and which holds the create-info's #define block and typedef."""
    source = normalized_glsl(rec["vertex_source" if stage == "VS" else "fragment_source"])
    defines = "".join(f"#define {n} {v}\n" for n, v in rec["defines"])
    marker = "#define GPU_VERTEX_SHADER\n" if stage == "VS" else "#define GPU_FRAGMENT_SHADER\n"
    matches = []
    for path in sorted(DUMP_DIR.glob(f"{stage}_*.glsl")):
        text = path.read_text(encoding="utf-8", errors="replace")
        if (marker + defines) not in text:
            continue
        if any(normalized_glsl(t) not in normalized_glsl(text) for t in rec["typedef_source"]):
            continue
        tail = re.split(r'\n(?://|#)ine 1 ""\n', text)[-1]
        if normalized_glsl(tail) != source:
            continue
        matches.append(text)
    if not matches:
        return None
    if len(set(matches)) > 1:
        log(f"  warning: {len(set(matches))} different Mesa dumps match one {stage}; "
            "taking the first")
    return matches[0]


class RecShader:
    def __init__(self, real, info_rec: dict):
        self._real = real
        self.info = info_rec
        self.ubos: dict = {}
        self.samplers: dict = {}
        self.uniforms: dict = {}
        self.glsl = {"vertex": _dumped_source(info_rec, "VS"),
                     "fragment": _dumped_source(info_rec, "FS")}
        if self.glsl["vertex"] is None or self.glsl["fragment"] is None:
            log("  warning: no Mesa dump found for a shader (MESA_SHADER_DUMP_PATH unused?)")

    def bind(self):
        self._real.bind()

    def uniform_block(self, name, ubo):
        self._real.uniform_block(name, _unwrap(ubo))
        self.ubos[name] = ubo

    def uniform_sampler(self, name, texture):
        self._real.uniform_sampler(name, _unwrap(texture))
        self.samplers[name] = texture

    def uniform_float(self, name, value):
        self._real.uniform_float(name, value)
        self.uniforms[name] = {"kind": "float",
                               "value": [float(v) for v in np.asarray(value, np.float64).ravel()]}

    def uniform_int(self, name, value):
        self._real.uniform_int(name, value)
        self.uniforms[name] = {"kind": "int",
                               "value": [int(v) for v in np.asarray(value).ravel()]}

    def __getattr__(self, name):
        return getattr(self._real, name)


def rec_create_from_info(info):
    shader = REAL_CREATE(_unwrap(info))
    if isinstance(info, RecCreateInfo):
        return RecShader(shader, info.rec)
    return shader


class RecUniformBuf:
    def __init__(self, data):
        self.data = bytes(data)
        self._real = REAL["GPUUniformBuf"](data)

    def update(self, data):
        self.data = bytes(data)
        self._real.update(data)


class RecTexture:
    def __init__(self, size, layers=0, is_cubemap=False, format="RGBA8", data=None):
        self._real = REAL["GPUTexture"](size, layers=layers, is_cubemap=is_cubemap,
                                        format=format, data=data)
        self.size = tuple(int(s) for s in (size if np.ndim(size) else (size,)))
        self.layers = int(layers)
        self.format = format
        # The 16-bit formats hold the factor precisions' texels (core/brdf/filtered_factors):
        # float values exact in the format, so a float32 record loses nothing.
        if format not in ("RGBA32F", "RGBA16F", "RGBA16"):
            raise ValueError(f"export_cases records RGBA32F, RGBA16F and RGBA16 textures, "
                             f"got {format}")
        # Blender 4.5 and 5.0 have no sampler API: their Python textures filter linearly
        # (texelFetch ignores the filter, so the textures read that way draw the same).
        self.linear = not hasattr(self._real, "filter_mode")
        texels = np.array(data, dtype=np.float32).ravel() if data is not None else None
        w, h = self.size
        shape = (self.layers, h, w, 4) if self.layers else (h, w, 4)
        self.texels = None if texels is None else texels.reshape(shape)

    def __getattr__(self, name):
        if name == "filter_mode":
            real = getattr(self._real, name)

            def filter_mode(use_filter):
                real(use_filter)
                self.linear = bool(use_filter)
            return filter_mode
        return getattr(self._real, name)


class RecVertFormat:
    def __init__(self):
        self._real = REAL["GPUVertFormat"]()
        self.attrs = []

    def attr_add(self, id, comp_type, len, fetch_mode):  # noqa: A002  (bpy's names)
        self.attrs.append({"name": id, "comp_type": comp_type, "len": len,
                           "fetch_mode": fetch_mode})
        self._real.attr_add(id=id, comp_type=comp_type, len=len, fetch_mode=fetch_mode)


class RecVertBuf:
    def __init__(self, fmt, length):
        self._real = REAL["GPUVertBuf"](_unwrap(fmt), length)
        self.format = fmt.attrs
        self.length = int(length)
        self.arrays: dict = {}

    def attr_fill(self, id, data):  # noqa: A002
        self._real.attr_fill(id, data)
        self.arrays[id] = np.array(data, dtype=np.float32).reshape(self.length, -1)


class RecIndexBuf:
    def __init__(self, type, seq):  # noqa: A002
        self._real = REAL["GPUIndexBuf"](type=type, seq=seq)
        self.type = type
        self.indices = np.array(seq, dtype=np.int64).reshape(-1)


class RecBatch:
    def __init__(self, type, buf, elem=None):  # noqa: A002
        self._real = REAL["GPUBatch"](type=type, buf=_unwrap(buf), elem=_unwrap(elem))
        self.type = type
        self.vbo = buf
        self.ibo = elem

    def draw(self, shader=None):
        self._real.draw(_unwrap(shader))
        if isinstance(shader, RecShader):
            EVENTS.append({"shader": shader, "batch": self, "state": dict(STATE),
                           "gl": gl_state(),
                           "ubos": {k: v.data for k, v in shader.ubos.items()},
                           "samplers": dict(shader.samplers),
                           "uniforms": json.loads(json.dumps(shader.uniforms))})

    def __getattr__(self, name):
        return getattr(self._real, name)


def _state_setter(name):
    real = REAL_STATE[name]

    def setter(*args):
        STATE[name] = list(args)
        return real(*args)
    return setter


_REAL_READ = offscreen.Target.read


def _recording_read(self):
    image = _REAL_READ(self)
    READS.append({"image": image, "event": len(EVENTS) - 1,
                  "size": (self.width, self.height)})
    return image


def install_recorders() -> None:
    gpu.types.GPUShaderCreateInfo = RecCreateInfo
    gpu.types.GPUStageInterfaceInfo = RecInterface
    gpu.types.GPUUniformBuf = RecUniformBuf
    gpu.types.GPUTexture = RecTexture
    gpu.types.GPUVertFormat = RecVertFormat
    gpu.types.GPUVertBuf = RecVertBuf
    gpu.types.GPUIndexBuf = RecIndexBuf
    gpu.types.GPUBatch = RecBatch
    gpu.shader.create_from_info = rec_create_from_info
    for name in REAL_STATE:
        setattr(gpu.state, name, _state_setter(name))
    offscreen.Target.read = _recording_read


# ------------------------------------------------------------------------ the store


class Store:
    """Content-addressed blobs (shared between cases), references, GLSL dumps."""

    def __init__(self, out: Path):
        self.out = out
        for sub in ("blobs", "refs", "glsl"):
            (out / sub).mkdir(parents=True, exist_ok=True)
        self.cases: list[dict] = []
        self.names: set[str] = set()

    def array(self, array: np.ndarray) -> str:
        array = np.ascontiguousarray(array)
        digest = hashlib.sha1(array.tobytes() + str((array.dtype.str, array.shape)).encode()
                              ).hexdigest()[:20]
        rel = f"blobs/{digest}.npy"
        if not (self.out / rel).exists():
            np.save(self.out / rel, array)
        return rel

    def raw(self, data: bytes) -> str:
        digest = hashlib.sha1(data).hexdigest()[:20]
        rel = f"blobs/{digest}.bin"
        if not (self.out / rel).exists():
            (self.out / rel).write_bytes(data)
        return rel

    def text(self, text: str | None, suffix: str) -> str | None:
        if text is None:
            return None
        digest = hashlib.sha1(text.encode()).hexdigest()[:20]
        rel = f"glsl/{digest}.{suffix}"
        if not (self.out / rel).exists():
            (self.out / rel).write_text(text, encoding="utf-8")
        return rel


def reference(store: Store, name: str, image: np.ndarray, stride: int | None = None) -> dict:
    """The project's read-back: full statistics, full-resolution coverage mask, a strided
    subsample and full-resolution crops, in refs/<name>.npz."""
    h, w = image.shape[:2]
    s = stride or ARGS.stride
    offset = s // 2
    covered = image[..., 3] > 0
    finite = np.isfinite(image)
    rgb = image[..., :3]
    sub = image[offset::s, offset::s]
    crops, origins = [], []
    ys, xs = np.nonzero(covered)
    if len(ys):
        c = ARGS.crop
        centres = [(int(np.median(ys)), int(np.median(xs)))]
        rng = np.random.default_rng(12345)
        for i in rng.choice(len(ys), size=min(3, len(ys)), replace=False):
            centres.append((int(ys[i]), int(xs[i])))
        # one crop on the coverage edge (the silhouette), where rasterisation differs first
        edge = covered & ~np.roll(covered, 1, axis=1)
        ey, ex = np.nonzero(edge)
        if len(ey):
            k = len(ey) // 2
            centres.append((int(ey[k]), int(ex[k])))
        for cy, cx in centres:
            y0 = int(np.clip(cy - c // 2, 0, h - c))
            x0 = int(np.clip(cx - c // 2, 0, w - c))
            origins.append((y0, x0))
            crops.append(image[y0:y0 + c, x0:x0 + c])
    path = store.out / "refs" / f"{name}.npz"
    np.savez_compressed(path, subsample=sub, mask=np.packbits(covered.ravel()),
                        crops=np.asarray(crops, dtype=np.float32).reshape(-1, ARGS.crop,
                                                                          ARGS.crop, 4),
                        crop_origins=np.asarray(origins, dtype=np.int32).reshape(-1, 2))
    alpha_values = np.unique(image[..., 3])
    cov_rgb = rgb[covered]
    return {
        "file": f"refs/{name}.npz", "width": w, "height": h, "stride": s, "offset": offset,
        "crop": ARGS.crop, "covered_pixels": int(covered.sum()),
        "lit_pixels": int(np.count_nonzero(rgb.max(axis=-1) > 0)),
        "nonfinite_values": int((~finite).sum()),
        "channel_sums": [float(v) for v in image.astype(np.float64).sum(axis=(0, 1))],
        "channel_max": [float(v) for v in np.nanmax(image.reshape(-1, 4), axis=0)],
        "alpha_values": [float(v) for v in alpha_values[:8]],
        "saturated_share": float(np.mean(np.all(cov_rgb >= 0.999, axis=-1))) if len(cov_rgb)
        else 0.0,
        "any_channel_saturated_share": float(np.mean(np.any(cov_rgb >= 0.999, axis=-1)))
        if len(cov_rgb) else 0.0,
        "zero_share": float(np.mean(np.all(cov_rgb == 0.0, axis=-1))) if len(cov_rgb) else 0.0,
    }


def export_event(store: Store, name: str, event: dict, image: np.ndarray, meta: dict,
                 stride: int | None = None) -> None:
    if name in store.names:
        return
    store.names.add(name)
    shader: RecShader = event["shader"]
    batch: RecBatch = event["batch"]
    info = shader.info
    samplers = {}
    for s in info["samplers"]:
        tex = event["samplers"].get(s["name"])
        if tex is None:
            raise RuntimeError(f"{name}: sampler {s['name']} was not bound")
        samplers[s["name"]] = {"slot": s["slot"], "type": s["type"], "format": tex.format,
                               "linear": tex.linear, "size": list(tex.size), "layers": tex.layers,
                               "shape": list(tex.texels.shape), "blob": store.array(tex.texels)}
    ubos = {}
    for u in info["uniform_bufs"]:
        data = event["ubos"].get(u["name"])
        if data is None:
            raise RuntimeError(f"{name}: uniform buffer {u['name']} was not bound")
        ubos[u["name"]] = {"slot": u["slot"], "type_name": u["type_name"], "bytes": len(data),
                           "blob": store.raw(data)}
    vbo: RecVertBuf = batch.vbo
    index_count = int(batch.ibo.indices.size) if batch.ibo is not None else 0
    gl = event["gl"]
    element_bytes = gl.get("element_buffer_bytes")
    index_size = (element_bytes // index_count) if (element_bytes and index_count) else None
    geometry = {
        "primitive": batch.type, "vertex_count": vbo.length,
        "vertex_format": vbo.format,
        "vertex_arrays": {a["name"]: store.array(vbo.arrays[a["name"]]) for a in vbo.format},
        "index_blob": store.array(batch.ibo.indices.astype(np.int32)) if batch.ibo else None,
        "index_count": index_count,
        "index_element_size": index_size or (2 if batch.ibo.indices.max() < 0xFFFF else 4),
        "index_element_size_observed": index_size,
    }
    case = {
        "name": name, **meta,
        "shader": {**{k: v for k, v in info.items()},
                   "blender_glsl": {"vertex": store.text(shader.glsl["vertex"], "vert"),
                                    "fragment": store.text(shader.glsl["fragment"], "frag")}},
        "uniform_buffers": ubos, "samplers": samplers,
        "push_constants": event["uniforms"], "geometry": geometry,
        "state": {"gpu_state_calls": event["state"], "gl": gl},
        "target": {"width": int(image.shape[1]), "height": int(image.shape[0]),
                   "format": "RGBA32F", "clear_color": [0.0, 0.0, 0.0, 0.0],
                   "clear_depth": 1.0},
        "reference": reference(store, name, image, stride),
    }
    case.setdefault("role", "timing")
    store.cases.append(case)
    r = case["reference"]
    log(f"  exported {name}: {r['covered_pixels']} px covered, saturated (any channel ≥ "
        f"0.999) {100 * r['any_channel_saturated_share']:.1f} %, non-finite "
        f"{r['nonfinite_values']}")


def reads_since(start: int) -> list[dict]:
    return READS[start:]


# ----------------------------------------------------------------------- families


def llvmpipe_rows(doc: str) -> dict | list:
    path = ROOT / "docs" / doc
    return json.loads(path.read_text()) if path.exists() else {}


def export_draw(store: Store) -> None:
    """bench_draw's cases through Bench.measure (1 frame, 1 repetition)."""
    import bench_draw as bd

    from spectral_materials.blender.gpu.offscreen import Target

    size = ARGS.draw_size or 1200
    docs = llvmpipe_rows("bench_draw.json")
    doc_rows = {(r["layout"], r["packs"], r["lights"], r["mode"]): r
                for r in docs.get("rows", [])}
    configs = [("io_iso", p, 1, True) for p in (1, 4, 22, 48)]
    configs += [("io_iso", 4, n, True) for n in (2, 4, 8)]
    configs += [("io_iso", 48, 1, False), ("hd", 48, 1, True)]
    configs += [("io_iso", 4, 1, False), ("hd", 4, 1, True)]
    arrays = bd.sphere_arrays()
    batches = bd.mesh_batches.MeshBatches.build(arrays)
    (batch,) = batches.batches.values()
    vp = bd.view_projection(0.5 / bd.DISC_FRACTION)
    with Target(size, size) as target:
        gpu.state.face_culling_set("BACK")
        try:
            bench = bd.Bench(target, batch, vp, 1, 1)
            for layout, packs, n_lights, pre in configs:
                start = len(READS)
                t0 = time.perf_counter()
                lights = bd.make_lights(n_lights)
                row = bench.measure(layout, packs, lights, pre)
                spectral_read, baseline_read = reads_since(start)[:2]
                mode = bd.MODES[pre]
                doc = doc_rows.get((layout, packs, n_lights, mode))
                meta = {"family": "factor_packs", "group": "draw",
                        "ratio_to": f"draw_baseline_l{n_lights}",
                        "params": {"layout": layout, "packs": packs, "lights": n_lights,
                                   "mode": mode, "light_kinds": row["light_kinds"],
                                   "terms": row["terms"],
                                   "texture_bytes": row["texture_bytes"]},
                        "project": {"source": "scripts/bench_draw.py Bench.measure",
                                    "covered_pixels": row["covered_pixels"],
                                    "lit_pixels": row["lit_pixels"]},
                        "llvmpipe_docs": {k: doc[k] for k in ("ms", "baseline_ms", "ratio")}
                        if doc else None}
                export_event(store, f"draw_{layout}_{mode}_p{packs}_l{n_lights}",
                             EVENTS[spectral_read["event"]], spectral_read["image"], meta)
                base_doc = next((r for r in docs.get("rows", []) if r["lights"] == n_lights),
                                None)
                export_event(store, f"draw_baseline_l{n_lights}",
                             EVENTS[baseline_read["event"]], baseline_read["image"],
                             {"family": "baseline", "group": "draw", "ratio_to": None,
                              "params": {"lights": n_lights, "light_kinds": row["light_kinds"]},
                              "project": {"source": "scripts/bench_draw.py Baseline",
                                          "covered_pixels": row["baseline_covered_pixels"]},
                              "llvmpipe_docs": {"baseline_ms": base_doc["baseline_ms"]}
                              if base_doc else None})
                export_xyz_twin(store, bench, bd, layout, packs, lights, pre)
                log(f"  ({time.perf_counter() - t0:.1f} s)")
        finally:
            gpu.state.face_culling_set("NONE")


def export_xyz_twin(store: Store, bench, bd, layout: str, packs: int, lights, pre: bool) -> None:
    """The same draw with output XYZ: a correctness twin. The DISPLAY output the benchmark
    times clips to [0, 1] (tone map, sRGB gamut) and with bench_draw's synthetic factors
    it is clipped on every pixel from 4 packs on, so its image cannot show a wrong
    shader; linear XYZ is not clipped. Set up as Bench.measure sets up its spectral
    draw, with output="XYZ", drawn and read back by Bench.warm."""
    from spectral_materials.blender.brdf.gpu_material import GPUMaterial
    from spectral_materials.blender.gpu import shaders
    from spectral_materials.blender.gpu.display import DisplaySettings

    model = bd.synthetic_model(layout, packs)
    material = GPUMaterial(model)
    key = material.key(lights, precontract=pre, output="XYZ")
    shader = shaders.get_shader(key)
    light_texture = material.light_texture(lights, pre)
    params = material.params(DisplaySettings(), view_origin=bd.VIEW_ORIGIN,
                             view_projection=bench.vp)

    def bind():
        material.bind(shader, light_texture, params)
        return shader

    start = len(READS)
    bench.warm(bind)
    (read,) = reads_since(start)
    mode = bd.MODES[pre]
    export_event(store, f"xyz_{layout}_{mode}_p{packs}_l{len(lights)}",
                 EVENTS[read["event"]], read["image"], {
                     "family": "factor_packs", "group": "draw-xyz", "role": "check",
                     "ratio_to": None,
                     "params": {"layout": layout, "packs": packs, "lights": len(lights),
                                "mode": mode, "output": "XYZ",
                                "twin_of": f"draw_{layout}_{mode}_p{packs}_l{len(lights)}"},
                     "project": {"source": "scripts/bench_draw.py Bench (Bench.measure's "
                                           "set-up with output XYZ)"},
                     "llvmpipe_docs": None}, stride=ARGS.check_stride)


@contextlib.contextmanager
def _sphere_bench(bd):
    """The draw benchmark's Bench on its sphere and target (1 frame, 1 repetition), back
    faces culled as the benchmark draws."""
    from spectral_materials.blender.gpu.offscreen import Target

    arrays = bd.sphere_arrays()
    batches = bd.mesh_batches.MeshBatches.build(arrays)
    (batch,) = batches.batches.values()
    vp = bd.view_projection(0.5 / bd.DISC_FRACTION)
    size = ARGS.draw_size or 1200
    with Target(size, size) as target:
        gpu.state.face_culling_set("BACK")
        try:
            yield bd.Bench(target, batch, vp, 1, 1)
        finally:
            gpu.state.face_culling_set("NONE")


#: (packs, lights) of the factor precisions' draws: benchmarks/factor_precision.py's cases
#: and the pack counts of the draw family.
PRECISION_CASES = ((4, 1), (22, 1), (48, 1), (22, 4))


def export_precision(store: Store) -> None:
    """benchmarks/factor_precision.py's draws: each fast factor precision (16-bit texels,
    hardware filtered or fetched and mixed) at the draw benchmark's settings, io_iso,
    pre-contracted, with an XYZ correctness twin; and the exact path in the same cases
    that the draw family does not export, so each has its exact ratio. Runs after the
    draw family, which exports the baselines (draw_baseline_l1 and _l4)."""
    import bench_draw as bd

    from benchmarks.draw_variants import material_binder
    from benchmarks.factor_precision import FAST
    from spectral_materials.blender.brdf.gpu_material import GPUMaterial

    with _sphere_bench(bd) as bench:
        for packs, n_lights in PRECISION_CASES:
            lights = bd.make_lights(n_lights)
            model = bd.synthetic_model("io_iso", packs)
            exact_name = f"draw_io_iso_precontract_p{packs}_l{n_lights}"
            for precision in ("exact", *FAST):
                material = GPUMaterial(model, precision)
                for output in ("DISPLAY", "XYZ"):
                    key = material.key(lights, precontract=True, output=output)
                    bind = material_binder(bench, material, key,
                                           material.light_texture(lights, True))
                    start = len(READS)
                    bench.warm(bind)
                    (read,) = reads_since(start)
                    timed = output == "DISPLAY"
                    base = exact_name if precision == "exact" else \
                        f"{exact_name}_{precision}"
                    name = base if timed else base.replace("draw_", "xyz_", 1)
                    export_event(store, name, EVENTS[read["event"]], read["image"], {
                        "family": "factor_packs", "group": "precision" if timed
                        else "precision-xyz", **({} if timed else {"role": "check"}),
                        "ratio_to": f"draw_baseline_l{n_lights}" if timed else None,
                        "exact_twin": exact_name if timed else None,
                        "params": {"layout": "io_iso", "packs": packs,
                                   "lights": n_lights, "mode": "precontract",
                                   "precision": precision, "output": output,
                                   "factor_texture_bytes": int(material.nbytes)},
                        "project": {"source": "benchmarks/factor_precision.py draw_rows"},
                        "llvmpipe_docs": None},
                        # The timed draws' display output clips (see
                        # export_xyz_twin): a coarse reference keeps the payload small.
                        stride=max(ARGS.stride, 8) if timed else ARGS.check_stride)
            log(f"  precision: {packs} packs, {n_lights} lights")


#: benchmarks/draw_variants.py's comparisons replayed: every factor-pack case; the XYZ
#: twins only where the shader's arithmetic changed (issue 18's edge rule, lobe, cells).
VARIANT_TWINS = ("edge rule", "specular lobe", "measured cells")
#: The light loop's two orders over more pack and light counts than draw_variants.CASES:
#: on a GPU the crossover is not llvmpipe's (docs/bench_gpu_variants.md).
LIGHT_LOOP_SWEEP = tuple(("light loop", packs, lights) for packs in (4, 8, 12, 16, 22)
                         for lights in (2, 4, 8))


def export_variants(store: Store) -> None:
    """benchmarks/draw_variants.py's factor-pack comparisons: each case's before and after
    draw (``variant_<comparison>_p<packs>_l<lights>_before``/``_after``), the after timed
    against its before, on the draw benchmark's sphere and target."""
    import bench_draw as bd

    from benchmarks.draw_variants import CASES, LABELS, binders
    from benchmarks.gpu_replay.variants_report import VARIANT_PREFIX, variant_stem

    with _sphere_bench(bd) as bench:
        sweep = [c for c in LIGHT_LOOP_SWEEP if c not in CASES]
        for comparison, packs, n_lights in (*CASES, *sweep):
            stem = variant_stem(comparison, packs, n_lights)
            outputs = ("DISPLAY", "XYZ") if comparison in VARIANT_TWINS else ("DISPLAY",)
            for output in outputs:
                pair = binders(bench, comparison, packs, n_lights, output=output)
                for side, bind, label in zip(("before", "after"), pair,
                                             LABELS[comparison]):
                    start = len(READS)
                    bench.warm(bind)
                    (read,) = reads_since(start)
                    timed = output == "DISPLAY"
                    name = f"{stem}_{side}" if timed else \
                        f"xyz_{stem[len(VARIANT_PREFIX):]}_{side}"
                    export_event(store, name, EVENTS[read["event"]], read["image"], {
                        "family": "variants", "group": "variants" if timed
                        else "variants-xyz", **({} if timed else {"role": "check"}),
                        "ratio_to": f"{stem}_before" if timed and side == "after"
                        else None,
                        "params": {"comparison": comparison, "side": side,
                                   "label": label, "layout": "io_iso", "packs": packs,
                                   "lights": n_lights, "mode": "precontract",
                                   "output": output},
                        "project": {"source": "benchmarks/draw_variants.py binders"},
                        "llvmpipe_docs": None},
                        stride=max(ARGS.stride, 8) if timed else ARGS.check_stride)
            log(f"  variants: {comparison}, {packs} packs, {n_lights} lights")


def export_btf(store: Store) -> None:
    """bench_btf.frame_times (1 frame, 1 repetition): RFP and RFNL, 1 and 4 lights."""
    import bench_btf

    docs = llvmpipe_rows("bench_btf.json")
    doc_rows = {(r["model"], r["lights"]): r for r in docs.get("frames", []) or []}
    start = len(READS)
    t0 = time.perf_counter()
    rows = bench_btf.frame_times(1, 1)
    log(f"  bench_btf.frame_times: {time.perf_counter() - t0:.1f} s")
    reads = reads_since(start)
    # frame_times: per light count (1, 4), per model (RFP, RFNL): warm BTF, warm baseline.
    order = [(count, kind) for count in (1, 4) for kind in ("RFP", "RFNL")]
    if len(reads) < 2 * len(order):
        raise RuntimeError(f"bench_btf.frame_times read {len(reads)} images, expected "
                           f"{2 * len(order)}")
    for i, (count, kind) in enumerate(order):
        btf_read, base_read = reads[2 * i], reads[2 * i + 1]
        event = EVENTS[btf_read["event"]]
        defines = dict(event["shader"].info["defines"])
        assert defines["SM_LIGHTS"] == str(count), defines
        assert defines["SM_BTF_KIND"] == {"RFP": "0", "RFNL": "1"}[kind], defines
        row = next(r for r in rows if r["model"] == kind and r["lights"] == count)
        doc = doc_rows.get((kind, count))
        export_event(store, f"btf_{kind.lower()}_l{count}", event, btf_read["image"], {
            "family": "btf", "group": "btf", "ratio_to": f"btf_baseline_l{count}",
            "params": {"model": kind, "lights": count, "material": "corduroy", "texels": 16,
                       "uv_scale": [4.0, 4.0], "gpu_bytes": int(row["gpu_bytes"])},
            "project": {"source": "scripts/bench_btf.py frame_times",
                        "covered_pixels": int(row["pixels"])},
            "llvmpipe_docs": {k: doc[k] for k in ("btf_ms", "baseline_ms", "ratio")}
            if doc else None})
        export_event(store, f"btf_baseline_l{count}", EVENTS[base_read["event"]],
                     base_read["image"], {
                         "family": "baseline", "group": "btf", "ratio_to": None,
                         "params": {"lights": count},
                         "project": {"source": "scripts/bench_btf.py frame_times "
                                               "(bench_draw.Baseline)"},
                         "llvmpipe_docs": {"baseline_ms": doc["baseline_ms"]} if doc else None})


def export_prt(store: Store) -> None:
    """bench_prt's headline draw: bands 5, basis 8, FL4 overcast sky, spectral and RGB."""
    import bench_prt as bp

    from spectral_materials import blender as addon
    from spectral_materials.blender import prt
    from spectral_materials.blender.gpu.offscreen import Target
    from spectral_materials.blender.prt import drawer as prt_gpu

    addon.register()
    scene, obj, mesh_info = bp.build_scene(bp.SUBDIVISIONS[0], bp.FLOOR_SUBDIVISIONS[0])
    env = scene.spectral.environment
    rays = ARGS.prt_rays or max(r for r in bp.RAYS[0] if r <= bp.MAIN_RAYS)
    env.bands, env.basis_size, env.illuminant = bp.MAIN_BANDS, bp.MAIN_BASIS, bp.ILLUMINANTS[0]
    env.window = bp.DEFAULT_WINDOW
    obj.spectral_prt.rays = rays
    t0 = time.perf_counter()
    baked = prt.bake_prt(obj, scene)
    log(f"  PRT bake ({rays} rays/vertex, {mesh_info['vertices']} vertices): "
        f"{time.perf_counter() - t0:.1f} s, backend {baked.backend}")
    docs = llvmpipe_rows("bench_prt.json")
    headline = docs.get("headline") if isinstance(docs, dict) else None
    with Target(bp.SIZE, bp.SIZE) as target:
        bench = bp.FrameBench(scene, obj, target)
        for albedo in ("chart", "image"):
            if albedo == "image":
                obj.spectral_prt.albedo_kind = "IMAGE"
                obj.spectral_prt.image = albedo_image()
            prefix = "prt" if albedo == "chart" else "prt_image"
            # Spectral with the albedo as Automatic draws it (the default), as the basis
            # and as the exact R̃ layers (the object's Albedo texture), and RGB PRT.
            for rgb, form in ((False, "AUTO"), (False, "BASIS"), (False, "EXACT"),
                              (True, "AUTO")):
                obj.spectral_prt.albedo_texture = form
                bench.frame(rgb)                       # switching modes rebuilds textures
                start = len(READS)
                covered = bench.covered(rgb)           # a frame and the project's read-back
                (read,) = reads_since(start)
                name = f"{prefix}_rgb" if rgb else f"{prefix}_spectral_m{bp.MAIN_BASIS}" + \
                    {"AUTO": "", "BASIS": "_basis", "EXACT": "_layers"}[form]
                drawn = prt_gpu._OBJECTS[obj.name].get("albedo_drawn")
                basis = drawn.basis if drawn is not None else None
                export_event(store, name, EVENTS[read["event"]], read["image"], {
                    "family": "prt", "group": "prt",
                    "ratio_to": None if rgb else f"{prefix}_rgb",
                    "params": {"bands": bp.MAIN_BANDS, "basis": 3 if rgb else bp.MAIN_BASIS,
                               "rgb": rgb, "albedo": albedo,
                               "albedo_form": drawn.form if drawn is not None else None,
                               "albedo_basis_rank": basis.rank if basis and not rgb else None,
                               "rays": rays, "illuminant": bp.ILLUMINANTS[0],
                               "sky": "overcast", "window": bp.DEFAULT_WINDOW, **mesh_info},
                    "project": {"source": "scripts/bench_prt.py FrameBench (headline "
                                          "settings)", "covered_pixels": covered},
                    "llvmpipe_docs": ({"rgb_ms": headline.get("rgb_ms")} if rgb else
                                      {k: headline.get(k) for k in ("ms", "rgb_ms", "ratio")})
                    if headline and albedo == "chart" else None})


def albedo_image(size: int = 256):
    """A linear RGB albedo texture of smooth colour fields (what an artist's texture is
    like, unlike the chart's 24 measured spectra): Smits' uplift makes it 7-dimensional."""

    y, x = np.mgrid[0:size, 0:size] / size
    rgb = np.stack([0.45 + 0.4 * np.sin(6.3 * x + 1.0) * np.cos(3.1 * y),
                    0.40 + 0.35 * np.sin(4.1 * y + 2.0 * x),
                    0.35 + 0.3 * np.cos(5.3 * x * y + 0.5)], axis=-1)
    image = bpy.data.images.new("PRT albedo", size, size, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    pixels = np.concatenate([np.clip(rgb, 0.02, 0.98), np.ones((size, size, 1))], axis=-1)
    image.pixels.foreach_set(pixels.astype(np.float32).ravel())
    return image


# --------------------------------------------------------------------------- main


def main() -> None:
    started = time.perf_counter()
    ensure_gpu()
    install_recorders()
    from bench_common import gpu_machine

    machine = gpu_machine()
    log(f"exporting with {machine['renderer']} ({machine['backend']}); Mesa dumps in {DUMP_DIR}")
    store = Store(OUT)
    families = [f.strip() for f in ARGS.families.split(",") if f.strip()]
    for family in families:
        log(f"{family}:")
        {"draw": export_draw, "precision": export_precision, "btf": export_btf,
         "prt": export_prt, "variants": export_variants}[family](store)
    manifest = {
        "format": 1, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "project": str(ROOT), "project_commit": _git_head(),
        "exporter": "gpu/export_cases.py", "machine": machine,
        "reference_note": "Images are the project's own offscreen read-backs (Blender "
                          "5.0.1 GPU module, OpenGL backend) on this machine's renderer.",
        "cases": store.cases,
    }
    (OUT / "manifest.json").write_text(json.dumps(manifest, indent=1))
    total = sum(p.stat().st_size for p in OUT.rglob("*") if p.is_file())
    log(f"wrote {len(store.cases)} cases to {OUT} ({total / 2**20:.1f} MiB) in "
        f"{time.perf_counter() - started:.0f} s")


def _git_head() -> str | None:
    head = ROOT / ".git" / "HEAD"
    try:
        ref = head.read_text().strip()
        if ref.startswith("ref: "):
            return (ROOT / ".git" / ref[5:]).read_text().strip()
        return ref
    except OSError:
        return None


if __name__ == "__main__":
    main()
    # The recorded events hold Blender GPU objects; freeing them while the bpy module
    # tears down its GPU context crashed the interpreter at exit (SIGSEGV after the
    # manifest was written). Everything is on disk: leave without that teardown.
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
