/* Mirror: spectral_materials.core.brdf.factored.FactoredBRDF.coefficients */
/* XYZ reflected toward wo per unit irradiance from wi (f·cosθi) for one light: the packs
 * (times cosθi where the table is not cosine-weighted) plus the analytic lobe. */

vec3 sm_stored_xyz(vec3 wi, vec3 wo, int light)
{
  vec3 reflected = sm_reflected_xyz(sm_lookups(sm_coordinates(wi, wo)), light);
#if !SM_COSINE_WEIGHTED
  reflected *= wi.z;
#endif
#if SM_LOBE_TEXEL > 0
  reflected += sm_lobe_xyz(wi, wo, light);
#endif
  return reflected;
}
