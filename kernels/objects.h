/* objects.h: the nearest hit among all objects of the scene (port of objects.cuh).
 *
 * Reads: the Sphere and Plane arrays. Writes: nothing. Why: the path tracer asks one question,
 * "what does this ray hit first", and then needs the surface only of the winner. The object
 * BVH (bvh.h) replaces the linear loops with the meshes issue.
 */
#ifndef CLPT_OBJECTS_H
#define CLPT_OBJECTS_H

#include "sphere.h"
#include "plane.h"

#define HIT_NONE 0u
#define HIT_SPHERE 1u
#define HIT_PLANE 2u

typedef struct Hit {
    float t;
    uint kind;  /* HIT_* */
    uint index; /* into the array of its kind */
} Hit;

/* The surface at a hit: refined point, its error bound, unit outward normal, material. */
typedef struct Surface {
    float3 p;
    float3 p_error;
    float3 n;
    uint material;
} Surface;

inline Hit scene_intersect(__global const RenderParams* params, __global const Sphere* spheres,
                           __global const Plane* planes, float3 o, float3 d) {
    Hit hit;
    hit.t = INFINITY;
    hit.kind = HIT_NONE;
    hit.index = 0u;
    for (uint i = 0u; i < params->num_spheres; ++i) {
        const float t = sphere_intersect(&spheres[i], o, d, hit.t);
        if (t < hit.t) {
            hit.t = t;
            hit.kind = HIT_SPHERE;
            hit.index = i;
        }
    }
    for (uint i = 0u; i < params->num_planes; ++i) {
        const float t = plane_intersect(&planes[i], o, d, hit.t);
        if (t < hit.t) {
            hit.t = t;
            hit.kind = HIT_PLANE;
            hit.index = i;
        }
    }
    return hit;
}

inline Surface scene_surface(__global const Sphere* spheres, __global const Plane* planes,
                             Hit hit, float3 o, float3 d) {
    Surface s;
    if (hit.kind == HIT_SPHERE) {
        sphere_surface(&spheres[hit.index], o, d, hit.t, &s.p, &s.n, &s.p_error);
        s.material = spheres[hit.index].material;
    } else {
        plane_surface(&planes[hit.index], o, d, hit.t, &s.p, &s.n, &s.p_error);
        s.material = planes[hit.index].material;
    }
    return s;
}

/* Where a hit falls on its object's texture: (u, v) and the unit directions of increasing u
 * and v (for bump maps). */
inline float2 scene_mapping(__global const Sphere* spheres, __global const Plane* planes, Hit hit,
                            Surface s, float3* dpdu, float3* dpdv) {
    if (hit.kind == HIT_SPHERE) {
        sphere_tangents(s.n, dpdu, dpdv);
        return sphere_uv(s.n);
    }
    plane_tangents(&planes[hit.index], dpdu, dpdv);
    return plane_uv(&planes[hit.index], s.p);
}

#endif
