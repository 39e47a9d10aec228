/* revsurface.h: ray/surface-of-revolution intersection (port of revsurface.cuh).
 *
 * Reads: one RevSurface and its Bezier segments (control points (x, y), degree+1 per segment;
 * the host turns B-splines into Bezier segments). Writes: nothing. The surface is
 * S(u, theta) = (x(u) cos theta, y(u), x(u) sin theta), the profile revolved about the y axis.
 *
 * Why this way: the original started Newton's method from 30 random (u, theta) pairs per ray
 * and still missed hits. Here every root is isolated before it is solved for. As in Kajiya
 * ("New techniques for ray tracing procedurally defined objects", SIGGRAPH 1983) the problem
 * is reduced to one unknown, the profile parameter u: the ray meets the surface at a profile
 * point (x(u), y(u)) exactly when, at the height y(u), its distance from the axis is |x(u)|.
 * Multiplied by d.y^2 so that no division is needed,
 *     F(u) = |m + y(u) d_xz|^2 - d.y^2 x(u)^2,   m = d.y o_xz - o.y d_xz,
 * is a polynomial of degree 2n in u whose roots are those profile points. On a sub-segment
 * F's Bernstein coefficients follow from the sub-curve's control points, and Bernstein
 * polynomials obey Descartes' rule of signs (the variation-diminishing property behind Lane
 * and Riesenfeld's subdivision root finding, 1981): no sign change among the coefficients
 * proves that there is no root there, one proves that there is exactly one. So sub-segments are
 * halved (depth first) until each holds no root, which is discarded, or one, which is solved
 * by safeguarded Newton on F and polished by Newton on (t, u). Coefficients are classed as
 * positive, negative or "within rounding of zero" by a bound on their rounding error, and a
 * sub-segment is only decided on certain signs. Rays that keep their height make F a square
 * (two roots at one u), and rays touching the surface make a double root: these sub-segments
 * never decide and end at REV_MAX_DEPTH, 2^-10 of a segment, where the profile is a straight
 * chord to within about 1e-7 of its size; the ray is met with the cone of that chord, and
 * Newton on (t, u) polishes the roots. Where the profile's speed vanishes (repeated control
 * points) a stretch of it lies within rounding of a point: such sub-curves end the halving
 * as soon as they are that small. A second test, the ray's height and radius range against
 * the hull's annulus, prunes sub-segments beyond the nearest hit so far.
 *
 * Numbers: f32 throughout. Every tolerance below is a stated multiple of the rounding of the
 * terms involved, and the hit's error bound (rev_surface, below) covers the widest. The
 * terms are the sizes of the profile's coordinates and of the ray's origin, so both are kept
 * to the surface's own size: the host stores the profile with its heights centred on 0 (its
 * shift in the transform, src/pack/mod.rs), leaving the largest |y| half the profile's
 * height and the largest |x| its radius, and revsurface_intersect starts the ray where it
 * enters the surface's box. The guarantees above then hold relative to the box: no root is
 * lost or invented by more than about 1e-5 of the profile's extent wherever the surface and
 * the ray come from (a goblet raised to y = 1e6 in its own coordinates is the goblet at the
 * origin, pixel for pixel: tests/far.rs).
 */
#ifndef CLPT_REVSURFACE_H
#define CLPT_REVSURFACE_H

#include "aabb.h"
#include "types.h"
#include "vecmath.h"
#include "scene.h"

#define REV_MAX_DEGREE 7
/* CLPT_REV_DEGREE > 0 says that every revolved surface of the scene has that degree: loops
 * over control points then have constant bounds, are unrolled and keep their arrays in
 * registers (the host sets it, render/mod.rs). 0 reads the degree from each surface. */
#if defined(CLPT_REV_DEGREE) && CLPT_REV_DEGREE > 0
#define REV_DEGREE(rs) ((uint)CLPT_REV_DEGREE)
#else
#define REV_DEGREE(rs) ((rs)->degree)
#endif
#define REV_MAX_DEPTH 10
#define REV_SOLVE_STEPS 40
#define REV_NEWTON_STEPS 8

/* Bernstein evaluation by de Casteljau: point and derivative at u of the degree-n curve. */
inline void bezier_eval(__global const float2* p, uint n, float u, float2* point, float2* deriv) {
    float2 b[REV_MAX_DEGREE + 1];
    for (uint i = 0u; i <= n; ++i) {
        b[i] = p[i];
    }
    for (uint k = n; k >= 1u; --k) {
        if (k == 1u) {
            *deriv = (b[1] - b[0]) * (float)n;
        }
        for (uint i = 0u; i < k; ++i) {
            b[i] = mix(b[i], b[i + 1u], u);
        }
    }
    *point = b[0];
}

/* The control points b of the sub-curve on [u0, u1] (two de Casteljau splits). */
inline void bezier_sub(__global const float2* p, uint n, float u0, float u1, float2* b) {
    for (uint i = 0u; i <= n; ++i) {
        b[i] = p[i];
    }
    /* Keep [0, u1], then within it [u0 / u1, 1]. */
    for (uint k = 1u; k <= n; ++k) {
        for (uint i = n; i >= k; --i) {
            b[i] = mix(b[i - 1u], b[i], u1);
        }
    }
    const float s = u1 > 0.0f ? u0 / u1 : 0.0f;
    for (uint k = 1u; k <= n; ++k) {
        for (uint i = 0u; i <= n - k; ++i) {
            b[i] = mix(b[i], b[i + 1u], s);
        }
    }
}

/* What one intersection cost: solver iterations (Newton steps on F or on (t, u)) and
 * sub-segments visited. Benchmarks read it (probe_rev_work); renders let the compiler drop
 * it. */
typedef struct RevWork {
    uint iterations;
    uint nodes;
} RevWork;

/* The ray in the terms F needs, and the rounding bounds of those terms. */
typedef struct RevRay {
    float3 o, d;
    float2 m;        /* d.y o_xz - o.y d_xz */
    float2 dxz;
    float dy2;
    float a;         /* |d_xz|^2 */
    float t_c;       /* where the ray passes nearest the axis (0 for vertical rays) */
    float rho2;      /* its squared distance from the axis there */
    float p_err;     /* bound on the rounding of m + y d_xz, for |y| up to the profile's */
    float x_err;     /* bound on the rounding of a sub-curve's x */
    float y_scale;   /* |o.y| + the profile's largest |y|: the size of the terms g1 cancels */
    float x_max;     /* the profile's largest |x| */
    float leaf_size; /* sub-curves this small are solved as chords whatever their depth */
} RevRay;

inline RevRay rev_ray(float3 o, float3 d) {
    RevRay r;
    r.o = o;
    r.d = d;
    r.dxz = (float2)(d.x, d.z);
    r.m = d.y * (float2)(o.x, o.z) - o.y * r.dxz;
    r.dy2 = d.y * d.y;
    /* Equations in t are solved about t_c, where the ray's radius is least: expanded about
     * the origin, they cancel |o_xz|^2 against the small radii of the surface. The least
     * radius comes from the cross product, which does not cancel. */
    r.a = d.x * d.x + d.z * d.z;
    const float cross = o.x * d.z - o.z * d.x;
    r.t_c = r.a > 0.0f ? -(o.x * d.x + o.z * d.z) / r.a : 0.0f;
    r.rho2 = r.a > 0.0f ? cross * cross / r.a : o.x * o.x + o.z * o.z;
    return r;
}

/* The rounding bounds for a segment whose control points are at most x_max, y_max in size,
 * which its stored hull (x_lo, x_hi, y_lo, y_hi) gives.
 * Sub-curve points carry at most 2n roundings of that size (two splits of n levels, each a
 * convex combination): 1e-6 of it covers degree 7. m carries two roundings of its terms. */
inline void rev_ray_segment(RevRay* r, float4 hull) {
    const float x_max = fmax(fabs(hull.x), fabs(hull.y));
    const float y_max = fmax(fabs(hull.z), fabs(hull.w));
    const float3 o = r->o, d = r->d;
    const float dxz_l1 = fabs(d.x) + fabs(d.z);
    r->p_err = 0x1.0p-22f * (fabs(d.y) * (fabs(o.x) + fabs(o.z)) + fabs(o.y) * dxz_l1) +
               1e-6f * y_max * dxz_l1;
    r->x_err = 1e-6f * x_max;
    r->y_scale = fabs(o.y) + y_max;
    r->x_max = x_max;
    /* Four times the rounding of the sub-curves' points: halving further would only split
     * noise. Where the profile's speed vanishes (repeated control points at the axis, as the
     * original's goblet has) F stays within rounding of zero over a long stretch of u, and
     * this ends the halving there after a few steps. */
    r->leaf_size = 4e-6f * (x_max + y_max);
}

/* F at a profile point s, and its derivative for the profile's derivative ds. */
inline float rev_f(const RevRay* r, float2 s, float2 ds, float* df) {
    const float2 q = r->m + s.y * r->dxz;
    *df = 2.0f * (dot(q, ds.y * r->dxz) - r->dy2 * s.x * ds.x);
    return dot(q, q) - r->dy2 * s.x * s.x;
}

/* What F's Bernstein coefficients on a sub-segment say. */
#define REV_NONE 0   /* certainly no root */
#define REV_ONE 1    /* certainly exactly one root, a simple one */
#define REV_SPLIT 2  /* undecided */

inline int rev_classify(const RevRay* r, const float2* b, uint n, float* f0, float* f1) {
    /* Unnormalised coefficients: the k-th is C(2n, k) times the Bernstein coefficient, the
     * sum over i + j = k of C(n, i) C(n, j) g_ij with g_ij = q_i.q_j - d.y^2 x_i x_j; the
     * positive factor changes no sign. */
    float c[2 * REV_MAX_DEGREE + 1], e[2 * REV_MAX_DEGREE + 1];
    float2 q[REV_MAX_DEGREE + 1];
    float qa[REV_MAX_DEGREE + 1], binom[REV_MAX_DEGREE + 1];
    binom[0] = 1.0f;
    for (uint i = 0u; i <= n; ++i) {
        q[i] = r->m + b[i].y * r->dxz;
        qa[i] = length(q[i]);
        if (i > 0u) {
            binom[i] = binom[i - 1u] * (float)(n + 1u - i) / (float)i;
        }
    }
    for (uint k = 0u; k <= 2u * n; ++k) {
        c[k] = 0.0f;
        e[k] = 0.0f;
    }
    const float pe = r->p_err, xe = r->x_err, dy2 = r->dy2;
    for (uint i = 0u; i <= n; ++i) {
        for (uint j = i; j <= n; ++j) {
            const float w = binom[i] * binom[j] * (i == j ? 1.0f : 2.0f);
            const float xi = fabs(b[i].x), xj = fabs(b[j].x);
            const float g = dot(q[i], q[j]) - dy2 * b[i].x * b[j].x;
            /* Rounding of q and x propagated through the products, and of the products and
             * the sums themselves (1e-6 of their magnitude). */
            const float err = pe * (qa[i] + qa[j] + pe) + dy2 * xe * (xi + xj + xe) +
                              1e-6f * (qa[i] * qa[j] + dy2 * xi * xj);
            c[i + j] += w * g;
            e[i + j] += w * err;
        }
    }
    *f0 = c[0];
    *f1 = c[2u * n];
    /* Signs of the certain coefficients; an uncertain run between two equal signs could hide
     * two sign changes, and uncertain ends leave the count open. */
    int prev = 0, variations = 0;
    bool pending = false, ambiguous = false;
    for (uint k = 0u; k <= 2u * n; ++k) {
        const int s = c[k] > e[k] ? 1 : (c[k] < -e[k] ? -1 : 0);
        if (s == 0) {
            pending = true;
            if (k == 0u || k == 2u * n) {
                ambiguous = true;
            }
            continue;
        }
        if (prev != 0 && s != prev) {
            ++variations;
        } else if (prev != 0 && pending) {
            ambiguous = true;
        }
        pending = false;
        prev = s;
    }
    if (prev == 0) {
        return REV_SPLIT; /* every coefficient within rounding of zero */
    }
    if (variations == 0 && !ambiguous) {
        return REV_NONE;
    }
    return (variations == 1 && !ambiguous) ? REV_ONE : REV_SPLIT;
}

/* Narrows [t0, t1] to where the ray is between the heights y_lo - pad and y_hi + pad of the
 * box (x_lo, x_hi, y_lo, y_hi); false when nothing is left. */
inline bool height_slab(float4 box, float pad, float3 o, float3 d, float* t0, float* t1) {
    if (d.y != 0.0f) {
        const float ta = (box.z - pad - o.y) / d.y;
        const float tb = (box.w + pad - o.y) / d.y;
        *t0 = fmax(*t0, fmin(ta, tb));
        *t1 = fmin(*t1, fmax(ta, tb));
    } else if (o.y < box.z - pad || o.y > box.w + pad) {
        return false;
    }
    return *t0 <= *t1;
}

/* Can the ray, for t in (t_lo, t_hi), come into the solid of revolution of the hull box
 * (x_lo, x_hi, y_lo, y_hi)? */
inline bool annulus_reachable(float4 box, float3 o, float3 d, float t_lo, float t_hi) {
    /* A little slack for the rounding of the hull and of r^2(t). */
    const float pad = 1e-5f * (fabs(box.y) + fabs(box.x) + fabs(box.z) + fabs(box.w)) + 1e-30f;
    float t0 = t_lo, t1 = t_hi;
    if (!height_slab(box, pad, o, d, &t0, &t1)) {
        return false;
    }
    const float r_hi = fmax(fabs(box.x), fabs(box.y)) + pad;
    const bool ring = box.x > 0.0f || box.y < 0.0f; /* the box does not span the axis */
    const float r_lo = ring ? fmax(0.0f, fmin(fabs(box.x), fabs(box.y)) - pad) : 0.0f;
    /* r^2(t) = a t^2 + b t + c, its least and greatest values on [t0, t1]. */
    const float a = d.x * d.x + d.z * d.z;
    const float b = 2.0f * (o.x * d.x + o.z * d.z);
    const float c = o.x * o.x + o.z * o.z;
    const float q0 = (a * t0 + b) * t0 + c;
    const float q1 = (a * t1 + b) * t1 + c;
    float q_min = fmin(q0, q1);
    float q_max = fmax(q0, q1);
    if (a > 0.0f) {
        const float tv = -b / (2.0f * a);
        if (tv > t0 && tv < t1) {
            q_min = fmin(q_min, (a * tv + b) * tv + c);
        }
    }
    /* The expanded quadratic cancels when the ray passes near the axis far from its origin:
     * widen the range by its rounding error. */
    const float tm = fmax(fabs(t0), fabs(t1));
    const float q_err = 8.0f * 0x1.0p-24f * (c + fabs(b) * tm + a * tm * tm);
    q_min -= q_err;
    q_max += q_err;
    return !(q_min > r_hi * r_hi || q_max < r_lo * r_lo);
}

/* The residuals of (t, u): the ray's height less the profile's, its squared radius less the
 * profile's. True when both are within their rounding: 1e-5 of the size of the terms they
 * cancel (f32 carries noise of about 1e-7 of those), where for the radius the ray point's own
 * position, a few roundings of |o| + |t d| in each coordinate, bounds how well r^2 can match
 * near the axis. */
inline bool rev_residuals_ok(const RevRay* r, float2 s, float t) {
    const float qx = r->o.x + t * r->d.x, qz = r->o.z + t * r->d.z;
    const float g1 = s.y - (r->o.y + t * r->d.y);
    const float rho2 = qx * qx + qz * qz;
    const float g2 = rho2 - s.x * s.x;
    const float y_scale = r->y_scale + fabs(t * r->d.y) + 1e-30f;
    const float pos_err = 1e-6f * (fabs(r->o.x) + fabs(r->o.z) +
                                   fabs(t) * (fabs(r->d.x) + fabs(r->d.z)) + r->x_max);
    const float r_tol = 1e-5f * (rho2 + s.x * s.x) +
                        2.0f * (sqrt(rho2) + fabs(s.x) + pos_err) * pos_err + 1e-30f;
    return fabs(g1) <= 1e-5f * y_scale && fabs(g2) <= r_tol;
}

/* Newton on (t, u) for g1 = y(u) - (o.y + t d.y) = 0, g2 = |o_xz + t d_xz|^2 - x(u)^2 = 0 from
 * (t, u); true with the root when it converges with u in [u0, u1] and t in (0, t_max). */
inline bool rev_newton(__global const float2* p, uint n, const RevRay* r, float u0, float u1,
                       float t, float u, float t_max, float* t_out, float* u_out, RevWork* work) {
    const float3 o = r->o, d = r->d;
    float2 s, ds;
    for (int i = 0; i < REV_NEWTON_STEPS; ++i) {
        ++work->iterations;
        bezier_eval(p, n, u, &s, &ds);
        /* r^2 of the ray point evaluated directly, not as a t^2 + b t + c, which cancels
         * near the axis. */
        const float qx = o.x + t * d.x, qz = o.z + t * d.z;
        const float g1 = s.y - (o.y + t * d.y);
        const float g2 = qx * qx + qz * qz - s.x * s.x;
        /* Jacobian [[dg1/dt, dg1/du], [dg2/dt, dg2/du]]. */
        const float j11 = -d.y, j12 = ds.y;
        const float j21 = 2.0f * (qx * d.x + qz * d.z), j22 = -2.0f * s.x * ds.x;
        const float det = j11 * j22 - j12 * j21;
        if (det == 0.0f || !isfinite(det)) {
            break;
        }
        const float dt = (g1 * j22 - g2 * j12) / det;
        const float du = (g2 * j11 - g1 * j21) / det;
        const float t_next = t - dt, u_next = u - du;
        if (!isfinite(t_next) || !isfinite(u_next) || u_next < u0 - (u1 - u0) ||
            u_next > u1 + (u1 - u0)) {
            break; /* the step left the sub-segment: keep the last point */
        }
        t = t_next;
        u = u_next;
        if (fabs(du) <= 1e-7f && fabs(dt) <= 1e-7f * fmax(1.0f, fabs(t))) {
            break;
        }
    }
    u = clamp(u, u0, u1);
    bezier_eval(p, n, u, &s, &ds);
    if (!rev_residuals_ok(r, s, t) || !(t > 0.0f && t < t_max)) {
        return false;
    }
    *t_out = t;
    *u_out = u;
    return true;
}

/* Where the ray meets the circle of the profile point s: from its height when it climbs, else
 * (and where that is ill-conditioned) the crossing of the cylinder of radius |s.x| whose height
 * is nearer s.y. */
inline float rev_t_at(const RevRay* r, float2 s) {
    const float3 o = r->o, d = r->d;
    float best = d.y != 0.0f ? (s.y - o.y) / d.y : INFINITY;
    float best_err = INFINITY;
    if (isfinite(best)) {
        const float qx = o.x + best * d.x, qz = o.z + best * d.z;
        best_err = fabs(sqrt(qx * qx + qz * qz) - fabs(s.x));
    }
    if (r->a > 0.0f && s.x * s.x >= r->rho2) {
        const float w = sqrt((s.x * s.x - r->rho2) / r->a);
        const float roots[2] = {r->t_c - w, r->t_c + w};
        for (int k = 0; k < 2; ++k) {
            const float err = fabs(o.y + roots[k] * d.y - s.y);
            if (err < best_err) {
                best_err = err;
                best = roots[k];
            }
        }
    }
    return best;
}

/* The one root of F on [u0, u1], where F is f0 and f1 at the ends (of opposite signs): Newton
 * on F from the secant's root, kept inside a shrinking bracket, then Newton on (t, u) from
 * there where the pair does not yet solve both equations. */
inline bool rev_solve_one(__global const float2* p, uint n, const RevRay* r, float u0, float u1,
                          float f0, float f1, float t_max, float* t_out, float* u_out,
                          RevWork* work) {
    float lo = u0, hi = u1;
    float u = u0 + clamp(f0 / (f0 - f1), 0.0f, 1.0f) * (u1 - u0);
    const bool lo_positive = f0 > 0.0f;
    float2 s, ds;
    for (int i = 0; i < REV_SOLVE_STEPS; ++i) {
        ++work->iterations;
        bezier_eval(p, n, u, &s, &ds);
        float df;
        const float f = rev_f(r, s, ds, &df);
        if ((f > 0.0f) == lo_positive) {
            lo = u;
        } else {
            hi = u;
        }
        float next = u - f / df;
        if (!(next > lo && next < hi)) {
            next = 0.5f * (lo + hi);
        }
        const bool done = fabs(next - u) <= 1e-7f || hi - lo <= 1e-7f;
        u = next;
        if (done) {
            break;
        }
    }
    bezier_eval(p, n, u, &s, &ds);
    const float t = rev_t_at(r, s);
    /* Usually (t, u) already solves both equations to rounding; else Newton polishes it. */
    if (rev_residuals_ok(r, s, t) && t > 0.0f && t < t_max) {
        *t_out = t;
        *u_out = u;
        return true;
    }
    return rev_newton(p, n, r, u0, u1, t, u, t_max, t_out, u_out, work);
}

/* A sub-segment at REV_MAX_DEPTH: its chord from b[0] to b[n], the line
 * dy x - dx y = dy x0 - dx y0, revolved is a cone (or a cylinder or a disc) on which
 * dy^2 r^2 = (dy x0 - dx y0 + dx y)^2, a quadratic in t along the ray. Its roots seed Newton
 * on (t, u), and stand for the hit where Newton cannot improve on them. */
inline bool rev_solve_chord(__global const float2* p, uint n, const RevRay* r, const float2* b,
                            float u0, float u1, float t_max, float* t_out, float* u_out,
                            RevWork* work) {
    const float3 o = r->o, d = r->d;
    const float dx = b[n].x - b[0].x, dy = b[n].y - b[0].y;
    /* In tau = t - t_c: the ray's r^2 is a tau^2 + rho2, its height o.y + t_c d.y + tau d.y. */
    const float k = dy * b[0].x - dx * (b[0].y - (o.y + r->t_c * d.y));
    const float qa = dy * dy * r->a - dx * dx * r->dy2;
    const float qb = -2.0f * dx * d.y * k;
    const float qc = dy * dy * r->rho2 - k * k;
    float roots[2];
    int count = 0;
    if (qa != 0.0f) {
        const float disc = qb * qb - 4.0f * qa * qc;
        /* A touching ray gives a double root that rounding may push below zero. */
        const float sq = sqrt(fmax(disc, 0.0f));
        const float q = -0.5f * (qb + copysign(sq, qb));
        roots[count++] = r->t_c + q / qa;
        if (q != 0.0f) {
            roots[count++] = r->t_c + qc / q;
        }
    } else if (qb != 0.0f) {
        roots[count++] = r->t_c - qc / qb;
    }
    bool found = false;
    float t_best = t_max;
    for (int i = 0; i < count; ++i) {
        /* The expanded quadratic cancels (c is |o_xz|^2, large for distant origins): two
         * Newton steps on the cone's equation with the ray point's radius taken directly. */
        float t = roots[i];
        for (int j = 0; j < 2; ++j) {
            const float qx = o.x + t * d.x, qz = o.z + t * d.z;
            const float lin = k + dx * d.y * (t - r->t_c);
            const float h = dy * dy * (qx * qx + qz * qz) - lin * lin;
            const float dh = 2.0f * (dy * dy * (qx * d.x + qz * d.z) - lin * dx * d.y);
            const float step = h / dh;
            /* A correction of the rounding, not a jump away from a double root. */
            if (isfinite(step) && fabs(step) <= 1e-3f * (fabs(t) + 1.0f)) {
                t -= step;
            }
        }
        if (!(t > 0.0f && t < t_best)) {
            continue;
        }
        /* Where on the chord: by height, or by radius where the chord is flatter. */
        const float3 q = o + t * d;
        const float rho = sqrt(q.x * q.x + q.z * q.z);
        float v;
        if (fabs(dy) >= fabs(dx)) {
            v = (q.y - b[0].y) / dy;
        } else {
            const float side = (b[0].x + b[n].x) < 0.0f ? -1.0f : 1.0f;
            v = (side * rho - b[0].x) / dx;
        }
        /* v is the chord's parameter, not the curve's: a root at the sub-segment's end may
         * come out a little beyond it on both sides. Such roots are taken by both, which is
         * harmless, and not by neither. */
        if (!(v >= -0.25f && v <= 1.25f)) {
            continue;
        }
        const float w0 = fmax(0.0f, u0 - 0.25f * (u1 - u0));
        const float w1 = fmin(1.0f, u1 + 0.25f * (u1 - u0));
        const float u = clamp(u0 + v * (u1 - u0), w0, w1);
        float th, uh;
        /* Newton polishes the root, but where the ray nearly touches the cone the Jacobian
         * is nearly singular and it may jump to the other root: it must stay nearer this
         * one. */
        const float reach = count == 2 ? 0.25f * fabs(roots[1] - roots[0]) : INFINITY;
        if (rev_newton(p, n, r, w0, w1, t, u, t_best, &th, &uh, work) && fabs(th - t) < reach) {
            t_best = th;
            *u_out = uh;
            found = true;
        } else {
            float2 s, ds;
            bezier_eval(p, n, u, &s, &ds);
            if (rev_residuals_ok(r, s, t)) {
                t_best = t;
                *u_out = u;
                found = true;
            }
        }
    }
    *t_out = t_best;
    return found;
}

/* The first t in (t_lo, t_hi) at which the ray is inside the solid of revolution of the box
 * (x_lo, x_hi, y_lo, y_hi) grown by pad, or t_hi if none: the height slab, then radius
 * between the box's least and greatest |x| (a ring, or a disc where the box spans the axis). */
inline float annulus_entry(const RevRay* r, float4 box, float pad, float t_lo, float t_hi) {
    float t0 = t_lo, t1 = t_hi;
    if (!height_slab(box, pad, r->o, r->d, &t0, &t1)) {
        return t_hi;
    }
    box.xy += (float2)(-pad, pad);
    const float r_hi = fmax(fabs(box.x), fabs(box.y));
    const float r_lo = (box.x > 0.0f || box.y < 0.0f) ? fmin(fabs(box.x), fabs(box.y)) : 0.0f;
    /* The ray's distance from the axis is least at t_c (RevRay) and reaches R at
     * t_c -+ sqrt((R^2 - rho2) / a). */
    if (r->a == 0.0f) {
        return (r->rho2 <= r_hi * r_hi && r->rho2 >= r_lo * r_lo) ? t0 : t_hi;
    }
    if (r->rho2 > r_hi * r_hi) {
        return t_hi;
    }
    const float w_hi = sqrt((r_hi * r_hi - r->rho2) / r->a);
    t0 = fmax(t0, r->t_c - w_hi);
    t1 = fmin(t1, r->t_c + w_hi);
    if (!(t0 <= t1)) {
        return t_hi;
    }
    if (r->rho2 < r_lo * r_lo) {
        /* In the hole at t0: the ring again from where the ray leaves the hole. */
        const float w_lo = sqrt((r_lo * r_lo - r->rho2) / r->a);
        if (t0 > r->t_c - w_lo && t0 < r->t_c + w_lo) {
            t0 = r->t_c + w_lo;
        }
    }
    return t0 <= t1 ? t0 : t_hi;
}

/* One step of a segment's root isolation: the sub-curve on [iv.x, iv.y] of the segment whose
 * control points are p, at halving depth dep, against the ray (its terms set for the segment,
 * rev_ray_segment). Discards it where the ray cannot reach it before *t_best or F has no root
 * there, solves it where F has one root or it is a chord's size (module doc), updating
 * *t_best, *u_hit and *found; true where it is to be halved. */
inline bool rev_visit(__global const float2* p, uint n, const RevRay* ray, float2 iv, uchar dep,
                      float* t_best, float* u_hit, bool* found, RevWork* work) {
    ++work->nodes;
    float2 b[REV_MAX_DEGREE + 1];
    bezier_sub(p, n, iv.x, iv.y, b);
    float4 box = (float4)(b[0].x, b[0].x, b[0].y, b[0].y);
    for (uint i = 1u; i <= n; ++i) {
        box = (float4)(fmin(box.x, b[i].x), fmax(box.y, b[i].x), fmin(box.z, b[i].y),
                       fmax(box.w, b[i].y));
    }
    if (!annulus_reachable(box, ray->o, ray->d, 0.0f, *t_best)) {
        return false;
    }
    float f0, f1;
    const int roots = rev_classify(ray, b, n, &f0, &f1);
    if (roots == REV_NONE) {
        return false;
    }
    float th, uh;
    if (roots == REV_ONE) {
        if (rev_solve_one(p, n, ray, iv.x, iv.y, f0, f1, *t_best, &th, &uh, work)) {
            *t_best = th;
            *u_hit = uh;
            *found = true;
        }
        return false;
    }
    const bool tiny = fmax(box.y - box.x, box.w - box.z) <= ray->leaf_size;
    if (dep < REV_MAX_DEPTH && !tiny) {
        return true;
    }
    if (rev_solve_chord(p, n, ray, b, iv.x, iv.y, *t_best, &th, &uh, work)) {
        *t_best = th;
        *u_hit = uh;
        *found = true;
    } else if (tiny) {
        /* A sub-curve within rounding of a point (where the profile's speed vanishes, a
         * chord is no model of it) that F cannot tell from the ray: where the ray enters its
         * box's ring, grown by the box's rounding, it is within a few roundings of the
         * surface. */
        const float t = annulus_entry(ray, box, ray->leaf_size, 0.0f, *t_best);
        if (t < *t_best) {
            *t_best = t;
            *u_hit = 0.5f * (iv.x + iv.y);
            *found = true;
        }
    }
    return false;
}

/* The sub-curves of one segment waiting to be visited, depth first: (u0, u1) and depth. */
#define REV_STACK (REV_MAX_DEPTH + 2)
typedef struct RevWalk {
    float2 iv[REV_STACK];
    uchar depth[REV_STACK];
    int top;
} RevWalk;

/* Stored hull number i (RevSurface.first_hull, types.h) as (x_lo, x_hi, y_lo, y_hi). */
inline float4 rev_hull(__global const RevSurface* rs, __global const float2* points, uint i) {
    return vload4(i, (__global const float*)(points + rs->first_hull));
}

/* Whether the ray (o + t d, t in (0, t_hi)) can reach segment k's stored hull revolved
 * (RevSurface.first_hull, types.h): where it cannot, the segment's setup and first step are
 * spared (BENCHMARKS.md, "The goblet's share of case3, and its segment hulls"). The hull is
 * the box of the segment's control points, which the first step tests again as its own. */
inline bool rev_hull_reachable(__global const RevSurface* rs, __global const float2* points,
                               uint k, const RevRay* ray, float t_hi) {
    return annulus_reachable(rev_hull(rs, points, k), ray->o, ray->d, 0.0f, t_hi);
}

/* Whether the ray can reach the hull of the group of REV_GROUP segments that segment k (a
 * multiple of REV_GROUP) begins (stored after the segments' hulls, types.h): where it cannot,
 * none of their hulls is tested. The group's hull holds theirs, so no segment that
 * rev_hull_reachable would pass is skipped, and the segments walked are the same. */
inline bool rev_group_reachable(__global const RevSurface* rs, __global const float2* points,
                                uint k, const RevRay* ray, float t_hi) {
    return annulus_reachable(rev_hull(rs, points, rs->num_segments + k / REV_GROUP), ray->o,
                             ray->d, 0.0f, t_hi);
}

/* The first segment from `next` on whose hull (and group's hull) the ray can reach, or
 * num_segments where none is left. */
inline uint rev_next_reachable(__global const RevSurface* rs, __global const float2* points,
                               uint next, const RevRay* ray, float t_hi) {
    while (next < rs->num_segments) {
        if (next % REV_GROUP == 0u && !rev_group_reachable(rs, points, next, ray, t_hi)) {
            next += REV_GROUP;
        } else if (rev_hull_reachable(rs, points, next, ray, t_hi)) {
            return next;
        } else {
            ++next;
        }
    }
    return rs->num_segments;
}

/* Segment k begun: the ray's terms for it, its whole parameter range waiting. Its points. */
inline __global const float2* rev_begin(__global const RevSurface* rs,
                                        __global const float2* points, uint n, uint k,
                                        RevRay* ray, RevWalk* walk) {
    __global const float2* p = points + rs->first_point + k * (n + 1u);
    rev_ray_segment(ray, rev_hull(rs, points, k));
    walk->iv[0] = (float2)(0.0f, 1.0f);
    walk->depth[0] = 0;
    walk->top = 1;
    return p;
}

/* One sub-curve taken from the walk and visited (rev_visit), its halves put back where it is
 * halved; true where it gave the nearest hit so far. */
inline bool rev_step(__global const float2* p, uint n, const RevRay* ray, RevWalk* walk,
                     float* t_best, float* u_hit, RevWork* work) {
    const int top = walk->top - 1;
    const float2 iv = walk->iv[top];
    const uchar dep = walk->depth[top];
    bool found = false;
    if (rev_visit(p, n, ray, iv, dep, t_best, u_hit, &found, work)) {
        const float um = 0.5f * (iv.x + iv.y);
        walk->iv[top] = (float2)(um, iv.y);
        walk->iv[top + 1] = (float2)(iv.x, um);
        walk->depth[top] = walk->depth[top + 1] = dep + 1;
        walk->top = top + 2;
    } else {
        walk->top = top;
    }
    return found;
}

/* The nearest hit in (0, t_max) of o + t d (d unit) with the surface: t, or t_max if none;
 * *seg and *u_hit say where on the profile, *work counts what it took.
 *
 * The segments are taken in order, each one's that the ray can reach (rev_next_reachable)
 * walked depth first to its end before the next is begun; two forms of the loop give the
 * same hits (CLPT_REV_MERGED, features.h):
 * - merged, one loop over every segment's sub-curves: a work-item done with a segment begins
 *   its next while others of its warp still halve theirs, so that a warp pays for the most
 *   sub-curves any of its work-items visits, not for the sum over segments of each segment's
 *   most (the loop merging of Aila and Laine, "Understanding the efficiency of ray traversal
 *   on GPUs", HPG 2009): bounce rays, unlike across a warp, each reach few segments, and
 *   rarely the same;
 * - segment by segment, a warp's work-items in step: shadow rays towards one light, alike
 *   across a warp, reach the same segments, and lose to the merged loop's bookkeeping.
 * BENCHMARKS.md, "The goblet's segments in one loop", has the figures. */
inline float revsurface_intersect(__global const RevSurface* rs, __global const float2* points,
                                  float3 o, float3 d, float t_max, uint* seg, float* u_hit,
                                  RevWork* work) {
    const uint n = REV_DEGREE(rs);
    /* The surface's box, grown by an eighth of its size: a ray that misses it misses the
     * surface, and one that starts outside it starts again at its entry (module doc), t_start
     * along the ray. The origin then lies within about its size of the surface, so the
     * solver's terms are of that size, and at least an eighth of it away: an origin within a
     * rounding of the surface (at its entry, on a ray nearly tangent at a cusp) leaves the
     * residual tests comparing numbers of that rounding: entering at 1e-3 of its size lost 3
     * grazing hits of the 1e6 rays tests/revsurface.rs sends at its cusped profile. */
    const float radius = rs->radius, pad = 0.125f * (radius + rs->y_hi - rs->y_lo) + 1e-30f;
    const float3 box_hi = (float3)(radius + pad, rs->y_hi + pad, radius + pad);
    const float3 box_lo = (float3)(-box_hi.x, rs->y_lo - pad, -box_hi.z);
    const float t_limit = t_max;
    float t_start = 0.0f, t_end = t_max;
    if (!aabb_clip(box_lo, box_hi, o, 1.0f / d, &t_start, &t_end)) {
        return t_limit;
    }
    o += t_start * d;
    t_max -= t_start;
    RevRay ray = rev_ray(o, d);
    float t_best = t_max;
    RevWalk walk;
#if CLPT_REV_MERGED
    walk.top = 0;
    __global const float2* p = points;
    for (uint k = 0u, next = 0u;;) {
        if (walk.top == 0) {
            k = rev_next_reachable(rs, points, next, &ray, t_best);
            if (k >= rs->num_segments) {
                break;
            }
            next = k + 1u;
            p = rev_begin(rs, points, n, k, &ray, &walk);
        }
        if (rev_step(p, n, &ray, &walk, &t_best, u_hit, work)) {
            *seg = k;
        }
    }
#else
    /* The same tests as rev_next_reachable's, written into this loop: called from it, they
     * cost light-sampling programs 3% of case3 on an H100 (BENCHMARKS.md, "Group hulls"). */
    for (uint k = 0u; k < rs->num_segments; ++k) {
        if (k % REV_GROUP == 0u && !rev_group_reachable(rs, points, k, &ray, t_best)) {
            k += REV_GROUP - 1u;
            continue;
        }
        if (!rev_hull_reachable(rs, points, k, &ray, t_best)) {
            continue;
        }
        __global const float2* p = rev_begin(rs, points, n, k, &ray, &walk);
        while (walk.top > 0) {
            if (rev_step(p, n, &ray, &walk, &t_best, u_hit, work)) {
                *seg = k;
            }
        }
    }
#endif
    return t_best < t_max ? t_start + t_best : t_limit;
}

/* The kind's three functions of SHAPES(X) (types.h; kernels/shapes.h dispatches through them):
 * one object's hit, every object's without the object BVH, the surface at a hit. */
inline void revsurface_object_intersect(const Scene* sc, uint index, float3 o, float3 d,
                                       Hit* hit) {
    __global const RevSurface* r = &sc->revsurfaces[index];
    float scale;
    to_object_space(sc, r->transform, &o, &d, &scale);
    const float t_max = hit->t * scale;
    uint seg = 0u;
    RevWork work = {0u, 0u};
    float u = 0.0f;
    const float t = revsurface_intersect(r, sc->rev_points, o, d, t_max, &seg, &u, &work);
    if (keep_hit(hit, t, t_max, scale, OBJECT_REVSURFACE, index)) {
        hit->prim = seg;
        hit->b1 = u;
    }
}

inline void revsurface_intersect_all(const Scene* sc, float3 o, float3 d, Hit* hit) {
    for (uint i = 0u; i < sc->params->counts[OBJECT_REVSURFACE]; ++i) {
        revsurface_object_intersect(sc, i, o, d, hit);
    }
}

/* The hit point moved onto the surface at the profile parameter found, its normal (the
 * profile's normal (y', -x') revolved, turned with the profile where x < 0) and an error
 * bound covering the Newton iteration's acceptance band. */
inline void rev_surface(const Scene* sc, __global const RevSurface* r, Hit hit, float3 p_ray,
                        float3* p, float3* p_error, float3* n) {
    const uint degree = REV_DEGREE(r);
    __global const float2* pts = sc->rev_points + r->first_point + hit.prim * (degree + 1u);
    float size = 0.0f;
    for (uint i = 0u; i <= degree; ++i) {
        size = fmax(size, fabs(pts[i].x) + fabs(pts[i].y));
    }
    float2 s, ds;
    bezier_eval(pts, degree, hit.b1, &s, &ds);
    const float rho = sqrt(p_ray.x * p_ray.x + p_ray.z * p_ray.z);
    const float3 radial = rho > 0.0f ? (float3)(p_ray.x / rho, 0.0f, p_ray.z / rho)
                                     : (float3)(1.0f, 0.0f, 0.0f);
    *p = fabs(s.x) * radial + (float3)(0.0f, s.y, 0.0f);
    /* Where the profile's speed all but vanishes (repeated control points: the original's
     * goblet meets the axis through three points 1e-6 apart) the derivative's direction is
     * that of rounding-sized wiggles. The tangent is then the secant to a point at least
     * 1e-4 of the segment's size away, towards the segment's interior. */
    float2 tangent = ds;
    if (length(ds) < 1e-2f * size) {
        const float dir = hit.b1 < 0.5f ? 1.0f : -1.0f;
        for (float du = 1.0f / 64.0f; du <= 0.5f; du *= 2.0f) {
            float2 s2, ds2;
            bezier_eval(pts, degree, hit.b1 + dir * du, &s2, &ds2);
            tangent = dir * (s2 - s);
            if (length(s2 - s) >= 1e-4f * size) {
                break;
            }
        }
    }
    const float sign = s.x < 0.0f ? -1.0f : 1.0f;
    *n = normalize(tangent.y * radial - sign * tangent.x * (float3)(0.0f, 1.0f, 0.0f));
    /* The solvers accept a root whose residuals are within 1e-5 of their terms' size, the
     * segment's largest coordinates among them (rev_residuals_ok), and sub-curves within
     * a few roundings of a point by where the ray enters their box: the point is known to
     * that band, and a ray spawned closer than it could find the surface it leaves. The
     * profile's speed |ds| keeps the band from vanishing near the object's origin. */
    *p_error = (float3)(2e-5f * (length(*p) + size + length(ds))) + fabs(p_ray - *p);
}

inline Surface revsurface_object_surface(const Scene* sc, uint index, Hit hit, float3 o, float3 d,
                                         uint* transform) {
    __global const RevSurface* r = &sc->revsurfaces[index];
    Surface s;
    *transform = r->transform;
    s.material = r->material;
    float scale;
    to_object_space(sc, *transform, &o, &d, &scale);
    const float t = hit.t * scale;
    rev_surface(sc, r, hit, o + t * d, &s.p, &s.p_error, &s.n);
    s.ns = s.n;
    return s;
}

#endif
