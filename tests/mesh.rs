//! Meshes and acceleration on the device: watertightness (1e6 rays aimed at shared edges and
//! vertices of closed meshes never pass through, nor rays along the axes or from afar), the
//! kd-tree and BVH traversal against brute force in f64 (generated meshes; the Stanford dragon
//! when ../shared/seed is there), transforms of spheres, planes and meshes against f64 for every
//! op and compositions, instancing, and bad OBJ input (errors at their line, file limits,
//! directories, copies of triangles dropped).

mod common;

use clpt::contract::{OBJECT_MESH, OBJECT_PLANE, OBJECT_SPHERE};
use clpt::pack::PackedScene;
use clpt::render::MeshTree;
use clpt::scene::Scene;
use clpt::scene::mesh::{self, TriangleMesh};
use common::procedural;
use common::traversal::kd_intersect;
use glam::{DMat4, DVec3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::path::{Path, PathBuf};

/// What the hit probe records for a mesh hit (kind, as a float).
const HIT_MESH: f32 = OBJECT_MESH as f32;

fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-mesh-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A scene file in `dir` with `objects` in its group (one grey material).
fn scene_in(dir: &Path, objects: &str) -> Scene {
    let text = format!(
        "PerspectiveCamera {{ center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }}\n\
         Materials {{ numMaterials 1 Material {{ color 0.5 0.5 0.5 }} }}\n\
         Group {{ numObjects 1 {objects} }}\n"
    );
    let path = dir.join("scene.txt");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn pack(scene: &Scene) -> PackedScene {
    PackedScene::new(scene, u64::MAX).unwrap_or_else(|e| panic!("{e}"))
}

/// The device's hits of `rays` in `scene` by every mesh traversal: kd-trees (the original's),
/// binary BVHs (accel/bvh2.rs, kernels/bvh2.h; a GPU's default) and 8-wide BVHs
/// (accel/wide_bvh.rs, kernels/wide_bvh.h; a CPU's) in the program of 16 lanes a work-item and
/// in the one-lane program.
fn probe_every_tree(
    device: &clpt::device::Device,
    scene: &Scene,
    rays: &[[f32; 9]],
) -> [(&'static str, Vec<[f32; 16]>); 4] {
    let with = |tree: MeshTree| {
        PackedScene::with_limits(scene, u64::MAX, mesh::DEFAULT_MAX_FILE_BYTES, tree)
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let (bvh2, wide) = (with(MeshTree::Bvh2), with(MeshTree::Wide));
    [
        ("kd-tree", common::probe_hits(device, &pack(scene), rays)),
        (
            "binary BVH",
            common::probe_hits_mesh_tree(device, &bvh2, rays),
        ),
        (
            "wide BVH",
            common::probe_hits_in_lanes(device, &wide, rays, 16),
        ),
        (
            "wide BVH, one lane",
            common::probe_hits_mesh_tree(device, &wide, rays),
        ),
    ]
}

fn ray(o: DVec3, d: DVec3) -> [f32; 9] {
    let (o, d) = (o.as_vec3().to_array(), d.normalize().as_vec3().to_array());
    [o[0], o[1], o[2], d[0], d[1], d[2], 0.0, 0.0, 1.0]
}

fn parts(r: &[f32; 9]) -> (DVec3, DVec3) {
    let v = |i: usize| DVec3::new(r[i] as f64, r[i + 1] as f64, r[i + 2] as f64);
    (v(0), v(3))
}

fn vertex(mesh: &TriangleMesh, i: u32) -> DVec3 {
    DVec3::from(mesh.positions[i as usize].map(f64::from))
}

/// Möller–Trumbore in f64: (t, u, v) of the ray's line with the triangle's plane, `None` when
/// parallel; u, v are the weights of the second and third vertex (outside [0, 1] = miss).
fn moller_trumbore(o: DVec3, d: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    Some((e2.dot(q) / det, u, v))
}

/// How far inside its triangle a (u, v) point lies: > 0 inside, < 0 outside, 0 on an edge.
fn inside_margin(u: f64, v: f64) -> f64 {
    u.min(v).min(1.0 - u - v)
}

/// The nearest hit by brute force: (t, triangle, u, v).
fn brute_force(mesh: &TriangleMesh, o: DVec3, d: DVec3) -> Option<(f64, u32, f64, f64)> {
    let mut best: Option<(f64, u32, f64, f64)> = None;
    for (i, t) in mesh.triangles.iter().enumerate() {
        let hit = moller_trumbore(
            o,
            d,
            vertex(mesh, t[0]),
            vertex(mesh, t[1]),
            vertex(mesh, t[2]),
        );
        if let Some((th, u, v)) = hit
            && inside_margin(u, v) >= 0.0
            && th > 0.0
            && best.is_none_or(|b| th < b.0)
        {
            best = Some((th, i as u32, u, v));
        }
    }
    best
}

/// Compares device hits with the f64 nearest hit. A disagreement is allowed only where the f64
/// answer itself is within `edge` (barycentric) of an edge: there the f32 ray may fall on either
/// side, and either answer is right.
fn check_against(
    mesh: &TriangleMesh,
    rays: &[[f32; 9]],
    got: &[[f32; 16]],
    want: impl Fn(DVec3, DVec3) -> Option<(f64, u32, f64, f64)>,
    what: &str,
) -> usize {
    let edge = 1e-4;
    let mut compared = 0;
    for (r, g) in rays.iter().zip(got) {
        let (o, d) = parts(r);
        let w = want(o, d);
        let device = (g[1] == HIT_MESH).then(|| (g[0] as f64, g[13]));
        match (w, device) {
            (Some((t, _, u, v)), Some((tg, _))) => {
                compared += 1;
                if (tg - t).abs() > 1e-4 * t + 1e-5 {
                    // A different surface: only if the f64 hit grazes an edge.
                    assert!(
                        inside_margin(u, v) < edge,
                        "{what}: t {tg} vs f64 {t} (o {o}, d {d})"
                    );
                } else {
                    // The same place: the surface the device built from the triangle it
                    // names (its vertices and barycentrics) lies where the ray meets it.
                    let p = DVec3::new(g[3] as f64, g[4] as f64, g[5] as f64);
                    let want_p = o + d.normalize() * t;
                    assert!(
                        (p - want_p).length() <= 1e-4 * t + 1e-5 * (1.0 + want_p.length()),
                        "{what}: surface point {p} vs f64 {want_p} (o {o}, d {d})"
                    );
                }
            }
            (Some((t, _, u, v)), None) => {
                assert!(
                    inside_margin(u, v) < edge,
                    "{what}: device missed, f64 hit at t {t} (o {o}, d {d})"
                );
            }
            (None, Some((tg, _))) => {
                // The f64 ray must pass within `edge` of some triangle near the device's t.
                let near_edge = mesh.triangles.iter().any(|t| {
                    moller_trumbore(
                        o,
                        d,
                        vertex(mesh, t[0]),
                        vertex(mesh, t[1]),
                        vertex(mesh, t[2]),
                    )
                    .is_some_and(|(th, u, v)| {
                        (th - tg).abs() <= 1e-4 * th + 1e-5 && inside_margin(u, v) > -edge
                    })
                });
                assert!(
                    near_edge,
                    "{what}: device hit at t {tg}, f64 missed (o {o}, d {d})"
                );
            }
            (None, None) => {}
        }
    }
    compared
}

fn write_mesh(dir: &Path, name: &str, mesh: &TriangleMesh) -> PathBuf {
    let path = dir.join(name);
    procedural::write_obj(mesh, &path, "test mesh").unwrap();
    path
}

/// How a watertightness test's rays leave the surface point they are aimed at.
#[derive(Clone, Copy)]
enum Approach {
    /// Any direction within the cone of the normals of the triangles meeting there.
    Oblique,
    /// Along an axis only: aimed at a vertex, the ray lies in the planes of the box faces
    /// through it, with an infinite inverse direction on two axes (kernels/aabb.h, bvh2.h).
    AxisParallel,
}

/// Rays from outside a closed mesh, each aimed at a point of an edge that two triangles share
/// (a third of them at a vertex), from `distance` away, coming `approach`; with each the
/// distance to its point.
fn rays_at_shared_points(
    loaded: &TriangleMesh,
    rng: &mut SmallRng,
    count: usize,
    approach: Approach,
    distance: std::ops::Range<f64>,
) -> (Vec<[f32; 9]>, Vec<f64>) {
    // Which triangles meet at each edge and each vertex.
    let mut at_edge: std::collections::HashMap<(u32, u32), Vec<usize>> = Default::default();
    let mut at_vertex: Vec<Vec<usize>> = vec![Vec::new(); loaded.positions.len()];
    for (i, t) in loaded.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            at_edge.entry((a.min(b), a.max(b))).or_default().push(i);
            at_vertex[a as usize].push(i);
        }
    }
    let normal = |i: usize| {
        let t = loaded.triangles[i];
        let (a, b, c) = (
            vertex(loaded, t[0]),
            vertex(loaded, t[1]),
            vertex(loaded, t[2]),
        );
        (b - a).cross(c - a).normalize()
    };
    let (mut rays, mut dists) = (Vec::with_capacity(count), Vec::with_capacity(count));
    while rays.len() < count {
        let t = loaded.triangles[rng.random_range(0..loaded.triangles.len())];
        let k = rng.random_range(0..3);
        let (ia, ib) = (t[k], t[(k + 1) % 3]);
        let (a, b) = (vertex(loaded, ia), vertex(loaded, ib));
        // A point on a shared edge, a third of the time exactly a vertex.
        let at_a = rng.random_range(0..3) == 0;
        let s = if at_a { 0.0 } else { rng.random::<f64>() };
        let p = a + (b - a) * s;
        let meeting = if at_a {
            &at_vertex[ia as usize]
        } else {
            &at_edge[&(ia.min(ib), ia.max(ib))]
        };
        let n: DVec3 = meeting
            .iter()
            .map(|&i| normal(i))
            .sum::<DVec3>()
            .normalize();
        let dir_out = match approach {
            Approach::Oblique => (n + common::random_unit(rng) * 0.8).normalize(),
            Approach::AxisParallel => {
                let mut axis = DVec3::ZERO;
                axis[rng.random_range(0..3)] = if rng.random::<bool>() { 1.0 } else { -1.0 };
                axis
            }
        };
        // From outside every triangle meeting there (not grazing any of them), so the ray
        // truly crosses the surface at p.
        if meeting.iter().any(|&i| dir_out.dot(normal(i)) <= 0.2) {
            continue;
        }
        let dist = rng.random_range(distance.clone());
        let o = p + dir_out * dist;
        rays.push(ray(o, p - o));
        dists.push(dist);
    }
    (rays, dists)
}

/// The rays of [`rays_at_shared_points`] that passed through `name` with some mesh tree: no
/// mesh hit up to their aimed-at point (the origin rounded to f32 moves a far ray's point by
/// up to 1e-4 of its distance).
fn passed_through(
    device: &clpt::device::Device,
    scene: &Scene,
    (rays, dists): &(Vec<[f32; 9]>, Vec<f64>),
    what: &str,
) -> usize {
    let mut passed = 0;
    for (accel, got) in probe_every_tree(device, scene, rays) {
        for (g, dist) in got.iter().zip(dists) {
            if g[1] != HIT_MESH || g[0] as f64 > dist * (1.0 + 1e-4) + 1e-5 {
                if passed < 5 {
                    eprintln!("{what}, {accel}: kind {} t {} want <= {dist}", g[1], g[0]);
                }
                passed += 1;
            }
        }
    }
    passed
}

/// The closed meshes of the watertightness tests, written to `dir`, each with its scene.
fn closed_meshes(dir: &Path) -> Vec<(&'static str, TriangleMesh, Scene)> {
    [
        ("icosphere.obj", procedural::icosphere(4)),
        ("torus.obj", procedural::torus(1.0, 0.35, 96, 48)),
    ]
    .into_iter()
    .map(|(name, mesh)| {
        write_mesh(dir, name, &mesh);
        // Reload as the renderer does (f32 positions from the OBJ text).
        let scene = scene_in(dir, &format!("Mesh {{ obj_file {name} }}"));
        (name, TriangleMesh::load(&dir.join(name)).unwrap(), scene)
    })
    .collect()
}

#[test]
fn rays_at_shared_edges_and_vertices_never_pass_through() {
    let dir = temp_dir("watertight");
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(41);
    for (name, loaded, scene) in closed_meshes(&dir) {
        let rays = rays_at_shared_points(&loaded, &mut rng, 500_000, Approach::Oblique, 0.05..2.0);
        let passed = passed_through(&device, &scene, &rays, name);
        assert_eq!(
            passed, 0,
            "{name}: {passed} of 500000 rays (each traversal) passed through"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The box tests' corner cases: rays along an axis, whose inverse direction is infinite on the
/// other two and which lie in the planes of the boxes' faces where they meet a vertex
/// (kernels/aabb.h, slab_inverse), and origins 10^3 to 10^5 away, where the binary BVH's
/// o * (1 / d) carries a large absolute error (kernels/bvh2.h, bvh2_slabs).
#[test]
fn rays_along_axes_and_from_afar_never_pass_through() {
    let dir = temp_dir("watertight-axes");
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(43);
    for (name, loaded, scene) in closed_meshes(&dir) {
        for (approach, distance, what) in [
            (Approach::AxisParallel, 0.05..2.0, "along an axis"),
            (Approach::AxisParallel, 1e3..1e5, "along an axis from afar"),
            (Approach::Oblique, 1e3..1e5, "from afar"),
        ] {
            let rays = rays_at_shared_points(&loaded, &mut rng, 60_000, approach, distance);
            let what = format!("{name}, {what}");
            let passed = passed_through(&device, &scene, &rays, &what);
            assert_eq!(
                passed, 0,
                "{what}: {passed} of 60000 rays (each traversal) passed through"
            );
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn kdtree_traversal_matches_brute_force_on_generated_meshes() {
    let dir = temp_dir("brute");
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(42);
    for (name, mesh) in [
        ("ico.obj", procedural::icosphere(3)),
        ("torus.obj", procedural::torus(1.0, 0.3, 48, 24)),
        ("knot.obj", procedural::torus_knot(2, 3, 0.35, 160, 16)),
    ] {
        write_mesh(&dir, name, &mesh);
        let loaded = TriangleMesh::load(&dir.join(name)).unwrap();
        let scene = scene_in(&dir, &format!("Mesh {{ obj_file {name} }}"));
        let bounds = clpt::accel::aabb::Aabb::from_points(
            loaded
                .positions
                .iter()
                .map(|p| DVec3::from(p.map(f64::from))),
        );
        let c = bounds.center();
        let size = bounds.extent().length();
        let rays: Vec<[f32; 9]> = (0..100_000)
            .map(|i| {
                let o = if i % 5 == 0 {
                    c + common::random_unit(&mut rng) * size * 0.2
                } else {
                    c + common::random_unit(&mut rng) * size * rng.random_range(0.6..2.0)
                };
                let target = c + common::random_unit(&mut rng) * size * rng.random_range(0.0..0.6);
                ray(o, target - o)
            })
            .collect();
        for (accel, got) in probe_every_tree(&device, &scene, &rays) {
            let what = format!("{name}, {accel}");
            let compared = check_against(
                &loaded,
                &rays,
                &got,
                |o, d| brute_force(&loaded, o, d),
                &what,
            );
            assert!(compared > 25_000, "{what}: only {compared} hits compared");
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn dragon_traversal_matches_host_tree_and_brute_force() {
    let Some(seed) = common::seed_dir("dragon_traversal_matches_host_tree_and_brute_force") else {
        return;
    };
    let path = seed.join("mesh/dragon_100k.obj");
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(43);
    let dir = temp_dir("dragon");
    let scene = scene_in(&dir, &format!("Mesh {{ obj_file {} }}", path.display()));
    let mesh = TriangleMesh::load(&path).unwrap();
    let tree =
        clpt::accel::kdtree::KdTree::build(&mesh.positions, &mesh.triangles, &Default::default());
    let rays: Vec<[f32; 9]> = (0..100_000)
        .map(|_| {
            let o = common::random_unit(&mut rng) * rng.random_range(1.5..4.0);
            let target = common::random_unit(&mut rng) * rng.random_range(0.0..0.8);
            ray(o, target - o)
        })
        .collect();
    let host = |o: DVec3, d: DVec3| {
        kd_intersect(
            &tree,
            &mesh.positions,
            &mesh.triangles,
            o,
            d,
            0.0,
            f64::INFINITY,
        )
        .map(|(t, tri)| {
            let tv = mesh.triangles[tri as usize];
            let (_, u, v) = moller_trumbore(
                o,
                d,
                vertex(&mesh, tv[0]),
                vertex(&mesh, tv[1]),
                vertex(&mesh, tv[2]),
            )
            .unwrap_or((t, 0.5, 0.25));
            (t, tri, u, v)
        })
    };
    for (accel, got) in probe_every_tree(&device, &scene, &rays) {
        let what = format!("dragon ({accel}) vs host kd-tree");
        let compared = check_against(&mesh, &rays[..], &got, host, &what);
        assert!(compared > 30_000, "{what}: only {compared} hits compared");
        let what = format!("dragon ({accel}) vs brute force");
        let brute = check_against(
            &mesh,
            &rays[..300],
            &got[..300],
            |o, d| brute_force(&mesh, o, d),
            &what,
        );
        assert!(brute > 60, "{what}: only {brute} hits compared");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The course framework's composition, written out independently of the parser: each op
/// multiplies on the right, `Matrix4f` (column by column) on the left.
fn compose(ops: &[(&str, &[f64])]) -> DMat4 {
    let mut m = DMat4::IDENTITY;
    for (op, v) in ops {
        let v3 = || DVec3::new(v[0], v[1], v[2]);
        match *op {
            "Scale" => m *= DMat4::from_scale(v3()),
            "UniformScale" => m *= DMat4::from_scale(DVec3::splat(v[0])),
            "Translate" => m *= DMat4::from_translation(v3()),
            "XRotate" => m *= DMat4::from_rotation_x(v[0].to_radians()),
            "YRotate" => m *= DMat4::from_rotation_y(v[0].to_radians()),
            "ZRotate" => m *= DMat4::from_rotation_z(v[0].to_radians()),
            "Rotate" => m *= DMat4::from_axis_angle(v3().normalize(), v[3].to_radians()),
            "Matrix4f" => m = DMat4::from_cols_slice(v) * m,
            _ => unreachable!(),
        }
    }
    m
}

fn op_text(ops: &[(&str, &[f64])]) -> String {
    ops.iter()
        .map(|(op, v)| {
            let nums = v
                .iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(" ");
            match *op {
                "Rotate" | "Matrix4f" => format!("{op} {{ {nums} }}"),
                _ => format!("{op} {nums}"),
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

const MATRIX: [f64; 16] = [
    1.0, 0.2, 0.0, 0.0, 0.0, 2.0, 0.1, 0.0, 0.3, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0, 1.0,
];

fn transform_cases() -> Vec<Vec<(&'static str, &'static [f64])>> {
    vec![
        vec![("Scale", &[2.0, 0.5, 1.5])],
        vec![("UniformScale", &[3.0])],
        vec![("Translate", &[1.0, -2.0, 3.0])],
        vec![("XRotate", &[30.0])],
        vec![("YRotate", &[-45.0])],
        vec![("ZRotate", &[90.0])],
        vec![("Rotate", &[1.0, 1.0, 0.0, 60.0])],
        vec![("Matrix4f", &MATRIX)],
        // case3's goblet and default-bak's surface, and a mix with a matrix in the middle.
        vec![
            ("Translate", &[0.0, 20.0, 90.0]),
            ("Scale", &[10.0, 10.0, 10.0]),
        ],
        vec![
            ("Scale", &[5.0, 5.0, 5.0]),
            ("Translate", &[0.0, 10.0, 0.0]),
            ("ZRotate", &[90.0]),
        ],
        vec![
            ("XRotate", &[20.0]),
            ("Matrix4f", &MATRIX),
            ("Translate", &[1.0, 1.0, 1.0]),
            ("Scale", &[1.0, 3.0, 0.5]),
        ],
    ]
}

#[test]
fn transformed_spheres_planes_and_meshes_match_f64() {
    let dir = temp_dir("transforms");
    write_mesh(&dir, "ico.obj", &procedural::icosphere(2));
    let ico = TriangleMesh::load(&dir.join("ico.obj")).unwrap();
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(44);
    let sphere = clpt::contract::Sphere {
        center: [0.3, 0.1, -0.2],
        radius: 1.0,
        ..Default::default()
    };
    for ops in transform_cases() {
        let m = compose(&ops);
        let inv = m.inverse();
        for (object, kind) in [
            ("Sphere { center 0.3 0.1 -0.2 radius 1 }", OBJECT_SPHERE),
            ("Plane { normal 0 0 1 offset 0.25 range 2 }", OBJECT_PLANE),
            ("Mesh { obj_file ico.obj }", OBJECT_MESH),
        ] {
            let scene = scene_in(&dir, &format!("Transform {{ {} {object} }}", op_text(&ops)));
            let packed = pack(&scene);
            // The object's box, moved from the device's coordinates to the scene's.
            let world = packed.object_boxes[0];
            let (c, size) = (world.center() + packed.origin, world.extent().length());
            let rays: Vec<[f32; 9]> = (0..4000)
                .map(|_| {
                    let o = c + common::random_unit(&mut rng) * size * 1.5;
                    let target = c + common::random_unit(&mut rng) * size * 0.2;
                    ray(o, target - o)
                })
                .collect();
            let got = common::probe_hits(&device, &packed, &rays);
            let mut hits = 0;
            for (r, g) in rays.iter().zip(&got) {
                let (o, d) = parts(r);
                let (lo, ld) = (inv.transform_point3(o), inv.transform_vector3(d));
                // The reference in object space: t is the same along both rays.
                let want: Option<(f64, DVec3)> = match kind {
                    OBJECT_SPHERE => common::reference::sphere_roots(&sphere, lo, ld.normalize())
                        .and_then(|(t0, t1)| {
                            let len = ld.length();
                            [t0, t1].into_iter().find(|&t| t > 0.0).map(|t| {
                                (t / len, lo + ld * (t / len) - DVec3::new(0.3, 0.1, -0.2))
                            })
                        }),
                    OBJECT_PLANE => {
                        // Normal +z (the default), its box centred on n * offset as the
                        // scene's is.
                        let plane = clpt::contract::Plane {
                            offset: 0.25,
                            range: 2.0,
                            center: [0.0, 0.0, 0.25],
                            ..Default::default()
                        };
                        common::reference::plane_hit(&plane, lo, ld, f64::INFINITY)
                            .map(|t| (t, DVec3::Z))
                    }
                    _ => brute_force(&ico, lo, ld).map(|(t, tri, _, _)| {
                        let tv = ico.triangles[tri as usize];
                        let (a, b, cc) = (
                            vertex(&ico, tv[0]),
                            vertex(&ico, tv[1]),
                            vertex(&ico, tv[2]),
                        );
                        (t, (b - a).cross(cc - a))
                    }),
                };
                let device_hit = (g[1] == kind as f32).then(|| g[0] as f64);
                let Some((t, n_obj)) = want else {
                    // Rays that just miss may graze: only a clear device hit far inside is wrong.
                    continue;
                };
                let Some(tg) = device_hit else {
                    // A device miss next to an f64 hit: only at a silhouette.
                    let p = inv.transform_point3(o + d * t);
                    let grazing = match kind {
                        OBJECT_SPHERE => {
                            ((p - DVec3::new(0.3, 0.1, -0.2))
                                .normalize()
                                .dot(ld.normalize()))
                            .abs()
                                < 1e-2
                        }
                        OBJECT_PLANE => {
                            (p.x.abs().max(p.y.abs()) - 2.0).abs() < 1e-3
                                || ld.normalize().z.abs() < 1e-3
                        }
                        _ => true,
                    };
                    assert!(
                        grazing,
                        "{} {object}: device missed an f64 hit at t {t}",
                        op_text(&ops)
                    );
                    continue;
                };
                hits += 1;
                assert!(
                    (tg - t).abs() <= 1e-4 * t + 1e-4,
                    "{} {object}: t {tg} vs {t}",
                    op_text(&ops)
                );
                let p = DVec3::new(g[3] as f64, g[4] as f64, g[5] as f64);
                assert!(
                    (p - (o + d * t)).length() <= 1e-4 * (1.0 + (o + d * t).length()),
                    "{} {object}: point {p}",
                    op_text(&ops)
                );
                let n_world = inv.transpose().transform_vector3(n_obj).normalize();
                let n = DVec3::new(g[6] as f64, g[7] as f64, g[8] as f64);
                if kind != OBJECT_MESH {
                    assert!(
                        (n - n_world).length() < 1e-3,
                        "{} {object}: normal {n} vs {n_world}",
                        op_text(&ops)
                    );
                } else {
                    assert!(
                        n.dot(n_world).abs() > 0.999,
                        "{} {object}: normal {n} vs {n_world}",
                        op_text(&ops)
                    );
                }
            }
            // A one-sided plane is hit by the rays from its front only.
            let enough = if kind == OBJECT_PLANE { 100 } else { 500 };
            assert!(
                hits > enough,
                "{} {object}: only {hits} hits",
                op_text(&ops)
            );
        }
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn the_parser_composes_like_the_course_framework() {
    let dir = temp_dir("compose");
    for ops in transform_cases() {
        let scene = scene_in(
            &dir,
            &format!(
                "Transform {{ {} Sphere {{ center 0 0 0 radius 1 }} }}",
                op_text(&ops)
            ),
        );
        let got = scene.objects[0].transform.expect("a transform");
        let want = compose(&ops);
        assert!(
            got.abs_diff_eq(want, 1e-12),
            "{}: {got} vs {want}",
            op_text(&ops)
        );
    }
    // Nested transforms compose outer * inner.
    let scene = scene_in(
        &dir,
        "Transform { Translate 1 0 0 Transform { Scale 2 2 2 Sphere { center 0 0 0 radius 1 } } }",
    );
    let want = DMat4::from_translation(DVec3::X) * DMat4::from_scale(DVec3::splat(2.0));
    assert!(scene.objects[0].transform.unwrap().abs_diff_eq(want, 1e-12));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_meshes_and_transforms_are_clear_errors() {
    let dir = temp_dir("bad");
    let load = |name: &str, text: &str| {
        std::fs::write(dir.join(name), text).unwrap();
        TriangleMesh::load(&dir.join(name))
    };
    let err = load("range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("range.obj:4: corner `9` names vertex 9"),
        "{err}"
    );
    let err = load("nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("nan.obj") && err.contains("not a finite number"),
        "{err}"
    );
    let err = load("inf.obj", "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("inf.obj"), "{err}");
    let err = load("empty.obj", "# nothing\n").unwrap_err().to_string();
    assert!(
        err.contains("empty.obj") && err.contains("no triangles"),
        "{err}"
    );
    let err = load("flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("2 degenerate"), "{err}");
    let mesh = load(
        "some.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    )
    .unwrap();
    assert_eq!((mesh.triangles.len(), mesh.degenerate), (1, 1));
    // Missing files list where they were looked for.
    let path = dir.join("scene.txt");
    std::fs::write(&path, "PerspectiveCamera { center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }\nMaterials { numMaterials 1 Material { } }\nGroup { numObjects 1 Mesh { obj_file nowhere.obj } }\n").unwrap();
    let scene = Scene::load(&path).unwrap();
    let err = PackedScene::new(&scene, u64::MAX).unwrap_err().to_string();
    assert!(
        err.contains("scene.txt:3:22") && err.contains("mesh file `nowhere.obj` not found"),
        "{err}"
    );
    // Transform errors: singular, no object, two objects, unknown op.
    for (text, fragment) in [
        (
            "Transform { Scale 1 0 1 Sphere { center 0 0 0 radius 1 } }",
            "singular",
        ),
        ("Transform { Translate 1 2 3 }", "without an object"),
        (
            "Transform { Sphere { center 0 0 0 radius 1 } Sphere { center 0 0 0 radius 1 } }",
            "one object",
        ),
        (
            "Transform { Shear 1 Sphere { center 0 0 0 radius 1 } }",
            "Shear",
        ),
        (
            "Transform { Rotate { 0 0 0 30 } Sphere { center 0 0 0 radius 1 } }",
            "Rotate",
        ),
    ] {
        let full = format!(
            "PerspectiveCamera {{ center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }}\nMaterials {{ numMaterials 1 Material {{ }} }}\nGroup {{ numObjects 1 {text} }}\n"
        );
        let err = clpt::scene::parse::parse_scene(&full, "t.txt")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("t.txt:3:") && err.contains(fragment),
            "{text}: {err}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn case1_loads_its_dragon_once_and_renders_small() {
    let Some(seed) = common::seed_dir("case1_loads_its_dragon_once_and_renders_small") else {
        return;
    };
    let mut scene = Scene::load(&seed.join("testcases/case1_dof_mesh.txt")).unwrap();
    scene.camera.width = 48;
    scene.camera.height = 27;
    let device = common::device();
    let options = clpt::render::RenderOptions {
        spp: Some(4),
        ..Default::default()
    };
    let mut renderer = clpt::render::Renderer::new(
        &device,
        &scene,
        &clpt::device::program::KernelSources::Embedded,
        options,
    )
    .unwrap();
    let info = &renderer.packed.mesh_info;
    assert_eq!(info.len(), 1, "dragon_100k.obj loaded {} times", info.len());
    assert_eq!(info[0].instances, 3);
    let film = renderer.render(&mut |_| {}).unwrap().0;
    assert!(
        film.sum.iter().flatten().all(|v| v.is_finite()),
        "NaN or Inf in case1"
    );
}

/// The trefoil asset is a closed tube that bounds its inside, under a transform too: the 410000
/// of 2^21 rays from outside that hit it all meet its outer side, and rays spawned from those
/// hits back into the outside never reach its inner side. The first asset's tube frame jumped where the curve's tangent
/// passed near the frame's helper axis, and the quads there folded through each other: 61 rays
/// hit an inner side first, 148 spawned rays got inside, and in scenes/lights.txt, where the
/// knot emits with albedo 1, such paths brought samples of about 1e6.
#[test]
fn rays_from_outside_never_reach_the_inside_of_the_trefoil() {
    let dir = temp_dir("spawn");
    let knot = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/trefoil.obj");
    let scene = scene_in(
        &dir,
        &format!(
            "Transform {{ Translate -30 45 20 YRotate 30 XRotate 20 UniformScale 26 \
             Mesh {{ obj_file {} }} }}",
            knot.display()
        ),
    );
    let packed = pack(&scene);
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(5);
    let centre = DVec3::new(-30.0, 45.0, 20.0);
    let (mut hits, mut inner_first, mut spawned_on_knot, mut inside) = (0u64, 0u64, 0u64, 0u64);
    for _ in 0..2 {
        let rays: Vec<[f32; 9]> = (0..1 << 20)
            .map(|_| {
                let o = centre + common::random_unit(&mut rng) * 120.0;
                let d = (centre + common::random_unit(&mut rng) * 30.0 - o).normalize();
                // A cosine-distributed direction about the normal of the side the ray met.
                let (u1, u2): (f64, f64) = (rng.random(), rng.random());
                let (r, phi) = (u1.sqrt(), std::f64::consts::TAU * u2);
                let w = DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).sqrt());
                let (o, d, w) = (o.as_vec3(), d.as_vec3(), w.as_vec3());
                [o.x, o.y, o.z, d.x, d.y, d.z, w.x, w.y, w.z]
            })
            .collect();
        let out = common::probe_scene_rays(&device, &packed, "probe_spawn", &rays, 4);
        for r in out.chunks_exact(4) {
            if r[0] == 0.0 {
                continue; // missed the knot
            }
            hits += 1;
            // The tube's triangles wind inwards: a ray from outside meets dot(d, n) > 0.
            inner_first += u64::from(r[0] < 0.0);
            if r[1] == HIT_MESH {
                spawned_on_knot += 1;
                inside += u64::from(r[2] < 0.0);
            }
        }
    }
    assert!(
        hits > 300_000 && spawned_on_knot > 30_000,
        "{hits} hits, {spawned_on_knot} spawned"
    );
    assert_eq!(
        (inner_first, inside),
        (0, 0),
        "of {hits} rays from outside, {inner_first} met an inner side first; of \
         {spawned_on_knot} spawned rays that hit the knot again, {inside} hit it from inside"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every OBJ error that lies on a line names `path:line` (and the column for bytes that are
/// not UTF-8), with the offending text quoted and escaped; tobj reports no line.
#[test]
fn obj_errors_name_their_line() {
    let dir = temp_dir("lines");
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    for (name, text, want) in [
        (
            "nan.obj",
            "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
            ":2: `nan` is not a finite number",
        ),
        (
            "inf.obj",
            "v 0 0 0\nv 1 0 0\nv 0 -inf 0\nf 1 2 3\n",
            ":3: `-inf` is not a finite",
        ),
        (
            "f32.obj",
            "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
            ":2: `1e39` is beyond the range of f32",
        ),
        (
            "normal.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 -1e39\nf 1 2 3\n",
            ":4: `-1e39` is beyond",
        ),
        (
            "w.obj",
            "v 0 0 0\nv 1 0 0 1e-40\nv 0 1 0\nf 1 2 3\n",
            ":2: dividing by w leaves a coordinate beyond the range of f32: `v 1 0 0 1e-40`",
        ),
        (
            "w0.obj",
            "v 0 0 0\nv 1 0 0 0\nv 0 1 0\nf 1 2 3\n",
            ":2: a vertex with w = 0: `v 1 0 0 0`",
        ),
        (
            "word.obj",
            "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n",
            ":2: a vertex needs three numbers: `v 1 zero 0`",
        ),
        (
            "face.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 x\n",
            ":5: a face corner is `v`, `v/vt`, `v//vn` or `v/vt/vn` in whole numbers: `f 1 2 x`",
        ),
        (
            "earlier.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\no a\nf 1 2 3\nf 3 2 7\no b\nv 0 0 1\nf 1 2 4\n",
            ":6: corner `7` names vertex 7; the file defines 3 by the end of its object",
        ),
        (
            "back.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
            ":4: corner `-4` counts back 4 to a vertex before the first",
        ),
        (
            "zero.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            ":4: corner `0` names vertex 0",
        ),
        (
            "vn.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
            ":5: corner `3//2` names normal 2; the file defines 1",
        ),
        (
            "nocorner.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n",
            ":5: a face without corners",
        ),
        (
            "hidden.obj",
            "v 0 0 0\nv 1 0 \u{200b}0\nv 0 1 0\nf 1 2 3\n",
            ":2: a vertex needs three numbers: `v 1 0 \\u{200b}0`",
        ),
        (
            "usemtl.obj",
            "v 0 0 0\nusemtl\n",
            ":2: `usemtl` needs a material name",
        ),
        (
            "far.obj",
            "v 0 0 0\nv 2e18 0 0\nv 0 1 0\nf 1 2 3\n",
            ":2: a coordinate of `v 2e18 0 0` is over 1e18 in size",
        ),
        (
            "farw.obj",
            "v 0 0 0\nv 1 0 0 1e-19\nv 0 1 0\nf 1 2 3\n",
            ":2: a coordinate of `v 1 0 0 1e-19` is over 1e18",
        ),
    ] {
        std::fs::write(dir.join(name), text).unwrap();
        let err = TriangleMesh::load(&dir.join(name)).unwrap_err().to_string();
        assert!(err.contains(&format!("{name}{want}")), "{name}: {err}");
    }
    // A Latin-1 byte in a comment: line and column (characters).
    std::fs::write(
        dir.join("latin1.obj"),
        b"v 0 0 0\n# \xe9t\xe9\nv 1 0 0\n".as_slice(),
    )
    .unwrap();
    let err = TriangleMesh::load(&dir.join("latin1.obj"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("latin1.obj:2:3: byte 0xE9 is not UTF-8 text"),
        "{err}"
    );
    let long = format!("v 0 0 {}\n", "9".repeat(100_000));
    std::fs::write(dir.join("long.obj"), format!("{triangle}{long}f 1 2 3\n")).unwrap();
    let err = TriangleMesh::load(&dir.join("long.obj"))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(":4: `999") && err.contains("…`") && err.len() < 300,
        "{err}"
    );
    // A byte-order mark is not part of the first statement; a material library is never
    // opened (this one would be read forever).
    let bom = format!("\u{feff}mtllib /dev/zero\n{triangle}f 1 2 3\n");
    std::fs::write(dir.join("bom.obj"), bom).unwrap();
    let mesh = TriangleMesh::load(&dir.join("bom.obj")).unwrap();
    assert_eq!((mesh.positions.len(), mesh.triangles.len()), (3, 1));
    // The largest coordinate accepted; normals of any finite length give their direction.
    let edge = "v 0 0 0\nv 1e18 0 0\nv 0 -1e18 0\nvn 0 0 1e30\nvn 0 0 1e-30\nvn 0 3e38 0\n\
                f 1//1 2//2 3//3\n";
    std::fs::write(dir.join("edge.obj"), edge).unwrap();
    let mesh = TriangleMesh::load(&dir.join("edge.obj")).unwrap();
    assert_eq!(
        mesh.normals,
        Some(vec![[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    );
    std::fs::remove_dir_all(dir).ok();
}

/// Copies of a triangle (the same corners in the same turning order, from any corner) are
/// dropped at load and counted; the reversed order is a surface of its own (it turns the
/// other way for glass) and stays.
#[test]
fn copies_of_triangles_are_dropped_and_counted() {
    let dir = temp_dir("copies");
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 0\nv 2 2 2\n\
                f 1 2 3\nf 2 3 1\nf 4 2 3\nf 1 3 2\nf 3 1 2\nf 1 1 2\nf 1 2 5\n";
    std::fs::write(dir.join("copies.obj"), text).unwrap();
    let mesh = TriangleMesh::load(&dir.join("copies.obj")).unwrap();
    assert_eq!(
        (mesh.triangles.len(), mesh.degenerate, mesh.duplicates),
        (3, 1, 3),
        "{:?}",
        mesh.triangles
    );
    assert_eq!(mesh.triangles[..2], [[0, 1, 2], [0, 2, 1]]);
    std::fs::remove_dir_all(dir).ok();
}

/// OBJ files over the size limit, directories and devices are refused by name before
/// anything is read.
#[test]
fn oversized_and_non_files_are_refused_as_such() {
    let dir = temp_dir("limits");
    let path = dir.join("ok.obj");
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let len = std::fs::metadata(&path).unwrap().len();
    assert!(TriangleMesh::load_within(&path, len).is_ok());
    let err = TriangleMesh::load_within(&path, len - 1)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains(&format!("the file is {len} bytes"))
            && err.contains(&format!("larger than the limit of {} bytes", len - 1))
            && err.contains("--max-mesh-bytes"),
        "{err}"
    );
    let err = TriangleMesh::load(&dir).unwrap_err().to_string();
    assert!(err.contains("this is a directory, not a file"), "{err}");
    let err = TriangleMesh::load(Path::new("/dev/zero"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("this is a device, not a file"), "{err}");
    // Named in a scene: the place where it was found.
    std::fs::create_dir_all(dir.join("x.obj")).unwrap();
    let path = dir.join("scene.txt");
    std::fs::write(&path, "PerspectiveCamera { center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }\nMaterials { numMaterials 1 Material { } }\nGroup { numObjects 1 Mesh { obj_file x.obj } }\n").unwrap();
    let scene = Scene::load(&path).unwrap();
    let err = PackedScene::new(&scene, u64::MAX).unwrap_err().to_string();
    assert!(
        err.contains("scene.txt:3:22: mesh file `x.obj` is a directory ("),
        "{err}"
    );
    std::fs::remove_dir_all(dir).ok();
}
