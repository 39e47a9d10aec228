/* types.h: every struct, constant and buffer shared between host and device.
 *
 * WRITTEN BY THE HOST from src/contract/types.rs and buffers.rs, its one definition: edit those
 * and run `CLPT_WRITE_TYPES_H=1 cargo test --release --test layout` (the test fails while this
 * file differs). Reads: nothing. Writes: nothing. Why: both sides must agree to the byte; the
 * layout probe (tests/layout.rs) also compiles offsetof() for every field and every constant on
 * the device and compares them with Rust's. Rules: only 4-byte scalars and arrays of them (no
 * float3: it is 16 bytes with 16-byte alignment), so no implicit padding can differ between
 * compilers.
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

/* Texture map formats (texture.h), each map in the smallest format that holds it. No map: a
 * material without this map. */
#define MAP_NONE 0xFFFFFFFFu
#define MAP_RGB8 0u    /* 3 bytes per texel: colour or emission, value / 255 */
#define MAP_TYPE8 1u   /* 1 byte per texel: a MATERIAL_* value */
#define MAP_BUMP8 2u   /* 2 signed bytes per texel: bump gradients (du, dv) * 127 */

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

/* The axis bits of a kd-tree leaf (KdNode.flags). */
#define KD_LEAF 3u

/* A kd-tree node over a mesh's triangles (kdtree.h), 8 bytes, in depth-first order: an interior
 * node's "below" child (coordinates < split) is the next node, its "above" child is at the index
 * stored in `flags`.
 *   interior: flags = axis (0, 1, 2) | above_child << 2; data = the split coordinate's bits
 *   leaf:     flags = 3 | triangle_count << 2;           data = first entry in the mesh's
 *             triangle index list (the triangles overlapping the leaf) */
typedef struct KdNode {
    uint flags;
    uint data;
} KdNode;
CLPT_ASSERT_SIZE(KdNode, 8);

/* Marks a wide BVH child that is a leaf: WIDE_BVH_LEAF | (count - 1) << 28 | first slot. */
#define WIDE_BVH_LEAF 0x80000000u

/* An unused child slot of a wide BVH node (its box empty). */
#define WIDE_BVH_EMPTY 0xFFFFFFFFu

/* The words of a tree leaf's triangle slot, which both mesh trees' leaves count in (in the
 * kd_indices buffer): the triangle's three vertices' numbers in the scene's vertex array and its
 * number in its mesh (src/shapes/mesh.rs, triangle.h `slots_intersect`). */
#define LEAF_SLOT 4u

/* A node of a mesh's 8-wide BVH (src/accel/wide_bvh.rs, wide_bvh.h), a CPU's mesh tree: the
 * boxes of up to eight children as arrays per bound, so that one ray tests all eight at once on
 * float8. A child is another node's index (relative to the mesh's first node), WIDE_BVH_LEAF |
 * (count - 1) << 28 | first slot (relative to the mesh's first index), or WIDE_BVH_EMPTY (its
 * box empty). */
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

/* A node of a mesh's binary BVH (src/accel/bvh2.rs, bvh2.h), a GPU's mesh tree: both children's
 * boxes and references, so that one step reads one node and tests both (Aila and Laine 2009). A
 * child is as in WideBvhNode: another node's index, WIDE_BVH_LEAF | (count - 1) << 28 | first
 * triangle (a Bvh2Triangle, relative to the mesh's first), or WIDE_BVH_EMPTY. 64 bytes with
 * `pad`, so that a node is four aligned float4, which bvh2.h reads it as. */
typedef struct Bvh2Node {
    float lo0[3];
    float hi0[3];
    float lo1[3];
    float hi1[3];
    uint child[2];
    uint pad[2];
} Bvh2Node;
CLPT_ASSERT_SIZE(Bvh2Node, 64);

/* A binary BVH leaf's triangle (src/shapes/mesh.rs, bvh2.h): its three vertices as the vertex
 * array holds them, its number in its mesh, and padding, so that it is three aligned float4 read
 * at once, with no vertex numbers to follow. */
typedef struct Bvh2Triangle {
    float vertices[9];
    uint number;
    uint pad[2];
} Bvh2Triangle;
CLPT_ASSERT_SIZE(Bvh2Triangle, 48);

/* Marks an object BVH child that is an object: BVH_LEAF | object index. */
#define BVH_LEAF 0x80000000u

/* The missing second child of a one-object BVH. */
#define BVH_EMPTY 0xFFFFFFFFu

/* A node of the object BVH (bvh.h) holding the boxes of both its children, so traversal tests
 * the two and descends into the nearer one first. A child is another node's index, or BVH_LEAF |
 * object index, or BVH_EMPTY (only in a one-object tree). */
typedef struct BvhNode {
    float lo0[3];
    float hi0[3];
    float lo1[3];
    float hi1[3];
    uint child[2];
} BvhNode;
CLPT_ASSERT_SIZE(BvhNode, 56);

/* The camera (camera.cuh): smallpt's basis, plus a thin lens when focus_distance > 0. A primary
 * ray through image point (x, y), y = 0 the bottom row, has direction cx*(x/w - 1/2) + cy*(y/h -
 * 1/2) + forward. */
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

/* A material (material.cuh): plain values, each replaced per texel by its map if it has one (an
 * index into the TextureMap array, or MAP_NONE). */
typedef struct Material {
    float emission[3];
    float color[3];
    uint kind;             /* MATERIAL_* */
    uint color_map;
    uint emission_map;
    uint type_map;
    uint bump_map;
} Material;
CLPT_ASSERT_SIZE(Material, 44);

/* An object without a transform. */
#define TRANSFORM_NONE 0xFFFFFFFFu

/* An affine object-to-world transform (transform.cuh) and its inverse, each the top three rows
 * of a 4x4 matrix, row by row (the bottom row is 0 0 0 1). */
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

/* A one-sided plane n.p = offset (plane.cuh), visible from the side n points to, limited to the
 * points p with |p - center| <= range in every coordinate (the original's bounding box, centred
 * on n*offset in the scene's own coordinates; the host moves both with the camera-relative
 * origin, src/pack/mod.rs). centerp, dir_u, dir_v map texture coordinates (texture issue). */
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

/* A triangle mesh's data, shared by every instance of it (mesh.cuh): its tree's nodes and leaf
 * slots (LEAF_SLOT words each, or Bvh2Triangles: `first_index` counts those), its index triples
 * (vertex numbers counted from first_vertex) and its vertices (and per-vertex normals when
 * has_normals), in the scene's common arrays. */
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

/* Segments a group hull of a surface of revolution bounds (RevSurface): a ray that cannot reach
 * a group's hull skips its segments' own hulls (revsurface.h). */
#define REV_GROUP 4u

/* A surface of revolution (revsurface.cuh): its profile as Bezier segments of one degree,
 * degree+1 (x, y) control points each, in the scene's float2 point array. The host centres the
 * profile's heights on 0 and moves the surface back by its transform, so the solver's tolerances
 * are relative to the profile's own size (revsurface.h). After the points, from `first_hull`,
 * each segment's hull: the box of its control points as two float2, (x_lo, x_hi) and (y_lo,
 * y_hi) (src/shapes/revsurface.rs, `segment_hulls`); after those, at `first_hull + 2
 * num_segments`, each group's hull in the same form: the union of REV_GROUP consecutive
 * segments' hulls, the last group's of those left (`group_hulls`). */
typedef struct RevSurface {
    uint first_point;
    uint first_hull;
    uint num_segments;
    uint degree;
    uint material;
    uint transform;        /* index into the Transform array, or TRANSFORM_NONE */
    float radius;          /* the largest |x| of its control points as stored */
    float y_lo;            /* their least and greatest y: the hull's box */
    float y_hi;
} RevSurface;
CLPT_ASSERT_SIZE(RevSurface, 36);

/* The kinds of object, one list for what a ray hit (Hit.kind, scene.h), what a BVH leaf holds
 * (ObjectRef) and what a light-list entry is (Light): each names an object by its kind and its
 * index among its kind. Each kind is also an entry of OBJECT_KINDS. */
#define OBJECT_NONE 0u
#define OBJECT_SPHERE 1u
#define OBJECT_PLANE 2u
#define OBJECT_MESH 3u
#define OBJECT_REVSURFACE 4u

/* An object of the object BVH's leaves (bvh.h). */
typedef struct ObjectRef {
    uint kind;             /* OBJECT_* */
    uint index;
} ObjectRef;
CLPT_ASSERT_SIZE(ObjectRef, 8);

/* An emitter of the light list that next-event estimation samples (nee.h), in world space (the
 * host applied its object's transform: src/pack/lights.rs). Entries are sorted by (kind, index,
 * triangle), so that a hit finds its entry by binary search, and `cdf` rises along them, so that
 * a uniform number picks an entry with probability `prob`. */
typedef struct Light {
    uint kind;             /* OBJECT_SPHERE, OBJECT_PLANE or OBJECT_MESH, as a hit on it is */
    uint index;            /* the sphere, plane or mesh instance */
    uint triangle;         /* a mesh's triangle (Hit.prim); 0 for spheres and planes */
    uint material;         /* of constant emission */
    float corner[3];       /* a sphere's centre; a square's or a triangle's first corner */
    float edge1[3];        /* a square's or a triangle's edges from that corner */
    float edge2[3];
    /* unit; a plane emits to this side, a triangle to both; a sphere's visible cap is about it */
    float normal[3];
    float radius;          /* a sphere's */
    float area;            /* a square's or a triangle's; a sphere cap's */
    float prob;            /* the probability that light sampling picks this entry */
    float cdf;             /* the sum of prob up to and including this entry */
    /* a sphere's visible cap: the points q with dot(q - corner, normal) >= radius - cap_height;
     * 0: all of it (src/pack/lights.rs, `visible_cap`) */
    float cap_height;
    /* 1: a rectangle sampled by the solid angle it subtends (nee.h sph_rect; a wall of the
     * closed room, src/pack/lights.rs); 0: by area */
    uint solid_angle;
} Light;
CLPT_ASSERT_SIZE(Light, 88);

/* Everything a render launch needs besides the object arrays, uploaded once per render. */
typedef struct RenderParams {
    Camera camera;
    /* the objects of each kind, at its OBJECT_* (slot 0, OBJECT_NONE, holds 0) */
    uint counts[5];
    /* ObjectRef entries; [first_unbounded, num_objects) are outside the BVH */
    uint num_objects;
    uint first_unbounded;
    uint num_bvh_nodes;
    uint seed_lo;          /* the 64-bit --seed, the Philox key */
    uint seed_hi;
    uint max_depth;        /* safety cap on path length (bounces) */
    uint rr_depth;         /* Russian roulette starts at this depth */
    uint texture_filter;   /* FILTER_* */
    uint num_lights;       /* Light entries of the light list (next-event estimation) */
    /* roulette's weight window: paths whose largest throughput component is below it play
     * roulette (pathtracer.cl) */
    float rr_threshold;
    /* the planes tested as walls where there is no object BVH (plane.h, walls_intersect): at 2k
     * the one whose normal is +axis k, at 2k + 1 the one whose normal is -axis k, or WALL_NONE
     * (src/pack/mod.rs, `walls`) */
    uint walls[6];
    /* bit i: plane i is one of walls[] (the host picks only planes numbered below 32) */
    uint wall_mask;
} RenderParams;
CLPT_ASSERT_SIZE(RenderParams, 176);

/* An empty slot of RenderParams.walls. */
#define WALL_NONE 0xFFFFFFFFu

/* One image row's error sums after some samples (pathtracer.cl error_rows, for the per-pass
 * report: src/render/mod.rs), each over the row's pixels and channels. */
typedef struct ErrorRow {
    /* the estimated squared error of the mean: the difference of the even and odd halves
     * squared, times n_even n_odd / n^2 (its expectation is the variance of the mean) */
    float estimate;
    float estimate_rel;    /* the same over (mean^2 + eps) */
    float squared;         /* with a reference: the squared error */
    float squared_rel;     /* with a reference: the squared error over (ref^2 + eps) */
    float absolute;        /* with a reference: the absolute error */
} ErrorRow;
CLPT_ASSERT_SIZE(ErrorRow, 20);

/* Every kind of object, in the order rays meet them without the object BVH
 * (src/contract/types.rs, OBJECT_KINDS): its program switch CLPT_KINDS (on unless the host's -D
 * turns it off: src/render/features.rs) and SHAPES(X), X(OBJECT_KIND, kind) for each kind the
 * program has. kernels/shapes.h says what each kind defines. */
#ifndef CLPT_SPHERES
#define CLPT_SPHERES 1
#endif
#if CLPT_SPHERES
#define SHAPE_SPHERE(X) X(OBJECT_SPHERE, sphere)
#else
#define SHAPE_SPHERE(X)
#endif
#ifndef CLPT_PLANES
#define CLPT_PLANES 1
#endif
#if CLPT_PLANES
#define SHAPE_PLANE(X) X(OBJECT_PLANE, plane)
#else
#define SHAPE_PLANE(X)
#endif
#ifndef CLPT_MESHES
#define CLPT_MESHES 1
#endif
#if CLPT_MESHES
#define SHAPE_MESH(X) X(OBJECT_MESH, mesh)
#else
#define SHAPE_MESH(X)
#endif
#ifndef CLPT_REVSURFACES
#define CLPT_REVSURFACES 1
#endif
#if CLPT_REVSURFACES
#define SHAPE_REVSURFACE(X) X(OBJECT_REVSURFACE, revsurface)
#else
#define SHAPE_REVSURFACE(X)
#endif
#define SHAPES(X) SHAPE_SPHERE(X) SHAPE_PLANE(X) SHAPE_MESH(X) SHAPE_REVSURFACE(X)

/* Every scene buffer, X(element type, parameter name), in the order kernels take them
 * (src/contract/buffers.rs; scene.h builds the Scene struct and the kernels' parameter list from
 * it). */
#define SCENE_BUFFERS(X) \
    X(RenderParams, params) \
    X(Material, materials) \
    X(Sphere, spheres) \
    X(Plane, planes) \
    X(TextureMap, maps) \
    X(uchar, texels) \
    X(Transform, transforms) \
    X(MeshDesc, meshes) \
    X(MeshInstance, mesh_instances) \
    X(KdNode, kd_nodes) \
    X(uint, kd_indices) \
    X(uint, triangles) \
    X(float, vertices) \
    X(float, normals) \
    X(ObjectRef, objects) \
    X(BvhNode, bvh) \
    X(RevSurface, revsurfaces) \
    X(float2, rev_points) \
    X(Light, lights)

#endif
