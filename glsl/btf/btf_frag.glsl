/* Mirror: spectral_materials.core.btf.render.DrawableBTF.shade_xyz, spectral_materials.core.btf.render.DrawableBTF.texel_blend */
/* Reflectance-field BTF (Meseth, Müller, Klein 2003, §5.1): per light, the fitted
 * luminance RF_v'(x, l) of the three measured views around the local view direction,
 * blended with barycentric weights, times the texel's spectral albedo under that
 * light. Mirrors spectral_materials/core/btf/render.py DrawableBTF.shade_xyz.
 * SM_BTF_KIND_RFP: biquadratic in l.x, l.y; SM_BTF_KIND_RFNL: ρd + Σ a_j max(t̂_j·l, 0)^n_j,
 * with unit t̂ so that nothing overflows. Parameters are fetched unfiltered (nearest texel,
 * repeat), and a texel's shading blends with its neighbour's near texel edges
 * (sm_btf_texel_blend). SM_OUTPUT is one of SM_OUTPUT_XYZ, _DISPLAY (sRGB), _POSITION (world),
 * _NORMAL (facing the viewer), _TANGENT (raw) and _UV (blender/gpu/outputs.py). */

vec4 sm_btf_record(int record, ivec2 texel)
{
  int layer = record / sm.tiles.z;
  int tile = record - layer * sm.tiles.z;
  ivec2 offset = ivec2(tile % sm.tiles.w, tile / sm.tiles.w) * sm.tiles.xy;
  return texelFetch(record_tex, ivec3(texel + offset, layer), 0);
}

float sm_btf_luminance(int view, ivec2 texel, vec3 l)
{
  int base = sm.counts.x + view * sm.counts.y;
  vec4 p0 = sm_btf_record(base, texel);
#if SM_BTF_KIND == SM_BTF_KIND_RFP
  vec4 p1 = sm_btf_record(base + 1, texel);
  float y = p0.x * l.x * l.x + p0.y * l.y * l.y + p0.z * l.x * l.y + p0.w * l.x
            + p1.x * l.y + p1.y;
#else
  float y = p0.x;
  for (int j = 0; j < SM_BTF_LOBES; j++) {
    vec4 lobe = sm_btf_record(base + 1 + j, texel);
    y += p0[1 + j] * pow(max(dot(lobe.xyz, l), 0.0), lobe.w);
  }
#endif
  return max(y, 0.0);
}

/* The texels a point's shading blends and their weights: per axis the texel alone, or
 * within SM_BTF_EDGE (texels) of an edge, it and its neighbour across the edge (repeat
 * wrap), ½ each at the edge. Continuous in the UV, so that GPUs whose interpolated UVs
 * differ by rounding draw the same picture (issue 19). i: the texel, n: its neighbours
 * across the near edges; blend weighs (i.x, i.y), (n.x, i.y), (i.x, n.y), (n.x, n.y).
 * Mirrors DrawableBTF.texel_blend. */
void sm_btf_texel_blend(vec2 st, out ivec2 i, out ivec2 n, out vec4 blend)
{
  vec2 f = st - floor(st);
  vec2 s = f * vec2(sm.tiles.xy);
  i = clamp(ivec2(floor(s)), ivec2(0), sm.tiles.xy - 1);
  vec2 g = s - vec2(i);
  ivec2 side = ivec2(0);
  vec2 own = vec2(1.0);
  for (int k = 0; k < 2; k++) {
    if (g[k] < SM_BTF_EDGE) {
      own[k] = 0.5 + 0.5 * g[k] / SM_BTF_EDGE;
      side[k] = -1;
    }
    else if (g[k] > 1.0 - SM_BTF_EDGE) {
      own[k] = 0.5 + 0.5 * (1.0 - g[k]) / SM_BTF_EDGE;
      side[k] = 1;
    }
  }
  /* i + side ∈ [−1, size]: wrapped without % on negative ints (undefined in GLSL). */
  n = i + side;
  n = ivec2(n.x < 0 ? sm.tiles.x - 1 : (n.x >= sm.tiles.x ? 0 : n.x),
            n.y < 0 ? sm.tiles.y - 1 : (n.y >= sm.tiles.y ? 0 : n.y));
  blend = vec4(own.x * own.y, (1.0 - own.x) * own.y, own.x * (1.0 - own.y),
               (1.0 - own.x) * (1.0 - own.y));
}

/* Texel t of the blend: (i or n).x by bit 0 of t, (i or n).y by bit 1. */
ivec2 sm_btf_blend_texel(ivec2 i, ivec2 n, int t)
{
  return ivec2((t & 1) == 0 ? i.x : n.x, (t & 2) == 0 ? i.y : n.y);
}

void main()
{
  vec3 P = world_position;
  vec3 N = sm_safe_normalize(world_normal, vec3(0.0, 0.0, 1.0));
  vec3 V = sm.view_origin.w > 0.5 ? sm_safe_normalize(sm.view_origin.xyz - P, N) :
                                 sm.view_origin.xyz;
  /* Two-sided: a face seen from behind is shaded with its normal flipped. */
  if (dot(N, V) < 0.0) {
    N = -N;
  }
#if SM_OUTPUT == SM_OUTPUT_POSITION
  frag_colour = vec4(P, 1.0);
#elif SM_OUTPUT == SM_OUTPUT_NORMAL
  frag_colour = vec4(N, 1.0);
#elif SM_OUTPUT == SM_OUTPUT_TANGENT
  frag_colour = vec4(world_tangent, 1.0);
#elif SM_OUTPUT == SM_OUTPUT_UV
  frag_colour = vec4(tex_uv, 0.0, 1.0);
#else
  mat3 frame = sm_frame(N, world_tangent);
  vec3 v = sm_to_local(frame, V);
  ivec3 views;
  vec3 w;
  sm_btf_views(v, views, w);
  ivec2 i, n;
  vec4 blend;
  sm_btf_texel_blend(tex_uv * sm.uv_scale.xy, i, n, blend);
  vec3 xyz = vec3(0.0);
#  if SM_BTF_KIND == SM_BTF_KIND_RFNL
  /* RFNL: texels outermost. A blended texel's records (albedo, and per view ρd and the
   * lobes) are fetched once for all lights, each light's incidence once for all texels.
   * With 4 lights on an NVIDIA H200 this draws in 0.40× the time of the lights-outermost
   * loop below, which fetches every record once per light (docs/bench_gpu.md). */
  vec3 light_local[SM_LIGHTS];
  float light_irradiance[SM_LIGHTS];
  for (int light = 0; light < SM_LIGHTS; light++) {
    vec3 wi_world;
    light_irradiance[light] = sm_light_incidence(light, P, wi_world);
    light_local[light] = sm_to_local(frame, wi_world);
  }
  for (int t = 0; t < 4; t++) {
    if (blend[t] > 0.0) {
      ivec2 texel = sm_btf_blend_texel(i, n, t);
      vec4 albedo[SM_BTF_ALBEDO_RECORDS];
      for (int r = 0; r < SM_BTF_ALBEDO_RECORDS; r++) {
        albedo[r] = sm_btf_record(r, texel);
      }
      vec4 records[3 * (1 + SM_BTF_LOBES)];
      for (int v = 0; v < 3; v++) {
        int base = sm.counts.x + views[v] * sm.counts.y;
        for (int r = 0; r <= SM_BTF_LOBES; r++) {
          records[v * (1 + SM_BTF_LOBES) + r] = sm_btf_record(base + r, texel);
        }
      }
      for (int light = 0; light < SM_LIGHTS; light++) {
        vec3 l = light_local[light];
        if (light_irradiance[light] > 0.0 && l.z > 0.0) {
          float y = 0.0;
          for (int v = 0; v < 3; v++) {
            vec4 p0 = records[v * (1 + SM_BTF_LOBES)];
            float yv = p0.x;
            for (int j = 0; j < SM_BTF_LOBES; j++) {
              vec4 lobe = records[v * (1 + SM_BTF_LOBES) + 1 + j];
              yv += p0[1 + j] * pow(max(dot(lobe.xyz, l), 0.0), lobe.w);
            }
            y += w[v] * max(yv, 0.0);
          }
          vec3 albedo_xyz = vec3(0.0);
          for (int j = 0; j < SM_BTF_COEFFS; j++) {
            albedo_xyz += albedo[j / 4][j % 4] * sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;
          }
          xyz += (blend[t] * light_irradiance[light] * y / SM_PI) * albedo_xyz;
        }
      }
    }
  }
#  else
  /* RFP: lights outermost (its two records per view are cheap to fetch again per light;
   * texels outermost drew 1.19× slower with 4 lights on the H200). */
  /* Albedo coefficients of the blended texels, 4 · SM_BTF_ALBEDO_RECORDS each. */
  float c[16 * SM_BTF_ALBEDO_RECORDS];
  for (int t = 0; t < 4; t++) {
    if (blend[t] > 0.0) {
      for (int r = 0; r < SM_BTF_ALBEDO_RECORDS; r++) {
        vec4 a = sm_btf_record(r, sm_btf_blend_texel(i, n, t));
        int base = 4 * (t * SM_BTF_ALBEDO_RECORDS + r);
        c[base] = a.x;
        c[base + 1] = a.y;
        c[base + 2] = a.z;
        c[base + 3] = a.w;
      }
    }
  }
  /* Lights outermost: a light's incidence and spectral weights once, then each blended
   * texel's luminance and albedo. */
  for (int light = 0; light < SM_LIGHTS; light++) {
    vec3 wi_world;
    float irradiance = sm_light_incidence(light, P, wi_world);
    vec3 l = sm_to_local(frame, wi_world);
    if (irradiance > 0.0 && l.z > 0.0) {
      vec3 k[SM_BTF_COEFFS];
      for (int j = 0; j < SM_BTF_COEFFS; j++) {
        k[j] = sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;
      }
      for (int t = 0; t < 4; t++) {
        if (blend[t] > 0.0) {
          ivec2 texel = sm_btf_blend_texel(i, n, t);
          float y = w.x * sm_btf_luminance(views.x, texel, l) +
                    w.y * sm_btf_luminance(views.y, texel, l) +
                    w.z * sm_btf_luminance(views.z, texel, l);
          vec3 albedo_xyz = vec3(0.0);
          for (int j = 0; j < SM_BTF_COEFFS; j++) {
            albedo_xyz += c[4 * t * SM_BTF_ALBEDO_RECORDS + j] * k[j];
          }
          xyz += (blend[t] * irradiance * y / SM_PI) * albedo_xyz;
        }
      }
    }
  }
#  endif
#  if SM_OUTPUT == SM_OUTPUT_XYZ
  frag_colour = vec4(xyz, 1.0);
#  else
  frag_colour = vec4(sm_xyz_to_display(xyz), 1.0);
#  endif
#endif
}
