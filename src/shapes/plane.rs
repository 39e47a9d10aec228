//! Planes (kernels/plane.h): the unit normal and, through the plane's box centre, its offset
//! (the packing module's doc); an emitting axis-aligned plane is one light-list entry, the
//! square its range keeps, clipped to the closed room around the camera.

use super::{HostShape, MeshFiles, ObjectPlace, Placement, ShapeSyntax, all_finite, cube_box};
use crate::accel::aabb::Aabb;
use crate::contract::{self, Light, Plane};
use crate::elements::syntax::{self, Cursor, Token};
use crate::error::Result;
use crate::pack::PackedScene;
use crate::pack::convert::f32x3;
use crate::pack::lights::{Affine, LightSources, Room, SQUARE, constant_emission, dvec};
use glam::DVec3;
use std::f64::consts::PI;

/// `Plane { normal V offset F range F [centerp V] [dirU V] [dirV V] }`: the points p with
/// normal.p = offset (the normal as written, or for a normal whose length would overflow or
/// underflow f64, normal and offset times one power of two
/// ([`crate::elements::length_safe_scale`]); packing divides normal and offset by its length),
/// visible from the side the normal points to.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneShape {
    pub normal: DVec3,
    pub offset: f64,
    pub range: f64,
    pub centerp: DVec3,
    pub dir_u: DVec3,
    pub dir_v: DVec3,
}

const FIELDS: [&str; 7] = ["normal", "offset", "range", "centerp", "dirU", "dirV", "}"];

impl ShapeSyntax for PlaneShape {
    const KEYWORDS: &'static [&'static str] = &["Plane"];
    const KIND: u32 = contract::OBJECT_PLANE;

    fn parse<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> syntax::Result<Self> {
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
                _ => return Err(cur.unknown_field(key, keyword, &FIELDS)),
            }
        };
        let normal = cur.required(normal, "normal", keyword, close)?;
        let (offset, offset_token) = cur.required(offset, "offset", keyword, close)?;
        let range = cur.required(range, "range", keyword, close)?;
        let (normal, offset) =
            length_safe_plane(normal, offset).map_err(|m| cur.error_at(offset_token, m))?;
        Ok(PlaneShape {
            normal,
            offset,
            range,
            centerp: centerp.map_or(DVec3::ZERO, |(v, _)| v),
            dir_u: dir_u.map_or(DVec3::ZERO, |(v, _)| v),
            dir_v: dir_v.map_or(DVec3::ZERO, |(v, _)| v),
        })
    }
}

/// A plane's normal (any length) and offset, scaled by one power of two where the normal's
/// length would overflow or underflow f64 (which leaves the plane's points as they are), if the
/// distance from the origin, offset / |normal|, which the device holds, fits an f32.
fn length_safe_plane(normal: DVec3, offset: f64) -> std::result::Result<(DVec3, f64), String> {
    let scale = crate::elements::length_safe_scale(normal);
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


impl HostShape for PlaneShape {
    fn pack(
        &self,
        packed: &mut PackedScene,
        object: &ObjectPlace,
        _: &mut MeshFiles,
    ) -> Result<usize> {
        let at = &object.at;
        // n.p = offset with n as written: the unit normal, and the offset through the box
        // centre with that normal as rounded, so that its rounding tilts the plane about the
        // centre (on the part a ray can meet) rather than about the origin (module doc).
        let len = self.normal.length();
        let unit = f32x3(self.normal / len);
        let center = (self.normal / len) * (self.offset / len) + at.shift;
        let transform = packed.push_transform(at.transform);
        packed.planes.push(Plane {
            normal: unit,
            offset: DVec3::from(unit.map(f64::from)).dot(center) as f32,
            range: self.range as f32,
            center: f32x3(center),
            centerp: f32x3(self.centerp + at.shift),
            dir_u: f32x3(self.dir_u),
            dir_v: f32x3(self.dir_v),
            material: object.material,
            transform,
        });
        Ok(packed.planes.len() - 1)
    }

    /// The original's finite plane: the cube of half-size `range` around its centre.
    fn texture_axes(&self) -> std::result::Result<(), String> {
        if self.dir_u.length() == 0.0 || self.dir_v.length() == 0.0 {
            return Err("this plane's `dirU` or `dirV` is zero, and they set the texture's axes \
                        and tile size: give both"
                .into());
        }
        Ok(())
    }

    fn world_bounds(&self, packed: &PackedScene, index: usize, at: &Placement) -> Aabb {
        let p = &packed.planes[index];
        cube_box(dvec(p.center), f64::from(p.range), at.transform)
    }

    fn finite(&self, packed: &PackedScene, index: usize) -> bool {
        let p = &packed.planes[index];
        all_finite(
            p.normal
                .iter()
                .chain(&p.center)
                .chain(&p.centerp)
                .chain([&p.offset, &p.range]),
        )
    }

    /// The emitting axis-aligned planes, each as the square its range keeps (clipped to the
    /// room), with its power.
    fn emitters(scene: &LightSources, room: Option<&Room>, out: &mut Vec<(Light, f64)>) {
        for (i, p) in scene.planes.iter().enumerate() {
            let Some(le) = constant_emission(scene.materials, p.material) else {
                continue;
            };
            let n = dvec(p.normal);
            if p.normal.iter().filter(|&&c| c != 0.0).count() != 1 {
                continue; // tilted: its visible part is a polygon
            }
            // The square centre + [-range, range] along the two other axes: what the plane's
            // range test (plane.h) keeps of it.
            let a = if n.x != 0.0 { DVec3::Y } else { DVec3::X };
            let b = if n.z != 0.0 { DVec3::Y } else { DVec3::Z };
            let range = f64::from(p.range);
            let corner = dvec(p.center) - (a + b) * range;
            let affine = Affine::of(scene.transforms, p.transform);
            let (mut e1, mut e2) = (
                affine.vector(a * 2.0 * range),
                affine.vector(b * 2.0 * range),
            );
            let cross = e1.cross(e2);
            let mut area = cross.length();
            let mut normal = cross / area;
            if normal.dot(affine.normal(n)) < 0.0 {
                std::mem::swap(&mut e1, &mut e2);
                normal = -normal;
            }
            let mut corner = affine.point(corner);
            if let Some(room) = room {
                if room.faces_away(corner, normal) {
                    continue; // seen from behind from everywhere in the room
                }
                let Some([a0, a1, b0, b1]) = room.clip(corner, e1, e2, &SQUARE) else {
                    continue; // wholly outside the room
                };
                corner += e1 * a0 + e2 * b0;
                e1 *= a1 - a0;
                e2 *= b1 - b0;
                area *= (a1 - a0) * (b1 - b0);
            }
            let light = Light {
                kind: contract::OBJECT_PLANE,
                index: i as u32,
                material: p.material,
                corner: f32x3(corner),
                edge1: f32x3(e1),
                edge2: f32x3(e2),
                normal: f32x3(normal),
                area: area as f32,
                // A wall is untransformed: its edges lie along two axes, a rectangle.
                solid_angle: u32::from(room.is_some_and(|room| room.walls.contains(&(i as u32)))),
                ..Light::default()
            };
            out.push((light, PI * le * area));
        }
    }
}
