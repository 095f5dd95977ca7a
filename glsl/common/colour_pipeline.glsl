/* Mirror: spectral_materials.core.colour.pipeline.xyz_to_display */
/* Display pipeline of the factor-pack paper (§3.1): XYZ → Bradford adaptation from
 * the scene white to D65 → linear sRGB → sigmoid tone map → sRGB encoding.
 * Mirrors spectral_materials/core/colour/pipeline.py. The two matrices come from
 * colour-science through the parameter block (SmParams): adaptation (Bradford, scene
 * white → D65) and xyz_to_rgb (XYZ → linear sRGB); display.x is the exposure and
 * display.y the tone map's white. */

vec3 sm_adapt(vec3 xyz)
{
  return mat3(sm.adaptation) * xyz;
}

vec3 sm_xyz_to_linear_srgb(vec3 xyz)
{
  return mat3(sm.xyz_to_rgb) * xyz;
}

/* Extended Reinhard x (1 + x / w²) / (1 + x), negative input 0, capped at 1;
 * white ≤ 0 means no tone map (clip to [0, 1], the panel's "Clip"). The ratio is
 * written x / (1 + x) · (1 + x / w²) so that huge x stays finite. */
vec3 sm_tonemap(vec3 rgb, float white)
{
  vec3 x = max(rgb, vec3(0.0));
  if (white <= 0.0) {
    return min(x, vec3(1.0));
  }
  return min(x / (1.0 + x) * (1.0 + x / (white * white)), vec3(1.0));
}

/* IEC 61966-2-1 encoding of values clipped to [0, 1]. */
vec3 sm_srgb_encode(vec3 rgb)
{
  vec3 c = clamp(rgb, 0.0, 1.0);
  vec3 low = 12.92 * c;
  vec3 high = 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055;
  return mix(low, high, step(vec3(0.0031308), c));
}

vec3 sm_xyz_to_display(vec3 xyz)
{
  vec3 rgb = sm_xyz_to_linear_srgb(sm_adapt(xyz * sm.display.x));
  return sm_srgb_encode(sm_tonemap(rgb, sm.display.y));
}
