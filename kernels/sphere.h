/* sphere.h: ray/sphere intersection (port of sphere.cuh).
 *
 * Reads: one Sphere. Writes: nothing. Why this form: the textbook quadratic loses every digit
 * of its discriminant when the sphere is large against the ray's distance to its centre
 * (smallpt's walls: radius 1e5). Following Ray Tracing Gems chapter 7 ("Precision improvements
 * for ray/sphere intersection", Haines et al.), the discriminant is r^2 - |f - (f.d)d|^2 and the
 * roots are q and c/q with q = -(b + sign(b) sqrt(disc)), so neither root subtracts nearly
 * equal numbers. The hit point is then projected back onto the sphere and its error bounded.
 */
#ifndef CLPT_SPHERE_H
#define CLPT_SPHERE_H

/* The nearest t in (0, t_max) where o + t d (d unit) meets the sphere, or t_max if none. */
inline float sphere_intersect(__global const Sphere* s, float3 o, float3 d, float t_max) {
    const float3 center = vload3(0, s->center);
    const float r = s->radius;
    const float3 f = o - center;
    const float b = dot(f, d);
    const float3 perp = f - b * d;
    const float disc = r * r - dot(perp, perp);
    if (disc < 0.0f) {
        return t_max;
    }
    const float c = dot(f, f) - r * r;
    const float q = -(b + copysign(sqrt(disc), b));
    float t0 = c / q;
    float t1 = q;
    if (t0 > t1) {
        const float tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > 0.0f && t0 < t_max) {
        return t0;
    }
    if (t1 > 0.0f && t1 < t_max) {
        return t1;
    }
    return t_max;
}

/* The refined hit point, its outward unit normal and a per-component bound on the point's
 * error, for a hit at parameter t. Projecting o + t d onto the sphere makes the error depend on
 * the sphere's size and place only, not on t: each component of c + r (p - c)/|p - c| carries
 * at most about seven roundings of |c_i| + r. */
inline void sphere_surface(__global const Sphere* s, float3 o, float3 d, float t, float3* p,
                           float3* n, float3* p_error) {
    const float3 center = vload3(0, s->center);
    const float3 rel = (o + t * d) - center;
    const float3 dir = rel * rsqrt(dot(rel, rel));
    *n = dir;
    *p = center + s->radius * dir;
    *p_error = error_gamma(7.0f) * (fabs(center) + s->radius);
}

#endif
