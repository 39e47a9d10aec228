//! Acceleration structures, built on the host in f64 and flattened into the compact nodes of
//! `kernels/types.h`: a Morton-code BVH over the scene's objects ([`bvh`], ← bvh.cuh) and an SAH
//! kd-tree over each mesh's triangles ([`kdtree`], ← kd-tree.cuh), or on a CPU an 8-wide
//! BVH over them ([`wide_bvh`]), on boxes of [`aabb`] (← AABB.cuh).

pub mod aabb;
pub mod bvh;
pub mod kdtree;
pub mod wide_bvh;
