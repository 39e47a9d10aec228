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

#if CLPT_MESHES
/* The vertices of each lane's triangle of mesh m (at width 1 the hit's; wider, those of the
 * lanes in `lanes`, others left 0), or of its vertex normals (`normals` for `vertices`). */
#if CLPT_WIDE
inline void mesh_triangle(const Scene* sc, __global const MeshDesc* m, __global const float* at,
                          luint prim, lmask lanes, LFloat3* v0, LFloat3* v1, LFloat3* v2) {
    *v0 = *v1 = *v2 = v3_splat((float3)(0.0f));
    for (uint lane = 0u; lane < CLPT_LANES; ++lane) {
        if (lane_on(lanes, lane)) {
            const uint3 v =
                vload3(m->first_triangle + lane_uint(prim, lane), sc->triangles) + m->first_vertex;
            lane_set_float3(v0, lane, vload3(v.x, at));
            lane_set_float3(v1, lane, vload3(v.y, at));
            lane_set_float3(v2, lane, vload3(v.z, at));
        }
    }
}
#else
#define mesh_triangle(sc, m, at, prim, lanes, v0, v1, v2)                                   \
    do {                                                                                     \
        const uint3 v_ = vload3((m)->first_triangle + (prim), (sc)->triangles) +             \
                         (m)->first_vertex;                                                  \
        *(v0) = vload3(v_.x, (at));                                                          \
        *(v1) = vload3(v_.y, (at));                                                          \
        *(v2) = vload3(v_.z, (at));                                                          \
    } while (0)
#endif

/* A mesh hit's surface in the mesh's space, in each lane of `lanes` that hit it: p = b0 v0 + b1
 * v1 + b2 v2 with pbrt-v4's bound gamma(7) (|b0 v0| + |b1 v1| + |b2 v2|), the face normal, and
 * the interpolated vertex normal turned to the face normal's side when the mesh has normals. */
inline void mesh_surface(const Scene* sc, __global const MeshDesc* m, Hit hit, lmask lanes,
                         LFloat3* p, LFloat3* p_error, LFloat3* n, LFloat3* ns) {
    LFloat3 v0, v1, v2;
    mesh_triangle(sc, m, sc->vertices, hit.prim, lanes, &v0, &v1, &v2);
    const lfloat b0 = 1.0f - hit.b1 - hit.b2;
    *p = v3_add(v3_add(v3_scale(b0, v0), v3_scale(hit.b1, v1)), v3_scale(hit.b2, v2));
    *p_error = v3_scale(error_gamma(7.0f), v3_add(v3_add(v3_fabs(v3_scale(b0, v0)),
                                                         v3_fabs(v3_scale(hit.b1, v1))),
                                                  v3_fabs(v3_scale(hit.b2, v2))));
    *n = v3_normalize(v3_cross(v3_sub(v1, v0), v3_sub(v2, v0)));
    *ns = *n;
    if (m->has_normals) {
        LFloat3 n0, n1, n2;
        mesh_triangle(sc, m, sc->normals, hit.prim, lanes, &n0, &n1, &n2);
        const LFloat3 s =
            v3_add(v3_add(v3_scale(b0, n0), v3_scale(hit.b1, n1)), v3_scale(hit.b2, n2));
        const lfloat len = v3_length(s);
        *ns = v3_select(*ns, v3_div(s, lselect(len, -len, v3_dot(s, *n) < 0.0f)), len > 0.0f);
    }
}
#endif

#if CLPT_SPHERES
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

#if CLPT_PLANES
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

#if CLPT_MESHES
/* In the lanes that hit instance `index`. */
inline Surface mesh_object_surface(const Scene* sc, uint index, Hit hit, LFloat3 o, LFloat3 d,
                                   uint* transform) {
    __global const MeshInstance* inst = &sc->mesh_instances[index];
    Surface s;
    *transform = inst->transform;
    s.material = inst->material;
    mesh_surface(sc, &sc->meshes[inst->mesh], hit, hit.kind == OBJECT_MESH && hit.index == index,
                 &s.p, &s.p_error, &s.n, &s.ns);
    return s;
}
#endif

#if CLPT_REVSURFACES
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
