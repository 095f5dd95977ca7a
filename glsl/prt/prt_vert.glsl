/* Mirror: spectral_materials.core.prt.transfer.irradiance */
/* Spectral PRT, vertex stage (the spectral PRT paper's inner sum): the spectral
 * irradiance coefficients Ê_j = Σ_k T̃_k L̃_kj of this vertex. T̃ (K SH values per
 * vertex, padded to texels of 4) comes from transfer_tex, texel v·SM_PRT_TEXELS + i laid
 * out row by row sm.sizes.x wide; L̃, per-draw constant, from the uniform buffer sm_env
 * (SM_PRT_ENV_BUFFER) or else environment_tex: one row per SH coefficient and
 * SM_PRT_VEC4 texels of spectral coefficients per row (turned into the object's
 * frame and divided by the world frame's white Y on the CPU). Mirrors
 * spectral_materials/core/prt/transfer.py irradiance(). */

void main()
{
  int v = int(vertex_index + 0.5);
  vec4 e[SM_PRT_VEC4];
  for (int b = 0; b < SM_PRT_VEC4; b++) {
    e[b] = vec4(0.0);
  }
  for (int i = 0; i < SM_PRT_TEXELS; i++) {
    int t = v * SM_PRT_TEXELS + i;
    vec4 transfer = texelFetch(transfer_tex, ivec2(t % sm.sizes.x, t / sm.sizes.x), 0);
    for (int c = 0; c < 4; c++) {
      for (int b = 0; b < SM_PRT_VEC4; b++) {
#if SM_PRT_ENV_BUFFER
        e[b] += transfer[c] * sm_env.texels[(4 * i + c) * SM_PRT_VEC4 + b];
#else
        e[b] += transfer[c] * texelFetch(environment_tex, ivec2(b, 4 * i + c), 0);
#endif
      }
    }
  }
  prt_e0 = e[0];
#if SM_PRT_VEC4 > 1
  prt_e1 = e[1];
#endif
#if SM_PRT_VEC4 > 2
  prt_e2 = e[2];
#endif
#if SM_PRT_VEC4 > 3
  prt_e3 = e[3];
#endif
  vec4 world = model_matrix * vec4(position, 1.0);
  world_position = world.xyz;
  tex_uv = uv;
  gl_Position = sm.view_projection * world;
}
