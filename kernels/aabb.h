/* aabb.h: ray/box slab test (port of AABB.cuh).
 *
 * Reads: nothing. Writes: nothing. The ray's inverse direction is computed once per traversal;
 * a zero direction component gives an infinite inverse, and the comparisons below are written
 * so that a NaN (0 * inf on a slab's face) leaves the interval unchanged instead of rejecting
 * the box (Williams et al., "An efficient and robust ray-box intersection algorithm", 2005).
 */
#ifndef CLPT_AABB_H
#define CLPT_AABB_H

/* Clips [*t0, *t1] to the part of o + t d inside [lo, hi]; false if nothing is left. */
inline bool aabb_clip(float3 lo, float3 hi, float3 o, float3 inv_d, float* t0, float* t1) {
    const float3 a = (lo - o) * inv_d;
    const float3 b = (hi - o) * inv_d;
    const float3 near = fmin(a, b);
    const float3 far = fmax(a, b);
    /* fmax/fmin return the other operand for NaN, so NaNs never narrow the interval. */
    *t0 = fmax(*t0, fmax(near.x, fmax(near.y, near.z)));
    /* The far bound is widened by two ulps so rounding never loses a grazing box (pbrt-v4
     * section 6.8.2). */
    *t1 = fmin(*t1, fmin(far.x, fmin(far.y, far.z)) * (1.0f + 2.0f * 0x1.0p-23f));
    return *t0 <= *t1;
}

#endif
