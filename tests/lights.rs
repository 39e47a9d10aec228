//! The light list next-event estimation samples (src/pack/lights.rs), on the host: which
//! emitters it takes, where it places them in world space, and the probabilities of picking
//! them. That light sampling and pure path tracing then agree on the device is
//! tests/convergence.rs's `light_sampling_and_pure_path_tracing_agree`.
//!
//! Clipping to the closed room around the camera (lights.rs module doc): case2's ceiling and
//! front wall shrink to the room; an open room, a wall of glass, a wall too short, a camera
//! outside or a lens through a wall clip nothing; a rotated panel through three walls becomes a
//! rectangle holding every point of it in the room, and not much more; emitters and triangles
//! no point of the room sees are dropped.

mod common;

use clpt::contract::{Light, OBJECT_MESH, OBJECT_PLANE, OBJECT_SPHERE};
use clpt::pack::PackedScene;
use clpt::pack::lights::Room;
use clpt::scene::Scene;
use glam::{DMat4, DVec3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::f64::consts::PI;

fn v(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

#[test]
fn the_list_holds_the_similar_sphere_the_square_and_the_triangles_and_no_ellipsoid() {
    let lights = common::every_light_scene_lights(
        "lights-the_list_holds_the_similar_sphere_the_square_and_the_triangles_and_no_ellipsoid",
    );
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
    let lights = common::every_light_scene_lights(
        "lights-the_rotated_square_maps_onto_the_plane_s_own_square_and_faces_its_side",
    );
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
    let lights = common::every_light_scene_lights("the_quad_s_triangles_carry_its_scaled_area");
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
    let lights = common::every_light_scene_lights("lights_are_picked_in_proportion_to_their_power");
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

/// The packed scene, its lights and room in the scene's coordinates.
fn pack(scene: &Scene) -> PackedScene {
    common::in_scene_coordinates(
        PackedScene::new(scene, u64::MAX).unwrap_or_else(|e| panic!("{e}")),
    )
}

/// The room of case2: x in [-100, 100], y in [0, 160], z in [-100, 1000].
const ROOM_LO: DVec3 = DVec3::new(-100.0, 0.0, -100.0);
const ROOM_HI: DVec3 = DVec3::new(100.0, 160.0, 1000.0);

fn plane_light(lights: &[Light], index: u32) -> &Light {
    lights
        .iter()
        .find(|l| l.kind == OBJECT_PLANE && l.index == index)
        .unwrap_or_else(|| panic!("plane {index} is not listed: {lights:?}"))
}

fn near(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).abs().max_element() <= tol
}

/// The room and its walls, as case2 and common::room_walls have them.
fn assert_case2_room(room: Option<&Room>) {
    let room = room.expect("a closed room");
    assert_eq!((room.lo, room.hi), (ROOM_LO, ROOM_HI));
    // x >= -100, x <= 100, y >= 0 (floor), y <= 160 (ceiling), z >= -100, z <= 1000.
    assert_eq!(room.walls, [3, 2, 5, 0, 4, 1]);
    assert!(
        room.tolerance > 0.0 && room.tolerance <= 0.011,
        "{}",
        room.tolerance
    );
}

/// Case2's ceiling (plane 0) and front wall (plane 1), both of range 1000, clipped to the
/// room: by hand, the ceiling becomes x in [-100, 100], z in [-100, 1000] at y = 160 (220000
/// of its 4e6), the front wall x in [-100, 100], y in [0, 160] at z = 1000 (32000), each
/// grown by the tolerance (0.01) where the room, not the square, ends it.
fn assert_case2_lights(lights: &[Light]) {
    let ceiling = plane_light(lights, 0);
    let (c, e1, e2) = (v(ceiling.corner), v(ceiling.edge1), v(ceiling.edge2));
    assert!(
        near(c, DVec3::new(-100.0, 160.0, -100.0), 0.02),
        "{ceiling:?}"
    );
    assert!(near(e1, DVec3::new(200.0, 0.0, 0.0), 0.03), "{ceiling:?}");
    assert!(near(e2, DVec3::new(0.0, 0.0, 1100.0), 0.03), "{ceiling:?}");
    // It holds the whole face: x from -100 to 100, z from -100 to the square's end, 1000.
    assert!(
        c.x <= -100.0 && c.x + e1.x >= 100.0 && c.z <= -100.0,
        "{ceiling:?}"
    );
    assert!(c.z + e2.z >= 1000.0 - 1e-3, "{ceiling:?}");
    assert!(
        close(f64::from(ceiling.area), 220_000.0, 2e-4),
        "{}",
        ceiling.area
    );
    assert_eq!(ceiling.normal, [0.0, -1.0, 0.0]);

    let front = plane_light(lights, 1);
    let (c, e1, e2) = (v(front.corner), v(front.edge1), v(front.edge2));
    // Edges swapped so that e1 x e2 points along its normal, -z: e1 along y, e2 along x.
    assert!(near(c, DVec3::new(-100.0, 0.0, 1000.0), 0.02), "{front:?}");
    assert!(near(e1, DVec3::new(0.0, 160.0, 0.0), 0.03), "{front:?}");
    assert!(near(e2, DVec3::new(200.0, 0.0, 0.0), 0.03), "{front:?}");
    assert!(c.x <= -100.0 && c.x + e2.x >= 100.0 && c.y <= 0.0 && c.y + e1.y >= 160.0);
    assert!(
        close(f64::from(front.area), 32_000.0, 3e-4),
        "{}",
        front.area
    );
    assert_eq!(front.normal, [0.0, 0.0, -1.0]);
    // Same emission: picked in proportion to the clipped areas.
    let ratio = f64::from(ceiling.prob) / f64::from(front.prob);
    assert!(close(ratio, 220.0 / 32.0, 1e-3), "{ratio}");
    // Both are walls of the room: sampled by solid angle (kernels/nee.h sph_rect).
    assert_eq!((ceiling.solid_angle, front.solid_angle), (1, 1));
}

#[test]
fn case2_s_ceiling_and_front_wall_are_clipped_to_the_room() {
    let Some(seed) = common::seed_dir("case2_s_ceiling_and_front_wall_are_clipped_to_the_room")
    else {
        return;
    };
    let path = seed.join("testcases/case2_softshadows_colorbleeding.txt");
    let packed = pack(&Scene::load(&path).unwrap_or_else(|e| panic!("{e}")));
    assert_case2_room(packed.room.as_ref());
    assert_eq!(packed.lights.len(), 2);
    assert_case2_lights(&packed.lights);
}

#[test]
fn the_case2_room_without_textures_clips_the_same() {
    let packed = pack(&common::room_scene(
        "center 0 60 500",
        &common::room_walls(),
    ));
    assert_case2_room(packed.room.as_ref());
    assert_case2_lights(&packed.lights);
}

/// Unclipped: both emitters keep their whole 2000 x 2000 squares.
fn assert_unclipped(packed: &PackedScene, what: &str) {
    assert_eq!(packed.room, None, "{what}");
    assert_eq!(packed.lights.len(), 2, "{what}");
    for l in &packed.lights {
        assert_eq!(l.area, 4e6, "{what}: {l:?}");
        assert_eq!(v(l.edge1).length(), 2000.0, "{what}: {l:?}");
        assert_eq!(l.solid_angle, 0, "{what}: no room, no wall: by area");
    }
}

#[test]
fn an_open_room_clips_nothing() {
    let walls = common::room_walls();
    // The floor left out, made of glass (paths pass it), too short to close the room (range
    // 500 < 1000, the back-to-front depth) or facing down (the camera behind it).
    let floors = [
        ("no floor", None),
        (
            "glass floor",
            Some("MaterialIndex 2 Plane { normal 0 1 0 offset 0 range 1000 }"),
        ),
        (
            "short floor",
            Some("MaterialIndex 1 Plane { normal 0 1 0 offset 0 range 500 }"),
        ),
        (
            "floor facing down",
            Some("MaterialIndex 1 Plane { normal 0 -1 0 offset 0 range 1000 }"),
        ),
    ];
    for (what, floor) in floors {
        let mut objects = walls[..5].to_vec();
        objects.extend(floor.map(String::from));
        assert_unclipped(
            &pack(&common::room_scene("center 0 60 500", &objects)),
            what,
        );
    }
    // The short floor of range 999.99 fails by 0.01; at range 1000 the room closes.
    let mut objects = walls[..5].to_vec();
    objects.push("MaterialIndex 1 Plane { normal 0 1 0 offset 0 range 999.99 }".into());
    assert_unclipped(
        &pack(&common::room_scene("center 0 60 500", &objects)),
        "999.99",
    );
}

/// A floor whose type map picks diffuse or mirror per texel closes the room (case0's and
/// case3's floors); one glass texel opens it, as paths may pass the floor there.
#[test]
fn a_floor_with_a_type_map_closes_the_room_unless_a_texel_is_glass() {
    let dir = std::env::temp_dir().join(format!("clpt-lights-{}-type-map", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut walls = common::room_walls();
    walls[5] = "MaterialIndex 5 Plane { normal 0 1 0 offset 0 range 1000 \
                centerp 0 0 0 dirU 0.01 0 0 dirV 0 0 0.01 }"
        .into();
    // Red: diffuse, green: mirror, blue: glass (the original's type rule).
    for (texels, closed) in [("255 0 0  0 255 0", true), ("255 0 0  0 0 255", false)] {
        let map = dir.join(format!("type-{closed}.ppm"));
        std::fs::write(&map, format!("P3\n2 1\n255\n{texels}\n")).unwrap();
        let floor = format!("Material {{ texture {{ type {} }} }}", map.display());
        let packed = pack(&common::room_scene_with(
            "center 0 60 500",
            &[floor],
            &walls,
        ));
        if closed {
            assert_case2_room(packed.room.as_ref());
            assert_case2_lights(&packed.lights);
        } else {
            assert_unclipped(&packed, "a glass texel in the floor's type map");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_camera_outside_the_room_or_a_lens_through_a_wall_clips_nothing() {
    let walls = common::room_walls();
    for (what, camera) in [
        ("behind the front wall", "center 0 60 1100"),
        ("beside the room", "center 150 60 500"),
        ("on the wall x = 100", "center 100 60 500"),
        // A thin lens of radius 4 at x = 97 reaches x = 101 (its square spans x and y).
        (
            "lens through x = 100",
            "center 97 60 500 flength 400 aperture 4",
        ),
        (
            "lens through the floor",
            "center 0 3 500 flength 400 aperture 4",
        ),
    ] {
        assert_unclipped(&pack(&common::room_scene(camera, &walls)), what);
    }
    // A lens of radius 2 there stays inside: clipped as usual.
    for camera in [
        "center 97 60 500 flength 400 aperture 2",
        "center 0 3 500 flength 400 aperture 2",
    ] {
        let packed = pack(&common::room_scene(camera, &walls));
        assert_case2_room(packed.room.as_ref());
        assert_case2_lights(&packed.lights);
    }
}

/// A lamp panel hung under the ceiling, facing down to the camera like a wall but covering
/// little: the room is still closed by the ceiling behind it, and the panel is listed whole.
#[test]
fn a_lamp_panel_under_the_ceiling_does_not_open_the_room() {
    let mut objects = common::room_walls();
    objects.push("MaterialIndex 3 Plane { normal 0 -1 0 offset -150 range 20 }".into());
    let packed = pack(&common::room_scene("center 0 60 500", &objects));
    assert_case2_room(packed.room.as_ref());
    assert_case2_lights(&packed.lights);
    let panel = plane_light(&packed.lights, 6);
    assert_eq!(panel.area, 1600.0);
    assert_eq!(v(panel.corner), DVec3::new(-20.0, 150.0, -20.0));
    assert_eq!(panel.solid_angle, 0, "not a wall: sampled by area");
}

/// Emitters no point of the room sees are dropped: a square above the ceiling facing down
/// (wholly outside), one on the ceiling's plane facing up (seen from behind only) and a mesh
/// quad above the ceiling; the quad inside keeps both its triangles.
#[test]
fn emitters_and_triangles_no_point_of_the_room_sees_are_dropped() {
    let dir = std::env::temp_dir().join(format!("clpt-lights-{}-dropped", std::process::id()));
    let scene = common::clipped_room_scene(&dir);
    let objects = [
        "MaterialIndex 3 Plane { normal 0 -1 0 offset -170 range 50 }",
        "MaterialIndex 3 Plane { normal 0 1 0 offset 160 range 50 }",
    ]
    .map(String::from);
    let mut all = scene.clone();
    all.objects
        .extend(common::room_scene("center 0 60 500", &objects).objects);
    let packed = pack(&all);
    let mut outside = all.clone();
    outside.camera.center = DVec3::new(0.0, 60.0, 1100.0);
    let unclipped = pack(&outside);
    let _ = std::fs::remove_dir_all(&dir);
    let keys: Vec<(u32, u32, u32)> = packed
        .lights
        .iter()
        .map(|l| (l.kind, l.index, l.triangle))
        .collect();
    // Planes: ceiling 0, front wall 1, the panel 6 (and not 7, 8). Meshes: instance 0 (inside)
    // and not 1 (above the ceiling).
    assert_eq!(
        keys,
        [
            (OBJECT_PLANE, 0, 0),
            (OBJECT_PLANE, 1, 0),
            (OBJECT_PLANE, 6, 0),
            (OBJECT_MESH, 0, 0),
            (OBJECT_MESH, 0, 1)
        ]
    );
    // The quad's triangles are whole: 30 x 30 between them.
    let area: f64 = packed.lights[3..].iter().map(|l| f64::from(l.area)).sum();
    assert!(close(area, 900.0, 1e-6), "{area}");
    // With the camera outside, nothing is clipped nor dropped.
    assert_eq!(unclipped.lights.len(), 9);
}

/// The part of the parallelogram `corner + e1 u + e2 v` (u, v in [0, 1]) in the box lo..hi:
/// every random point of it lies in `light`'s parallelogram, and on a 400 x 400 grid the
/// light's area is within 2% of its points' bounding rectangle (in u, v).
fn assert_holds_part_in_room(light: &Light, corner: DVec3, e1: DVec3, e2: DVec3, what: &str) {
    let (lc, l1, l2) = (v(light.corner), v(light.edge1), v(light.edge2));
    let (g11, g12, g22) = (l1.dot(l1), l1.dot(l2), l2.dot(l2));
    let det = g11 * g22 - g12 * g12;
    let inside = |p: DVec3| p.cmpge(ROOM_LO).all() && p.cmple(ROOM_HI).all();
    let holds = |p: DVec3| {
        let r = p - lc;
        let (r1, r2) = (l1.dot(r), l2.dot(r));
        let a = (g22 * r1 - g12 * r2) / det;
        let b = (g11 * r2 - g12 * r1) / det;
        let off_plane = (r - l1 * a - l2 * b).length();
        let slack = 1e-5;
        (-slack..=1.0 + slack).contains(&a)
            && (-slack..=1.0 + slack).contains(&b)
            && off_plane < 1e-3
    };
    let mut rng = SmallRng::seed_from_u64(12);
    let mut tried = 0;
    for _ in 0..40_000 {
        let (u, w) = (rng.random_range(0.0..=1.0), rng.random_range(0.0..=1.0));
        let p = corner + e1 * u + e2 * w;
        if inside(p) {
            tried += 1;
            assert!(
                holds(p),
                "{what}: {p} (u {u}, v {w}) is in the room, not in {light:?}"
            );
        }
    }
    assert!(
        tried > 100,
        "{what}: only {tried} random points in the room"
    );
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let n = 400;
    for i in 0..=n {
        for j in 0..=n {
            let (u, w) = (i as f64 / n as f64, j as f64 / n as f64);
            let p = corner + e1 * u + e2 * w;
            if inside(p) {
                assert!(holds(p), "{what}: {p} is in the room, not in {light:?}");
                lo = [lo[0].min(u), lo[1].min(w)];
                hi = [hi[0].max(u), hi[1].max(w)];
            }
        }
    }
    let bounding = e1.cross(e2).length() * (hi[0] - lo[0]) * (hi[1] - lo[1]);
    let area = f64::from(light.area);
    assert!(
        area >= 0.999 * bounding && area <= 1.02 * bounding,
        "{what}: area {area}, its part in the room bounded by {bounding}"
    );
    assert!(
        close(l1.cross(l2).length(), area, 1e-5),
        "{what}: {light:?}"
    );
}

#[test]
fn random_points_of_the_emitters_in_the_room_lie_in_their_clipped_regions() {
    let dir = std::env::temp_dir().join(format!("clpt-lights-{}-points", std::process::id()));
    let packed = pack(&common::clipped_room_scene(&dir));
    let _ = std::fs::remove_dir_all(&dir);
    assert_case2_room(packed.room.as_ref());
    // The panel's own square |x|, |z| <= 30 at y = 0, in the world.
    let m = common::room_panel_transform();
    let corner = m.transform_point3(DVec3::new(-30.0, 0.0, -30.0));
    let (ex, ez) = (
        m.transform_vector3(DVec3::new(60.0, 0.0, 0.0)),
        m.transform_vector3(DVec3::new(0.0, 0.0, 60.0)),
    );
    let panel = plane_light(&packed.lights, 6);
    assert!(
        f64::from(panel.area) < 0.8 * 3600.0 && panel.area > 0.0,
        "the panel pokes through three walls: {panel:?}"
    );
    assert_holds_part_in_room(panel, corner, ex, ez, "panel");
    // It still faces its own side, -y turned by the transform.
    let n = m.transform_vector3(DVec3::NEG_Y).normalize();
    assert!(v(panel.normal).dot(n) > 1.0 - 1e-6);
    assert!(v(panel.edge1).cross(v(panel.edge2)).normalize().dot(n) > 1.0 - 1e-6);
    // The ceiling and the front wall, from their whole squares.
    let (x, y, z) = (DVec3::X * 2000.0, DVec3::Y * 2000.0, DVec3::Z * 2000.0);
    let ceiling = DVec3::new(-1000.0, 160.0, -1000.0);
    assert_holds_part_in_room(plane_light(&packed.lights, 0), ceiling, x, z, "ceiling");
    let front = DVec3::new(-1000.0, -1000.0, 1000.0);
    assert_holds_part_in_room(plane_light(&packed.lights, 1), front, x, y, "front wall");
}

/// Sphere lights sunk into walls (lights.rs, `visible_cap`): smallpt's light, a sphere of radius
/// 600 sunk into the ceiling (itself a sphere of radius 1e5 around the room) all but 0.27, is
/// sampled over the cap below the ceiling, and carries that cap's area in its power.
#[test]
fn smallpt_s_light_is_sampled_over_the_cap_below_the_ceiling() {
    let packed = pack(&clpt::scene::builtin::scene().unwrap());
    let l = packed
        .lights
        .iter()
        .find(|l| l.kind == OBJECT_SPHERE)
        .expect("smallpt's light");
    let (c, r) = (v(l.corner), f64::from(l.radius));
    let h = f64::from(l.cap_height);
    // The ceiling's sphere: centre y = -1e5 + 81.6, radius 1e5; the light's bottom at 81.33.
    let depth = (c.y - r) - (81.6 - 1e5 + 1e5);
    assert!(depth < 0.0, "the light pokes below the ceiling");
    assert!(near(v(l.normal), DVec3::NEG_Y, 1e-6), "axis {:?}", l.normal);
    // The cap reaches from the light's bottom up to the ceiling, and a little tolerance more.
    assert!(
        h > -depth && h < -depth + 0.1,
        "cap height {h}, depth {}",
        -depth
    );
    assert!(close(f64::from(l.area), 2.0 * PI * r * h, 1e-6));
    // Every point of the light below the ceiling (the rim of the cap included) is in the cap.
    let mut rng = SmallRng::seed_from_u64(5);
    let mut below = 0;
    for _ in 0..200_000 {
        let q = c + DVec3::new(
            rng.random::<f64>() - 0.5,
            -rng.random::<f64>(),
            rng.random::<f64>() - 0.5,
        )
        .normalize()
            * r;
        let ceiling = DVec3::new(50.0, 81.6 - 1e5, 81.6);
        if (q - ceiling).length() < 1e5 {
            below += 1;
            assert!(
                (q - c).dot(DVec3::NEG_Y) >= r - h,
                "{q} below the ceiling, off the cap"
            );
        }
    }
    assert!(below > 0, "no point below the ceiling drawn");
}

/// A sphere light wholly outside the closed room, or inside an opaque ball the camera is outside
/// of, is dropped; one free in the room keeps all of itself; one poking through a wall of the
/// room is cut at it.
#[test]
fn sphere_lights_keep_what_the_room_and_opaque_balls_leave_visible() {
    let text = |extra: &str| {
        format!(
            "PerspectiveCamera {{ center 0 1 3 direction 0 0 -1 angle 40 width 8 height 6 }}\n\
             Materials {{ numMaterials 3 Material {{ color 0.5 0.5 0.5 }} \
               Material {{ emission 4 4 4 }} Material {{ color 0.5 0.5 0.5 type refr }} }}\n\
             Group {{ numObjects 10 MaterialIndex 0 \
               Plane {{ normal 0 1 0 offset 0 range 10 }} Plane {{ normal 0 -1 0 offset -4 range 10 }} \
               Plane {{ normal 1 0 0 offset -2 range 10 }} Plane {{ normal -1 0 0 offset -2 range 10 }} \
               Plane {{ normal 0 0 1 offset -2 range 10 }} Plane {{ normal 0 0 -1 offset -5 range 10 }} \
               Sphere {{ center 1 1 -1 radius 0.8 }} {extra} }}\n"
        )
    };
    let sphere = |scene: &str| {
        let scene =
            clpt::scene::parse::parse_scene(scene, "caps").unwrap_or_else(|e| panic!("{e}"));
        let packed = pack(&scene);
        packed
            .lights
            .iter()
            .find(|l| l.kind == OBJECT_SPHERE)
            .copied()
    };
    // Free in the room: the whole sphere.
    let free = sphere(&text(
        "MaterialIndex 1 Sphere { center -1 2 -1 radius 0.3 }",
    ))
    .unwrap();
    assert_eq!(free.cap_height, 0.0);
    // Sunk 0.5 into the ceiling (y = 4): the cap below it, 0.3 high (and tolerance).
    let sunk = sphere(&text(
        "MaterialIndex 1 Sphere { center -1 4.1 -1 radius 0.4 }",
    ))
    .unwrap();
    assert!(near(v(sunk.normal), DVec3::NEG_Y, 1e-9), "{sunk:?}");
    assert!((f64::from(sunk.cap_height) - 0.3).abs() < 1e-3, "{sunk:?}");
    // Poking only 0.2 through: more than a hemisphere left, sampled whole (by its cone).
    let poking = sphere(&text(
        "MaterialIndex 1 Sphere { center -1 3.8 -1 radius 0.4 }",
    ))
    .unwrap();
    assert_eq!(poking.cap_height, 0.0);
    // Inside the opaque ball at (1, 1, -1): nothing to see; inside a glass ball: all of it.
    assert!(sphere(&text("MaterialIndex 1 Sphere { center 1 1 -1 radius 0.3 }")).is_none());
    let glass = text(
        "MaterialIndex 2 Sphere { center -1 1 -1 radius 0.8 } \
         MaterialIndex 1 Sphere { center -1 1 -1 radius 0.3 }",
    );
    assert_eq!(sphere(&glass).unwrap().cap_height, 0.0);
    // Mostly buried in the opaque ball (centre 0.7 from the ball's, radii 0.2 and 0.8): the cap
    // outside it, up to the circle where the spheres meet, 0.2 - (0.8² - 0.7² - 0.2²) / 1.4 =
    // 0.1214 high.
    let buried = sphere(&text(
        "MaterialIndex 1 Sphere { center 1 1.7 -1 radius 0.2 }",
    ))
    .unwrap();
    assert!(near(v(buried.normal), DVec3::Y, 1e-6), "{buried:?}");
    let h = 0.2 - (0.8f64 * 0.8 - 0.7 * 0.7 - 0.2 * 0.2) / 1.4;
    assert!(
        (f64::from(buried.cap_height) - h).abs() < 1e-4,
        "{buried:?}, {h}"
    );
    // Wholly outside the room (beyond the ceiling): dropped.
    assert!(
        sphere(&text(
            "MaterialIndex 1 Sphere { center -1 5 -1 radius 0.3 }"
        ))
        .is_none()
    );
}
