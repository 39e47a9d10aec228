/* kdtree.h: nearest hit of a ray with a mesh through its kd-tree (port of kd-tree.cuh).
 *
 * Reads: the mesh's KdNode array (layout in types.h), its leaves' triangle slots (in the
 * kd_indices buffer, triangle.h `slots_intersect`) and vertices. Writes: nothing. The ray is in the mesh's object space (direction not normalised).
 * Traversal is front to back with a small stack of (node, t_min, t_max): a node's children are
 * visited nearer first, and the walk stops as soon as the nearest hit found lies before the next
 * node's interval (pbrt-v3 section 4.5.3). The original instead visited every leaf the ray
 * touched and kept a per-ray bit array of tested triangles, cleared at every call.
 */
#ifndef CLPT_KDTREE_H
#define CLPT_KDTREE_H

#include "aabb.h"
#include "triangle.h"
#include "types.h"

#define KD_STACK 64

typedef struct KdTodo {
    uint node;
    float t0, t1;
} KdTodo;

/* Updates *t, *prim, *b1, *b2 with the nearest hit in (0, *t) of o + t d with mesh `m`. */
inline bool kdtree_intersect(__global const MeshDesc* m, __global const KdNode* kd_nodes,
                             __global const uint* kd_indices, __global const float* vertices, float3 o, float3 d, float* t,
                             uint* prim, float* b1, float* b2) {
    /* The split planes' t takes the plain inverse: the walk below handles its infinities. */
    const float3 inv_d = 1.0f / d;
    float t0 = 0.0f;
    float t1 = *t;
    if (!aabb_clip(vload3(0, m->lo), vload3(0, m->hi), o, slab_inverse(d), &t0, &t1)) {
        return false;
    }
    __global const KdNode* nodes = kd_nodes + m->first_node;
    const WatertightRay ray = watertight_setup(o, d);
    KdTodo todo[KD_STACK];
    int top = 0;
    uint node = 0u;
    bool found = false;
    while (true) {
        if (*t < t0) {
            break; /* the nearest hit lies before this node */
        }
        /* Down to a leaf in a loop of its own, so that a warp's work-items test their leaves
         * together rather than in turn with others' descents (Aila and Laine's "while-while",
         * HPG 2009; BENCHMARKS.md, "The kd-tree's descent in a loop of its own"). */
        KdNode n = nodes[node];
        uint axis = n.flags & 3u;
        while (axis != KD_LEAF) {
            const float split = as_float(n.data);
            const float oa = component(o, (int)axis);
            const float da = component(d, (int)axis);
            const float t_split = (split - oa) * component(inv_d, (int)axis);
            const bool below_first = oa < split || (oa == split && da <= 0.0f);
            const uint first = below_first ? node + 1u : n.flags >> 2;
            const uint second = below_first ? n.flags >> 2 : node + 1u;
            /* Where the ray crosses the split within rounding of this node's entry or exit,
             * both children are visited: a hit on a triangle edge lying in the split plane may
             * belong to a triangle of either side, and watertightness needs both tested. */
            const float slack = 0x1.0p-20f * fabs(t_split);
            if (t_split > t1 + slack || t_split <= 0.0f) {
                node = first;
            } else if (t_split < t0 - slack) {
                node = second;
            } else {
                if (top < KD_STACK) {
                    todo[top].node = second;
                    todo[top].t0 = t_split;
                    todo[top].t1 = t1;
                    ++top;
                }
                node = first;
                t1 = t_split;
            }
            n = nodes[node];
            axis = n.flags & 3u;
        }
        found |= slots_intersect(kd_indices + m->first_index + LEAF_SLOT * n.data, n.flags >> 2,
                                 vertices, &ray, t, prim, b1, b2);
        if (top == 0) {
            break;
        }
        --top;
        node = todo[top].node;
        t0 = todo[top].t0;
        t1 = todo[top].t1;
    }
    return found;
}

#endif
