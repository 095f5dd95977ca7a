/* Mirror: spectral_materials.blender.prt.drawer.params_block */
/* The PRT parameter block (uniform buffer `sm`), std140. Filled by
 * spectral_materials/blender/prt/drawer.py params_block(), which must match. The
 * adaptation, xyz_to_rgb and display fields have the names colour_pipeline.glsl reads. */

struct SmPrtParams {
  mat4 view_projection;  /* world → clip */
  mat4 adaptation;       /* Bradford, the environment's white → D65 (upper 3 × 3) */
  mat4 xyz_to_rgb;       /* XYZ → linear sRGB (upper 3 × 3) */
  mat4 rgb_to_xyz;       /* linear sRGB → XYZ (RGB PRT, upper 3 × 3) */
  vec4 display;          /* x: exposure, y: tone-map white */
  ivec4 sizes;           /* x: transfer texture width, y/z: albedo texture width/height */
};
