/* ray.h: rounding-error bounds and robust spawning of rays from surfaces.
 *
 * Reads: nothing. Writes: nothing. Why: a fixed epsilon cannot serve smallpt's walls (spheres of
 * radius 1e5, where f32 has a spacing of 0.008) and its small spheres at once. Each intersection
 * routine refines its hit point and bounds the point's error per component; a new ray starts
 * that bound away from the surface, on the side it leaves to, rounded away once more
 * (pbrt-v4, section 6.8.6 "Robust spawned ray origins"; Ray Tracing Gems, chapter 6).
 */
#ifndef CLPT_RAY_H
#define CLPT_RAY_H

#include "vecmath.h"

/* gamma(n) = n u / (1 - n u), u = 2^-24: the bound on the relative error of n chained f32
 * operations (Higham; pbrt-v4 section 6.8.1). */
inline float error_gamma(float n) {
    const float u = 0x1.0p-24f;
    return (n * u) / (1.0f - n * u);
}

/* Error-free transformations (Knuth's TwoSum; TwoProduct through fma, which OpenCL requires to
 * be correctly rounded): a op b == hi + lo exactly. */
inline LFloat2 two_sum(lfloat a, lfloat b) {
    const lfloat s = a + b;
    const lfloat bb = s - a;
    return make_lfloat2(s, (a - (s - bb)) + (b - bb));
}

inline LFloat2 two_prod(lfloat a, lfloat b) {
    const lfloat p = a * b;
    return make_lfloat2(p, fma(a, b, -p));
}

/* |o - c|^2 - r^2 as if computed in twice the precision (the Dot2 scheme of Ogita, Rump and
 * Oishi, "Accurate sum and dot product", 2005), for the double-float centre c + c_lo and
 * radius r + r_lo (types.h): o - c is split exactly into hi + lo (less c_lo), squares and r^2
 * are exact pairs, and the rounding errors are summed apart. Error about
 * 2u |result| + 32 u^2 (|o - c|^2 + r^2), where plain f32 has 3u (|o - c|^2 + r^2): on a sphere
 * of radius 1e5 that is 1e-3 instead of 2e3, so the sign of the result, inside or outside,
 * is right to within 1e-8 of the surface instead of 0.01 (and of the surface the scene's
 * decimals give, not of its f32 rounding, which is 0.004 away there). */
inline lfloat sphere_excess(LFloat3 o, float3 c, float3 c_lo, float r, float r_lo) {
    /* o - c - c_lo = hi + (lo - c_lo): the low part's one rounding is u |c_lo|, u^2 |c|. The
     * pair need not be normalised for the expansion below, which is exact in any split. */
    LFloat2 fx = two_sum(o.x, (lfloat)(-c.x));
    LFloat2 fy = two_sum(o.y, (lfloat)(-c.y));
    LFloat2 fz = two_sum(o.z, (lfloat)(-c.z));
    fx.y -= c_lo.x;
    fy.y -= c_lo.y;
    fz.y -= c_lo.z;
    LFloat2 p = two_prod(fx.x, fx.x);
    lfloat s = p.x;
    lfloat e = p.y;
    p = two_prod(fy.x, fy.x);
    LFloat2 t = two_sum(s, p.x);
    s = t.x;
    e += t.y + p.y;
    p = two_prod(fz.x, fz.x);
    t = two_sum(s, p.x);
    s = t.x;
    e += t.y + p.y;
    /* (r + r_lo)^2 = r^2 + r_lo (2 r + r_lo), r^2 an exact pair. */
    const LFloat2 r2 = two_prod((lfloat)(r), (lfloat)(r));
    t = two_sum(s, -r2.x);
    s = t.x;
    e += t.y - r2.y - r_lo * (2.0f * r + r_lo);
    /* (hi + lo)^2 = hi^2 + 2 hi lo + lo^2: the cross and low terms, small against hi^2. */
    e += 2.0f * (fx.x * fx.y + fy.x * fy.y + fz.x * fz.y) + (fx.y * fx.y + fy.y * fy.y + fz.y * fz.y);
    return s + e;
}

/* x moved one f32 step away from x - offset (not at all where offset is 0). */
inline lfloat round_away(lfloat x, lfloat offset) {
    return lselect(lselect(x, nextafter(x, (lfloat)(-INFINITY)), offset < 0.0f),
                   nextafter(x, (lfloat)(INFINITY)), offset > 0.0f);
}

/* The spawn point for leaving p (error bound p_error, geometric normal n) in direction w. */
inline LFloat3 offset_ray_origin(LFloat3 p, LFloat3 p_error, LFloat3 n, LFloat3 w) {
    const lfloat dist = v3_dot(v3_fabs(n), p_error);
    LFloat3 offset = v3_scale(dist, n);
    offset = v3_select(offset, v3_neg(offset), v3_dot(w, n) < 0.0f);
    const LFloat3 po = v3_add(p, offset);
    /* Round away from p, so rounding the sum cannot pull po back inside the error box. */
    return make_lfloat3(round_away(po.x, offset.x), round_away(po.y, offset.y),
                        round_away(po.z, offset.z));
}

#endif
