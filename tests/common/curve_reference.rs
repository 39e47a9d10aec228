//! The f64 reference intersection of a ray with a surface of revolution: the tests' oracle for
//! the device's (tests/curve.rs, tests/revsurface.rs), kept out of the library.
//!
//! [`intersect_reference`] is a certain, slow f64 ray/surface intersection used as ground
//! truth. It follows Kajiya's reduction to one dimension (J. T. Kajiya, "New techniques for ray
//! tracing procedurally defined objects", SIGGRAPH 1983): on the ray o + t d with d_y ≠ 0 the
//! height fixes t = (y(s) − o_y)/d_y, and the ray meets the surface where
//!
//! G(s) = |d_y o_h + d_h (y(s) − o_y)|² − d_y² x(s)² = 0      (h: the xz components),
//!
//! which is d_y² times "squared distance of the ray point from the axis minus x(s)²": a polynomial
//! of degree 2n on each Bézier segment of degree n, formed exactly in Bernstein form from products
//! of the segment's coefficients. Its roots are isolated by recursive de Casteljau subdivision
//! with the convex-hull property (Bernstein coefficients all of one sign: no root; those of G' all
//! of one sign: at most one root, found by bisection). Every test allows for a bound on the
//! rounding error of the coefficients, which are formed afresh from the subdivided x and y
//! coefficients at every level so that the bound stays relative to what G is on that piece; a
//! piece that can be neither excluded nor resolved by the time it is [`MIN_INTERVAL`] wide yields a
//! candidate at its middle (a run of such touching pieces, as a graze leaves, gives one). Nearly
//! horizontal rays (|d_y| < [`HORIZONTAL_THRESHOLD`] |d|) take the other reduction: roots of
//! y(s) = the ray's height at the middle of its span over the segment, then the ray/circle
//! intersections at each (up to two hits per root). Every candidate is then polished by damped
//! Newton steps on the two equations (y(s) = o_y + t d_y, x(s)² = r(t)²) in (s, t), within the
//! piece that isolated it, which also makes hits of nearly horizontal rays exact for the tilted
//! ray. A candidate is kept if the ray point lies within [`HIT_TOLERANCE`] · scale of the surface
//! (10 · [`HIT_TOLERANCE`] · scale for a root proved by a sign change), so every hit returned is
//! within 1e-9 · scale of the surface; hits closer than 1e-9 · scale along the ray are one.
//!
//! What it can miss, by construction: a graze (a double root) that rounding cannot tell from a
//! near miss, and, for rays flatter than [`HORIZONTAL_THRESHOLD`], hits within that band of
//! heights of a horizontal tangent of the profile (a rim's top): grazes at the 1e-9 level.

use clpt::scene::curve::{Curve, MAX_BEZIER_POINTS, revolution_box};
use glam::{DVec2, DVec3};

/// Rays with |d_y| below this fraction of |d| are treated as horizontal by
/// [`intersect_reference`] (roots of y(s) = height, then ray/circle intersections); their
/// candidates are polished against the true, slightly tilted ray.
pub const HORIZONTAL_THRESHOLD: f64 = 1e-9;

/// Root isolation stops subdividing a segment's parameter interval at this width and reports a
/// candidate at its middle (a multiple root, or roots closer than this).
pub const MIN_INTERVAL: f64 = 1e-12;

/// A candidate root is a hit only if the ray point lies within this fraction of the curve's
/// scale (its largest absolute control coordinate) of the surface after polishing (ten times
/// this for a root proved by a sign change).
pub const HIT_TOLERANCE: f64 = 1e-10;

const MAX_DEG: usize = MAX_BEZIER_POINTS - 1;
const MAX_G: usize = 2 * MAX_DEG + 1;
/// Most subdivision nodes one segment may take (never reached on ordinary input; a ray lying in
/// the surface along a stretch ends as one candidate long before).
const NODE_BUDGET: u32 = 20_000;

/// The point of the surface of revolution at profile point `point` = (x(s), y(s)) and angle θ:
/// (x cos θ, y, x sin θ).
pub fn revolve(point: DVec2, theta: f64) -> DVec3 {
    let (sin, cos) = theta.sin_cos();
    DVec3::new(point.x * cos, point.y, point.x * sin)
}

/// A ray/surface-of-revolution hit.
#[derive(Clone, Copy, Debug)]
pub struct RevHit {
    /// Ray parameter: the point is o + t d.
    pub t: f64,
    /// Curve parameter in [0, 1] (as for [`Curve::eval`]).
    pub s: f64,
    /// Angle with S(s, θ) = the hit point, in (−π, π]; where x(s) < 0 it is the angle of the
    /// point's own direction plus π. 0 on the axis.
    pub theta: f64,
    /// Unit normal: the profile's right-hand normal (y', −x') for tangent (x', y'), revolved:
    /// (y' cos θ, −x', y' sin θ). That is ±(∂S/∂s × ∂S/∂θ)/|…| (+ where x(s) > 0), and it is
    /// continuous over the whole surface, the axis included; for a profile running upwards at
    /// x > 0 it points away from the axis.
    pub normal: DVec3,
}

/// One Bézier segment of the profile as coordinate arrays.
#[derive(Clone, Copy)]
struct Segment {
    deg: usize,
    x: [f64; MAX_BEZIER_POINTS],
    y: [f64; MAX_BEZIER_POINTS],
}

impl Segment {
    fn new(points: &[DVec2]) -> Option<Segment> {
        if points.len() < 2 || points.len() > MAX_BEZIER_POINTS {
            return None;
        }
        let mut s = Segment {
            deg: points.len() - 1,
            x: [0.0; MAX_BEZIER_POINTS],
            y: [0.0; MAX_BEZIER_POINTS],
        };
        for (i, p) in points.iter().enumerate() {
            s.x[i] = p.x;
            s.y[i] = p.y;
        }
        Some(s)
    }

    /// (x, y, x', y') at u (derivatives with respect to the segment's own parameter).
    fn eval(&self, u: f64) -> (f64, f64, f64, f64) {
        let (x, dx) = bernstein_eval(&self.x[..=self.deg], u);
        let (y, dy) = bernstein_eval(&self.y[..=self.deg], u);
        (x, y, dx, dy)
    }

    /// The two halves at u = 1/2.
    fn split(&self) -> (Segment, Segment) {
        let (mut l, mut r) = (*self, *self);
        split_half(&self.x[..=self.deg], &mut l.x, &mut r.x);
        split_half(&self.y[..=self.deg], &mut l.y, &mut r.y);
        (l, r)
    }
}

/// Value and derivative of a polynomial in Bernstein form (degree ≥ 1) by de Casteljau.
fn bernstein_eval(c: &[f64], u: f64) -> (f64, f64) {
    let n = c.len() - 1;
    let mut b = [0.0; MAX_G];
    b[..=n].copy_from_slice(c);
    // Stop with two points left: their difference is the derivative's.
    for level in (2..=n).rev() {
        for i in 0..level {
            b[i] += (b[i + 1] - b[i]) * u;
        }
    }
    (b[0] + (b[1] - b[0]) * u, n as f64 * (b[1] - b[0]))
}

/// Value of a polynomial in Bernstein form by de Casteljau (the same arithmetic as
/// [`bernstein_eval`]'s value, which needs degree ≥ 1).
fn bernstein_value(c: &[f64], u: f64) -> f64 {
    if c.len() == 1 {
        c[0]
    } else {
        bernstein_eval(c, u).0
    }
}

/// Bernstein coefficients of the two halves [0, 1/2] and [1/2, 1].
fn split_half(c: &[f64], left: &mut [f64], right: &mut [f64]) {
    let n = c.len() - 1;
    let mut b = [0.0; MAX_G];
    b[..=n].copy_from_slice(c);
    left[0] = b[0];
    right[n] = b[n];
    for level in 1..=n {
        for i in 0..=n - level {
            b[i] = 0.5 * (b[i] + b[i + 1]);
        }
        left[level] = b[0];
        right[n - level] = b[n - level];
    }
}

/// Binomial coefficients C(n, k) for n < MAX_G (Pascal's triangle; exact in f64).
const BINOMIAL: [[f64; MAX_G]; MAX_G] = {
    let mut t = [[0.0; MAX_G]; MAX_G];
    let mut n = 0;
    while n < MAX_G {
        t[n][0] = 1.0;
        let mut k = 1;
        while k <= n {
            t[n][k] = t[n - 1][k - 1] + t[n - 1][k];
            k += 1;
        }
        n += 1;
    }
    t
};

/// What the root isolation looks for on a segment.
enum Target {
    /// Roots of G(u) for the ray p + t d (rays that are not nearly horizontal).
    Revolution { p: DVec3, d: DVec3 },
    /// Roots of y(u) − height (nearly horizontal rays).
    Height(f64),
}

impl Target {
    /// Bernstein coefficients on the piece `seg` (a subdivision of depth `depth` of a segment),
    /// their count, and a bound on their rounding error.
    fn coefficients(&self, seg: &Segment, depth: u32) -> ([f64; MAX_G], usize, f64) {
        const EPS: f64 = f64::EPSILON;
        let n = seg.deg;
        // Relative error of the subdivided control coordinates: n roundings per level.
        let levels = (depth as f64 + 2.0) * n as f64 + 4.0;
        let xa = seg.x[..=n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let ya = seg.y[..=n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut g = [0.0; MAX_G];
        match self {
            Target::Height(c) => {
                for (gi, yi) in g.iter_mut().zip(&seg.y[..=n]) {
                    *gi = yi - c;
                }
                (g, n + 1, 4.0 * (levels + 1.0) * EPS * (ya + c.abs()))
            }
            Target::Revolution { p, d } => {
                let (mut a, mut b, mut c) = ([0.0; MAX_BEZIER_POINTS], [0.0; 8], [0.0; 8]);
                for i in 0..=n {
                    let yy = seg.y[i] - p.y;
                    a[i] = d.y * p.x + d.x * yy;
                    b[i] = d.y * p.z + d.z * yy;
                    c[i] = d.y * seg.x[i];
                }
                // Product of two degree-n Bernstein polynomials: the (i, j) term goes to
                // coefficient i + j with weight C(n,i) C(n,j)/C(2n,i+j) (Farin, ch. 5).
                let (bn, b2n) = (&BINOMIAL[n], &BINOMIAL[2 * n]);
                for i in 0..=n {
                    for j in 0..=n {
                        let w = bn[i] * bn[j] / b2n[i + j];
                        g[i + j] += w * (a[i] * a[j] + b[i] * b[j] - c[i] * c[j]);
                    }
                }
                let amax = a[..=n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let bmax = b[..=n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let cmax = c[..=n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let dy_abs = levels * EPS * (ya + p.y.abs());
                let rest = 4.0 * EPS * (d.x.abs() * (ya + p.y.abs()));
                let da = d.x.abs() * dy_abs + rest + 4.0 * EPS * (d.y * p.x).abs();
                let rest = 4.0 * EPS * (d.z.abs() * (ya + p.y.abs()));
                let db = d.z.abs() * dy_abs + rest + 4.0 * EPS * (d.y * p.z).abs();
                let dc = d.y.abs() * levels * EPS * xa;
                let err = 2.0 * (amax * da + bmax * db + cmax * dc)
                    + (2 * n + 4) as f64 * EPS * (amax * amax + bmax * bmax + cmax * cmax);
                (g, 2 * n + 1, 4.0 * err)
            }
        }
    }
}

/// A root candidate in a segment: u, the piece [lo, hi] that isolated it, and whether a sign
/// change proved it.
#[derive(Clone, Copy)]
struct Candidate {
    u: f64,
    lo: f64,
    hi: f64,
    certain: bool,
}

/// Isolates the roots of `target` on the piece `seg` = [lo, hi] of a segment, in increasing u.
fn isolate(
    target: &Target,
    seg: &Segment,
    lo: f64,
    hi: f64,
    depth: u32,
    out: &mut Vec<Candidate>,
    budget: &mut u32,
) {
    if *budget == 0 {
        return;
    }
    *budget -= 1;
    let (g, len, err) = target.coefficients(seg, depth);
    let g = &g[..len];
    let n = len - 1;
    let mid = 0.5 * (lo + hi);
    if !err.is_finite() || g.iter().any(|v| !v.is_finite()) {
        return;
    }
    // Convex hull: all coefficients of one sign, beyond their error: no root here.
    if g.iter().all(|&v| v > err) || g.iter().all(|&v| v < -err) {
        return;
    }
    // Indistinguishable from zero throughout (the ray runs in the surface, or a root is
    // narrower than rounding can resolve): one candidate.
    if g.iter().all(|&v| v.abs() <= err) {
        out.push(Candidate {
            u: mid,
            lo,
            hi,
            certain: false,
        });
        return;
    }
    // Bernstein coefficients of G' of one sign: G is monotone, at most one root.
    let rising = g.windows(2).all(|w| w[1] - w[0] > 2.0 * err);
    let falling = g.windows(2).all(|w| w[1] - w[0] < -2.0 * err);
    if rising || falling {
        let (g0, gn) = (g[0], g[n]);
        if g0.abs() <= err {
            out.push(Candidate {
                u: lo,
                lo,
                hi,
                certain: false,
            });
        } else if gn.abs() <= err {
            out.push(Candidate {
                u: hi,
                lo,
                hi,
                certain: false,
            });
        } else if (g0 < 0.0) != (gn < 0.0) {
            let v = bisect(g);
            out.push(Candidate {
                u: lo + (hi - lo) * v,
                lo,
                hi,
                certain: true,
            });
        }
        return;
    }
    if hi - lo <= MIN_INTERVAL {
        out.push(Candidate {
            u: mid,
            lo,
            hi,
            certain: false,
        });
        return;
    }
    let (left, right) = seg.split();
    isolate(target, &left, lo, mid, depth + 1, out, budget);
    isolate(target, &right, mid, hi, depth + 1, out, budget);
}

/// Joins runs of unproved candidates whose pieces touch (a multiple root or a graze leaves a
/// string of unresolved pieces) into one candidate over the run, at the member u with the
/// lowest `score`.
fn merge_runs(candidates: Vec<Candidate>, score: impl Fn(f64) -> f64) -> Vec<Candidate> {
    let mut out: Vec<Candidate> = Vec::with_capacity(candidates.len());
    for c in candidates {
        match out.last_mut() {
            Some(last) if !last.certain && !c.certain && c.lo <= last.hi => {
                last.hi = last.hi.max(c.hi);
                if score(c.u) < score(last.u) {
                    last.u = c.u;
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// The root in [0, 1] of a monotone Bernstein polynomial whose end values differ in sign.
fn bisect(g: &[f64]) -> f64 {
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let neg_at_a = g[0] < 0.0;
    for _ in 0..64 {
        let m = 0.5 * (a + b);
        if m <= a || m >= b {
            break;
        }
        let v = bernstein_value(g, m);
        if v == 0.0 {
            return m;
        }
        if (v < 0.0) == neg_at_a {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// The ray (rebased at p) as the polishing step sees it.
struct LocalRay {
    p: DVec3,
    d: DVec3,
}

impl LocalRay {
    /// Distance from the ray point at t to the circle of profile point (x, y): the distance to
    /// the surface point S(u, θ) in the ray point's own half-plane.
    fn residual(&self, x: f64, y: f64, t: f64) -> f64 {
        let q = self.p + self.d * t;
        let r = (q.x * q.x + q.z * q.z).sqrt();
        (r - x.abs()).hypot(q.y - y)
    }

    /// The ray parameters where the ray's horizontal projection is at distance |x| from the
    /// axis (none, one for a tangent within rounding, or two).
    fn circle(&self, x: f64) -> Vec<f64> {
        let (p, d) = (self.p, self.d);
        let a = d.x * d.x + d.z * d.z;
        if a == 0.0 {
            return Vec::new();
        }
        let b = p.x * d.x + p.z * d.z; // half of the usual b
        let c = p.x * p.x + p.z * p.z - x * x;
        let disc = b * b - a * c;
        let scale = b * b + (a * c).abs();
        if disc < -1e-12 * scale {
            return Vec::new();
        }
        let root = disc.max(0.0).sqrt();
        if root == 0.0 {
            return vec![-b / a];
        }
        // Stable form: q = −(b + sign(b) √disc); t = q/a and c/q.
        let q = -(b + b.signum() * root);
        if q == 0.0 {
            return vec![-b / a];
        }
        vec![q / a, c / q]
    }

    /// Newton's method on (y(u) − q_y(t), x(u)² − r(t)²) from (u, t), u kept in [lo, hi]; returns
    /// the best (u, t, residual) seen.
    fn polish(&self, seg: &Segment, u: f64, t: f64, lo: f64, hi: f64) -> (f64, f64, f64) {
        let (x, y, _, _) = seg.eval(u);
        let mut best = (u, t, self.residual(x, y, t));
        let (mut u, mut t) = (u, t);
        for _ in 0..32 {
            let (x, y, dx, dy) = seg.eval(u);
            let q = self.p + self.d * t;
            let e1 = y - q.y;
            let e2 = x * x - (q.x * q.x + q.z * q.z);
            let (j11, j12) = (dy, -self.d.y);
            let (j21, j22) = (2.0 * x * dx, -2.0 * (q.x * self.d.x + q.z * self.d.z));
            let det = j11 * j22 - j12 * j21;
            if det == 0.0 || !det.is_finite() {
                break;
            }
            let du = (-e1 * j22 + j12 * e2) / det;
            let dt = (-j11 * e2 + j21 * e1) / det;
            // Damped: halve the step until the residual drops (near a graze the quadratic
            // model is poor).
            let mut improved = false;
            let mut step = 1.0;
            for _ in 0..10 {
                let (nu, nt) = ((u + step * du).clamp(lo, hi), t + step * dt);
                if nt.is_finite() {
                    let (nx, ny, _, _) = seg.eval(nu);
                    let res = self.residual(nx, ny, nt);
                    if res < best.2 {
                        best = (nu, nt, res);
                        (u, t) = (nu, nt);
                        improved = true;
                        break;
                    }
                }
                step *= 0.5;
            }
            if !improved {
                break;
            }
        }
        best
    }
}

/// All hits t ∈ (t_min, t_max) of the ray o + t d with the surface of revolution of `curve`, in
/// increasing t (see the module documentation for the method). Hits closer together than
/// 1e-9 · scale along the ray (a graze, a joint between segments) are reported once. A ray that
/// runs inside the surface along a stretch (a vertical ray on a cylinder's wall) gives one hit
/// somewhere on that stretch. Invalid input (a curve [`Curve::new`] would refuse, non-finite o or
/// d, d = 0, t_min ≥ t_max) gives no hits, as do coordinates so large that the squares overflow.
pub fn intersect_reference(
    curve: &Curve,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Vec<RevHit> {
    let mut hits: Vec<(RevHit, f64)> = Vec::new();
    let dn = d.length();
    if Curve::new(curve.kind, curve.controls.clone()).is_err()
        || !o.is_finite()
        || !d.is_finite()
        || dn == 0.0
        || t_min.is_nan()
        || t_max.is_nan()
        || t_min >= t_max
    {
        return Vec::new();
    }
    let scale = curve
        .controls
        .iter()
        .fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()));
    if scale == 0.0 {
        return Vec::new();
    }
    let tolerance = HIT_TOLERANCE * scale;
    let pad = DVec3::splat(1e-9 * scale);
    let horizontal = d.y.abs() < HORIZONTAL_THRESHOLD * dn;
    let pieces = curve.bezier_segments();
    let count = pieces.len() as f64;
    for (k, points) in pieces.iter().enumerate() {
        let Some(seg) = Segment::new(points) else {
            continue;
        };
        let mut bounds = revolution_box(points);
        bounds.lo -= pad;
        bounds.hi += pad;
        let Some((ta, tb)) = bounds.clip_ray(o, d, t_min, t_max) else {
            continue;
        };
        // Rebase the ray at the segment box's entry for better-conditioned coefficients.
        let ray = LocalRay { p: o + d * ta, d };
        let target = if horizontal {
            Target::Height(ray.p.y + d.y * 0.5 * (tb - ta))
        } else {
            Target::Revolution { p: ray.p, d }
        };
        let mut candidates = Vec::new();
        let mut budget = NODE_BUDGET;
        isolate(&target, &seg, 0.0, 1.0, 0, &mut candidates, &mut budget);
        // Where polishing starts for a root at u: the ray parameter(s) and how well the best
        // fits. Not nearly horizontal: one hit per root of G, its t from the height, or from
        // the circle points where d_y is small; the start that fits best. Nearly horizontal:
        // both circle points are hits at this height.
        let starts = |u: f64| -> (Vec<f64>, f64) {
            let (x, y, _, _) = seg.eval(u);
            let mut starts = ray.circle(x);
            if !horizontal {
                starts.push((y - ray.p.y) / d.y);
            }
            let fit = |t: f64| ray.residual(x, y, t);
            let best = starts
                .iter()
                .copied()
                .min_by(|&a, &b| fit(a).total_cmp(&fit(b)));
            let best_fit = best.map_or(f64::INFINITY, fit);
            if !horizontal {
                starts = best.into_iter().collect();
            }
            (starts, best_fit)
        };
        for cand in merge_runs(candidates, |u| starts(u).1) {
            let (starts, _) = starts(cand.u);
            // Polishing stays within the piece that isolated the root (a little around it when
            // the root was not proved by a sign change).
            let (lo, hi) = if cand.certain {
                (cand.lo, cand.hi)
            } else {
                let w = cand.hi - cand.lo;
                ((cand.lo - w).max(0.0), (cand.hi + w).min(1.0))
            };
            for t_start in starts {
                let (u, t_local, res) = ray.polish(&seg, cand.u, t_start, lo, hi);
                // A root proved by a sign change is kept unless polishing went badly wrong;
                // others must reach the tolerance.
                let limit = if cand.certain {
                    10.0 * tolerance
                } else {
                    tolerance
                };
                let t = ta + t_local;
                let keep = res <= limit && t > t_min && t < t_max;
                if !keep {
                    continue;
                }
                hits.push((hit_at(&seg, u, (k as f64 + u) / count, t, o + d * t), res));
            }
        }
    }
    hits.sort_by(|a, b| a.0.t.total_cmp(&b.0.t));
    let merge = 1e-9 * scale / dn;
    let mut out: Vec<(RevHit, f64)> = Vec::with_capacity(hits.len());
    for (hit, res) in hits {
        match out.last_mut() {
            Some(last) if hit.t - last.0.t <= merge => {
                if res < last.1 {
                    *last = (hit, res);
                }
            }
            _ => out.push((hit, res)),
        }
    }
    out.into_iter().map(|(h, _)| h).collect()
}

/// The hit record at segment parameter u (curve parameter s), ray parameter t, ray point q.
fn hit_at(seg: &Segment, u: f64, s: f64, t: f64, q: DVec3) -> RevHit {
    let (x, _, mut dx, mut dy) = seg.eval(u);
    let sign = if x < 0.0 { -1.0 } else { 1.0 };
    let theta = if q.x == 0.0 && q.z == 0.0 {
        0.0
    } else {
        (sign * q.z).atan2(sign * q.x)
    };
    let length2 = dx * dx + dy * dy;
    if length2.is_nan() || length2 == 0.0 {
        // A stationary point of the parametrisation: the chord around it.
        let (a, b) = ((u - 1e-6).max(0.0), (u + 1e-6).min(1.0));
        let (xa, ya, _, _) = seg.eval(a);
        let (xb, yb, _, _) = seg.eval(b);
        (dx, dy) = (xb - xa, yb - ya);
    }
    let (sin, cos) = theta.sin_cos();
    let n = DVec3::new(dy * cos, -dx, dy * sin);
    let normal = n.try_normalize().unwrap_or(DVec3::Y);
    RevHit {
        t,
        s: s.clamp(0.0, 1.0),
        theta,
        normal,
    }
}
