/* bvh.h: the object BVH's traversal (port of bvh.cuh).
 *
 * Reads: the BvhNode array (both children's boxes in each node; layout in types.h) and the
 * ObjectRef table its leaves point into. Writes: nothing. Traversal keeps a stack of nodes,
 * tests both children of a node at once and goes to the nearer one first, and skips any child
 * whose box starts beyond the nearest hit so far. Objects outside the tree (unbounded ones)
 * are tested after it.
 */
#ifndef CLPT_BVH_H
#define CLPT_BVH_H

#include "aabb.h"
#include "shapes.h"

#define BVH_STACK 64

/* Visits the objects the ray may hit, calling object_intersect(scene, ref, o, d, hit). */
inline void bvh_intersect(const Scene* sc, float3 o, float3 d, Hit* hit) {
    const float3 inv_d = slab_inverse(d);
    uint stack[BVH_STACK];
    int top = 0;
    if (sc->params->num_bvh_nodes > 0u) {
        stack[top++] = 0u;
    }
    while (top > 0) {
        __global const BvhNode* n = &sc->bvh[stack[--top]];
        float a0 = 0.0f, a1 = hit->t, c0 = 0.0f, c1 = hit->t;
        uint near = n->child[0], far = n->child[1];
        bool enter_near = aabb_clip(vload3(0, n->lo0), vload3(0, n->hi0), o, inv_d, &a0, &a1) &&
                          near != BVH_EMPTY;
        bool enter_far = aabb_clip(vload3(0, n->lo1), vload3(0, n->hi1), o, inv_d, &c0, &c1) &&
                         far != BVH_EMPTY;
        if (enter_far && (!enter_near || c0 < a0)) { /* the second child is nearer */
            const uint c = near;
            near = far;
            far = c;
            const bool e = enter_near;
            enter_near = enter_far;
            enter_far = e;
        }
        /* Leaves now, nearer first, so the nearest t shrinks early; nodes go on the stack,
         * farther first, so the nearer is taken next. */
        if (enter_near && (near & BVH_LEAF)) {
            object_intersect(sc, sc->objects[near & ~BVH_LEAF], o, d, hit);
        }
        if (enter_far && (far & BVH_LEAF)) {
            object_intersect(sc, sc->objects[far & ~BVH_LEAF], o, d, hit);
        }
        if (enter_far && !(far & BVH_LEAF) && top < BVH_STACK) {
            stack[top++] = far;
        }
        if (enter_near && !(near & BVH_LEAF) && top < BVH_STACK) {
            stack[top++] = near;
        }
    }
    for (uint i = sc->params->first_unbounded; i < sc->params->num_objects; ++i) {
        object_intersect(sc, sc->objects[i], o, d, hit);
    }
}

#endif
