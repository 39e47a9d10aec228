//! An 8-wide BVH over a mesh's triangles, a CPU's mesh tree (kernels/wide_bvh.h; render/mod.rs
//! `MeshTree`).
//!
//! A CPU traces a mesh one ray at a time (a wide program, kernels/lanes.h, lane by lane), where
//! a kd-tree step decides one split plane per node: scalar work on SIMD hardware. A node of
//! this tree holds the boxes of up to eight children as six float8 arrays, so one ray tests all
//! eight with a few vector instructions (Wald et al., "Getting rid of packets", 2008; Embree's
//! BVH8; Ylitie, Karras and Laine 2017 on wide BVHs). It is the binned-SAH binary BVH
//! ([`super::binary_bvh`]) collapsed: each node takes in the children of its largest inner
//! children until it has eight (pbrt-v4 and Embree collapse the same way). Leaves hold up to
//! [`MAX_LEAF`] triangles. GPUs walk the binary BVH as it is ([`super::bvh2`]): this traversal,
//! with its deep stack, ran 9 to 43% slower there with light sampling than the kd-tree
//! (BENCHMARKS.md).

use super::binary_bvh::{Binary, FlatBvh, Flatten};
use crate::contract::{WIDE_BVH_EMPTY, WideBvhNode};

/// Children a node holds (the eight of `WideBvhNode` in types.h).
pub const WIDTH: usize = 8;
/// The most triangles a leaf holds: on the dragon room (2 cores, PoCL, user CPU) 2 ran 2 to 5%
/// faster than 4, as fast as 1 (within 1.4%), 8 about 10% slower.
pub const MAX_LEAF: usize = 2;

/// A mesh's 8-wide BVH, built by [`FlatBvh::build`].
pub type WideBvh = FlatBvh<WideBvhNode>;

impl Flatten for WideBvhNode {
    const MAX_LEAF: usize = MAX_LEAF;

    fn empty() -> Self {
        WideBvhNode {
            lo_x: [f32::INFINITY; WIDTH],
            hi_x: [f32::NEG_INFINITY; WIDTH],
            lo_y: [f32::INFINITY; WIDTH],
            hi_y: [f32::NEG_INFINITY; WIDTH],
            lo_z: [f32::INFINITY; WIDTH],
            hi_z: [f32::NEG_INFINITY; WIDTH],
            child: [WIDE_BVH_EMPTY; WIDTH],
        }
    }

    fn set_child(&mut self, k: usize, child: &Binary, reference: u32) {
        let (lo, hi) = child.bounds().to_f32_outward();
        self.lo_x[k] = lo[0];
        self.lo_y[k] = lo[1];
        self.lo_z[k] = lo[2];
        self.hi_x[k] = hi[0];
        self.hi_y[k] = hi[1];
        self.hi_z[k] = hi[2];
        self.child[k] = reference;
    }

    /// The binary subtree `inner` collapsed: its largest inner child opened, again and again,
    /// until there are WIDTH children or only leaves.
    fn children(inner: &Binary) -> Vec<&Binary> {
        let Binary::Inner { children, .. } = inner else {
            unreachable!("children of a leaf")
        };
        let mut open: Vec<&Binary> = children.iter().collect();
        while open.len() < WIDTH {
            let largest = open
                .iter()
                .enumerate()
                .filter(|(_, c)| matches!(c, Binary::Inner { .. }))
                .max_by(|a, b| {
                    a.1.bounds()
                        .surface_area()
                        .total_cmp(&b.1.bounds().surface_area())
                })
                .map(|(i, _)| i);
            let Some(i) = largest else { break };
            let Binary::Inner { children, .. } = open.swap_remove(i) else {
                unreachable!()
            };
            open.extend(children.iter());
        }
        open
    }
}

#[cfg(test)]
mod tests {
    use super::super::binary_bvh::test_meshes::{check_tree, degenerate, grid};
    use super::*;
    use crate::accel::aabb::Aabb;
    use glam::DVec3;

    /// The tree's leaves ([`check_tree`]).
    fn check(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> usize {
        let tree = WideBvh::build(positions, triangles).expect("fits");
        let children = |node: u32| {
            let n = &tree.nodes[node as usize];
            (0..WIDTH)
                .map(|k| {
                    let lo = DVec3::new(n.lo_x[k] as f64, n.lo_y[k] as f64, n.lo_z[k] as f64);
                    let hi = DVec3::new(n.hi_x[k] as f64, n.hi_y[k] as f64, n.hi_z[k] as f64);
                    (Aabb { lo, hi }, n.child[k])
                })
                .collect()
        };
        let tree_of = (tree.bounds, &tree.indices[..], MAX_LEAF);
        check_tree(positions, triangles, tree_of, children).0
    }

    #[test]
    fn every_triangle_is_in_one_leaf_inside_its_boxes() {
        for (n, flat) in [(1, true), (2, false), (40, true), (60, false)] {
            let (p, t) = grid(n, flat);
            assert!(check(&p, &t) >= t.len() / MAX_LEAF);
        }
    }

    #[test]
    fn degenerate_input_builds_shallow_trees() {
        let (p, t) = degenerate();
        check(&p, &t);
        // No triangle at all: one empty root.
        let tree = WideBvh::build(&p, &[]).unwrap();
        assert_eq!(tree.nodes.len(), 1);
        assert!(tree.nodes[0].child.iter().all(|&c| c == WIDE_BVH_EMPTY));
        assert!(tree.bounds.is_empty());
    }
}
