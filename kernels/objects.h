/* objects.h: the nearest hit among the scene's objects and the surface there (port of
 * objects.cuh).
 *
 * Reads: every scene buffer, through the Scene struct (shapes.h). Writes: nothing.
 * Why: the path tracer asks one question, "what does this ray hit first", through the object
 * BVH (bvh.h) or, with few objects, kind by kind (shapes.h), and then needs the surface only of
 * the winner.
 */
#ifndef CLPT_OBJECTS_H
#define CLPT_OBJECTS_H

#include "shapes.h"
#if CLPT_BVH
#include "bvh.h"
#endif

/* The nearest hit of the ray o + t d with t < t_max, or kind OBJECT_NONE. */
inline Hit scene_intersect_until(const Scene* sc, LFloat3 o, LFloat3 d, lfloat t_max) {
    Hit hit;
    hit.t = t_max;
    hit.kind = hit.index = hit.prim = (luint)(OBJECT_NONE);
    hit.b1 = hit.b2 = (lfloat)(0.0f);
#if CLPT_BVH
    bvh_intersect(sc, o, d, &hit);
#else
    /* Kind by kind, so all work-items run the same code at the same time. */
#define SHAPE_INTERSECT_ALL(KIND, name) name##_intersect_all(sc, o, d, &hit);
    SHAPES(SHAPE_INTERSECT_ALL)
#undef SHAPE_INTERSECT_ALL
#endif
    return hit;
}

/* The nearest hit of the ray o + t d, t > 0. */
inline Hit scene_intersect(const Scene* sc, LFloat3 o, LFloat3 d) {
    return scene_intersect_until(sc, o, d, (lfloat)(INFINITY));
}

/* The surface of object (kind, index) where the rays (o, d) hit it at hit.t: its kind's, taken
 * to world space by its transform. */
inline Surface object_surface(const Scene* sc, uint kind, uint index, Hit hit, LFloat3 o,
                              LFloat3 d) {
    Surface s;
    uint transform = TRANSFORM_NONE;
#define SHAPE_SURFACE(KIND, name)                                                               \
    if (kind == KIND) {                                                                      \
        s = name##_object_surface(sc, index, hit, o, d, &transform);                         \
    }
    SHAPES(SHAPE_SURFACE)
#undef SHAPE_SURFACE
    s.p_local = s.p;
    s.n_local = s.n;
    s.transform = transform;
#if CLPT_TRANSFORMS
    if (transform != TRANSFORM_NONE) {
        __global const Transform* x = &sc->transforms[transform];
        s.p_error = xform_point_error(x->m, s.p, s.p_error);
        s.p = xform_point(x->m, s.p);
        s.n = xform_normal(x->inv, s.n);
        s.ns = xform_normal(x->inv, s.ns);
    }
#endif
    return s;
}

/* The surface at each lane's hit (rays (o, d)). */
inline Surface scene_surface(const Scene* sc, Hit hit, LFloat3 o, LFloat3 d) {
#if CLPT_WIDE
    /* Lanes that hit one object share its data: one pass per object that some lane hit (a
     * wide program's few objects: no BVH). Lanes that hit nothing keep zeros. */
    Surface s;
    s.p = s.p_error = s.n = s.ns = s.p_local = s.n_local = v3_splat((float3)(0.0f));
    s.material = s.transform = (luint)(0u);
    lmask pending = hit.kind != OBJECT_NONE;
    while (lane_any(pending)) {
        const uint lane = lane_first(pending);
        const uint kind = lane_uint(hit.kind, lane), index = lane_uint(hit.index, lane);
        const lmask same = pending && hit.kind == kind && hit.index == index;
        const Surface one = object_surface(sc, kind, index, hit, o, d);
        s.p = v3_select(s.p, one.p, same);
        s.p_error = v3_select(s.p_error, one.p_error, same);
        s.n = v3_select(s.n, one.n, same);
        s.ns = v3_select(s.ns, one.ns, same);
        s.p_local = v3_select(s.p_local, one.p_local, same);
        s.n_local = v3_select(s.n_local, one.n_local, same);
        s.material = select(s.material, one.material, same);
        s.transform = select(s.transform, one.transform, same);
        pending = pending && !same;
    }
    return s;
#else
    return object_surface(sc, hit.kind, hit.index, hit, o, d);
#endif
}


#if CLPT_TEXTURES
/* Where a hit falls on its object's texture: (u, v) and the world directions of increasing u
 * and v (for bump maps). Meshes carry no texture coordinates (the loader refuses maps on them). */
inline float2 scene_mapping(const Scene* sc, Hit hit, Surface s, float3* dpdu, float3* dpdv) {
    float2 uv = (float2)(0.0f, 0.0f);
    *dpdu = (float3)(1.0f, 0.0f, 0.0f);
    *dpdv = (float3)(0.0f, 1.0f, 0.0f);
#if CLPT_SPHERES
    if (hit.kind == OBJECT_SPHERE) {
        sphere_tangents(s.n_local, dpdu, dpdv);
        uv = sphere_uv(s.n_local);
    }
#endif
#if CLPT_PLANES
    if (hit.kind == OBJECT_PLANE) {
        plane_tangents(&sc->planes[hit.index], dpdu, dpdv);
        uv = plane_uv(&sc->planes[hit.index], s.p_local);
    }
#endif
#if CLPT_TRANSFORMS
    if (s.transform != TRANSFORM_NONE && (hit.kind == OBJECT_SPHERE || hit.kind == OBJECT_PLANE)) {
        __global const float* m = sc->transforms[s.transform].m;
        *dpdu = normalize(xform_vector(m, *dpdu));
        *dpdv = normalize(xform_vector(m, *dpdv));
    }
#endif
    return uv;
}
#endif

#endif
