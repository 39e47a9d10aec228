/* sphere.h: ray/sphere intersection (port of sphere.cuh).
 *
 * Reads: one Sphere. Writes: nothing. Why this form: the textbook quadratic loses every digit
 * of its discriminant when the sphere is large against the ray's distance to its centre
 * (smallpt's walls: radius 1e5). Following Ray Tracing Gems chapter 7 ("Precision improvements
 * for ray/sphere intersection", Haines et al.), the discriminant is r^2 - |f - (f.d)d|^2 and the
 * roots are q and c/q with q = -(b + sign(b) sqrt(disc)), so neither root subtracts nearly
 * equal numbers. The constant term c = |o - c|^2 - r^2 is what decides whether a ray leaving
 * the surface sees the surface again; it is computed in double-float arithmetic
 * (sphere_excess in ray.h), so a spawned origin only a few ulps of itself away from a sphere of
 * radius 1e5 is still reliably on the right side. The hit point is refined by one Newton step
 * onto the sphere and its error bounded.
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
    const float c = sphere_excess(o, center, vload3(0, s->center_lo), r, s->radius_lo);
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
 * error, for a hit at parameter t. One Newton step along the normal removes the signed
 * distance delta = (|p - c|^2 - r^2) / (|p - c| + r), computed in double-float, so the point's
 * error is a few roundings of its own coordinates (and of delta), not of |c| + r: on smallpt's
 * walls 2e-5 instead of 0.08, which matters where its light is sunk only 0.27 into the ceiling. */
inline void sphere_surface(__global const Sphere* s, float3 o, float3 d, float t, float3* p,
                           float3* n, float3* p_error) {
    const float3 center = vload3(0, s->center);
    const float r = s->radius;
    const float3 raw = o + t * d;
    const float3 rel = raw - center;
    const float dist = length(rel);
    const float3 normal = rel / dist;
    const float delta =
        sphere_excess(raw, center, vload3(0, s->center_lo), r, s->radius_lo) / (dist + r);
    *n = normal;
    *p = raw - delta * normal;
    const float u = 0x1.0p-24f;
    *p_error = error_gamma(4.0f) * (fabs(*p) + fabs(delta)) + 64.0f * u * u * (length(center) + 2.0f * r);
}

#if CLPT_TEXTURES
/* Texture coordinates from the unit outward normal, as the original's sphere.cuh:
 * u = atan2(n.x, n.z) / 2pi + 1/2 (longitude, 1/2 towards +z), v = n.y / 2 + 1/2 (linear in
 * height: the south pole is v = 0, the north pole v = 1). */
inline float2 sphere_uv(float3 n) {
    return (float2)(atan2(n.x, n.z) * (0.5f / M_PI_F) + 0.5f, n.y * 0.5f + 0.5f);
}

/* Unit surface directions of increasing u (east) and v (north) at unit normal n. At a pole,
 * where east is undefined, the directions of longitude u = 1/2 are taken: east = +x, north =
 * -z at the north pole and +z at the south pole. */
inline void sphere_tangents(float3 n, float3* dpdu, float3* dpdv) {
    const float rho = sqrt(n.x * n.x + n.z * n.z);
    if (rho < 1e-7f) {
        *dpdu = (float3)(1.0f, 0.0f, 0.0f);
        *dpdv = (float3)(0.0f, 0.0f, n.y > 0.0f ? -1.0f : 1.0f);
        return;
    }
    *dpdu = (float3)(n.z, 0.0f, -n.x) / rho;
    *dpdv = (float3)(-n.y * n.x / rho, rho, -n.y * n.z / rho);
}
#endif

#endif
