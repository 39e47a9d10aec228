//! The object BVH: a binary tree over the scene's objects, built on the host in f64 from one box
//! per object and flattened into the [`BvhNode`]s of `kernels/types.h` (host side of `bvh.cuh`).
//!
//! Construction follows Karras, "Maximizing parallelism in the construction of BVHs, octrees,
//! and k-d trees" (HPG 2012): each object's box centre gets a 30-bit Morton code, the objects
//! are radix-sorted by code, and every range of sorted objects is split where the highest bit
//! that differs between its first and last codes flips from 0 to 1. Spatially close objects so
//! end up in the same subtree, and the tree is at most 30 levels of such splits deep.
//!
//! The original (`bvh.cuh`) also sorted by Morton code, then halved the sorted list at every
//! level, but coded the centres without normalising them to the scene's box: in a scene like
//! smallpt's, spanning ±1e5, the coordinates outside the code's range clamped to its ends, so
//! the codes saturated and far-apart objects shared a code and a subtree. Here the centres are
//! normalised to the box of all centres first ([`normalised`]), so the 10 bits per axis resolve
//! the scene itself, and ranges split where their codes differ rather than at their middle,
//! which keeps each subtree's box tight. A run of equal codes is split in the middle (Karras
//! breaks such ties by the index, which is equivalent), so the depth stays within
//! [`MAX_DEPTH`] for any input.
//!
//! Objects with an empty or non-finite box cannot be placed in a tree; they are listed in
//! [`Bvh::unbounded`] for the renderer to test outside it. (Every clpt object is bounded today:
//! planes use their finite `range` box, as in the original.)
//!
//! The host traversal, the reference of the device's that the tests check against brute force,
//! is `bvh_intersect` in tests/common/traversal.rs.

use super::aabb::Aabb;
use crate::contract::{BVH_EMPTY, BVH_LEAF, BvhNode};
use glam::DVec3;

/// The most objects a tree can index: a leaf child is `BVH_LEAF | object`, and object
/// `BVH_LEAF - 1` would read as `BVH_EMPTY`.
pub const MAX_OBJECTS: usize = (BVH_LEAF - 1) as usize;

/// A bound on [`BvhStats::max_depth`] for every tree [`Bvh::build`] makes: at most 30 levels
/// split on a code bit, then ⌈log2 n⌉ ≤ 31 levels halving a run of equal codes. A traversal
/// stack of `MAX_DEPTH + 1` entries never overflows.
pub const MAX_DEPTH: u32 = 64;

/// Bits of a Morton code per axis.
const AXIS_BITS: u32 = 10;
/// Bits of a Morton code.
const CODE_BITS: u32 = 3 * AXIS_BITS;
/// Bits sorted per radix pass: three passes over the code, 1024 buckets each.
const RADIX_BITS: u32 = 10;
/// A sort key holds the code above the object index, so sorting the keys sorts the objects.
const CODE_SHIFT: u32 = 32;

/// SAH cost of testing a ray against a node's two child boxes.
const TRAVERSAL_COST: f64 = 1.0;
/// SAH cost of testing a ray against one object.
const INTERSECTION_COST: f64 = 1.0;

/// A flattened object BVH.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh {
    /// Node 0 is the root; empty when no object is bounded. A tree of n ≥ 2 objects has n - 1
    /// nodes, one of a single object has one node whose second child is `BVH_EMPTY`.
    pub nodes: Vec<BvhNode>,
    /// The union of the boxes in the tree (f64; `Aabb::EMPTY` for an empty tree).
    pub bounds: Aabb,
    /// The objects left out of the tree because their box is empty or not finite, ascending.
    pub unbounded: Vec<u32>,
}

/// Shape and quality of a [`Bvh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhStats {
    pub nodes: usize,
    /// Objects in the tree.
    pub leaves: usize,
    /// The most nodes on a path from the root to an object (0 for an empty tree).
    pub max_depth: u32,
    /// Surface-area-heuristic cost: for every node, the probability that a ray through the root
    /// box meets its box (area ratio) times the traversal cost 1, plus the same for every
    /// object's box times the intersection cost 1. Computed on the stored f32 boxes; every ratio
    /// is taken as 1 when the root box has no area.
    pub sah_cost: f64,
}

impl Bvh {
    /// Builds the tree over `boxes`, one per object (the index is the object number).
    /// Empty input, or no bounded box, gives a tree without nodes.
    ///
    /// # Panics
    /// If there are more than [`MAX_OBJECTS`] boxes (2^31 boxes: about 100 GB of them).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        assert!(
            boxes.len() <= MAX_OBJECTS,
            "a BVH indexes at most {MAX_OBJECTS} objects, got {}",
            boxes.len()
        );
        let mut unbounded = Vec::new();
        let mut bounds = Aabb::EMPTY;
        let mut centroids = Aabb::EMPTY;
        let mut inside = Vec::with_capacity(boxes.len());
        for (object, b) in (0u32..).zip(boxes) {
            if is_bounded(b) {
                bounds = bounds.union(*b);
                centroids = centroids.grow(centroid(b));
                inside.push(object);
            } else {
                unbounded.push(object);
            }
        }
        let nodes = match inside[..] {
            [] => Vec::new(),
            [object] => {
                let (lo0, hi0) = boxes[object as usize].to_f32_outward();
                let (lo1, hi1) = Aabb::EMPTY.to_f32_outward();
                vec![BvhNode {
                    lo0,
                    hi0,
                    lo1,
                    hi1,
                    child: [BVH_LEAF | object, BVH_EMPTY],
                }]
            }
            _ => {
                let mut keys: Vec<u64> = inside
                    .iter()
                    .map(|&object| {
                        let code =
                            morton_code(normalised(centroid(&boxes[object as usize]), &centroids));
                        (u64::from(code) << CODE_SHIFT) | u64::from(object)
                    })
                    .collect();
                radix_sort(&mut keys);
                flatten(&hierarchy(&keys), boxes)
            }
        };
        Bvh {
            nodes,
            bounds,
            unbounded,
        }
    }

    /// Node count, leaves, depth and SAH cost, read from the nodes.
    pub fn stats(&self) -> BvhStats {
        let mut stats = BvhStats {
            nodes: self.nodes.len(),
            leaves: 0,
            max_depth: 0,
            sah_cost: 0.0,
        };
        let Some(root) = self.nodes.first() else {
            return stats;
        };
        let root_area = child_box(root, 0).union(child_box(root, 1)).surface_area();
        let ratio = |b: Aabb| {
            if root_area > 0.0 {
                b.surface_area() / root_area
            } else {
                1.0
            }
        };
        stats.sah_cost = TRAVERSAL_COST;
        let mut stack = vec![(0u32, 1u32)];
        while let Some((index, depth)) = stack.pop() {
            let node = &self.nodes[index as usize];
            stats.max_depth = stats.max_depth.max(depth);
            for (k, &child) in node.child.iter().enumerate() {
                if child == BVH_EMPTY {
                    continue;
                }
                let p = ratio(child_box(node, k));
                if child & BVH_LEAF != 0 {
                    stats.leaves += 1;
                    stats.sah_cost += p * INTERSECTION_COST;
                } else {
                    stats.sah_cost += p * TRAVERSAL_COST;
                    stack.push((child, depth + 1));
                }
            }
        }
        stats
    }
}

/// The 30-bit Morton code of a point normalised to [0, 1]³: each coordinate quantised to 10
/// bits (clamped; NaN counts as 0), the bits interleaved x, y, z from the top.
pub fn morton_code(p_normalised: DVec3) -> u32 {
    let cells = f64::from(1u32 << AXIS_BITS);
    let cell = |v: f64| (v * cells).clamp(0.0, cells - 1.0) as u32;
    (spread_bits(cell(p_normalised.x)) << 2)
        | (spread_bits(cell(p_normalised.y)) << 1)
        | spread_bits(cell(p_normalised.z))
}

/// `p` mapped into [0, 1]³ by the box `centroids` (the box of all centroids), as the builder
/// does before coding. An axis on which the box has no extent maps to 0.
pub fn normalised(p: DVec3, centroids: &Aabb) -> DVec3 {
    // Halved so that hi - lo stays finite for boxes reaching towards ±f64::MAX.
    let lo = centroids.lo * 0.5;
    let extent = centroids.hi * 0.5 - lo;
    let q = (p * 0.5 - lo) / extent;
    DVec3::select(extent.cmpgt(DVec3::ZERO), q, DVec3::ZERO)
}

/// Whether a box can go into the tree: not empty, and finite (a NaN bound is neither).
fn is_bounded(b: &Aabb) -> bool {
    !b.is_empty() && b.lo.is_finite() && b.hi.is_finite()
}

/// The centre of a finite box, without the overflow of (lo + hi) / 2 near ±f64::MAX.
fn centroid(b: &Aabb) -> DVec3 {
    b.lo * 0.5 + b.hi * 0.5
}

/// The low 10 bits of `v` moved to bits 0, 3, 6, ..., 27.
fn spread_bits(v: u32) -> u32 {
    let mut v = v & 0x3ff;
    v = (v | (v << 16)) & 0x0300_00ff;
    v = (v | (v << 8)) & 0x0300_f00f;
    v = (v | (v << 4)) & 0x030c_30c3;
    (v | (v << 2)) & 0x0924_9249
}

/// LSD radix sort of the keys by their code bits, `RADIX_BITS` per pass. Each pass is a stable
/// counting sort, so keys of equal code keep their order: that of the object index.
fn radix_sort(keys: &mut Vec<u64>) {
    const BUCKETS: usize = 1 << RADIX_BITS;
    let digit = |key: u64, shift: u32| (key >> shift) as usize & (BUCKETS - 1);
    let mut scratch = vec![0u64; keys.len()];
    for pass in 0..CODE_BITS.div_ceil(RADIX_BITS) {
        let shift = CODE_SHIFT + pass * RADIX_BITS;
        let mut start = [0usize; BUCKETS];
        for &key in keys.iter() {
            start[digit(key, shift)] += 1;
        }
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for &key in keys.iter() {
            let b = &mut start[digit(key, shift)];
            scratch[*b] = key;
            *b += 1;
        }
        std::mem::swap(keys, &mut scratch);
    }
}

/// Where Karras splits the sorted range `first..=last` (at least two keys): the last index of
/// the left half.
fn find_split(keys: &[u64], first: usize, last: usize) -> usize {
    let code = |key: u64| (key >> CODE_SHIFT) as u32;
    let (a, b) = (code(keys[first]), code(keys[last]));
    if a == b {
        return first + (last - first) / 2;
    }
    // All codes of the range share the bits above the highest one where a and b differ; that
    // bit is 0 on a leading run and 1 after it, so a binary search finds where it flips.
    let prefix = (a ^ b).leading_zeros();
    let zeros = keys[first..=last].partition_point(|&k| (a ^ code(k)).leading_zeros() > prefix);
    first + zeros - 1
}

/// The tree's topology over the sorted keys (at least two): each node's two child references
/// (node index, or `BVH_LEAF | object`), in depth-first order, so children follow their parent.
/// An explicit stack instead of recursion: the depth is bounded, but a stack overflow on a
/// thread with a small stack is not worth risking.
fn hierarchy(keys: &[u64]) -> Vec<[u32; 2]> {
    /// A range of sorted keys waiting for its subtree, and the node slot that will refer to it
    /// (none for the root).
    struct Pending {
        first: usize,
        last: usize,
        parent: Option<(usize, usize)>,
    }
    let mut children: Vec<[u32; 2]> = Vec::with_capacity(keys.len() - 1);
    let mut stack = vec![Pending {
        first: 0,
        last: keys.len() - 1,
        parent: None,
    }];
    while let Some(Pending {
        first,
        last,
        parent,
    }) = stack.pop()
    {
        let reference = if first == last {
            BVH_LEAF | keys[first] as u32
        } else {
            let node = children.len();
            children.push([BVH_EMPTY; 2]);
            let split = find_split(keys, first, last);
            // Right pushed first, so the left subtree is laid out right after its parent.
            stack.push(Pending {
                first: split + 1,
                last,
                parent: Some((node, 1)),
            });
            stack.push(Pending {
                first,
                last: split,
                parent: Some((node, 0)),
            });
            node as u32
        };
        if let Some((node, slot)) = parent {
            children[node][slot] = reference;
        }
    }
    children
}

/// The nodes with their children's boxes: f64 unions bottom-up (every child has a larger index
/// than its parent), each stored rounded outwards to f32. Rounding outwards is monotone, so the
/// stored boxes nest as the f64 ones do.
fn flatten(children: &[[u32; 2]], boxes: &[Aabb]) -> Vec<BvhNode> {
    let mut node_box = vec![Aabb::EMPTY; children.len()];
    let mut nodes = vec![BvhNode::default(); children.len()];
    for (index, child) in children.iter().enumerate().rev() {
        let b = child.map(|c| {
            if c & BVH_LEAF != 0 {
                boxes[(c & !BVH_LEAF) as usize]
            } else {
                node_box[c as usize]
            }
        });
        node_box[index] = b[0].union(b[1]);
        let ((lo0, hi0), (lo1, hi1)) = (b[0].to_f32_outward(), b[1].to_f32_outward());
        nodes[index] = BvhNode {
            lo0,
            hi0,
            lo1,
            hi1,
            child: *child,
        };
    }
    nodes
}

/// Child `k`'s stored box, widened to f64.
pub fn child_box(node: &BvhNode, k: usize) -> Aabb {
    let (lo, hi) = if k == 0 {
        (node.lo0, node.hi0)
    } else {
        (node.lo1, node.hi1)
    };
    Aabb {
        lo: DVec3::from(lo.map(f64::from)),
        hi: DVec3::from(hi.map(f64::from)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radix_sort_matches_a_stable_sort() {
        // A small LCG: codes with many repeats, indices ascending as the builder makes them.
        let mut state = 12345u64;
        let mut keys: Vec<u64> = (0..5000u64)
            .map(|i| {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let code = (state >> 33) as u32 & ((1 << CODE_BITS) - 1) & 0x3fc0_3f0f;
                (u64::from(code) << CODE_SHIFT) | i
            })
            .collect();
        let mut expected = keys.clone();
        expected.sort_by_key(|k| k >> CODE_SHIFT);
        radix_sort(&mut keys);
        assert_eq!(keys, expected);
    }

    #[test]
    fn split_is_at_the_highest_differing_bit() {
        let keys: Vec<u64> = [0b0001u64, 0b0010, 0b0011, 0b0100, 0b0101, 0b1000, 0b1100]
            .iter()
            .map(|c| c << CODE_SHIFT)
            .collect();
        // Bit 3 splits the whole range, bit 2 the first five codes, bit 1 the first three.
        assert_eq!(find_split(&keys, 0, 6), 4);
        assert_eq!(find_split(&keys, 0, 4), 2);
        assert_eq!(find_split(&keys, 0, 2), 0);
        assert_eq!(find_split(&keys, 5, 6), 5);
        let equal = vec![7u64 << CODE_SHIFT; 9];
        assert_eq!(find_split(&equal, 0, 8), 4);
    }

    #[test]
    fn morton_bits_interleave_x_y_z() {
        assert_eq!(morton_code(DVec3::ZERO), 0);
        assert_eq!(morton_code(DVec3::ONE), (1 << CODE_BITS) - 1);
        assert_eq!(morton_code(DVec3::new(0.5, 0.0, 0.0)), 1 << 29);
        assert_eq!(morton_code(DVec3::new(0.0, 0.5, 0.0)), 1 << 28);
        assert_eq!(morton_code(DVec3::new(0.0, 0.0, 0.5)), 1 << 27);
        assert_eq!(morton_code(DVec3::new(0.0, 0.0, 1.0 / 1024.0)), 1);
        assert_eq!(morton_code(DVec3::splat(f64::NAN)), 0);
    }
}
