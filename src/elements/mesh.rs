//! Triangle meshes from OBJ files (host side of mesh.cuh), through `tobj`: faces triangulated,
//! every model of the file merged, vertex normals kept when the file has one for every vertex
//! (smooth shading), else none (face normals, as the original).
//!
//! Bad input is an error naming the file and, for what lies on one line, `path:line` with the
//! line quoted: a number tobj cannot read, a coordinate that is not finite in f32 (`nan`,
//! `1e39`), a face corner naming a vertex that does not exist, bytes that are not UTF-8 (with
//! the column), a file with no triangles. tobj reports no line, so the line is found here:
//! from how far tobj had read when it failed, and for indices out of range (which tobj checks
//! only at the end of each object) by scanning the faces up to there.
//!
//! Limits: the file is read only if it is a regular file of at most `max_file_bytes`
//! ([`DEFAULT_MAX_FILE_BYTES`], `--max-mesh-bytes`); its vertices and triangles are counted
//! line by line before tobj stores any ([`MAX_VERTICES`], [`kdtree::MAX_TRIANGLES`]). Material
//! libraries (`mtllib`) are never opened: clpt uses no OBJ materials, and the name could be
//! anything (`mtllib /dev/zero` made tobj read forever).
//!
//! Triangles no ray can find are dropped and counted, not refused: degenerate ones (two equal
//! indices, or zero area) and copies of an earlier triangle (see `surface_triangles`).

use crate::accel::kdtree;
use crate::error::{Error, Result, quote};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// The largest OBJ file read unless `--max-mesh-bytes` says otherwise: 1 GiB, 32 times the
/// original's largest mesh (dragon_871k.obj, 33 MB for 871k triangles), so about 27 million
/// triangles. Loading holds the text and tobj's arrays at once, about 8 times the file.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 1 << 30;

/// The most vertices a mesh may have: the device numbers the vertices of all meshes of a
/// scene together in 32 bits.
pub const MAX_VERTICES: usize = (u32::MAX / 2) as usize;

/// The largest vertex coordinate accepted, in size. The kernels multiply differences of
/// coordinates in f32 (edge cross products in `kernels/mesh.h`, the watertight test's 2x2
/// determinants in `kernels/triangle.h`), which overflow from about 1.8e19 on: a triangle
/// with corners at ±1e19, facing the camera in front of a light, rendered black.
pub const MAX_COORDINATE: f32 = 1e18;

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
    /// Triangles of the file dropped as copies of an earlier one.
    pub duplicates: usize,
}

impl TriangleMesh {
    /// Loads and checks an OBJ file of at most [`DEFAULT_MAX_FILE_BYTES`].
    pub fn load(path: &Path) -> Result<TriangleMesh> {
        TriangleMesh::load_within(path, DEFAULT_MAX_FILE_BYTES)
    }

    /// Loads and checks an OBJ file of at most `max_file_bytes`.
    pub fn load_within(path: &Path, max_file_bytes: u64) -> Result<TriangleMesh> {
        let fail = |message: String| Error::Mesh {
            path: path.to_path_buf(),
            message,
        };
        let bytes =
            crate::input::read_regular(path, max_file_bytes, "--max-mesh-bytes").map_err(fail)?;
        let text = obj_text(path, &bytes)?;
        check_lines(path, text, MAX_VERTICES, kdtree::MAX_TRIANGLES)?;
        let models = parse(path, text)?;
        let (positions, normals, corners) = merge_models(path, &models)?;
        drop(models);
        let (triangles, degenerate, duplicates) = surface_triangles(&positions, &corners);
        if triangles.is_empty() {
            return Err(fail(format!(
                "no triangles with any area ({} faces read, {degenerate} degenerate, \
                 {duplicates} copies)",
                corners.len() / 3
            )));
        }
        Ok(TriangleMesh {
            path: path.to_path_buf(),
            positions,
            normals,
            triangles,
            degenerate,
            duplicates,
        })
    }
}

/// The file as text: UTF-8, a leading byte-order mark dropped (tobj would read `\u{feff}v` as
/// an unknown statement and lose the vertex); anything else is an error at its line:column.
fn obj_text<'a>(path: &Path, bytes: &'a [u8]) -> Result<&'a str> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let good = &bytes[..e.valid_up_to()];
        let line_start = good.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        // The prefix is valid UTF-8, so it splits into characters.
        let column = String::from_utf8_lossy(&good[line_start..]).chars().count() + 1;
        Error::MeshLine {
            path: path.to_path_buf(),
            line: good.iter().filter(|&&b| b == b'\n').count() + 1,
            column: Some(column),
            message: format!(
                "byte 0x{:02X} is not UTF-8 text (OBJ files are text: save it as UTF-8)",
                bytes[e.valid_up_to()]
            ),
        }
    })?;
    Ok(text.strip_prefix('\u{feff}').unwrap_or(text))
}

/// An error on line `line` of an OBJ file.
fn line_error(path: &Path, line: usize, message: String) -> Error {
    Error::MeshLine {
        path: path.to_path_buf(),
        line,
        column: None,
        message,
    }
}

/// The checks tobj does not make, line by line before it runs: every number of a vertex or
/// normal finite in f32, as tobj will store it (a coordinate divided by its w included), every
/// face with a corner, and at most `max_vertices` vertices and `max_triangles` triangles
/// (so a huge file is refused before tobj grows its arrays). Numbers tobj cannot read at all
/// are left to it: it refuses them, and [`parse`] names the line.
fn check_lines(path: &Path, text: &str, max_vertices: usize, max_triangles: usize) -> Result<()> {
    let (mut vertices, mut triangles) = (0usize, 0usize);
    for (i, line) in text.lines().enumerate() {
        let fail = |message: String| line_error(path, i + 1, message);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                vertices += 1;
                if vertices > max_vertices {
                    return Err(fail(format!(
                        "more than {max_vertices} vertices, the most a mesh may have"
                    )));
                }
                // x y z, and w when a fourth number is all that follows (six are x y z r g b).
                let numbers: Vec<&str> = words.collect();
                let checked = if numbers.len() == 4 {
                    4
                } else {
                    numbers.len().min(3)
                };
                check_numbers(&numbers[..checked]).map_err(&fail)?;
                let stored = stored_coordinates(&numbers).unwrap_or_default();
                if !stored.iter().all(|c| c.is_finite()) {
                    return Err(fail(format!(
                        "dividing by w leaves a coordinate beyond the range of f32: {}",
                        quote(line.trim())
                    )));
                }
                if stored.iter().any(|c| c.abs() > MAX_COORDINATE) {
                    return Err(fail(format!(
                        "a coordinate of {} is over {MAX_COORDINATE:e} in size: the device \
                         multiplies coordinate differences in f32, which would overflow",
                        quote(line.trim())
                    )));
                }
            }
            Some("vn") => {
                check_numbers(&words.take(3).collect::<Vec<_>>()).map_err(&fail)?;
            }
            Some("f" | "l") => {
                let corners = words.count();
                if corners == 0 {
                    return Err(fail("a face without corners".into()));
                }
                // tobj makes a triangle of a point or a line, and a fan of n - 2 of a polygon.
                triangles += corners.max(3) - 2;
                if triangles > max_triangles {
                    return Err(fail(format!(
                        "more than {max_triangles} triangles, the most a mesh may have"
                    )));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Each word that reads as an f32 must be a finite one: NaN and infinity are refused, and so
/// are values finite as written but beyond f32 (`1e39`), which tobj would store as infinite.
fn check_numbers(words: &[&str]) -> std::result::Result<(), String> {
    for word in words {
        let Ok(value) = word.parse::<f32>() else {
            continue;
        };
        if value.is_finite() {
            continue;
        }
        let written = word.parse::<f64>().unwrap_or(f64::NAN);
        return Err(if written.is_finite() {
            format!(
                "{} is beyond the range of f32 (±{:.2e})",
                quote(word),
                f32::MAX
            )
        } else {
            format!("{} is not a finite number", quote(word))
        });
    }
    Ok(())
}

/// The coordinates tobj stores for `v x y z [w]`: divided by w in f32 when a fourth number
/// is all that follows (six are x y z r g b); `None` where it cannot read them (it refuses
/// those, as it does w = 0, which is left undivided here).
fn stored_coordinates(numbers: &[&str]) -> Option<[f32; 3]> {
    let count = if numbers.len() == 4 { 4 } else { 3 };
    let parsed: Vec<f32> = numbers
        .get(..count)?
        .iter()
        .map(|s| s.parse().ok())
        .collect::<Option<_>>()?;
    let w = match parsed.get(3) {
        Some(&w) if w != 0.0 => w,
        _ => 1.0,
    };
    Some([parsed[0] / w, parsed[1] / w, parsed[2] / w])
}

/// The models of the file by tobj, with an error naming the line where it failed.
fn parse(path: &Path, text: &str) -> Result<Vec<tobj::Model>> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let mut rest = text.as_bytes();
    // No material library is ever opened (module doc).
    let result = tobj::load_obj_buf(&mut rest, &options, |_| Ok(Default::default()));
    result.map(|(models, _)| models).map_err(|e| {
        // tobj reads a line at a time and fails on the line it has just read, or at the end of
        // an object (the `o`/`g` line after it, or the end of the file) for indices.
        let consumed = text.len() - rest.len();
        let read = &text.as_bytes()[..consumed.saturating_sub(1)];
        let stop = read.iter().filter(|&&b| b == b'\n').count() + 1;
        let (line, message) = match e {
            tobj::LoadError::FaceVertexOutOfBounds
            | tobj::LoadError::FaceNormalOutOfBounds
            | tobj::LoadError::FaceTexCoordOutOfBounds => out_of_range(text, stop)
                .unwrap_or_else(|| (stop, format!("{e} (by the end of this object)"))),
            e => (
                stop,
                format!("{}: {}", what_tobj_refused(&e), line_at(text, stop)),
            ),
        };
        line_error(path, line, message)
    })
}

/// Line `line` (1-based) of `text`, trimmed and quoted (crate::error::quote).
fn line_at(text: &str, line: usize) -> String {
    quote(text.lines().nth(line - 1).unwrap_or("").trim())
}

/// What tobj's error means, in the file's terms.
fn what_tobj_refused(e: &tobj::LoadError) -> String {
    use tobj::LoadError as E;
    match e {
        E::PositionParseError => "a vertex needs three numbers".into(),
        E::ScalingByZeroError => "a vertex with w = 0".into(),
        E::ColorParseError => "a vertex takes 3 numbers, 4 (with w) or 6 (with a colour)".into(),
        E::NormalParseError => "a normal needs three numbers".into(),
        E::TexcoordParseError => "a texture coordinate needs two numbers".into(),
        E::FaceParseError => {
            "a face corner is `v`, `v/vt`, `v//vn` or `v/vt/vn` in whole numbers".into()
        }
        E::MaterialParseError => "`usemtl` needs a material name".into(),
        e => e.to_string(),
    }
}

/// The elements face corners name: statement and name.
const ELEMENTS: [(&str, &str); 3] = [
    ("v", "vertex"),
    ("vt", "texture coordinate"),
    ("vn", "normal"),
];

/// Which of [`ELEMENTS`] a line defines, if any.
fn element_of(line: &str) -> Option<usize> {
    let word = line.split_whitespace().next()?;
    ELEMENTS.iter().position(|(w, _)| *w == word)
}

/// The first face corner on lines 1 to `stop` that names an element beyond those the file
/// defines by line `stop` (where tobj checked them), with its line and the message.
fn out_of_range(text: &str, stop: usize) -> Option<(usize, String)> {
    let mut total = [0i64; 3];
    for k in text.lines().take(stop).filter_map(element_of) {
        total[k] += 1;
    }
    let mut before = [0i64; 3];
    for (i, line) in text.lines().take(stop).enumerate() {
        if let Some(k) = element_of(line) {
            before[k] += 1;
            continue;
        }
        let mut words = line.split_whitespace();
        if !matches!(words.next(), Some("f" | "l")) {
            continue;
        }
        if let Some(message) = words.find_map(|c| corner_out_of_range(c, &before, &total)) {
            return Some((i + 1, message));
        }
    }
    None
}

/// What is wrong with face corner `v/vt/vn` if it names an element beyond the `total` the
/// file defines, resolved as tobj does: a negative index counts back from the `before`
/// defined before its line; texture and normal indices count only where the file has some
/// (and 0 there means none).
fn corner_out_of_range(corner: &str, before: &[i64; 3], total: &[i64; 3]) -> Option<String> {
    corner.split('/').take(3).enumerate().find_map(|(k, part)| {
        let index = part.parse::<i64>().ok()?;
        let missing = k > 0 && (index == 0 || total[k] == 0);
        let at = if index < 0 {
            before[k] + index
        } else {
            index - 1
        };
        if missing || (0..total[k]).contains(&at) {
            return None;
        }
        let (corner, name) = (quote(corner), ELEMENTS[k].1);
        Some(if index < 0 {
            format!(
                "corner {corner} counts back {} to a {name} before the first (the file \
                 defines {} before this line)",
                -index, before[k]
            )
        } else {
            format!(
                "corner {corner} names {name} {index}; the file defines {} by the end of its \
                 object",
                total[k]
            )
        })
    })
}

/// Every model's vertices, normals (when all have one) and corner indices, merged.
type Merged = (Vec<[f32; 3]>, Option<Vec<[f32; 3]>>, Vec<u32>);

fn merge_models(path: &Path, models: &[tobj::Model]) -> Result<Merged> {
    let fail = |message: String| Error::Mesh {
        path: path.to_path_buf(),
        message,
    };
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut all_have_normals = true;
    let mut corners = Vec::new();
    for model in models {
        let mesh = &model.mesh;
        let base = positions.len();
        if mesh.positions.len() % 3 != 0 {
            return Err(fail(format!(
                "model {} has a partial vertex",
                quote(&model.name)
            )));
        }
        let count = mesh.positions.len() / 3;
        if base + count > MAX_VERTICES {
            return Err(fail(format!(
                "more than {MAX_VERTICES} vertices, the most a mesh may have"
            )));
        }
        positions.extend(mesh.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
        if mesh.normals.len() == mesh.positions.len() && count > 0 {
            normals.extend(mesh.normals.chunks_exact(3).map(|n| [n[0], n[1], n[2]]));
        } else {
            all_have_normals = false;
        }
        // tobj's indices are checked against its positions (parse); this keeps a broken
        // promise from indexing out of bounds later.
        if let Some(&i) = mesh.indices.iter().find(|&&i| i as usize >= count) {
            return Err(fail(format!(
                "model {} refers to vertex {} of {count}",
                quote(&model.name),
                i as u64 + 1
            )));
        }
        corners.extend(mesh.indices.iter().map(|&i| base as u32 + i));
    }
    // Vertex normals serve only when every vertex has a usable one.
    let normals = (all_have_normals && normals.iter().all(|n| usable_normal(*n)))
        .then(|| normals.into_iter().map(normalized).collect());
    Ok((positions, normals, corners))
}

/// The triangles of `corners` a ray can find, with the numbers of degenerate ones and of
/// copies dropped.
///
/// A degenerate triangle has no area (two equal indices, or three corners on a line): no ray
/// hits it. A copy has the same three corner positions as an earlier triangle in the same
/// turning order (from any corner: abc, bca, cab): a ray meets both at one point, and the
/// earlier one is kept. The reversed order (acb) is not a copy: its geometric normal points
/// the other way, and that decides whether a path enters or leaves glass (`kernels/material.h`,
/// `bsdf_sample`), so a pair of opposite faces is a surface of its own. Copies made piles a
/// kd-tree cannot split (2 million copies of a triangle: one leaf, milliseconds a ray) and
/// counted an emitter twice in the light list.
fn surface_triangles(positions: &[[f32; 3]], corners: &[u32]) -> (Vec<[u32; 3]>, usize, usize) {
    let mut triangles = Vec::with_capacity(corners.len() / 3);
    let mut seen = HashSet::with_capacity(corners.len() / 3);
    let (mut degenerate, mut duplicates) = (0, 0);
    for t in corners.chunks_exact(3) {
        let tri = [t[0], t[1], t[2]];
        if !has_area(positions, tri) {
            degenerate += 1;
        } else if !seen.insert(turning_key(positions, tri)) {
            duplicates += 1;
        } else {
            triangles.push(tri);
        }
    }
    (triangles, degenerate, duplicates)
}

/// The corner positions of a triangle as bits (-0 as +0), rotated to start at the smallest:
/// equal for two triangles with the same corners in the same turning order.
fn turning_key(positions: &[[f32; 3]], tri: [u32; 3]) -> [[u32; 3]; 3] {
    let corner = |i: u32| positions[i as usize].map(|c| (c + 0.0).to_bits());
    let mut key = tri.map(corner);
    let first = (0..3).min_by_key(|&i| key[i]).unwrap_or(0);
    key.rotate_left(first);
    key
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

/// `n` at unit length; in f64 where f32 would overflow or underflow (a normal of length 1e30
/// or 1e-30 came out zero or NaN), so any finite non-zero normal gives its direction.
fn normalized(n: [f32; 3]) -> [f32; 3] {
    let v = glam::Vec3::from(n).normalize();
    if v.is_finite() && v != glam::Vec3::ZERO {
        v.to_array()
    } else {
        glam::DVec3::from(n.map(f64::from))
            .normalize()
            .as_vec3()
            .to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertices and triangles are counted as the lines come, tobj's fans and degenerate
    /// points and lines included, and refused at the line that passes the limit.
    #[test]
    fn counts_are_bounded_line_by_line() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\nl 1 2\np 1\nf 1\n";
        let check = |v, t| check_lines(Path::new("m.obj"), text, v, t).map_err(|e| e.to_string());
        assert_eq!(check(4, 4), Ok(()));
        let err = check(3, 4).unwrap_err();
        assert!(
            err.starts_with("mesh m.obj:4: more than 3 vertices"),
            "{err}"
        );
        // f 1 2 3 4 is two triangles, l 1 2 one; p is no face; f 1 the fourth.
        let err = check(4, 3).unwrap_err();
        assert!(
            err.starts_with("mesh m.obj:8: more than 3 triangles"),
            "{err}"
        );
    }

    #[test]
    fn copies_in_the_same_turning_order_are_dropped_reversed_ones_kept() {
        let positions = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [-0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
        ];
        let corners = [
            0, 1, 2, // kept
            1, 2, 0, // a rotation: a copy
            3, 1, 2, // -0 for 0: a copy
            0, 2, 1, // reversed: kept
            0, 1, 4, // no area
            2, 0, 1, // a copy
        ];
        let (triangles, degenerate, duplicates) = surface_triangles(&positions, &corners);
        assert_eq!(triangles, vec![[0, 1, 2], [0, 2, 1]]);
        assert_eq!((degenerate, duplicates), (1, 3));
    }
}
