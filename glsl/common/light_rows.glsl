/* Mirror: spectral_materials.core.brdf.shading.light_rows */
/* One texel of a light's row (its header, then its spectral weights: lights.glsl,
 * spectral_basis.glsl). Where a variant's SM_LIGHT_STRIDE is > 0 (the factor-pack
 * shaders, when every row fits a uniform buffer: GPUMaterial.light_stride), the rows
 * are read from the uniform buffer `sm_lights`, SM_LIGHT_STRIDE texels each, one after
 * another: a uniform read in place of a texel fetch (issue 19). Otherwise they are the
 * rows of the texture `light_tex` (SM_LIGHT_STRIDE 0). */

#if SM_LIGHT_STRIDE > 0
vec4 sm_light_texel(int x, int light)
{
  return sm_lights.texels[light * SM_LIGHT_STRIDE + x];
}
#else
vec4 sm_light_texel(int x, int light)
{
  return texelFetch(light_tex, ivec2(x, light), 0);
}
#endif
