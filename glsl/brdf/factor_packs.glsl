/* Mirror: spectral_materials.core.brdf.factored.FactoredBRDF.coefficients */
/* Factor-pack reconstruction: per pack of 4 rank-one terms, the product over the
 * angular axes of each factor interpolated at the pixel's coordinates.
 * Mirrors FactoredBRDF.coefficients (spectral_materials/core/brdf/factored.py).
 *
 * factor_tex is the material's factor image (blender/brdf/storage.py): texel (x, k·G + g)
 * holds terms 4g … 4g+3 of axis k at sample x, with G = sm.misc.y texel rows per axis.
 * Texels are read with texelFetch and interpolated here, exactly as the Python
 * lookup does (a hardware filter would round its weights to 8 bits). */

struct SmLookup {
  ivec4 i0;
  ivec4 i1;
  vec4 w;
  float scale; /* the horizon edge rule's fall to 0 at θi = 90° (1 elsewhere) */
};

SmLookup sm_lookups(vec4 coords)
{
  SmLookup lookup;
  lookup.i0 = ivec4(0);
  lookup.i1 = ivec4(0);
  lookup.w = vec4(0.0);
  lookup.scale = 1.0;
  for (int k = 0; k < SM_AXES; k++) {
    int i0, i1;
    float w, scale;
    sm_axis_lookup(coords[k], sm.axis_lo[k], sm.axis_span[k], sm.axis_flags[k], sm.axis_cells[k],
                   sm.misc.x, i0, i1, w, scale);
    lookup.i0[k] = i0;
    lookup.i1[k] = i1;
    lookup.w[k] = w;
    lookup.scale *= scale;
  }
  return lookup;
}

/* The 4 terms of pack `pack` over the axes in the bit mask `axes`:
 * Π_{k in axes} mix(A_k[i0], A_k[i1], w_k). With several lights, the view's axes
 * (SM_VIEW_AXES) once per pack and each light's own axes per light (surface_frag.glsl). */
vec4 sm_pack_product_axes(SmLookup lookup, int pack, int axes)
{
  vec4 product = vec4(1.0);
  for (int k = 0; k < SM_AXES; k++) {
    if ((axes & (1 << k)) != 0) {
      int row = k * sm.misc.y + pack;
      vec4 a = texelFetch(factor_tex, ivec2(lookup.i0[k], row), 0);
      vec4 b = texelFetch(factor_tex, ivec2(lookup.i1[k], row), 0);
      product *= mix(a, b, lookup.w[k]);
    }
  }
  return product;
}

/* The 4 terms of pack `pack` over every axis. */
vec4 sm_pack_product(SmLookup lookup, int pack)
{
  return sm_pack_product_axes(lookup, pack, (1 << SM_AXES) - 1);
}
