/* Mirror: spectral_materials.core.brdf.factored.FactoredBRDF.xyz, spectral_materials.core.brdf.shading.light_texels */
/* The spectral side: reflected XYZ from the pack products and one light's
 * light × CMF coefficients. Mirrors FactoredBRDF.xyz and core/brdf/shading.py.
 *
 * SM_PRECONTRACT 0 (the factor-pack paper, eq. 9): the reflectance coefficients
 *   R̃_j = Σ_packs S_pack[j] · product are accumulated, then XYZ = Σ_j R̃_j Ĩ_j,
 *   with Ĩ_j (texels SM_LIGHT_HEADER + j of the light's row) the light's SPD × CMF
 *   projected on the basis: SM_COEFFS texel fetches and dot products per pack.
 * SM_PRECONTRACT 1: the CPU folds the spectral factor into the light side once per
 *   light, K_pack = S_packᵀ Ĩ (texels SM_LIGHT_HEADER + 3·pack + {0,1,2} hold the X,
 *   Y, Z weights of the pack's 4 terms): 3 fetches and 3 dot products per pack. */

vec3 sm_reflected_xyz(SmLookup lookup, int light)
{
#if SM_PRECONTRACT
  vec3 xyz = vec3(0.0);
  for (int p = 0; p < SM_PACKS; p++) {
    vec4 product = sm_pack_product(lookup, p);
    int x = SM_LIGHT_HEADER + 3 * p;
    xyz += vec3(dot(sm_light_texel(x, light), product),
                dot(sm_light_texel(x + 1, light), product),
                dot(sm_light_texel(x + 2, light), product));
  }
  return xyz * lookup.scale;
#else
  float coefficients[SM_COEFFS];
  for (int j = 0; j < SM_COEFFS; j++) {
    coefficients[j] = 0.0;
  }
  int spectral_row = SM_AXES * sm.misc.y;
  for (int p = 0; p < SM_PACKS; p++) {
    vec4 product = sm_pack_product(lookup, p);
    for (int j = 0; j < SM_COEFFS; j++) {
      coefficients[j] += dot(texelFetch(factor_tex, ivec2(j, spectral_row + p), 0), product);
    }
  }
  vec3 xyz = vec3(0.0);
  for (int j = 0; j < SM_COEFFS; j++) {
    xyz += coefficients[j] * sm_light_texel(SM_LIGHT_HEADER + j, light).xyz;
  }
  return xyz * lookup.scale;
#endif
}
