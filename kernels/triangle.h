/* triangle.h: watertight ray/triangle intersection (Woop, Benthin and Wald, "Watertight
 * ray/triangle intersection", JCGT 2013; port of the triangle test inside mesh.cuh).
 *
 * Reads: three vertices. Writes: nothing. Why: the original's test let rays slip between two
 * triangles sharing an edge. Here the ray is sheared so it runs along +z from the origin; each
 * edge function is a 2x2 determinant of the sheared vertices, computed so that a shared edge
 * seen from its two triangles gives exactly opposite values (or zero for both): a ray through
 * an edge or vertex always hits at least one of the triangles meeting there. Contraction into
 * fma is switched off for this: an fma would round the two orders differently.
 */
#ifndef CLPT_TRIANGLE_H
#define CLPT_TRIANGLE_H

/* The ray's shear, computed once per ray and mesh. */
typedef struct WatertightRay {
    float3 o;
    int kx, ky, kz;
    float sx, sy, sz;
} WatertightRay;

inline float component(float3 v, int k) {
    return k == 0 ? v.x : (k == 1 ? v.y : v.z);
}

inline WatertightRay watertight_setup(float3 o, float3 d) {
    WatertightRay r;
    r.o = o;
    const float3 a = fabs(d);
    r.kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    r.kx = r.kz == 2 ? 0 : r.kz + 1;
    r.ky = r.kx == 2 ? 0 : r.kx + 1;
    if (component(d, r.kz) < 0.0f) { /* keep the winding */
        const int tmp = r.kx;
        r.kx = r.ky;
        r.ky = tmp;
    }
    const float dz = component(d, r.kz);
    r.sx = component(d, r.kx) / dz;
    r.sy = component(d, r.ky) / dz;
    r.sz = 1.0f / dz;
    return r;
}

#pragma OPENCL FP_CONTRACT OFF
/* A hit at t in (0, t_max): true, with t and the barycentric weights of v1 and v2. */
inline bool triangle_intersect(const WatertightRay* r, float3 v0, float3 v1, float3 v2,
                               float t_max, float* t, float* b1, float* b2) {
    const float3 a = v0 - r->o;
    const float3 b = v1 - r->o;
    const float3 c = v2 - r->o;
    const float az = component(a, r->kz), bz = component(b, r->kz), cz = component(c, r->kz);
    const float ax = component(a, r->kx) - r->sx * az;
    const float ay = component(a, r->ky) - r->sy * az;
    const float bx = component(b, r->kx) - r->sx * bz;
    const float by = component(b, r->ky) - r->sy * bz;
    const float cx = component(c, r->kx) - r->sx * cz;
    const float cy = component(c, r->ky) - r->sy * cz;
    const float u = cx * by - cy * bx;
    const float v = ax * cy - ay * cx;
    const float w = bx * ay - by * ax;
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) {
        return false;
    }
    const float det = u + v + w;
    if (det == 0.0f) {
        return false;
    }
    const float tt = u * (r->sz * az) + v * (r->sz * bz) + w * (r->sz * cz);
    if (det < 0.0f ? (tt >= 0.0f || tt < t_max * det) : (tt <= 0.0f || tt > t_max * det)) {
        return false;
    }
    const float inv = 1.0f / det;
    *t = tt * inv;
    *b1 = v * inv;
    *b2 = w * inv;
    return *t < t_max;
}
#pragma OPENCL FP_CONTRACT ON

/* Vertex i of the scene's vertex array. */
inline float3 mesh_vertex(__global const float* vertices, uint i) {
    return vload3(i, vertices);
}

/* Updates *t, *prim, *b1, *b2 where the ray meets triangle `tri` (vertices a, b, c) in
 * (0, *t); whether it does. */
inline bool leaf_triangle(const WatertightRay* ray, float3 a, float3 b, float3 c, uint tri,
                          float* t, uint* prim, float* b1, float* b2) {
    float th, u1, u2;
    if (!triangle_intersect(ray, a, b, c, *t, &th, &u1, &u2)) {
        return false;
    }
    *t = th;
    *prim = tri;
    *b1 = u1;
    *b2 = u2;
    return true;
}

/* A BVH leaf reference's parts (WIDE_BVH_LEAF | (count - 1) << 28 | first, types.h; the
 * binary and the 8-wide BVH's): its first entry and its count of triangles. */
inline uint bvh_leaf_first(uint c) {
    return c & 0x0FFFFFFFu;
}

inline uint bvh_leaf_count(uint c) {
    return ((c >> 28) & 7u) + 1u;
}

/* Updates *t, *prim, *b1, *b2 with the nearest hit in (0, *t) of the ray with the `count`
 * triangles of a tree leaf's slots (LEAF_SLOT words each: the vertices' numbers in the scene's
 * vertex array, then the triangle's number in its mesh; src/shapes/mesh.rs). A slot is read at
 * once, so a triangle costs one load before its vertices, where a list of triangle numbers cost
 * two (BENCHMARKS.md, "Leaf slots"). The kd-tree's and the 8-wide BVH's leaves use it
 * (kdtree.h, wide_bvh.h); a binary BVH's hold their vertices (bvh2.h). */
inline bool slots_intersect(__global const uint* slots, uint count,
                            __global const float* vertices, const WatertightRay* ray, float* t,
                            uint* prim, float* b1, float* b2) {
    bool found = false;
    for (uint i = 0u; i < count; ++i) {
        const uint4 s = vload4(i, slots);
        found |= leaf_triangle(ray, mesh_vertex(vertices, s.x), mesh_vertex(vertices, s.y),
                               mesh_vertex(vertices, s.z), s.w, t, prim, b1, b2);
    }
    return found;
}

#endif
