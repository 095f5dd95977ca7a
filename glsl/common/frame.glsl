/* Mirror: spectral_materials.core.brdf.shading.shading_frame, spectral_materials.core.brdf.shading.generated_tangent, spectral_materials.core.brdf.shading.TANGENT_EPS_SQ */
/* The per-pixel shading frame (t, b, n). Mirrors core/brdf/shading.py shading_frame.
 * The tangent is made orthogonal to n (Gram–Schmidt). Where it is missing, zero or
 * parallel to n, the generated field t = normalize(ŷ × n) is used, and x̂ where
 * that is undefined (n = ±ŷ): the sphere protocol's tangent field. */

/* |t − (t·n)n|² at or below this: the tangent carries no direction. */
#define SM_TANGENT_EPS_SQ 1e-8

vec3 sm_generated_tangent(vec3 n)
{
  vec3 g = vec3(n.z, 0.0, -n.x);
  return dot(g, g) > 1e-24 ? normalize(g) : vec3(1.0, 0.0, 0.0);
}

mat3 sm_frame(vec3 normal, vec3 tangent)
{
  vec3 n = sm_safe_normalize(normal, vec3(0.0, 0.0, 1.0));
  vec3 t = tangent - n * dot(n, tangent);
  t = dot(t, t) > SM_TANGENT_EPS_SQ ? normalize(t) : sm_generated_tangent(n);
  return mat3(t, cross(n, t), n);
}

/* World direction → local (t, b, n) coordinates. */
vec3 sm_to_local(mat3 frame, vec3 v)
{
  return vec3(dot(frame[0], v), dot(frame[1], v), dot(frame[2], v));
}
