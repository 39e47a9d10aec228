//! A binary BVH over a mesh's triangles, a GPU's mesh tree (kernels/bvh2.h; render/mod.rs
//! `MeshTree`).
//!
//! The binned-SAH binary BVH ([`super::binary_bvh`]) stored in Aila and Laine's layout
//! ("Understanding the efficiency of ray traversal on GPUs", HPG 2009): a node holds both its
//! children's boxes and references, so one step of the walk reads one node and tests both
//! boxes. Nodes are in depth-first order, a node's first inner child right after it. On an
//! H100 it walked case1 4% faster than the SAH kd-tree without light sampling (2% with it), the
//! dragon room 12% (4%), at leaves of [`MAX_LEAF`] (BENCHMARKS.md, "A binary BVH for GPUs").

use super::aabb::Aabb;
use super::binary_bvh::{Binary, BinaryBvh, leaf_ref};
use crate::contract::{Bvh2Node, WIDE_BVH_EMPTY};

/// The most triangles a leaf holds: on the H100, 4 and 2 ran level (within 1%), 8 3 to 5%
/// slower.
pub const MAX_LEAF: usize = 4;

/// The flattened tree of one mesh: `nodes[0]` is the root; a leaf reference's first index
/// indexes `indices`, which hold triangle numbers of the mesh.
pub struct Bvh2 {
    pub nodes: Vec<Bvh2Node>,
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when the mesh has none that can be hit).
    pub bounds: Aabb,
}

impl Bvh2 {
    /// The tree of a mesh given as vertex positions (object space) and index triples, the
    /// triangles left out as the kd-tree's ([`super::kdtree::KdTree::build`]). `None` when a
    /// mesh has 2^28 triangles or more (the leaf reference's limit).
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Option<Bvh2> {
        let binary = BinaryBvh::build(positions, triangles, MAX_LEAF)?;
        let mut out = Bvh2 {
            nodes: Vec::new(),
            indices: binary.indices,
            bounds: binary.bounds,
        };
        match &binary.root {
            None => out.nodes.push(empty_node()),
            Some(leaf @ Binary::Leaf { .. }) => {
                // One leaf: a root holding it as its first child.
                let mut node = empty_node();
                set_child(&mut node, 0, leaf, leaf_ref(leaf));
                out.nodes.push(node);
            }
            Some(inner) => {
                emit(inner, &mut out.nodes);
            }
        }
        Some(out)
    }
}

/// A node with no children: boxes empty (lo +inf, hi -inf), both children `WIDE_BVH_EMPTY`.
fn empty_node() -> Bvh2Node {
    Bvh2Node {
        lo0: [f32::INFINITY; 3],
        hi0: [f32::NEG_INFINITY; 3],
        lo1: [f32::INFINITY; 3],
        hi1: [f32::NEG_INFINITY; 3],
        child: [WIDE_BVH_EMPTY; 2],
        pad: [0; 2],
    }
}

/// Child `k` of `node`: `child`'s box, rounded outward to f32, and reference `reference`.
fn set_child(node: &mut Bvh2Node, k: usize, child: &Binary, reference: u32) {
    let (lo, hi) = child.bounds().to_f32_outward();
    if k == 0 {
        (node.lo0, node.hi0) = (lo, hi);
    } else {
        (node.lo1, node.hi1) = (lo, hi);
    }
    node.child[k] = reference;
}

/// Writes the node of the binary subtree `inner` (and, depth first, those below it), and
/// returns its index.
fn emit(inner: &Binary, nodes: &mut Vec<Bvh2Node>) -> u32 {
    let Binary::Inner { children, .. } = inner else {
        unreachable!("emit of a leaf")
    };
    let index = nodes.len();
    nodes.push(empty_node());
    for (k, child) in children.iter().enumerate() {
        let reference = match child {
            Binary::Leaf { .. } => leaf_ref(child),
            Binary::Inner { .. } => emit(child, nodes),
        };
        set_child(&mut nodes[index], k, child, reference);
    }
    index as u32
}

#[cfg(test)]
mod tests {
    use super::super::binary_bvh::{INDEX_BITS, SAH_DEPTH};
    use super::super::kdtree::valid_triangles;
    use super::*;
    use crate::contract::WIDE_BVH_LEAF;
    use glam::DVec3;

    /// Every triangle that can be hit is in exactly one leaf, inside every box on its way down,
    /// and no path from the root is deeper than the programs' stack (kernels/bvh2.h). The
    /// number of leaves and the depth.
    fn check(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> (usize, usize) {
        let tree = Bvh2::build(positions, triangles).expect("fits");
        let mut seen = vec![0u32; triangles.len()];
        let mut stack = vec![(0u32, tree.bounds, 1usize)];
        let (mut leaves, mut deepest) = (0, 0);
        while let Some((node, outer, depth)) = stack.pop() {
            deepest = deepest.max(depth);
            let n = &tree.nodes[node as usize];
            for (k, (lo, hi)) in [(n.lo0, n.hi0), (n.lo1, n.hi1)].into_iter().enumerate() {
                let c = n.child[k];
                if c == WIDE_BVH_EMPTY {
                    continue;
                }
                let b = Aabb {
                    lo: DVec3::from(lo.map(f64::from)),
                    hi: DVec3::from(hi.map(f64::from)),
                };
                assert!(
                    outer.contains(&b) || node == 0,
                    "a child's box outside its parent's"
                );
                if c & WIDE_BVH_LEAF != 0 {
                    leaves += 1;
                    let count = ((c >> INDEX_BITS) & 7) as usize + 1;
                    let first = (c & ((1 << INDEX_BITS) - 1)) as usize;
                    assert!(count <= MAX_LEAF);
                    for &t in &tree.indices[first..first + count] {
                        seen[t as usize] += 1;
                        let v = triangles[t as usize]
                            .map(|i| DVec3::from(positions[i as usize].map(f64::from)));
                        assert!(
                            b.contains(&Aabb::from_points(v)),
                            "a triangle outside its leaf"
                        );
                    }
                } else {
                    assert!(c > node, "children come after their parent");
                    stack.push((c, b, depth + 1));
                }
            }
        }
        let valid = valid_triangles(positions, triangles);
        for t in &valid {
            assert_eq!(
                seen[t.number as usize], 1,
                "triangle {} not in one leaf",
                t.number
            );
        }
        assert_eq!(seen.iter().map(|&s| s as usize).sum::<usize>(), valid.len());
        (leaves, deepest)
    }

    fn grid(n: u32, flat: bool) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let z = if flat {
                    0.0
                } else {
                    ((i * 7 + j * 3) % 5) as f32 * 0.1
                };
                p.push([i as f32, j as f32, z]);
            }
        }
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                t.push([a, a + 1, a + n + 1]);
                t.push([a + 1, a + n + 2, a + n + 1]);
            }
        }
        (p, t)
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
        // Many copies of one triangle (every centroid on one point) fall back to medians below
        // SAH_DEPTH: about log2(n / MAX_LEAF) levels. Zero-area and out-of-range ones are left
        // out.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 2.0, 2.0],
        ];
        let mut t = vec![[0, 1, 2]; 5000];
        t.push([3, 3, 3]);
        t.push([0, 1, 9]);
        let (_, depth) = check(&p, &t);
        assert!(depth <= SAH_DEPTH + 12, "depth {depth}");
        // A staircase whose SAH splits peel one triangle at a time goes to the median past
        // SAH_DEPTH.
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
