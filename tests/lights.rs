//! The light list next-event estimation samples (src/device/lights.rs), on the host: which
//! emitters it takes, where it places them in world space, and the probabilities of picking
//! them. That light sampling and pure path tracing then agree on the device is
//! tests/convergence.rs's `light_sampling_and_pure_path_tracing_agree`.

mod common;

use clpt::device::layout::{Light, OBJECT_MESH, OBJECT_PLANE, OBJECT_SPHERE};
use clpt::device::upload::PackedScene;
use glam::{DMat4, DVec3};
use std::f64::consts::PI;

/// The light list of common::every_light_scene (its files under a folder of the test's own).
fn lights(test: &str) -> Vec<Light> {
    let dir = std::env::temp_dir().join(format!("clpt-lights-{}-{test}", std::process::id()));
    let scene = common::every_light_scene(&dir);
    let packed = PackedScene::new(&scene, u64::MAX).unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_dir_all(&dir);
    packed.lights
}

fn v(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn the_list_holds_the_similar_sphere_the_square_and_the_triangles_and_no_ellipsoid() {
    let lights =
        lights("the_list_holds_the_similar_sphere_the_square_and_the_triangles_and_no_ellipsoid");
    let keys: Vec<(u32, u32, u32)> = lights
        .iter()
        .map(|l| (l.kind, l.index, l.triangle))
        .collect();
    // Spheres: the light (index 0) and not the ellipsoid (1) nor the grey ball (2). Planes: the
    // rotated square (index 6, after the six walls). Meshes: instance 1 (the quad; the ball,
    // instance 0, does not emit), both triangles.
    assert_eq!(
        keys,
        [
            (OBJECT_SPHERE, 0, 0),
            (OBJECT_PLANE, 6, 0),
            (OBJECT_MESH, 1, 0),
            (OBJECT_MESH, 1, 1)
        ]
    );
    let sphere = &lights[0];
    assert!(
        close(f64::from(sphere.radius), 0.4, 1e-6),
        "{}",
        sphere.radius
    );
    assert!((v(sphere.corner) - DVec3::new(-1.5, 2.2, -1.0)).length() < 1e-6);
}

#[test]
fn the_rotated_square_maps_onto_the_plane_s_own_square_and_faces_its_side() {
    let lights = lights("the_rotated_square_maps_onto_the_plane_s_own_square_and_faces_its_side");
    let square = &lights[1];
    let m = DMat4::from_translation(DVec3::new(1.8, 2.6, -1.5))
        * DMat4::from_rotation_x(20f64.to_radians())
        * DMat4::from_rotation_z(15f64.to_radians());
    let inv = m.inverse();
    let (c, e1, e2) = (v(square.corner), v(square.edge1), v(square.edge2));
    // Its four corners, back in the plane's own space: y = 0, |x| = |z| = range = 0.5.
    for p in [c, c + e1, c + e2, c + e1 + e2] {
        let q = inv.transform_point3(p);
        assert!(q.y.abs() < 1e-6, "{q}");
        assert!(
            (q.x.abs() - 0.5).abs() < 1e-6 && (q.z.abs() - 0.5).abs() < 1e-6,
            "{q}"
        );
    }
    assert!(close(f64::from(square.area), 1.0, 1e-6), "{}", square.area);
    // It emits to the side its own normal (0, -1, 0) points to; e1 x e2 along it.
    let n = m.transform_vector3(DVec3::NEG_Y);
    assert!(v(square.normal).dot(n) > 1.0 - 1e-6, "{:?}", square.normal);
    assert!(e1.cross(e2).normalize().dot(n) > 1.0 - 1e-6);
}

#[test]
fn the_quad_s_triangles_carry_its_scaled_area() {
    let lights = lights("the_quad_s_triangles_carry_its_scaled_area");
    let area: f64 = lights[2..].iter().map(|l| f64::from(l.area)).sum();
    assert!(close(area, 1.6 * 0.6, 1e-6), "{area}");
    for l in &lights[2..] {
        let n = v(l.edge1).cross(v(l.edge2));
        assert!(close(n.length() / 2.0, f64::from(l.area), 1e-6));
        assert!(close(n.normalize().dot(v(l.normal)), 1.0, 1e-6));
    }
}

#[test]
fn lights_are_picked_in_proportion_to_their_power() {
    let lights = lights("lights_are_picked_in_proportion_to_their_power");
    // pi Le area, Le the mean channel; the triangles emit to both sides.
    let power = [
        PI * 5.0 * 4.0 * PI * 0.4 * 0.4,
        PI * 4.0 * 1.0,
        2.0 * PI * 4.0 * 0.48,
        2.0 * PI * 4.0 * 0.48,
    ];
    let total: f64 = power.iter().sum();
    let mut cdf = 0.0f32;
    for (l, p) in lights.iter().zip(power) {
        assert!(
            close(f64::from(l.prob), p / total, 1e-5),
            "{} vs {}",
            l.prob,
            p / total
        );
        assert!(l.cdf >= cdf && l.cdf - cdf == l.prob, "{l:?}");
        cdf = l.cdf;
    }
    assert_eq!(cdf, 1.0);
}

/// scenes/lights.txt lists the lamp (a transformed sphere), the panel (a rotated square) and
/// every triangle of the glowing knot.
#[test]
fn the_shipped_lights_scene_lists_all_its_emitters() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/lights.txt");
    let scene = clpt::scene::Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let lights = PackedScene::new(&scene, u64::MAX)
        .unwrap_or_else(|e| panic!("{e}"))
        .lights;
    let count = |kind| lights.iter().filter(|l| l.kind == kind).count();
    assert_eq!(
        (
            count(OBJECT_SPHERE),
            count(OBJECT_PLANE),
            count(OBJECT_MESH)
        ),
        (1, 1, 24576)
    );
}
