/* features.h: the program switches, one place on the device side (the host's is
 * src/render/features.rs, which derives them from the scene).
 *
 * Reads: the -D options the program was built with. Writes: nothing. Why: a scene should not
 * carry code it does not use (larger programs spill registers and run slower on GPUs, and
 * build slower everywhere). Each switch is 0 or 1; a program built without options (the test
 * probes) gets every feature. The kernel loader (src/device/program.rs) also drops the text of
 * `#if CLPT_X` blocks whose switch is 0, so `--dump-kernel` shows exactly what was compiled.
 *
 *   CLPT_SPHERES      spheres (sphere.h)
 *   CLPT_PLANES       planes (plane.h)
 *   CLPT_MESHES       triangle meshes: kd-tree traversal, watertight triangles
 *   CLPT_REVSURFACES  surfaces of revolution: root isolation and Newton (revsurface.h)
 *                     (one switch a kind of object, named by the host's list of kinds: their
 *                     defaults are written in types.h with the SHAPES(X) list)
 *   CLPT_REV_DEGREE   the one degree of every revolved surface (loops unrolled), 0: mixed
 *   CLPT_REV_MERGED   a revolved surface's segments walked in one loop (revsurface.h), not
 *                     one after another in step across a warp. Follows !CLPT_NEE when absent:
 *                     bounce rays gain from it, a GPU's shadow rays lose
 *   CLPT_BVH          the object BVH (bvh.h); 0: objects are tested kind by kind in a loop
 *   CLPT_WALLS        without the BVH, axis planes tested as walls (plane.h walls_intersect):
 *                     set on CPUs where some axis has a wall on each side, as a room does
 *   CLPT_TRANSFORMS   objects inside Transform (transform.h's matrices applied per ray)
 *   CLPT_TEXTURES     texture maps of any kind (texture.h, texture coordinates, bump frames)
 *   CLPT_THIN_LENS    depth of field (the camera's lens sampling); 0: a pinhole
 *   CLPT_NEE          next-event estimation with MIS (nee.h); 0: pure path tracing
 *   CLPT_REGENERATE   a lane starts its next sample while others still trace, by warp vote
 *                     (pathtracer.cl render_pass; NVIDIA's inline PTX): set for NVIDIA GPUs
 *   CLPT_LANES        the lanes a work-item carries (lanes.h): 1, or 4, 8 or 16 with CLPT_WIDE
 *   CLPT_WIDE         work-items of CLPT_LANES > 1 lanes (lanes.h); 0: plain scalars. Unlike
 *                     the others, it follows CLPT_LANES when absent (the probes of each width)
 *   CLPT_WIDE_BVH     meshes walk 8-wide BVHs (wide_bvh.h); 0: kd-trees (kdtree.h) or, with
 *                     CLPT_BVH2, binary BVHs. Follows CLPT_WIDE when absent; a wide program
 *                     needs it
 *   CLPT_BVH2         meshes walk binary BVHs (bvh2.h), where CLPT_WIDE_BVH is 0: set for
 *                     GPUs
 *   CLPT_PREFETCH     the wide BVH asks for its children's nodes and slots ahead with clang's
 *                     __builtin_prefetch (wide_bvh.h): set for CPUs (NVIDIA's compiler
 *                     refuses it on global pointers)
 */
#ifndef CLPT_FEATURES_H
#define CLPT_FEATURES_H

#ifndef CLPT_REV_DEGREE
#define CLPT_REV_DEGREE 0
#endif
#ifndef CLPT_BVH
#define CLPT_BVH 1
#endif
#ifndef CLPT_WALLS
#define CLPT_WALLS 1
#endif
#ifndef CLPT_TRANSFORMS
#define CLPT_TRANSFORMS 1
#endif
#ifndef CLPT_TEXTURES
#define CLPT_TEXTURES 1
#endif
#ifndef CLPT_THIN_LENS
#define CLPT_THIN_LENS 1
#endif
#ifndef CLPT_NEE
#define CLPT_NEE 1
#endif
#ifndef CLPT_REGENERATE
#define CLPT_REGENERATE 0
#endif
#ifndef CLPT_LANES
#define CLPT_LANES 1
#endif
#ifndef CLPT_WIDE
#define CLPT_WIDE (CLPT_LANES > 1)
#endif
#ifndef CLPT_REV_MERGED
#define CLPT_REV_MERGED (!CLPT_NEE)
#endif
#ifndef CLPT_WIDE_BVH
#define CLPT_WIDE_BVH CLPT_WIDE
#endif
#ifndef CLPT_BVH2
#define CLPT_BVH2 0
#endif
#ifndef CLPT_PREFETCH
#define CLPT_PREFETCH 0
#endif

#endif
