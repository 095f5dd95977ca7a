/* Mirror: spectral_materials.core.brdf.shading.shade_xyz */
/* Spectral surface shading: every light through the factor packs, to linear XYZ
 * (SM_OUTPUT_XYZ) or to display sRGB (SM_OUTPUT_DISPLAY). SM_OUTPUT_POSITION, _NORMAL
 * and _TANGENT write the world position, the geometric normal facing the viewer and
 * the raw tangent instead, so that tests can evaluate the Python mirror on the same
 * geometry; SM_OUTPUT_PARAMETERIZATION writes the parameterisation's coordinates for
 * light 0 (blender/gpu/outputs.py). */

void main()
{
  vec3 P, N, T;
#ifdef SM_GEOMETRY_SPHERE
  /* Pixel centre → [−1, 1]²; row 0 is the bottom (+y up). */
  vec2 xy = gl_FragCoord.xy / sm.display.zw * 2.0 - 1.0;
  float r2 = dot(xy, xy);
  if (r2 >= 1.0) {
    discard;
  }
  N = vec3(xy, sqrt(1.0 - r2));
  P = N;
  T = vec3(0.0); /* the generated field ŷ × n: the protocol's tangent */
  vec3 V = vec3(0.0, 0.0, 1.0);
#else
  P = world_position;
  N = sm_safe_normalize(world_normal, vec3(0.0, 0.0, 1.0));
  T = world_tangent;
  vec3 V = sm.view_origin.w > 0.5 ? sm_safe_normalize(sm.view_origin.xyz - P, N) :
                                 sm.view_origin.xyz;
  /* Two-sided: a face seen from behind is shaded with its normal flipped. */
  if (dot(N, V) < 0.0) {
    N = -N;
  }
#endif
#if SM_OUTPUT == SM_OUTPUT_POSITION
  frag_colour = vec4(P, 1.0);
  return;
#elif SM_OUTPUT == SM_OUTPUT_NORMAL
  frag_colour = vec4(N, 1.0);
  return;
#elif SM_OUTPUT == SM_OUTPUT_TANGENT
  frag_colour = vec4(T, 1.0);
  return;
#else
  mat3 frame = sm_frame(N, T);
  vec3 wo = sm_to_local(frame, V);
#  if SM_OUTPUT == SM_OUTPUT_PARAMETERIZATION
  vec3 wi0;
  sm_light_incidence(0, P, wi0);
  frag_colour = sm_coordinates(sm_to_local(frame, wi0), wo);
  return;
#  endif
  vec3 xyz = vec3(0.0);
#  if SM_PRECONTRACT && SM_SHARE_VIEW && SM_VIEW_AXES != 0 && SM_LIGHTS > 1 && !SM_CELLS
  /* Packs outermost, so that the axes depending on the view alone (SM_VIEW_AXES: θo,
   * and φo where the parameterisation has it) are fetched and interpolated once per
   * pack for all lights, and only each light's own axes per light (issue 19). The sum
   * is the light-by-light one below, reordered. SM_SHARE_VIEW: where there are enough
   * packs for that to pay on a GPU (shaders.shares_view_axes). */
  SmLookup lookups[SM_LIGHTS];
  float weight[SM_LIGHTS];
  vec3 light_xyz[SM_LIGHTS]; /* each light's sum, clamped at 0 as the other branch's */
  for (int light = 0; light < SM_LIGHTS; light++) {
    light_xyz[light] = vec3(0.0);
    vec3 wi_world;
    float irradiance = sm_light_incidence(light, P, wi_world);
    vec3 wi = sm_to_local(frame, wi_world);
    weight[light] = 0.0;
    /* Unread while the weight is 0; set field by field (no struct constructor, which
     * not every shader translation accepts). */
    lookups[light].i0 = ivec4(0);
    lookups[light].i1 = ivec4(0);
    lookups[light].w = vec4(0.0);
    lookups[light].scale = 1.0;
    if (irradiance > 0.0 && wi.z > 0.0 && wo.z > 0.0) {
      lookups[light] = sm_lookups(sm_coordinates(wi, wo));
      weight[light] = irradiance * lookups[light].scale;
#    if !SM_COSINE_WEIGHTED
      weight[light] *= wi.z;
#    endif
#    if SM_LOBE_TEXEL > 0
      light_xyz[light] = irradiance * sm_lobe_xyz(wi, wo, light);
#    endif
    }
  }
  /* Any incident direction gives the view's axes the same coordinates. */
  SmLookup view = sm_lookups(sm_coordinates(vec3(0.0, 0.0, 1.0), wo));
  int own_axes = ((1 << SM_AXES) - 1) & ~SM_VIEW_AXES;
  for (int p = 0; p < SM_PACKS; p++) {
    vec4 view_product = sm_pack_product_axes(view, p, SM_VIEW_AXES);
    for (int light = 0; light < SM_LIGHTS; light++) {
      if (weight[light] != 0.0) {
        vec4 product = view_product * sm_pack_product_axes(lookups[light], p, own_axes);
        int x = SM_LIGHT_HEADER + 3 * p;
        light_xyz[light] += weight[light] * vec3(dot(sm_light_texel(x, light), product),
                                                 dot(sm_light_texel(x + 1, light), product),
                                                 dot(sm_light_texel(x + 2, light), product));
      }
    }
  }
  for (int light = 0; light < SM_LIGHTS; light++) {
    xyz += max(light_xyz[light], vec3(0.0));
  }
#  else
  for (int light = 0; light < SM_LIGHTS; light++) {
    vec3 wi_world;
    float irradiance = sm_light_incidence(light, P, wi_world);
    vec3 wi = sm_to_local(frame, wi_world);
    if (irradiance > 0.0 && wi.z > 0.0 && wo.z > 0.0) {
      /* Each light's XYZ clamped at 0 (FactoredBRDF.xyz): the packs' signed rest can
       * dip below 0 beside a black reference near the horizon. */
#    if SM_CELLS
      xyz += irradiance * max(sm_cells_xyz(wi, wo, light), vec3(0.0));
#    else
      xyz += irradiance * max(sm_stored_xyz(wi, wo, light), vec3(0.0));
#    endif
    }
  }
#  endif
#  if SM_OUTPUT == SM_OUTPUT_XYZ
  frag_colour = vec4(xyz, 1.0);
#  else
  frag_colour = vec4(sm_xyz_to_display(xyz), 1.0);
#  endif
#endif
}
