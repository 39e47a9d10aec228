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
pub(super) struct BinaryBvh {
    /// `None` when the mesh has no triangle that can be hit.
    pub root: Option<Binary>,
    /// The mesh's triangle numbers, each leaf's consecutive.
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles (empty when there are none).
    pub bounds: Aabb,
}

impl BinaryBvh {
    /// The tree of a mesh given as vertex positions (object space) and index triples, with
    /// leaves of at most `max_leaf` triangles (at most [`LEAF_LIMIT`]); the triangles the
    /// kd-tree leaves out ([`super::kdtree::KdTree::build`]: zero area, missing or non-finite
    /// vertices) are left out here too. `None` when a mesh has 2^28 triangles or more (the
    /// leaf reference's limit).
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]], max_leaf: usize) -> Option<Self> {
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
pub(super) enum Binary {
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
    pub(super) fn bounds(&self) -> Aabb {
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
pub(super) fn leaf_ref(leaf: &Binary) -> u32 {
    let Binary::Leaf { first, count, .. } = leaf else {
        unreachable!("leaf_ref of an inner node")
    };
    WIDE_BVH_LEAF | (((*count - 1) as u32) << INDEX_BITS) | *first as u32
}
