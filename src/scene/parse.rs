//! Reads a scene file of the original's "seed dialect" into a [`Scene`]; the counterpart of the
//! course framework's `scene_parser` in the original.
//!
//! A scene is three top-level blocks, `PerspectiveCamera`, `Materials` and `Group`, made of
//! whitespace-separated tokens (the format is described in the original's README, section "The
//! scene format"). Every original file made of spheres and planes loads. Beyond the original:
//!
//! - `#` starts a comment that runs to the end of the line, wherever it appears.
//! - `{`, `}`, `[` and `]` are tokens of their own even when glued to a word, so `Sphere{` reads
//!   as `Sphere {` (the original needs spaces around them).
//! - A byte-order mark at the start of the file is skipped.
//! - The top-level blocks, and the fields inside a block, may come in any order.
//!
//! Slips found in the original's own files load with a [`Warning`]: a `numMaterials` or
//! `numObjects` count that differs from what the block lists, and a `MaterialIndex` with no
//! number. Anything else the original would misread is a [`ParseError`] at file:line:column
//! (columns count characters, a tab is one) naming what was expected and what was found:
//! unknown words, malformed or non-finite numbers, repeated or missing fields, values out of
//! range, material indices with no material, blocks left open at the end of the file.
//!
//! Hostile input (issue 14) ends with an error too, never a crash, a hang or a flood: bytes that
//! are not UTF-8 (at their line and column), blocks nested deeper than [`MAX_NESTING`], numbers
//! the device cannot hold as an f32 (finite in f64 but not in f32, or nonzero but 0 in f32), an
//! object whose composed `Transform` or its inverse has such an entry, a projective `Matrix4f`.
//! A bad token is quoted through [`crate::error::quote`]: escaped and at most 60 characters.
//! Negative emission, like a colour outside [0, 1], is clamped with a warning. Tokens are read
//! one at a time as the parser asks for them, and declared counts reserve nothing, so memory
//! follows what the scene holds, not how many tokens or what counts it claims.

use super::curve::{Curve, CurveKind};
use super::{
    CameraDesc, Material, MaterialKind, MeshShape, Object, PlaneShape, RevSurfaceShape, Scene,
    Shape, SphereShape, TextureFiles,
};
use crate::error::{Location, ParseError, Warning, quote};
use glam::{DMat4, DVec2, DVec3};
use std::num::IntErrorKind;
use std::path::PathBuf;

type Result<T> = std::result::Result<T, ParseError>;

/// A field's value with the token of its name, so a repeat can point back at the first one.
type Slot<'a, T> = Option<(T, Token<'a>)>;

const BLOCKS: [&str; 3] = ["PerspectiveCamera", "Materials", "Group"];
const CAMERA_FIELDS: [&str; 8] = [
    "center",
    "direction",
    "angle",
    "width",
    "height",
    "flength",
    "aperture",
    "}",
];
const MATERIAL_FIELDS: [&str; 5] = ["emission", "color", "type", "texture", "}"];
const TEXTURE_FIELDS: [&str; 5] = ["color", "emission", "type", "bump", "}"];
const SPHERE_FIELDS: [&str; 3] = ["center", "radius", "}"];
const PLANE_FIELDS: [&str; 7] = ["normal", "offset", "range", "centerp", "dirU", "dirV", "}"];
const GROUP_ITEMS: [&str; 8] = [
    "MaterialIndex",
    "Sphere",
    "Plane",
    "Mesh",
    "TriangleMesh",
    "Transform",
    "RevSurface",
    "}",
];
const TRANSFORM_ITEMS: [&str; 15] = [
    "Scale",
    "UniformScale",
    "Translate",
    "XRotate",
    "YRotate",
    "ZRotate",
    "Rotate",
    "Matrix4f",
    "Sphere",
    "Plane",
    "Mesh",
    "TriangleMesh",
    "Transform",
    "RevSurface",
    "}",
];

/// Blocks may nest at most this deep (`Group`, each `Transform`, the object, a `Rotate` or curve
/// in it): 10,000 nested `Transform` blocks overflowed the stack. The original's scenes nest 4
/// deep, and nested transforms compose into one matrix per object, so depth buys nothing on the
/// device. Each `Transform` level takes about 2 KiB of the parser's stack (254 levels needed
/// between 384 and 512 KiB, in release and debug builds alike), so 256 levels use a quarter of
/// the 2 MiB a spawned thread gets.
pub const MAX_NESTING: usize = 256;

/// Parses the bytes of a scene file: [`parse_scene`] once they are known to be UTF-8, else an
/// error at the line and column of the first byte that is not.
pub fn parse_scene_bytes(bytes: &[u8], file: &str) -> Result<Scene> {
    let text = std::str::from_utf8(bytes).map_err(|e| not_utf8(bytes, e, file))?;
    parse_scene(text, file)
}

/// Where the text stops being UTF-8, and the bytes there (a Latin-1 `é` is the byte 0xE9).
fn not_utf8(bytes: &[u8], error: std::str::Utf8Error, file: &str) -> ParseError {
    let valid = error.valid_up_to();
    // The bytes before `valid` are UTF-8: `from_utf8` said so.
    let before = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
    let mut counter = Tokenizer::new(before.strip_prefix('\u{feff}').unwrap_or(before));
    counter.advance(counter.rest.len());
    let bad = &bytes[valid..valid + error.error_len().unwrap_or(bytes.len() - valid)];
    let hex: Vec<String> = bad.iter().map(|b| format!("0x{b:02X}")).collect();
    let what = match error.error_len() {
        Some(_) => "not UTF-8 (is the file Latin-1 or Windows-1252? save it as UTF-8)",
        None => "an unfinished UTF-8 character at the end of the file",
    };
    ParseError {
        location: Location {
            file: file.to_string(),
            line: counter.line,
            column: counter.column,
        },
        message: format!(
            "expected UTF-8 text, found the byte{} {}: {what}",
            if bad.len() == 1 { "" } else { "s" },
            hex.join(" ")
        ),
    }
}

/// Parses the text of a scene file; `file` names it in locations and becomes [`Scene::source`].
pub fn parse_scene(text: &str, file: &str) -> Result<Scene> {
    let mut cur = Cursor::new(text, file);
    let (mut camera, mut group) = (None, None);
    let mut materials: Slot<Vec<Material>> = None;
    while let Some(keyword) = cur.next() {
        match keyword.text {
            "PerspectiveCamera" => cur.once(&mut camera, keyword, |c| camera_block(c, keyword))?,
            "Materials" => cur.once(&mut materials, keyword, |c| materials_block(c, keyword))?,
            "Group" => {
                let known = materials.as_ref().map(|(m, _)| m.len());
                cur.once(&mut group, keyword, |c| group_block(c, keyword, known))?
            }
            _ => return Err(cur.expected(Some(keyword), &one_of(&BLOCKS))),
        }
    }
    let (camera, materials, group) = match (camera, materials, group) {
        (Some((c, _)), Some((m, _)), Some((g, _))) => (c, m, g),
        (c, m, g) => return Err(cur.missing_blocks([c.is_none(), m.is_none(), g.is_none()])),
    };

    // A `Group` read before `Materials` could not check its indices then.
    for (index, token) in group.unchecked {
        cur.check_index(index, token, materials.len())?;
    }
    // Objects before any `MaterialIndex` use material 0, which exists only if some material does.
    if let Some(object) = group.objects.iter().find(|o| o.material >= materials.len()) {
        return Err(ParseError {
            location: object.location.clone(),
            message: format!(
                "expected `Materials` to define material {} used by this object, found {} materials",
                object.material,
                materials.len()
            ),
        });
    }

    let mut warnings = cur.warnings;
    warnings.sort_by_key(|w| (w.location.line, w.location.column));
    Ok(Scene {
        source: file.to_string(),
        camera,
        materials,
        objects: group.objects,
        warnings,
        base_dir: None,
    })
}

fn camera_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<CameraDesc> {
    cur.open_block(keyword)?;
    let (mut center, mut direction, mut angle) = (None, None, None);
    let (mut width, mut height, mut flength, mut aperture) = (None, None, None, None);
    let close = loop {
        let key = cur.field()?;
        match key.text {
            "}" => break key,
            "center" => cur.once(&mut center, key, |c| c.vector("center").map(|(v, _)| v))?,
            "direction" => cur.once(&mut direction, key, Cursor::camera_direction)?,
            "angle" => cur.once(&mut angle, key, |c| {
                c.number_where(
                    "angle",
                    |a| a > 0.0 && a < 180.0,
                    "greater than 0 and less than 180",
                )
            })?,
            "width" => cur.once(&mut width, key, |c| c.image_size("width"))?,
            "height" => cur.once(&mut height, key, |c| c.image_size("height"))?,
            "flength" => cur.once(&mut flength, key, |c| c.non_negative("flength"))?,
            "aperture" => cur.once(&mut aperture, key, |c| c.non_negative("aperture"))?,
            _ => return Err(cur.unknown_field(key, keyword, &CAMERA_FIELDS)),
        }
    };
    Ok(CameraDesc {
        center: cur.required(center, "center", keyword, close)?,
        direction: cur.required(direction, "direction", keyword, close)?,
        angle_deg: cur.required(angle, "angle", keyword, close)?,
        width: cur.required(width, "width", keyword, close)?,
        height: cur.required(height, "height", keyword, close)?,
        flength: flength.map_or(0.0, |(v, _)| v),
        aperture: aperture.map_or(0.0, |(v, _)| v),
    })
}

fn materials_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Vec<Material>> {
    cur.open_block(keyword)?;
    let (declared, count) = cur.count_field("numMaterials")?;
    let mut materials = Vec::new();
    loop {
        let key = cur.field()?;
        match key.text {
            "}" => break,
            "Material" => materials.push(material_block(cur, key)?),
            _ => return Err(cur.unknown_field(key, keyword, &["Material", "}"])),
        }
    }
    if declared != materials.len() {
        cur.warn(
            count,
            format!(
                "`numMaterials` declares {declared} materials, but {} `Material` blocks follow",
                materials.len()
            ),
        );
    }
    Ok(materials)
}

fn material_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Material> {
    cur.open_block(keyword)?;
    let (mut emission, mut color, mut kind, mut textures) = (None, None, None, None);
    loop {
        let key = cur.field()?;
        match key.text {
            "}" => break,
            "emission" => cur.once(&mut emission, key, |c| c.vector("emission").map(|(v, _)| v))?,
            "color" => cur.once(&mut color, key, |c| c.vector("color").map(|(v, _)| v))?,
            "type" => cur.once(&mut kind, key, Cursor::material_kind)?,
            "texture" => cur.once(&mut textures, key, |c| texture_block(c, key))?,
            _ => return Err(cur.unknown_field(key, keyword, &MATERIAL_FIELDS)),
        }
    }
    // A colour is the share of light a surface reflects or transmits: above 1 it would make
    // energy, and a closed scene's radiance, and any estimate of it, unbounded (colour 2 in a
    // closed room gave NaN pixels). Clamped to [0, 1], with a warning, as no renderer can give
    // such a scene a finite image; the samples themselves are never clamped.
    let color = color.map_or(DVec3::ONE, |(v, key)| {
        cur.clamped(
            v,
            DVec3::ONE,
            key,
            "is outside [0, 1] (a surface cannot reflect more light than it receives, nor less \
             than none)",
        )
    });
    // Negative emission would subtract light: radiance, and pixels, below zero. Clamped to 0
    // with a warning, as colours are.
    let emission = emission.map_or(DVec3::ZERO, |(v, key)| {
        cur.clamped(
            v,
            DVec3::INFINITY,
            key,
            "is negative (a surface cannot emit less than no light)",
        )
    });
    Ok(Material {
        emission,
        color,
        kind: kind.map(|(v, _)| v).unwrap_or_default(),
        textures: textures.map(|(v, _)| v).unwrap_or_default(),
        location: cur.at(keyword),
    })
}

fn texture_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<TextureFiles> {
    cur.open_block(keyword)?;
    let (mut color, mut emission, mut kind, mut bump) = (None, None, None, None);
    loop {
        let key = cur.field()?;
        match key.text {
            "}" => break,
            "color" => cur.once(&mut color, key, |c| c.path("color"))?,
            "emission" => cur.once(&mut emission, key, |c| c.path("emission"))?,
            "type" => cur.once(&mut kind, key, |c| c.path("type"))?,
            "bump" => cur.once(&mut bump, key, |c| c.path("bump"))?,
            _ => return Err(cur.unknown_field(key, keyword, &TEXTURE_FIELDS)),
        }
    }
    Ok(TextureFiles {
        color: color.map(|(v, _)| v),
        emission: emission.map(|(v, _)| v),
        kind: kind.map(|(v, _)| v),
        bump: bump.map(|(v, _)| v),
    })
}

/// The objects of a `Group`, and the `MaterialIndex` numbers it could not check because no
/// `Materials` block came before it.
struct Group<'a> {
    objects: Vec<Object>,
    unchecked: Vec<(usize, Token<'a>)>,
}

fn group_block<'a>(
    cur: &mut Cursor<'a>,
    keyword: Token<'a>,
    material_count: Option<usize>,
) -> Result<Group<'a>> {
    cur.open_block(keyword)?;
    let (declared, count) = cur.count_field("numObjects")?;
    let mut group = Group {
        objects: Vec::new(),
        unchecked: Vec::new(),
    };
    let mut material = 0;
    loop {
        let key = cur.field()?;
        match key.text {
            "}" => break,
            "MaterialIndex" => {
                // The original's case2 ends its group with a bare `MaterialIndex`.
                if cur
                    .peek()
                    .is_some_and(|t| t.text == "}" || is_object(t.text))
                {
                    cur.warn(key, "`MaterialIndex` without a number is ignored");
                    continue;
                }
                let (index, token) = cur.count("MaterialIndex")?;
                match material_count {
                    Some(n) => cur.check_index(index, token, n)?,
                    None => group.unchecked.push((index, token)),
                }
                material = index;
            }
            word if is_object(word) => {
                let (shape, transform) = object_block(cur, key)?;
                if let Some(m) = &transform {
                    device_matrix(m).map_err(|message| cur.error_at(key, message))?;
                }
                group.objects.push(Object {
                    shape,
                    material,
                    transform,
                    location: cur.at(key),
                });
            }
            _ => return Err(cur.unknown_field(key, keyword, &GROUP_ITEMS)),
        }
    }
    if declared != group.objects.len() {
        cur.warn(
            count,
            format!(
                "`numObjects` declares {declared} objects, but the group lists {}",
                group.objects.len()
            ),
        );
    }
    Ok(group)
}

fn is_object(word: &str) -> bool {
    matches!(
        word,
        "Sphere" | "Plane" | "Mesh" | "TriangleMesh" | "Transform" | "RevSurface"
    )
}

/// Checks an object's composed `Transform` matrix as the device gets it: the top three rows of
/// it and of its inverse must be finite in f32. Each op's numbers fit f32, but products of them
/// need not (`UniformScale 1e20` twice), and one infinite entry blacked out the whole image. A
/// tiny entry that is 0 in f32 is only rounding (a rotation's 6e-17 under a small scale), unless
/// the whole matrix flushes towards 0, and then its inverse is infinite.
fn device_matrix(m: &DMat4) -> std::result::Result<(), String> {
    for (name, matrix) in [("matrix", *m), ("inverse", m.inverse())] {
        let rows = [matrix.row(0), matrix.row(1), matrix.row(2)];
        if let Some(bad) = rows
            .iter()
            .flat_map(|r| r.to_array())
            .find(|&v| !(v as f32).is_finite())
        {
            return Err(format!(
                "expected this object's `Transform` matrix and its inverse to have entries of at \
                 most {:?} in magnitude, as the device holds them as f32s, found {bad:?} in its \
                 {name}",
                f32::MAX
            ));
        }
    }
    Ok(())
}

/// One object (after its keyword), with the matrix of the `Transform` blocks around it.
fn object_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<(Shape, Option<DMat4>)> {
    match keyword.text {
        "Sphere" => Ok((sphere_block(cur, keyword)?, None)),
        "Plane" => Ok((plane_block(cur, keyword)?, None)),
        "Mesh" | "TriangleMesh" => Ok((mesh_block(cur, keyword)?, None)),
        "Transform" => transform_block(cur, keyword),
        _ => Ok((revsurface_block(cur, keyword)?, None)),
    }
}

/// `RevSurface { profile BezierCurve|BsplineCurve { controls [ x y z ] ... } }`: a profile in
/// the xy-plane, revolved about the y axis.
fn revsurface_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Shape> {
    cur.open_block(keyword)?;
    let mut curve = None;
    let close = loop {
        let key = cur.field()?;
        match key.text {
            "}" => break key,
            "profile" => cur.once(&mut curve, key, |c| c.curve())?,
            _ => return Err(cur.unknown_field(key, keyword, &["profile", "}"])),
        }
    };
    Ok(Shape::RevSurface(RevSurfaceShape {
        curve: cur.required(curve, "profile", keyword, close)?,
    }))
}

fn mesh_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Shape> {
    cur.open_block(keyword)?;
    let mut file = None;
    let close = loop {
        let key = cur.field()?;
        match key.text {
            "}" => break key,
            "obj_file" => cur.once(&mut file, key, |c| c.path("obj_file"))?,
            _ => return Err(cur.unknown_field(key, keyword, &["obj_file", "}"])),
        }
    };
    Ok(Shape::Mesh(MeshShape {
        file: cur.required(file, "obj_file", keyword, close)?,
    }))
}

/// `Transform { Op* Object }`. As in the course framework's parser, each op multiplies the
/// matrix on the right (M = M Op, so the first op listed is applied last to the object), and
/// `Matrix4f { 16 numbers }`, read column by column, multiplies it on the left.
fn transform_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<(Shape, Option<DMat4>)> {
    cur.open_block(keyword)?;
    let mut m = DMat4::IDENTITY;
    let mut inner: Option<(Shape, Option<DMat4>)> = None;
    loop {
        let key = cur.field()?;
        match key.text {
            "}" => break,
            "Scale" => m *= DMat4::from_scale(cur.vector("Scale")?.0),
            "UniformScale" => m *= DMat4::from_scale(DVec3::splat(cur.number("UniformScale")?.0)),
            "Translate" => m *= DMat4::from_translation(cur.vector("Translate")?.0),
            "XRotate" => m *= DMat4::from_rotation_x(cur.number("XRotate")?.0.to_radians()),
            "YRotate" => m *= DMat4::from_rotation_y(cur.number("YRotate")?.0.to_radians()),
            "ZRotate" => m *= DMat4::from_rotation_z(cur.number("ZRotate")?.0.to_radians()),
            "Rotate" => {
                cur.open_block(key)?;
                let (_, axis, _) = cur.direction("Rotate")?;
                let degrees = cur.number("Rotate")?.0;
                cur.close_block(key)?;
                m *= DMat4::from_axis_angle(axis, degrees.to_radians());
            }
            "Matrix4f" => {
                cur.open_block(key)?;
                let matrix = cur.affine_matrix()?;
                cur.close_block(key)?;
                m = matrix * m;
            }
            word if is_object(word) => {
                if inner.is_some() {
                    return Err(cur.error_at(
                        key,
                        format!("`Transform` holds one object; found a second, `{word}`"),
                    ));
                }
                inner = Some(object_block(cur, key)?);
            }
            _ => return Err(cur.unknown_field(key, keyword, &TRANSFORM_ITEMS)),
        }
    }
    let Some((shape, inner_m)) = inner else {
        return Err(cur.error_at(keyword, "`Transform` without an object".into()));
    };
    let m = inner_m.map_or(m, |i| m * i);
    // Singular relative to the linear part's own scale, axis by axis: |det| against the product
    // of the lengths of its columns (Hadamard's inequality bounds it by that product, with
    // equality for orthogonal axes), so any uniform or per-axis scale (1e-4, or 1 1e20 1) and any
    // translation pass, and only axes that collapse or nearly line up fail. Below 1e-6 an f32
    // inverse keeps no digit of the flattened direction.
    let axes = [m.x_axis, m.y_axis, m.z_axis].map(|c| c.truncate());
    let lengths: f64 = axes.iter().map(|a| a.length()).product();
    let det = m.determinant();
    if !det.is_finite() || lengths == 0.0 || det.abs() <= 1e-6 * lengths {
        return Err(cur.error_at(
            keyword,
            "this `Transform` is singular or nearly so (a zero scale, or axes that line up): \
             objects would be flattened"
                .into(),
        ));
    }
    Ok((shape, Some(m)))
}

fn sphere_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Shape> {
    cur.open_block(keyword)?;
    let (mut center, mut radius) = (None, None);
    let close = loop {
        let key = cur.field()?;
        match key.text {
            "}" => break key,
            "center" => cur.once(&mut center, key, |c| c.vector("center").map(|(v, _)| v))?,
            "radius" => cur.once(&mut radius, key, |c| c.positive("radius"))?,
            _ => return Err(cur.unknown_field(key, keyword, &SPHERE_FIELDS)),
        }
    };
    Ok(Shape::Sphere(SphereShape {
        center: cur.required(center, "center", keyword, close)?,
        radius: cur.required(radius, "radius", keyword, close)?,
    }))
}

fn plane_block<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> Result<Shape> {
    cur.open_block(keyword)?;
    let (mut normal, mut offset, mut range) = (None, None, None);
    let (mut centerp, mut dir_u, mut dir_v) = (None, None, None);
    let close = loop {
        let key = cur.field()?;
        match key.text {
            "}" => break key,
            "normal" => cur.once(&mut normal, key, |c| c.direction("normal").map(|(v, ..)| v))?,
            // Any size: the device holds offset / |normal|, checked below.
            "offset" => cur.once(&mut offset, key, |c| c.finite_number("`offset`"))?,
            "range" => cur.once(&mut range, key, |c| c.positive("range"))?,
            "centerp" => cur.once(&mut centerp, key, |c| c.vector("centerp").map(|(v, _)| v))?,
            "dirU" => cur.once(&mut dir_u, key, |c| c.vector("dirU").map(|(v, _)| v))?,
            "dirV" => cur.once(&mut dir_v, key, |c| c.vector("dirV").map(|(v, _)| v))?,
            _ => return Err(cur.unknown_field(key, keyword, &PLANE_FIELDS)),
        }
    };
    let normal = cur.required(normal, "normal", keyword, close)?;
    let (offset, offset_token) = cur.required(offset, "offset", keyword, close)?;
    let range = cur.required(range, "range", keyword, close)?;
    let (normal, offset) =
        length_safe_plane(normal, offset).map_err(|m| cur.error_at(offset_token, m))?;
    Ok(Shape::Plane(PlaneShape {
        normal,
        offset,
        range,
        centerp: centerp.map_or(DVec3::ZERO, |(v, _)| v),
        dir_u: dir_u.map_or(DVec3::ZERO, |(v, _)| v),
        dir_v: dir_v.map_or(DVec3::ZERO, |(v, _)| v),
    }))
}

/// Whether the device can hold `value` as an f32: finite there, and not 0 unless it is 0 (a
/// radius of 1e-50 would be none at all).
fn fits_f32(value: f64) -> bool {
    let single = value as f32;
    single.is_finite() && (single != 0.0 || value == 0.0)
}

/// f32's range as messages state it.
fn f32_range() -> String {
    format!(
        "f32's range (0, or a magnitude from {:?} to {:?}, as the device computes in f32)",
        f32::from_bits(1),
        f32::MAX
    )
}

/// A plane's normal (any length) and offset, scaled by one power of two where the normal's
/// length would overflow or underflow f64 (which leaves the plane's points as they are), if the
/// distance from the origin, offset / |normal|, which the device holds, fits an f32.
fn length_safe_plane(normal: DVec3, offset: f64) -> std::result::Result<(DVec3, f64), String> {
    let scale = super::length_safe_scale(normal);
    let (scaled_normal, scaled_offset) = (normal * scale, offset * scale);
    let length = scaled_normal.length();
    if ((scaled_offset / length) as f32).is_finite() {
        Ok((scaled_normal, scaled_offset))
    } else {
        Err(format!(
            "expected `offset` divided by the length of `normal` (the plane's distance from the \
             origin) of at most {:?} in magnitude, as the device holds it as an f32, found {:?} \
             over a normal of length {:?}",
            f32::MAX,
            offset,
            length / scale
        ))
    }
}

/// "`a`, `b` or `c`".
fn one_of(words: &[&str]) -> String {
    listed(words, "or")
}

fn listed(words: &[&str], conjunction: &str) -> String {
    let quoted: Vec<String> = words.iter().map(|w| format!("`{w}`")).collect();
    match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, rest)) => format!("{} {conjunction} {last}", rest.join(", ")),
        None => String::new(),
    }
}

/// A word of the scene file and where it starts (1-based; the column counts characters).
#[derive(Clone, Copy)]
struct Token<'a> {
    text: &'a str,
    line: usize,
    column: usize,
}

fn is_bracket(c: char) -> bool {
    matches!(c, '{' | '}' | '[' | ']')
}

/// Splits a scene's text into tokens, skipping whitespace and `#` comments.
struct Tokenizer<'a> {
    rest: &'a str,
    line: usize,
    column: usize,
}

impl<'a> Tokenizer<'a> {
    fn new(text: &'a str) -> Self {
        Tokenizer {
            rest: text,
            line: 1,
            column: 1,
        }
    }

    /// Consumes the next `len` bytes (always a whole number of characters), keeping the line and
    /// column in step.
    fn advance(&mut self, len: usize) -> &'a str {
        let (taken, rest) = self.rest.split_at_checked(len).unwrap_or((self.rest, ""));
        for c in taken.chars() {
            if c == '\n' {
                self.line += 1;
                self.column = 1;
            } else {
                self.column += 1;
            }
        }
        self.rest = rest;
        taken
    }
}

impl<'a> Iterator for Tokenizer<'a> {
    type Item = Token<'a>;

    fn next(&mut self) -> Option<Token<'a>> {
        let first = loop {
            let c = self.rest.chars().next()?;
            if c == '#' {
                let comment = self.rest.find('\n').unwrap_or(self.rest.len());
                self.advance(comment);
            } else if c.is_whitespace() {
                self.advance(c.len_utf8());
            } else {
                break c;
            }
        };
        let (line, column) = (self.line, self.column);
        let len = if is_bracket(first) {
            first.len_utf8()
        } else {
            self.rest
                .find(|c: char| c.is_whitespace() || c == '#' || is_bracket(c))
                .unwrap_or(self.rest.len())
        };
        Some(Token {
            text: self.advance(len),
            line,
            column,
        })
    }
}

/// The parser's position in the scene's tokens, read one at a time as the parser asks for them
/// (a token list held 32 bytes a token before any was parsed), the blocks open around it, and the
/// warnings so far.
struct Cursor<'a> {
    file: &'a str,
    tokens: Tokenizer<'a>,
    /// The token after the last one taken, once `peek` has read it.
    ahead: Option<Token<'a>>,
    /// The last token taken: end-of-file errors, which come once every token is taken, point
    /// just after it.
    last: Option<Token<'a>>,
    /// Keywords of the blocks opened and not yet closed, innermost last.
    open: Vec<Token<'a>>,
    warnings: Vec<Warning>,
}

impl<'a> Cursor<'a> {
    fn new(text: &'a str, file: &'a str) -> Self {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Cursor {
            file,
            tokens: Tokenizer::new(text),
            ahead: None,
            last: None,
            open: Vec::new(),
            warnings: Vec::new(),
        }
    }

    fn peek(&mut self) -> Option<Token<'a>> {
        if self.ahead.is_none() {
            self.ahead = self.tokens.next();
        }
        self.ahead
    }

    fn next(&mut self) -> Option<Token<'a>> {
        let token = self.ahead.take().or_else(|| self.tokens.next())?;
        self.last = Some(token);
        Some(token)
    }

    /// Just after the last token (1:1 when there is none): where end-of-file errors point.
    fn end(&self) -> Location {
        let (line, column) = self
            .last
            .map_or((1, 1), |t| (t.line, t.column + t.text.chars().count()));
        Location {
            file: self.file.to_string(),
            line,
            column,
        }
    }

    fn at(&self, token: Token) -> Location {
        Location {
            file: self.file.to_string(),
            line: token.line,
            column: token.column,
        }
    }

    fn error_at(&self, token: Token, message: String) -> ParseError {
        ParseError {
            location: self.at(token),
            message,
        }
    }

    fn warn(&mut self, token: Token, message: impl Into<String>) {
        self.warnings.push(Warning {
            location: self.at(token),
            message: message.into(),
        });
    }

    /// `value` clamped to [0, `most`] component by component, with a warning at its field `key`
    /// saying `why` when that changed it.
    fn clamped(&mut self, value: DVec3, most: DVec3, key: Token, why: &str) -> DVec3 {
        let clamped = value.clamp(DVec3::ZERO, most);
        if clamped != value {
            let v = |v: DVec3| format!("{} {} {}", v.x, v.y, v.z);
            self.warn(
                key,
                format!(
                    "`{} {}` {why}: clamped to {}",
                    key.text,
                    v(value),
                    v(clamped)
                ),
            );
        }
        clamped
    }

    /// "expected {what}, found `{token}`", or at the end of the file, naming the innermost block
    /// left open.
    fn expected(&self, found: Option<Token>, what: &str) -> ParseError {
        match found {
            Some(token) => self.error_at(
                token,
                format!("expected {what}, found {}", quote(token.text)),
            ),
            None => ParseError {
                location: self.end(),
                message: match self.open.last() {
                    Some(block) => format!(
                        "expected {what}, found end of file inside {} opened at {}:{}",
                        quote(block.text),
                        block.line,
                        block.column
                    ),
                    None => format!("expected {what}, found end of file"),
                },
            },
        }
    }

    fn unknown_field(&self, key: Token, block: Token, fields: &[&str]) -> ParseError {
        self.expected(
            Some(key),
            &format!("{} in {}", one_of(fields), quote(block.text)),
        )
    }

    fn missing_blocks(&self, missing: [bool; 3]) -> ParseError {
        let names: Vec<&str> = BLOCKS
            .iter()
            .zip(missing)
            .filter_map(|(name, absent)| absent.then_some(*name))
            .collect();
        let what = match names.as_slice() {
            [one] => format!("a `{one}` block"),
            _ => format!("{} blocks", listed(&names, "and")),
        };
        ParseError {
            location: self.end(),
            message: format!("expected {what}, found end of file"),
        }
    }

    /// `BezierCurve { controls [ x y z ] ... }` or `BsplineCurve { ... }`, checked: the points
    /// must lie in the xy-plane (z = 0) and be enough for the curve's kind.
    fn curve(&mut self) -> Result<Curve> {
        let kind_token = match self.next() {
            Some(t) if t.text == "BezierCurve" || t.text == "BsplineCurve" => t,
            found => return Err(self.expected(found, "`BezierCurve` or `BsplineCurve`")),
        };
        let kind = if kind_token.text == "BezierCurve" {
            CurveKind::Bezier
        } else {
            CurveKind::BSpline
        };
        self.open_block(kind_token)?;
        match self.next() {
            Some(t) if t.text == "controls" => {}
            found => return Err(self.expected(found, "`controls`")),
        }
        let mut points = Vec::new();
        loop {
            match self.next() {
                Some(t) if t.text == "}" => {
                    self.open.pop();
                    break;
                }
                Some(t) if t.text == "[" => {
                    let x = self.number("controls")?.0;
                    let y = self.number("controls")?.0;
                    let (z, z_token) = self.number("controls")?;
                    if z != 0.0 {
                        return Err(self.error_at(
                            z_token,
                            format!(
                                "control point {} of the profile has z = {z}: a profile lies in \
                                 the xy-plane (z = 0) and is revolved about the y axis",
                                points.len() + 1
                            ),
                        ));
                    }
                    match self.next() {
                        Some(t) if t.text == "]" => {}
                        found => return Err(self.expected(found, "`]` after a control point")),
                    }
                    points.push(DVec2::new(x, y));
                }
                found => return Err(self.expected(found, "`[` (a control point) or `}`")),
            }
        }
        Curve::new(kind, points).map_err(|message| self.error_at(kind_token, message))
    }

    /// Consumes the `}` that closes a block of fixed contents (`Rotate { .. }`, `Matrix4f`).
    fn close_block(&mut self, keyword: Token<'a>) -> Result<()> {
        match self.next() {
            Some(token) if token.text == "}" => {
                self.open.pop();
                Ok(())
            }
            found => Err(self.expected(found, &format!("`}}` to close {}", quote(keyword.text)))),
        }
    }

    /// Consumes the `{` after a block's keyword and marks the block open, at most
    /// [`MAX_NESTING`] deep.
    fn open_block(&mut self, keyword: Token<'a>) -> Result<()> {
        if self.open.len() >= MAX_NESTING {
            return Err(self.error_at(
                keyword,
                format!(
                    "expected blocks nested at most {MAX_NESTING} deep, found {} {} deep",
                    quote(keyword.text),
                    self.open.len() + 1
                ),
            ));
        }
        match self.next() {
            Some(token) if token.text == "{" => {
                self.open.push(keyword);
                Ok(())
            }
            found => Err(self.expected(found, &format!("`{{` after {}", quote(keyword.text)))),
        }
    }

    /// The next token in the innermost open block: a field name, or the `}` that closes it.
    fn field(&mut self) -> Result<Token<'a>> {
        match self.next() {
            Some(token) => {
                if token.text == "}" {
                    self.open.pop();
                }
                Ok(token)
            }
            None => Err(match self.open.last() {
                Some(block) => ParseError {
                    location: self.end(),
                    message: format!(
                        "expected `}}` to close {} opened at {}:{}, found end of file",
                        quote(block.text),
                        block.line,
                        block.column
                    ),
                },
                None => self.expected(None, "`}`"),
            }),
        }
    }

    /// Reads a field's value into its slot, refusing a field given twice.
    fn once<T>(
        &mut self,
        slot: &mut Slot<'a, T>,
        key: Token<'a>,
        value: impl FnOnce(&mut Self) -> Result<T>,
    ) -> Result<()> {
        if let Some((_, first)) = slot {
            return Err(self.error_at(
                key,
                format!(
                    "expected {} only once, found it again (first at {}:{})",
                    quote(key.text),
                    first.line,
                    first.column
                ),
            ));
        }
        *slot = Some((value(self)?, key));
        Ok(())
    }

    /// A required field's value, or an error at the `}` that closed its block without it.
    fn required<T>(&self, slot: Slot<T>, field: &str, block: Token, close: Token) -> Result<T> {
        slot.map(|(value, _)| value).ok_or_else(|| {
            self.error_at(
                close,
                format!(
                    "expected `{field}` in {} opened at {}:{}, found `}}`",
                    quote(block.text),
                    block.line,
                    block.column
                ),
            )
        })
    }

    /// A number the device reads as an f32, and its token.
    fn number(&mut self, field: &str) -> Result<(f64, Token<'a>)> {
        let (value, token) = self.finite_number(&format!("`{field}`"))?;
        Ok((self.device_value(field, value, token)?, token))
    }

    /// A finite number of any size (`what` names it: "`field`").
    fn finite_number(&mut self, what: &str) -> Result<(f64, Token<'a>)> {
        let found = self.next();
        match found.map(|t| (t.text.parse::<f64>(), t)) {
            Some((Ok(value), token)) if value.is_finite() => Ok((value, token)),
            Some((Ok(_), token)) => {
                Err(self.expected(Some(token), &format!("a finite number for {what}")))
            }
            _ => Err(self.expected(found, &format!("a number for {what}"))),
        }
    }

    /// `value`, read from `token` for `field`, if the device can hold it as an f32.
    fn device_value(&self, field: &str, value: f64, token: Token) -> Result<f64> {
        if fits_f32(value) {
            Ok(value)
        } else {
            Err(self.expected(Some(token), &format!("`{field}` within {}", f32_range())))
        }
    }

    /// A number that must satisfy `ok`; `rule` says how, after "expected `field` ".
    fn number_where(&mut self, field: &str, ok: impl Fn(f64) -> bool, rule: &str) -> Result<f64> {
        let (value, token) = self.number(field)?;
        if ok(value) {
            Ok(value)
        } else {
            Err(self.error_at(
                token,
                format!("expected `{field}` {rule}, found {}", quote(token.text)),
            ))
        }
    }

    fn positive(&mut self, field: &str) -> Result<f64> {
        self.number_where(field, |v| v > 0.0, "greater than 0")
    }

    fn non_negative(&mut self, field: &str) -> Result<f64> {
        self.number_where(field, |v| v >= 0.0, "of at least 0")
    }

    /// Three finite numbers of any size, with their tokens.
    fn components(&mut self, field: &str) -> Result<[(f64, Token<'a>); 3]> {
        let what = format!("`{field}`, which takes three");
        Ok([
            self.finite_number(&what)?,
            self.finite_number(&what)?,
            self.finite_number(&what)?,
        ])
    }

    /// Three numbers the device reads as f32s, and the token of the first.
    fn vector(&mut self, field: &str) -> Result<(DVec3, Token<'a>)> {
        let components = self.components(field)?;
        for (value, token) in components {
            self.device_value(field, value, token)?;
        }
        let [(x, first), (y, _), (z, _)] = components;
        Ok((DVec3::new(x, y, z), first))
    }

    /// A direction: three finite numbers of any size, not all 0, as written and as a unit
    /// vector (normalised without overflow or underflow), and the token of the first.
    fn direction(&mut self, field: &str) -> Result<(DVec3, DVec3, Token<'a>)> {
        let [(x, first), (y, _), (z, _)] = self.components(field)?;
        let written = DVec3::new(x, y, z);
        match super::unit_vector(written) {
            Some(unit) => Ok((written, unit, first)),
            None => Err(self.error_at(
                first,
                format!("expected a nonzero vector for `{field}`, found the zero vector"),
            )),
        }
    }

    /// The camera's `direction` as written, checked as the camera's basis needs it.
    fn camera_direction(&mut self) -> Result<DVec3> {
        let (written, _, first) = self.direction("direction")?;
        super::camera::forward(written)
            .map(|_| written)
            .map_err(|message| self.error_at(first, message))
    }

    /// `Matrix4f`'s 16 numbers, column by column, as the course framework reads them. Its
    /// bottom row (numbers 4, 8, 12, 16) must be 0 0 0 1: the device keeps the top three rows
    /// of an affine matrix, and a projective row was dropped silently.
    fn affine_matrix(&mut self) -> Result<DMat4> {
        let mut columns = [0.0; 16];
        for (i, value) in columns.iter_mut().enumerate() {
            let (number, token) = self.number("Matrix4f")?;
            let bottom = [0.0, 0.0, 0.0, 1.0][i / 4];
            if i % 4 == 3 && number != bottom {
                return Err(self.error_at(
                    token,
                    format!(
                        "expected `{bottom}` as number {} of `Matrix4f`, found {}: read column \
                         by column, its bottom row must be 0 0 0 1, as clpt's transforms are \
                         affine (the device keeps the top three rows; a projective row would be \
                         dropped)",
                        i + 1,
                        quote(token.text)
                    ),
                ));
            }
            *value = number;
        }
        Ok(DMat4::from_cols_array(&columns))
    }

    fn integer(&mut self, field: &str) -> Result<(i64, Token<'a>)> {
        let found = self.next();
        match found.map(|t| (t.text.parse::<i64>(), t)) {
            Some((Ok(integer), token)) => Ok((integer, token)),
            Some((Err(e), token))
                if matches!(
                    e.kind(),
                    IntErrorKind::PosOverflow | IntErrorKind::NegOverflow
                ) =>
            {
                Err(self.expected(
                    Some(token),
                    &format!(
                        "an integer of at most {} in magnitude for `{field}`",
                        i64::MAX
                    ),
                ))
            }
            _ => Err(self.expected(found, &format!("an integer for `{field}`"))),
        }
    }

    fn count(&mut self, field: &str) -> Result<(usize, Token<'a>)> {
        let (value, token) = self.integer(field)?;
        match usize::try_from(value) {
            Ok(count) => Ok((count, token)),
            Err(_) => Err(self.expected(
                Some(token),
                &format!("a non-negative integer for `{field}`"),
            )),
        }
    }

    /// The `numMaterials N` / `numObjects N` that opens a list block, and the token of `N`.
    fn count_field(&mut self, key: &str) -> Result<(usize, Token<'a>)> {
        match self.next() {
            Some(token) if token.text == key => self.count(key),
            found => Err(self.expected(found, &format!("`{key}`"))),
        }
    }

    fn image_size(&mut self, field: &str) -> Result<u32> {
        let (value, token) = self.integer(field)?;
        u32::try_from(value)
            .ok()
            .filter(|v| (1..=65536).contains(v))
            .ok_or_else(|| {
                self.error_at(
                    token,
                    format!(
                        "expected `{field}` between 1 and 65536, found {}",
                        quote(token.text)
                    ),
                )
            })
    }

    fn check_index(&self, index: usize, token: Token, count: usize) -> Result<()> {
        if index < count {
            return Ok(());
        }
        let what = match count {
            0 => "no `MaterialIndex`, as `Materials` lists no material".to_string(),
            _ => format!("a material index from 0 to {}", count - 1),
        };
        Err(self.expected(Some(token), &what))
    }

    fn material_kind(&mut self) -> Result<MaterialKind> {
        let found = self.next();
        match found.map(|t| t.text) {
            Some("diff") => Ok(MaterialKind::Diffuse),
            Some("spec") => Ok(MaterialKind::Specular),
            Some("refr") => Ok(MaterialKind::Refractive),
            _ => Err(self.expected(
                found,
                &format!("{} for `type`", one_of(&["diff", "spec", "refr"])),
            )),
        }
    }

    fn path(&mut self, field: &str) -> Result<PathBuf> {
        match self.next() {
            Some(token) if !token.text.starts_with(is_bracket) => Ok(PathBuf::from(token.text)),
            found => Err(self.expected(found, &format!("a file path for `{field}`"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tokens(text: &str) -> Vec<(&str, usize, usize)> {
        Tokenizer::new(text)
            .map(|t| (t.text, t.line, t.column))
            .collect()
    }

    #[test]
    fn tokens_carry_line_and_character_column() {
        assert_eq!(
            tokens("Sphere {\n\tcenter 1 -2 3.5\n  radius  é9 }"),
            [
                ("Sphere", 1, 1),
                ("{", 1, 8),
                ("center", 2, 2),
                ("1", 2, 9),
                ("-2", 2, 11),
                ("3.5", 2, 14),
                ("radius", 3, 3),
                ("é9", 3, 11),
                ("}", 3, 14),
            ]
        );
    }

    #[test]
    fn brackets_split_from_words_and_comments_are_skipped() {
        assert_eq!(
            tokens("a{b}[c]# x { y\n#\nd#e\n"),
            [
                ("a", 1, 1),
                ("{", 1, 2),
                ("b", 1, 3),
                ("}", 1, 4),
                ("[", 1, 5),
                ("c", 1, 6),
                ("]", 1, 7),
                ("d", 3, 1),
            ]
        );
    }

    #[test]
    fn end_of_file_is_just_after_the_last_token() {
        let end = |text| {
            let mut cur = Cursor::new(text, "f");
            while cur.next().is_some() {}
            let end = cur.end();
            (end.line, end.column)
        };
        assert_eq!(end("a\n  bé # c\n\n"), (2, 5));
        assert_eq!(end(" \n# only a comment\n"), (1, 1));
    }

    #[test]
    fn lists_read_as_english() {
        assert_eq!(one_of(&["a"]), "`a`");
        assert_eq!(one_of(&["a", "b", "c"]), "`a`, `b` or `c`");
        assert_eq!(listed(&["a", "b"], "and"), "`a` and `b`");
    }
}
