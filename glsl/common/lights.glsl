/* Mirror: spectral_materials.core.lights.SpectralLight.incidence, spectral_materials.core.brdf.shading.light_rows */
/* Light incidence: the direction toward the light and the irradiance it brings at P,
 * for a surface facing it. Mirrors core/lights.py (SpectralLight.incidence).
 *
 * Light texture, one row per light: texel 0 = (position, type), texel 1 = (emission
 * axis, strength), texel 2 = (cos of the spot's half angle, spot blend width, 0, 0),
 * then the light's spectral weights (spectral_basis.glsl).
 *   sun:   E = strength (W/m²), toward −axis
 *   point: E = strength / (4π r²)
 *   spot:  point × smoothstep((cos α − cos half) / blend width), α off the axis
 *   area:  E = strength · max(cos at the emitter, 0) / (π r²), a small Lambertian
 *          emitter (far-field approximation, see core/lights.py). *
 * The rows are read through sm_light_texel (light_rows.glsl). */

float sm_light_incidence(int light, vec3 P, out vec3 wi)
{
  vec4 position_type = sm_light_texel(0, light);
  vec4 axis_strength = sm_light_texel(1, light);
  int kind = int(position_type.w + 0.5);
#if SM_LIGHT_TYPES & 1
  if (kind == SM_SUN) {
    wi = -axis_strength.xyz;
    return axis_strength.w;
  }
#endif
  vec3 d = position_type.xyz - P;
  float r2 = dot(d, d);
  if (r2 < SM_MIN_DISTANCE_SQ) {
    wi = vec3(0.0);
    return 0.0;
  }
  wi = d * inversesqrt(r2);
  float irradiance = 0.0;
#if SM_LIGHT_TYPES & 6
  if (kind == SM_POINT || kind == SM_SPOT) {
    irradiance = axis_strength.w / (4.0 * SM_PI * r2);
  }
#endif
#if SM_LIGHT_TYPES & 4
  if (kind == SM_SPOT) {
    vec4 spot = sm_light_texel(2, light);
    float c = dot(-wi, axis_strength.xyz);
    float t = spot.y > 0.0 ? clamp((c - spot.x) / spot.y, 0.0, 1.0) : (c >= spot.x ? 1.0 : 0.0);
    irradiance *= t * t * (3.0 - 2.0 * t);
  }
#endif
#if SM_LIGHT_TYPES & 8
  if (kind == SM_AREA) {
    irradiance = axis_strength.w * max(dot(-wi, axis_strength.xyz), 0.0) / (SM_PI * r2);
  }
#endif
  return irradiance;
}
