//! Closed triangle meshes made in code, with shared vertices: an icosphere, a torus and a
//! (p, q) torus knot tube. The watertightness tests aim rays at their shared edges and vertices,
//! and `examples/make_assets.rs` (which includes this file) writes them to `assets/` as OBJ
//! files. Generators for tests and assets, kept out of the library.

use clpt::scene::mesh::TriangleMesh;
use glam::DVec3;
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

fn mesh(name: &str, positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> TriangleMesh {
    TriangleMesh {
        path: PathBuf::from(name),
        positions: positions.iter().map(|p| p.as_vec3().to_array()).collect(),
        normals: None,
        triangles,
        degenerate: 0,
        duplicates: 0,
    }
}

/// A unit sphere from an icosahedron split `level` times (20 * 4^level triangles), outward
/// (counter-clockwise) winding.
pub fn icosphere(level: u32) -> TriangleMesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *midpoints.entry(key).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for [a, b, c] in triangles {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    mesh("icosphere", positions, triangles)
}

/// A closed tube of radius `tube` around a closed curve `center(s)`, s in [0, 1), with `rings`
/// rings of `sides` vertices.
fn tube(
    name: &str,
    center: impl Fn(f64) -> DVec3,
    tube: f64,
    rings: u32,
    sides: u32,
) -> TriangleMesh {
    let h = 1e-4;
    let ring_s = |i: u32| i as f64 / rings as f64;
    let tangent = |s: f64| (center(s + h) - center(s - h)).normalize();
    // A rotation-minimising frame (parallel transport: each ring's normal is the previous one
    // turned by the least rotation that takes the previous tangent to this one), its twist
    // after one turn spread evenly over the rings so the tube closes. A frame built from a
    // fixed helper axis jumps where the tangent passes near that axis, and the quads between
    // two such rings fold through each other: the first trefoil asset had such folds, through
    // which paths got inside the tube.
    let t0 = tangent(0.0);
    let n0 = t0.any_orthonormal_vector();
    let mut normals = Vec::with_capacity(rings as usize);
    let mut n = n0;
    let mut t_prev = t0;
    for i in 0..=rings {
        let t = tangent(ring_s(i % rings));
        n = glam::DQuat::from_rotation_arc(t_prev, t) * n;
        n = (n - t * n.dot(t)).normalize();
        t_prev = t;
        if i < rings {
            normals.push(n);
        }
    }
    // n is ring 0's normal carried once around: the twist is its angle from n0 about t0.
    let twist = t0.dot(n0.cross(n)).atan2(n0.dot(n));
    let mut positions = Vec::with_capacity((rings * sides) as usize);
    for (i, &n_i) in normals.iter().enumerate() {
        let s = ring_s(i as u32);
        let t = tangent(s);
        let n = glam::DQuat::from_axis_angle(t, -twist * s) * n_i;
        let b = t.cross(n);
        for j in 0..sides {
            let a = std::f64::consts::TAU * j as f64 / sides as f64;
            positions.push(center(s) + (n * a.cos() + b * a.sin()) * tube);
        }
    }
    let mut triangles = Vec::with_capacity((2 * rings * sides) as usize);
    let at = |i: u32, j: u32| (i % rings) * sides + (j % sides);
    for i in 0..rings {
        for j in 0..sides {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    mesh(name, positions, triangles)
}

/// A torus in the xz-plane: ring radius `major`, tube radius `minor`.
pub fn torus(major: f64, minor: f64, rings: u32, sides: u32) -> TriangleMesh {
    let circle = move |s: f64| {
        let a = std::f64::consts::TAU * s;
        DVec3::new(major * a.cos(), 0.0, major * a.sin())
    };
    tube("torus", circle, minor, rings, sides)
}

/// A (p, q) torus knot tube (p = 2, q = 3: the trefoil).
pub fn torus_knot(p: u32, q: u32, tube_radius: f64, rings: u32, sides: u32) -> TriangleMesh {
    let curve = move |s: f64| {
        let a = std::f64::consts::TAU * s;
        let r = 2.0 + (q as f64 * a).cos();
        DVec3::new(
            r * (p as f64 * a).cos(),
            (q as f64 * a).sin(),
            r * (p as f64 * a).sin(),
        )
    };
    tube("torus_knot", curve, tube_radius, rings, sides)
}

/// Writes a mesh as an OBJ file (positions and faces, 1-based), atomically (clpt::output).
pub fn write_obj(mesh: &TriangleMesh, path: &Path, comment: &str) -> clpt::Result<()> {
    clpt::output::write_atomically(path, |out| {
        let mut write = || -> std::io::Result<()> {
            for line in comment.lines() {
                writeln!(out, "# {line}")?;
            }
            for p in &mesh.positions {
                writeln!(out, "v {} {} {}", p[0], p[1], p[2])?;
            }
            for t in &mesh.triangles {
                writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
            }
            Ok(())
        };
        write().map_err(|e| e.to_string())
    })
}
