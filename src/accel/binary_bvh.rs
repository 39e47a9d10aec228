//! The binary BVH both BVH mesh trees are built from: binned SAH over triangle centroids
//! (Wald, "On fast construction of SAH-based bounding volume hierarchies", 2007), leaves of a
//! given size. The 8-wide BVH ([`super::wide_bvh`], a CPU's) collapses it; the binary BVH
//! ([`super::bvh2`], a GPU's) stores it as it is. Leaves are referred to as
//! `WIDE_BVH_LEAF | (count - 1) << 28 | first` in both.

use super::aabb::Aabb;
use super::kdtree::{Tri, valid_triangles};
use crate::contract::WIDE_BVH_LEAF;
use glam::DVec3;

/// Leaf references carry the count less one in 3 bits and the first index in 28.
pub(super) const INDEX_BITS: u32 = 28;
/// The most triangles a leaf can hold (the count's 3 bits).
pub(super) const LEAF_LIMIT: usize = 8;
/// SAH bins per axis.
const BINS: usize = 16;
/// Below this depth splits follow the SAH; deeper, the object median, so that a degenerate
/// input (every centroid on one point, or SAH's one-triangle splits) cannot recurse past
/// about 32 + log2(n) levels: at most 60 for the 2^28 triangles a leaf reference can name,
/// within the programs' stacks of 64 (kernels/wide_bvh.h, kernels/bvh2.h).
pub(super) const SAH_DEPTH: usize = 32;

/// The binary tree of a mesh, before it is stored.
struct BinaryBvh {
    /// `None` when the mesh has no triangle that can be hit.
    pub root: Option<Binary>,
    /// The mesh's triangle numbers, each leaf's consecutive.
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when there are none).
    pub bounds: Aabb,
}

impl BinaryBvh {
    /// The tree of a mesh, with leaves of at most `max_leaf` triangles (at most
    /// [`LEAF_LIMIT`]); `None` as [`FlatBvh::build`].
    fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]], max_leaf: usize) -> Option<Self> {
        assert!((1..=LEAF_LIMIT).contains(&max_leaf));
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
        let root = (!items.is_empty()).then(|| split(&mut items, 0, 0, max_leaf));
        Some(BinaryBvh {
            root,
            indices: items.iter().map(|it| tris[it.tri].number).collect(),
            bounds,
        })
    }
}

/// A node of the binary tree.
pub enum Binary {
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
    pub fn bounds(&self) -> Aabb {
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

/// The binary tree over `items` (reordered so that each leaf's triangles are consecutive),
/// whose first item is number `first` of the whole list; leaves of at most `max_leaf`.
fn split(items: &mut [Item], first: usize, depth: usize, max_leaf: usize) -> Binary {
    let bounds = items.iter().fold(Aabb::EMPTY, |b, it| b.union(it.bounds));
    if items.len() <= max_leaf {
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
    let l = split(left, first, depth + 1, max_leaf);
    let r = split(right, first + mid, depth + 1, max_leaf);
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

/// The reference of a leaf: `WIDE_BVH_LEAF`, its count less one, its first index (in the
/// tree's `indices`, and so its first slot on the device).
fn leaf_ref(leaf: &Binary) -> u32 {
    let Binary::Leaf { first, count, .. } = leaf else {
        unreachable!("leaf_ref of an inner node")
    };
    WIDE_BVH_LEAF | (((*count - 1) as u32) << INDEX_BITS) | *first as u32
}

/// A mesh's BVH as the programs read it: `nodes[0]` is the root; a leaf reference's first
/// index indexes `indices`, which hold triangle numbers of the mesh.
pub struct FlatBvh<N> {
    pub nodes: Vec<N>,
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when the mesh has none that can be hit).
    pub bounds: Aabb,
}

impl<N: Flatten> FlatBvh<N> {
    /// The tree of a mesh given as vertex positions (object space) and index triples, leaves of
    /// at most `N::MAX_LEAF` triangles; the triangles the kd-tree leaves out
    /// ([`super::kdtree::KdTree::build`]: zero area, missing or non-finite vertices) are left
    /// out here too. `None` when a mesh has 2^28 triangles or more (the leaf reference's
    /// limit).
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Option<Self> {
        let binary = BinaryBvh::build(positions, triangles, N::MAX_LEAF)?;
        Some(FlatBvh {
            nodes: flatten(binary.root.as_ref()),
            indices: binary.indices,
            bounds: binary.bounds,
        })
    }
}

/// A node format the binary tree is stored in ([`super::bvh2`], [`super::wide_bvh`]).
pub trait Flatten: Sized {
    /// The most triangles a leaf holds.
    const MAX_LEAF: usize;
    /// A node with no children: boxes empty, every child `WIDE_BVH_EMPTY`.
    fn empty() -> Self;
    /// Child `k` of the node: `child`'s box, rounded outward to f32, and `reference`.
    fn set_child(&mut self, k: usize, child: &Binary, reference: u32);
    /// The subtrees a node made of the binary subtree `inner` holds as its children.
    fn children(inner: &Binary) -> Vec<&Binary>;
}

/// Writes the node of the binary subtree `inner` (and, depth first, those below it) and
/// returns its index.
fn emit<N: Flatten>(inner: &Binary, nodes: &mut Vec<N>) -> u32 {
    let index = nodes.len();
    nodes.push(N::empty());
    for (k, child) in N::children(inner).into_iter().enumerate() {
        let reference = match child {
            Binary::Leaf { .. } => leaf_ref(child),
            Binary::Inner { .. } => emit(child, nodes),
        };
        nodes[index].set_child(k, child, reference);
    }
    index as u32
}

/// The nodes of the tree whose root is `root`, `nodes[0]` the root: one empty node for a mesh
/// with no triangle, one node holding the leaf alone for a mesh of one leaf.
fn flatten<N: Flatten>(root: Option<&Binary>) -> Vec<N> {
    let mut nodes = Vec::new();
    match root {
        None => nodes.push(N::empty()),
        Some(leaf @ Binary::Leaf { .. }) => {
            let mut node = N::empty();
            node.set_child(0, leaf, leaf_ref(leaf));
            nodes.push(node);
        }
        Some(inner) => {
            emit(inner, &mut nodes);
        }
    }
    nodes
}

/// Meshes the BVHs' tests build trees over.
#[cfg(test)]
pub(super) mod test_meshes {
    use super::super::aabb::Aabb;
    use super::super::kdtree::valid_triangles;
    use super::INDEX_BITS;
    use crate::contract::{WIDE_BVH_EMPTY, WIDE_BVH_LEAF};
    use glam::DVec3;

    /// An n x n grid of squares split in two, flat or with heights in five steps.
    pub fn grid(n: u32, flat: bool) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
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

    /// Many copies of one triangle (every centroid on one point), one of zero area and one
    /// naming a missing vertex.
    pub fn degenerate() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [2.0, 2.0, 2.0],
        ];
        let mut t = vec![[0, 1, 2]; 5000];
        t.push([3, 3, 3]);
        t.push([0, 1, 9]);
        (p, t)
    }

    /// Walks a flattened tree from node 0, `children(node)` giving a node's children as
    /// (box, reference): every triangle that can be hit is in exactly one leaf of at most
    /// `max_leaf`, inside every box on its way down, and children come after their parent. The
    /// number of leaves and the depth of the deepest node.
    pub fn check_tree(
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        (bounds, indices, max_leaf): (Aabb, &[u32], usize),
        children: impl Fn(u32) -> Vec<(Aabb, u32)>,
    ) -> (usize, usize) {
        let mut seen = vec![0u32; triangles.len()];
        let mut stack = vec![(0u32, bounds, 1usize)];
        let (mut leaves, mut deepest) = (0, 0);
        while let Some((node, outer, depth)) = stack.pop() {
            deepest = deepest.max(depth);
            for (b, c) in children(node) {
                if c == WIDE_BVH_EMPTY {
                    continue;
                }
                assert!(
                    outer.contains(&b) || node == 0,
                    "a child's box outside its parent's"
                );
                if c & WIDE_BVH_LEAF == 0 {
                    assert!(c > node, "children come after their parent");
                    stack.push((c, b, depth + 1));
                    continue;
                }
                leaves += 1;
                let count = ((c >> INDEX_BITS) & 7) as usize + 1;
                let first = (c & ((1 << INDEX_BITS) - 1)) as usize;
                assert!(count <= max_leaf);
                for &t in &indices[first..first + count] {
                    seen[t as usize] += 1;
                    let v = triangles[t as usize]
                        .map(|i| DVec3::from(positions[i as usize].map(f64::from)));
                    assert!(
                        b.contains(&Aabb::from_points(v)),
                        "a triangle outside its leaf"
                    );
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
}
