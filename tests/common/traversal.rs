//! Host traversals of the trees, in f64: the references the tests hold the device's walks to
//! (tests/kdtree.rs, tests/bvh.rs, tests/mesh.rs), kept out of the library.

use clpt::accel::bvh::{Bvh, MAX_DEPTH as BVH_MAX_DEPTH, child_box};
use clpt::accel::kdtree::{KdTree, MAX_DEPTH};
use clpt::contract::{BVH_EMPTY, BVH_LEAF};
use glam::DVec3;

/// The vertices of triangle `index` in f64, or `None` when it names a vertex that does not
/// exist.
pub fn triangle_vertices(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    index: u32,
) -> Option<[DVec3; 3]> {
    let tri = triangles.get(index as usize)?;
    let vertex = |i: u32| {
        positions
            .get(i as usize)
            .map(|p| DVec3::from(p.map(f64::from)))
    };
    Some([vertex(tri[0])?, vertex(tri[1])?, vertex(tri[2])?])
}

/// Möller–Trumbore in f64: the parameter t of the point where o + t d crosses triangle `v`, if
/// t_min < t < t_max. Both faces count; a ray in the triangle's plane (and a zero-area
/// triangle) has det = 0 and misses. Inlined across crates: the tests' brute force calls it
/// billions of times.
#[inline]
pub fn intersect_triangle(
    o: DVec3,
    d: DVec3,
    v: &[DVec3; 3],
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let w = d.dot(q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    (t > t_min && t < t_max).then_some(t)
}

/// The nearest hit (t, triangle number) of o + t d for t_min < t < t_max: the host
/// reference of the device traversal.
///
/// The ray is clipped to the root box, then walks the tree front to back: at an interior
/// node it visits the child it is in before reaching the plane, then (pushed on the stack
/// with the interval past the plane) the other child, if it reaches the plane within the
/// node's interval. A ray parallel to the plane stays on its origin's side (below if it lies
/// in the plane). Each leaf's triangles are tested against the whole ray; the nearest hit
/// so far ends the walk as soon as it lies within the current leaf's [t_min, t_max] (every
/// later leaf starts beyond it), and a hit beyond the leaf waits for the later leaves.
/// Keeping a hit beyond the leaf, instead of dropping it and finding it again in the leaf
/// that owns it, gives the same answer but also keeps hits that rounding puts an ulp past
/// the plane or box face they lie on (a triangle in a split plane or on the root box is
/// stored on one side only); the device should do the same in f32.
pub fn kd_intersect(
    tree: &KdTree,
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, u32)> {
    if tree.bounds.is_empty() {
        return None;
    }
    let (mut near, mut far) = tree.bounds.clip_ray(o, d, t_min, t_max)?;
    let inv_d = d.recip();
    let mut stack = [(0u32, 0.0f64, 0.0f64); MAX_DEPTH as usize];
    let mut depth = 0usize;
    let mut node_index = 0usize;
    let mut best: Option<(f64, u32)> = None;
    loop {
        let node = tree.nodes.get(node_index)?;
        if node.is_leaf() {
            let first = node.first_index() as usize;
            let leaf = tree
                .indices
                .get(first..first + node.count() as usize)
                .unwrap_or(&[]);
            for &tri in leaf {
                let limit = best.map_or(t_max, |b| b.0);
                let hit = triangle_vertices(positions, triangles, tri)
                    .and_then(|v| intersect_triangle(o, d, &v, t_min, limit));
                if let Some(t) = hit {
                    best = Some((t, tri));
                }
            }
            if best.is_some_and(|b| b.0 <= far) || depth == 0 {
                return best;
            }
            depth -= 1;
            let (next, n0, n1) = stack[depth];
            (node_index, near, far) = (next as usize, n0, n1);
            if best.is_some_and(|b| b.0 < near) {
                return best;
            }
            continue;
        }
        let axis = node.axis();
        let split = f64::from(node.split());
        let below = node_index + 1;
        let above = node.above_child() as usize;
        if d[axis] == 0.0 {
            // Parallel to the plane: the ray stays on its origin's side (below if in it).
            node_index = if o[axis] <= split { below } else { above };
            continue;
        }
        // The ray is on the `before` side for t < t_split and on `after` beyond it.
        let t_split = (split - o[axis]) * inv_d[axis];
        let (before, after) = if d[axis] > 0.0 {
            (below, above)
        } else {
            (above, below)
        };
        if t_split > far {
            node_index = before;
        } else if t_split < near {
            node_index = after;
        } else {
            if let Some(slot) = stack.get_mut(depth) {
                *slot = (after as u32, t_split, far);
                depth += 1;
            }
            node_index = before;
            far = t_split;
        }
    }
}

/// The nearest hit of the ray `o + t d`, 0 ≤ t < `t_max`, among the objects in the tree, as
/// (t, object). Calls `hit(object, t_nearest)` for each object whose box the ray enters
/// before the nearest hit found so far; `hit` returns the object's hit distance, if any.
///
/// Explicit stack, nearer child first: the reference of the device traversal.
pub fn bvh_intersect(
    bvh: &Bvh,
    o: DVec3,
    d: DVec3,
    t_max: f64,
    mut hit: impl FnMut(u32, f64) -> Option<f64>,
) -> Option<(f64, u32)> {
    if bvh.nodes.is_empty() {
        return None;
    }
    let mut nearest = None;
    let mut t_nearest = t_max;
    // Children whose box the ray entered, with the entry distance: one queued before a
    // nearer hit was found is dropped when popped if it now starts beyond that hit.
    let mut stack: Vec<(u32, f64)> = Vec::with_capacity(BVH_MAX_DEPTH as usize + 1);
    stack.push((0, 0.0));
    while let Some((child, t_enter)) = stack.pop() {
        if t_enter >= t_nearest {
            continue;
        }
        if child & BVH_LEAF != 0 {
            let object = child & !BVH_LEAF;
            if let Some(t) = hit(object, t_nearest)
                && t < t_nearest
            {
                t_nearest = t;
                nearest = Some((t, object));
            }
            continue;
        }
        let node = &bvh.nodes[child as usize];
        let mut entered = [None; 2];
        for (k, slot) in entered.iter_mut().enumerate() {
            // The empty slot must be skipped by its reference, not by its box: the slab test
            // swaps an inverted box's planes and then accepts every ray.
            if node.child[k] != BVH_EMPTY {
                *slot = child_box(node, k)
                    .clip_ray(o, d, 0.0, t_nearest)
                    .map(|(t0, _)| (node.child[k], t0));
            }
        }
        match entered {
            [Some(a), Some(b)] => {
                let (near, far) = if b.1 < a.1 { (b, a) } else { (a, b) };
                stack.push(far);
                stack.push(near);
            }
            [Some(one), None] | [None, Some(one)] => stack.push(one),
            [None, None] => {}
        }
    }
    nearest
}
