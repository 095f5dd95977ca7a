/* Mirror: spectral_materials.core.lights.LIGHT_CODES, spectral_materials.core.lights.MIN_DISTANCE_SQ, spectral_materials.core.brdf.shading.LIGHT_HEADER */
/* Constants and safe vector helpers shared by every stage.
 * Mirrors spectral_materials/core/brdf/shading.py. */

#define SM_PI 3.14159265358979
#define SM_TWO_PI 6.28318530717959

/* Light types as stored in the light texture (core/lights.py LIGHT_CODES). */
#define SM_SUN 0
#define SM_POINT 1
#define SM_SPOT 2
#define SM_AREA 3

/* Texels before a light's spectral weights in its light-texture row (lights.glsl). */
#define SM_LIGHT_HEADER 3

/* Squared distance below which a point light sits on the shaded point: its direction
 * is undefined, so it contributes nothing (core/lights.py MIN_DISTANCE_SQ). */
#define SM_MIN_DISTANCE_SQ 1e-10

vec3 sm_safe_normalize(vec3 v, vec3 fallback)
{
  float len2 = dot(v, v);
  /* 1e-30 keeps inversesqrt finite in float32 (denormals start at 1.2e-38). */
  return len2 > 1e-30 ? v * inversesqrt(len2) : fallback;
}
