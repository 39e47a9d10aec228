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
#include "scene.h"

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

/* The kind's three functions of SHAPES(X) (types.h; kernels/shapes.h dispatches through them):
 * one object's hit, every object's without the object BVH, the surface at a hit. */
inline void plane_object_intersect(const Scene* sc, uint index, LFloat3 o, LFloat3 d, Hit* hit) {
    __global const Plane* p = &sc->planes[index];
    lfloat scale;
    to_object_space(sc, p->transform, &o, &d, &scale);
    const lfloat t_max = hit->t * scale;
    keep_hit(hit, plane_intersect(p, o, d, t_max), t_max, scale, OBJECT_PLANE, index);
}

#if CLPT_WALLS
/* The walls (RenderParams.walls, chosen by the host: src/pack/mod.rs, `walls`): untransformed
 * planes whose normal is an axis, one per axis and sign. A one-sided plane meets only rays
 * moving against its normal (plane.h), so of an axis's two walls a ray can meet only the one
 * it moves towards, and each lane tests that one: three tests where a room's six walls took
 * six (PoCL, 16 lanes: the dragon room 8% less user CPU; BENCHMARKS.md, "Walls"). Each
 * test is plane_intersect's on the lane's wall: with the normal +-e_k, n.o and n.d are +-o_k
 * and +-d_k exactly, so t and the range test round as there, and the hits are the same bits.
 * Hits at equal t go to the walls, tested before the other planes. */
inline void walls_intersect(const Scene* sc, LFloat3 o, LFloat3 d, Hit* hit) {
    __global const RenderParams* params = sc->params;
    for (uint k = 0u; k < 3u; ++k) {
        const uint up = params->walls[2u * k], down = params->walls[2u * k + 1u];
        if (up == WALL_NONE && down == WALL_NONE) {
            continue;
        }
        const lfloat dk = k == 0u ? d.x : (k == 1u ? d.y : d.z);
        const lfloat ok = k == 0u ? o.x : (k == 1u ? o.y : o.z);
        /* The wall whose normal is +e_k meets the lanes moving towards -e_k. */
        const lmask towards_up = dk < 0.0f;
        const lmask has_wall = lselect((lmask)(down != WALL_NONE), (lmask)(up != WALL_NONE),
                                       towards_up);
        /* An empty slot reads the other's plane, which the mask then ignores. */
        __global const Plane* pu = &sc->planes[up != WALL_NONE ? up : down];
        __global const Plane* pd = &sc->planes[down != WALL_NONE ? down : up];
        const lfloat sign = lselect((lfloat)(-1.0f), (lfloat)(1.0f), towards_up);
        const lfloat denom = sign * dk;
        const lfloat offset = lselect((lfloat)(pd->offset), (lfloat)(pu->offset), towards_up);
        const lfloat t = (offset - sign * ok) / denom;
        const lmask nearer = has_wall && denom < 0.0f && t > 0.0f && t < hit->t;
        if (!lane_any(nearer)) {
            continue;
        }
        const LFloat3 center = v3_select(v3_splat(vload3(0, pd->center)),
                                         v3_splat(vload3(0, pu->center)), towards_up);
        const lfloat range = lselect((lfloat)(pd->range), (lfloat)(pu->range), towards_up);
        const LFloat3 rel = v3_sub(v3_add(o, v3_scale(t, d)), center);
        const lmask keep =
            nearer && !(fabs(rel.x) > range || fabs(rel.y) > range || fabs(rel.z) > range);
        hit->t = lselect(hit->t, t, keep);
        hit->kind = lselect(hit->kind, (luint)(OBJECT_PLANE), keep);
        hit->index = lselect(hit->index, lselect((luint)(down), (luint)(up), towards_up), keep);
    }
}
#endif

/* The walls first (where CLPT_WALLS), then every other plane. */
inline void plane_intersect_all(const Scene* sc, LFloat3 o, LFloat3 d, Hit* hit) {
#if CLPT_WALLS
    walls_intersect(sc, o, d, hit);
#endif
    for (uint i = 0u; i < sc->params->counts[OBJECT_PLANE]; ++i) {
#if CLPT_WALLS
        if (i < 32u && ((sc->params->wall_mask >> i) & 1u) != 0u) {
            continue; /* a wall, tested above */
        }
#endif
        plane_object_intersect(sc, i, o, d, hit);
    }
}

inline Surface plane_object_surface(const Scene* sc, uint index, Hit hit, LFloat3 o, LFloat3 d,
                                    uint* transform) {
    __global const Plane* pl = &sc->planes[index];
    Surface s;
    *transform = pl->transform;
    s.material = pl->material;
    lfloat scale;
    to_object_space(sc, *transform, &o, &d, &scale);
    plane_surface(pl, o, d, hit.t * scale, &s.p, &s.n, &s.p_error);
    s.ns = s.n;
    return s;
}

#endif
