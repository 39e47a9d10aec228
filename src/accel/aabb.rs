//! Axis-aligned boxes in f64 (host side of AABB.cuh), shared by the object BVH and the mesh
//! kd-trees. Device copies are rounded outwards to f32 ([`Aabb::to_f32_outward`]) so a box never
//! shrinks past what it bounds.

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        lo: DVec3::splat(f64::INFINITY),
        hi: DVec3::splat(f64::NEG_INFINITY),
    };

    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    pub fn grow(self, p: DVec3) -> Aabb {
        Aabb {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    pub fn union(self, other: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x || self.lo.y > self.hi.y || self.lo.z > self.hi.z
    }

    pub fn extent(&self) -> DVec3 {
        if self.is_empty() {
            DVec3::ZERO
        } else {
            self.hi - self.lo
        }
    }

    pub fn center(&self) -> DVec3 {
        (self.lo + self.hi) * 0.5
    }

    pub fn surface_area(&self) -> f64 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    pub fn contains(&self, other: &Aabb) -> bool {
        other.is_empty() || (self.lo.cmple(other.lo).all() && self.hi.cmpge(other.hi).all())
    }

    /// The f32 box (lo, hi) containing this one: each bound rounded away from the inside.
    pub fn to_f32_outward(&self) -> ([f32; 3], [f32; 3]) {
        let down = |v: f64| {
            let f = v as f32;
            if (f as f64) > v { f.next_down() } else { f }
        };
        let up = |v: f64| {
            let f = v as f32;
            if (f as f64) < v { f.next_up() } else { f }
        };
        (
            [down(self.lo.x), down(self.lo.y), down(self.lo.z)],
            [up(self.hi.x), up(self.hi.y), up(self.hi.z)],
        )
    }

    /// The parameter interval [t0, t1] of the ray o + t d inside the box, clipped to
    /// [t_min, t_max]; `None` if it misses (slab test; d may have zero components).
    pub fn clip_ray(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (t_min, t_max);
        for axis in 0..3 {
            let inv = 1.0 / d[axis];
            let (mut near, mut far) = (
                (self.lo[axis] - o[axis]) * inv,
                (self.hi[axis] - o[axis]) * inv,
            );
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            // NaN (0 * inf on a slab boundary) leaves the interval as it is.
            if near > t0 {
                t0 = near;
            }
            if far < t1 {
                t1 = far;
            }
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}
