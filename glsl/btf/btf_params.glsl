/* Mirror: spectral_materials.blender.btf.drawer.BTFMaterial.params_block */
/* The BTF parameter block (uniform buffer `sm`), std140. Filled by
 * spectral_materials/blender/btf/drawer.py BTFMaterial.params_block(), which must match. The
 * adaptation, xyz_to_rgb and display fields have the names colour_pipeline.glsl reads. */

struct SmBtfParams {
  mat4 view_projection;  /* world → clip */
  mat4 adaptation;       /* Bradford, scene white → D65 (upper 3 × 3) */
  mat4 xyz_to_rgb;       /* XYZ → linear sRGB (upper 3 × 3) */
  vec4 display;          /* x: exposure, y: tone-map white */
  vec4 view_origin;      /* eye position (w = 1) or direction toward the viewer (w = 0) */
  vec4 uv_scale;         /* xy: texture repeats across the UV square */
  ivec4 tiles;           /* x, y: BTF texels W, H; z: tiles per layer; w: tile columns */
  ivec4 counts;          /* x: albedo records, y: records per view, z: view-cell grid */
};
