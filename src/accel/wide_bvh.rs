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

use super::aabb::Aabb;
use super::binary_bvh::{Binary, BinaryBvh, leaf_ref};
use crate::contract::{WIDE_BVH_EMPTY, WideBvhNode};

/// Children a node holds (the eight of `WideBvhNode` in types.h).
pub const WIDTH: usize = 8;
/// The most triangles a leaf holds: on the dragon room (2 cores, PoCL, user CPU) 2 ran 2 to 5%
/// faster than 4, as fast as 1 (within 1.4%), 8 about 10% slower.
pub const MAX_LEAF: usize = 2;

/// The flattened tree of one mesh: `nodes[0]` is the root; leaf `first` indexes `indices`,
/// which hold triangle numbers of the mesh.
pub struct WideBvh {
    pub nodes: Vec<WideBvhNode>,
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when the mesh has none that can be hit).
    pub bounds: Aabb,
}

impl WideBvh {
    /// The tree of a mesh given as vertex positions (object space) and index triples; the
    /// triangles the kd-tree leaves out ([`super::kdtree::KdTree::build`]: zero area, missing
    /// or non-finite vertices) are left out here too. `None` when a mesh has more than 2^28
    /// triangles (the leaf format's limit).
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Option<WideBvh> {
        let binary = BinaryBvh::build(positions, triangles, MAX_LEAF)?;
        let mut out = WideBvh {
            nodes: Vec::new(),
            indices: binary.indices,
            bounds: binary.bounds,
        };
        match &binary.root {
            None => out.nodes.push(empty_node()),
            Some(leaf @ Binary::Leaf { .. }) => {
                // One leaf: a root node holding it alone.
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

/// A node with no children: boxes empty (lo +inf, hi -inf) and every child `WIDE_BVH_EMPTY`.
fn empty_node() -> WideBvhNode {
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

/// Slot `k` of `node`: `child`'s box, rounded outward to f32, and reference `reference`.
fn set_child(node: &mut WideBvhNode, k: usize, child: &Binary, reference: u32) {
    let (lo, hi) = child.bounds().to_f32_outward();
    node.lo_x[k] = lo[0];
    node.lo_y[k] = lo[1];
    node.lo_z[k] = lo[2];
    node.hi_x[k] = hi[0];
    node.hi_y[k] = hi[1];
    node.hi_z[k] = hi[2];
    node.child[k] = reference;
}

/// Writes the wide node that collapses the binary subtree `inner` (and, depth first, those
/// below it), and returns its index.
fn emit(inner: &Binary, nodes: &mut Vec<WideBvhNode>) -> u32 {
    let Binary::Inner { children, .. } = inner else {
        unreachable!("emit of a leaf")
    };
    // Open the largest inner child until there are WIDTH children or only leaves.
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
    let index = nodes.len();
    nodes.push(empty_node());
    for (k, child) in open.iter().enumerate() {
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
    use super::super::binary_bvh::INDEX_BITS;
    use super::super::kdtree::valid_triangles;
    use super::*;
    use crate::contract::WIDE_BVH_LEAF;
    use glam::DVec3;

    /// Every triangle that can be hit is in exactly one leaf, inside every box on its way down.
    fn check(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> usize {
        let tree = WideBvh::build(positions, triangles).expect("fits");
        let mut seen = vec![0u32; triangles.len()];
        let mut stack = vec![(0u32, tree.bounds)];
        let mut leaves = 0;
        while let Some((node, outer)) = stack.pop() {
            let n = &tree.nodes[node as usize];
            for k in 0..WIDTH {
                let c = n.child[k];
                if c == WIDE_BVH_EMPTY {
                    continue;
                }
                let b = Aabb {
                    lo: DVec3::new(n.lo_x[k] as f64, n.lo_y[k] as f64, n.lo_z[k] as f64),
                    hi: DVec3::new(n.hi_x[k] as f64, n.hi_y[k] as f64, n.hi_z[k] as f64),
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
                    stack.push((c, b));
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
        leaves
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
            assert!(check(&p, &t) >= t.len() / MAX_LEAF);
        }
    }

    #[test]
    fn degenerate_input_builds_shallow_trees() {
        // Many copies of one triangle (every centroid on one point), and zero-area ones left out.
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 2.0, 2.0],
        ];
        let mut t = vec![[0, 1, 2]; 5000];
        t.push([3, 3, 3]);
        t.push([0, 1, 9]);
        check(&p, &t);
        // No triangle at all: one empty root.
        let tree = WideBvh::build(&p, &[]).unwrap();
        assert_eq!(tree.nodes.len(), 1);
        assert!(tree.nodes[0].child.iter().all(|&c| c == WIDE_BVH_EMPTY));
        assert!(tree.bounds.is_empty());
    }
}
