//! A binary BVH over a mesh's triangles, a GPU's mesh tree (kernels/bvh2.h; render/mod.rs
//! `MeshTree`).
//!
//! The binned-SAH binary BVH ([`super::binary_bvh`]) stored in Aila and Laine's layout
//! ("Understanding the efficiency of ray traversal on GPUs", HPG 2009): a node holds both its
//! children's boxes and references, so one step of the walk reads one node and tests both
//! boxes. Nodes are in depth-first order, a node's first inner child right after it. Leaves
//! of up to [`MAX_LEAF`] triangles hold their vertices (src/shapes/mesh.rs,
//! `push_bvh2_triangles`). On an H100 it walked case1 about 6% faster than the SAH kd-tree
//! without light sampling (2 to 4% with it), the dragon room 15% (7%) (BENCHMARKS.md, "A binary
//! BVH for GPUs" and "A binary BVH's triangles in its leaves").

use super::binary_bvh::{Binary, FlatBvh, Flatten};
use crate::contract::{Bvh2Node, WIDE_BVH_EMPTY};

/// A mesh's binary BVH, built by [`FlatBvh::build`].
pub type Bvh2 = FlatBvh<Bvh2Node>;

/// The most triangles a leaf holds: on the H100, 4 and 2 ran level (within 1%), 8 3 to 5%
/// slower.
pub const MAX_LEAF: usize = 4;

impl Flatten for Bvh2Node {
    const MAX_LEAF: usize = MAX_LEAF;

    fn empty() -> Self {
        Bvh2Node {
            lo0: [f32::INFINITY; 3],
            hi0: [f32::NEG_INFINITY; 3],
            lo1: [f32::INFINITY; 3],
            hi1: [f32::NEG_INFINITY; 3],
            child: [WIDE_BVH_EMPTY; 2],
            pad: [0; 2],
        }
    }

    fn set_child(&mut self, k: usize, child: &Binary, reference: u32) {
        let (lo, hi) = child.bounds().to_f32_outward();
        if k == 0 {
            (self.lo0, self.hi0) = (lo, hi);
        } else {
            (self.lo1, self.hi1) = (lo, hi);
        }
        self.child[k] = reference;
    }

    fn children(inner: &Binary) -> Vec<&Binary> {
        let Binary::Inner { children, .. } = inner else {
            unreachable!("children of a leaf")
        };
        children.iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::binary_bvh::SAH_DEPTH;
    use super::super::binary_bvh::test_meshes::{check_tree, degenerate, grid};
    use super::*;
    use crate::accel::aabb::Aabb;
    use glam::DVec3;

    /// The tree's leaves and depth ([`check_tree`]), the depth within the programs' stack
    /// (kernels/bvh2.h).
    fn check(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> (usize, usize) {
        let tree = Bvh2::build(positions, triangles).expect("fits");
        let children = |node: u32| {
            let n = &tree.nodes[node as usize];
            let b = |lo: [f32; 3], hi: [f32; 3]| Aabb {
                lo: DVec3::from(lo.map(f64::from)),
                hi: DVec3::from(hi.map(f64::from)),
            };
            vec![(b(n.lo0, n.hi0), n.child[0]), (b(n.lo1, n.hi1), n.child[1])]
        };
        let tree_of = (tree.bounds, &tree.indices[..], MAX_LEAF);
        let (leaves, depth) = check_tree(positions, triangles, tree_of, children);
        assert!(depth <= 64, "depth {depth}");
        (leaves, depth)
    }

    #[test]
    fn every_triangle_is_in_one_leaf_inside_its_boxes() {
        for (n, flat) in [(1, true), (2, false), (40, true), (60, false)] {
            let (p, t) = grid(n, flat);
            assert!(check(&p, &t).0 >= t.len() / MAX_LEAF);
        }
    }

    #[test]
    fn degenerate_input_builds_trees_within_the_stack() {
        // Copies of one triangle fall back to medians below SAH_DEPTH: about log2(n / MAX_LEAF)
        // levels.
        let (p, t) = degenerate();
        let (_, depth) = check(&p, &t);
        assert!(depth <= SAH_DEPTH + 12, "depth {depth}");
        // A staircase of triangles whose sizes double every eight steps.
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..400u32 {
            let x = 2f32.powi(i as i32 / 8);
            p.extend([[x, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0]]);
            t.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let (_, depth) = check(&p, &t);
        assert!(depth <= SAH_DEPTH + 9, "depth {depth}");
        // No triangle at all: one empty root.
        let tree = Bvh2::build(&p, &[]).unwrap();
        assert_eq!(tree.nodes.len(), 1);
        assert_eq!(tree.nodes[0].child, [WIDE_BVH_EMPTY; 2]);
        assert!(tree.bounds.is_empty());
    }
}
