/* Mirror: spectral_materials.core.brdf.axes.axis_lookup */
/* Linear-interpolation indices and weight on an axis's cell centres.
 * Mirrors axes.axis_lookup: value ≈ mix(table[i0], table[i1], w). Periodic axes
 * wrap between the last and first cells; other axes clamp the value into [lo, hi]
 * and extrapolate linearly beyond the end centres (edge_clamp holds them instead).
 * flags: bit 0 periodic, bit 1 square-root warp. */

void sm_axis_lookup(float v, float lo, float span, int flags, int cells, bool edge_clamp,
                    out int i0, out int i1, out float w)
{
  if (cells <= 1) {
    i0 = 0;
    i1 = 0;
    w = 0.0;
    return;
  }
  bool periodic = (flags & 1) != 0;
  float t;
  if (periodic) {
    float r = mod(v - lo, span);
    t = (r >= span ? 0.0 : r) / span;
  }
  else {
    t = (clamp(v, lo, lo + span) - lo) / span;
  }
  t = clamp(t, 0.0, 1.0);
  if ((flags & 2) != 0) {
    t = sqrt(t);
  }
  float x = t * float(cells) - 0.5;
  float f = floor(x);
  if (periodic) {
    w = x - f;
    /* f ∈ [−1, cells − 1]; no % on negative ints, whose result GLSL leaves undefined
     * (llvmpipe computes it unsigned). */
    i0 = int(f) < 0 ? int(f) + cells : int(f);
    i1 = i0 + 1 < cells ? i0 + 1 : 0;
  }
  else {
    i0 = clamp(int(f), 0, cells - 2);
    i1 = i0 + 1;
    w = x - float(i0);
    if (edge_clamp) {
      w = clamp(w, 0.0, 1.0);
    }
  }
}
