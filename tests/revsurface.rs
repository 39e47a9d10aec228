//! Surfaces of revolution on the device against the certain f64 reference of
//! `common::curve_reference::intersect_reference`: for each profile (the original's goblet and vase,
//! and a profile with a cusp on the axis), 1e6 rays each of every kind (random, along and near
//! the axis, nearly horizontal, at the rim and the foot's edge): no false hit (a device hit more
//! than 1e-4 of the scene's size from the surface), no missed hit (a root more than that before
//! the device's hit, or a root where the device found none) where the ray does not graze
//! (|n.d| > 0.01), and no ray spawned from a hit that finds the surface it leaves. Renders of
//! the goblet are deterministic: the same seed gives the same bits however the work is split.
//! The device's de Casteljau evaluation (point and derivative) matches the f64 curves for
//! Bezier curves of degree 1 to 7 and the three profiles.

mod common;

use clpt::device::kernel::NamedArgs;
use clpt::device::program::KernelSources;
use clpt::pack::PackedScene;
use clpt::render::{RenderOptions, Renderer};
use clpt::scene::curve::{Curve, CurveKind};
use clpt::scene::parse::parse_scene;
use common::curve_reference;
use glam::{DVec2, DVec3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// What the hit probe records for a surface of revolution (kind, as a float).
const HIT_REVSURFACE: f32 = clpt::contract::OBJECT_REVSURFACE as f32;

fn profiles() -> Vec<(&'static str, Curve)> {
    let pts = |p: &[[f64; 2]]| p.iter().map(|&[x, y]| DVec2::new(x, y)).collect::<Vec<_>>();
    vec![
        (
            "goblet",
            Curve::new(CurveKind::BSpline, pts(&common::GOBLET)).unwrap(),
        ),
        (
            "vase",
            Curve::new(
                CurveKind::Bezier,
                pts(&[[-2.0, 2.0], [-4.0, 0.0], [0.0, 0.0], [-2.0, -2.0]]),
            )
            .unwrap(),
        ),
        // A spindle with a cusp on the axis at both ends.
        (
            "cusp",
            Curve::new(
                CurveKind::Bezier,
                pts(&[[0.0, -1.0], [1.5, -0.6], [0.1, 0.0], [1.2, 0.7], [0.0, 1.0]]),
            )
            .unwrap(),
        ),
    ]
}

/// The surface alone, with the camera at the scene's origin: the device's coordinates are then
/// the scene's, and the probe's rays reach the device unrounded.
fn scene_text(curve: &Curve) -> String {
    let kind = match curve.kind {
        CurveKind::Bezier => "BezierCurve",
        CurveKind::BSpline => "BsplineCurve",
    };
    let controls: String = curve
        .controls
        .iter()
        .map(|p| format!("[ {} {} 0 ] ", p.x, p.y))
        .collect();
    format!(
        "PerspectiveCamera {{ center 0 0 0 direction 0 0 -1 angle 30 width 8 height 8 }}\n\
         Materials {{ numMaterials 1 Material {{ color 0.5 0.5 0.5 }} }}\n\
         Group {{ numObjects 1 RevSurface {{ profile {kind} {{ controls {controls} }} }} }}\n"
    )
}

fn ray(o: DVec3, d: DVec3, w: DVec3) -> [f32; 9] {
    let (o, d, w) = (
        o.as_vec3().to_array(),
        d.normalize().as_vec3().to_array(),
        w.normalize().as_vec3().to_array(),
    );
    [o[0], o[1], o[2], d[0], d[1], d[2], w[0], w[1], w[2]]
}

/// The distance from p to the surface: in p's meridian plane, from (r, y) to the profile
/// revolved there, by a fine scan of the curve refined by ternary search.
fn distance_to_surface(curve: &Curve, p: DVec3) -> f64 {
    let q = DVec2::new((p.x * p.x + p.z * p.z).sqrt(), p.y);
    let dist = |s: f64| {
        let c = curve.eval(s).0;
        (DVec2::new(c.x.abs(), c.y) - q).length()
    };
    let samples = 4000;
    let best = (0..=samples)
        .min_by(|&a, &b| {
            dist(a as f64 / samples as f64).total_cmp(&dist(b as f64 / samples as f64))
        })
        .unwrap_or(0);
    let (mut lo, mut hi) = (
        ((best as f64 - 1.0) / samples as f64).max(0.0),
        ((best as f64 + 1.0) / samples as f64).min(1.0),
    );
    for _ in 0..60 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if dist(m1) < dist(m2) {
            hi = m2
        } else {
            lo = m1
        }
    }
    dist(0.5 * (lo + hi))
}

/// Each ray's hits against the f64 reference (below), on the probes as built: their programs
/// have light sampling (features.h), whose revolved surfaces walk their segments one after
/// another in step. The loop that programs without light sampling run
/// (`CLPT_REV_MERGED`, kernels/revsurface.h) visits each ray's segments and sub-curves in the
/// same order, and must give the same bits for every ray.
#[test]
fn device_hits_match_the_f64_reference() {
    let device = common::device();
    let merged =
        common::build_without_warnings(&device, "probes.cl", &[("CLPT_REV_MERGED", "1".into())]);
    let mut merged_differ = 0usize;
    let mut rng = SmallRng::seed_from_u64(51);
    let mut results = Vec::new();
    for (name, curve) in profiles() {
        let scene = parse_scene(&scene_text(&curve), name).unwrap();
        let packed = PackedScene::new(&scene, u64::MAX).unwrap();
        let bounds = curve.revolution_bounds();
        let (c, size) = (bounds.center(), bounds.extent().length());
        let segments = 1_000_000 / 100_000;
        let (mut missed, mut false_hits, mut compared) = (0usize, 0usize, 0usize);
        let mut self_hits = 0usize;
        for batch in 0..segments {
            let rays: Vec<[f32; 9]> = (0..100_000)
                .map(|i| {
                    let w = common::random_unit(&mut rng);
                    let kind = (batch * 100_000 + i) % 6;
                    let o = c + common::random_unit(&mut rng) * size * rng.random_range(0.8..2.0);
                    let target = match kind {
                        // Along and near the axis.
                        0 => DVec3::new(
                            rng.random_range(-1e-3..1e-3),
                            rng.random_range(bounds.lo.y..bounds.hi.y),
                            rng.random_range(-1e-3..1e-3),
                        ),
                        // A point on the surface (rim, foot edge, anywhere), from any side.
                        1 | 2 => {
                            let (p, _) = curve.eval(rng.random::<f64>());
                            curve_reference::revolve(
                                p,
                                rng.random_range(0.0..std::f64::consts::TAU),
                            )
                        }
                        // The profile's ends and its extreme points: the rim and the foot's edge.
                        3 => {
                            let s = if rng.random::<bool>() {
                                rng.random_range(0.0..0.02)
                            } else {
                                rng.random_range(0.98..1.0)
                            };
                            curve_reference::revolve(
                                curve.eval(s).0,
                                rng.random_range(0.0..std::f64::consts::TAU),
                            )
                        }
                        _ => c + common::random_unit(&mut rng) * size * 0.5,
                    };
                    let mut d = target - o;
                    if kind == 4 {
                        d.y *= 1e-4; // nearly horizontal
                    }
                    ray(o, d, w)
                })
                .collect();
            let got = common::probe_hits(&device, &packed, &rays);
            let bits = |h: &[f32; 16]| h.map(f32::to_bits);
            merged_differ += common::probe_hits_on(&merged, &device, &packed, &rays)
                .iter()
                .zip(&got)
                .filter(|(m, g)| bits(m) != bits(g))
                .count();
            // Each device answer against the f64 reference, spread over the cores (the
            // reference's root isolation was most of the test's time): (compared, missed,
            // false hits, self-hits) of one ray.
            let check = |r: &[f32; 9], g: &[f32; 16]| -> [usize; 4] {
                let mut counts = [0usize; 4];
                let o = DVec3::new(r[0] as f64, r[1] as f64, r[2] as f64);
                let d = DVec3::new(r[3] as f64, r[4] as f64, r[5] as f64);
                let hits = curve_reference::intersect_reference(&curve, o, d, 0.0, f64::INFINITY);
                let tol = 1e-4 * (size + o.length());
                if g[1] == HIT_REVSURFACE {
                    let t = g[0] as f64;
                    counts[0] += 1;
                    // The ray spawned from the hit towards w must not find the surface it
                    // leaves: a hit closer than 1e-4 of the size with no root there is a
                    // self-hit.
                    let w = DVec3::new(r[6] as f64, r[7] as f64, r[8] as f64);
                    let p = DVec3::new(g[3] as f64, g[4] as f64, g[5] as f64);
                    let n = DVec3::new(g[6] as f64, g[7] as f64, g[8] as f64);
                    // Spawned rays that graze (|w.n| < 0.05) are exempt, as grazing rays are
                    // from the missed-hit count.
                    if g[13] == HIT_REVSURFACE
                        && w.dot(n).abs() >= 0.05
                        && (g[12] as f64) < 1e-4 * size
                        && curve_reference::intersect_reference(
                            &curve,
                            p,
                            w,
                            1e-9 * size,
                            2e-4 * size,
                        )
                        .is_empty()
                    {
                        counts[3] += 1;
                    }
                    // A device hit must lie on the surface (within `tol` of it), and no root
                    // may lie clearly before it unless the ray grazes there.
                    if !hits.iter().any(|h| (h.t - t).abs() <= tol)
                        && distance_to_surface(&curve, o + d * t) > tol
                    {
                        counts[2] += 1;
                    }
                    if let Some(first) = hits.first()
                        && first.t < t - tol
                        && first.normal.dot(d).abs() > 1e-2
                    {
                        counts[1] += 1;
                    }
                } else if let Some(first) = hits.first()
                    && first.normal.dot(d).abs() > 1e-2
                {
                    counts[1] += 1;
                }
                counts
            };
            let pairs: Vec<_> = rays.iter().zip(&got).collect();
            let counts = common::on_all_cores(&pairs, |&(r, g)| check(r, g))
                .into_iter()
                .fold([0usize; 4], |mut sum, c| {
                    for (s, c) in sum.iter_mut().zip(c) {
                        *s += c;
                    }
                    sum
                });
            compared += counts[0];
            missed += counts[1];
            false_hits += counts[2];
            self_hits += counts[3];
        }
        eprintln!(
            "{name}: {compared} device hits, {missed} missed, {false_hits} false, {self_hits} self-hits"
        );
        assert!(compared > 100_000, "{name}: only {compared} hits");
        results.push((name, missed, false_hits, self_hits));
    }
    assert_eq!(
        merged_differ, 0,
        "rays whose hits the merged segment loop (CLPT_REV_MERGED) answers otherwise"
    );
    for (name, missed, false_hits, self_hits) in results {
        assert_eq!(false_hits, 0, "{name}: false hits");
        assert_eq!(missed, 0, "{name}: missed hits");
        assert_eq!(
            self_hits, 0,
            "{name}: spawned rays hit the surface they leave"
        );
    }
}

#[test]
fn goblet_renders_are_deterministic() {
    let device = common::device();
    let controls: String = common::GOBLET
        .iter()
        .map(|[x, y]| format!("[ {x} {y} 0 ] "))
        .collect();
    let text = format!(
        "PerspectiveCamera {{ center 0 0 12 direction 0 0 -1 angle 30 width 64 height 36 }}\n\
         Materials {{ numMaterials 3 Material {{ emission 4 4 4 }} \
         Material {{ color 0.94 0.75 0.34 type spec }} Material {{ color 0.75 0.75 0.75 }} }}\n\
         Group {{ numObjects 3 MaterialIndex 0 Sphere {{ center 0 8 4 radius 2 }} \
         MaterialIndex 1 RevSurface {{ profile BsplineCurve {{ controls {controls} }} }} \
         MaterialIndex 2 Plane {{ normal 0 1 0 offset -2.4588 range 100 }} }}\n"
    );
    let scene = parse_scene(&text, "goblet").unwrap_or_else(|e| panic!("{e}"));
    let render = |seed: u64, launch_target: Option<std::time::Duration>| {
        let options = RenderOptions {
            spp: Some(4),
            seed,
            launch_target,
            ..RenderOptions::default()
        };
        let mut renderer = Renderer::new(&device, &scene, &KernelSources::Embedded, options)
            .unwrap_or_else(|e| panic!("{e}"));
        renderer
            .render(&mut |_| {})
            .unwrap_or_else(|e| panic!("{e}"))
            .0
    };
    let a = render(3, RenderOptions::default().launch_target);
    let b = render(3, Some(std::time::Duration::from_nanos(1)));
    let c = render(4, RenderOptions::default().launch_target);
    assert!(a.sum.iter().any(|p| p[..3] != [0.0; 3]), "a black image");
    assert_eq!(
        a.sum, b.sum,
        "same seed, other launch split: different sums"
    );
    assert_ne!(a.sum, c.sum, "another seed gave the same image");
}

#[test]
fn device_bezier_eval_matches_the_f64_curves() {
    let device = common::device();
    let program = common::probes(&device);
    let mut rng = SmallRng::seed_from_u64(7);
    let mut curves: Vec<Curve> = (2..=8)
        .map(|n| {
            let controls = (0..n)
                .map(|_| DVec2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)))
                .collect();
            Curve::new(CurveKind::Bezier, controls).unwrap()
        })
        .collect();
    curves.extend(profiles().into_iter().map(|(_, c)| c));
    for curve in curves {
        let segments = curve.bezier_segments();
        let m = segments.len();
        let points: Vec<[f32; 2]> = segments
            .iter()
            .flatten()
            .map(|p| [p.x as f32, p.y as f32])
            .collect();
        let degree = curve.degree();
        // Random parameters, and the ends of every segment.
        let queries: Vec<(usize, f32)> = (0..4000)
            .map(|i| match i % 8 {
                0 => (i % m, 0.0),
                1 => (i % m, 1.0),
                _ => (rng.random_range(0..m), rng.random::<f32>()),
            })
            .collect();
        let seg: Vec<[u32; 2]> = queries
            .iter()
            .map(|&(k, _)| [(k * (degree + 1)) as u32, degree as u32])
            .collect();
        let u: Vec<f32> = queries.iter().map(|&(_, u)| u).collect();
        let (points_buf, seg_buf, u_buf) = (
            common::buffer(&device, &points.concat()),
            common::buffer(&device, &seg.concat()),
            common::buffer(&device, &u),
        );
        let out = common::output::<f32>(&device, queries.len() * 4);
        let kernel = NamedArgs::new(&program, "probe_bezier", &device.queue)
            .buffer("points", &points_buf)
            .buffer("segment", &seg_buf)
            .buffer("u", &u_buf)
            .buffer("out", &out)
            .build()
            .unwrap();
        common::run(&kernel, queries.len());
        let got = common::read(&out);
        let size = curve
            .controls
            .iter()
            .map(|p| p.abs().max_element())
            .fold(0.0, f64::max);
        for (q, g) in queries.iter().zip(got.chunks_exact(4)) {
            // Segment k covers s in [k/m, (k+1)/m]: dC/du = dC/ds / m.
            let s = (q.0 as f64 + q.1 as f64) / m as f64;
            let (p, dp) = curve.eval(s);
            let dp = dp / m as f64;
            let (gp, gd) = (
                DVec2::new(g[0] as f64, g[1] as f64),
                DVec2::new(g[2] as f64, g[3] as f64),
            );
            // f32 de Casteljau: a few roundings of the control points' size per level.
            let tol = 4.0 * (degree as f64 + 1.0) * f32::EPSILON as f64 * size;
            assert!(
                (gp - p).length() <= tol,
                "degree {degree} at {s}: {gp} against {p}"
            );
            assert!(
                (gd - dp).length() <= tol * degree as f64 * 2.0,
                "degree {degree} at {s}: derivative {gd} against {dp}"
            );
        }
    }
}
