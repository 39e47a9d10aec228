//! Profile curves and their surfaces of revolution, in f64: the host-side counterpart of the
//! original's `curve.cuh` (and the `RevSurface` object built on it).
//!
//! A [`Curve`] is a Bézier curve of degree 1 to 7 or a uniform cubic B-spline in the profile
//! plane (x, y); revolving it about the y axis gives the surface
//! S(s, θ) = (x(s) cos θ, y(s), x(s) sin θ) (`revolve`).
//!
//! - Bézier curves use the Bernstein basis: the point by de Casteljau's algorithm, the
//!   derivative from the degree n − 1 hodograph (Farin, *Curves and Surfaces for CAGD*, 5th ed.,
//!   chapters 3–5).
//! - B-splines are cubic on the uniform knots t_i = i/(m+3) for m control points. Such a curve is
//!   only defined (its basis only sums to one) on [t_3, t_m]; the original evaluated it on all of
//!   [0, 1], where it is pulled towards the origin, and drew thin spurious spindles near the axis.
//!   Here the curve parameter s ∈ [0, 1] maps linearly onto [t_3, t_m], and [`Curve::eval`] clamps
//!   s to [0, 1], so no point outside the valid range is ever produced.
//!   [`Curve::bezier_segments`] converts it to m − 3 cubic Bézier segments (Farin, ch. 7).
//!
//! The f64 ray/surface intersection the tests hold the device's to (`intersect_reference`)
//! lives with the tests, in `tests/common/curve_reference.rs`.

use crate::accel::aabb::Aabb;
use glam::{DVec2, DVec3};

/// The most control points a Bézier profile may have (degree 7).
pub const MAX_BEZIER_POINTS: usize = 8;

const MAX_DEG: usize = MAX_BEZIER_POINTS - 1;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveKind {
    Bezier,
    BSpline,
}

/// A profile curve in the (x, y) plane (the scene file's z is dropped).
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    pub kind: CurveKind,
    pub controls: Vec<DVec2>,
}

impl Curve {
    /// Checks the control points: a Bézier curve needs 2 to 8 (degree 1 to 7), a cubic B-spline
    /// at least 4; every coordinate must be finite.
    pub fn new(kind: CurveKind, controls: Vec<DVec2>) -> Result<Curve, String> {
        check(kind, &controls)?;
        Ok(Curve { kind, controls })
    }

    /// The polynomial degree of the curve (of each of its Bézier segments).
    pub fn degree(&self) -> usize {
        match self.kind {
            CurveKind::Bezier => self.controls.len().saturating_sub(1),
            CurveKind::BSpline => 3,
        }
    }

    /// Point and derivative (with respect to s) at s ∈ [0, 1]; s is clamped to [0, 1]. A Bézier
    /// curve's own parameter is s; a B-spline's knot parameter is t = t_3 + s (t_m − t_3), so the
    /// derivative is dC/dt · (t_m − t_3). A curve with too few points (built without
    /// [`Curve::new`]) gives NaN.
    pub fn eval(&self, s: f64) -> (DVec2, DVec2) {
        let s = s.clamp(0.0, 1.0);
        let p = &self.controls;
        match self.kind {
            CurveKind::Bezier => {
                if p.is_empty() {
                    return (DVec2::NAN, DVec2::NAN);
                }
                let point = casteljau(p, s);
                let n = p.len() - 1;
                let deriv = if n == 0 {
                    DVec2::ZERO
                } else {
                    let hodograph: Vec<DVec2> = p.windows(2).map(|w| w[1] - w[0]).collect();
                    casteljau(&hodograph, s) * n as f64
                };
                (point, deriv)
            }
            CurveKind::BSpline => {
                let m = p.len();
                if m < 4 {
                    return (DVec2::NAN, DVec2::NAN);
                }
                let h = 1.0 / (m + 3) as f64;
                let knot = |i: usize| i as f64 * h;
                let (t3, tm) = (knot(3), knot(m));
                let t = t3 + s * (tm - t3);
                // The span [t_j, t_j+1) holding t, j in [3, m − 1] (t = t_m uses the last span).
                let j = ((t / h).floor() as usize).clamp(3, m - 1);
                let point = de_boor(3, p, knot, j, t);
                // C'(t) = Σ Q_i N_{i,2}(t), Q_i = 3 (P_i+1 − P_i)/(t_i+4 − t_i+1), on the knots
                // t_1.. (Farin ch. 8); span j − 1 of that knot vector.
                let q: Vec<DVec2> = p
                    .windows(2)
                    .enumerate()
                    .map(|(i, w)| (w[1] - w[0]) * (3.0 / (knot(i + 4) - knot(i + 1))))
                    .collect();
                let dt = de_boor(2, &q, |i| knot(i + 1), j - 1, t);
                (point, dt * (tm - t3))
            }
        }
    }

    /// The curve as Bézier segments in order, each of degree + 1 control points, covering
    /// s ∈ [0, 1] in equal steps: segment k of K covers [k/K, (k+1)/K]. A Bézier curve is one
    /// segment; a B-spline with m points gives m − 3 cubic segments.
    pub fn bezier_segments(&self) -> Vec<Vec<DVec2>> {
        match self.kind {
            CurveKind::Bezier => vec![self.controls.clone()],
            CurveKind::BSpline => self
                .controls
                .windows(4)
                .map(|w| {
                    let (p0, p1, p2, p3) = (w[0], w[1], w[2], w[3]);
                    vec![
                        (p0 + 4.0 * p1 + p2) / 6.0,
                        (2.0 * p1 + p2) / 3.0,
                        (p1 + 2.0 * p2) / 3.0,
                        (p1 + 4.0 * p2 + p3) / 6.0,
                    ]
                })
                .collect(),
        }
    }

    /// Box of the surface of revolution: x and z in [−r, r] with r the largest |x| of the control
    /// points, y over the control points' y (both curve kinds lie in their control polygon's
    /// convex hull).
    pub fn revolution_bounds(&self) -> Aabb {
        revolution_box(&self.controls)
    }
}

fn check(kind: CurveKind, controls: &[DVec2]) -> Result<(), String> {
    if let Some(i) = controls.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "control point {i} ({}, {}) is not finite",
            controls[i].x, controls[i].y
        ));
    }
    let n = controls.len();
    match kind {
        CurveKind::Bezier if !(2..=MAX_BEZIER_POINTS).contains(&n) => Err(format!(
            "a Bezier curve needs 2 to {MAX_BEZIER_POINTS} control points (degree 1 to {MAX_DEG}), got {n}"
        )),
        CurveKind::BSpline if n < 4 => Err(format!(
            "a cubic B-spline needs at least 4 control points, got {n}"
        )),
        _ => Ok(()),
    }
}

/// The box about the y axis that holds the surface of revolution of a control polygon (its
/// convex hull, revolved).
pub fn revolution_box(points: &[DVec2]) -> Aabb {
    if points.is_empty() {
        return Aabb::EMPTY;
    }
    let r = points.iter().fold(0.0f64, |r, p| r.max(p.x.abs()));
    let (ylo, yhi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
    Aabb {
        lo: DVec3::new(-r, ylo, -r),
        hi: DVec3::new(r, yhi, r),
    }
}

/// De Casteljau's algorithm on any number of points.
fn casteljau(points: &[DVec2], u: f64) -> DVec2 {
    let mut b = points.to_vec();
    for level in (1..b.len()).rev() {
        for i in 0..level {
            b[i] = b[i].lerp(b[i + 1], u);
        }
    }
    b.first().copied().unwrap_or(DVec2::NAN)
}

/// De Boor's algorithm: the degree-`p` B-spline with controls `c` and knots `knot(i)` at t in
/// span j (knot(j) ≤ t < knot(j+1), p ≤ j < c.len()).
fn de_boor(p: usize, c: &[DVec2], knot: impl Fn(usize) -> f64, j: usize, t: f64) -> DVec2 {
    if j < p || j >= c.len() {
        return DVec2::NAN;
    }
    let mut d: Vec<DVec2> = c[j - p..=j].to_vec();
    for r in 1..=p {
        for k in (r..=p).rev() {
            let i = j - p + k;
            let alpha = (t - knot(i)) / (knot(i + 1 + p - r) - knot(i));
            d[k] = d[k - 1].lerp(d[k], alpha);
        }
    }
    d[p]
}
