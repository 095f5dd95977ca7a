"""Diagnostic variants of exported cases: text patches of Blender's GLSL (and sampler
changes) added to an export's manifest as ``<case>__<variant>``, for run_gpu.py to time
beside the unchanged case in the same run. What each costs on a GPU decides what the
shaders adopt (issue 19); the variants' images are not meant to be right.

Three sets: ``explored`` patches the shaders of commit b30c25a (the albedo basis with G
interpolated, BTF lights outermost), whose timings on an H200 are
docs/gpu/h200_explored_*.json; ``prt_paths`` those of commit 5223be0 (where the PRT albedo
is filtered, and in what format), timed in docs/gpu/h200_prt_paths_*.json; both led to
today's shaders. ``current`` patches today's (the loop orders they replaced, timed
against them in the same run). ``cells_edge`` moves the measured-cells twin's θd index off
the cell edge that the draw benchmark's sun sits on.

    python benchmarks/gpu_replay/patch_cases.py .replay/data [--set current]
"""

from __future__ import annotations

import argparse
import copy
import hashlib
import json
from pathlib import Path

import numpy as np

_HW = "texture(albedo_tex, vec3(tex_uv, float(l)))"
_HW_SAMPLER = {"albedo_tex": {"linear": True, "repeat": True}}
_HALF_SAMPLER = {"albedo_tex": {"linear": True, "repeat": True, "format": "RGBA16F"}}
_TWO_LAYERS = [("#define SM_PRT_BASIS_LAYERS 3", "#define SM_PRT_BASIS_LAYERS 2")]

# PRT: Ê (2 vec4) interpolated and G = Ê · M formed per pixel, instead of G (3 vec4 per
# layer of weights) interpolated.
_G_OUT = "".join(f"  smooth vec4 prt_g{q};\n" for q in range(9))
_E_OUT = "  smooth vec4 prt_e0;\n  smooth vec4 prt_e1;\n"
_PIXEL_G_VERTEX = [(_G_OUT, _E_OUT),
                   ("#if SM_PRT_BASIS_LAYERS\n", "#if 0\n")]
_PIXEL_G_FRAGMENT = [(_G_OUT, _E_OUT), *[(f"  g[{q}] = prt_g{q};\n", "") for q in range(12)],
                     ("  vec4 g[3 * SM_PRT_BASIS_LAYERS];\n",
                      "  vec4 g[3 * SM_PRT_BASIS_LAYERS];\n  vec4 e_[2];\n"
                      "  e_[0] = prt_e0;\n  e_[1] = prt_e1;\n"
                      "  for (int q = 0; q < 3 * SM_PRT_BASIS_LAYERS; q++) {\n"
                      "    g[q] = vec4(0.0);\n"
                      "    for (int b = 0; b < SM_PRT_VEC4; b++) {\n"
                      "      for (int c = 0; c < 4; c++) {\n"
                      "        g[q] += e_[b][c] * sm_basis.texels[(q * SM_PRT_VEC4 + b) * 4 + c];\n"
                      "      }\n    }\n  }\n")]
_HW_EDIT = ("vec4 weights = sm_albedo_filtered(c0, w, l);", f"vec4 weights = {_HW};")

# BTF: texels outermost, each blended texel's records fetched once for all lights.
_BTF_OLD_START = "  float c[16 * SM_BTF_ALBEDO_RECORDS];\n"
_BTF_TEXEL_OUTER = """#if SM_BTF_KIND == SM_BTF_KIND_RFP
#  define SM_BTF_USED 2
#else
#  define SM_BTF_USED (1 + SM_BTF_LOBES)
#endif
  vec3 ls[SM_LIGHTS];
  float irr[SM_LIGHTS];
  for (int light = 0; light < SM_LIGHTS; light++) {
    vec3 wi_world;
    irr[light] = sm_light_incidence(light, P, wi_world);
    ls[light] = sm_to_local(frame, wi_world);
  }
  vec3 xyz = vec3(0.0);
  for (int t = 0; t < 4; t++) {
    if (blend[t] > 0.0) {
      ivec2 texel = sm_btf_blend_texel(i, n, t);
      vec4 a[SM_BTF_ALBEDO_RECORDS];
      for (int r = 0; r < SM_BTF_ALBEDO_RECORDS; r++) {
        a[r] = sm_btf_record(r, texel);
      }
      vec4 rec[3 * SM_BTF_USED];
      for (int v = 0; v < 3; v++) {
        int base = sm.counts.x + views[v] * sm.counts.y;
        for (int r = 0; r < SM_BTF_USED; r++) {
          rec[v * SM_BTF_USED + r] = sm_btf_record(base + r, texel);
        }
      }
      for (int light = 0; light < SM_LIGHTS; light++) {
        vec3 l = ls[light];
        if (irr[light] > 0.0 && l.z > 0.0) {
          float y = 0.0;
          for (int v = 0; v < 3; v++) {
            vec4 p0 = rec[v * SM_BTF_USED];
#if SM_BTF_KIND == SM_BTF_KIND_RFP
            vec4 p1 = rec[v * SM_BTF_USED + 1];
            float yv = p0.x * l.x * l.x + p0.y * l.y * l.y + p0.z * l.x * l.y + p0.w * l.x
                       + p1.x * l.y + p1.y;
#else
            float yv = p0.x;
            for (int jl = 0; jl < SM_BTF_LOBES; jl++) {
              vec4 lobe = rec[v * SM_BTF_USED + 1 + jl];
              yv += p0[1 + jl] * pow(max(dot(lobe.xyz, l), 0.0), lobe.w);
            }
#endif
            y += w[v] * max(yv, 0.0);
          }
          vec3 albedo_xyz = vec3(0.0);
          for (int j = 0; j < SM_BTF_COEFFS; j++) {
            albedo_xyz += a[j / 4][j % 4] * sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;
          }
          xyz += (blend[t] * irr[light] * y / SM_PI) * albedo_xyz;
        }
      }
    }
  }
"""
# The same with each light's spectral weights K read once, before the texel loop.
_BTF_TEXEL_OUTER_K = _BTF_TEXEL_OUTER.replace(
    "    ls[light] = sm_to_local(frame, wi_world);\n",
    "    ls[light] = sm_to_local(frame, wi_world);\n"
    "    for (int j = 0; j < SM_BTF_COEFFS; j++) {\n"
    "      kk[light * SM_BTF_COEFFS + j] = sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;\n"
    "    }\n").replace(
    "  float irr[SM_LIGHTS];\n", "  float irr[SM_LIGHTS];\n  vec3 kk[SM_LIGHTS * SM_BTF_COEFFS];\n"
    ).replace("sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;\n          }",
              "kk[light * SM_BTF_COEFFS + j];\n          }")
assert _BTF_TEXEL_OUTER_K.count("kk[") == 3
_NEAREST = ("sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);",
            "sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);\n"
            "  blend = vec4(1.0, 0.0, 0.0, 0.0);")

#: variant → (case, {stage: [(old, new), …]}, sampler overrides), on commit b30c25a.
EXPLORED: dict[str, tuple[str, dict, dict]] = {
    # PRT with the albedo basis: where its cost over RGB PRT goes.
    "no_basis_ubo": ("prt_spectral_m8", {"vertex": [(
        "sm_basis.texels[(q * SM_PRT_VEC4 + b) * 4 + c]", "vec4(1.0)")]}, {}),
    "no_fetch": ("prt_spectral_m8", {"fragment": [(
        "vec4 weights = sm_albedo_filtered(c0, w, l);", "vec4 weights = w;")]}, {}),
    "hw32": ("prt_spectral_m8", {"fragment": [(
        "vec4 weights = sm_albedo_filtered(c0, w, l);", f"vec4 weights = {_HW};")]},
        _HW_SAMPLER),
    "hw16": ("prt_spectral_m8", {"fragment": [(
        "vec4 weights = sm_albedo_filtered(c0, w, l);", f"vec4 weights = {_HW};")]},
        _HALF_SAMPLER),
    "two_layers": ("prt_spectral_m8", {"vertex": _TWO_LAYERS, "fragment": _TWO_LAYERS}, {}),
    "two_layers_hw16": ("prt_spectral_m8", {"vertex": _TWO_LAYERS, "fragment": [
        *_TWO_LAYERS, ("vec4 weights = sm_albedo_filtered(c0, w, l);",
                       f"vec4 weights = {_HW};")]}, _HALF_SAMPLER),
    "rgb_no_fetch": ("prt_rgb", {"fragment": [(
        "vec3 albedo = sm_albedo_filtered(c0, w, 0).rgb;", "vec3 albedo = w.rgb;")]}, {}),
    "rgb_hw16": ("prt_rgb", {"fragment": [(
        "vec3 albedo = sm_albedo_filtered(c0, w, 0).rgb;",
        "vec3 albedo = texture(albedo_tex, vec3(tex_uv, 0.0)).rgb;")]}, _HALF_SAMPLER),
    "pixel_g": ("prt_spectral_m8", {"vertex": _PIXEL_G_VERTEX,
                                    "fragment": _PIXEL_G_FRAGMENT}, {}),
    "pixel_g_hw16": ("prt_spectral_m8", {"vertex": _PIXEL_G_VERTEX,
                                         "fragment": [*_PIXEL_G_FRAGMENT, _HW_EDIT]},
                     _HALF_SAMPLER),
    "pixel_g_hw32": ("prt_spectral_m8", {"vertex": _PIXEL_G_VERTEX,
                                         "fragment": [*_PIXEL_G_FRAGMENT, _HW_EDIT]},
                     _HW_SAMPLER),
    # BTF: the texel-edge blend against the nearest texel alone.
    "nearest": ("btf_rfnl_l4", {"fragment": [(
        "sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);",
        "sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);\n"
        "  blend = vec4(1.0, 0.0, 0.0, 0.0);")]}, {}),
    "nearest_l1": ("btf_rfnl_l1", {"fragment": [(
        "sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);",
        "sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);\n"
        "  blend = vec4(1.0, 0.0, 0.0, 0.0);")]}, {}),
}
for _case in ("btf_rfnl_l4", "btf_rfnl_l1", "btf_rfp_l1", "btf_rfp_l4"):
    EXPLORED[f"texel_outer_{_case}"] = (_case, {"fragment": [("@BTF_BODY", _BTF_TEXEL_OUTER)]},
                                        {})
    EXPLORED[f"texel_outer_k_{_case}"] = (_case, {"fragment": [
        ("@BTF_BODY", _BTF_TEXEL_OUTER_K)]}, {})
EXPLORED["texel_outer_nearest"] = ("btf_rfnl_l4", {"fragment": [
    _NEAREST, ("@BTF_BODY", _BTF_TEXEL_OUTER)]}, {})


#: On today's shaders: RFNL's BTF loop with lights outermost again (the RFP branch).
CURRENT: dict[str, tuple[str, dict, dict]] = {
    f"lights_outer_{case}": (case, {"fragment": [(
        "#  if SM_BTF_KIND == SM_BTF_KIND_RFNL\n", "#  if 0\n")]}, {})
    for case in ("btf_rfnl_l1", "btf_rfnl_l4")}
#: On the shaders of commit 5223be0 (the albedo basis the default): the packed R̃ layers
#: filtered by the texture unit (one fetch per layer, 3m/4 of them) instead of by hand
#: (four), as RGBA32F and RGBA16F; the basis's weights as RGBA16F; the chart's basis cut to
#: 8 weights (the colour bound needs 12); RGB PRT filtered alike. Their H200 replays,
#: docs/gpu/h200_prt_paths_*.json, led to the 16-bit layers (core/prt/albedo_forms.py).
PRT_PATHS: dict[str, tuple[str, dict, dict]] = {}
_LAYER_HW = [(f"sm_albedo_filtered(c0, w, 3 * g{k})",
              f"textureLod(albedo_tex, vec3(tex_uv, float(3 * g{k})), 0.0)")
             for k in ("", " + 1", " + 2")]
_REPEAT = {"albedo_tex": {"linear": True, "repeat": True}}
_REPEAT_HALF = {"albedo_tex": {"linear": True, "repeat": True, "format": "RGBA16F"}}
for _case in ("prt_spectral_m8_layers", "prt_image_spectral_m8_layers"):
    PRT_PATHS[f"layers_hw32_{_case}"] = (_case, {"fragment": _LAYER_HW}, _REPEAT)
    PRT_PATHS[f"layers_hw16_{_case}"] = (_case, {"fragment": _LAYER_HW}, _REPEAT_HALF)
PRT_PATHS["basis_hw16"] = ("prt_spectral_m8", {}, {"albedo_tex": {"format": "RGBA16F"}})
PRT_PATHS["basis_two_layers"] = ("prt_spectral_m8", {"fragment": _TWO_LAYERS}, {})
for _case in ("prt_rgb", "prt_image_rgb"):
    PRT_PATHS[f"rgb_hw32_{_case}"] = (_case, {"fragment": [(
        "vec3 albedo = sm_albedo_filtered(c0, w, 0).rgb;",
        "vec3 albedo = textureLod(albedo_tex, vec3(tex_uv, 0.0), 0.0).rgb;")]}, _REPEAT)
#: The measured-cells twin with θd's cell index a quarter cell off its edge. The draw
#: benchmark's sun sits 10° off an orthographic view, which puts θd = 5° (a cell edge) at
#: every pixel: a tie each renderer's rounding breaks its own way. Replayed beside an
#: llvmpipe run of the same patch (docs/bench_gpu_variants.md, "Measured cells").
_THETA_D_INDEX = "floor(hd.z / (0.5 * SM_PI) * float(SM_CELLS_D))"
CELLS_EDGE: dict[str, tuple[str, dict, dict]] = {
    "off_edge": ("xyz_measured_cells_p4_l4_after", {"fragment": [(
        _THETA_D_INDEX, _THETA_D_INDEX.replace("))", ") + 0.25)"))]}, {})}
SETS = {"explored": EXPLORED, "prt_paths": PRT_PATHS, "current": CURRENT,
        "cells_edge": CELLS_EDGE}

#: The albedo precisions (``--set albedo_precision``): the exact cases' packed R̃ layers
#: re-encoded, each filtered by the texture unit: ``half_plain`` RGBA16F; ``half_lo``
#: RGBA16F plus the first layer's rounding error in one more layer; ``unorm16`` RGBA16
#: with a range per layer and component, decoded in the shader. Replayed with
#: ``run_gpu.py --save-images`` to compare each GPU image's colours with the exact
#: layers' (``albedo_precision_report``).
PRECISION_BASES = ("prt_spectral_m8_layers", "prt_image_spectral_m8_layers")
_FETCH = "textureLod(albedo_tex, vec3(tex_uv, float({})), 0.0)"


def _precision_texels(packed: np.ndarray, encoding: str):
    """(texels as uploaded in float32, GLSL decoding each layer's fetch ``v``)."""
    if encoding == "half_plain":
        return packed.astype(np.float16).astype(np.float32), None
    if encoding == "half_lo":
        high = packed.astype(np.float16).astype(np.float32)
        low = (packed[:1].astype(np.float64) - high[:1]).astype(np.float16)
        return np.concatenate([high, low.astype(np.float32)]), None
    low = packed.min(axis=(1, 2))
    span = np.maximum(packed.max(axis=(1, 2)) - low, 1e-30)
    texels = np.rint((packed - low[:, None, None]) / span[:, None, None] * 65535.0) / 65535.0

    def vec4s(rows):
        return ", ".join("vec4(" + ", ".join(f"{float(v):.9e}" for v in r) + ")" for r in rows)
    n = len(packed)
    decode = (f"const vec4 SM_LOW[{n}] = vec4[{n}]({vec4s(low)});\n"
              f"const vec4 SM_SPAN[{n}] = vec4[{n}]({vec4s(span)});\n")
    return texels.astype(np.float32), decode


def add_precision_variants(data: Path) -> list[str]:
    manifest_path = data / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    cases = {c["name"]: c for c in manifest["cases"]}
    added = []
    for base in PRECISION_BASES:
        albedo = cases[base]["samplers"]["albedo_tex"]
        packed = np.load(data / albedo["blob"])
        for encoding in ("half_plain", "half_lo", "unorm16"):
            texels, decode = _precision_texels(packed, encoding)
            name = f"{base}__{encoding}"
            case = copy.deepcopy(cases[base])
            case.update(name=name, variant_of=base, ratio_to=cases[base]["ratio_to"])
            rel = f"blobs/{hashlib.sha1(texels.tobytes()).hexdigest()[:20]}.npy"
            np.save(data / rel, texels)
            case["samplers"]["albedo_tex"].update(
                blob=rel, layers=len(texels), shape=list(texels.shape), linear=True,
                repeat=True, format="RGBA16" if encoding == "unorm16" else "RGBA16F")
            glsl = case["shader"]["blender_glsl"]
            text = (data / glsl["fragment"]).read_text()
            for k in ("", " + 1", " + 2"):
                old = f"sm_albedo_layer(c0, w, padded, 3 * g{k})"
                fetch = _FETCH.format(f"3 * g{k}")
                new = f"(SM_LOW[3 * g{k}] + SM_SPAN[3 * g{k}] * {fetch})" if decode else fetch
                if old not in text:
                    raise SystemExit(f"{name}: fragment source lacks {old!r}")
                text = text.replace(old, new)
            if encoding == "half_lo":
                first = _FETCH.format("3 * g")
                text = text.replace(f"vec4 l0 = {first};", f"vec4 l0 = {first} + "
                                    f"(g == 0 ? {_FETCH.format(len(packed))} : vec4(0.0));")
            if decode:
                text = text.replace("vec4 sm_albedo_texel(", decode + "vec4 sm_albedo_texel(", 1)
            rel = f"glsl/{hashlib.sha1(text.encode()).hexdigest()[:20]}.frag"
            (data / rel).write_text(text)
            glsl["fragment"] = rel
            manifest["cases"] = [c for c in manifest["cases"] if c["name"] != name] + [case]
            added.append(name)
    manifest_path.write_text(json.dumps(manifest, indent=1))
    return added


def _replace_btf_body(text: str, new: str) -> str:
    """The dumped BTF main's albedo and light loops (from the albedo array to the output)."""
    start = text.index(_BTF_OLD_START)
    end = text.index("#  if SM_OUTPUT == SM_OUTPUT_XYZ\n  frag_colour = vec4(xyz", start)
    return text[:start] + new + text[end:]


def add_variants(data: Path, names: list[str] | None = None,
                 variants: dict | None = None) -> list[str]:
    manifest_path = data / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    cases = {c["name"]: c for c in manifest["cases"]}
    added = []
    for variant, (base, patches, samplers) in (variants or CURRENT).items():
        if names and variant not in names:
            continue
        name = f"{base}__{variant}"
        case = copy.deepcopy(cases[base])
        case["name"] = name
        case["variant_of"] = base
        if case.get("role") != "check" and cases[base].get("ratio_to") is None:
            case["ratio_to"] = base
        glsl = case["shader"]["blender_glsl"]
        for stage, edits in patches.items():
            text = (data / glsl[stage]).read_text()
            for old, new in edits:
                if old == "@BTF_BODY":
                    text = _replace_btf_body(text, new)
                    continue
                if old not in text:
                    raise SystemExit(f"{name}: {stage} source lacks {old!r}")
                text = text.replace(old, new)
            suffix = "vert" if stage == "vertex" else "frag"
            rel = f"glsl/{hashlib.sha1(text.encode()).hexdigest()[:20]}.{suffix}"
            (data / rel).write_text(text)
            glsl[stage] = rel
        for sampler, changes in samplers.items():
            case["samplers"][sampler].update(changes)
        manifest["cases"] = [c for c in manifest["cases"] if c["name"] != name] + [case]
        added.append(name)
    manifest_path.write_text(json.dumps(manifest, indent=1))
    return added


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data")
    parser.add_argument("--set", choices=sorted([*SETS, "albedo_precision"]),
                        default="current")
    parser.add_argument("--only", default="", help="comma-separated variant names")
    args = parser.parse_args()
    if args.set == "albedo_precision":
        for name in add_precision_variants(Path(args.data)):
            print("added", name)
        return
    names = [n for n in args.only.split(",") if n]
    for name in add_variants(Path(args.data), names or None, SETS[args.set]):
        print("added", name)


if __name__ == "__main__":
    main()
