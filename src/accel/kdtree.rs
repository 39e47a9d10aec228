//! The kd-tree over one mesh's triangles (← the original's `kd-tree.cuh`), built on the host and
//! flattened into the 8-byte [`KdNode`]s of `kernels/types.h`.
//!
//! The original split round-robin on x, y, z at the median triangle, stopped at depth 15 or at
//! 15 triangles per leaf, and, because a triangle overlapping several leaves was tested once per
//! leaf, kept a per-ray "already tested" bit array that it cleared on every mesh intersection.
//! Here instead:
//!
//! - The split planes minimise the surface area heuristic (SAH) with the O(n log n) sweep of
//!   I. Wald and V. Havran, "On building fast kd-Trees for Ray Tracing, and on doing that in
//!   O(N log N)", IEEE Symposium on Interactive Ray Tracing 2006: the triangles' bound events
//!   are sorted once per axis; each node sweeps its three sorted lists to find the cheapest
//!   plane and splits them into its children's lists in linear time, re-clipping only the
//!   triangles that straddle the plane. A split that leaves one side empty is discounted by
//!   the empty-space bonus, so empty space gets cut off.
//! - Triangles are clipped to the node box before their bounds become events ("perfect
//!   splits"), so a long thin triangle does not follow its bounding box into cells it misses:
//!   a leaf holds only triangles that overlap it, and fewer leaves hold each triangle. Only the
//!   triangles straddling a plane are clipped, and they need new events anyway, so the build
//!   stays O(n log n).
//! - Leaves end where SAH says a split no longer pays (with a depth limit that grows with
//!   log n), not at a fixed depth and count, so dense parts get deep trees and empty space
//!   gets big empty leaves.
//! - Bounds for any input: nodes of more than 16 triangles are split even where SAH would
//!   stop, if some plane takes triangles off both sides ([`KdParams::max_leaf_triangles`]);
//!   splits of large nodes may duplicate at most 16 references per triangle in all
//!   (`LARGE_SPLIT_ENTRIES_PER_TRIANGLE`), so piles of overlapping triangles stop after a
//!   few levels; and a tree never holds more than 64 entries per triangle
//!   ([`KdParams::max_entries_per_triangle`]; a build that would is redone shallower). A leaf
//!   holds more than 16 triangles only where they overlap so that no plane separates them
//!   (copies of one triangle; the mesh loader drops exact copies) or at these bounds.
//! - Traversal (`kd_intersect` of tests/common/traversal.rs, the reference for the device code)
//!   visits leaves front to back with a small stack and stops after the first leaf whose
//!   interval holds the nearest hit found so far: no per-ray memory for tested triangles. A hit
//!   beyond the current leaf is not taken as final, since a nearer one can still lie in a later
//!   leaf; it is kept as the best so far, which is the same as clipping the leaf's hits to its
//!   interval but also accepts a hit computed an ulp outside the leaf on a plane or box face
//!   (see `kd_intersect`).
//!
//! Classification. All geometry is in f64 on exact copies of the f32 inputs. Every split
//! coordinate is an f32 value (a bound of some triangle's clipped box, strictly inside the
//! node) and the triangles are classified against exactly that value, so the flattened tree
//! means what the builder decided: a triangle whose clipped box ends at or below the plane goes
//! below, one that starts at or above it goes above, one that crosses it goes to both (and is
//! clipped to each side). A triangle touching the plane from one side goes to that side only.
//! A triangle lying in the plane goes to the side SAH finds cheaper for all such triangles
//! together (Wald–Havran's p_side): never both, since a ray meets it at the plane, which both
//! children's intervals share.
//!
//! Zero-area triangles (and those with missing or non-finite vertices) are left out: no ray
//! can hit them, and a zero-area box would only attract pointless splits.

use super::aabb::Aabb;
use crate::contract::KdNode;
use glam::DVec3;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Triangles numbered at or above this are left out (a leaf stores its count in 30 bits); a
/// mesh loader should refuse larger meshes.
pub const MAX_TRIANGLES: usize = (1 << 30) - 1;

/// The deepest tree [`KdTree::build`] makes, whatever [`KdParams::max_depth`] asks: a traversal
/// stack of this many entries never overflows.
pub const MAX_DEPTH: u32 = 64;

/// The original's limits, kept by [`KdTree::build_median`].
const MEDIAN_MAX_DEPTH: u32 = 15;
const MEDIAN_LEAF_TRIANGLES: usize = 15;

/// Nodes with at least this many triangles may hand a child to another thread.
const PARALLEL_MIN_TRIANGLES: usize = 4096;

/// Entries (nodes and leaf references) a tree may hold beyond
/// [`KdParams::max_entries_per_triangle`] per triangle, so small meshes are never cramped.
pub const ENTRY_SLACK: usize = 4096;

/// Splits of nodes of more than [`LARGE_NODE`] triangles may add at most this many entries
/// (the references they duplicate and their children's nodes) per triangle of the mesh,
/// shared out in proportion to triangle counts as the tree splits.
///
/// SAH counts time, not memory. On a pile of triangles that overlap one another (copies of a
/// triangle each moved a little) it splits a node in half along its long axis, each half
/// keeping 96% of the triangles, because a ray through either half then tests 4% fewer; 30
/// levels of that want 2^30 times the pile. The original's meshes never come near the bound:
/// their splits above 64 triangles duplicate a few percent; 100k jittered copies of one
/// triangle stop after 11 levels with 10 references per triangle (where a ray must still test
/// most of the pile, which covers one spot: no tree can help that).
const LARGE_SPLIT_ENTRIES_PER_TRIANGLE: usize = 16;
const LARGE_NODE: usize = 64;

/// The SAH build's knobs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdParams {
    /// Cost of one traversal step (a node load, a plane distance, a stack push).
    pub traversal_cost: f64,
    /// Cost of one ray/triangle test.
    pub intersection_cost: f64,
    /// Fraction taken off a split's cost when one side holds no triangle (Wald–Havran's
    /// λ = 1 - empty_bonus), so empty space is cut off even where SAH is otherwise indifferent.
    pub empty_bonus: f64,
    /// Deepest leaf (the root is depth 0); 0 picks 8 + 1.3 log2(n), as pbrt does. Never above
    /// [`MAX_DEPTH`]. A node at this depth is a leaf whatever it holds.
    pub max_depth: u32,
    /// A node holding at most this many triangles becomes a leaf when SAH finds no split
    /// cheaper than testing them all; a node holding more is split even when SAH would rather
    /// stop, at its cheapest plane if that takes triangles off both sides, else at the plane
    /// that leaves the larger side fewest triangles if that one does (so splitting makes
    /// progress; a plane that only shaves one side can be taken again and again, down to the
    /// depth limit, with the pile whole). `u32::MAX` leaves every decision to SAH.
    pub max_leaf_triangles: u32,
    /// The most entries (8-byte nodes and 4-byte leaf references) the tree may hold per
    /// triangle, plus [`ENTRY_SLACK`]: a build that would hold more stops and is done again
    /// 4 levels shallower, so memory and build time stay proportional to the mesh whatever
    /// it is. The original's meshes need 4 to 30 (block.obj's long thin triangles the most).
    pub max_entries_per_triangle: usize,
}

impl Default for KdParams {
    /// Traversal 1, intersection 1.5, empty bonus 0.2, automatic depth, 16.
    ///
    /// The cost ratio is Wald and Havran's (15 : 20) and suits the device, where a triangle test
    /// (an index, three vertex indices, nine floats, ~30 flops) is dearer than a step (one
    /// 8-byte node, a multiply-add, a branch, sometimes a push) but not by much. Measured on
    /// the 100k-triangle dragon with 2e5 rays aimed at it (host traversal): intersection cost
    /// 1.5 makes 737k nodes (77 bytes per triangle), 36 steps and 3.1 triangle tests per ray;
    /// 3 makes 1.1M nodes for 37 steps and 2.5 tests, 10 makes 1.5M nodes for 38 and 2.2,
    /// 1 makes 519k nodes for 35 and 3.7. Dearer tests buy little, at twice the memory.
    ///
    /// The empty bonus is the paper's. The depth limit binds (the trees reach it), but only
    /// through chains of ever smaller cells around vertices where many triangles meet (SAH sees
    /// the same picture at every scale there): a limit of 64 instead of 30 adds 27% nodes to
    /// the dragon for the same SAH cost. Forced splits above 16 triangles are rare on the
    /// original's meshes (8 in the five dragons, of 17 to 22 triangles); they bound leaves where
    /// a greedy SAH stops early: 4000 long triangles fanned through one point make one leaf of
    /// 4000 by SAH alone and leaves of 54 on average with them, at about the same SAH cost.
    /// Taking the most even plane where the cheapest only shaves one side changed two nodes of
    /// dragon_871k's tree and nothing in the other meshes; 20k random triangles spanning a
    /// cube went from a leaf of 20000 at the depth limit (0.7 ms per ray on the host) to
    /// leaves of 120 on average (13 µs).
    fn default() -> KdParams {
        KdParams {
            traversal_cost: 1.0,
            intersection_cost: 1.5,
            empty_bonus: 0.2,
            max_depth: 0,
            max_leaf_triangles: 16,
            max_entries_per_triangle: 64,
        }
    }
}

/// A mesh's kd-tree: nodes in depth-first order (node 0 the root; an interior node's child
/// below its split is the next node), the leaves' triangle lists, and the box the tree covers.
#[derive(Clone, Debug, PartialEq)]
pub struct KdTree {
    pub nodes: Vec<KdNode>,
    /// Triangle numbers; leaf `l` holds `indices[l.first_index()..][..l.count()]`.
    pub indices: Vec<u32>,
    /// Tight bounds of the triangles the tree holds (empty when it holds none). Every bound is
    /// an f32 vertex coordinate, so rounding it to f32 outward changes nothing.
    pub bounds: Aabb,
}

/// What a tree looks like, for tests and `-v` output.
#[derive(Clone, Debug, PartialEq)]
pub struct KdStats {
    pub nodes: usize,
    pub leaves: usize,
    pub empty_leaves: usize,
    /// Depth of the deepest leaf (the root is depth 0); the traversal stack needs this many
    /// entries.
    pub max_depth: u32,
    /// Mean triangle count of the non-empty leaves.
    pub mean_leaf_triangles: f64,
    pub index_entries: usize,
    /// Expected cost of a ray through the tree (the SAH: each node's cost weighted by its
    /// surface area over the root's), with the default cost constants and no empty bonus, so
    /// trees built any way compare on one scale.
    pub sah_cost: f64,
    /// Device size: 8 bytes per node, 4 per index entry.
    pub bytes: usize,
    /// Triangles the tree leaves out: zero area, non-finite or out-of-range vertices, or
    /// numbered at or above [`MAX_TRIANGLES`].
    pub skipped_triangles: usize,
}

/// A triangle the tree holds: its number in the mesh and its vertices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tri {
    pub(crate) number: u32,
    v: [[f32; 3]; 3],
}

impl Tri {
    fn vertices(&self) -> [DVec3; 3] {
        self.v.map(|p| DVec3::from(p.map(f64::from)))
    }

    pub(crate) fn bounds(&self) -> Aabb {
        Aabb::from_points(self.vertices())
    }
}

/// Triangle `index` if the tree can hold it: numbered below [`MAX_TRIANGLES`], with vertices
/// that exist, are finite and span a non-zero area (a zero-area triangle cannot be hit:
/// Möller–Trumbore's det is 0).
fn valid_triangle(positions: &[[f32; 3]], triangles: &[[u32; 3]], index: usize) -> Option<Tri> {
    if index >= MAX_TRIANGLES {
        return None;
    }
    let vertex = |i: u32| positions.get(i as usize).copied();
    let [a, b, c] = *triangles.get(index)?;
    let tri = Tri {
        number: index as u32,
        v: [vertex(a)?, vertex(b)?, vertex(c)?],
    };
    let v = tri.vertices();
    let finite = v.iter().all(|p| p.is_finite());
    (finite && (v[1] - v[0]).cross(v[2] - v[0]) != DVec3::ZERO).then_some(tri)
}

/// Every valid triangle, in order.
pub(crate) fn valid_triangles(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<Tri> {
    (0..triangles.len())
        .filter_map(|i| valid_triangle(positions, triangles, i))
        .collect()
}

/// The box of the part of triangle `v` (with bounds `tri`) inside `node`, rounded outward to
/// f32 values and kept inside both boxes, or `None` when the triangle misses the box.
///
/// The polygon is clipped against `node` grown by a margin far above f64 rounding (2^-40 of the
/// largest coordinate) and far below f32 spacing, so its computed box contains the exact one
/// and a triangle that reaches into the box is never dropped; clamping to the triangle's own
/// bounds and the node's (both exact f32 values) then undoes the margin wherever the true bound
/// is a vertex or a box face, so the f32 event positions are exact in the common cases and one
/// f32 step conservative at worst.
fn clip_bounds(v: &[DVec3; 3], tri: &Aabb, node: &Aabb) -> Option<Aabb> {
    if node.contains(tri) {
        return Some(*tri);
    }
    if (0..3).any(|a| tri.hi[a] < node.lo[a] || tri.lo[a] > node.hi[a]) {
        return None;
    }
    let scale = [node.lo, node.hi, tri.lo, tri.hi]
        .iter()
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    let margin = scale * (f64::EPSILON * 4096.0);
    let mut poly = Polygon::triangle(v);
    for axis in 0..3 {
        // Only the faces that cut the triangle's bounds can cut the triangle.
        if tri.lo[axis] < node.lo[axis] {
            poly.clip(axis, node.lo[axis] - margin, false);
        }
        if tri.hi[axis] > node.hi[axis] {
            poly.clip(axis, node.hi[axis] + margin, true);
        }
    }
    let clipped = Aabb::from_points(poly.points[..poly.len].iter().copied());
    if clipped.is_empty() {
        return None;
    }
    let (lo, hi) = clipped.to_f32_outward();
    let lo_limit = tri.lo.max(node.lo);
    let hi_limit = tri.hi.min(node.hi);
    let fit = |p: [f32; 3]| DVec3::from(p.map(f64::from)).max(lo_limit).min(hi_limit);
    Some(Aabb {
        lo: fit(lo),
        hi: fit(hi),
    })
}

/// A convex polygon of at most 9 points: a triangle clipped by the 6 planes of a box (each
/// plane adds at most one point).
struct Polygon {
    points: [DVec3; 9],
    len: usize,
}

impl Polygon {
    fn triangle(v: &[DVec3; 3]) -> Polygon {
        let mut points = [DVec3::ZERO; 9];
        points[..3].copy_from_slice(v);
        Polygon { points, len: 3 }
    }

    /// Sutherland–Hodgman against the plane `axis = c`, keeping the side below it (`below`)
    /// or above it.
    fn clip(&mut self, axis: usize, c: f64, below: bool) {
        let inside = |p: DVec3| if below { p[axis] <= c } else { p[axis] >= c };
        let (points, len) = (self.points, self.len);
        self.len = 0;
        for i in 0..len {
            let (a, b) = (points[i], points[(i + 1) % len]);
            if inside(a) {
                self.push(a);
            }
            if inside(a) != inside(b) {
                let mut p = a + (b - a) * ((c - a[axis]) / (b[axis] - a[axis]));
                p[axis] = c;
                self.push(p);
            }
        }
    }

    fn push(&mut self, p: DVec3) {
        // A convex polygon cut by a plane gains at most one point, so 9 is never exceeded;
        // the check only keeps a broken invariant from indexing out of bounds.
        if let Some(slot) = self.points.get_mut(self.len) {
            *slot = p;
            self.len += 1;
        }
    }
}

/// Event kinds, in the order events at one position are swept: ends before planar before
/// starts (Wald–Havran section 4.2).
const END: u32 = 0;
const PLANAR: u32 = 1;
const START: u32 = 2;
const TRI_MASK: u32 = (1 << 30) - 1;

/// A triangle's clipped box beginning, ending or (flat on this axis) lying at `pos`; the kind
/// sits in the top 2 bits of `packed`, the triangle's build number in the low 30.
#[derive(Clone, Copy, Debug)]
struct Event {
    pos: f32,
    packed: u32,
}

impl Event {
    fn new(pos: f64, kind: u32, tri: u32) -> Event {
        Event {
            // Positions are f32 values already; + 0.0 turns -0 into +0 so both sort as one.
            pos: pos as f32 + 0.0,
            packed: kind << 30 | tri,
        }
    }

    fn kind(self) -> u32 {
        self.packed >> 30
    }

    fn tri(self) -> usize {
        (self.packed & TRI_MASK) as usize
    }

    /// Sorts by position, then kind, then triangle (so the build is deterministic).
    fn key(self) -> u64 {
        let bits = self.pos.to_bits();
        let ordered = if bits >> 31 == 1 {
            !bits
        } else {
            bits | 1 << 31
        };
        u64::from(ordered) << 32 | u64::from(self.packed)
    }
}

/// Appends the events of triangle `tri` with clipped box `b` to the three axis lists.
fn push_events(lists: &mut [Vec<Event>; 3], tri: u32, b: &Aabb) {
    for (axis, list) in lists.iter_mut().enumerate() {
        if b.lo[axis] == b.hi[axis] {
            list.push(Event::new(b.lo[axis], PLANAR, tri));
        } else {
            list.push(Event::new(b.lo[axis], START, tri));
            list.push(Event::new(b.hi[axis], END, tri));
        }
    }
}

/// Merges two lists sorted by [`Event::key`].
fn merge(a: Vec<Event>, mut b: Vec<Event>) -> Vec<Event> {
    if b.is_empty() {
        return a;
    }
    b.sort_unstable_by_key(|e| e.key());
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        if a[i].key() <= b[j].key() {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// `entries` shared between two children of `left` and `right` triangles in proportion to
/// their counts (plus one, for empty children): no subtree's splits take more than its
/// node's allowance, and the tree's no more than the root's, without any order between the
/// builder's threads.
fn share(entries: usize, left: usize, right: usize) -> (usize, usize) {
    let (l, r) = (left as f64 + 1.0, right as f64 + 1.0);
    let to_left = ((entries as f64 * l / (l + r)) as usize).min(entries);
    (to_left, entries - to_left)
}

/// What a split of a node of `count` triangles into children of `left` and `right` takes
/// from the node's allowance: the references it duplicates and its two children's nodes, in a
/// node of more than [`LARGE_NODE`] triangles; nothing in a smaller one.
fn charged(count: usize, left: usize, right: usize) -> usize {
    if count > LARGE_NODE {
        2 + (left + right).saturating_sub(count)
    } else {
        0
    }
}

/// Where a triangle goes when its node splits.
const BOTH: u8 = 0;
const LEFT: u8 = 1;
const RIGHT: u8 = 2;

/// The plane a node splits at.
#[derive(Clone, Copy, Debug)]
struct Split {
    axis: usize,
    pos: f32,
    /// Triangles lying in the plane go below it (else above).
    planar_left: bool,
    cost: f64,
    left: usize,
    right: usize,
}

impl Split {
    /// The triangle count of the larger child.
    fn larger(&self) -> usize {
        self.left.max(self.right)
    }
}

/// The parameters with the automatic depth resolved.
struct Costs {
    traversal: f64,
    intersection: f64,
    empty_factor: f64,
    max_depth: u32,
    max_leaf_triangles: usize,
}

impl Costs {
    /// SAH cost of a split, relative to the node's area.
    fn split(&self, p_left: f64, p_right: f64, left: usize, right: usize) -> f64 {
        let c =
            self.traversal + self.intersection * (p_left * left as f64 + p_right * right as f64);
        if left == 0 || right == 0 {
            c * self.empty_factor
        } else {
            c
        }
    }
}

/// The entries (nodes and leaf references) a build may make, shared by its threads. Every
/// split only adds entries, and each split's count depends on the tree alone, so a build
/// passes the bound exactly when its whole tree would, whatever order the threads work in:
/// the outcome stays deterministic.
struct Budget {
    limit: usize,
    used: AtomicUsize,
}

impl Budget {
    /// The budget of a tree over `triangles` with `per_triangle` entries each, its root leaf
    /// already counted.
    fn new(triangles: usize, per_triangle: usize) -> Budget {
        Budget {
            limit: triangles
                .saturating_mul(per_triangle)
                .saturating_add(ENTRY_SLACK),
            used: AtomicUsize::new(triangles + 1),
        }
    }

    /// Counts `entries` more; false once the bound is passed.
    fn spend(&self, entries: usize) -> bool {
        self.used.fetch_add(entries, Ordering::Relaxed) + entries <= self.limit
    }

    fn exhausted(&self) -> bool {
        self.used.load(Ordering::Relaxed) > self.limit
    }
}

/// A tree under construction (or a subtree built on another thread), indices relative to
/// its own start.
#[derive(Default)]
struct Output {
    nodes: Vec<KdNode>,
    indices: Vec<u32>,
}

impl Output {
    /// Appends a subtree built into its own `Output`, moving its node and index references.
    /// (References past the format's range wrap; [`fits_format`] then rejects the tree.)
    fn append(&mut self, sub: Output) {
        let node_base = self.nodes.len() as u32;
        let index_base = self.indices.len() as u32;
        self.nodes.extend(sub.nodes.iter().map(|n| {
            if n.is_leaf() {
                KdNode::leaf(n.first_index().wrapping_add(index_base), n.count())
            } else {
                let above = n.above_child().wrapping_add(node_base);
                KdNode::interior(n.axis(), n.split(), above)
            }
        }));
        self.indices.extend_from_slice(&sub.indices);
    }

    fn leaf(&mut self, mut triangles: Vec<u32>) {
        triangles.sort_unstable();
        self.nodes.push(KdNode::leaf(
            self.indices.len() as u32,
            triangles.len() as u32,
        ));
        self.indices.extend_from_slice(&triangles);
    }
}

/// A child node to build: its event lists and triangle count.
type Child = ([Vec<Event>; 3], usize);

/// The SAH builder's state: the valid triangles (build numbers index `tris`), the per-triangle
/// side scratch of the split being made, and the output.
struct SahBuilder<'a> {
    tris: &'a [Tri],
    costs: &'a Costs,
    budget: &'a Budget,
    side: Vec<u8>,
    out: Output,
    /// Nodes shallower than this may build their above child on another thread.
    parallel_depth: u32,
}

impl<'a> SahBuilder<'a> {
    fn new(tris: &'a [Tri], costs: &'a Costs, budget: &'a Budget, parallel_depth: u32) -> Self {
        SahBuilder {
            tris,
            costs,
            budget,
            side: vec![BOTH; tris.len()],
            out: Output::default(),
            parallel_depth,
        }
    }

    /// Builds the subtree of a node of `count` triangles whose forced splits may add
    /// `allowance` entries; gives up, leaving a broken tree, once the budget is spent.
    fn node(
        &mut self,
        events: [Vec<Event>; 3],
        bx: Aabb,
        count: usize,
        allowance: usize,
        depth: u32,
    ) {
        if self.budget.exhausted() {
            return;
        }
        let split = if depth < self.costs.max_depth {
            self.choose_split(&events, &bx, count, allowance)
        } else {
            None
        };
        let Some(split) = split else {
            return self.out.leaf(self.leaf_triangles(&events));
        };
        let (left, right) = self.split_events(events, &bx, &split);
        let (mut left_box, mut right_box) = (bx, bx);
        left_box.hi[split.axis] = f64::from(split.pos);
        right_box.lo[split.axis] = f64::from(split.pos);
        // The node's two children and the references they duplicate.
        if !self
            .budget
            .spend(2 + (left.1 + right.1).saturating_sub(count))
        {
            return;
        }
        let rest = allowance.saturating_sub(charged(count, left.1, right.1));
        let (left_allowance, right_allowance) = share(rest, left.1, right.1);
        let at = self.out.nodes.len();
        self.out.nodes.push(KdNode::default());
        let mut right = Some(right);
        let mut helped = None;
        if depth < self.parallel_depth && count >= PARALLEL_MIN_TRIANGLES {
            // The above child on another thread, into its own output; if no thread can be
            // started, it is built here after the below child, as in the serial case.
            let mut helper =
                SahBuilder::new(self.tris, self.costs, self.budget, self.parallel_depth);
            let ran = beside(
                || self.node(left.0, left_box, left.1, left_allowance, depth + 1),
                || {
                    if let Some((events, n)) = right.take() {
                        helper.node(events, right_box, n, right_allowance, depth + 1);
                    }
                },
            );
            helped = ran.then_some(helper.out);
        } else {
            self.node(left.0, left_box, left.1, left_allowance, depth + 1);
        }
        self.out.nodes[at] = KdNode::interior(split.axis, split.pos, self.out.nodes.len() as u32);
        if let Some(sub) = helped {
            self.out.append(sub);
        }
        if let Some((events, n)) = right {
            self.node(events, right_box, n, right_allowance, depth + 1);
        }
    }

    /// The mesh numbers of the triangles in a node's event lists.
    fn leaf_triangles(&self, events: &[Vec<Event>; 3]) -> Vec<u32> {
        events[0]
            .iter()
            .filter(|e| e.kind() != END)
            .map(|e| self.tris[e.tri()].number)
            .collect()
    }

    /// The plane a node splits at, if any: the cheapest by SAH; else, in a node of more than
    /// `max_leaf_triangles`, a forced plane or the midpoint fallback, if the entries it can
    /// add (the split's counts bound its children's: clipping only drops triangles) fit the
    /// node's `allowance`.
    fn choose_split(
        &self,
        events: &[Vec<Event>; 3],
        bx: &Aabb,
        count: usize,
        allowance: usize,
    ) -> Option<Split> {
        let split = self.find_split(events, bx, count)?;
        (charged(count, split.left, split.right) <= allowance).then_some(split)
    }

    /// The cheapest plane strictly inside `bx` (Wald–Havran's sweep over each axis's sorted
    /// events), if the node should be split there.
    fn find_split(&self, events: &[Vec<Event>; 3], bx: &Aabb, count: usize) -> Option<Split> {
        let area = bx.surface_area();
        if area <= 0.0 {
            return None;
        }
        let extent = bx.extent();
        let inv_area = 1.0 / area;
        let mut best: Option<Split> = None;
        // The plane that leaves the larger child fewest triangles, for forced splits.
        let mut balanced: Option<Split> = None;
        for (axis, list) in events.iter().enumerate() {
            let (lo, hi) = (bx.lo[axis], bx.hi[axis]);
            let (e1, e2) = (extent[(axis + 1) % 3], extent[(axis + 2) % 3]);
            // A child's area over the node's: (2 e1 e2 + 2 (e1 + e2) width) / area.
            let (cap, side) = (2.0 * e1 * e2 * inv_area, 2.0 * (e1 + e2) * inv_area);
            let (mut left, mut right) = (0usize, count);
            let mut i = 0;
            while i < list.len() {
                let pos = list[i].pos;
                let mut n = [0usize; 3];
                while i < list.len() && list[i].pos == pos {
                    n[list[i].kind() as usize] += 1;
                    i += 1;
                }
                let [ends, planar, starts] = n;
                right -= planar + ends;
                let p = f64::from(pos);
                if p > lo && p < hi {
                    let p_left = cap + side * (p - lo);
                    let p_right = cap + side * (hi - p);
                    let below = self.costs.split(p_left, p_right, left + planar, right);
                    let above = self.costs.split(p_left, p_right, left, right + planar);
                    let candidate = if below < above {
                        (below, true, left + planar, right)
                    } else {
                        (above, false, left, right + planar)
                    };
                    let split = Split {
                        axis,
                        pos,
                        planar_left: candidate.1,
                        cost: candidate.0,
                        left: candidate.2,
                        right: candidate.3,
                    };
                    if best.is_none_or(|b| split.cost < b.cost) {
                        best = Some(split);
                    }
                    if balanced.is_none_or(|b| split.larger() < b.larger()) {
                        balanced = Some(split);
                    }
                }
                left += starts + planar;
            }
        }
        let best = best?;
        if best.cost < self.costs.intersection * count as f64 {
            return Some(best);
        }
        // SAH would stop here. A node of more than max_leaf_triangles is split anyway where
        // the larger child gets fewest triangles, if both lose some: the cheapest plane can
        // be a sliver that takes one triangle off a pile, and a chain of those only reaches
        // the depth limit with the pile whole.
        if count <= self.costs.max_leaf_triangles {
            return None;
        }
        [best, balanced?].into_iter().find(|s| s.larger() < count)
    }

    /// Splits the node's event lists into its children's, in time linear in their length
    /// plus sorting the events of the triangles that straddle the plane, which are clipped to
    /// each child's box afresh. Returns each child's lists and triangle count.
    fn split_events(
        &mut self,
        events: [Vec<Event>; 3],
        bx: &Aabb,
        split: &Split,
    ) -> (Child, Child) {
        let axis_list = &events[split.axis];
        for e in axis_list.iter().filter(|e| e.kind() != END) {
            self.side[e.tri()] = BOTH;
        }
        for e in axis_list {
            match e.kind() {
                END if e.pos <= split.pos => self.side[e.tri()] = LEFT,
                START if e.pos >= split.pos => self.side[e.tri()] = RIGHT,
                PLANAR => {
                    let left = e.pos < split.pos || (e.pos == split.pos && split.planar_left);
                    self.side[e.tri()] = if left { LEFT } else { RIGHT };
                }
                _ => {}
            }
        }
        let straddling: Vec<usize> = axis_list
            .iter()
            .filter(|e| e.kind() == START && self.side[e.tri()] == BOTH)
            .map(|e| e.tri())
            .collect();

        let mut left: [Vec<Event>; 3] = Default::default();
        let mut right: [Vec<Event>; 3] = Default::default();
        for (axis, list) in events.into_iter().enumerate() {
            let (l, r) = (&mut left[axis], &mut right[axis]);
            l.reserve(list.len() / 2 + 16);
            r.reserve(list.len() / 2 + 16);
            for e in list {
                match self.side[e.tri()] {
                    LEFT => l.push(e),
                    RIGHT => r.push(e),
                    _ => {}
                }
            }
        }
        let sides = |lists: &[Vec<Event>; 3]| lists[0].iter().filter(|e| e.kind() != END).count();
        let (mut left_count, mut right_count) = (sides(&left), sides(&right));

        let (mut left_box, mut right_box) = (*bx, *bx);
        left_box.hi[split.axis] = f64::from(split.pos);
        right_box.lo[split.axis] = f64::from(split.pos);
        let mut new_left: [Vec<Event>; 3] = Default::default();
        let mut new_right: [Vec<Event>; 3] = Default::default();
        for t in straddling {
            let tri = &self.tris[t];
            let (v, tri_box) = (tri.vertices(), tri.bounds());
            if let Some(b) = clip_bounds(&v, &tri_box, &left_box) {
                push_events(&mut new_left, t as u32, &b);
                left_count += 1;
            }
            if let Some(b) = clip_bounds(&v, &tri_box, &right_box) {
                push_events(&mut new_right, t as u32, &b);
                right_count += 1;
            }
        }
        let merged = |old: [Vec<Event>; 3], new: [Vec<Event>; 3]| {
            let [o0, o1, o2] = old;
            let [n0, n1, n2] = new;
            [merge(o0, n0), merge(o1, n1), merge(o2, n2)]
        };
        (
            (merged(left, new_left), left_count),
            (merged(right, new_right), right_count),
        )
    }
}

/// The original's builder, kept for comparison: round-robin axes, the split at the median of
/// the triangles' clipped-box centres, leaves at depth 15 or at most 15 triangles.
struct MedianBuilder<'a> {
    tris: &'a [Tri],
    out: Output,
    parallel_depth: u32,
}

impl MedianBuilder<'_> {
    /// `items`: build numbers of the node's triangles with their boxes clipped to it.
    fn node(&mut self, items: Vec<(usize, Aabb)>, bx: Aabb, depth: u32) {
        let axis = (depth % 3) as usize;
        let split = (depth < MEDIAN_MAX_DEPTH && items.len() > MEDIAN_LEAF_TRIANGLES)
            .then(|| {
                let mut centres: Vec<f64> = items.iter().map(|(_, b)| b.center()[axis]).collect();
                let mid = centres.len() / 2;
                let median = *centres.select_nth_unstable_by(mid, f64::total_cmp).1;
                let inside = |s: f32| f64::from(s) > bx.lo[axis] && f64::from(s) < bx.hi[axis];
                // The median centre can sit on the box face (triangles crowding it): then
                // the middle of the box, as a spatial median.
                [median as f32, bx.center()[axis] as f32]
                    .into_iter()
                    .find(|&s| inside(s))
            })
            .flatten();
        let Some(split) = split else {
            self.out
                .leaf(items.iter().map(|&(t, _)| self.tris[t].number).collect());
            return;
        };
        let (mut left_box, mut right_box) = (bx, bx);
        left_box.hi[axis] = f64::from(split);
        right_box.lo[axis] = f64::from(split);
        let child = |child_box: &Aabb| -> Vec<(usize, Aabb)> {
            items
                .iter()
                .filter_map(|&(t, _)| {
                    let tri = &self.tris[t];
                    clip_bounds(&tri.vertices(), &tri.bounds(), child_box).map(|b| (t, b))
                })
                .collect()
        };
        let (left, right) = (child(&left_box), child(&right_box));
        let parallel = depth < self.parallel_depth && items.len() >= PARALLEL_MIN_TRIANGLES;
        drop(items);
        let at = self.out.nodes.len();
        self.out.nodes.push(KdNode::default());
        let mut right = Some(right);
        let mut helped = None;
        if parallel {
            // As SahBuilder::node: the above child on another thread, into its own output, or
            // here after the below child if no thread can be started.
            let mut helper = MedianBuilder {
                tris: self.tris,
                out: Output::default(),
                parallel_depth: self.parallel_depth,
            };
            let ran = beside(
                || self.node(left, left_box, depth + 1),
                || {
                    if let Some(items) = right.take() {
                        helper.node(items, right_box, depth + 1);
                    }
                },
            );
            helped = ran.then_some(helper.out);
        } else {
            self.node(left, left_box, depth + 1);
        }
        self.out.nodes[at] = KdNode::interior(axis, split, self.out.nodes.len() as u32);
        if let Some(sub) = helped {
            self.out.append(sub);
        }
        if let Some(items) = right {
            self.node(items, right_box, depth + 1);
        }
    }
}

/// Runs `here` on this thread and `there` on another (a node's two children, built at once):
/// whether `there` ran. False when no thread could be started: the caller then does that work
/// itself, after `here`, as in a serial build. A panic in either goes on.
fn beside(here: impl FnOnce(), there: impl FnOnce() + Send) -> bool {
    let joined = std::thread::scope(|s| {
        let handle = std::thread::Builder::new().spawn_scoped(s, there);
        here();
        handle.map(|h| h.join())
    });
    match joined {
        Ok(Ok(())) => true,
        Ok(Err(panic)) => std::panic::resume_unwind(panic),
        Err(_) => false,
    }
}

/// The depth above which a node may hand a child to another thread: two subtrees per thread at
/// the top balance the load well enough.
fn parallel_depth() -> u32 {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if threads > 1 {
        usize::BITS - (threads - 1).leading_zeros() + 1
    } else {
        0
    }
}

/// True when the flattened tree's references fit the node format (30-bit child index, 32-bit
/// index offset).
fn fits_format(out: &Output) -> bool {
    out.nodes.len() <= (1 << 30) && u32::try_from(out.indices.len()).is_ok()
}

impl KdTree {
    /// The SAH kd-tree of a mesh given as vertex positions (object space) and index triples.
    /// Zero-area triangles and those with missing or non-finite vertices are left out.
    pub fn build(positions: &[[f32; 3]], triangles: &[[u32; 3]], params: &KdParams) -> KdTree {
        let tris = valid_triangles(positions, triangles);
        let bounds = tris.iter().fold(Aabb::EMPTY, |b, t| b.union(t.bounds()));
        let auto_depth = || (8.0 + 1.3 * (tris.len().max(1) as f64).log2()).round() as u32;
        let mut max_depth = match params.max_depth {
            0 => auto_depth(),
            d => d,
        }
        .min(MAX_DEPTH);
        let parallel_depth = parallel_depth();
        let mut events: [Vec<Event>; 3] = Default::default();
        for (t, tri) in tris.iter().enumerate() {
            push_events(&mut events, t as u32, &tri.bounds());
        }
        for list in &mut events {
            list.sort_unstable_by_key(|e| e.key());
        }
        loop {
            let costs = Costs {
                traversal: params.traversal_cost,
                intersection: params.intersection_cost,
                empty_factor: 1.0 - params.empty_bonus,
                max_depth,
                max_leaf_triangles: params.max_leaf_triangles as usize,
            };
            let budget = Budget::new(tris.len(), params.max_entries_per_triangle);
            let mut builder = SahBuilder::new(&tris, &costs, &budget, parallel_depth);
            let allowance = tris.len().saturating_mul(LARGE_SPLIT_ENTRIES_PER_TRIANGLE);
            builder.node(events.clone(), bounds, tris.len(), allowance, 0);
            // A tree over its budget (max_entries_per_triangle), or one of hundreds of
            // millions of triangles that overflows the format, is built again shallower:
            // depth 0 is one leaf of fewer than 2^30 triangles, within both.
            if (!budget.exhausted() && fits_format(&builder.out)) || max_depth == 0 {
                return KdTree {
                    nodes: builder.out.nodes,
                    indices: builder.out.indices,
                    bounds,
                };
            }
            max_depth = max_depth.saturating_sub(4);
        }
    }

    /// The original's tree, for comparison: round-robin axes, median splits, depth ≤ 15,
    /// ≤ 15 triangles per leaf (more only at depth 15).
    pub fn build_median(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> KdTree {
        let tris = valid_triangles(positions, triangles);
        let items: Vec<(usize, Aabb)> = tris
            .iter()
            .enumerate()
            .map(|(t, tri)| (t, tri.bounds()))
            .collect();
        let bounds = items.iter().fold(Aabb::EMPTY, |b, (_, t)| b.union(*t));
        let mut builder = MedianBuilder {
            tris: &tris,
            out: Output::default(),
            parallel_depth: parallel_depth(),
        };
        builder.node(items, bounds, 0);
        KdTree {
            nodes: builder.out.nodes,
            indices: builder.out.indices,
            bounds,
        }
    }

    /// Every node with its box and depth, depth first (boxes recomputed from the root bounds
    /// and the splits). Stops at references out of range rather than panicking.
    pub fn node_boxes(&self) -> Vec<(usize, Aabb, u32)> {
        let mut out = Vec::with_capacity(self.nodes.len());
        let mut stack = vec![(0usize, self.bounds, 0u32)];
        while let Some((i, bx, depth)) = stack.pop() {
            let Some(node) = self.nodes.get(i) else {
                continue;
            };
            out.push((i, bx, depth));
            if !node.is_leaf() && depth < MAX_DEPTH {
                let (mut below, mut above) = (bx, bx);
                below.hi[node.axis()] = f64::from(node.split());
                above.lo[node.axis()] = f64::from(node.split());
                stack.push((node.above_child() as usize, above, depth + 1));
                stack.push((i + 1, below, depth + 1));
            }
        }
        out
    }

    /// Size, shape and SAH cost of the tree (`positions` and `triangles` are the mesh it was
    /// built from, to count the triangles it leaves out).
    pub fn stats(&self, positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> KdStats {
        let costs = KdParams::default();
        let root_area = self.bounds.surface_area();
        let mut stats = KdStats {
            nodes: self.nodes.len(),
            leaves: 0,
            empty_leaves: 0,
            max_depth: 0,
            mean_leaf_triangles: 0.0,
            index_entries: self.indices.len(),
            sah_cost: 0.0,
            bytes: self.nodes.len() * size_of::<KdNode>() + self.indices.len() * size_of::<u32>(),
            skipped_triangles: (0..triangles.len())
                .filter(|&i| valid_triangle(positions, triangles, i).is_none())
                .count(),
        };
        let mut referenced = 0usize;
        for (i, bx, depth) in self.node_boxes() {
            let node = self.nodes[i];
            let weight = if root_area > 0.0 {
                bx.surface_area() / root_area
            } else {
                1.0
            };
            if node.is_leaf() {
                stats.leaves += 1;
                stats.max_depth = stats.max_depth.max(depth);
                if node.count() == 0 {
                    stats.empty_leaves += 1;
                }
                referenced += node.count() as usize;
                stats.sah_cost += costs.intersection_cost * f64::from(node.count()) * weight;
            } else {
                stats.sah_cost += costs.traversal_cost * weight;
            }
        }
        let full = stats.leaves - stats.empty_leaves;
        if full > 0 {
            stats.mean_leaf_triangles = referenced as f64 / full as f64;
        }
        stats
    }
}
