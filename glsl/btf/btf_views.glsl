/* Mirror: spectral_materials.core.btf.container.HemisphereTriangulation.weights */
/* The three measured views around a local view direction and their barycentric
 * weights. Mirrors spectral_materials/core/btf/container.py HemisphereTriangulation.weights:
 * the azimuthal-equidistant image of v picks a cell of a grid × grid table (cell_tex:
 * first entry and count of its candidate triangles in candidate_tex, entry i at
 * (i % SM_BTF_LIST_WIDTH, i / SM_BTF_LIST_WIDTH)); per triangle, triangle_tex
 * holds the rows of M⁻¹ (M = the three view directions as columns) in xyz and the view
 * indices in w, three texels a row. The first candidate with all weights ≥ −1e-6
 * wins; else the best one, clamped and renormalised (views beyond the last ring). */

#define SM_BTF_EPS 1e-6

vec2 sm_hemisphere_plane(vec3 d)
{
  float rho = length(d.xy);
  float theta = atan(rho, d.z);
  return rho > 1e-15 ? d.xy * (theta / (0.5 * SM_PI) / rho) : vec2(0.0);
}

void sm_btf_views(vec3 v, out ivec3 views, out vec3 weights)
{
  v.z = max(v.z, 0.0);
  v = sm_safe_normalize(v, vec3(0.0, 0.0, 1.0));
  int grid = sm.counts.z;
  ivec2 cell = clamp(ivec2(floor((sm_hemisphere_plane(v) + 1.0) * 0.5 * float(grid))),
                     ivec2(0), ivec2(grid - 1));
  vec4 list = texelFetch(cell_tex, cell, 0);
  int first = int(list.x + 0.5);
  int count = int(list.y + 0.5);
  float best_score = -1e30;
  vec3 best_w = vec3(1.0, 0.0, 0.0);
  ivec3 best_views = ivec3(0);
  for (int k = 0; k < count; k++) {
    int entry = first + k;
    int t = int(texelFetch(candidate_tex, ivec2(entry % SM_BTF_LIST_WIDTH,
                                                entry / SM_BTF_LIST_WIDTH), 0).x + 0.5);
    vec4 r0 = texelFetch(triangle_tex, ivec2(0, t), 0);
    vec4 r1 = texelFetch(triangle_tex, ivec2(1, t), 0);
    vec4 r2 = texelFetch(triangle_tex, ivec2(2, t), 0);
    vec3 w = vec3(dot(r0.xyz, v), dot(r1.xyz, v), dot(r2.xyz, v));
    float s = w.x + w.y + w.z;
    float score = -1e30;
    if (s > 0.0) {
      w /= s;
      score = min(w.x, min(w.y, w.z));
    }
    if (score > best_score) {
      best_score = score;
      best_w = w;
      best_views = ivec3(int(r0.w + 0.5), int(r1.w + 0.5), int(r2.w + 0.5));
    }
    if (score >= -SM_BTF_EPS) {
      break;
    }
  }
  vec3 w = max(best_w, vec3(0.0));
  weights = w / max(w.x + w.y + w.z, 1e-30);
  views = best_views;
}
