//! An 8-wide BVH over a mesh's triangles, a CPU's mesh tree (kernels/wide_bvh.h; render/mod.rs
//! `MeshTree`).
//!
//! A CPU traces a mesh one ray at a time (a wide program, kernels/lanes.h, lane by lane), where
//! a kd-tree step decides one split plane per node: scalar work on SIMD hardware. A node of
//! this tree holds the boxes of up to eight children as six float8 arrays, so one ray tests all
//! eight with a few vector instructions (Wald et al., "Getting rid of packets", 2008; Embree's
//! BVH8; Ylitie, Karras and Laine 2017 on wide BVHs). It is built as a binary BVH by binned SAH
//! over triangle centroids (Wald, "On fast construction of SAH-based bounding volume
//! hierarchies", 2007), then collapsed: each node takes in the children of its largest inner
//! children until it has eight (pbrt-v4 and Embree collapse the same way). Leaves hold up to
//! [`MAX_LEAF`] triangles. GPUs keep the kd-tree (kernels/kdtree.h): this traversal, with its
//! deep stack, ran 9 to 43% slower there with light sampling (BENCHMARKS.md).

use super::aabb::Aabb;
use super::kdtree::{Tri, valid_triangles};
use crate::contract::{WIDE_BVH_EMPTY, WIDE_BVH_LEAF, WideBvhNode};
use glam::DVec3;

/// Children a node holds (the eight of `WideBvhNode` in types.h).
pub const WIDTH: usize = 8;
/// The most triangles a leaf holds: on the dragon room (2 cores, PoCL, user CPU) 2 ran 2 to 5%
/// faster than 4, as fast as 1 (within 1.4%), 8 about 10% slower.
pub const MAX_LEAF: usize = 2;
/// Leaf references carry the count less one in 3 bits and the first index in 28.
const INDEX_BITS: u32 = 28;
/// SAH bins per axis.
const BINS: usize = 16;
/// Below this depth splits follow the SAH; deeper, the object median, so that a degenerate
/// input (every centroid on one point, or SAH's one-triangle splits) cannot recurse past
/// about 64 + log2(n) levels.
const SAH_DEPTH: usize = 32;

/// The flattened tree of one mesh: `nodes[0]` is the root; leaf `first` indexes `indices`,
/// which hold triangle numbers of the mesh.
pub struct WideBvh {
    pub nodes: Vec<WideBvhNode>,
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when the mesh has none that can be hit).
    pub bounds: Aabb,
}

/// A binary node before the collapse.
enum Binary {
    Leaf {
        bounds: Aabb,
        first: usize,
        count: usize,
    },
    Inner {
        bounds: Aabb,
        children: Box<[Binary; 2]>,
    },
}

impl Binary {
    fn bounds(&self) -> Aabb {
        match self {
            Binary::Leaf { bounds, .. } | Binary::Inner { bounds, .. } => *bounds,
        }
    }
}

/// A triangle while building: its position in the mesh's list, box and centroid.
struct Item {
    tri: usize,
    bounds: Aabb,
    centroid: DVec3,
}

impl WideBvh {
    /// The tree of a mesh given as vertex positions (object space) and index triples; the
    /// triangles the kd-tree leaves out ([`super::kdtree::KdTree::build`]: zero area, missing
    /// or non-finite vertices) are left out here too. `None` when a mesh has more than 2^28
    /// triangles (the leaf format's limit).
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Option<WideBvh> {
        let tris: Vec<Tri> = valid_triangles(positions, triangles);
        if tris.len() >= 1 << INDEX_BITS {
            return None;
        }
        let mut items: Vec<Item> = tris
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let bounds = t.bounds();
                Item {
                    tri: i,
                    bounds,
                    centroid: bounds.center(),
                }
            })
            .collect();
        let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
        let mut out = WideBvh {
            nodes: Vec::new(),
            indices: Vec::with_capacity(items.len()),
            bounds,
        };
        if items.is_empty() {
            out.nodes.push(empty_node());
            return Some(out);
        }
        let root = split(&mut items, 0, 0);
        let order: Vec<u32> = items.iter().map(|it| tris[it.tri].number).collect();
        out.indices = order;
        match &root {
            Binary::Leaf { .. } => {
                // One leaf: a root node holding it alone.
                let mut node = empty_node();
                set_child(&mut node, 0, &root, leaf_ref(&root));
                out.nodes.push(node);
            }
            Binary::Inner { .. } => {
                emit(&root, &mut out.nodes);
            }
        }
        Some(out)
    }
}

/// The binary tree over `items` (reordered so that each leaf's triangles are consecutive),
/// whose first item is number `first` of the whole list.
fn split(items: &mut [Item], first: usize, depth: usize) -> Binary {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
    if items.len() <= MAX_LEAF {
        return Binary::Leaf {
            bounds,
            first,
            count: items.len(),
        };
    }
    let centroids = items.iter().fold(Aabb::EMPTY, |b, it| b.grow(it.centroid));
    let extent = centroids.extent();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = if depth < SAH_DEPTH {
        sah_partition(items, &centroids)
    } else {
        None
    }
    .unwrap_or_else(|| {
        // The object median along the widest centroid axis: always halves.
        let half = items.len() / 2;
        items.select_nth_unstable_by(half, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
        half
    });
    let (left, right) = items.split_at_mut(mid);
    let l = split(left, first, depth + 1);
    let r = split(right, first + mid, depth + 1);
    Binary::Inner {
        bounds,
        children: Box::new([l, r]),
    }
}

/// The SAH bin of an item along `axis`: BINS equal parts of the centroids' extent.
fn bin(item: &Item, centroids: &Aabb, axis: usize) -> usize {
    let scale = BINS as f64 / centroids.extent()[axis];
    (((item.centroid[axis] - centroids.lo[axis]) * scale) as usize).min(BINS - 1)
}

/// Partitions `items` at the cheapest binned SAH split over the three axes; the number in the
/// first part, or `None` when the centroids do not spread (or no split beats the median's
/// certainty of progress).
fn sah_partition(items: &mut [Item], centroids: &Aabb) -> Option<usize> {
    let extent = centroids.extent();
    let mut best: Option<(f64, usize, usize)> = None; // cost, axis, bins on the left
    for axis in 0..3 {
        if extent[axis] <= 0.0 || !extent[axis].is_finite() {
            continue;
        }
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for it in items.iter() {
            let b = bin(it, centroids, axis);
            counts[b] += 1;
            boxes[b] = boxes[b].union(it.bounds);
        }
        // Areas and counts of the first k bins and of the rest.
        let mut right_area = [0.0f64; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0usize);
        for k in (1..BINS).rev() {
            acc = acc.union(boxes[k]);
            n += counts[k];
            right_area[k] = acc.surface_area();
            right_count[k] = n;
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0usize);
        for k in 1..BINS {
            acc = acc.union(boxes[k - 1]);
            n += counts[k - 1];
            if n == 0 || right_count[k] == 0 {
                continue;
            }
            let cost = acc.surface_area() * n as f64 + right_area[k] * right_count[k] as f64;
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, k));
            }
        }
    }
    let (_, axis, k) = best?;
    // An in-place partition: the left part first.
    let mut mid = 0;
    for i in 0..items.len() {
        if bin(&items[i], centroids, axis) < k {
            items.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < items.len()).then_some(mid)
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

/// The reference of a leaf: `WIDE_BVH_LEAF`, its count less one, its first index (in
/// `indices`, and so its first slot on the device).
fn leaf_ref(leaf: &Binary) -> u32 {
    let Binary::Leaf { first, count, .. } = leaf else {
        unreachable!("leaf_ref of an inner node")
    };
    WIDE_BVH_LEAF | (((*count - 1) as u32) << INDEX_BITS) | *first as u32
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
    use super::*;

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
