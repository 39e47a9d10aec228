//! Triangle meshes from OBJ files (host side of mesh.cuh), through `tobj`: faces triangulated,
//! every model of the file merged, vertex normals kept when the file has one for every vertex
//! (smooth shading), else none (face normals, as the original).
//!
//! Bad input is an error naming the file and what is wrong (a NaN or infinite coordinate, an
//! index out of range, no triangles at all). Degenerate triangles (two equal indices, or zero
//! area) can never be hit: they are dropped and counted, not refused.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// A mesh as the kernels need it: f32 positions, optional per-vertex normals, index triples.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMesh {
    pub path: PathBuf,
    pub positions: Vec<[f32; 3]>,
    /// One unit normal per vertex, or `None` for face normals.
    pub normals: Option<Vec<[f32; 3]>>,
    pub triangles: Vec<[u32; 3]>,
    /// Triangles of the file dropped for having no area.
    pub degenerate: usize,
}

impl TriangleMesh {
    /// Loads and checks an OBJ file.
    pub fn load(path: &Path) -> Result<TriangleMesh> {
        let fail = |message: String| Error::Mesh {
            path: path.to_path_buf(),
            message,
        };
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _materials) =
            tobj::load_obj(path, &options).map_err(|e| fail(e.to_string()))?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut all_have_normals = true;
        let mut indices = Vec::new();
        for model in &models {
            let mesh = &model.mesh;
            let base = positions.len() as u64;
            if mesh.positions.len() % 3 != 0 {
                return Err(fail(format!("model `{}` has a partial vertex", model.name)));
            }
            let count = mesh.positions.len() / 3;
            for (i, p) in mesh.positions.chunks_exact(3).enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(fail(format!(
                        "vertex {} of model `{}` has a coordinate that is not a finite number",
                        i + 1,
                        model.name
                    )));
                }
                positions.push([p[0], p[1], p[2]]);
            }
            if mesh.normals.len() == mesh.positions.len() && count > 0 {
                normals.extend(mesh.normals.chunks_exact(3).map(|n| [n[0], n[1], n[2]]));
            } else {
                all_have_normals = false;
            }
            for &i in &mesh.indices {
                if i as usize >= count {
                    return Err(fail(format!(
                        "model `{}` refers to vertex {} of {count}",
                        model.name,
                        i as u64 + 1
                    )));
                }
                indices.push(base + i as u64);
            }
        }
        if positions.len() > u32::MAX as usize / 2 {
            return Err(fail(format!("{} vertices are too many", positions.len())));
        }
        let mut triangles = Vec::with_capacity(indices.len() / 3);
        let mut degenerate = 0;
        for t in indices.chunks_exact(3) {
            let tri = [t[0] as u32, t[1] as u32, t[2] as u32];
            if has_area(&positions, tri) {
                triangles.push(tri);
            } else {
                degenerate += 1;
            }
        }
        if triangles.is_empty() {
            return Err(fail(format!(
                "no triangles with any area ({} faces read, {degenerate} degenerate)",
                indices.len() / 3
            )));
        }
        // Vertex normals serve only when every vertex has a usable one.
        let normals = (all_have_normals && normals.iter().all(|n| usable_normal(*n)))
            .then(|| normals.into_iter().map(normalized).collect());
        Ok(TriangleMesh {
            path: path.to_path_buf(),
            positions,
            normals,
            triangles,
            degenerate,
        })
    }
}

fn has_area(positions: &[[f32; 3]], [a, b, c]: [u32; 3]) -> bool {
    if a == b || b == c || a == c {
        return false;
    }
    let p = |i: u32| glam::DVec3::from(positions[i as usize].map(|v| v as f64));
    (p(b) - p(a)).cross(p(c) - p(a)).length_squared() > 0.0
}

fn usable_normal(n: [f32; 3]) -> bool {
    n.iter().all(|c| c.is_finite()) && n.iter().any(|&c| c != 0.0)
}

fn normalized(n: [f32; 3]) -> [f32; 3] {
    let v = glam::Vec3::from(n).normalize();
    v.to_array()
}
