/* Mirror: spectral_materials.core.prt.albedo.sample_layers, spectral_materials.core.prt.albedo.layers_to_rgba, spectral_materials.core.prt.albedo_basis.AlbedoBasis, spectral_materials.core.prt.albedo_forms.unorm16_texels, spectral_materials.core.prt.transfer.vertex_xyz */
/* Spectral PRT, fragment stage: XYZ = Σ_j Ê_j R̃_j(uv), R̃_j the albedo × CMF layers
 * (RGB channels = X, Y, Z) filtered bilinearly by hand (texel centres, repeat wrap, as
 * spectral_materials/core/prt/albedo.py sample_layers) so that the Python mirror matches.
 * The 3m values of a texel are packed four to a layer (albedo.layers_to_rgba): value
 * q = 3j + c (coefficient j, channel c) is component q % 4 of layer q / 4, so a pixel
 * filters SM_PRT_LAYERS = ⌈3m/4⌉ layers (4 fetches each) instead of m.
 * SM_PRT_UNORM_LAYERS: the same layers as 16-bit unorm texels over each layer component's
 * range, filtered by the texture unit (one fetch each) and decoded as low + span · t with
 * the uniform buffer sm_range (core/prt/albedo_forms.py unorm16_texels).
 * SM_PRT_BASIS_LAYERS > 0: the albedo as r weights per texel in a texture basis
 * (core/prt/albedo_basis.py), four to a layer, filtered by the texture unit:
 * XYZ_c = Σ_k w_k(uv) G_kc, so a pixel reads ⌈r/4⌉ texels.
 * SM_PRT_RGB: classical RGB PRT, (Ê_rgb ⊙ albedo_rgb) → XYZ. SM_OUTPUT is one of
 * SM_OUTPUT_XYZ, _DISPLAY (sRGB), _POSITION (world), _UV and _PRIMITIVE (the triangle's
 * index) (blender/gpu/outputs.py). */

vec4 sm_albedo_texel(ivec2 texel, int layer)
{
  /* REPEAT: GLSL's % is undefined for negative operands, mod() is not. */
  ivec2 wrapped = ivec2(mod(vec2(texel), vec2(sm.sizes.yz)));
  return texelFetch(albedo_tex, ivec3(wrapped, layer), 0);
}

/* One layer filtered bilinearly by hand: weights w of the texels c0, c0 + x, c0 + y, c0 + xy. */
vec4 sm_albedo_filtered(ivec2 c0, vec4 w, int layer)
{
  return w.x * sm_albedo_texel(c0, layer) + w.y * sm_albedo_texel(c0 + ivec2(1, 0), layer) +
         w.z * sm_albedo_texel(c0 + ivec2(0, 1), layer) +
         w.w * sm_albedo_texel(c0 + ivec2(1, 1), layer);
}

/* Layer `layer` of the packed R̃ at this pixel: by the texture unit from the wrap-padded
 * unorm16 layers (at `padded`), decoded, else filtered by hand. */
vec4 sm_albedo_layer(ivec2 c0, vec4 w, vec2 padded, int layer)
{
#if SM_PRT_UNORM_LAYERS
  return sm_range.texels[2 * layer] +
         sm_range.texels[2 * layer + 1] * textureLod(albedo_tex, vec3(padded, float(layer)), 0.0);
#else
  return sm_albedo_filtered(c0, w, layer);
#endif
}

void main()
{
#if SM_OUTPUT == SM_OUTPUT_POSITION
  frag_colour = vec4(world_position, 1.0);
  return;
#elif SM_OUTPUT == SM_OUTPUT_UV
  frag_colour = vec4(tex_uv, 0.0, 1.0);
  return;
#elif SM_OUTPUT == SM_OUTPUT_PRIMITIVE
  frag_colour = vec4(float(gl_PrimitiveID), 0.0, 0.0, 1.0);
  return;
#else
  vec2 st = tex_uv * vec2(sm.sizes.yz) - 0.5;
  vec2 cell = floor(st);
  vec2 f = st - cell;
  ivec2 c0 = ivec2(cell);
  vec4 w = vec4((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
  vec3 xyz = vec3(0.0);
  vec4 e[4];
  e[0] = prt_e0;
#  if SM_PRT_VEC4 > 1
  e[1] = prt_e1;
#  endif
#  if SM_PRT_VEC4 > 2
  e[2] = prt_e2;
#  endif
#  if SM_PRT_VEC4 > 3
  e[3] = prt_e3;
#  endif
  /* Filtered textures have one texel of wrap padding on every side
   * (core/prt/albedo.py wrap_padded), so filtering near 0 and 1 blends across the wrap as
   * REPEAT would, with no sampler setting that Blender 4.5 and 5.0 lack. */
  vec2 padded = (fract(tex_uv) * vec2(sm.sizes.yz) + 1.0) / vec2(sm.sizes.yz + 2);
#  if SM_PRT_BASIS_LAYERS
  /* G_kc = Σ_j Ê_j M_kjc is formed here from the interpolated Ê rather than interpolated
   * itself: on an NVIDIA H200 three vec4 varyings per layer of weights cost more than
   * these 3·r·m multiply-adds (docs/bench_gpu.md). The texture unit filters the
   * weights. */
  for (int l = 0; l < SM_PRT_BASIS_LAYERS; l++) {
    vec4 weights = textureLod(albedo_tex, vec3(padded, float(l)), 0.0);
    for (int c = 0; c < 3; c++) {
      vec4 g = vec4(0.0);
      for (int b = 0; b < SM_PRT_VEC4; b++) {
        for (int k = 0; k < 4; k++) {
          g += e[b][k] * sm_basis.texels[((3 * l + c) * SM_PRT_VEC4 + b) * 4 + k];
        }
      }
      xyz[c] += dot(weights, g);
    }
  }
#  elif SM_PRT_RGB
  vec3 albedo = sm_albedo_filtered(c0, w, 0).rgb;
  xyz = mat3(sm.rgb_to_xyz) * (e[0].rgb * albedo);
#  else
  /* Coefficients 4g … 4g+3 fill layers 3g, 3g+1, 3g+2 exactly: (X0 Y0 Z0 X1) (Y1 Z1 X2 Y2)
   * (Z2 X3 Y3 Z3), so each channel is one dot4 with e[g] of fixed swizzles (no indexing
   * by a computed component, which llvmpipe runs 1.5× slower). Layers past the last
   * (m not a multiple of 4) read as 0. */
  for (int g = 0; g < SM_PRT_VEC4; g++) {
    vec4 l0 = sm_albedo_layer(c0, w, padded, 3 * g);
    vec4 l1 = 3 * g + 1 < SM_PRT_LAYERS ? sm_albedo_layer(c0, w, padded, 3 * g + 1) :
                                          vec4(0.0);
    vec4 l2 = 3 * g + 2 < SM_PRT_LAYERS ? sm_albedo_layer(c0, w, padded, 3 * g + 2) :
                                          vec4(0.0);
    xyz += vec3(dot(e[g], vec4(l0.x, l0.w, l1.z, l2.y)), dot(e[g], vec4(l0.y, l1.x, l1.w, l2.z)),
                dot(e[g], vec4(l0.z, l1.y, l2.x, l2.w)));
  }
#  endif
  /* Ringing of a band-limited sharp light: no physical spectrum has a negative XYZ. */
  xyz = max(xyz, vec3(0.0));
#  if SM_OUTPUT == SM_OUTPUT_XYZ
  frag_colour = vec4(xyz, 1.0);
#  else
  frag_colour = vec4(sm_xyz_to_display(xyz), 1.0);
#  endif
#endif
}
