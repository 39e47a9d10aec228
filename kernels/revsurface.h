/* revsurface.h: ray/surface-of-revolution intersection (port of revsurface.cuh).
 *
 * Reads: one RevSurface and its Bezier segments (control points (x, y), degree+1 per segment;
 * the host turns B-splines into Bezier segments). Writes: nothing. The surface is
 * S(u, theta) = (x(u) cos theta, y(u), x(u) sin theta), the profile revolved about the y axis.
 *
 * Why this way: the original started Newton's method from 30 random (u, theta) pairs per ray
 * and still missed hits. Here the search is deterministic: for each segment, sub-segments are
 * visited by recursive halving, and a sub-segment is discarded only when the ray provably
 * cannot meet the solid of revolution of its control polygon's hull (an annulus of radii
 * [r_min, r_max] between heights [y_min, y_max]: the ray's height interval there, and the
 * quadratic r^2(t) on that interval, must meet it). Sub-segments small enough are solved by a
 * two-dimensional Newton iteration on (t, u):
 *   g1 = y(u) - (o.y + t d.y) = 0,   g2 = (o.x + t d.x)^2 + (o.z + t d.z)^2 - x(u)^2 = 0,
 * which needs no special case for horizontal rays (Kajiya 1983 reduces the problem to u the
 * same way).
 */
#ifndef CLPT_REVSURFACE_H
#define CLPT_REVSURFACE_H

#define REV_MAX_DEGREE 7
#define REV_STACK 32
#define REV_LEAF_DEPTH 7      /* sub-segments of 1/128 of a segment are solved directly */
#define REV_MAX_DEPTH 10      /* where that finds nothing but the hull still admits the ray,
                               * halving goes on down to 1/1024 */
#define REV_NEWTON_STEPS 12

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

/* The hull box (x_lo, x_hi, y_lo, y_hi) of the sub-curve on [u0, u1] (de Casteljau splits). */
inline float4 bezier_hull(__global const float2* p, uint n, float u0, float u1) {
    float2 b[REV_MAX_DEGREE + 1];
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
    float4 box = (float4)(b[0].x, b[0].x, b[0].y, b[0].y);
    for (uint i = 1u; i <= n; ++i) {
        box = (float4)(fmin(box.x, b[i].x), fmax(box.y, b[i].x), fmin(box.z, b[i].y),
                       fmax(box.w, b[i].y));
    }
    return box;
}

/* Can the ray, for t in (t_lo, t_hi), come into the solid of revolution of this box? */
inline bool annulus_reachable(float4 box, float3 o, float3 d, float t_lo, float t_hi) {
    /* A little slack for the rounding of the hull and of r^2(t). */
    const float pad = 1e-5f * (fabs(box.y) + fabs(box.x) + fabs(box.z) + fabs(box.w)) + 1e-30f;
    float t0 = t_lo, t1 = t_hi;
    if (d.y != 0.0f) {
        const float ta = (box.z - pad - o.y) / d.y;
        const float tb = (box.w + pad - o.y) / d.y;
        t0 = fmax(t0, fmin(ta, tb));
        t1 = fmin(t1, fmax(ta, tb));
    } else if (o.y < box.z - pad || o.y > box.w + pad) {
        return false;
    }
    if (!(t0 <= t1)) {
        return false;
    }
    const float r_hi = fmax(fabs(box.x), fabs(box.y)) + pad;
    const float r_lo = (box.x > 0.0f || box.y < 0.0f) ? fmax(0.0f, fmin(fabs(box.x), fabs(box.y)) - pad)
                                                     : 0.0f;
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

/* Newton on (t, u) from the middle of [u0, u1]; true with the root when it converges inside
 * [u0, u1] x (0, t_max). In f32 the residuals carry rounding noise of about 1e-7 of the
 * magnitudes involved, so steps may never shrink below that: the iteration stops on a step
 * small against the interval, and the root is judged by its residuals, scaled to the size of
 * the terms they cancel. */
inline bool rev_newton(__global const float2* p, uint n, float3 o, float3 d, float u0, float u1,
                       float t_guess, float t_max, float* t_out, float* u_out) {
    float u = 0.5f * (u0 + u1);
    float t = t_guess;
    float g1 = 0.0f, g2 = 0.0f;
    float2 s = (float2)(0.0f), ds = (float2)(0.0f);
    for (int i = 0; i < REV_NEWTON_STEPS; ++i) {
        bezier_eval(p, n, u, &s, &ds);
        /* r^2 of the ray point evaluated directly, not as a t^2 + b t + c, which cancels
         * near the axis. */
        const float qx = o.x + t * d.x, qz = o.z + t * d.z;
        g1 = s.y - (o.y + t * d.y);
        g2 = qx * qx + qz * qz - s.x * s.x;
        /* Jacobian [[dg1/dt, dg1/du], [dg2/dt, dg2/du]]. */
        const float j11 = -d.y, j12 = ds.y;
        const float j21 = 2.0f * (qx * d.x + qz * d.z), j22 = -2.0f * s.x * ds.x;
        const float det = j11 * j22 - j12 * j21;
        if (det == 0.0f || !isfinite(det)) {
            return false;
        }
        const float dt = (g1 * j22 - g2 * j12) / det;
        const float du = (g2 * j11 - g1 * j21) / det;
        t -= dt;
        u -= du;
        if (!isfinite(t) || !isfinite(u) || u < u0 - (u1 - u0) || u > u1 + (u1 - u0)) {
            return false; /* left the neighbourhood: that root is another leaf's */
        }
        if (fabs(du) < 1e-6f * (u1 - u0) && fabs(dt) < 1e-6f * fmax(1.0f, fabs(t))) {
            break;
        }
    }
    bezier_eval(p, n, u, &s, &ds);
    const float qx = o.x + t * d.x, qz = o.z + t * d.z;
    g1 = s.y - (o.y + t * d.y);
    g2 = qx * qx + qz * qz - s.x * s.x;
    const float y_scale = fabs(s.y) + fabs(o.y) + fabs(t * d.y) + 1e-30f;
    const float r_scale = qx * qx + qz * qz + s.x * s.x + 1e-30f;
    if (fabs(g1) > 1e-5f * y_scale || fabs(g2) > 1e-5f * r_scale) {
        return false;
    }
    if (u < u0 || u > u1 || !(t > 0.0f && t < t_max)) {
        return false;
    }
    *t_out = t;
    *u_out = u;
    return true;
}

/* For rays that change height: f(u) = r^2 of the ray at the height y(u), minus x(u)^2. */
inline float rev_height_residual(__global const float2* p, uint n, float3 o, float3 d, float u,
                                 float* t) {
    float2 s, ds;
    bezier_eval(p, n, u, &s, &ds);
    *t = (s.y - o.y) / d.y;
    const float3 q = o + *t * d;
    return q.x * q.x + q.z * q.z - s.x * s.x;
}

/* Where Newton cannot converge (the profile's speed vanishes: repeated control points where
 * it meets the axis, flat parts), a sign change of f over the leaf still brackets a root:
 * bisection finds it whatever the parameterisation. */
inline bool rev_bisect(__global const float2* p, uint n, float3 o, float3 d, float u0, float u1,
                       float t_max, float* t_out, float* u_out) {
    float ta, tb;
    float fa = rev_height_residual(p, n, o, d, u0, &ta);
    const float fb = rev_height_residual(p, n, o, d, u1, &tb);
    if (!(fa * fb <= 0.0f)) {
        return false;
    }
    float lo = u0, hi = u1, t = ta;
    for (int i = 0; i < 32; ++i) {
        const float mid = 0.5f * (lo + hi);
        const float fm = rev_height_residual(p, n, o, d, mid, &t);
        if ((fm <= 0.0f) == (fa <= 0.0f)) {
            lo = mid;
            fa = fm;
        } else {
            hi = mid;
        }
    }
    const float u = 0.5f * (lo + hi);
    rev_height_residual(p, n, o, d, u, &t);
    if (!(t > 0.0f && t < t_max)) {
        return false;
    }
    *t_out = t;
    *u_out = u;
    return true;
}

/* The nearest hit in (0, t_max) of o + t d (d unit) with the surface: t, or t_max if none;
 * *seg and *u_hit say where on the profile. */
inline float revsurface_intersect(__global const RevSurface* rs, __global const float2* points,
                                  float3 o, float3 d, float t_max, uint* seg, float* u_hit) {
    const uint n = rs->degree;
    float t_best = t_max;
    for (uint k = 0u; k < rs->num_segments; ++k) {
        __global const float2* p = points + rs->first_point + k * (n + 1u);
        float2 stack[REV_STACK]; /* (u0, u1) */
        uchar depth[REV_STACK];
        int top = 0;
        stack[0] = (float2)(0.0f, 1.0f);
        depth[0] = 0;
        top = 1;
        while (top > 0) {
            --top;
            const float2 iv = stack[top];
            const uchar dep = depth[top];
            const float4 box = bezier_hull(p, n, iv.x, iv.y);
            if (!annulus_reachable(box, o, d, 0.0f, t_best)) {
                continue;
            }
            const float t_before = t_best;
            if (dep >= REV_LEAF_DEPTH || top + 2 > REV_STACK) {
                /* Starting points: where the ray is at the sub-segment's middle height, and
                 * where it enters and leaves the cylinder of the middle's radius (the only
                 * good guesses for rays that keep their height). The nearest root wins. */
                float2 mid, dmid;
                bezier_eval(p, n, 0.5f * (iv.x + iv.y), &mid, &dmid);
                const float a = d.x * d.x + d.z * d.z;
                const float b = 2.0f * (o.x * d.x + o.z * d.z);
                const float c = o.x * o.x + o.z * o.z - mid.x * mid.x;
                const float disc = b * b - 4.0f * a * c;
                float guesses[3];
                int count = 0;
                if (d.y != 0.0f) {
                    guesses[count++] = (mid.y - o.y) / d.y;
                }
                if (a > 0.0f && disc >= 0.0f) {
                    const float q = -0.5f * (b + copysign(sqrt(disc), b));
                    guesses[count++] = q / a;
                    if (q != 0.0f) {
                        guesses[count++] = c / q;
                    }
                }
                bool found = false;
                for (int g = 0; g < count; ++g) {
                    float th, uh;
                    if (rev_newton(p, n, o, d, iv.x, iv.y, guesses[g], t_best, &th, &uh)) {
                        t_best = th;
                        *seg = k;
                        *u_hit = uh;
                        found = true;
                    }
                }
                float th, uh;
                if (fabs(d.y) > 1e-3f) {
                    if (!found) {
                        if (rev_bisect(p, n, o, d, iv.x, iv.y, t_best, &th, &uh)) {
                            t_best = th;
                            *seg = k;
                            *u_hit = uh;
                        }
                    } else if (*seg == k) {
                        /* Two roots in one leaf (a ray clipping a bulge): Newton found one;
                         * a sign change on either side of it brackets the other, which
                         * wins if it is nearer. */
                        const float ur = *u_hit;
                        const float gap = 1e-4f * (iv.y - iv.x);
                        if (ur - gap > iv.x &&
                            rev_bisect(p, n, o, d, iv.x, ur - gap, t_best, &th, &uh)) {
                            t_best = th;
                            *u_hit = uh;
                        } else if (ur + gap < iv.y &&
                                   rev_bisect(p, n, o, d, ur + gap, iv.y, t_best, &th, &uh)) {
                            t_best = th;
                            *u_hit = uh;
                        }
                    }
                }
                /* Nothing here although the hull admits the ray: two roots too close for
                 * Newton and bisection (a ray clipping a bulge), or a ray just missing. Look
                 * closer, down to REV_MAX_DEPTH. */
                const bool nothing = t_best == t_before;
                if (!(nothing && dep < REV_MAX_DEPTH && top + 2 <= REV_STACK)) {
                    continue;
                }
            }
            const float um = 0.5f * (iv.x + iv.y);
            stack[top] = (float2)(um, iv.y);
            depth[top] = dep + 1;
            ++top;
            stack[top] = (float2)(iv.x, um);
            depth[top] = dep + 1;
            ++top;
        }
    }
    return t_best;
}

#endif
