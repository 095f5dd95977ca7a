/* Mirror: spectral_materials.core.brdf.measured_cells.in_cells, spectral_materials.core.brdf.measured_cells.cell_indices, spectral_materials.core.brdf.measured_cells.centre_angles */
/* A model drawn in a measured table's cells, as the table's readers look it up
 * (core/brdf/measured_cells.py): the BRDF at the centre of the pair's (θh, θd, φd) cell,
 * weighted by the pair's own cosθi; a cell whose centre is below the horizon takes the
 * mean over its face neighbours' centres above it, or the pair's own value where none is.
 * SM_CELLS_H, _D, _P are the cell counts (MERL: 90, 90, 180). sm_stored_xyz is the
 * surface's f·cosθi at a pair (surface_frag.glsl). */

#if SM_CELLS
/* (θh, θd, φd) of a cell's centre; φd continues past the seam for k outside [0, n). */
vec3 sm_cell_centre(int ih, int id, int ip)
{
  float u = (float(ih) + 0.5) / float(SM_CELLS_H);
  return vec3(u * u * 0.5 * SM_PI, (float(id) + 0.5) / float(SM_CELLS_D) * 0.5 * SM_PI,
              (float(ip) + 0.5) / float(SM_CELLS_P) * SM_PI);
}

/* Rusinkiewicz's inverse (params._hd_inverse): wi = Rz(φh) Ry(θh) d, wo its mirror about h. */
void sm_hd_inverse(float th, float ph, float td, float pd, out vec3 wi, out vec3 wo)
{
  vec3 d = vec3(sin(td) * cos(pd), sin(td) * sin(pd), cos(td));
  float ct = cos(th), st = sin(th), cp = cos(ph), sp = sin(ph);
  float x1 = ct * d.x + st * d.z;
  float z1 = -st * d.x + ct * d.z;
  wi = vec3(cp * x1 - sp * d.y, sp * x1 + cp * d.y, z1);
  vec3 h = vec3(st * cp, st * sp, ct);
  wo = 2.0 * dot(wi, h) * h - wi;
}

/* The BRDF (XYZ per unit irradiance, without the cosine) at a cell's centre; false where
 * the centre is below the horizon. */
bool sm_cell_brdf(int ih, int id, int ip, float ph, float upper, int light, out vec3 f)
{
  vec3 c = sm_cell_centre(ih, id, ip);
  vec3 wi, wo;
  sm_hd_inverse(c.x, ph, c.y, c.z + upper * SM_PI, wi, wo);
  f = vec3(0.0);
  if (wi.z <= 0.0 || wo.z <= 0.0) {
    return false;
  }
  f = sm_stored_xyz(wi, wo, light) / max(wi.z, SM_MIN_CENTRE_COSINE);
  return true;
}

/* f·cosθi of the pair (wi, wo) in cells; both above the horizon. */
vec3 sm_cells_xyz(vec3 wi, vec3 wo, int light)
{
  vec4 hd = sm_half_difference(wi, wo); /* θh, φh, θd, φd ∈ [0, 2π) */
  int ih = clamp(int(floor(sqrt(max(hd.x, 0.0) / (0.5 * SM_PI)) * float(SM_CELLS_H))), 0,
                 SM_CELLS_H - 1);
  int id = clamp(int(floor(hd.z / (0.5 * SM_PI) * float(SM_CELLS_D))), 0, SM_CELLS_D - 1);
  float upper = hd.w > SM_PI ? 1.0 : 0.0;
  float pd = hd.w - upper * SM_PI;
  int ip = clamp(int(floor(pd / SM_PI * float(SM_CELLS_P))), 0, SM_CELLS_P - 1);
  vec3 f;
  if (!sm_cell_brdf(ih, id, ip, hd.y, upper, light, f)) {
    vec3 total = vec3(0.0);
    float count = 0.0;
    for (int k = 0; k < 6; k++) {
      int axis = k / 2;
      int step = (k % 2 == 0) ? -1 : 1;
      int jh = ih + (axis == 0 ? step : 0);
      int jd = id + (axis == 1 ? step : 0);
      int jp = ip + (axis == 2 ? step : 0);
      vec3 g;
      if (jh >= 0 && jh < SM_CELLS_H && jd >= 0 && jd < SM_CELLS_D &&
          sm_cell_brdf(jh, jd, jp, hd.y, upper, light, g))
      {
        total += g;
        count += 1.0;
      }
    }
    f = count > 0.0 ? total / count : sm_stored_xyz(wi, wo, light) / max(wi.z, SM_MIN_CENTRE_COSINE);
  }
  return f * wi.z;
}
#endif
