/* mesh.h: triangle meshes as objects of the scene (port of mesh.cuh's mesh intersection): an
 * instance's ray taken to the mesh's space, the walk through its tree (the binary BVH of
 * bvh2.h on GPUs, the 8-wide BVH of wide_bvh.h on CPUs, or the original's kd-tree of kdtree.h)
 * and the surface at a triangle's hit.
 *
 * Reads: MeshInstance, MeshDesc, the trees, triangles, vertices and normals. Writes: nothing.
 * Why: a mesh is placed by its instance's transform, so one tree serves every instance; the
 * direction is not normalised there, so t is the same in both spaces.
 */
#ifndef CLPT_MESH_H
#define CLPT_MESH_H

#include "scene.h"
#include "aabb.h"
#include "triangle.h"
#if CLPT_WIDE_BVH
#include "wide_bvh.h"
#else
#if CLPT_BVH2
#include "bvh2.h"
#else
#include "kdtree.h"
#endif
#endif

/* The ray (o, d) in the space of mesh instance inst: its inverse transform applied, the
 * direction not normalised (transform.h), so t is the same in both spaces. */
inline void to_mesh_space(const Scene* sc, __global const MeshInstance* inst, LFloat3* o,
                          LFloat3* d) {
#if CLPT_TRANSFORMS
    if (inst->transform != TRANSFORM_NONE) {
        __global const float* inv = sc->transforms[inst->transform].inv;
        *o = xform_point(inv, *o);
        *d = xform_vector(inv, *d);
    }
#endif
}

/* Updates hit t, prim, b1, b2 with the nearest hit in (0, *t) of o + t d, in mesh m's space,
 * through its tree: the 8-wide BVH (wide_bvh.h), the binary BVH (bvh2.h) or the kd-tree
 * (kdtree.h), as CLPT_WIDE_BVH and CLPT_BVH2 say; whether there was one. */
inline bool mesh_tree_intersect(const Scene* sc, __global const MeshDesc* m, float3 o, float3 d,
                                float* t, uint* prim, float* b1, float* b2) {
#if CLPT_WIDE_BVH
    return wide_bvh_intersect(m, (__global const WideBvhNode*)sc->kd_nodes, sc->kd_indices,
                              sc->vertices, o, d, t, prim, b1, b2);
#else
#if CLPT_BVH2
    return bvh2_intersect(m, (__global const Bvh2Node*)sc->kd_nodes,
                          (__global const Bvh2Triangle*)sc->kd_indices, o, d, t, prim, b1, b2);
#else
    return kdtree_intersect(m, sc->kd_nodes, sc->kd_indices, sc->vertices, o, d, t, prim, b1,
                            b2);
#endif
#endif
}


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

/* The kind's three functions of SHAPES(X) (types.h; kernels/shapes.h dispatches through them):
 * one object's hit, every object's without the object BVH, the surface at a hit. */
#if CLPT_WIDE
/* Each lane's ray against mesh instance `index`, the lanes whose nearest hit so far (hit->t)
 * is positive: those that enter the mesh's box walk its 8-wide BVH one after another
 * (wide_bvh.h: a ray's eight boxes a node on float8); the rest of the path runs on all lanes.
 * Lanes with hit->t = 0 ask nothing. */
inline void mesh_object_intersect(const Scene* sc, uint index, LFloat3 o, LFloat3 d, Hit* hit) {
    __global const MeshInstance* inst = &sc->mesh_instances[index];
    __global const MeshDesc* m = &sc->meshes[inst->mesh];
    LFloat3 lo = o, ld = d;
    to_mesh_space(sc, inst, &lo, &ld);
    lfloat t0 = 0.0f, t1 = hit->t;
    const lmask enters = hit->t > 0.0f &&
                         aabb_clip_lanes(vload3(0, m->lo), vload3(0, m->hi), lo,
                                         make_lfloat3(slab_inverse_lanes(ld.x),
                                                      slab_inverse_lanes(ld.y),
                                                      slab_inverse_lanes(ld.z)),
                                         &t0, &t1);
    for (uint lane = 0u; lane < CLPT_LANES; ++lane) {
        if (!lane_on(enters, lane)) {
            continue;
        }
        float t = lane_float(hit->t, lane), b1, b2;
        uint prim;
        if (mesh_tree_intersect(sc, m, lane_float3(lo, lane), lane_float3(ld, lane), &t, &prim,
                                &b1, &b2)) {
            lane_set_float(&hit->t, lane, t);
            lane_set_uint(&hit->prim, lane, prim);
            lane_set_float(&hit->b1, lane, b1);
            lane_set_float(&hit->b2, lane, b2);
            lane_set_uint(&hit->kind, lane, OBJECT_MESH);
            lane_set_uint(&hit->index, lane, index);
        }
    }
}
#else
inline void mesh_object_intersect(const Scene* sc, uint index, float3 o, float3 d, Hit* hit) {
    __global const MeshInstance* inst = &sc->mesh_instances[index];
    float3 lo = o, ld = d;
    to_mesh_space(sc, inst, &lo, &ld);
    if (mesh_tree_intersect(sc, &sc->meshes[inst->mesh], lo, ld, &hit->t, &hit->prim, &hit->b1,
                            &hit->b2)) {
        hit->kind = OBJECT_MESH;
        hit->index = index;
    }
}
#endif

inline void mesh_intersect_all(const Scene* sc, LFloat3 o, LFloat3 d, Hit* hit) {
    for (uint i = 0u; i < sc->params->counts[OBJECT_MESH]; ++i) {
        mesh_object_intersect(sc, i, o, d, hit);
    }
}

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
