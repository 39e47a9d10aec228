/* shapes.h: the scene's objects kind by kind (port of objects.cuh's per-object tests): the Scene
 * struct of buffers, a hit, each kind's intersection in its own space and its surface, and
 * object_intersect, one object of any kind (what the object BVH's leaves call, bvh.h).
 *
 * Reads: every scene buffer, through the Scene struct of pointers below. Writes: nothing.
 * Why: transformed objects are intersected in their own space with the ray taken there by the
 * inverse transform; spheres and planes need a unit direction, so their t is scaled back.
 * objects.h asks the scene-wide question on top of these.
 */
#ifndef CLPT_SHAPES_H
#define CLPT_SHAPES_H

#include "types.h"
#include "vecmath.h"
#include "ray.h"

/* What is compiled follows the program switches of features.h. Programs of several lanes a
 * work-item (lanes.h) have spheres, planes, meshes and transforms, without surfaces of
 * revolution and the object BVH so far (docs/cpu-lanes.md). */
#if CLPT_WIDE && (CLPT_REVSURFACES || CLPT_BVH || !CLPT_WIDE_BVH)
#error "a wide program (CLPT_WIDE) walks wide BVHs, without revolved surfaces or the object BVH"
#endif
#if CLPT_TRANSFORMS
#include "transform.h"
#endif
#if CLPT_SPHERES
#include "sphere.h"
#endif
#if CLPT_PLANES
#include "plane.h"
#endif
#if CLPT_MESHES
#include "triangle.h"
#include "kdtree.h"
#if CLPT_WIDE_BVH
#include "wide_bvh.h"
#endif
#endif
#if CLPT_REVSURFACES
#include "revsurface.h"
#endif

/* Every kind of object, one list: SHAPES(X) in types.h, written from the host's OBJECT_KINDS
 * (src/contract/types.rs), gives X(KIND, name) for each kind the program has (its switch, as
 * CLPT_SPHERES, on): its OBJECT_* constant and the prefix of the functions each kind defines:
 *   name_object_intersect(sc, index, o, d, hit)  object `index`'s hit, kept in hit if nearer;
 *   name_intersect_all(sc, o, d, hit)             every object of the kind, without the BVH;
 *   name_object_surface(sc, index, hit, o, d, &transform)
 *                                                 the surface at a hit in the object's own
 *                                                 space, with its material (objects.h).
 * object_intersect (the BVH's leaves), scene_intersect_until (without the BVH) and
 * object_surface dispatch through it, in the list's order: the one rays meet the kinds in
 * without the BVH, part of the image (at equal t the first hit found is kept). A kind's count
 * is sc->params->counts[OBJECT_KIND]. docs/adding-a-shape.md says how a kind joins. */

/* Every scene buffer, in the order kernels take them: built from types.h's SCENE_BUFFERS, the
 * host's one list (src/contract/buffers.rs), which binds each by its name. */
#define SCENE_FIELD(T, name) __global const T* name;
typedef struct Scene {
    SCENE_BUFFERS(SCENE_FIELD)
} Scene;

/* The scene's kernel parameters, each with its comma: a kernel writes
 * `k(SCENE_KERNEL_ARGS __global float* out)`. */
#define SCENE_PARAM(T, name) __global const T *name,
#define SCENE_KERNEL_ARGS SCENE_BUFFERS(SCENE_PARAM)
#define SCENE_NAME(T, name) name,
#define SCENE_FROM_KERNEL_ARGS {SCENE_BUFFERS(SCENE_NAME)}

/* A hit of each lane (lanes.h). */
typedef struct Hit {
    lfloat t;
    luint kind;  /* OBJECT_* (types.h) */
    luint index; /* among spheres, planes or mesh instances */
    luint prim;  /* meshes: the triangle; surfaces of revolution: the profile segment */
    lfloat b1, b2; /* meshes: barycentric weights of the triangle's second and third vertex;
                    * surfaces of revolution: b1 is the segment's parameter u */
} Hit;

/* The surface at a hit, in world space: refined point, its error bound, unit geometric normal
 * (outward), shading normal (interpolated vertex normals on smooth meshes, else n), material,
 * and the point and normal in the object's own space (for texture coordinates). */
typedef struct Surface {
    LFloat3 p;
    LFloat3 p_error;
    LFloat3 n;
    LFloat3 ns;
    LFloat3 p_local;
    LFloat3 n_local;
    luint material;
    luint transform;
} Surface;

#if CLPT_MESHES
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
 * through its tree: the 8-wide BVH (wide_bvh.h) or the kd-tree (kdtree.h), as CLPT_WIDE_BVH
 * says; whether there was one. */
inline bool mesh_tree_intersect(const Scene* sc, __global const MeshDesc* m, float3 o, float3 d,
                                float* t, uint* prim, float* b1, float* b2) {
#if CLPT_WIDE_BVH
    return wide_bvh_intersect(m, (__global const WideBvhNode*)sc->kd_nodes, sc->kd_indices,
                              sc->vertices, o, d, t, prim, b1, b2);
#else
    return kdtree_intersect(m, sc->kd_nodes, sc->kd_indices, sc->triangles, sc->vertices, o, d,
                            t, prim, b1, b2);
#endif
}

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
                                         make_lfloat3(1.0f / ld.x, 1.0f / ld.y, 1.0f / ld.z),
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
#endif

/* The ray in a sphere's or plane's own space, with a unit direction: `scale` is the length
 * of the world's unit direction there, so object-space t = world t * scale. */
inline void to_object_space(const Scene* sc, uint transform, LFloat3* o, LFloat3* d,
                            lfloat* scale) {
    *scale = 1.0f;
#if CLPT_TRANSFORMS
    if (transform != TRANSFORM_NONE) {
        __global const float* inv = sc->transforms[transform].inv;
        *o = xform_point(inv, *o);
        *d = xform_vector(inv, *d);
        *scale = v3_length(*d);
        *d = v3_div(*d, *scale);
    }
#endif
}

/* Keeps an object's hit at object-space t, found on a ray whose world unit direction has length
 * `scale` there, when it is nearer than t_max (the nearest hit so far, in that space). */
inline lmask keep_hit(Hit* hit, lfloat t, lfloat t_max, lfloat scale, uint kind, uint index) {
    const lmask nearer = t < t_max;
    if (!lane_any(nearer)) {
        return nearer;
    }
    hit->t = lselect(hit->t, t / scale, nearer);
    hit->kind = lselect(hit->kind, (luint)(kind), nearer);
    hit->index = lselect(hit->index, (luint)(index), nearer);
    return nearer;
}

#if CLPT_SPHERES
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

#endif

#if CLPT_PLANES
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
#endif

#if CLPT_REVSURFACES
inline void revsurface_object_intersect(const Scene* sc, uint index, float3 o, float3 d,
                                       Hit* hit) {
    __global const RevSurface* r = &sc->revsurfaces[index];
    float scale;
    to_object_space(sc, r->transform, &o, &d, &scale);
    const float t_max = hit->t * scale;
    uint seg = 0u;
    RevWork work = {0u, 0u};
    float u = 0.0f;
    const float t = revsurface_intersect(r, sc->rev_points, o, d, t_max, &seg, &u, &work);
    if (keep_hit(hit, t, t_max, scale, OBJECT_REVSURFACE, index)) {
        hit->prim = seg;
        hit->b1 = u;
    }
}

inline void revsurface_intersect_all(const Scene* sc, float3 o, float3 d, Hit* hit) {
    for (uint i = 0u; i < sc->params->counts[OBJECT_REVSURFACE]; ++i) {
        revsurface_object_intersect(sc, i, o, d, hit);
    }
}

/* The hit point moved onto the surface at the profile parameter found, its normal (the
 * profile's normal (y', -x') revolved, turned with the profile where x < 0) and an error
 * bound covering the Newton iteration's acceptance band. */
inline void rev_surface(const Scene* sc, __global const RevSurface* r, Hit hit, float3 p_ray,
                        float3* p, float3* p_error, float3* n) {
    const uint degree = REV_DEGREE(r);
    __global const float2* pts = sc->rev_points + r->first_point + hit.prim * (degree + 1u);
    float size = 0.0f;
    for (uint i = 0u; i <= degree; ++i) {
        size = fmax(size, fabs(pts[i].x) + fabs(pts[i].y));
    }
    float2 s, ds;
    bezier_eval(pts, degree, hit.b1, &s, &ds);
    const float rho = sqrt(p_ray.x * p_ray.x + p_ray.z * p_ray.z);
    const float3 radial = rho > 0.0f ? (float3)(p_ray.x / rho, 0.0f, p_ray.z / rho)
                                     : (float3)(1.0f, 0.0f, 0.0f);
    *p = fabs(s.x) * radial + (float3)(0.0f, s.y, 0.0f);
    /* Where the profile's speed all but vanishes (repeated control points: the original's
     * goblet meets the axis through three points 1e-6 apart) the derivative's direction is
     * that of rounding-sized wiggles. The tangent is then the secant to a point at least
     * 1e-4 of the segment's size away, towards the segment's interior. */
    float2 tangent = ds;
    if (length(ds) < 1e-2f * size) {
        const float dir = hit.b1 < 0.5f ? 1.0f : -1.0f;
        for (float du = 1.0f / 64.0f; du <= 0.5f; du *= 2.0f) {
            float2 s2, ds2;
            bezier_eval(pts, degree, hit.b1 + dir * du, &s2, &ds2);
            tangent = dir * (s2 - s);
            if (length(s2 - s) >= 1e-4f * size) {
                break;
            }
        }
    }
    const float sign = s.x < 0.0f ? -1.0f : 1.0f;
    *n = normalize(tangent.y * radial - sign * tangent.x * (float3)(0.0f, 1.0f, 0.0f));
    /* The solvers accept a root whose residuals are within 1e-5 of their terms' size, the
     * segment's largest coordinates among them (rev_residuals_ok), and sub-curves within
     * a few roundings of a point by where the ray enters their box: the point is known to
     * that band, and a ray spawned closer than it could find the surface it leaves. The
     * profile's speed |ds| keeps the band from vanishing near the object's origin. */
    *p_error = (float3)(2e-5f * (length(*p) + size + length(ds))) + fabs(p_ray - *p);
}
#endif

#if CLPT_BVH
/* A BVH leaf's object, whatever its kind. */
inline void object_intersect(const Scene* sc, ObjectRef ref, float3 o, float3 d, Hit* hit) {
#define SHAPE_OBJECT_INTERSECT(KIND, name)                                                      \
    if (ref.kind == KIND) {                                                                  \
        name##_object_intersect(sc, ref.index, o, d, hit);                                   \
        return;                                                                              \
    }
    SHAPES(SHAPE_OBJECT_INTERSECT)
#undef SHAPE_OBJECT_INTERSECT
}
#endif

#endif
