/* Mirror: spectral_materials.core.brdf.lobe.family_terms, spectral_materials.core.brdf.shading.light_texels */
/* The analytic lobe beside the factor packs (core/brdf/lobe.py), of the family
 * SM_LOBE_FAMILY (lobe.LOBE_FAMILIES' index + 1): 1, Ashikhmin–Shirley's specular term
 * with two free Schlick spectra, sm.lobe holding the exponents (nu, nv); 2, Oren–Nayar's
 * back-scatter term with one free spectrum (no exponents). Each light's row holds, from
 * texel SM_LOBE_TEXEL, the XYZ weights of the lobe's two spectra under that light
 * (c₀ᵀĨ, c₁ᵀĨ). Called for lit pairs only. */

#if SM_LOBE_TEXEL > 0
#  if SM_LOBE_FAMILY == 2
vec2 sm_lobe_terms(vec3 wi, vec3 wo)
{
  float projected = max(wi.x * wo.x + wi.y * wo.y, 0.0);
  return vec2(projected / max(max(wi.z, wo.z), SM_LOBE_DENOMINATOR_FLOOR), 0.0);
}
#  else
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
#  endif

/* XYZ reflected toward wo per unit irradiance from wi (f_lobe · cosθi). */
vec3 sm_lobe_xyz(vec3 wi, vec3 wo, int light)
{
  vec2 g = sm_lobe_terms(wi, wo) * wi.z;
  return g.x * sm_light_texel(SM_LOBE_TEXEL, light).xyz +
         g.y * sm_light_texel(SM_LOBE_TEXEL + 1, light).xyz;
}
#endif
