//! Every constant and struct the host and the kernels share, declared once: `kernels/types.h`
//! is written from these declarations ([`super::header`]), and the device's layout probe checks
//! every size, offset and constant against them (`device::layout`). Rules: only 4-byte scalars
//! and arrays of them (no `float3`: it is 16 bytes with 16-byte alignment), so no implicit
//! padding can differ between compilers.

shared! {
    /// Material types, as the original's `type diff|spec|refr`.
    pub const MATERIAL_DIFFUSE: u32 = 0;
    pub const MATERIAL_SPECULAR: u32 = 1;
    pub const MATERIAL_REFRACTIVE: u32 = 2;

    /// Texture map formats (texture.h), each map in the smallest format that holds it. No map:
    /// a material without this map.
    pub const MAP_NONE: u32 = u32::MAX;
    /// 3 bytes per texel: colour or emission, value / 255
    pub const MAP_RGB8: u32 = 0;
    /// 1 byte per texel: a MATERIAL_* value
    pub const MAP_TYPE8: u32 = 1;
    /// 2 signed bytes per texel: bump gradients (du, dv) * 127
    pub const MAP_BUMP8: u32 = 2;

    /// Texture lookup filters (RenderParams.texture_filter).
    pub const FILTER_BILINEAR: u32 = 0;
    pub const FILTER_NEAREST: u32 = 1;

    /// One texture map inside the scene's texel buffer; row 0 is the top of the image (v = 1).
    pub struct TextureMap {
        /// in bytes
        pub offset: u32,
        pub width: u32,
        pub height: u32,
        /// MAP_*
        pub format: u32,
    }

    /// The axis bits of a kd-tree leaf (KdNode.flags).
    pub const KD_LEAF: u32 = 3;

    /// A kd-tree node over a mesh's triangles (kdtree.h), 8 bytes, in depth-first order: an
    /// interior node's "below" child (coordinates < split) is the next node, its "above" child
    /// is at the index stored in `flags`.
    ///   interior: flags = axis (0, 1, 2) | above_child << 2; data = the split coordinate's bits
    ///   leaf:     flags = 3 | triangle_count << 2;           data = first entry in the mesh's
    ///             triangle index list (the triangles overlapping the leaf)
    pub struct KdNode {
        pub flags: u32,
        pub data: u32,
    }

    /// Marks a wide BVH child that is a leaf: WIDE_BVH_LEAF | (count - 1) << 28 | first slot.
    pub const WIDE_BVH_LEAF: u32 = 0x8000_0000;
    /// An unused child slot of a wide BVH node (its box empty).
    pub const WIDE_BVH_EMPTY: u32 = u32::MAX;
    /// The words of a tree leaf's triangle slot, which both mesh trees' leaves count in (in the
    /// kd_indices buffer): the triangle's three vertices' numbers in the scene's vertex array
    /// and its number in its mesh (src/shapes/mesh.rs, triangle.h `slots_intersect`).
    pub const LEAF_SLOT: u32 = 4;

    /// A node of a mesh's 8-wide BVH (src/accel/wide_bvh.rs, wide_bvh.h), a CPU's mesh tree:
    /// the boxes of up to eight children as arrays per bound, so that one ray tests all eight
    /// at once on float8. A child is another node's index (relative to the mesh's first node),
    /// WIDE_BVH_LEAF | (count - 1) << 28 | first slot (relative to the mesh's first index), or
    /// WIDE_BVH_EMPTY (its box empty).
    pub struct WideBvhNode {
        pub lo_x: [f32; 8],
        pub hi_x: [f32; 8],
        pub lo_y: [f32; 8],
        pub hi_y: [f32; 8],
        pub lo_z: [f32; 8],
        pub hi_z: [f32; 8],
        pub child: [u32; 8],
    }

    /// A node of a mesh's binary BVH (src/accel/bvh2.rs, bvh2.h), a GPU's mesh tree: both
    /// children's boxes and references, so that one step reads one node and tests both (Aila
    /// and Laine 2009). A child is as in WideBvhNode: another node's index, WIDE_BVH_LEAF |
    /// (count - 1) << 28 | first triangle (a Bvh2Triangle, relative to the mesh's first), or
    /// WIDE_BVH_EMPTY. 64 bytes with `pad`, so that a node is four aligned float4, which bvh2.h
    /// reads it as.
    pub struct Bvh2Node {
        pub lo0: [f32; 3],
        pub hi0: [f32; 3],
        pub lo1: [f32; 3],
        pub hi1: [f32; 3],
        pub child: [u32; 2],
        pub pad: [u32; 2],
    }

    /// A binary BVH leaf's triangle (src/shapes/mesh.rs, bvh2.h): its three vertices as the
    /// vertex array holds them, its number in its mesh, and padding, so that it is three aligned
    /// float4 read at once, with no vertex numbers to follow.
    pub struct Bvh2Triangle {
        pub vertices: [f32; 9],
        pub number: u32,
        pub pad: [u32; 2],
    }

    /// Marks an object BVH child that is an object: BVH_LEAF | object index.
    pub const BVH_LEAF: u32 = 0x8000_0000;
    /// The missing second child of a one-object BVH.
    pub const BVH_EMPTY: u32 = u32::MAX;

    /// A node of the object BVH (bvh.h) holding the boxes of both its children, so traversal
    /// tests the two and descends into the nearer one first. A child is another node's index,
    /// or BVH_LEAF | object index, or BVH_EMPTY (only in a one-object tree).
    pub struct BvhNode {
        pub lo0: [f32; 3],
        pub hi0: [f32; 3],
        pub lo1: [f32; 3],
        pub hi1: [f32; 3],
        pub child: [u32; 2],
    }

    /// The camera (camera.cuh): smallpt's basis, plus a thin lens when focus_distance > 0.
    /// A primary ray through image point (x, y), y = 0 the bottom row, has direction
    /// cx*(x/w - 1/2) + cy*(y/h - 1/2) + forward.
    pub struct Camera {
        pub origin: [f32; 3],
        /// unit view direction d
        pub forward: [f32; 3],
        /// image-plane x axis, length w*a/h (a = angle in radians)
        pub cx: [f32; 3],
        /// image-plane y axis, length a
        pub cy: [f32; 3],
        /// unit vectors spanning the lens disk
        pub lens_u: [f32; 3],
        pub lens_v: [f32; 3],
        /// 0: pinhole
        pub lens_radius: f32,
        /// distance of the plane in focus, along forward
        pub focus_distance: f32,
        pub width: u32,
        pub height: u32,
    }

    /// A material (material.cuh): plain values, each replaced per texel by its map if it has
    /// one (an index into the TextureMap array, or MAP_NONE).
    pub struct Material {
        pub emission: [f32; 3],
        pub color: [f32; 3],
        /// MATERIAL_*
        pub kind: u32,
        pub color_map: u32,
        pub emission_map: u32,
        pub type_map: u32,
        pub bump_map: u32,
    }

    /// An object without a transform.
    pub const TRANSFORM_NONE: u32 = u32::MAX;

    /// An affine object-to-world transform (transform.cuh) and its inverse, each the top three
    /// rows of a 4x4 matrix, row by row (the bottom row is 0 0 0 1).
    pub struct Transform {
        pub m: [f32; 12],
        pub inv: [f32; 12],
    }

    /// A sphere (sphere.cuh), in its object space when it has a transform. Centre and radius
    /// are double-floats, center + center_lo and radius + radius_lo (the host rounds its f64
    /// values twice), so that a huge sphere's surface lies where the scene's decimals put it:
    /// smallpt's ceiling, centre y -99918.4, is 1.6e-3 off in f32 alone, 0.6% of the depth its
    /// light is sunk.
    pub struct Sphere {
        pub center: [f32; 3],
        pub radius: f32,
        pub center_lo: [f32; 3],
        pub radius_lo: f32,
        pub material: u32,
        /// index into the Transform array, or TRANSFORM_NONE
        pub transform: u32,
    }

    /// A one-sided plane n.p = offset (plane.cuh), visible from the side n points to, limited
    /// to the points p with |p - center| <= range in every coordinate (the original's bounding
    /// box, centred on n*offset in the scene's own coordinates; the host moves both with the
    /// camera-relative origin, src/pack/mod.rs). centerp, dir_u, dir_v map texture
    /// coordinates (texture issue).
    pub struct Plane {
        /// unit
        pub normal: [f32; 3],
        pub offset: f32,
        pub range: f32,
        pub center: [f32; 3],
        pub centerp: [f32; 3],
        pub dir_u: [f32; 3],
        pub dir_v: [f32; 3],
        pub material: u32,
        /// index into the Transform array, or TRANSFORM_NONE
        pub transform: u32,
    }

    /// A triangle mesh's data, shared by every instance of it (mesh.cuh): its tree's nodes and
    /// leaf slots (LEAF_SLOT words each, or Bvh2Triangles: `first_index` counts those), its
    /// index triples (vertex numbers counted from first_vertex) and
    /// its vertices (and per-vertex normals when has_normals), in the scene's common arrays.
    pub struct MeshDesc {
        pub first_node: u32,
        pub first_index: u32,
        pub first_triangle: u32,
        pub first_vertex: u32,
        pub has_normals: u32,
        /// object-space bounds, rounded outwards
        pub lo: [f32; 3],
        pub hi: [f32; 3],
    }

    /// A mesh placed in the scene.
    pub struct MeshInstance {
        /// index into the MeshDesc array
        pub mesh: u32,
        /// index into the Transform array, or TRANSFORM_NONE
        pub transform: u32,
        pub material: u32,
    }

    /// Segments a group hull of a surface of revolution bounds (RevSurface): a ray that cannot
    /// reach a group's hull skips its segments' own hulls (revsurface.h).
    pub const REV_GROUP: u32 = 4;

    /// A surface of revolution (revsurface.cuh): its profile as Bezier segments of one degree,
    /// degree+1 (x, y) control points each, in the scene's float2 point array. The host centres
    /// the profile's heights on 0 and moves the surface back by its transform, so the solver's
    /// tolerances are relative to the profile's own size (revsurface.h). After the points, from
    /// `first_hull`, each segment's hull: the box of its control points as two float2,
    /// (x_lo, x_hi) and (y_lo, y_hi) (src/shapes/revsurface.rs, `segment_hulls`); after
    /// those, at `first_hull + 2 num_segments`, each group's hull in the same form: the union
    /// of REV_GROUP consecutive segments' hulls, the last group's of those left
    /// (`group_hulls`).
    pub struct RevSurface {
        pub first_point: u32,
        pub first_hull: u32,
        pub num_segments: u32,
        pub degree: u32,
        pub material: u32,
        /// index into the Transform array, or TRANSFORM_NONE
        pub transform: u32,
        /// the largest |x| of its control points as stored
        pub radius: f32,
        /// their least and greatest y: the hull's box
        pub y_lo: f32,
        pub y_hi: f32,
    }

    /// The kinds of object, one list for what a ray hit (Hit.kind, scene.h), what a BVH leaf
    /// holds (ObjectRef) and what a light-list entry is (Light): each names an object by its
    /// kind and its index among its kind. Each kind is also an entry of OBJECT_KINDS.
    pub const OBJECT_NONE: u32 = 0;
    pub const OBJECT_SPHERE: u32 = 1;
    pub const OBJECT_PLANE: u32 = 2;
    pub const OBJECT_MESH: u32 = 3;
    pub const OBJECT_REVSURFACE: u32 = 4;

    /// An object of the object BVH's leaves (bvh.h).
    pub struct ObjectRef {
        /// OBJECT_*
        pub kind: u32,
        pub index: u32,
    }

    /// An emitter of the light list that next-event estimation samples (nee.h), in world space
    /// (the host applied its object's transform: src/pack/lights.rs). Entries are sorted by
    /// (kind, index, triangle), so that a hit finds its entry by binary search, and `cdf` rises
    /// along them, so that a uniform number picks an entry with probability `prob`.
    pub struct Light {
        /// OBJECT_SPHERE, OBJECT_PLANE or OBJECT_MESH, as a hit on it is
        pub kind: u32,
        /// the sphere, plane or mesh instance
        pub index: u32,
        /// a mesh's triangle (Hit.prim); 0 for spheres and planes
        pub triangle: u32,
        /// of constant emission
        pub material: u32,
        /// a sphere's centre; a square's or a triangle's first corner
        pub corner: [f32; 3],
        /// a square's or a triangle's edges from that corner
        pub edge1: [f32; 3],
        pub edge2: [f32; 3],
        /// unit; a plane emits to this side, a triangle to both; a sphere's visible cap is
        /// about it
        pub normal: [f32; 3],
        /// a sphere's
        pub radius: f32,
        /// a square's or a triangle's; a sphere cap's
        pub area: f32,
        /// the probability that light sampling picks this entry
        pub prob: f32,
        /// the sum of prob up to and including this entry
        pub cdf: f32,
        /// a sphere's visible cap: the points q with dot(q - corner, normal) >= radius -
        /// cap_height; 0: all of it (src/pack/lights.rs, `visible_cap`)
        pub cap_height: f32,
        /// 1: a rectangle sampled by the solid angle it subtends (nee.h sph_rect; a wall of the
        /// closed room, src/pack/lights.rs); 0: by area
        pub solid_angle: u32,
    }

    /// Everything a render launch needs besides the object arrays, uploaded once per render.
    pub struct RenderParams {
        pub camera: Camera,
        /// the objects of each kind, at its OBJECT_* (slot 0, OBJECT_NONE, holds 0)
        pub counts: [u32; OBJECT_SLOTS],
        /// ObjectRef entries; [first_unbounded, num_objects) are outside the BVH
        pub num_objects: u32,
        pub first_unbounded: u32,
        pub num_bvh_nodes: u32,
        /// the 64-bit --seed, the Philox key
        pub seed_lo: u32,
        pub seed_hi: u32,
        /// safety cap on path length (bounces)
        pub max_depth: u32,
        /// Russian roulette starts at this depth
        pub rr_depth: u32,
        /// FILTER_*
        pub texture_filter: u32,
        /// Light entries of the light list (next-event estimation)
        pub num_lights: u32,
        /// roulette's weight window: paths whose largest throughput component is below it play
        /// roulette (pathtracer.cl)
        pub rr_threshold: f32,
        /// the planes tested as walls where there is no object BVH (plane.h, walls_intersect):
        /// at 2k the one whose normal is +axis k, at 2k + 1 the one whose normal is -axis k, or
        /// WALL_NONE (src/pack/mod.rs, `walls`)
        pub walls: [u32; 6],
        /// bit i: plane i is one of walls[] (the host picks only planes numbered below 32)
        pub wall_mask: u32,
    }

    /// An empty slot of RenderParams.walls.
    pub const WALL_NONE: u32 = u32::MAX;

    /// One image row's error sums after some samples (pathtracer.cl error_rows, for the
    /// per-pass report: src/render/mod.rs), each over the row's pixels and channels.
    pub struct ErrorRow {
        /// the estimated squared error of the mean: the difference of the even and odd halves
        /// squared, times n_even n_odd / n^2 (its expectation is the variance of the mean)
        pub estimate: f32,
        /// the same over (mean^2 + eps)
        pub estimate_rel: f32,
        /// with a reference: the squared error
        pub squared: f32,
        /// with a reference: the squared error over (ref^2 + eps)
        pub squared_rel: f32,
        /// with a reference: the absolute error
        pub absolute: f32,
    }
}

/// A kind of object as the program sees it: its constant, the prefix of its device functions
/// (kernels/shapes.h) and its program switch.
pub struct ObjectKind {
    /// Its `OBJECT_*` constant.
    pub id: u32,
    /// The prefix of its device functions: `NAME_object_intersect`, `NAME_intersect_all`,
    /// `NAME_object_surface`.
    pub name: &'static str,
    /// Its program switch (kernels/features.h); lower-cased without `CLPT_`, its name in
    /// `clpt render -v`'s feature list.
    pub switch: &'static str,
}

/// Every kind of object, in the order rays meet the kinds without the object BVH (at equal t
/// the first hit found is kept, so the order is part of the image). `kernels/types.h` writes
/// from it each kind's program switch and the `SHAPES(X)` list through which the kernels
/// dispatch (shapes.h); the host counts objects (`RenderParams::counts`) and switches kinds
/// (`render/features.rs`) by it. docs/adding-a-shape.md says how a kind joins.
pub const OBJECT_KINDS: [ObjectKind; 4] = [
    ObjectKind {
        id: OBJECT_SPHERE,
        name: "sphere",
        switch: "CLPT_SPHERES",
    },
    ObjectKind {
        id: OBJECT_PLANE,
        name: "plane",
        switch: "CLPT_PLANES",
    },
    ObjectKind {
        id: OBJECT_MESH,
        name: "mesh",
        switch: "CLPT_MESHES",
    },
    ObjectKind {
        id: OBJECT_REVSURFACE,
        name: "revsurface",
        switch: "CLPT_REVSURFACES",
    },
];

/// Slots of a table indexed by `OBJECT_*`: every kind and `OBJECT_NONE`.
pub const OBJECT_SLOTS: usize = OBJECT_KINDS.len() + 1;

// The kinds are numbered 1, 2, ... in the list's order: a table by kind is a table by place.
const _: () = {
    let mut i = 0;
    while i < OBJECT_KINDS.len() {
        assert!(OBJECT_KINDS[i].id as usize == i + 1);
        i += 1;
    }
};

/// `Default` as all zeros, for the structs where zero is a sensible empty value.
macro_rules! zeroed_default {
    ($($name:ident),*) => {
        $(impl Default for $name {
            fn default() -> Self {
                bytemuck::Zeroable::zeroed()
            }
        })*
    };
}

zeroed_default!(
    TextureMap,
    KdNode,
    WideBvhNode,
    Bvh2Node,
    Bvh2Triangle,
    BvhNode,
    Camera,
    Material,
    Transform,
    MeshDesc,
    MeshInstance,
    RevSurface,
    ObjectRef,
    Light,
    ErrorRow
);

impl KdNode {
    pub fn interior(axis: usize, split: f32, above_child: u32) -> KdNode {
        KdNode {
            flags: axis as u32 | (above_child << 2),
            data: split.to_bits(),
        }
    }

    pub fn leaf(first_index: u32, count: u32) -> KdNode {
        KdNode {
            flags: KD_LEAF | (count << 2),
            data: first_index,
        }
    }

    pub fn is_leaf(&self) -> bool {
        self.flags & 3 == KD_LEAF
    }

    /// Interior nodes: the split axis.
    pub fn axis(&self) -> usize {
        (self.flags & 3) as usize
    }

    /// Interior nodes: the split coordinate.
    pub fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }

    /// Interior nodes: the index of the child above the split (the child below is the next).
    pub fn above_child(&self) -> u32 {
        self.flags >> 2
    }

    /// Leaves: how many triangles, and the first of them in the index list.
    pub fn count(&self) -> u32 {
        self.flags >> 2
    }

    pub fn first_index(&self) -> u32 {
        self.data
    }
}

impl Default for Sphere {
    fn default() -> Self {
        Sphere {
            center: [0.0; 3],
            radius: 1.0,
            center_lo: [0.0; 3],
            radius_lo: 0.0,
            material: 0,
            transform: TRANSFORM_NONE,
        }
    }
}

impl Sphere {
    /// The double-float centre `center + center_lo`, in f64.
    pub fn center_f64(&self) -> glam::DVec3 {
        glam::DVec3::from(self.center.map(f64::from))
            + glam::DVec3::from(self.center_lo.map(f64::from))
    }

    /// The double-float radius `radius + radius_lo`, in f64.
    pub fn radius_f64(&self) -> f64 {
        f64::from(self.radius) + f64::from(self.radius_lo)
    }
}

impl Plane {
    /// The axis its normal lies along, where exactly one of the normal's components is not 0:
    /// the walls of a closed room (pack/lights.rs) and of `walls_intersect` (pack/mod.rs).
    pub fn axis(&self) -> Option<usize> {
        let mut axes = (0..3).filter(|&k| self.normal[k] != 0.0);
        match (axes.next(), axes.next()) {
            (Some(k), None) => Some(k),
            _ => None,
        }
    }
}

impl Default for Plane {
    fn default() -> Self {
        Plane {
            normal: [0.0, 0.0, 1.0],
            offset: 0.0,
            range: 1.0,
            center: [0.0; 3],
            centerp: [0.0; 3],
            dir_u: [0.0; 3],
            dir_v: [0.0; 3],
            material: 0,
            transform: TRANSFORM_NONE,
        }
    }
}

/// Zero, but with no walls: a zeroed slot would name plane 0.
impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            walls: [WALL_NONE; 6],
            ..bytemuck::Zeroable::zeroed()
        }
    }
}
