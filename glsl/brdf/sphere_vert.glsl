/* Mirror: spectral_materials.core.brdf.shading.sphere_pixels */
/* The sphere protocol (shared/PROTOCOL.md): a quad over the whole target; the
 * fragment stage intersects the unit sphere seen orthographically down −z. */

void main()
{
  gl_Position = vec4(corner, 0.0, 1.0);
}
