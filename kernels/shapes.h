/* shapes.h: the scene's objects kind by kind (port of objects.cuh's per-object tests): each
 * kind's header, with its functions of the SHAPES(X) list, and object_intersect, one object of
 * any kind (what the object BVH's leaves call, bvh.h).
 *
 * Reads: every scene buffer, through the Scene struct (scene.h). Writes: nothing. Why: one list
 * of kinds (types.h's SHAPES, from the host's OBJECT_KINDS) drives every dispatch, so a kind is
 * its own header and a line of that list; objects.h asks the scene-wide question on top.
 */
#ifndef CLPT_SHAPES_H
#define CLPT_SHAPES_H

#include "types.h"
#include "scene.h"

/* What is compiled follows the program switches of features.h. Programs of several lanes a
 * work-item (lanes.h) have spheres, planes, meshes and transforms, without surfaces of
 * revolution and the object BVH so far (docs/cpu-lanes.md). */
#if CLPT_WIDE && (CLPT_REVSURFACES || CLPT_BVH || !CLPT_WIDE_BVH)
#error "a wide program (CLPT_WIDE) walks wide BVHs, without revolved surfaces or the object BVH"
#endif
#if CLPT_SPHERES
#include "sphere.h"
#endif
#if CLPT_PLANES
#include "plane.h"
#endif
#if CLPT_MESHES
#include "mesh.h"
#endif
#if CLPT_REVSURFACES
#include "revsurface.h"
#endif

/* Every kind of object, one list: SHAPES(X) in types.h, written from the host's OBJECT_KINDS
 * (src/contract/types.rs), gives X(KIND, name) for each kind the program has (its switch, as
 * CLPT_SPHERES, on): its OBJECT_* constant and the prefix of the functions each kind defines:
 * (in its header, included above):
 *   name_object_intersect(sc, index, o, d, hit)  object `index`'s hit, kept in hit if nearer;
 *   name_intersect_all(sc, o, d, hit)             every object of the kind, without the BVH;
 *   name_object_surface(sc, index, hit, o, d, &transform)
 *                                                 the surface at a hit in the object's own
 *                                                 space, with its material.
 * object_intersect (the BVH's leaves), scene_intersect_until (without the BVH) and
 * object_surface dispatch through it, in the list's order: the one rays meet the kinds in
 * without the BVH, part of the image (at equal t the first hit found is kept). A kind's count
 * is sc->params->counts[OBJECT_KIND]. docs/adding-a-shape.md says how a kind joins. */

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
