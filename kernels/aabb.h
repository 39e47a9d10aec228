/* aabb.h: ray/box slab test (port of AABB.cuh).
 *
 * Reads: nothing. Writes: nothing. The ray's inverse direction is computed once per traversal
 * (slab_inverse), finite: a zero direction component's infinite inverse made a ray lying in a
 * box face's plane compute 0 * inf = NaN for that face's slab and +-inf for the other, and
 * fmin/fmax, which return the number beside a NaN, then emptied the interval. Rays along an
 * axis through a mesh's vertices passed through it: with the binary BVH 5% and the 8-wide 15% of
 * them (tests/mesh.rs, `rays_along_axes_and_from_afar_never_pass_through`).
 * (Williams et al., "An efficient and robust ray-box intersection algorithm", 2005, rely on
 * IEEE comparisons instead; pbrt-v4 section 6.8.2 for the widened far end.)
 */
#ifndef CLPT_AABB_H
#define CLPT_AABB_H

#include "types.h"
#include "vecmath.h"

/* 1 / d for the slab tests, its magnitude at most 2^80. A power of two, so (lo - o) times it is
 * exact where the clamp acts: a direction component of 0 (or below 2^-80) makes that axis's
 * slab [-huge, +huge] when o lies within it or on its face, [0, +huge] or [-huge, 0] at a face,
 * and beyond every t a scene reaches when o lies outside it (by more than 2^-80 of a t). Never
 * NaN: no interval is emptied by one. */
#define SLAB_INVERSE(d) copysign(fmin(fabs(1.0f / (d)), 0x1.0p80f), (d))

inline float3 slab_inverse(float3 d) {
    return SLAB_INVERSE(d);
}

/* Clips [*t0, *t1] to the part of o + t d inside [lo, hi] (inv_d: slab_inverse(d)); false if
 * nothing is left. */
inline bool aabb_clip(float3 lo, float3 hi, float3 o, float3 inv_d, float* t0, float* t1) {
    const float3 a = (lo - o) * inv_d;
    const float3 b = (hi - o) * inv_d;
    const float3 near = fmin(a, b);
    const float3 far = fmax(a, b);
    *t0 = fmax(*t0, fmax(near.x, fmax(near.y, near.z)));
    /* The far bound is widened by two ulps so rounding never loses a grazing box (pbrt-v4
     * section 6.8.2). */
    *t1 = fmin(*t1, fmin(far.x, fmin(far.y, far.z)) * (1.0f + 2.0f * 0x1.0p-23f));
    return *t0 <= *t1;
}

#if CLPT_WIDE && CLPT_MESHES
/* slab_inverse of one component in each lane. */
inline lfloat slab_inverse_lanes(lfloat d) {
    return SLAB_INVERSE(d);
}

/* aabb_clip in each lane (lanes.h), with the same roundings: the lanes whose ray meets the
 * box. */
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
