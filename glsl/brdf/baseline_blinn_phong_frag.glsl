/* Mirror: none (the RGB baseline of the draw benchmark) */
/* Baseline of the draw benchmark (benchmarks/draw.py): an RGB Blinn–Phong surface lit
 * by BP_LIGHTS lights, drawn on the same mesh as the spectral shader so that frame times
 * can be stated as ratios (shared/PROTOCOL.md, "Time and memory").
 *
 * Per light: a sun (light_position.w = 0, xyz = unit direction toward the light,
 * irradiance 1) or a point light (w = 1, xyz = position, irradiance 1 / (4π r²));
 * light_colour.rgb is its linear-sRGB colour times its strength. Energy-normalised
 * Blinn–Phong: kd / π + ks (n + 8) / (8π) (n·h)^n, times n·l. Two-sided like
 * surface_frag.glsl; output clipped to [0, 1] and gamma-encoded (1/2.2). */

#define BP_PI 3.14159265358979

void main()
{
  vec3 N = normalize(world_normal);
  vec3 V = bp.view_origin.w > 0.5 ? normalize(bp.view_origin.xyz - world_position) :
                                 bp.view_origin.xyz;
  if (dot(N, V) < 0.0) {
    N = -N;
  }
  float shininess = bp.specular.w;
  float normalisation = (shininess + 8.0) / (8.0 * BP_PI);
  vec3 rgb = vec3(0.0);
  for (int i = 0; i < BP_LIGHTS; i++) {
    vec4 light = bp.light_position[i];
    vec3 L;
    float irradiance;
    if (light.w < 0.5) {
      L = light.xyz;
      irradiance = 1.0;
    }
    else {
      vec3 d = light.xyz - world_position;
      float r2 = max(dot(d, d), 1e-10);
      L = d * inversesqrt(r2);
      irradiance = 1.0 / (4.0 * BP_PI * r2);
    }
    float ndl = max(dot(N, L), 0.0);
    vec3 H = normalize(L + V);
    float spec = pow(max(dot(N, H), 0.0), shininess);
    rgb += irradiance * ndl * bp.light_colour[i].rgb *
           (bp.diffuse.rgb / BP_PI + bp.specular.rgb * normalisation * spec);
  }
  rgb = clamp(rgb * bp.diffuse.w, 0.0, 1.0);
  frag_colour = vec4(pow(rgb, vec3(1.0 / 2.2)), 1.0);
}
