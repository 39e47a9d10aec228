/* bvh2.h: nearest hit of a ray with a mesh through its binary BVH, on a GPU (the job of
 * kdtree.h in the original; src/accel/bvh2.rs builds the tree, render/mod.rs `MeshTree`
 * chooses).
 *
 * Reads: the mesh's Bvh2Node array and its leaves' Bvh2Triangles (types.h; in the kd_nodes and
 * kd_indices buffers). Writes: nothing. The ray is in the mesh's object space (direction not
 * normalised).
 * Why: Aila and Laine's walk ("Understanding the efficiency of ray traversal on GPUs", HPG
 * 2009). A node holds both children's boxes, so a step reads one node (four float4) and tests
 * both; the ray goes on into the nearer child entered and pushes the other. Descents run in a
 * loop of their own down to a leaf ("while-while"), so that a warp's work-items test their
 * leaves together. The stack holds nodes only, not their entry distances: a popped node whose
 * box lies beyond the nearest hit is dropped by its own box test one step later, which on an
 * H100 cost less than keeping and checking the distances (BENCHMARKS.md, "A binary BVH for
 * GPUs"). Against the SAH kd-tree of kdtree.h it saves the split-plane slack and the
 * (t0, t1) bookkeeping of each step, and a triangle sits in one leaf only. A leaf holds its
 * triangles' vertices, read at once, not their numbers in the vertex array ("A binary BVH's
 * triangles in its leaves").
 */
#ifndef CLPT_BVH2_H
#define CLPT_BVH2_H

#include "aabb.h"
#include "triangle.h"
#include "types.h"

/* Enough for any tree the host builds: at most SAH_DEPTH + 28 = 60 levels (src/accel/
 * binary_bvh.rs), each pushing at most one node. */
#define BVH2_STACK 64

/* Updates *t, *prim, *b1, *b2 with the nearest hit in (0, *t) of the ray with the `count`
 * triangles of a leaf, each read as three float4 (types.h). */
inline bool bvh2_leaf_intersect(__global const Bvh2Triangle* triangles, uint count,
                                const WatertightRay* ray, float* t, uint* prim, float* b1,
                                float* b2) {
    __global const float4* w = (__global const float4*)triangles;
    bool found = false;
    for (uint i = 0u; i < count; ++i) {
        const float4 a = w[3u * i], b = w[3u * i + 1u], c = w[3u * i + 2u];
        found |= leaf_triangle(ray, a.xyz, (float3)(a.w, b.x, b.y), (float3)(b.z, b.w, c.x),
                               as_uint(c.y), t, prim, b1, b2);
    }
    return found;
}

/* A ray's slab constants for bvh2_box: `inv` is slab_inverse(d) (aabb.h), whose clamp to 2^80
 * keeps o * inv exact where it acts; `os_lo` and `os_hi` are o * inv moved apart by
 * 2^-22 |o * inv|, four times the rounding error of the product, toward widening whichever slab
 * each plane bounds. */
typedef struct Bvh2Slabs {
    float3 inv, os_lo, os_hi;
} Bvh2Slabs;

inline Bvh2Slabs bvh2_slabs(float3 o, float3 inv_d) {
    Bvh2Slabs s;
    s.inv = inv_d;
    const float3 os = o * s.inv;
    /* The lo plane's t is the near one where inv > 0: lowering it (a larger os) widens. */
    const float3 slack = copysign(0x1.0p-22f * fabs(os), s.inv);
    /* An origin so far out that o * inv overflows: NaN slabs, so the axis is not tested. */
    const int3 finite = isfinite(os);
    s.os_lo = select((float3)(NAN), os + slack, finite);
    s.os_hi = select((float3)(NAN), os - slack, finite);
    return s;
}

/* Whether the ray meets box [lo, hi] within [0, t_max], and where it enters (*t0). aabb_clip's
 * test with one fma a plane (lo * inv - o * inv) instead of a subtraction and a product: o * inv
 * is computed once a walk (bvh2_slabs), its rounding an absolute error that bvh2_slabs' offsets
 * cover, and the relative errors of inv and of the fma are covered by widening the far bound as
 * aabb_clip does. An axis whose two slabs are NaN (bvh2_slabs' overflow) leaves the interval as
 * it is: fmin and fmax return the number beside a NaN. On an H100 this took 2.4% off the dragon
 * room and left case1 level, with the same bits (BENCHMARKS.md, "One fma a slab"). */
inline bool bvh2_box(float3 lo, float3 hi, const Bvh2Slabs* s, float t_max, float* t0) {
    const float3 a = fma(lo, s->inv, -s->os_lo);
    const float3 b = fma(hi, s->inv, -s->os_hi);
    const float3 near = fmin(a, b);
    const float3 far = fmax(a, b);
    *t0 = fmax(0.0f, fmax(near.x, fmax(near.y, near.z)));
    return *t0 <= fmin(t_max, fmin(far.x, fmin(far.y, far.z)) * (1.0f + 2.0f * 0x1.0p-23f));
}

/* Updates *t, *prim, *b1, *b2 with the nearest hit in (0, *t) of o + t d with mesh `m`;
 * whether there was one. */
inline bool bvh2_intersect(__global const MeshDesc* m, __global const Bvh2Node* bvh2_nodes,
                           __global const Bvh2Triangle* bvh2_triangles, float3 o, float3 d,
                           float* t, uint* prim, float* b1, float* b2) {
    const float3 inv_d = slab_inverse(d);
    {
        float t0 = 0.0f, t1 = *t;
        if (!aabb_clip(vload3(0, m->lo), vload3(0, m->hi), o, inv_d, &t0, &t1)) {
            return false;
        }
    }
    /* A node as four float4 (64 bytes, aligned: types.h): lo0.xyz hi0.x, hi0.yz lo1.xy,
     * lo1.z hi1.xyz, the two children and padding. */
    __global const float4* nodes = (__global const float4*)(bvh2_nodes + m->first_node);
    __global const Bvh2Triangle* triangles = bvh2_triangles + m->first_index;
    const WatertightRay ray = watertight_setup(o, d);
    const Bvh2Slabs slabs = bvh2_slabs(o, inv_d);
    uint stack[BVH2_STACK];
    int top = 0;
    uint node = 0u; /* a node, or a leaf (WIDE_BVH_LEAF) */
    bool found = false;
    while (true) {
        while ((node & WIDE_BVH_LEAF) == 0u) {
            const float4 w0 = nodes[4u * node];
            const float4 w1 = nodes[4u * node + 1u];
            const float4 w2 = nodes[4u * node + 2u];
            const uint4 c = as_uint4(nodes[4u * node + 3u]);
            float t0a, t0b;
            const bool a = c.x != WIDE_BVH_EMPTY &&
                           bvh2_box(w0.xyz, (float3)(w0.w, w1.x, w1.y), &slabs, *t, &t0a);
            const bool b = c.y != WIDE_BVH_EMPTY &&
                           bvh2_box((float3)(w1.z, w1.w, w2.x), w2.yzw, &slabs, *t, &t0b);
            if (a && b) {
                const bool a_first = t0a <= t0b;
                node = a_first ? c.x : c.y;
                stack[top++] = a_first ? c.y : c.x;
            } else if (a || b) {
                node = a ? c.x : c.y;
            } else if (top == 0) {
                return found;
            } else {
                node = stack[--top];
            }
        }
        found |= bvh2_leaf_intersect(triangles + bvh_leaf_first(node), bvh_leaf_count(node),
                                     &ray, t, prim, b1, b2);
        if (top == 0) {
            return found;
        }
        node = stack[--top];
    }
}

#endif
