/* Mirror: none (the RGB baseline of the draw benchmark) */
/* Baseline of the draw benchmark (benchmarks/draw.py): the mesh stage of an RGB
 * Blinn–Phong shader, the same work as mesh_vert.glsl (world position and normal, clip
 * position). The parameter block `bp` (BpParams) is declared by
 * benchmarks/draw_baseline.py, next to its packing. */

void main()
{
  vec4 world = model_matrix * vec4(position, 1.0);
  world_position = world.xyz;
  world_normal = mat3(normal_matrix) * normal;
  gl_Position = bp.view_projection * world;
}
