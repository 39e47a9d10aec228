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

#include "types.h"
#include "vecmath.h"
#include "ray.h"
#include "scene.h"

/* The nearest t in (0, t_max) where o + t d (d unit) meets the sphere, or t_max if none. */
inline lfloat sphere_intersect(__global const Sphere* s, LFloat3 o, LFloat3 d, lfloat t_max) {
    const float3 center = vload3(0, s->center);
    const float r = s->radius;
    const LFloat3 f = v3_sub(o, v3_splat(center));
    const lfloat b = v3_dot(f, d);
    const LFloat3 perp = v3_sub(f, v3_scale(b, d));
    const lfloat disc = r * r - v3_dot(perp, perp);
    const lmask miss = disc < 0.0f;
    if (lane_all(miss)) {
        return t_max;
    }
    const lfloat c = sphere_excess(o, center, vload3(0, s->center_lo), r, s->radius_lo);
    const lfloat q = -(b + copysign(sqrt(disc), b));
    const lfloat t0 = c / q, t1 = q;
    const lmask swap = t0 > t1;
    const lfloat t_near = lselect(t0, t1, swap), t_far = lselect(t1, t0, swap);
    const lfloat t = lselect(lselect(t_max, t_far, t_far > 0.0f && t_far < t_max), t_near,
                             t_near > 0.0f && t_near < t_max);
    return lselect(t, t_max, miss);
}

/* The refined hit point, its outward unit normal and a per-component bound on the point's
 * error, for a hit at parameter t. One Newton step along the normal removes the signed
 * distance delta = (|p - c|^2 - r^2) / (|p - c| + r), computed in double-float, so the point's
 * error is a few roundings of its own coordinates (and of delta), not of |c| + r: on smallpt's
 * walls 2e-5 instead of 0.08, which matters where its light is sunk only 0.27 into the ceiling. */
inline void sphere_surface(__global const Sphere* s, LFloat3 o, LFloat3 d, lfloat t, LFloat3* p,
                           LFloat3* n, LFloat3* p_error) {
    const float3 center = vload3(0, s->center);
    const float r = s->radius;
    const LFloat3 raw = v3_add(o, v3_scale(t, d));
    const LFloat3 rel = v3_sub(raw, v3_splat(center));
    const lfloat dist = v3_length(rel);
    const LFloat3 normal = v3_div(rel, dist);
    const lfloat delta =
        sphere_excess(raw, center, vload3(0, s->center_lo), r, s->radius_lo) / (dist + r);
    *n = normal;
    *p = v3_sub(raw, v3_scale(delta, normal));
    const float u = 0x1.0p-24f;
    *p_error = v3_add_s(v3_scale(error_gamma(4.0f), v3_add_s(v3_fabs(*p), fabs(delta))),
                        64.0f * u * u * (length(center) + 2.0f * r));
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

/* The kind's three functions of SHAPES(X) (types.h; kernels/shapes.h dispatches through them):
 * one object's hit, every object's without the object BVH, the surface at a hit. */
inline void sphere_object_intersect(const Scene* sc, uint index, LFloat3 o, LFloat3 d, Hit* hit) {
    __global const Sphere* s = &sc->spheres[index];
    lfloat scale;
    to_object_space(sc, s->transform, &o, &d, &scale);
    const lfloat t_max = hit->t * scale;
    keep_hit(hit, sphere_intersect(s, o, d, t_max), t_max, scale, OBJECT_SPHERE, index);
}

inline void sphere_intersect_all(const Scene* sc, LFloat3 o, LFloat3 d, Hit* hit) {
    for (uint i = 0u; i < sc->params->counts[OBJECT_SPHERE]; ++i) {
        sphere_object_intersect(sc, i, o, d, hit);
    }
}

inline Surface sphere_object_surface(const Scene* sc, uint index, Hit hit, LFloat3 o, LFloat3 d,
                                     uint* transform) {
    __global const Sphere* sp = &sc->spheres[index];
    Surface s;
    *transform = sp->transform;
    s.material = sp->material;
    lfloat scale;
    to_object_space(sc, *transform, &o, &d, &scale);
    sphere_surface(sp, o, d, hit.t * scale, &s.p, &s.n, &s.p_error);
    s.ns = s.n;
    return s;
}

#endif
