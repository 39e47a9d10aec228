/* scene.h: the scene as each kind of object's functions see it (port of hit.cuh and the
 * scene half of objects.cuh): the Scene struct of buffers, a hit, the surface at a hit, and the
 * two steps every kind shares: the ray taken to an object's space and a nearer hit kept.
 *
 * Reads: every scene buffer, through the Scene struct of pointers below. Writes: nothing.
 * Why: transformed objects are intersected in their own space with the ray taken there by the
 * inverse transform; spheres and planes need a unit direction, so their t is scaled back.
 */
#ifndef CLPT_SCENE_H
#define CLPT_SCENE_H

#include "types.h"
#include "vecmath.h"
#if CLPT_TRANSFORMS
#include "transform.h"
#endif

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

#endif
