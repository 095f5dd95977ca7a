/* Mirror: spectral_materials.core.brdf.params.Parameterization.forward */
/* BRDF parameterisations: local (wi, wo) → grid coordinates.
 * Mirrors Parameterization.forward in spectral_materials/core/brdf/params.py.
 * SM_PARAM selects one, SM_PARAM_<NAME> names each (generated from the list of them,
 * core/brdf/params.py PARAMETERIZATIONS, by blender/gpu/shaders.py).
 * Unused coordinates are 0. */

float sm_wrap_2pi(float a)
{
  float r = mod(a, SM_TWO_PI);
  return r >= SM_TWO_PI ? 0.0 : r;
}

/* Below this ρ = |v.xy| the azimuth is float32 rounding noise (θ < 1e-5 rad): take
 * φ = 0, as directions.spherical does below 1e-12. Where wi = wo exactly (a light behind
 * the camera) d = (0, 0, 1) in float64 but carries ~1e-6 noise here (llvmpipe),
 * and φd would otherwise be arbitrary. */
#define SM_POLE_RHO 1e-5

/* (θ, φ): θ = atan(ρ, z) is accurate at the poles. */
vec2 sm_spherical(vec3 v)
{
  float rho = length(v.xy);
  float theta = atan(rho, v.z);
  float phi = rho > SM_POLE_RHO ? sm_wrap_2pi(atan(v.y, v.x)) : 0.0;
  return vec2(theta, phi);
}

/* norm(wi + wo), n where wi ≈ −wo. */
vec3 sm_half_vector(vec3 wi, vec3 wo)
{
  return sm_safe_normalize(wi + wo, vec3(0.0, 0.0, 1.0));
}

/* Rusinkiewicz (θh, φh, θd, φd): d = Ry(−θh) Rz(−φh) wi. */
vec4 sm_half_difference(vec3 wi, vec3 wo)
{
  vec3 h = sm_half_vector(wi, wo);
  vec2 th = sm_spherical(h);
  float ct = cos(th.x), st = sin(th.x);
  float cp = cos(th.y), sp = sin(th.y);
  float x1 = cp * wi.x + sp * wi.y;
  float y1 = -sp * wi.x + cp * wi.y;
  vec3 d = vec3(ct * x1 - st * wi.z, y1, st * x1 + ct * wi.z);
  vec2 td = sm_spherical(d);
  return vec4(th, td);
}

/* Kautz–McCool Gram–Schmidt frame t' = norm(t − (t·h)h), s' = h × t', written as
 * t' = (ρ, −hx·hy/ρ, −hx·hz/ρ), ρ = √(hy² + hz²), to avoid cancellation. */
vec4 sm_gram_schmidt(vec3 wi, vec3 wo)
{
  vec3 h = sm_half_vector(wi, wo);
  float rho = length(h.yz);
  float cb = rho > 0.0 ? h.y / rho : 0.0;
  float sb = rho > 0.0 ? h.z / rho : 1.0;
  vec3 tp = sm_safe_normalize(vec3(rho, -h.x * cb, -h.x * sb), vec3(0.0, 0.0, -h.x));
  vec3 sp = cross(h, tp);
  return vec4(h.x, h.y, dot(wi, tp), dot(wi, sp));
}

vec4 sm_coordinates(vec3 wi, vec3 wo)
{
#if SM_PARAM == SM_PARAM_IO || SM_PARAM == SM_PARAM_IO_ISO || SM_PARAM == SM_PARAM_EA
  vec2 si = sm_spherical(wi);
  vec2 so = sm_spherical(wo);
#  if SM_PARAM == SM_PARAM_IO
  return vec4(si.x, si.y, so.x, so.y);
#  elif SM_PARAM == SM_PARAM_IO_ISO
  return vec4(si.x, sm_wrap_2pi(so.y - si.y), so.x, 0.0);
#  else /* ea */
  return vec4(si.x, so.x, si.y, so.y);
#  endif
#elif SM_PARAM == SM_PARAM_HD
  return sm_half_difference(wi, wo);
#elif SM_PARAM == SM_PARAM_HD_ISO
  vec4 hd = sm_half_difference(wi, wo);
  return vec4(hd.x, hd.z, hd.w, 0.0);
#elif SM_PARAM == SM_PARAM_GS
  return sm_gram_schmidt(wi, wo);
#else
#  error "SM_PARAM names no parameterisation this file draws"
#endif
}
