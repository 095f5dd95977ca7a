/* Mirror: spectral_materials.core.brdf.lobe.lobe_terms, spectral_materials.core.brdf.shading.light_texels */
/* The analytic specular lobe beside the factor packs (core/brdf/lobe.py): Ashikhmin–
 * Shirley's specular term with two free Schlick spectra. sm.lobe holds the exponents
 * (nu, nv); each light's row holds, from texel SM_LOBE_TEXEL, the XYZ weights of the
 * lobe's two spectra under that light (c₀ᵀĨ, c₁ᵀĨ). Called for lit pairs only. */

#if SM_LOBE_TEXEL > 0
vec2 sm_lobe_terms(vec3 wi, vec3 wo)
{
  vec3 v = wi + wo;
  float len = length(v);
  vec3 h = v / len;
  float h_dot_k = min(0.5 * len, 1.0);
  float s2 = h.x * h.x + h.y * h.y;
  float ratio = s2 > 0.0 ? h.y * h.y / s2 : 0.0;
  float e = sm.lobe.x + (sm.lobe.y - sm.lobe.x) * ratio;
  float peak = exp(e * log(clamp(h.z, 1.175494e-38, 1.0)));
  float norm = sqrt((sm.lobe.x + 1.0) * (sm.lobe.y + 1.0)) / (8.0 * SM_PI);
  float a = norm * peak / max(h_dot_k * max(wi.z, wo.z), SM_LOBE_DENOMINATOR_FLOOR);
  float c = 1.0 - h_dot_k;
  float s = c * c * c * c * c;
  return vec2(a * (1.0 - s), a * s);
}

/* XYZ reflected toward wo per unit irradiance from wi (f_lobe · cosθi). */
vec3 sm_lobe_xyz(vec3 wi, vec3 wo, int light)
{
  vec2 g = sm_lobe_terms(wi, wo) * wi.z;
  return g.x * sm_light_texel(SM_LOBE_TEXEL, light).xyz +
         g.y * sm_light_texel(SM_LOBE_TEXEL + 1, light).xyz;
}
#endif
