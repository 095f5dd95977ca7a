/* Mirror: spectral_materials.core.brdf.axes.axis_lookup, spectral_materials.core.brdf.axes.horizon_scale, spectral_materials.core.brdf.axes.holds_horizon */
/* Linear-interpolation indices and weight on an axis's cell centres.
 * Mirrors axes.axis_lookup: value ≈ mix(table[i0], table[i1], w). Periodic axes
 * wrap between the last and first cells; other axes clamp the value into [lo, hi]
 * and, by edge rule, extrapolate linearly beyond the end centres (SM_EDGE_LINEAR),
 * hold them (SM_EDGE_CLAMP), or hold the last centre of a horizon axis and let
 * the returned scale take the lookup to 0 at hi (SM_EDGE_HORIZON on θi, SM_EDGE_HORIZONS
 * on θi and θo: axes.horizon_scale).
 * flags: bit 0 periodic, bit 1 square-root warp, bit 2 the model's edge rule holds this
 * axis's horizon (axes.holds_horizon, decided on the CPU by gpu_material.py, so that the
 * pixel tests one bit per axis). SM_EDGE_<RULE> are defined per variant from
 * axes.EDGE_RULES (gpu/shaders.py). */

/* The axis value as x = u·cells − 0.5, u the warped unit coordinate. */
float sm_axis_x(float v, float lo, float span, int flags, int cells)
{
  float t;
  if ((flags & 1) != 0) {
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
  return t * float(cells) - 0.5;
}

/* axes.holds_horizon: whether the edge rule takes this axis to 0 at hi (flag bit 2). */
bool sm_holds_horizon(int flags)
{
  return (flags & 4) != 0;
}

/* axes.horizon_scale's value at x (1 unless the rule holds this axis's horizon). */
float sm_horizon_scale(float x, int flags, int cells, int edge)
{
  if (sm_holds_horizon(flags)) {
    return clamp(2.0 * (float(cells) - 0.5 - x), 0.0, 1.0);
  }
  return 1.0;
}

/* scale: sm_horizon_scale's value, from the same x. */
void sm_axis_lookup(float v, float lo, float span, int flags, int cells, int edge,
                    out int i0, out int i1, out float w, out float scale)
{
  float x = sm_axis_x(v, lo, span, flags, cells);
  scale = sm_horizon_scale(x, flags, cells, edge);
  if (cells <= 1) {
    i0 = 0;
    i1 = 0;
    w = 0.0;
    return;
  }
  float f = floor(x);
  if ((flags & 1) != 0) {
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
    if (edge == SM_EDGE_CLAMP) {
      w = clamp(w, 0.0, 1.0);
    }
    else if (sm_holds_horizon(flags)) {
      w = min(w, 1.0);
    }
  }
}
