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

#include "types.h"
#include "vecmath.h"
#include "ray.h"

inline lfloat plane_intersect(__global const Plane* pl, LFloat3 o, LFloat3 d, lfloat t_max) {
    const float3 n = vload3(0, pl->normal);
    const lfloat denom = v3_dot(v3_splat(n), d);
    const lmask front = denom < 0.0f; /* not parallel, nor seen from behind */
    if (!lane_any(front)) {
        return t_max;
    }
    const lfloat t = (pl->offset - v3_dot(v3_splat(n), o)) / denom;
    const lmask nearer = front && t > 0.0f && t < t_max;
    if (!lane_any(nearer)) {
        return t_max; /* most planes lie behind the nearest hit so far */
    }
    const LFloat3 rel = v3_sub(v3_add(o, v3_scale(t, d)), v3_splat(vload3(0, pl->center)));
    const float range = pl->range;
    const lmask inside = !(fabs(rel.x) > range || fabs(rel.y) > range || fabs(rel.z) > range);
    return lselect(t_max, t, nearer && inside);
}

/* The hit point projected onto the plane (so its error does not grow with t), the normal, and
 * a bound on the point's error: the projection carries a few roundings of |p_i| + |offset|. */
inline void plane_surface(__global const Plane* pl, LFloat3 o, LFloat3 d, lfloat t, LFloat3* p,
                          LFloat3* n, LFloat3* p_error) {
    const LFloat3 normal = v3_splat(vload3(0, pl->normal));
    const LFloat3 raw = v3_add(o, v3_scale(t, d));
    *p = v3_sub(raw, v3_scale(v3_dot(normal, raw) - pl->offset, normal));
    *n = normal;
    *p_error = v3_scale(error_gamma(6.0f), v3_add_s(v3_fabs(*p), fabs(pl->offset)));
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
