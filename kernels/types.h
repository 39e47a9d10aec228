/* types.h: every struct shared between host and device, declared once.
 *
 * Reads: nothing. Writes: nothing. Why: the Rust mirrors in src/device/layout.rs copy these
 * declarations field for field (#[repr(C)] + bytemuck); both sides assert the sizes, and the
 * layout probe (tests/layout.rs) compiles offsetof() for every field on the device and compares
 * it with Rust's offset_of!. Rules: only 4-byte scalars and arrays of them (no float3: it is
 * 16 bytes with 16-byte alignment), so no implicit padding can differ between compilers.
 */
#ifndef CLPT_TYPES_H
#define CLPT_TYPES_H

#include "features.h"

/* Compile-time size check that works in OpenCL C 1.2 (C99 has no _Static_assert). */
#define CLPT_ASSERT_SIZE(T, n) typedef char clpt_size_check_##T[(sizeof(T) == (n)) ? 1 : -1]

/* Material types, as the original's `type diff|spec|refr`. */
#define MATERIAL_DIFFUSE 0u
#define MATERIAL_SPECULAR 1u
#define MATERIAL_REFRACTIVE 2u

/* Texture map formats (texture.h): each map in the smallest format that holds it. */
#define MAP_NONE 0xFFFFFFFFu
#define MAP_RGB8 0u  /* 3 bytes per texel: colour or emission, value / 255 */
#define MAP_TYPE8 1u /* 1 byte per texel: a MATERIAL_* value */
#define MAP_BUMP8 2u /* 2 signed bytes per texel: bump gradients (du, dv) * 127 */

/* Texture lookup filters (RenderParams.texture_filter). */
#define FILTER_BILINEAR 0u
#define FILTER_NEAREST 1u

/* One texture map inside the scene's texel buffer; row 0 is the top of the image (v = 1). */
typedef struct TextureMap {
    uint offset;           /* in bytes */
    uint width;
    uint height;
    uint format;           /* MAP_* */
} TextureMap;
CLPT_ASSERT_SIZE(TextureMap, 16);

/* A kd-tree node over a mesh's triangles (kdtree.h), 8 bytes, in depth-first order: an
 * interior node's "below" child (coordinates < split) is the next node, its "above" child is at
 * the index stored in `flags`.
 *   interior: flags = axis (0, 1, 2) | above_child << 2; data = the split coordinate's bits
 *   leaf:     flags = 3 | triangle_count << 2;           data = first entry in the mesh's
 *             triangle index list (the triangles overlapping the leaf) */
#define KD_LEAF 3u
typedef struct KdNode {
    uint flags;
    uint data;
} KdNode;
CLPT_ASSERT_SIZE(KdNode, 8);

/* A node of a mesh's 8-wide BVH (src/accel/wide_bvh.rs, wide_bvh.h), a CPU's mesh tree: the
 * boxes of up to eight children as arrays per bound, so that one ray tests all
 * eight at once on float8. A child is another node's index (relative to the mesh's first node),
 * WIDE_BVH_LEAF | (count - 1) << 28 | first slot (relative to the mesh's first index), or
 * WIDE_BVH_EMPTY (its box empty). */
#define WIDE_BVH_LEAF 0x80000000u
#define WIDE_BVH_EMPTY 0xFFFFFFFFu
/* The words of a leaf's triangle slot, which a wide BVH's first index counts in (in the
 * kd_indices buffer): the triangle's three vertices' numbers in the scene's vertex array and its
 * number in its mesh (src/device/upload.rs, wide_bvh.h). */
#define WIDE_BVH_SLOT 4u
typedef struct WideBvhNode {
    float lo_x[8];
    float hi_x[8];
    float lo_y[8];
    float hi_y[8];
    float lo_z[8];
    float hi_z[8];
    uint child[8];
} WideBvhNode;
CLPT_ASSERT_SIZE(WideBvhNode, 224);

/* A node of the object BVH (bvh.h) holding the boxes of both its children, so traversal tests
 * the two and descends into the nearer one first. A child is another node's index, or
 * BVH_LEAF | object index, or BVH_EMPTY (only in a one-object tree). */
#define BVH_LEAF 0x80000000u
#define BVH_EMPTY 0xFFFFFFFFu
typedef struct BvhNode {
    float lo0[3];
    float hi0[3];
    float lo1[3];
    float hi1[3];
    uint child[2];
} BvhNode;
CLPT_ASSERT_SIZE(BvhNode, 56);

/* The camera (camera.cuh): smallpt's basis, plus a thin lens when focus_distance > 0.
 * A primary ray through image point (x, y), y = 0 the bottom row, has direction
 * cx*(x/w - 1/2) + cy*(y/h - 1/2) + forward. */
typedef struct Camera {
    float origin[3];
    float forward[3];      /* unit view direction d */
    float cx[3];           /* image-plane x axis, length w*a/h (a = angle in radians) */
    float cy[3];           /* image-plane y axis, length a */
    float lens_u[3];       /* unit vectors spanning the lens disk */
    float lens_v[3];
    float lens_radius;     /* 0: pinhole */
    float focus_distance;  /* distance of the plane in focus, along forward */
    uint width;
    uint height;
} Camera;
CLPT_ASSERT_SIZE(Camera, 88);

/* A material (material.cuh): plain values, each replaced per texel by its map if it has one
 * (an index into the TextureMap array, or MAP_NONE). */
typedef struct Material {
    float emission[3];
    float color[3];
    uint type;             /* MATERIAL_* */
    uint color_map;
    uint emission_map;
    uint type_map;
    uint bump_map;
} Material;
CLPT_ASSERT_SIZE(Material, 44);

/* An affine object-to-world transform (transform.cuh) and its inverse, each the top three
 * rows of a 4x4 matrix, row by row (the bottom row is 0 0 0 1). */
#define TRANSFORM_NONE 0xFFFFFFFFu
typedef struct Transform {
    float m[12];
    float inv[12];
} Transform;
CLPT_ASSERT_SIZE(Transform, 96);

/* A sphere (sphere.cuh), in its object space when it has a transform. Centre and radius are
 * double-floats, center + center_lo and radius + radius_lo (the host rounds its f64 values
 * twice), so that a huge sphere's surface lies where the scene's decimals put it: smallpt's
 * ceiling, centre y -99918.4, is 1.6e-3 off in f32 alone, 0.6% of the depth its light is sunk. */
typedef struct Sphere {
    float center[3];
    float radius;
    float center_lo[3];
    float radius_lo;
    uint material;
    uint transform;        /* index into the Transform array, or TRANSFORM_NONE */
} Sphere;
CLPT_ASSERT_SIZE(Sphere, 40);

/* A one-sided plane n.p = offset (plane.cuh), visible from the side n points to, limited to
 * the points p with |p - center| <= range in every coordinate (the original's bounding box,
 * centred on n*offset in the scene's own coordinates; the host moves both with the
 * camera-relative origin, src/device/upload.rs). centerp, dir_u, dir_v map texture
 * coordinates (texture issue). */
typedef struct Plane {
    float normal[3];       /* unit */
    float offset;
    float range;
    float center[3];
    float centerp[3];
    float dir_u[3];
    float dir_v[3];
    uint material;
    uint transform;        /* index into the Transform array, or TRANSFORM_NONE */
} Plane;
CLPT_ASSERT_SIZE(Plane, 76);

/* A triangle mesh's data, shared by every instance of it (mesh.cuh): its kd-tree nodes and
 * triangle index list, its index triples (vertex numbers counted from first_vertex) and its
 * vertices (and per-vertex normals when has_normals), in the scene's common arrays. */
typedef struct MeshDesc {
    uint first_node;
    uint first_index;
    uint first_triangle;
    uint first_vertex;
    uint has_normals;
    float lo[3];           /* object-space bounds, rounded outwards */
    float hi[3];
} MeshDesc;
CLPT_ASSERT_SIZE(MeshDesc, 44);

/* A mesh placed in the scene. */
typedef struct MeshInstance {
    uint mesh;             /* index into the MeshDesc array */
    uint transform;        /* index into the Transform array, or TRANSFORM_NONE */
    uint material;
} MeshInstance;
CLPT_ASSERT_SIZE(MeshInstance, 12);

/* A surface of revolution (revsurface.cuh): its profile as Bezier segments of one degree,
 * degree+1 (x, y) control points each, in the scene's float2 point array. The host centres the
 * profile's heights on 0 and moves the surface back by its transform, so the solver's
 * tolerances are relative to the profile's own size (revsurface.h). */
typedef struct RevSurface {
    uint first_point;
    uint num_segments;
    uint degree;
    uint material;
    uint transform;        /* index into the Transform array, or TRANSFORM_NONE */
    float radius;          /* the largest |x| of its control points as stored */
    float y_lo;            /* their least and greatest y: the hull's box */
    float y_hi;
} RevSurface;
CLPT_ASSERT_SIZE(RevSurface, 32);

/* What a BVH leaf holds: an object of some kind, by its index among its kind. */
#define OBJECT_SPHERE 0u
#define OBJECT_PLANE 1u
#define OBJECT_MESH 2u
#define OBJECT_REVSURFACE 3u
typedef struct ObjectRef {
    uint kind;             /* OBJECT_* */
    uint index;
} ObjectRef;
CLPT_ASSERT_SIZE(ObjectRef, 8);

/* An emitter of the light list that next-event estimation samples (nee.h), in world space
 * (the host applied its object's transform: src/device/lights.rs). Entries are sorted by
 * (kind, index, triangle), so that a hit finds its entry by binary search, and `cdf` rises along
 * them, so that a uniform number picks an entry with probability `prob`. */
typedef struct Light {
    uint kind;             /* OBJECT_SPHERE, OBJECT_PLANE or OBJECT_MESH, as the hit is */
    uint index;            /* the sphere, plane or mesh instance */
    uint triangle;         /* a mesh's triangle (Hit.prim); 0 for spheres and planes */
    uint material;         /* of constant emission */
    float corner[3];       /* a sphere's centre; a square's or a triangle's first corner */
    float edge1[3];        /* a square's or a triangle's edges from that corner */
    float edge2[3];
    float normal[3];       /* unit; a plane emits to this side, a triangle to both; a
                            * sphere's visible cap is about it */
    float radius;          /* a sphere's */
    float area;            /* a square's or a triangle's; a sphere cap's */
    float prob;            /* the probability that light sampling picks this entry */
    float cdf;             /* the sum of prob up to and including this entry */
    float cap_height;      /* a sphere's visible cap: the points q with
                            * dot(q - corner, normal) >= radius - cap_height; 0: all of it */
    uint solid_angle;      /* 1: a rectangle sampled by the solid angle it subtends (nee.h
                            * sph_rect; a wall of the closed room); 0: by area */
} Light;
CLPT_ASSERT_SIZE(Light, 88);

/* Everything a render launch needs besides the object arrays, uploaded once per render. */
typedef struct RenderParams {
    Camera camera;
    uint num_spheres;
    uint num_planes;
    uint num_mesh_instances;
    uint num_revsurfaces;
    uint num_objects;      /* ObjectRef entries; [first_unbounded, num_objects) are outside the BVH */
    uint first_unbounded;
    uint num_bvh_nodes;
    uint seed_lo;          /* the 64-bit --seed, the Philox key */
    uint seed_hi;
    uint max_depth;        /* safety cap on path length (bounces) */
    uint rr_depth;         /* Russian roulette starts at this depth */
    uint texture_filter;   /* FILTER_* */
    uint num_lights;       /* Light entries of the light list (next-event estimation) */
    float rr_threshold;    /* roulette's weight window: paths whose largest throughput
                            * component is below it play roulette (pathtracer.cl) */
    uint walls[6];         /* the planes tested as walls where there is no object BVH
                            * (objects.h, walls_intersect): at 2k the one whose normal is +axis
                            * k, at 2k + 1 the one whose normal is -axis k, or WALL_NONE */
    uint wall_mask;        /* bit i: plane i is one of walls[] (the host picks only planes
                            * numbered below 32) */
} RenderParams;
CLPT_ASSERT_SIZE(RenderParams, 172);

/* An empty slot of RenderParams.walls. */
#define WALL_NONE 0xFFFFFFFFu

#endif
