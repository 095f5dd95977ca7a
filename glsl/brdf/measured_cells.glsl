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

/* f·cosθi of the pair (wi, wo) in cells; both above the horizon. One call site of the
 * packs for the cell and its fill: candidate 0 is the cell's centre (most pixels stop
 * there), 1–6 its face neighbours' centres, taken when the cell's centre is below the
 * horizon, and 7 the pair itself where none of them was above it. A call site per
 * candidate made every pixel pay for the few that need the fill (on llvmpipe). */
vec3 sm_cells_xyz(vec3 wi, vec3 wo, int light)
{
  vec4 hd = sm_half_difference(wi, wo); /* θh, φh, θd, φd ∈ [0, 2π) */
  int ih = clamp(int(floor(sqrt(max(hd.x, 0.0) / (0.5 * SM_PI)) * float(SM_CELLS_H))), 0,
                 SM_CELLS_H - 1);
  int id = clamp(int(floor(hd.z / (0.5 * SM_PI) * float(SM_CELLS_D))), 0, SM_CELLS_D - 1);
  float upper = hd.w > SM_PI ? 1.0 : 0.0;
  int ip = clamp(int(floor((hd.w - upper * SM_PI) / SM_PI * float(SM_CELLS_P))), 0,
                 SM_CELLS_P - 1);
  vec3 total = vec3(0.0);
  float count = 0.0;
  for (int k = 0; k < 8; k++) {
    vec3 a = wi, b = wo;
    bool take = count == 0.0; /* candidate 7: the pair itself */
    if (k < 7) {
      int axis = (k - 1) / 2;
      int offset = k == 0 ? 0 : ((k % 2 == 1) ? -1 : 1);
      int jh = ih + (axis == 0 ? offset : 0);
      int jd = id + (axis == 1 ? offset : 0);
      int jp = ip + (axis == 2 ? offset : 0);
      vec3 c = sm_cell_centre(jh, jd, jp);
      sm_hd_inverse(c.x, hd.y, c.y, c.z + upper * SM_PI, a, b);
      take = jh >= 0 && jh < SM_CELLS_H && jd >= 0 && jd < SM_CELLS_D && a.z > 0.0 &&
             b.z > 0.0;
    }
    if (take) {
      total += sm_stored_xyz(a, b, light) / max(a.z, SM_MIN_CENTRE_COSINE);
      count += 1.0;
    }
    if (k == 0 && count > 0.0) {
      break;
    }
  }
  return total / count * wi.z;
}
#endif
