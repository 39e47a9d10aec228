//! Ray/sphere and ray/plane intersection on the device against an f64 reference, on random and
//! adversarial rays (spheres of radius 1e5 and 1e-3, grazing rays, origins on the surface), and
//! rays spawned from hit points: the refined point lies within its error bound of the surface,
//! and no spawned ray hits the surface it leaves (1e5 tries per case).

mod common;

use clpt::contract::{OBJECT_NONE, OBJECT_PLANE, OBJECT_SPHERE, Plane, Sphere};
use clpt::device::kernel::NamedArgs;
use common::reference::{self, v3};
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// Unit roundoff of f32.
const EPS: f64 = 1.0 / 16_777_216.0;

fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

fn ray(o: DVec3, d: DVec3, w: DVec3) -> [f32; 9] {
    let (o, d, w) = (f32x3(o), f32x3(d.normalize()), f32x3(w.normalize()));
    [o[0], o[1], o[2], d[0], d[1], d[2], w[0], w[1], w[2]]
}

fn parts(r: &[f32; 9]) -> (DVec3, DVec3, DVec3) {
    (
        v3([r[0], r[1], r[2]]),
        v3([r[3], r[4], r[5]]),
        v3([r[6], r[7], r[8]]),
    )
}

/// A sphere case: the sphere, and where ray origins come from (centre, spread).
struct SphereCase {
    name: &'static str,
    sphere: Sphere,
    origin_center: DVec3,
    origin_spread: f64,
}

fn sphere_cases() -> Vec<SphereCase> {
    let s = |c: [f32; 3], r: f32| Sphere {
        center: c,
        radius: r,
        ..Default::default()
    };
    vec![
        // smallpt's left wall, seen from inside the room.
        SphereCase {
            name: "radius 1e5 wall",
            sphere: s([100001.0, 40.8, 81.6], 1e5),
            origin_center: DVec3::new(50.0, 40.0, 80.0),
            origin_spread: 45.0,
        },
        // smallpt's light: radius 600 sunk into the ceiling.
        SphereCase {
            name: "radius 600 light",
            sphere: s([50.0, 681.33, 81.6], 600.0),
            origin_center: DVec3::new(50.0, 40.0, 80.0),
            origin_spread: 40.0,
        },
        SphereCase {
            name: "unit sphere",
            sphere: s([0.3, -0.2, 0.1], 1.0),
            origin_center: DVec3::new(0.3, -0.2, 0.1),
            origin_spread: 5.0,
        },
        SphereCase {
            name: "radius 1e-3",
            sphere: s([0.3, -0.2, 0.1], 1e-3),
            origin_center: DVec3::new(0.3, -0.2, 0.1),
            origin_spread: 0.01,
        },
        SphereCase {
            name: "far from the origin",
            sphere: s([2e4, -3e4, 1e4], 16.5),
            origin_center: DVec3::new(2e4, -3e4, 1e4),
            origin_spread: 100.0,
        },
    ]
}

/// Rays at the sphere: random ones aimed near it, grazing ones (the line's distance from the
/// centre within 1e-4 r of the radius), and ones starting on the surface.
fn sphere_rays(case: &SphereCase, n: usize, rng: &mut SmallRng) -> Vec<[f32; 9]> {
    let c = v3(case.sphere.center);
    let r = case.sphere.radius as f64;
    let mut rays = Vec::with_capacity(n);
    while rays.len() < n {
        let o = case.origin_center
            + common::random_unit(rng) * rng.random_range(0.0..case.origin_spread);
        let w = common::random_unit(rng);
        let kind = rays.len() % 4;
        let d = match kind {
            0 | 1 => {
                let target = c + common::random_unit(rng) * r * rng.random_range(0.0..1.3);
                target - o
            }
            2 => {
                // Grazing: aim at a point at distance r (1 +- 1e-4) from the centre, tangent.
                let to_c = c - o;
                if to_c.length() <= r * 1.01 {
                    // Inside (smallpt's room is inside its wall spheres): no tangent rays;
                    // aim nearly along the surface from a point just inside it instead.
                    let p = c + common::random_unit(rng) * r * (1.0 - 1e-4);
                    let along = common::random_unit(rng).reject_from(p - c).normalize();
                    rays.push(ray(p, along, w));
                    continue;
                }
                let axis = to_c.normalize();
                let side = common::random_unit(rng).reject_from(axis).normalize();
                let k = r * (1.0 + rng.random_range(-1e-4..1e-4));
                let tangent = c + side * k;
                tangent - o
            }
            _ => {
                // Origin on the surface (rounded to f32), any direction.
                let p = c + common::random_unit(rng) * r;
                rays.push(ray(p, common::random_unit(rng), w));
                continue;
            }
        };
        if d.length() > 0.0 {
            rays.push(ray(o, d, w));
        }
    }
    rays
}

#[test]
fn sphere_hits_match_f64_and_spawned_rays_never_self_hit() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(1);
    for case in sphere_cases() {
        let scene = common::packed(vec![case.sphere], vec![], vec![Default::default()]);
        let rays = sphere_rays(&case, 100_000, &mut rng);
        for lanes in common::LANE_WIDTHS {
            let out = common::probe_hits_in_lanes(&device, &scene, &rays, lanes);
            let name = format!("{} ({lanes} lanes)", case.name);
            let s = &case.sphere;
            let (c, r) = (v3(s.center), s.radius as f64);
            let (mut compared, mut hits, mut worst_t, mut worst_p) = (0, 0, 0.0f64, 0.0f64);
            for (input, got) in rays.iter().zip(&out) {
                let (o, d, w) = parts(input);
                let f = o - c;
                let b = f.dot(d);
                let perp2 = (f - b * d).length_squared();
                let grazing = (perp2.sqrt() - r).abs() <= 1e-3 * r + 8.0 * EPS * (f.length() + r);
                let on_surface = (f.length() - r).abs() <= 8.0 * EPS * (c.abs().max_element() + r);
                let want = reference::sphere_hit(s, o, d, f64::INFINITY);
                let got_t = (got[1] == OBJECT_SPHERE as f32).then_some(got[0] as f64);
                if !grazing && !on_surface {
                    assert_eq!(
                        want.is_some(),
                        got_t.is_some(),
                        "{}: hit/miss differs for o={o} d={d}: f64 {want:?}, device {got_t:?}",
                        name
                    );
                    if let (Some(t64), Some(t32)) = (want, got_t) {
                        let disc = (r * r - perp2).max(0.0).sqrt();
                        let tol =
                            32.0 * EPS * ((f.length_squared() + r * r) / (b.abs() + disc) + t64);
                        worst_t = worst_t.max((t32 - t64).abs() / tol);
                        compared += 1;
                    }
                }
                let Some(_) = got_t else { continue };
                hits += 1;
                let p = v3([got[3], got[4], got[5]]);
                let n = v3([got[6], got[7], got[8]]);
                let p_error = v3([got[9], got[10], got[11]]);
                // The refined point is within its own bound of the surface.
                let off_surface = ((p - c).length() - r).abs();
                let bound = n.abs().dot(p_error);
                worst_p = worst_p.max(off_surface / bound);
                assert!(
                    off_surface <= bound,
                    "{}: hit point {p} is {off_surface:e} off the surface, bound {bound:e}",
                    name
                );
                // p is rounded to f32 near |c|, so the normal is known to about that over r.
                let n_true = (p - c).normalize();
                let n_tol = 1e-5 + 16.0 * EPS * (c.abs().max_element() + r) / r;
                assert!(
                    (n - n_true).length() < n_tol,
                    "{}: normal {n} vs {n_true}",
                    name
                );
                // The spawned ray: outward never meets the sphere again; inward meets its far side.
                let spawn_dist = got[15] as f64;
                assert!(
                    spawn_dist.abs() >= bound,
                    "{}: spawn offset below the bound",
                    name
                );
                let cos = w.dot(n_true);
                if cos > 0.0 {
                    assert_eq!(
                        got[13], OBJECT_NONE as f32,
                        "{}: outward ray from {p} re-hit (t={})",
                        name, got[12]
                    );
                } else if cos < -1e-3 {
                    let chord = 2.0 * r * -cos;
                    assert_eq!(
                        got[13], OBJECT_SPHERE as f32,
                        "{}: inward ray from {p} missed the far side",
                        name
                    );
                    assert!(
                        got[12] as f64 > 0.5 * chord,
                        "{}: self-hit: inward ray from {p} hit at t={} (chord {chord})",
                        name,
                        got[12]
                    );
                }
            }
            assert!(
                compared > 30_000 && hits > 30_000,
                "{}: too few hits tested",
                name
            );
            eprintln!(
                "{}: {compared} t compared, worst |dt|/tol {worst_t:.3}; {hits} hits, worst surface distance/bound {worst_p:.3}",
                name
            );
            assert!(worst_t <= 1.0, "{}: t error {worst_t} x tolerance", name);
        }
    }
}

#[test]
fn plane_hits_match_f64_and_spawned_rays_never_self_hit() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(2);
    let tilted = DVec3::new(0.3, -0.8, 0.52).normalize();
    let cases = [
        ("floor", [0.0, 1.0, 0.0], 0.0f32, 1000.0f32),
        ("far wall", [0.0, 0.0, 1.0], -1000.0, 1000.0),
        ("tilted", f32x3(tilted), 37.5, 200.0),
        ("small range", [1.0, 0.0, 0.0], -100.0, 5.0),
    ];
    for (name, normal, offset, range) in cases {
        let plane = Plane {
            normal,
            offset,
            range,
            ..Default::default()
        };
        let scene = common::packed(vec![], vec![plane], vec![Default::default()]);
        let n = v3(normal);
        let center = n * offset as f64;
        let mut rays = Vec::new();
        while rays.len() < 100_000 {
            let o =
                center + common::random_unit(&mut rng) * rng.random_range(0.0..3.0 * range as f64);
            let target = center
                + common::random_unit(&mut rng).reject_from(n)
                    * rng.random_range(0.0..1.5 * range as f64);
            let d = if rays.len() % 5 == 0 {
                // Grazing: nearly parallel to the plane.
                (target - o).reject_from(n) + n * rng.random_range(-1e-4..1e-4)
            } else {
                target - o
            };
            if d.length() > 0.0 {
                rays.push(ray(o, d, common::random_unit(&mut rng)));
            }
        }
        for lanes in common::LANE_WIDTHS {
            let out = common::probe_hits_in_lanes(&device, &scene, &rays, lanes);
            let name = format!("{name} ({lanes} lanes)");
            let mut hits = 0;
            for (input, got) in rays.iter().zip(&out) {
                let (o, d, w) = parts(input);
                let want = reference::plane_hit(&scene.planes[0], o, d, f64::INFINITY);
                let got_t = (got[1] == OBJECT_PLANE as f32).then_some(got[0] as f64);
                let denom = n.dot(d);
                let scale = offset.abs() as f64 + o.abs().max_element();
                // Hits within rounding of the range's edge may go either way.
                let near_edge = want.or(got_t).is_some_and(|t| {
                    let rel = (o + t * d - center).abs().max_element();
                    (rel - range as f64).abs()
                        <= 1e-5 * (scale + range as f64) / denom.abs().max(1e-9)
                });
                if !near_edge {
                    assert_eq!(
                        want.is_some(),
                        got_t.is_some(),
                        "{name}: o={o} d={d}: {want:?} vs {got_t:?}"
                    );
                }
                let (Some(t64), Some(t32)) = (want, got_t) else {
                    continue;
                };
                hits += 1;
                let tol = 16.0 * EPS * (scale / denom.abs() + t64);
                assert!(
                    (t32 - t64).abs() <= tol,
                    "{name}: t {t32} vs {t64} (tol {tol:e})"
                );
                let p = v3([got[3], got[4], got[5]]);
                let p_error = v3([got[9], got[10], got[11]]);
                let off = (n.dot(p) - offset as f64).abs();
                assert!(
                    off <= n.abs().dot(p_error),
                    "{name}: hit point {off:e} off the plane"
                );
                // One-sided: a spawned ray never meets the plane it leaves, on either side.
                assert_eq!(
                    got[13], OBJECT_NONE as f32,
                    "{name}: ray spawned from {p} towards {w} re-hit the plane"
                );
            }
            assert!(hits > 20_000, "{name}: only {hits} hits tested");
        }
    }
}

/// The walls (kernels/objects.h, `walls_intersect`): a room's six axis planes, each ray testing
/// only the wall it moves towards on each axis, among planes the plane loop still tests (a
/// second floor facing up, a tilted panel, a transformed-looking far wall left to the loop by
/// being the second facing -z). Every ray's nearest plane and its t must be the f64
/// reference's, in the one-lane program (walls in the object BVH) and the wide ones (walls
/// apart): rays from inside and outside the room, along axes (a direction component exactly 0)
/// and through its corners.
#[test]
fn walls_and_other_planes_give_the_nearest_plane() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(11);
    let plane = |normal: [f32; 3], offset: f32, range: f32| Plane {
        normal,
        offset,
        range,
        ..Default::default()
    };
    let tilted = DVec3::new(0.2, 0.9, -0.38).normalize();
    let planes = vec![
        plane([0.0, -1.0, 0.0], -160.0, 400.0), // 0 ceiling, y = 160
        plane([1.0, 0.0, 0.0], -100.0, 400.0),  // 1 x = -100
        plane([-1.0, 0.0, 0.0], -100.0, 400.0), // 2 x = 100
        plane([0.0, 1.0, 0.0], 0.0, 400.0),     // 3 floor, y = 0
        plane([0.0, 0.0, 1.0], -100.0, 400.0),  // 4 back, z = -100
        plane([0.0, 0.0, -1.0], -300.0, 400.0), // 5 front, z = 300
        plane([0.0, 1.0, 0.0], 10.0, 30.0),     // 6 a raised floor panel facing up
        plane(f32x3(tilted), 20.0, 40.0),       // 7 a tilted panel
        plane([0.0, 0.0, -1.0], -250.0, 50.0),  // 8 a second wall facing -z
    ];
    let scene = common::packed(vec![], planes, vec![Default::default()]);
    assert_eq!(
        clpt::pack::walls(&scene.planes),
        ([1, 2, 3, 0, 4, 5], 0b111111),
        "the six room planes are the walls, the second ones of a side are not"
    );
    let inside = |rng: &mut SmallRng| {
        DVec3::new(
            rng.random_range(-99.0..99.0),
            rng.random_range(1.0..159.0),
            rng.random_range(-99.0..299.0),
        )
    };
    let mut rays = Vec::new();
    while rays.len() < 60_000 {
        let o = if rays.len() % 4 == 3 {
            // Outside the room: the walls are one-sided, and the range still counts.
            inside(&mut rng) + common::random_unit(&mut rng) * 500.0
        } else {
            inside(&mut rng)
        };
        let mut d = match rays.len() % 5 {
            // Towards a corner of the room.
            0 => {
                DVec3::new(
                    if rng.random_bool(0.5) { -100.0 } else { 100.0 },
                    if rng.random_bool(0.5) { 0.0 } else { 160.0 },
                    if rng.random_bool(0.5) { -100.0 } else { 300.0 },
                ) - o
            }
            _ => common::random_unit(&mut rng),
        };
        if rays.len() % 7 == 0 {
            d[rays.len() / 7 % 3] = 0.0; // along a wall's plane
        }
        if d.length() > 0.0 {
            rays.push(ray(o, d, common::random_unit(&mut rng)));
        }
    }
    for lanes in common::LANE_WIDTHS {
        let out = common::probe_hits_in_lanes(&device, &scene, &rays, lanes);
        let mut checked = 0;
        for (input, got) in rays.iter().zip(&out) {
            let (o, d, _) = parts(input);
            let mut hits: Vec<(f64, usize)> = scene
                .planes
                .iter()
                .enumerate()
                .filter_map(|(i, p)| reference::plane_hit(p, o, d, f64::INFINITY).map(|t| (t, i)))
                .collect();
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            let tol = |t: f64| 64.0 * EPS * (o.abs().max_element() + 400.0 + t);
            // Within rounding of a range's edge a plane may be met or not, and planes met at
            // nearly the same t (a corner) may come in either order.
            let edge = scene.planes.iter().any(|p| {
                let n = v3(p.normal);
                let denom = n.dot(d);
                let t = (p.offset as f64 - n.dot(o)) / denom;
                let rel = (o + t * d - v3(p.center)).abs().max_element();
                t > 0.0 && denom < 0.0 && (rel - p.range as f64).abs() <= 1e-3
            });
            let tie = hits.len() > 1 && hits[1].0 - hits[0].0 <= tol(hits[1].0);
            if edge || tie {
                continue;
            }
            let want = hits.first().copied();
            let got_hit =
                (got[1] == OBJECT_PLANE as f32).then_some((got[0] as f64, got[2] as usize));
            match (want, got_hit) {
                (None, None) => {}
                (Some((t64, i64)), Some((t32, i32))) => {
                    assert_eq!(
                        i32, i64,
                        "{lanes} lanes: o={o} d={d}: plane {i32} for {i64}"
                    );
                    assert!(
                        (t32 - t64).abs() <= tol(t64),
                        "{lanes} lanes: o={o} d={d}: t {t32} vs {t64}"
                    );
                }
                _ => panic!("{lanes} lanes: o={o} d={d}: f64 {want:?}, device {got_hit:?}"),
            }
            checked += 1;
        }
        assert!(
            checked > 40_000,
            "{lanes} lanes: only {checked} rays checked"
        );
    }
}

#[test]
fn camera_rays_match_f64() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(3);
    for (flength, aperture) in [(0.0, 0.0), (120.0, 4.0)] {
        let desc = clpt::scene::CameraDesc {
            center: DVec3::new(50.0, 52.0, 295.6),
            direction: DVec3::new(0.0, -0.042612, -1.0),
            angle_deg: 29.421356,
            width: 1024,
            height: 768,
            flength,
            aperture,
        };
        let mut scene = common::packed(vec![], vec![], vec![Default::default()]);
        scene.camera = clpt::scene::camera::CameraBasis::new(&desc).unwrap();
        let params = scene.params(0, 1, 1, 0);
        let buffers = clpt::device::upload::SceneBuffers::new(&device, &scene, &params).unwrap();
        let n = 4096;
        let pixels: Vec<ocl::prm::Uint4> = (0..n)
            .map(|_| {
                ocl::prm::Uint4::new(
                    rng.random_range(0..desc.width),
                    rng.random_range(0..desc.height),
                    0,
                    0,
                )
            })
            .collect();
        let u: Vec<ocl::prm::Float4> = (0..n)
            .map(|_| ocl::prm::Float4::new(rng.random(), rng.random(), rng.random(), rng.random()))
            .collect();
        let (pb, ub) = (
            common::buffer(&device, &pixels),
            common::buffer(&device, &u),
        );
        let out = common::output::<f32>(&device, n * 6);
        let program = common::probes(&device);
        let kernel = NamedArgs::new(&program, "probe_camera", &device.queue)
            .buffer("params", &buffers.params)
            .buffer("pixel", &pb)
            .buffer("u", &ub)
            .buffer("out", &out)
            .build()
            .unwrap();
        common::run(&kernel, n);
        let out = common::read(&out);
        for i in 0..n {
            let uu = [
                u[i][0] as f64,
                u[i][1] as f64,
                u[i][2] as f64,
                u[i][3] as f64,
            ];
            let (o, d) = reference::camera_ray(&scene.camera, pixels[i][0], pixels[i][1], uu);
            let go = v3([out[6 * i], out[6 * i + 1], out[6 * i + 2]]);
            let gd = v3([out[6 * i + 3], out[6 * i + 4], out[6 * i + 5]]);
            assert!(
                (go - o).length() <= 1e-5 * (1.0 + o.length()),
                "origin {go} vs {o}"
            );
            assert!(
                (gd - d).length() <= 1e-5,
                "direction {gd} vs {d} (flength {flength})"
            );
        }
    }
}
