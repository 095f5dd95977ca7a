/* Mirror: spectral_materials.core.brdf.factored.FactoredBRDF.coefficients, spectral_materials.core.brdf.filtered_factors.FilteredFactorsBRDF._angular_terms */
/* Factor-pack reconstruction: per pack of 4 rank-one terms, the product over the
 * angular axes of each factor interpolated at the pixel's coordinates.
 *
 * factor_tex holds per axis k and texel row g (G = sm.misc.y rows per axis) terms
 * 4g … 4g+3 at each sample; SM_FACTORS says how (codes generated from
 * filtered_factors.FACTOR_PRECISIONS):
 * - SM_FACTORS_EXACT: the material's float32 factor image (blender/brdf/storage.py),
 *   read with texelFetch and interpolated here with the edge rule, as
 *   FactoredBRDF.coefficients does (a hardware filter would round its weights to 8 bits).
 * - otherwise 16-bit rows with one pad texel at each end that carries the edge rule
 *   (filtered_factors.py), so the lookup is at p = x + 1 with no end cases;
 *   SM_FACTORS_FILTERED lets the texture unit interpolate (one fetch),
 *   SM_FACTORS_UNORM decodes unorm16's (a + 1)/2 after interpolating (linear, so exact). */

struct SmLookup {
  ivec4 i0;
  ivec4 i1;
  vec4 w;
  float scale; /* the horizon edge rules' fall to 0 at θi (and θo) = 90° (1 elsewhere) */
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
#if SM_FACTORS == SM_FACTORS_EXACT
    sm_axis_lookup(coords[k], sm.axis_lo[k], sm.axis_span[k], sm.axis_flags[k], sm.axis_cells[k],
                   sm.misc.x, i0, i1, w, scale);
#else
    float x = sm_axis_x(coords[k], sm.axis_lo[k], sm.axis_span[k], sm.axis_flags[k],
                        sm.axis_cells[k]);
    scale = sm_horizon_scale(x, sm.axis_flags[k], sm.axis_cells[k], sm.misc.x);
    float p = x + 1.0;
#  if SM_FACTORS_FILTERED
    /* w holds the texture coordinate: texel centres at (p + 0.5) / width. */
    i0 = 0;
    i1 = 0;
    w = (p + 0.5) / float(textureSize(factor_tex, 0).x);
#  else
    i0 = clamp(int(floor(p)), 0, sm.axis_cells[k]);
    i1 = i0 + 1;
    w = p - float(i0);
#  endif
#endif
    lookup.i0[k] = i0;
    lookup.i1[k] = i1;
    lookup.w[k] = w;
    lookup.scale *= scale;
  }
  return lookup;
}

/* The 4 terms of pack `pack` over the axes in the bit mask `axes`:
 * Π_{k in axes} mix(A_k[i0], A_k[i1], w_k). Where the lights share the view's axes
 * (SM_SHARE_VIEW), those (SM_VIEW_AXES) once per pack and each light's own axes per
 * light (surface_frag.glsl). */
vec4 sm_pack_product_axes(SmLookup lookup, int pack, int axes)
{
  vec4 product = vec4(1.0);
  for (int k = 0; k < SM_AXES; k++) {
    if ((axes & (1 << k)) != 0) {
      int row = k * sm.misc.y + pack;
#if SM_FACTORS_FILTERED
      /* Level 0 explicitly: no implicit derivatives, whatever mip or anisotropy state. */
      vec4 value = textureLod(
          factor_tex, vec2(lookup.w[k], (float(row) + 0.5) / float(textureSize(factor_tex, 0).y)),
          0.0);
#else
      vec4 a = texelFetch(factor_tex, ivec2(lookup.i0[k], row), 0);
      vec4 b = texelFetch(factor_tex, ivec2(lookup.i1[k], row), 0);
      vec4 value = mix(a, b, lookup.w[k]);
#endif
#if SM_FACTORS_UNORM
      value = value * 2.0 - 1.0;
#endif
      product *= value;
    }
  }
  return product;
}

/* The 4 terms of pack `pack` over every axis. */
vec4 sm_pack_product(SmLookup lookup, int pack)
{
  return sm_pack_product_axes(lookup, pack, (1 << SM_AXES) - 1);
}
