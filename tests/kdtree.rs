//! The mesh kd-tree (src/accel/kdtree.rs) on meshes made here (an icosphere, a torus, a random
//! triangle soup, a subdivided cube with coplanar axis-aligned sheets and broken triangles, a
//! flat grid) and on the Stanford dragon from the original's data: the traversal's nearest hit
//! against a brute-force loop over every triangle (1e5 rays per mesh: from outside aimed at the
//! mesh, from inside, axis-aligned, with short [t_min, t_max]), the tree's structure (every
//! triangle referenced, every leaf's triangles overlapping its box, splits inside their boxes,
//! references in range, depth), SAH cost against the original's median tree, deterministic and
//! O(n log n) builds, and meshes that are empty or all broken. Hostile meshes (issue 14): a
//! pile of 100k overlapping copies of a triangle, copies of one triangle, triangles crossing
//! each other all over a cube, and a tree held to a small entry budget, all against brute
//! force.

mod common;

use clpt::accel::aabb::Aabb;
use clpt::accel::kdtree::{ENTRY_SLACK, KdParams, KdTree, MAX_DEPTH};
use common::traversal::{self, kd_intersect};
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::sync::{Mutex, MutexGuard};
use std::time::Instant;

/// The tests time builds and spread brute force over every core: one at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

struct Mesh {
    name: String,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl Mesh {
    fn tree(&self) -> KdTree {
        KdTree::build(&self.positions, &self.triangles, &KdParams::default())
    }

    fn vertices(&self, t: u32) -> Option<[DVec3; 3]> {
        traversal::triangle_vertices(&self.positions, &self.triangles, t)
    }

    /// What the tree must hold: existing, finite vertices spanning a non-zero area.
    fn is_valid(&self, t: u32) -> bool {
        self.vertices(t).is_some_and(|v| {
            v.iter().all(|p| p.is_finite()) && (v[1] - v[0]).cross(v[2] - v[0]) != DVec3::ZERO
        })
    }

    fn valid_bounds(&self) -> Aabb {
        (0..self.triangles.len() as u32)
            .filter(|&t| self.is_valid(t))
            .filter_map(|t| self.vertices(t))
            .fold(Aabb::EMPTY, |b, v| v.into_iter().fold(b, Aabb::grow))
    }

    /// Every triangle's number and vertices, for [`brute_force`]: looked up once, not once a
    /// ray (that lookup was a third of the brute force's time).
    fn all_vertices(&self) -> Vec<(u32, [DVec3; 3])> {
        (0..self.triangles.len() as u32)
            .filter_map(|t| self.vertices(t).map(|v| (t, v)))
            .collect()
    }
}

/// The nearest hit among `triangles` ([`Mesh::all_vertices`]), each tested in turn.
fn brute_force(
    triangles: &[(u32, [DVec3; 3])],
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, u32)> {
    let mut best: Option<(f64, u32)> = None;
    for (t, v) in triangles {
        let limit = best.map_or(t_max, |b| b.0);
        if let Some(hit) = traversal::intersect_triangle(o, d, v, t_min, limit) {
            best = Some((hit, *t));
        }
    }
    best
}

/// An icosahedron subdivided `levels` times onto the unit sphere (clpt's own generator),
/// vertices shared: 20·4^levels triangles.
fn icosphere(levels: u32) -> Mesh {
    from_procedural(common::procedural::icosphere(levels))
}

fn from_procedural(m: clpt::scene::mesh::TriangleMesh) -> Mesh {
    Mesh {
        name: format!("{} {}", m.path.display(), m.triangles.len()),
        positions: m.positions,
        triangles: m.triangles,
    }
}

/// A torus (radii 1 and 0.3) on a `major` × `minor` grid (clpt's own generator), vertices
/// shared.
fn torus(major: u32, minor: u32) -> Mesh {
    from_procedural(common::procedural::torus(1.0, 0.3, major, minor))
}

/// `n` random triangles in [-1, 1]^3: mostly small, some long and thin, some large.
fn soup(n: usize, seed: u64) -> Mesh {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut positions = Vec::new();
    for _ in 0..n {
        let size = match rng.random_range(0..10) {
            0 => 1.0,
            1 => 0.3,
            _ => 0.05,
        };
        let centre = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        for _ in 0..3 {
            let p = centre + common::random_unit(&mut rng) * size * rng.random::<f64>();
            positions.push(
                p.clamp(DVec3::splat(-1.0), DVec3::splat(1.0))
                    .as_vec3()
                    .to_array(),
            );
        }
    }
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    Mesh {
        name: format!("soup {n}"),
        positions,
        triangles,
    }
}

/// `n` copies of the triangle (0, 0, 0), (1, 0, 0), (0, 1, 0), each vertex moved by up to
/// `jitter` on every axis (0: identical copies): a pile where every point of the triangle lies
/// on nearly every copy.
fn pile(n: usize, jitter: f32, seed: u64) -> Mesh {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut positions = Vec::new();
    for _ in 0..n {
        for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
            positions.push(v.map(|c| c + rng.random::<f32>() * jitter));
        }
    }
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    Mesh {
        name: format!("pile of {n} moved by {jitter}"),
        positions,
        triangles,
    }
}

/// `n` triangles with vertices anywhere in the unit cube: large triangles crossing one another
/// everywhere, so no plane takes any of them off a cell without cutting most of the others.
fn crossing(n: usize, seed: u64) -> Mesh {
    let mut rng = SmallRng::seed_from_u64(seed);
    let positions = (0..3 * n)
        .map(|_| {
            [
                rng.random::<f32>(),
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        })
        .collect();
    let triangles = (0..n as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
    Mesh {
        name: format!("{n} crossing triangles"),
        positions,
        triangles,
    }
}

/// Entries of a tree: nodes and leaf references.
fn entries(tree: &KdTree) -> usize {
    tree.nodes.len() + tree.indices.len()
}

/// Adds the parallelogram origin + [0, 1] u + [0, 1] v as a `cells` × `cells` grid of squares,
/// each split in two.
fn grid(mesh: &mut Mesh, origin: DVec3, u: DVec3, v: DVec3, cells: u32) {
    let base = mesh.positions.len() as u32;
    for i in 0..=cells {
        for j in 0..=cells {
            let p = origin + u * (i as f64 / cells as f64) + v * (j as f64 / cells as f64);
            mesh.positions.push(p.as_vec3().to_array());
        }
    }
    let at = |i: u32, j: u32| base + i * (cells + 1) + j;
    for i in 0..cells {
        for j in 0..cells {
            mesh.triangles
                .push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            mesh.triangles
                .push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
}

/// The cube [-1, 1]^3 with each face an n×n grid of squares split in two, the sheets z = 0 and
/// x = 0.25 inside it on the same grid (coplanar, axis-aligned triangles on likely split planes),
/// a staircase of small axis-aligned squares, and broken triangles: zero-area (a repeated
/// vertex, three collinear vertices), a vertex out of range, NaN and infinite vertices.
fn cube(n: u32) -> Mesh {
    let mut mesh = Mesh {
        name: format!("subdivided cube {n}"),
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    let mut grid = |origin, u, v, cells| grid(&mut mesh, origin, u, v, cells);
    let (x, y, z) = (DVec3::X * 2.0, DVec3::Y * 2.0, DVec3::Z * 2.0);
    let corner = DVec3::splat(-1.0);
    grid(corner, y, z, n);
    grid(corner + x, y, z, n);
    grid(corner, x, z, n);
    grid(corner + y, x, z, n);
    grid(corner, x, y, n);
    grid(corner + z, x, y, n);
    grid(DVec3::new(-1.0, -1.0, 0.0), x, y, n);
    grid(DVec3::new(0.25, -1.0, -1.0), y, z, n);
    for k in 0..16 {
        let s = k as f64 / 16.0 - 0.5;
        let step = 1.0 / 16.0;
        grid(DVec3::new(s, s, s), DVec3::X * step, DVec3::Y * step, 1);
        grid(
            DVec3::new(s + step, s, s),
            DVec3::Y * step,
            DVec3::Z * step,
            1,
        );
    }
    let v = mesh.positions.len() as u32;
    mesh.positions.extend([
        [0.125, 0.25, 0.375],
        [0.25, 0.5, 0.75],
        [0.375, 0.75, 1.125],
        [f32::NAN, 0.0, 0.0],
        [0.0, f32::INFINITY, 0.0],
    ]);
    mesh.triangles.extend([
        [v, v, v + 1],
        [v, v + 1, v + 2],
        [0, 1, v + 100],
        [v + 3, 0, 1],
        [v + 4, 0, 1],
    ]);
    mesh
}

/// The meshes of the seed data (`mesh/NAME.obj`), all models in one list.
fn load_obj(path: &std::path::Path) -> Mesh {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &options).expect("obj loads");
    let mut mesh = Mesh {
        name: path
            .file_name()
            .map_or(String::new(), |f| f.to_string_lossy().into_owned()),
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for model in models {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(
            model
                .mesh
                .positions
                .chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]]),
        );
        mesh.triangles.extend(
            model
                .mesh
                .indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    mesh
}

/// A ray: origin, direction, t_min, t_max.
type Ray = (DVec3, DVec3, f64, f64);

/// `n` rays around a mesh with bounds `b`: 45% from a sphere around it aimed at points of its
/// box, 25% from inside the box in random directions, 15% axis-aligned (exact zero direction
/// components), 15% from anywhere near with a short [t_min, t_max].
fn rays(b: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let (centre, radius) = (b.center(), b.extent().length() * 0.5);
    let in_box = |rng: &mut SmallRng, grow: f64| {
        // At least a fifth of the radius thick, so a flat mesh gets origins off its plane.
        let e = (b.extent() * (1.0 + grow)).max(DVec3::splat(radius * 0.2));
        centre
            + DVec3::new(
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
                rng.random::<f64>() - 0.5,
            ) * e
    };
    (0..n)
        .map(|i| match i % 20 {
            0..9 => {
                let o =
                    centre + common::random_unit(&mut rng) * radius * rng.random_range(1.2..3.0);
                let target = in_box(&mut rng, 0.1);
                (o, (target - o).normalize(), 0.0, f64::INFINITY)
            }
            9..14 => (
                in_box(&mut rng, 0.0),
                common::random_unit(&mut rng),
                0.0,
                f64::INFINITY,
            ),
            14..17 => {
                let axis = rng.random_range(0..3);
                let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                let mut d = DVec3::ZERO;
                d[axis] = sign;
                (in_box(&mut rng, 0.5), d, 0.0, f64::INFINITY)
            }
            _ => {
                let o = in_box(&mut rng, 1.0);
                let t_min = rng.random::<f64>() * radius * 0.5;
                let t_max = t_min + rng.random::<f64>() * radius * 2.0;
                (o, common::random_unit(&mut rng), t_min, t_max)
            }
        })
        .collect()
}

/// Counts the rays on which two nearest-hit answers disagree: a different t (beyond 1e-9
/// relative), or a different triangle that is not hit at the same t (a tie on a shared edge).
fn compare(
    mesh: &Mesh,
    what: &str,
    rays: &[Ray],
    got: &[Option<(f64, u32)>],
    want: &[Option<(f64, u32)>],
) -> usize {
    let mut bad = 0;
    for ((ray, g), w) in rays.iter().zip(got).zip(want) {
        let ok = match (g, w) {
            (None, None) => true,
            (Some((tg, ig)), Some((tw, iw))) => {
                let same_t = (tg - tw).abs() <= 1e-9 * tw.abs();
                let tie = mesh
                    .vertices(*ig)
                    .and_then(|v| traversal::intersect_triangle(ray.0, ray.1, &v, ray.2, ray.3))
                    == Some(*tg);
                same_t && (ig == iw || tie)
            }
            _ => false,
        };
        if !ok {
            if bad < 5 {
                eprintln!(
                    "{}: {what} differ on ray {ray:?}: {g:?} against {w:?}",
                    mesh.name
                );
            }
            bad += 1;
        }
    }
    bad
}

/// The tree's nearest hits against brute force on `n` rays; returns the number of hits.
fn check_against_brute_force(mesh: &Mesh, tree: &KdTree, n: usize, seed: u64) -> usize {
    let rays = rays(&mesh.valid_bounds(), n, seed);
    let got = common::on_all_cores(&rays, |r| {
        kd_intersect(tree, &mesh.positions, &mesh.triangles, r.0, r.1, r.2, r.3)
    });
    let triangles = mesh.all_vertices();
    let want = common::on_all_cores(&rays, |r| brute_force(&triangles, r.0, r.1, r.2, r.3));
    let bad = compare(mesh, "kd-tree and brute force", &rays, &got, &want);
    let hits = want.iter().filter(|h| h.is_some()).count();
    println!(
        "{}: {n} rays, {hits} hits, {bad} differ from brute force",
        mesh.name
    );
    assert_eq!(
        bad, 0,
        "{}: kd-tree hits differ from brute force",
        mesh.name
    );
    assert!(
        hits > n / 10,
        "{}: too few rays hit ({hits}) to test much",
        mesh.name
    );
    hits
}

/// Whether triangle `v` overlaps box `b` (separating axis test: the box's axes, the
/// triangle's normal and the nine edge × axis products), `b` grown by `tol`.
fn triangle_overlaps_box(v: &[DVec3; 3], b: &Aabb, tol: f64) -> bool {
    let c = b.center();
    let h = b.extent() * 0.5 + DVec3::splat(tol);
    let p = v.map(|q| q - c);
    let edges = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let mut axes = vec![DVec3::X, DVec3::Y, DVec3::Z, edges[0].cross(edges[1])];
    for e in edges {
        for a in [DVec3::X, DVec3::Y, DVec3::Z] {
            axes.push(e.cross(a));
        }
    }
    axes.into_iter().filter(|a| *a != DVec3::ZERO).all(|a| {
        let proj = p.map(|q| q.dot(a));
        let r = h.dot(a.abs());
        let (lo, hi) = (
            proj.iter().copied().fold(f64::INFINITY, f64::min),
            proj.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        );
        lo <= r && hi >= -r
    })
}

/// The depth limit `build` uses with the default parameters on `n` triangles.
fn auto_depth(n: usize) -> u32 {
    ((8.0 + 1.3 * (n.max(1) as f64).log2()).round() as u32).min(MAX_DEPTH)
}

/// Structure: node references in range and each node reached once, splits strictly inside
/// their boxes, depth within `max_depth`, every leaf's triangles valid and overlapping its box,
/// every valid triangle in some leaf, bounds tight.
fn check_structure(mesh: &Mesh, tree: &KdTree, max_depth: u32) {
    let name = &mesh.name;
    assert_eq!(tree.bounds, mesh.valid_bounds(), "{name}: bounds");
    let boxes = tree.node_boxes();
    assert_eq!(
        boxes.len(),
        tree.nodes.len(),
        "{name}: every node reached once"
    );
    let mut seen = vec![false; tree.nodes.len()];
    let mut referenced = vec![false; mesh.triangles.len()];
    let scale = tree.bounds.lo.abs().max(tree.bounds.hi.abs()).max_element();
    for (i, bx, depth) in boxes {
        assert!(
            !std::mem::replace(&mut seen[i], true),
            "{name}: node {i} reached twice"
        );
        assert!(
            depth <= max_depth,
            "{name}: node {i} at depth {depth} > {max_depth}"
        );
        let node = tree.nodes[i];
        if node.is_leaf() {
            let (first, count) = (node.first_index() as usize, node.count() as usize);
            assert!(
                first + count <= tree.indices.len(),
                "{name}: leaf {i} indices out of range"
            );
            for &t in &tree.indices[first..first + count] {
                assert!(
                    mesh.is_valid(t),
                    "{name}: leaf {i} holds invalid triangle {t}"
                );
                referenced[t as usize] = true;
                let v = mesh.vertices(t).expect("valid triangle");
                assert!(
                    triangle_overlaps_box(&v, &bx, 1e-9 * scale),
                    "{name}: triangle {t} in leaf {i} misses its box {bx:?}"
                );
            }
        } else {
            let (axis, split) = (node.axis(), f64::from(node.split()));
            assert!(axis < 3);
            assert!(
                split > bx.lo[axis] && split < bx.hi[axis],
                "{name}: node {i} splits {axis} at {split} outside {bx:?}"
            );
            let above = node.above_child() as usize;
            assert!(
                i + 1 < above && above < tree.nodes.len(),
                "{name}: node {i} children out of range"
            );
        }
    }
    for t in 0..mesh.triangles.len() as u32 {
        assert_eq!(
            referenced[t as usize],
            mesh.is_valid(t),
            "{name}: triangle {t} referenced"
        );
    }
}

/// Builds the SAH and median trees of `mesh`, checks both, prints and returns their stats.
fn build_and_check(mesh: &Mesh) -> (KdTree, KdTree) {
    let start = Instant::now();
    let tree = mesh.tree();
    let sah_time = start.elapsed();
    let median = KdTree::build_median(&mesh.positions, &mesh.triangles);
    let valid = (0..mesh.triangles.len() as u32)
        .filter(|&t| mesh.is_valid(t))
        .count();
    check_structure(mesh, &tree, auto_depth(valid));
    check_structure(mesh, &median, 15);
    let (s, m) = (
        tree.stats(&mesh.positions, &mesh.triangles),
        median.stats(&mesh.positions, &mesh.triangles),
    );
    assert_eq!(s.skipped_triangles, mesh.triangles.len() - valid);
    println!(
        "{}: SAH build {:.1} ms, {s:?}",
        mesh.name,
        sah_time.as_secs_f64() * 1e3
    );
    println!("{}: median tree {m:?}", mesh.name);
    println!(
        "{}: SAH cost {:.2} (SAH tree) against {:.2} (median tree)",
        mesh.name, s.sah_cost, m.sah_cost
    );
    (tree, median)
}

/// The SAH tree's expected cost per ray is below the original's median tree's.
fn assert_sah_beats_median(mesh: &Mesh, tree: &KdTree, median: &KdTree) {
    let s = tree.stats(&mesh.positions, &mesh.triangles);
    let m = median.stats(&mesh.positions, &mesh.triangles);
    assert!(
        s.sah_cost < m.sah_cost,
        "{}: SAH tree costs {} against the median tree's {}",
        mesh.name,
        s.sah_cost,
        m.sah_cost
    );
}

#[test]
fn icosphere_matches_brute_force() {
    let _serial = serial();
    let mesh = icosphere(5);
    let (tree, median) = build_and_check(&mesh);
    assert_sah_beats_median(&mesh, &tree, &median);
    check_against_brute_force(&mesh, &tree, 100_000, 1);
    check_against_brute_force(&mesh, &median, 10_000, 2);
}

#[test]
fn torus_matches_brute_force() {
    let _serial = serial();
    let mesh = torus(160, 48);
    let (tree, median) = build_and_check(&mesh);
    assert_sah_beats_median(&mesh, &tree, &median);
    check_against_brute_force(&mesh, &tree, 100_000, 3);
}

#[test]
fn triangle_soup_matches_brute_force() {
    let _serial = serial();
    let mesh = soup(5000, 4);
    let (tree, _) = build_and_check(&mesh);
    check_against_brute_force(&mesh, &tree, 100_000, 5);
}

#[test]
fn coplanar_axis_aligned_and_broken_triangles_match_brute_force() {
    let _serial = serial();
    let mesh = cube(24);
    let (tree, _) = build_and_check(&mesh);
    assert_eq!(
        tree.stats(&mesh.positions, &mesh.triangles)
            .skipped_triangles,
        5
    );
    check_against_brute_force(&mesh, &tree, 100_000, 6);
}

#[test]
fn flat_mesh_matches_brute_force() {
    let _serial = serial();
    let mut mesh = Mesh {
        name: "flat grid".into(),
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    grid(
        &mut mesh,
        DVec3::new(-1.0, -1.0, 0.5),
        DVec3::X * 2.0,
        DVec3::Y * 2.0,
        60,
    );
    let (tree, _) = build_and_check(&mesh);
    assert_eq!(tree.bounds.extent().z, 0.0);
    check_against_brute_force(&mesh, &tree, 50_000, 10);
}

#[test]
fn builds_are_deterministic() {
    let _serial = serial();
    for mesh in [icosphere(5), soup(3000, 11), cube(10)] {
        let first = mesh.tree();
        assert!(first == mesh.tree(), "{}: two builds differ", mesh.name);
        let median = KdTree::build_median(&mesh.positions, &mesh.triangles);
        assert!(median == KdTree::build_median(&mesh.positions, &mesh.triangles));
    }
}

#[test]
fn parameters_change_the_tree_not_the_hits() {
    let _serial = serial();
    let mesh = torus(60, 20);
    let valid = mesh.triangles.len();
    for params in [
        KdParams {
            max_depth: 6,
            ..KdParams::default()
        },
        KdParams {
            intersection_cost: 80.0,
            empty_bonus: 0.0,
            max_leaf_triangles: u32::MAX,
            ..KdParams::default()
        },
        KdParams {
            traversal_cost: 10.0,
            max_leaf_triangles: 2,
            ..KdParams::default()
        },
    ] {
        let tree = KdTree::build(&mesh.positions, &mesh.triangles, &params);
        let depth = if params.max_depth == 0 {
            auto_depth(valid)
        } else {
            params.max_depth
        };
        check_structure(&mesh, &tree, depth);
        let stats = tree.stats(&mesh.positions, &mesh.triangles);
        println!("{params:?}: {stats:?}");
        check_against_brute_force(&mesh, &tree, 20_000, 7);
    }
}

#[test]
fn empty_single_and_broken_meshes_never_panic() {
    let _serial = serial();
    let o = DVec3::new(0.2, 0.2, 5.0);
    let d = DVec3::new(0.0, 0.0, -1.0);
    let unit = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let case = |positions: Vec<[f32; 3]>, triangles: Vec<[u32; 3]>| Mesh {
        name: format!("{positions:?} {triangles:?}"),
        positions,
        triangles,
    };
    // Each mesh with the triangle the ray hits and the number of triangles left out.
    let cases = [
        (case(vec![], vec![]), None, 0),
        (case(vec![[0.0; 3]], vec![[0, 0, 0]]), None, 1),
        (case(unit.clone(), vec![[0, 1, 2]]), Some(0), 0),
        (case(unit.clone(), vec![[0, 1, 7], [0, 1, 1]]), None, 2),
        (
            case(
                vec![[f32::NAN; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                vec![[0, 1, 2]],
            ),
            None,
            1,
        ),
        (
            case(
                [unit.clone(), vec![[f32::INFINITY, 0.0, 0.0]]].concat(),
                vec![[3, 1, 2], [0, 1, 2], [0, 1, 2]],
            ),
            Some(1),
            1,
        ),
    ];
    for (mesh, want, skipped) in cases {
        let (positions, triangles, name) = (&mesh.positions, &mesh.triangles, &mesh.name);
        for tree in [
            KdTree::build(positions, triangles, &KdParams::default()),
            KdTree::build_median(positions, triangles),
        ] {
            check_structure(&mesh, &tree, 15);
            let hit = kd_intersect(&tree, positions, triangles, o, d, 0.0, f64::INFINITY);
            assert_eq!(hit.map(|h| h.1), want, "{name}");
            let stats = tree.stats(positions, triangles);
            assert_eq!(stats.skipped_triangles, skipped, "{name}");
            assert_eq!(stats.index_entries, triangles.len() - skipped);
            // A tree asked about a mesh it was not built from answers without panicking.
            assert_eq!(kd_intersect(&tree, &[], &[], o, d, 0.0, 1.0), None);
        }
    }
}

#[test]
fn sah_build_time_grows_as_n_log_n() {
    let _serial = serial();
    let mut rates = Vec::new();
    for levels in 4..=7 {
        let mesh = icosphere(levels);
        let n = mesh.triangles.len() as f64;
        let repeats = if levels < 7 { 5 } else { 2 };
        let seconds = (0..repeats)
            .map(|_| {
                let start = Instant::now();
                std::hint::black_box(mesh.tree());
                start.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min);
        let rate = seconds / (n * n.log2());
        println!(
            "icosphere {n}: SAH build {:.1} ms ({:.1} ns per n log2 n)",
            seconds * 1e3,
            rate * 1e9
        );
        rates.push(rate);
    }
    let ratio = rates[rates.len() - 1] / rates[0];
    println!("time per n log2 n, largest over smallest: {ratio:.2}");
    assert!(
        ratio < 4.0,
        "build time grows faster than n log n ({ratio:.2}x)"
    );
}

#[test]
fn dragon_matches_brute_force_and_median_tree() {
    let _serial = serial();
    let Some(seed) = common::seed_dir("dragon_matches_brute_force_and_median_tree") else {
        return;
    };
    let path = seed.join("mesh/dragon_100k.obj");
    if !path.is_file() {
        eprintln!(
            "SKIPPED dragon_matches_brute_force_and_median_tree: no {}",
            path.display()
        );
        return;
    }
    let mesh = load_obj(&path);
    let (tree, median) = build_and_check(&mesh);
    assert_sah_beats_median(&mesh, &tree, &median);
    check_against_brute_force(&mesh, &tree, 2000, 8);
    let rays = rays(&mesh.valid_bounds(), 100_000, 9);
    let time = |t: &KdTree| {
        let start = Instant::now();
        let hits = common::on_all_cores(&rays, |r| {
            kd_intersect(t, &mesh.positions, &mesh.triangles, r.0, r.1, r.2, r.3)
        });
        (hits, start.elapsed().as_secs_f64())
    };
    let (got, sah_seconds) = time(&tree);
    let (want, median_seconds) = time(&median);
    println!(
        "{}: 1e5 rays on the host: SAH tree {:.0} ms, median tree {:.0} ms",
        mesh.name,
        sah_seconds * 1e3,
        median_seconds * 1e3
    );
    assert_eq!(
        compare(&mesh, "SAH and median trees", &rays, &got, &want),
        0
    );
}

#[test]
fn dragon_build_times_and_sizes() {
    let _serial = serial();
    let Some(seed) = common::seed_dir("dragon_build_times_and_sizes") else {
        return;
    };
    for name in common::DRAGONS {
        let path = seed.join(format!("mesh/{name}.obj"));
        if !path.is_file() {
            eprintln!("SKIPPED {name}: no {}", path.display());
            continue;
        }
        let mesh = load_obj(&path);
        let start = Instant::now();
        let tree = mesh.tree();
        let seconds = start.elapsed().as_secs_f64();
        let s = tree.stats(&mesh.positions, &mesh.triangles);
        let m = KdTree::build_median(&mesh.positions, &mesh.triangles)
            .stats(&mesh.positions, &mesh.triangles);
        println!(
            "{name}: {} triangles, SAH build {:.0} ms, {:.1} bytes per triangle, depth {}, {} nodes, \
             {:.2} per leaf, SAH cost {:.2} against {:.2} for the median tree",
            mesh.triangles.len(),
            seconds * 1e3,
            s.bytes as f64 / mesh.triangles.len() as f64,
            s.max_depth,
            s.nodes,
            s.mean_leaf_triangles,
            s.sah_cost,
            m.sah_cost
        );
        assert!(
            s.sah_cost < m.sah_cost,
            "{name}: SAH tree costs more than the median tree"
        );
    }
}

/// SAH counts time, not memory: on a pile of overlapping triangles it keeps halving cells that
/// each keep nearly the whole pile. Splits of large nodes may add only 16 entries per
/// triangle, so even with the tree's entry bound off the pile's tree stays small (it grew to
/// gigabytes before that), and the tree still finds every nearest hit. Copies of one triangle
/// make one leaf: no plane separates them.
#[test]
fn piles_of_overlapping_triangles_make_small_trees_that_match_brute_force() {
    let _serial = serial();
    let mesh = pile(100_000, 1e-4, 21);
    let unbounded = KdParams {
        max_entries_per_triangle: usize::MAX,
        ..KdParams::default()
    };
    let start = Instant::now();
    let tree = KdTree::build(&mesh.positions, &mesh.triangles, &unbounded);
    let seconds = start.elapsed().as_secs_f64();
    let n = mesh.triangles.len();
    println!(
        "{}: built in {seconds:.2} s, {:?}",
        mesh.name,
        tree.stats(&mesh.positions, &mesh.triangles)
    );
    // The root's references, and at most 16 per triangle from splits of large nodes; the
    // pile has next to no small nodes, whose splits are not counted.
    assert!(
        entries(&tree) <= 17 * n + ENTRY_SLACK,
        "{}: {} entries",
        mesh.name,
        entries(&tree)
    );
    assert!(seconds < 20.0, "{}: built in {seconds:.1} s", mesh.name);
    check_structure(&mesh, &tree, auto_depth(n));
    check_against_brute_force(&mesh, &tree, 2000, 22);
    assert!(tree == mesh.tree(), "the entry bound does not bind here");

    let copies = pile(20_000, 0.0, 23);
    let tree = copies.tree();
    check_structure(&copies, &tree, auto_depth(1));
    assert_eq!(
        (tree.nodes.len(), tree.indices.len()),
        (1, 20_000),
        "copies of one triangle: one leaf"
    );
    check_against_brute_force(&copies, &tree, 2000, 24);
}

/// Where SAH would stop, a node of more than 16 triangles is split at the most even plane when
/// the cheapest one only shaves a triangle off one side: a chain of such slivers reached the
/// depth limit with all 20000 crossing triangles in one leaf, slower than testing them all.
/// Now the tree beats brute force by far (11 times on 2 cores, where it was slower).
#[test]
fn crossing_triangles_get_small_leaves() {
    let _serial = serial();
    let mesh = crossing(20_000, 25);
    let (tree, _) = build_and_check(&mesh);
    let rays = rays(&mesh.valid_bounds(), 2000, 26);
    let time = |f: &(dyn Fn(&Ray) -> Option<(f64, u32)> + Sync)| {
        let start = Instant::now();
        let hits = common::on_all_cores(&rays, f);
        (hits, start.elapsed().as_secs_f64())
    };
    let (got, tree_seconds) =
        time(&|r| kd_intersect(&tree, &mesh.positions, &mesh.triangles, r.0, r.1, r.2, r.3));
    let triangles = mesh.all_vertices();
    let (want, brute_seconds) = time(&|r| brute_force(&triangles, r.0, r.1, r.2, r.3));
    println!(
        "{}: 2000 rays, tree {:.1} ms, brute force {:.1} ms",
        mesh.name,
        tree_seconds * 1e3,
        brute_seconds * 1e3
    );
    assert_eq!(
        compare(&mesh, "kd-tree and brute force", &rays, &got, &want),
        0
    );
    assert!(
        tree_seconds * 5.0 < brute_seconds,
        "{}: the tree is not 5 times faster than brute force",
        mesh.name
    );
}

/// A tree that would hold more entries than `max_entries_per_triangle` allows is built again
/// shallower until it fits, and still finds every nearest hit.
#[test]
fn a_tree_over_its_entry_budget_is_built_shallower() {
    let _serial = serial();
    let mesh = icosphere(5);
    let n = mesh.triangles.len();
    let limit = 2 * n + ENTRY_SLACK;
    assert!(entries(&mesh.tree()) > limit, "the bound must bind");
    let params = KdParams {
        max_entries_per_triangle: 2,
        ..KdParams::default()
    };
    let tree = KdTree::build(&mesh.positions, &mesh.triangles, &params);
    println!(
        "{}: {:?}",
        mesh.name,
        tree.stats(&mesh.positions, &mesh.triangles)
    );
    assert!(entries(&tree) <= limit, "{} entries", entries(&tree));
    check_structure(&mesh, &tree, auto_depth(n));
    check_against_brute_force(&mesh, &tree, 20_000, 27);
}
