/* wide_bvh.h: nearest hit of a ray with a mesh through its 8-wide BVH, on a CPU (the job of
 * bvh2.h on a GPU; src/accel/wide_bvh.rs builds the tree, render/mod.rs `MeshTree` chooses).
 *
 * Reads: the mesh's WideBvhNode array (types.h), its leaves' triangle slots (in the kd_indices
 * buffer, triangle.h `slots_intersect`) and vertices. Writes: nothing. The ray is in the
 * mesh's object space (direction not normalised).
 * Why: a CPU walks a mesh one ray at a time, a wide program (lanes.h) one lane's after another;
 * where a kd-tree step decides one split plane, a wide node's eight boxes are tested at once on
 * float8 (Wald, Benthin and Boulos, "Getting rid of packets", 2008; Embree's BVH8). The nearest
 * child entered, node or leaf, is visited next, the others wait on a stack with their entry
 * distance and are dropped once a hit lies before it: a leaf's triangles are tested in the
 * order of its box's entry, not as soon as its node is met (BENCHMARKS.md, "Leaves in order").
 */
#ifndef CLPT_WIDE_BVH_H
#define CLPT_WIDE_BVH_H

#include "aabb.h"
#include "features.h"
#include "triangle.h"
#include "types.h"

/* Asks for the cache lines of the `bytes` bytes at p ahead of their use, with CLPT_PREFETCH
 * (a CPU's program: clang's __builtin_prefetch, which PoCL's compiler takes; OpenCL's own
 * `prefetch` bought nothing there, and NVIDIA's compiler refuses the builtin on a global
 * pointer); absent elsewhere, with the loop that calls it. */
#if CLPT_PREFETCH
inline void prefetch_lines(__global const char* p, uint bytes) {
    for (uint at = 0u; at < bytes; at += 64u) {
        __builtin_prefetch(p + at);
    }
}
#endif

/* A leaf child's slots (bvh_leaf_first, triangle.h). */
inline __global const uint* wide_leaf_slots(__global const uint* indices, uint c) {
    return indices + LEAF_SLOT * bvh_leaf_first(c);
}

/* At most seven children wait per level of the path from the root, and the host's trees have
 * at most 64 levels (accel/wide_bvh.rs: SAH splits to depth 32, object medians below). */
#define WIDE_BVH_STACK 448

/* Updates *t, *prim, *b1, *b2 with the nearest hit in (0, *t) of o + t d with mesh `m`. */
inline bool wide_bvh_intersect(__global const MeshDesc* m, __global const WideBvhNode* all_nodes,
                               __global const uint* all_indices, __global const float* vertices,
                               float3 o, float3 d, float* t, uint* prim, float* b1, float* b2) {
    __global const WideBvhNode* nodes = all_nodes + m->first_node;
    __global const uint* indices = all_indices + m->first_index;
    const float3 inv_d = slab_inverse(d);
    const WatertightRay ray = watertight_setup(o, d);
    uint todo[WIDE_BVH_STACK];
    float todo_t[WIDE_BVH_STACK];
    int top = 0;
    uint node = 0u; /* the child visited: a node, or a leaf (WIDE_BVH_LEAF) */
    bool found = false;
    while (true) {
        if ((node & WIDE_BVH_LEAF) != 0u) {
            found |= slots_intersect(wide_leaf_slots(indices, node), bvh_leaf_count(node),
                                     vertices, &ray, t, prim, b1, b2);
        } else {
            __global const WideBvhNode* n = nodes + node;
            const float8 ax = (vload8(0, n->lo_x) - o.x) * inv_d.x;
            const float8 bx = (vload8(0, n->hi_x) - o.x) * inv_d.x;
            const float8 ay = (vload8(0, n->lo_y) - o.y) * inv_d.y;
            const float8 by = (vload8(0, n->hi_y) - o.y) * inv_d.y;
            const float8 az = (vload8(0, n->lo_z) - o.z) * inv_d.z;
            const float8 bz = (vload8(0, n->hi_z) - o.z) * inv_d.z;
            /* aabb_clip (aabb.h) on eight boxes: the same order, NaN rule and widened far end. */
            const float8 t0 =
                fmax((float8)(0.0f), fmax(fmin(ax, bx), fmax(fmin(ay, by), fmin(az, bz))));
            const float8 t1 =
                fmin((float8)(*t), fmin(fmax(ax, bx), fmin(fmax(ay, by), fmax(az, bz))) *
                                       (1.0f + 2.0f * 0x1.0p-23f));
            /* The children entered, as bits: a mask (all bits or none) ANDed with each lane's bit
             * and folded. */
            const int8 entered = (t0 <= t1) & (vload8(0, n->child) != (uint8)(WIDE_BVH_EMPTY)) &
                                 (int8)(1, 2, 4, 8, 16, 32, 64, 128);
            const int4 f4 = entered.lo | entered.hi;
            const int2 f2 = f4.lo | f4.hi;
            uint bits = (uint)(f2.x | f2.y);
            float near[8];
            vstore8(t0, 0, near);
            /* What the children entered will read, asked for before it is needed: a CPU's walk
             * otherwise waits on each node's and slot's load (BENCHMARKS.md, "Prefetching the
             * wide BVH"). */
#if CLPT_PREFETCH
            for (uint ahead = bits; ahead != 0u; ahead &= ahead - 1u) {
                const uint c = n->child[ctz(ahead)];
                if ((c & WIDE_BVH_LEAF) == 0u) {
                    prefetch_lines((__global const char*)(nodes + c), sizeof(WideBvhNode));
                } else {
                    prefetch_lines((__global const char*)wide_leaf_slots(indices, c),
                                   4u * LEAF_SLOT * bvh_leaf_count(c));
                }
            }
#endif
            uint next = WIDE_BVH_EMPTY;
            float next_t = 0.0f;
            while (bits != 0u) {
                const uint k = ctz(bits);
                bits &= bits - 1u;
                const uint c = n->child[k];
                uint wait = c;
                float wait_t = near[k];
                if (next == WIDE_BVH_EMPTY || near[k] < next_t) {
                    wait = next;
                    wait_t = next_t;
                    next = c;
                    next_t = near[k];
                }
                if (wait != WIDE_BVH_EMPTY && top < WIDE_BVH_STACK) {
                    todo[top] = wait;
                    todo_t[top] = wait_t;
                    ++top;
                }
            }
            if (next != WIDE_BVH_EMPTY && next_t <= *t) {
                node = next;
                continue;
            }
        }
        /* The nearest waiting child that a hit found since has not passed. */
        while (top > 0 && todo_t[top - 1] > *t) {
            --top;
        }
        if (top == 0) {
            break;
        }
        --top;
        node = todo[top];
    }
    return found;
}

#endif
