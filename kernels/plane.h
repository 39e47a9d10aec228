/* plane.h: ray/plane intersection (port of plane.cuh).
 *
 * Reads: one Plane. Writes: nothing. The plane n.p = offset is one-sided, as the original's:
 * rays meet it only from the side n points to, which lets a scene keep smallpt's black front
 * wall while the camera looks through its back. It is limited to the points within `range` of
 * its centre in every coordinate (the original intersected through that bounding box only,
 * around n*offset).
 */
#ifndef CLPT_PLANE_H
#define CLPT_PLANE_H

inline float plane_intersect(__global const Plane* pl, float3 o, float3 d, float t_max) {
    const float3 n = vload3(0, pl->normal);
    const float denom = dot(n, d);
    if (!(denom < 0.0f)) {
        return t_max; /* parallel, or seen from behind */
    }
    const float t = (pl->offset - dot(n, o)) / denom;
    if (!(t > 0.0f && t < t_max)) {
        return t_max;
    }
    const float3 rel = o + t * d - vload3(0, pl->center);
    const float range = pl->range;
    if (fabs(rel.x) > range || fabs(rel.y) > range || fabs(rel.z) > range) {
        return t_max;
    }
    return t;
}

/* The hit point projected onto the plane (so its error does not grow with t), the normal, and
 * a bound on the point's error: the projection carries a few roundings of |p_i| + |offset|. */
inline void plane_surface(__global const Plane* pl, float3 o, float3 d, float t, float3* p,
                          float3* n, float3* p_error) {
    const float3 normal = vload3(0, pl->normal);
    const float3 raw = o + t * d;
    *p = raw - (dot(normal, raw) - pl->offset) * normal;
    *n = normal;
    *p_error = error_gamma(6.0f) * (fabs(*p) + fabs(pl->offset));
}

#if CLPT_TEXTURES
/* Texture coordinates, as the original's plane.cuh: the plane tiles from centerp along dirU
 * and dirV, whose lengths are the inverse tile sizes. */
inline float2 plane_uv(__global const Plane* pl, float3 p) {
    const float3 rel = p - vload3(0, pl->centerp);
    return (float2)(frac_unit(dot(rel, vload3(0, pl->dir_u))),
                    frac_unit(dot(rel, vload3(0, pl->dir_v))));
}

inline void plane_tangents(__global const Plane* pl, float3* dpdu, float3* dpdv) {
    *dpdu = normalize(vload3(0, pl->dir_u));
    *dpdv = normalize(vload3(0, pl->dir_v));
}
#endif

#endif
