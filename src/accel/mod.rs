//! Acceleration structures, built on the host in f64 and flattened into the compact nodes of
//! `kernels/types.h`: a Morton-code BVH over the scene's objects ([`bvh`], ← bvh.cuh) and an SAH
//! kd-tree over each mesh's triangles ([`kdtree`], ← kd-tree.cuh), or a BVH over them: binary
//! on a GPU ([`bvh2`]), 8-wide on a CPU ([`wide_bvh`]), both from one SAH build
//! ([`binary_bvh`]); on boxes of [`aabb`] (← AABB.cuh).

pub mod aabb;
pub mod binary_bvh;
pub mod bvh;
pub mod bvh2;
pub mod kdtree;
pub mod wide_bvh;

/// The tree a mesh's triangles are walked through (render/mod.rs chooses it for a device).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum MeshTree {
    /// A SAH kd-tree ([`kdtree`], kernels/kdtree.h): the original's.
    #[default]
    Kd,
    /// A binary BVH ([`bvh2`], kernels/bvh2.h): a GPU's.
    Bvh2,
    /// An 8-wide BVH ([`wide_bvh`], kernels/wide_bvh.h): a CPU's, the only one its wide
    /// programs walk.
    Wide,
}
