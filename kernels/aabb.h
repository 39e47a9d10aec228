/* aabb.h: ray/box slab test (port of AABB.cuh).
 *
 * Reads: nothing. Writes: nothing. The ray's inverse direction is computed once per traversal;
 * a zero direction component gives an infinite inverse, and the comparisons below are written
 * so that a NaN (0 * inf on a slab's face) leaves the interval unchanged instead of rejecting
 * the box (Williams et al., "An efficient and robust ray-box intersection algorithm", 2005).
 */
#ifndef CLPT_AABB_H
#define CLPT_AABB_H

#include "types.h"
#include "vecmath.h"

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

#if CLPT_WIDE && CLPT_MESHES
/* aabb_clip in each lane (lanes.h), with the same roundings and NaN rules: the lanes whose ray
 * meets the box. */
inline lmask aabb_clip_lanes(float3 lo, float3 hi, LFloat3 o, LFloat3 inv_d, lfloat* t0,
                             lfloat* t1) {
    const lfloat ax = (lo.x - o.x) * inv_d.x, bx = (hi.x - o.x) * inv_d.x;
    const lfloat ay = (lo.y - o.y) * inv_d.y, by = (hi.y - o.y) * inv_d.y;
    const lfloat az = (lo.z - o.z) * inv_d.z, bz = (hi.z - o.z) * inv_d.z;
    *t0 = fmax(*t0, fmax(fmin(ax, bx), fmax(fmin(ay, by), fmin(az, bz))));
    *t1 = fmin(*t1, fmin(fmax(ax, bx), fmin(fmax(ay, by), fmax(az, bz))) *
                        (1.0f + 2.0f * 0x1.0p-23f));
    return *t0 <= *t1;
}
#endif

#endif
