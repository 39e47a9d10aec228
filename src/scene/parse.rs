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
//! Slips found in the original's own files load with a [`Warning`](crate::error::Warning): a `numMaterials` or
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

use super::{CameraDesc, Material, Object, Scene, TextureFiles};
use crate::elements::syntax::{Cursor, Result, Slot, Token, Tokenizer, one_of};
use crate::error::{Location, ParseError};
use crate::shapes::{self, Shape};
use glam::{DMat4, DVec3};

pub use crate::elements::syntax::MAX_NESTING;

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
/// What a `Transform` holds besides its object.
const TRANSFORM_OPS: [&str; 8] = [
    "Scale",
    "UniformScale",
    "Translate",
    "XRotate",
    "YRotate",
    "ZRotate",
    "Rotate",
    "Matrix4f",
];

/// What a block that holds objects may hold: `before`, every kind's keywords, `Transform`, and
/// the closing brace (for messages).
fn items(before: &[&'static str]) -> Vec<&'static str> {
    let kinds = shapes::KEYWORDS
        .iter()
        .flat_map(|words| words.iter().copied());
    before
        .iter()
        .copied()
        .chain(kinds)
        .chain(["Transform", "}"])
        .collect()
}
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
        (c, m, g) => {
            return Err(cur.missing_blocks(&BLOCKS, &[c.is_none(), m.is_none(), g.is_none()]));
        }
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
            _ => return Err(cur.unknown_field(key, keyword, &items(&["MaterialIndex"]))),
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
    word == "Transform" || shapes::is_keyword(word)
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
    if keyword.text == "Transform" {
        return transform_block(cur, keyword);
    }
    match shapes::parse(cur, keyword) {
        Some(shape) => Ok((shape?, None)),
        None => Err(cur.expected(Some(keyword), "an object")),
    }
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
            _ => return Err(cur.unknown_field(key, keyword, &items(&TRANSFORM_OPS))),
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
