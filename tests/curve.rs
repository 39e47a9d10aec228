//! Profile curves and the reference ray/surface-of-revolution intersection
//! (`clpt::scene::curve`).
//!
//! - Evaluation against bases written out here: Bernstein polynomials for Bézier curves of degree
//!   1 to 7, Cox–de Boor recursion on the uniform knots for B-splines of 4 to 12 points, and
//!   derivatives against central differences. The B-spline basis sums to one on [t_3, t_m] only
//!   and falls short outside, which is why `eval` maps s onto that range and clamps s.
//! - Bézier segments reproduce `eval`, and a B-spline's segments join with C2 continuity.
//! - `intersect_reference` against closed forms (cylinders and cones from straight profiles,
//!   1e4 rays each: random, along and parallel to the axis, horizontal and nearly horizontal,
//!   grazing, starting inside, clipped to random [t_min, t_max]).
//! - On the original goblet (case3_wineglass's B-spline) and vase (scene08_core's Bézier), every
//!   hit lies on the surface, and the hits are checked against two brute-force scans that do not
//!   share the reference's root isolation:
//!   * G-scan: G(s) = |d_y o_h + d_h (y(s) − o_y)|² − d_y² x(s)², the reduced function, sampled
//!     on a fine grid of s with `eval`; every sign change (a root, by the intermediate value
//!     theorem) whose ray parameter lies inside the ray's range must have a reported hit in its
//!     grid cell (rays with |d_y| > 0.05 |d|, where the scan itself is well conditioned);
//!   * parity (goblet only: its profile starts and ends on the axis, so the surface is closed):
//!     a point is inside when a horizontal half-line in its (r, y) half-plane, from the point away
//!     from the axis, crosses the profile an odd number of times (roots of y(s) = height by
//!     bisection on the pieces where y is monotone, local extrema of y found first so that two
//!     roots near a rim's top cannot hide in one grid cell). Along a ray from outside the box,
//!     the inside test at 1/4, 1/2 and 3/4 of every gap between hits must read outside, inside,
//!     outside, ..., each hit flipping it, ending outside. Hits closer than 1e-6 · scale along
//!     the ray (a graze, finer than the check resolves) form a cluster whose effect is read from
//!     the samples after it. This holds for every direction, horizontal ones included.
//! - The goblet's hard cases under the parity check: horizontal and nearly horizontal rays
//!   (tilts 0 to 1e-2, around the horizontal threshold), rays in the tangent plane of a random
//!   surface point moved off it by ±1e-4 to ±1e-8 of the scale (or not at all), rays at the
//!   height of the rim's top ± 0 to 1e-3 with tilts 0 to 1e-4, and rays along or near the axis
//!   through the two poles.
//! - 1e5 goblet rays timed.

mod common;

use clpt::scene::curve::{Curve, CurveKind};
use common::curve_reference::{HORIZONTAL_THRESHOLD, RevHit, intersect_reference, revolve};
use glam::{DVec2, DVec3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::time::Instant;

/// scene08_core.txt's BezierCurve.
const VASE: [[f64; 2]; 4] = [[-2.0, 2.0], [-4.0, 0.0], [0.0, 0.0], [-2.0, -2.0]];

fn points(p: &[[f64; 2]]) -> Vec<DVec2> {
    p.iter().map(|&[x, y]| DVec2::new(x, y)).collect()
}

fn goblet() -> Curve {
    Curve::new(CurveKind::BSpline, points(&common::GOBLET)).expect("goblet")
}

fn vase() -> Curve {
    Curve::new(CurveKind::Bezier, points(&VASE)).expect("vase")
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// B_i^n(s) = C(n, i) s^i (1 − s)^(n − i).
fn bernstein(n: usize, i: usize, s: f64) -> f64 {
    binomial(n, i) * s.powi(i as i32) * (1.0 - s).powi((n - i) as i32)
}

/// Cox–de Boor: N_{i,p}(t) on `knots` (half-open spans, 0/0 = 0).
fn cox_de_boor(i: usize, p: usize, t: f64, knots: &[f64]) -> f64 {
    if p == 0 {
        return if knots[i] <= t && t < knots[i + 1] {
            1.0
        } else {
            0.0
        };
    }
    let mut v = 0.0;
    let a = knots[i + p] - knots[i];
    if a > 0.0 {
        v += (t - knots[i]) / a * cox_de_boor(i, p - 1, t, knots);
    }
    let b = knots[i + p + 1] - knots[i + 1];
    if b > 0.0 {
        v += (knots[i + p + 1] - t) / b * cox_de_boor(i + 1, p - 1, t, knots);
    }
    v
}

fn uniform_knots(m: usize) -> Vec<f64> {
    (0..m + 4).map(|i| i as f64 / (m + 3) as f64).collect()
}

fn random_points(rng: &mut SmallRng, n: usize) -> Vec<DVec2> {
    (0..n)
        .map(|_| DVec2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)))
        .collect()
}

fn unit(rng: &mut SmallRng) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    }
}

fn scale_of(curve: &Curve) -> f64 {
    curve
        .controls
        .iter()
        .fold(0.0f64, |m, p| m.max(p.x.abs()).max(p.y.abs()))
}

/// |o + t d − S(s, θ)| for a hit, with S from `eval`.
fn residual(curve: &Curve, o: DVec3, d: DVec3, h: &RevHit) -> f64 {
    (o + d * h.t - revolve(curve.eval(h.s).0, h.theta)).length()
}

#[test]
fn new_checks_counts_and_finiteness() {
    let p = |n: usize| vec![DVec2::new(1.0, 0.0); n];
    for n in 0..12 {
        let ok = (2..=8).contains(&n);
        let r = Curve::new(CurveKind::Bezier, p(n));
        assert_eq!(r.is_ok(), ok, "Bezier with {n} points");
        if let Err(e) = r {
            assert!(e.contains("Bezier") && e.contains(&n.to_string()), "{e}");
        }
        let r = Curve::new(CurveKind::BSpline, p(n));
        assert_eq!(r.is_ok(), n >= 4, "B-spline with {n} points");
        if let Err(e) = r {
            assert!(e.contains("B-spline") && e.contains(&n.to_string()), "{e}");
        }
    }
    let mut bad = p(4);
    bad[2].y = f64::NAN;
    let e = Curve::new(CurveKind::BSpline, bad).unwrap_err();
    assert!(
        e.contains("control point 2") && e.contains("not finite"),
        "{e}"
    );
    let mut bad = p(3);
    bad[0].x = f64::INFINITY;
    assert!(Curve::new(CurveKind::Bezier, bad).is_err());
    assert_eq!(Curve::new(CurveKind::Bezier, p(6)).unwrap().degree(), 5);
    assert_eq!(Curve::new(CurveKind::BSpline, p(9)).unwrap().degree(), 3);
}

#[test]
fn bezier_eval_matches_bernstein_basis_and_finite_differences() {
    let mut rng = SmallRng::seed_from_u64(1);
    for n in 1..=7 {
        for _ in 0..50 {
            let controls = random_points(&mut rng, n + 1);
            let curve = Curve::new(CurveKind::Bezier, controls.clone()).unwrap();
            for _ in 0..40 {
                let s: f64 = rng.random();
                let sum: f64 = (0..=n).map(|i| bernstein(n, i, s)).sum();
                assert!((sum - 1.0).abs() < 1e-14, "partition of unity {sum}");
                assert!((0..=n).all(|i| bernstein(n, i, s) >= 0.0));
                let direct: DVec2 = (0..=n).map(|i| controls[i] * bernstein(n, i, s)).sum();
                let (p, _) = curve.eval(s);
                assert!(
                    (p - direct).length() < 1e-13,
                    "n {n} s {s}: {p} vs {direct}"
                );
                let h = 1e-5;
                let s = s.clamp(h, 1.0 - h);
                let fd = (curve.eval(s + h).0 - curve.eval(s - h).0) / (2.0 * h);
                let dp_s = curve.eval(s).1;
                assert!(
                    (dp_s - fd).length() <= 1e-6 * dp_s.length().max(1.0),
                    "n {n} s {s}: {dp_s} vs {fd}"
                );
            }
            // Ends interpolate, and the end tangents are n (P1 − P0), n (Pn − Pn−1).
            let (p0, d0) = curve.eval(0.0);
            let (p1, d1) = curve.eval(1.0);
            assert_eq!(p0, controls[0]);
            assert!((p1 - controls[n]).length() < 1e-15);
            assert!((d0 - (controls[1] - controls[0]) * n as f64).length() < 1e-13);
            assert!((d1 - (controls[n] - controls[n - 1]) * n as f64).length() < 1e-13);
            // s is clamped.
            assert_eq!(curve.eval(-0.5), curve.eval(0.0));
            assert_eq!(curve.eval(1.5), curve.eval(1.0));
        }
    }
}

#[test]
fn bspline_eval_matches_cox_de_boor_on_the_valid_range_only() {
    let mut rng = SmallRng::seed_from_u64(2);
    for m in 4..=12 {
        let knots = uniform_knots(m);
        let (t3, tm) = (knots[3], knots[m]);
        for _ in 0..30 {
            let controls = random_points(&mut rng, m);
            let curve = Curve::new(CurveKind::BSpline, controls.clone()).unwrap();
            for _ in 0..40 {
                let s: f64 = rng.random();
                let t = t3 + s * (tm - t3);
                let basis: Vec<f64> = (0..m).map(|i| cox_de_boor(i, 3, t, &knots)).collect();
                let sum: f64 = basis.iter().sum();
                assert!((sum - 1.0).abs() < 1e-13, "m {m} t {t}: sum {sum}");
                let direct: DVec2 = (0..m).map(|i| controls[i] * basis[i]).sum();
                let (p, _) = curve.eval(s);
                assert!(
                    (p - direct).length() < 1e-13,
                    "m {m} s {s}: {p} vs {direct}"
                );
                let h = 1e-5;
                let s = s.clamp(h, 1.0 - h);
                let fd = (curve.eval(s + h).0 - curve.eval(s - h).0) / (2.0 * h);
                let dp = curve.eval(s).1;
                assert!(
                    (dp - fd).length() <= 1e-6 * dp.length().max(1.0),
                    "m {m} s {s}: {dp} vs {fd}"
                );
            }
            // Outside [t_3, t_m] the basis no longer sums to one: the original's spindles. (The
            // shortfall grows as the cube of the distance, so stay a tenth of a span away.)
            let span = 1.0 / (m + 3) as f64;
            for _ in 0..20 {
                let t = if rng.random::<bool>() {
                    rng.random_range(0.0..t3 - 0.1 * span)
                } else {
                    rng.random_range(tm + 0.1 * span..1.0)
                };
                let sum: f64 = (0..m).map(|i| cox_de_boor(i, 3, t, &knots)).sum();
                assert!(
                    sum < 1.0 - 1e-4,
                    "m {m} t {t}: sum {sum} outside the valid range"
                );
            }
            // eval clamps s, so it never leaves the valid range; the ends are the B-spline's
            // end points (P0 + 4 P1 + P2)/6 and (Pm−3 + 4 Pm−2 + Pm−1)/6.
            assert_eq!(curve.eval(-0.25), curve.eval(0.0));
            assert_eq!(curve.eval(1.25), curve.eval(1.0));
            let c = &controls;
            let start = (c[0] + 4.0 * c[1] + c[2]) / 6.0;
            let end = (c[m - 3] + 4.0 * c[m - 2] + c[m - 1]) / 6.0;
            assert!((curve.eval(0.0).0 - start).length() < 1e-14);
            assert!((curve.eval(1.0).0 - end).length() < 1e-14);
        }
    }
}

/// Point, first and second derivative of a Bézier segment at u (from the basis directly).
fn bezier_d2(c: &[DVec2], u: f64) -> (DVec2, DVec2, DVec2) {
    let n = c.len() - 1;
    let p = (0..=n).map(|i| c[i] * bernstein(n, i, u)).sum();
    let d1 = (0..n)
        .map(|i| (c[i + 1] - c[i]) * (n as f64 * bernstein(n - 1, i, u)))
        .sum();
    let d2 = if n >= 2 {
        (0..n - 1)
            .map(|i| {
                (c[i + 2] - 2.0 * c[i + 1] + c[i]) * ((n * (n - 1)) as f64 * bernstein(n - 2, i, u))
            })
            .sum()
    } else {
        DVec2::ZERO
    };
    (p, d1, d2)
}

#[test]
fn segments_reproduce_eval_and_join_c2() {
    let mut rng = SmallRng::seed_from_u64(3);
    let mut curves = Vec::new();
    for n in 1..=7 {
        for _ in 0..20 {
            let c = random_points(&mut rng, n + 1);
            curves.push(Curve::new(CurveKind::Bezier, c).unwrap());
        }
    }
    for m in 4..=12 {
        for _ in 0..20 {
            let c = random_points(&mut rng, m);
            curves.push(Curve::new(CurveKind::BSpline, c).unwrap());
        }
    }
    curves.push(goblet());
    curves.push(vase());
    for curve in &curves {
        let segs = curve.bezier_segments();
        let k = segs.len();
        match curve.kind {
            CurveKind::Bezier => assert_eq!(k, 1),
            CurveKind::BSpline => assert_eq!(k, curve.controls.len() - 3),
        }
        assert!(segs.iter().all(|s| s.len() == curve.degree() + 1));
        for _ in 0..200 {
            let s: f64 = rng.random();
            let j = ((s * k as f64) as usize).min(k - 1);
            let u = s * k as f64 - j as f64;
            let (p, d1, _) = bezier_d2(&segs[j], u);
            let (q, dq) = curve.eval(s);
            assert!(
                (p - q).length() < 1e-12,
                "{:?} s {s}: {p} vs {q}",
                curve.kind
            );
            // The segment parameter runs k times faster than s.
            assert!((d1 - dq / k as f64).length() < 1e-11 * dq.length().max(1.0));
        }
        for j in 1..k {
            let (p0, a0, b0) = bezier_d2(&segs[j - 1], 1.0);
            let (p1, a1, b1) = bezier_d2(&segs[j], 0.0);
            assert!((p0 - p1).length() < 1e-14, "C0 at joint {j}");
            assert!((a0 - a1).length() < 1e-13, "C1 at joint {j}");
            assert!((b0 - b1).length() < 1e-12, "C2 at joint {j}");
        }
    }
}

#[test]
fn revolution_bounds_hold_the_surface() {
    let mut rng = SmallRng::seed_from_u64(4);
    for curve in [goblet(), vase()] {
        let b = curve.revolution_bounds();
        let r = curve.controls.iter().fold(0.0f64, |m, p| m.max(p.x.abs()));
        assert_eq!(b.hi.x, r);
        assert_eq!(b.lo.z, -r);
        for _ in 0..10_000 {
            let s: f64 = rng.random();
            let th = rng.random_range(-3.2..3.2);
            let p = revolve(curve.eval(s).0, th);
            assert!(
                b.lo.cmple(p).all() && b.hi.cmpge(p).all(),
                "{p} outside {b:?}"
            );
        }
    }
}

/// Roots in ascending order of a t² + b t + c (a ≠ 0), real ones only.
fn quadratic(a: f64, b: f64, c: f64) -> Vec<f64> {
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return Vec::new();
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let mut r = if q == 0.0 {
        vec![-b / (2.0 * a)]
    } else {
        vec![q / a, c / q]
    };
    r.sort_by(f64::total_cmp);
    r
}

/// A ray for the straight-profile tests, the profile spanning y in [−1, 1], radius ≤ 1.
struct Ray {
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
    /// Ambiguous by construction (exact tangent): the count is not checked.
    tangent: bool,
}

fn straight_rays(rng: &mut SmallRng, count: usize) -> Vec<Ray> {
    let mut rays = Vec::with_capacity(count);
    for i in 0..count {
        let len = rng.random_range(0.2..5.0);
        let mut ray = Ray {
            o: DVec3::ZERO,
            d: DVec3::Y,
            t_min: 0.0,
            t_max: f64::INFINITY,
            tangent: false,
        };
        match i % 8 {
            // From outside towards a random point in a slightly larger box.
            0 | 1 => {
                ray.o = unit(rng) * 4.0;
                let target = DVec3::new(
                    rng.random_range(-1.3..1.3),
                    rng.random_range(-1.3..1.3),
                    rng.random_range(-1.3..1.3),
                );
                ray.d = (target - ray.o).normalize() * len;
            }
            // Along the axis or parallel to it.
            2 => {
                let r = [0.0, 0.3, 0.999, 1.001, 2.0][rng.random_range(0..5)];
                let a = rng.random_range(-3.2..3.2f64);
                let up = rng.random::<bool>();
                ray.o = DVec3::new(r * a.cos(), if up { -3.0 } else { 3.0 }, r * a.sin());
                ray.d = DVec3::new(0.0, if up { len } else { -len }, 0.0);
            }
            // Horizontal.
            3 => {
                let a = rng.random_range(-3.2..3.2f64);
                ray.o = DVec3::new(3.0 * a.cos(), rng.random_range(-0.99..0.99), 3.0 * a.sin());
                let target = DVec3::new(
                    rng.random_range(-1.2..1.2),
                    0.0,
                    rng.random_range(-1.2..1.2),
                );
                let h = DVec3::new(target.x - ray.o.x, 0.0, target.z - ray.o.z);
                ray.d = h.normalize() * len;
            }
            // Nearly horizontal, around the threshold.
            4 => {
                let a = rng.random_range(-3.2..3.2f64);
                ray.o = DVec3::new(3.0 * a.cos(), rng.random_range(-0.9..0.9), 3.0 * a.sin());
                let target = DVec3::new(
                    rng.random_range(-1.2..1.2),
                    0.0,
                    rng.random_range(-1.2..1.2),
                );
                let h = DVec3::new(target.x - ray.o.x, 0.0, target.z - ray.o.z).normalize();
                let near = [0.5, 0.99, 1.01, 2.0].map(|f| f * HORIZONTAL_THRESHOLD);
                let tilt = [
                    1e-13, 1e-11, near[0], near[1], near[2], near[3], 1e-7, 1e-5, 1e-3,
                ][rng.random_range(0..9)]
                    * if rng.random::<bool>() { 1.0 } else { -1.0 };
                ray.d = (h + DVec3::Y * tilt) * len;
            }
            // Grazing: the horizontal projection passes at 1 ± δ from the axis (exactly 1:
            // tangent, ambiguous).
            5 => {
                let a = rng.random_range(-3.2..3.2f64);
                let (radial, along) = (
                    DVec3::new(a.cos(), 0.0, a.sin()),
                    DVec3::new(-a.sin(), 0.0, a.cos()),
                );
                let delta = [0.0, 1e-6, -1e-6, 1e-4, -1e-4][rng.random_range(0..5)];
                ray.tangent = delta == 0.0;
                let y = rng.random_range(-0.9..0.9);
                ray.o = radial * (1.0 + delta) - along * 3.0 + DVec3::Y * y;
                ray.d = (along + DVec3::Y * rng.random_range(-0.2..0.2)) * len;
            }
            // Starting inside the box.
            6 => {
                ray.o = DVec3::new(
                    rng.random_range(-0.9..0.9),
                    rng.random_range(-0.9..0.9),
                    rng.random_range(-0.9..0.9),
                );
                ray.d = unit(rng) * len;
            }
            // Random window [t_min, t_max].
            _ => {
                ray.o = unit(rng) * 4.0;
                let target = DVec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                ray.d = (target - ray.o).normalize() * len;
                let a = rng.random_range(0.0..8.0) / len;
                let b = rng.random_range(0.0..8.0) / len;
                (ray.t_min, ray.t_max) = (a.min(b), a.max(b));
            }
        }
        rays.push(ray);
    }
    rays
}

/// Compares the reference with closed-form hits (`expected`, ascending) on one ray; returns
/// whether the ray was skipped as ambiguous (a closed-form hit within `margin` of a rim or of
/// the ray's ends).
fn compare(curve: &Curve, ray: &Ray, expected: &[f64], what: &str, ambiguous: bool) -> bool {
    let hits = intersect_reference(curve, ray.o, ray.d, ray.t_min, ray.t_max);
    let scale = scale_of(curve);
    for h in &hits {
        let r = residual(curve, ray.o, ray.d, h);
        assert!(r < 1e-9 * scale, "{what}: residual {r} at {h:?}");
        assert!(h.t > ray.t_min && h.t < ray.t_max);
    }
    assert!(hits.windows(2).all(|w| w[0].t < w[1].t));
    if ambiguous || ray.tangent {
        assert!(
            hits.len() <= 2,
            "{what}: {} hits on a tangent ray",
            hits.len()
        );
        return true;
    }
    let got: Vec<f64> = hits.iter().map(|h| h.t).collect();
    assert_eq!(
        got.len(),
        expected.len(),
        "{what}: o {} d {} [{}, {}]: got {got:?}, expected {expected:?}",
        ray.o,
        ray.d,
        ray.t_min,
        ray.t_max
    );
    for (g, e) in got.iter().zip(expected) {
        assert!(
            (g - e).abs() * ray.d.length() < 1e-9,
            "{what}: o {} d {}: got {got:?}, expected {expected:?}",
            ray.o,
            ray.d
        );
    }
    false
}

#[test]
fn cylinders_match_the_closed_form() {
    let mut rng = SmallRng::seed_from_u64(5);
    let rays = straight_rays(&mut rng, 10_000);
    let profiles: [(&str, CurveKind, Vec<DVec2>); 4] = [
        (
            "line up",
            CurveKind::Bezier,
            points(&[[1.0, -1.0], [1.0, 1.0]]),
        ),
        (
            "line down, x < 0",
            CurveKind::Bezier,
            points(&[[-1.0, 1.0], [-1.0, -1.0]]),
        ),
        (
            "cubic, uneven",
            CurveKind::Bezier,
            points(&[[1.0, -1.0], [1.0, -0.2], [1.0, 0.7], [1.0, 1.0]]),
        ),
        (
            "B-spline",
            CurveKind::BSpline,
            points(&[[1.0, -3.0], [1.0, -1.0], [1.0, 0.0], [1.0, 1.0], [1.0, 3.0]]),
        ),
    ];
    for (name, kind, controls) in profiles {
        let curve = Curve::new(kind, controls).unwrap();
        let (ylo, yhi) = (
            curve.eval(0.0).0.y.min(curve.eval(1.0).0.y),
            curve.eval(0.0).0.y.max(curve.eval(1.0).0.y),
        );
        let mut skipped = 0;
        for ray in &rays {
            let (o, d) = (ray.o, ray.d);
            let a = d.x * d.x + d.z * d.z;
            let mut ambiguous = false;
            let mut expected = Vec::new();
            if a > 0.0 {
                for t in quadratic(
                    a,
                    2.0 * (o.x * d.x + o.z * d.z),
                    o.x * o.x + o.z * o.z - 1.0,
                ) {
                    let y = o.y + t * d.y;
                    let near_end = (t - ray.t_min).abs() < 1e-7 || (t - ray.t_max).abs() < 1e-7;
                    if (y - ylo).abs() < 1e-7 || (y - yhi).abs() < 1e-7 || near_end {
                        ambiguous = true;
                    }
                    if y > ylo && y < yhi && t > ray.t_min && t < ray.t_max {
                        expected.push(t);
                    }
                }
            } else {
                // Parallel to the axis: on the wall only when at radius 1 exactly (not drawn).
                let r = (o.x * o.x + o.z * o.z).sqrt();
                ambiguous = (r - 1.0).abs() < 1e-12;
            }
            if compare(&curve, ray, &expected, name, ambiguous) {
                skipped += 1;
            }
        }
        println!("cylinder {name}: {} rays, {skipped} ambiguous", rays.len());
        assert!(skipped < rays.len() / 10);
    }
}

#[test]
fn cones_match_the_closed_form() {
    let mut rng = SmallRng::seed_from_u64(6);
    let rays = straight_rays(&mut rng, 10_000);
    // The cone r = (1 − y)/2, y in [−1, 1], apex (0, 1), from profiles in either direction and
    // on either side of the axis.
    let profiles: [(&str, Vec<DVec2>); 3] = [
        ("apex first", points(&[[0.0, 1.0], [1.0, -1.0]])),
        ("base first", points(&[[1.0, -1.0], [0.0, 1.0]])),
        (
            "x < 0, quadratic",
            points(&[[0.0, 1.0], [-0.5, 0.0], [-1.0, -1.0]]),
        ),
    ];
    for (name, controls) in profiles {
        let curve = Curve::new(CurveKind::Bezier, controls).unwrap();
        let mut skipped = 0;
        let mut apex = 0;
        for ray in &rays {
            let (o, d) = (ray.o, ray.d);
            let a = d.x * d.x + d.z * d.z - d.y * d.y / 4.0;
            let b = 2.0 * (o.x * d.x + o.z * d.z) + (1.0 - o.y) * d.y / 2.0;
            let c = o.x * o.x + o.z * o.z - (1.0 - o.y) * (1.0 - o.y) / 4.0;
            let mut ambiguous = false;
            let mut expected = Vec::new();
            let on_axis = o.x == 0.0 && o.z == 0.0 && d.x == 0.0 && d.z == 0.0;
            let roots = if on_axis {
                // Along the axis: the apex only.
                apex += 1;
                vec![(1.0 - o.y) / d.y]
            } else if a.abs() < 1e-6 * d.length_squared() {
                // Parallel to a generator.
                ambiguous = true;
                Vec::new()
            } else {
                let disc = b * b - 4.0 * a * c;
                if disc.abs() < 1e-9 * (b * b + (4.0 * a * c).abs()) {
                    ambiguous = true;
                }
                quadratic(a, b, c)
            };
            for t in roots {
                let y = if on_axis { 1.0 } else { o.y + t * d.y };
                let near_end = (t - ray.t_min).abs() < 1e-7 || (t - ray.t_max).abs() < 1e-7;
                if (y + 1.0).abs() < 1e-7 || (y - 1.0).abs() < 1e-7 && !on_axis || near_end {
                    ambiguous = true;
                }
                if (-1.0..=1.0).contains(&y) && t > ray.t_min && t < ray.t_max {
                    expected.push(t);
                }
            }
            if compare(&curve, ray, &expected, name, ambiguous) {
                skipped += 1;
            }
        }
        println!(
            "cone {name}: {} rays ({apex} along the axis), {skipped} ambiguous",
            rays.len()
        );
        assert!(apex > 100);
        assert!(skipped < rays.len() / 10);
    }
}

#[test]
fn normals_are_unit_perpendicular_and_follow_the_profile_rule() {
    let mut rng = SmallRng::seed_from_u64(7);
    // Upwards at x > 0: outwards; downwards: inwards; the rule is the revolved (y', −x').
    let up = Curve::new(CurveKind::Bezier, points(&[[1.0, -1.0], [1.0, 1.0]])).unwrap();
    let down = Curve::new(CurveKind::Bezier, points(&[[1.0, 1.0], [1.0, -1.0]])).unwrap();
    for _ in 0..1000 {
        let o = DVec3::new(0.0, rng.random_range(-0.5..0.5), 0.0) + unit(&mut rng) * 0.1;
        let a = rng.random_range(-3.2..3.2f64);
        let d = DVec3::new(a.cos(), 0.1, a.sin());
        for (curve, outwards) in [(&up, true), (&down, false)] {
            let hits = intersect_reference(curve, o, d, 0.0, f64::INFINITY);
            assert_eq!(hits.len(), 1);
            let p = o + d * hits[0].t;
            let radial = DVec3::new(p.x, 0.0, p.z).normalize();
            let n = hits[0].normal;
            assert!((n - if outwards { radial } else { -radial }).length() < 1e-9);
        }
    }
    for curve in [goblet(), vase()] {
        let b = curve.revolution_bounds();
        for _ in 0..2000 {
            let o = b.center() + unit(&mut rng) * 8.0;
            let target =
                b.lo + (b.hi - b.lo) * DVec3::new(rng.random(), rng.random(), rng.random());
            let d = target - o;
            for h in intersect_reference(&curve, o, d, 0.0, f64::INFINITY) {
                let (p, dp) = curve.eval(h.s);
                let (sin, cos) = h.theta.sin_cos();
                let ds = DVec3::new(dp.x * cos, dp.y, dp.x * sin);
                let dth = DVec3::new(-p.x * sin, 0.0, p.x * cos);
                let n = h.normal;
                assert!((n.length() - 1.0).abs() < 1e-12);
                assert!(n.dot(ds).abs() < 1e-9 * ds.length());
                assert!(n.dot(dth).abs() < 1e-9 * dth.length().max(1e-300));
                // The revolved right-hand normal of the profile.
                let rule = DVec3::new(dp.y * cos, -dp.x, dp.y * sin).normalize();
                assert!((n - rule).length() < 1e-9);
                // ±(∂S/∂s × ∂S/∂θ), + where x > 0.
                let cross = ds.cross(dth);
                if cross.length() > 1e-9 {
                    assert!((n - cross.normalize() * p.x.signum()).length() < 1e-9);
                }
            }
        }
    }
}

fn bisect(g: &dyn Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let neg = g(a) < 0.0;
    for _ in 0..80 {
        let m = 0.5 * (a + b);
        if (g(m) < 0.0) == neg {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// Knots (s, y(s)) cutting [0, 1] into pieces on which y is monotone: a grid of `n` cells
/// refined at the local extrema of y (where y' changes sign, found by bisection on y'). The
/// extrema keep two roots of y(s) = h near a rim's top from hiding in one cell.
fn monotone_knots(curve: &Curve, n: usize) -> Vec<(f64, f64)> {
    let dy = |s: f64| curve.eval(s).1.y;
    let mut knots = vec![0.0];
    for i in 1..=n {
        let (a, b) = ((i - 1) as f64 / n as f64, i as f64 / n as f64);
        if (dy(a) < 0.0) != (dy(b) < 0.0) {
            knots.push(bisect(&dy, a, b));
        }
        knots.push(b);
    }
    knots.into_iter().map(|s| (s, curve.eval(s).0.y)).collect()
}

/// Roots s of y(s) = height, by bisection on each monotone piece it crosses.
fn height_roots(curve: &Curve, knots: &[(f64, f64)], height: f64) -> Vec<f64> {
    let f = |s: f64| curve.eval(s).0.y - height;
    let mut roots = Vec::new();
    for w in knots.windows(2) {
        let ((sa, ya), (sb, yb)) = (w[0], w[1]);
        let (fa, fb) = (ya - height, yb - height);
        if fa == 0.0 {
            roots.push(sa);
        } else if fb != 0.0 && (fa < 0.0) != (fb < 0.0) {
            roots.push(bisect(&f, sa, sb));
        }
    }
    if knots.last().is_some_and(|&(_, y)| y == height) {
        roots.push(1.0);
    }
    roots
}

/// Even-odd inside test for a closed profile (both ends on the axis): crossings of the
/// half-line from (r, y) away from the axis with the profile (in |x|).
fn inside(curve: &Curve, knots: &[(f64, f64)], p: DVec3) -> bool {
    let r = (p.x * p.x + p.z * p.z).sqrt();
    height_roots(curve, knots, p.y)
        .into_iter()
        .filter(|&s| curve.eval(s).0.x.abs() > r)
        .count()
        % 2
        == 1
}

/// G(s) for the ray o + t d (see the module documentation).
fn g_scan(curve: &Curve, o: DVec3, d: DVec3, s: f64) -> (f64, f64) {
    let (p, _) = curve.eval(s);
    let yy = p.y - o.y;
    let a = d.y * o.x + d.x * yy;
    let b = d.y * o.z + d.z * yy;
    let c = d.y * p.x;
    (a * a + b * b - c * c, yy / d.y)
}

struct ScanStats {
    rays: usize,
    hits: usize,
    brackets: usize,
    extra: usize,
    parity_rays: usize,
    clusters: usize,
}

/// Random rays from outside the box at a random point in it; residual, G-scan and (closed
/// profiles) parity checks.
fn check_profile(curve: &Curve, name: &str, closed: bool, rays: usize, seed: u64) -> ScanStats {
    let mut rng = SmallRng::seed_from_u64(seed);
    let b = curve.revolution_bounds();
    let scale = scale_of(curve);
    let radius = 1.5 * (b.hi - b.lo).length();
    let grid = 20_000;
    let knots = if closed {
        monotone_knots(curve, 2000)
    } else {
        Vec::new()
    };
    let mut stats = ScanStats {
        rays: 0,
        hits: 0,
        brackets: 0,
        extra: 0,
        parity_rays: 0,
        clusters: 0,
    };
    for i in 0..rays {
        let o = b.center() + unit(&mut rng) * radius;
        let target = b.lo + (b.hi - b.lo) * DVec3::new(rng.random(), rng.random(), rng.random());
        let d = (target - o) * rng.random_range(0.3..3.0);
        let (t_min, t_max) = if i % 4 == 3 {
            let a: f64 = rng.random_range(0.0..1.5);
            let c: f64 = rng.random_range(0.0..1.5);
            (a.min(c), a.max(c))
        } else {
            (0.0, f64::INFINITY)
        };
        let hits = intersect_reference(curve, o, d, t_min, t_max);
        stats.rays += 1;
        stats.hits += hits.len();
        for h in &hits {
            let r = residual(curve, o, d, h);
            assert!(
                r < 1e-9 * scale,
                "{name}: residual {r} at {h:?}, o {o} d {d}"
            );
            assert!(h.t > t_min && h.t < t_max && (0.0..=1.0).contains(&h.s));
        }
        assert!(hits.windows(2).all(|w| w[0].t < w[1].t));
        if d.y.abs() > 0.05 * d.length() {
            let mut prev = g_scan(curve, o, d, 0.0);
            let mut found = 0;
            for j in 1..=grid {
                let s1 = j as f64 / grid as f64;
                let cur = g_scan(curve, o, d, s1);
                if (prev.0 < 0.0) != (cur.0 < 0.0) && prev.0 != 0.0 && cur.0 != 0.0 {
                    let (tl, th) = (prev.1.min(cur.1), prev.1.max(cur.1));
                    let margin = 1e-6 * (th - tl).abs().max(1e-9);
                    if tl > t_min + margin && th < t_max - margin {
                        found += 1;
                        let s0 = (j - 1) as f64 / grid as f64;
                        assert!(
                            hits.iter().any(|h| h.s >= s0 - 1e-9 && h.s <= s1 + 1e-9),
                            "{name}: missed the root of G in s [{s0}, {s1}] (t ≈ {tl}), o {o} d {d} [{t_min}, {t_max}]: {hits:?}"
                        );
                    }
                }
                prev = cur;
            }
            stats.brackets += found;
            assert!(hits.len() >= found);
            stats.extra += hits.len() - found;
        }
        if closed && t_min == 0.0 && t_max == f64::INFINITY {
            stats.clusters += check_parity(curve, &knots, name, o, d, &hits);
            stats.parity_rays += 1;
        }
    }
    stats
}

/// Parity along a ray starting outside the closed surface's box: the inside test sampled at
/// 1/4, 1/2 and 3/4 of every gap between hits (and before the first, after the last) must say
/// outside, inside, outside, ..., each hit flipping it. Hits closer together along the ray than
/// 1e-6 · scale form a cluster (a graze, below what the check can resolve): the state after
/// a cluster of several is read from the samples, which must agree. Returns the number of such
/// clusters.
fn check_parity(
    curve: &Curve,
    knots: &[(f64, f64)],
    name: &str,
    o: DVec3,
    d: DVec3,
    hits: &[RevHit],
) -> usize {
    let close = 1e-6 * scale_of(curve) / d.length();
    let mut clusters: Vec<&[RevHit]> = Vec::new();
    let mut first = 0;
    for i in 1..=hits.len() {
        if i == hits.len() || hits[i].t - hits[i - 1].t >= close {
            clusters.push(&hits[first..i]);
            first = i;
        }
    }
    let exit = curve
        .revolution_bounds()
        .clip_ray(o, d, 0.0, f64::INFINITY)
        .map_or(1.0, |(_, t1)| t1)
        .max(hits.last().map_or(0.0, |h| h.t))
        + 1e-3;
    let mut state = Some(false);
    let mut gap_start = 0.0;
    let mut multi = 0;
    for j in 0..=clusters.len() {
        let gap_end = clusters.get(j).map_or(exit, |c| c[0].t);
        let samples: Vec<bool> = [0.25, 0.5, 0.75]
            .iter()
            .map(|f| {
                inside(
                    curve,
                    knots,
                    o + d * (gap_start + f * (gap_end - gap_start)),
                )
            })
            .collect();
        let expected = if j == clusters.len() {
            false
        } else {
            state.unwrap_or(samples[1])
        };
        assert!(
            samples.iter().all(|&v| v == expected),
            "{name}: inside {samples:?}, expected {expected} in gap {j} (t {gap_start} .. {gap_end}), o {o} d {d}: {hits:?}"
        );
        if let Some(c) = clusters.get(j) {
            state = if c.len() == 1 {
                Some(!expected)
            } else {
                multi += 1;
                None
            };
            gap_start = c[c.len() - 1].t;
        }
    }
    multi
}

#[test]
fn goblet_hits_lie_on_the_surface_and_match_both_scans() {
    let curve = goblet();
    let st = check_profile(&curve, "goblet", true, 2000, 8);
    println!(
        "goblet: {} rays, {} hits, {} G sign changes matched, {} hits beyond them, {} rays parity-checked ({} graze clusters)",
        st.rays, st.hits, st.brackets, st.extra, st.parity_rays, st.clusters
    );
    assert!(st.brackets > 1000 && st.parity_rays > 1000);
    // Along the axis: the two poles, (0, −0.459544) (inside the bowl) and (0, −2.458801).
    let hits = intersect_reference(
        &curve,
        DVec3::new(0.0, 5.0, 0.0),
        DVec3::NEG_Y,
        0.0,
        f64::INFINITY,
    );
    let ys: Vec<f64> = hits.iter().map(|h| 5.0 - h.t).collect();
    let p0 = curve.eval(0.0).0.y;
    let p1 = curve.eval(1.0).0.y;
    assert_eq!(ys.len(), 2, "{hits:?}");
    assert!(
        (ys[0] - p0).abs() < 1e-9 && (ys[1] - p1).abs() < 1e-9,
        "{ys:?}"
    );
}

#[test]
fn vase_hits_lie_on_the_surface_and_match_the_g_scan() {
    let curve = vase();
    let st = check_profile(&curve, "vase", false, 2000, 9);
    println!(
        "vase: {} rays, {} hits, {} G sign changes matched, {} hits beyond them",
        st.rays, st.hits, st.brackets, st.extra
    );
    assert!(st.brackets > 1000);
}

#[test]
fn horizontal_and_nearly_horizontal_rays_on_the_goblet_keep_parity() {
    let curve = goblet();
    let mut rng = SmallRng::seed_from_u64(10);
    let b = curve.revolution_bounds();
    let scale = scale_of(&curve);
    let tilts = [
        0.0, 1e-15, 1e-12, 1e-10, 0.99e-9, 1.01e-9, 1e-8, 1e-6, 1e-4, 1e-2,
    ];
    let mut total = 0;
    let mut clusters = 0;
    let knots = monotone_knots(&curve, 2000);
    for i in 0..3000 {
        let a = rng.random_range(-3.2..3.2f64);
        let y = rng.random_range(b.lo.y..b.hi.y);
        let o = DVec3::new(4.0 * a.cos(), y, 4.0 * a.sin());
        let target = DVec3::new(rng.random_range(-1.3..1.3), y, rng.random_range(-1.3..1.3));
        let tilt = tilts[i % tilts.len()] * if rng.random::<bool>() { 1.0 } else { -1.0 };
        let d = (target - o).normalize() + DVec3::Y * tilt;
        let hits = intersect_reference(&curve, o, d, 0.0, f64::INFINITY);
        total += hits.len();
        for h in &hits {
            let r = residual(&curve, o, d, h);
            assert!(r < 1e-9 * scale, "residual {r} at {h:?}, o {o} d {d}");
        }
        clusters += check_parity(&curve, &knots, "goblet, horizontal", o, d, &hits);
    }
    println!("goblet, nearly horizontal: 3000 rays, {total} hits, {clusters} graze clusters");
    assert!(total > 3000);
}

#[test]
fn grazing_rays_on_the_goblet_keep_parity() {
    // Rays in the tangent plane of a random surface point, moved off it along the normal by
    // ±1e-4 .. ±1e-8 of the scale (two nearby hits or none), or not at all (a graze: either).
    let curve = goblet();
    let scale = scale_of(&curve);
    let mut rng = SmallRng::seed_from_u64(12);
    let offsets = [1e-4, -1e-4, 1e-6, -1e-6, 1e-8, -1e-8, 0.0];
    let mut total = 0;
    let mut clusters = 0;
    let knots = monotone_knots(&curve, 2000);
    for i in 0..2100 {
        let s: f64 = rng.random();
        let th: f64 = rng.random_range(-3.2..3.2);
        let (p2, dp) = curve.eval(s);
        let (sin, cos) = th.sin_cos();
        let n = DVec3::new(dp.y * cos, -dp.x, dp.y * sin).normalize();
        let a = unit(&mut rng);
        let tangent = (a - n * a.dot(n)).normalize();
        let eps = offsets[i % offsets.len()] * scale;
        let o = revolve(p2, th) + n * eps - tangent * 10.0;
        let hits = intersect_reference(&curve, o, tangent, 0.0, f64::INFINITY);
        total += hits.len();
        for h in &hits {
            let r = residual(&curve, o, tangent, h);
            assert!(r < 1e-9 * scale, "residual {r} at {h:?}, o {o} d {tangent}");
        }
        if eps != 0.0 {
            clusters += check_parity(&curve, &knots, "goblet, grazing", o, tangent, &hits);
        }
    }
    println!("goblet, grazing: 2100 rays, {total} hits, {clusters} graze clusters");
}

#[test]
fn rim_top_and_near_axis_rays_on_the_goblet_keep_parity() {
    let curve = goblet();
    let scale = scale_of(&curve);
    // The rim's top: the highest point of the profile.
    let (mut ymax, mut smax) = (f64::MIN, 0.0);
    for i in 0..=100_000 {
        let s = i as f64 / 100_000.0;
        let y = curve.eval(s).0.y;
        if y > ymax {
            (ymax, smax) = (y, s);
        }
    }
    let (mut a, mut b) = (smax - 1e-5, smax + 1e-5);
    for _ in 0..100 {
        let (m1, m2) = (a + (b - a) / 3.0, b - (b - a) / 3.0);
        if curve.eval(m1).0.y < curve.eval(m2).0.y {
            a = m1;
        } else {
            b = m2;
        }
    }
    smax = 0.5 * (a + b);
    ymax = curve.eval(smax).0.y;
    let mut rng = SmallRng::seed_from_u64(13);
    let sign = |rng: &mut SmallRng| if rng.random::<bool>() { 1.0 } else { -1.0 };
    let mut total = 0;
    let mut clusters = 0;
    let knots = monotone_knots(&curve, 2000);
    for i in 0..2000 {
        let (o, d);
        if i % 2 == 0 {
            // Nearly horizontal at the rim's top height, ± a little.
            let tilt = [0.0, 1e-12, 1e-10, 1e-9, 1e-8, 1e-6, 1e-4][rng.random_range(0..7)];
            let dh = [1e-3, 1e-5, 1e-7, 1e-9, 1e-11, 0.0][rng.random_range(0..6)];
            let (tilt, dh) = (tilt * sign(&mut rng), dh * sign(&mut rng));
            let a = rng.random_range(-3.2..3.2f64);
            o = DVec3::new(4.0 * a.cos(), ymax + dh, 4.0 * a.sin());
            let target = DVec3::new(
                rng.random_range(-1.3..1.3),
                o.y,
                rng.random_range(-1.3..1.3),
            );
            d = (target - o).normalize() + DVec3::Y * tilt;
        } else {
            // Down along the axis or close to it, upright or slightly tilted: through the
            // poles (the bowl's bottom and the foot's).
            let r = [0.0, 1e-12, 1e-9, 1e-6, 1e-3, 0.05][rng.random_range(0..6)];
            let a = rng.random_range(-3.2..3.2f64);
            let tilt = [0.0, 1e-9, 1e-6, 1e-3][rng.random_range(0..4)];
            o = DVec3::new(r * a.cos(), 5.0, r * a.sin());
            d = DVec3::new(tilt * a.cos(), -1.0, tilt * a.sin());
        }
        let hits = intersect_reference(&curve, o, d, 0.0, f64::INFINITY);
        total += hits.len();
        for h in &hits {
            let r = residual(&curve, o, d, h);
            assert!(r < 1e-9 * scale, "residual {r} at {h:?}, o {o} d {d}");
        }
        clusters += check_parity(&curve, &knots, "goblet, rim top / axis", o, d, &hits);
    }
    println!(
        "goblet, rim top (y {ymax} at s {smax}) and axis: 2000 rays, {total} hits, {clusters} graze clusters"
    );
}

#[test]
fn degenerate_input_gives_no_hits_and_no_panic() {
    let curve = goblet();
    let o = DVec3::new(0.0, 0.0, 5.0);
    assert!(intersect_reference(&curve, o, DVec3::ZERO, 0.0, 1e9).is_empty());
    assert!(intersect_reference(&curve, o, DVec3::NAN, 0.0, 1e9).is_empty());
    assert!(intersect_reference(&curve, DVec3::NAN, DVec3::Z, 0.0, 1e9).is_empty());
    assert!(intersect_reference(&curve, o, DVec3::NEG_Z, 5.0, 1.0).is_empty());
    assert!(intersect_reference(&curve, o, DVec3::NEG_Z, f64::NAN, 1.0).is_empty());
    // Curves built around `new`.
    for bad in [
        Curve {
            kind: CurveKind::Bezier,
            controls: vec![],
        },
        Curve {
            kind: CurveKind::Bezier,
            controls: vec![DVec2::X; 12],
        },
        Curve {
            kind: CurveKind::BSpline,
            controls: vec![DVec2::X; 3],
        },
        Curve {
            kind: CurveKind::Bezier,
            controls: vec![DVec2::ZERO; 3],
        },
    ] {
        assert!(intersect_reference(&bad, o, DVec3::NEG_Z, 0.0, 1e9).is_empty());
        let _ = bad.eval(0.5);
        let _ = bad.eval(f64::NAN);
        let _ = bad.bezier_segments();
        let _ = bad.revolution_bounds();
    }
    // A ray lying in a cylinder's wall: one hit on the stretch, quickly.
    let cyl = Curve::new(CurveKind::Bezier, points(&[[1.0, -1.0], [1.0, 1.0]])).unwrap();
    let hits = intersect_reference(&cyl, DVec3::new(1.0, -3.0, 0.0), DVec3::Y, 0.0, 10.0);
    assert!(hits.len() <= 1);
    // A horizontal ray in the plane of a flat annulus.
    let disk = Curve::new(CurveKind::Bezier, points(&[[0.5, 0.0], [2.0, 0.0]])).unwrap();
    let hits = intersect_reference(&disk, DVec3::new(-5.0, 0.0, 0.1), DVec3::X, 0.0, 10.0);
    assert!(hits.len() <= 4);
    // Deterministic.
    let d = DVec3::new(0.1, -0.3, -1.0);
    let a = intersect_reference(&curve, o, d, 0.0, 1e9);
    let b = intersect_reference(&curve, o, d, 0.0, 1e9);
    assert_eq!(format!("{a:?}"), format!("{b:?}"));
}

#[test]
fn goblet_timing() {
    let curve = goblet();
    let mut rng = SmallRng::seed_from_u64(11);
    let b = curve.revolution_bounds();
    let radius = 1.5 * (b.hi - b.lo).length();
    let rays: Vec<(DVec3, DVec3)> = (0..100_000)
        .map(|_| {
            let o = b.center() + unit(&mut rng) * radius;
            let target =
                b.lo + (b.hi - b.lo) * DVec3::new(rng.random(), rng.random(), rng.random());
            (o, target - o)
        })
        .collect();
    let start = Instant::now();
    let mut hits = 0;
    for &(o, d) in &rays {
        hits += intersect_reference(&curve, o, d, 0.0, f64::INFINITY).len();
    }
    let per_ray = start.elapsed().as_secs_f64() / rays.len() as f64;
    println!(
        "goblet: {} rays, {hits} hits, {:.2} µs per ray",
        rays.len(),
        per_ray * 1e6
    );
    assert!(per_ray < 1e-3, "{per_ray} s per ray");
}
