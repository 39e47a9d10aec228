//! The scene's device buffers, listed once: kernels take them in this order (`SCENE_BUFFERS`
//! in `kernels/types.h`, written from this list, from which `kernels/scene.h` builds the
//! `Scene` struct and every scene kernel's parameters), and the host binds each by its name.

macro_rules! scene_buffers {
    ($($(#[doc = $doc:literal])* $name:ident: $c_type:literal,)*) => {
        /// Every scene buffer as (parameter name, C element type), in the kernels' order.
        pub const SCENE_BUFFERS: &[(&str, &str)] = &[$((stringify!($name), $c_type)),*];

        /// One `B` per scene buffer (the device's buffers), by the kernels' parameter names.
        pub struct SceneBuffers<B> {
            $($(#[doc = $doc])* pub $name: B,)*
        }

        impl<B> SceneBuffers<B> {
            /// Each buffer with its kernel parameter's name, in the kernels' order.
            pub fn named(&self) -> [(&'static str, &B); SCENE_BUFFERS.len()] {
                [$((stringify!($name), &self.$name)),*]
            }
        }
    };
}

scene_buffers! {
    /// One `RenderParams`.
    params: "RenderParams",
    materials: "Material",
    spheres: "Sphere",
    planes: "Plane",
    maps: "TextureMap",
    /// Every texture map's texels, each map at its `offset`.
    texels: "uchar",
    transforms: "Transform",
    meshes: "MeshDesc",
    mesh_instances: "MeshInstance",
    /// Every mesh's tree nodes: `KdNode`s, or `Bvh2Node`s or `WideBvhNode`s in a program
    /// whose meshes walk those (`CLPT_BVH2`, `CLPT_WIDE_BVH`).
    kd_nodes: "KdNode",
    /// The mesh trees' leaf slots (`LEAF_SLOT` words each), or `Bvh2Triangle`s in a program
    /// whose meshes walk binary BVHs (`CLPT_BVH2`).
    kd_indices: "uint",
    /// Every mesh's triangles as vertex-number triples.
    triangles: "uint",
    /// Every mesh's vertices, three floats each.
    vertices: "float",
    /// Every smooth mesh's vertex normals, three floats each.
    normals: "float",
    objects: "ObjectRef",
    bvh: "BvhNode",
    revsurfaces: "RevSurface",
    /// Every surface of revolution's profile control points.
    rev_points: "float2",
    lights: "Light",
}
