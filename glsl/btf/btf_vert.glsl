/* Mirror: none (geometry only: world position, normal, tangent and UV) */
/* BTF meshes: world position, normal, tangent and UV for the fragment stage. */

void main()
{
  vec4 world = model_matrix * vec4(position, 1.0);
  world_position = world.xyz;
  world_normal = mat3(normal_matrix) * normal;
  world_tangent = mat3(model_matrix) * tangent.xyz;
  tex_uv = uv;
  gl_Position = sm.view_projection * world;
}
