/* Mirror: spectral_materials.blender.brdf.gpu_material.params_block */
/* The parameter block (uniform buffer `sm`), std140. Filled by
 * spectral_materials/blender/brdf/gpu_material.py params_block(), which must match. */

struct SmParams {
  vec4 axis_lo;          /* per angular axis: lower end */
  vec4 axis_span;        /* per angular axis: hi − lo (the period of an azimuth) */
  ivec4 axis_flags;      /* bit 0 periodic, bit 1 square-root warp, bit 2 the edge rule holds the horizon */
  ivec4 axis_cells;      /* cells per axis (1 for unused axes) */
  ivec4 misc;            /* x: edge rule (SM_EDGE_*), y: texel rows per axis */
  vec4 display;          /* x: exposure, y: tone-map white, zw: target size (sphere) */
  vec4 view_origin;      /* eye position (w = 1) or direction toward the viewer (w = 0) */
  vec4 lobe;             /* analytic specular lobe: x nu, y nv (specular_lobe.glsl) */
  mat4 adaptation;       /* Bradford, scene white → D65 (upper 3 × 3) */
  mat4 xyz_to_rgb;       /* XYZ → linear sRGB (upper 3 × 3) */
  mat4 view_projection;  /* world → clip (meshes) */
};
