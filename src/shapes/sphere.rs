//! Spheres (kernels/sphere.h): centre and radius as double-floats, the centre moved to the
//! device's origin (the packing module's doc); an emitting sphere of uniform scale is one
//! light-list entry, sampled over the cap some path can see.

use super::{HostShape, MeshFiles, ObjectPlace, Placement, ShapeSyntax, all_finite, cube_box};
use crate::accel::aabb::Aabb;
use crate::contract::{self, Light, Sphere};
use crate::elements::syntax::{self, Cursor, Token};
use crate::error::Result;
use crate::pack::PackedScene;
use crate::pack::convert::{f32x3, split_f32, split_f32x3};
use crate::pack::lights::{Affine, LightSources, Room, Visible, constant_emission, visible_cap};
use glam::DVec3;
use std::f64::consts::PI;

/// `Sphere { center V radius F }`.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereShape {
    pub center: DVec3,
    pub radius: f64,
}

const FIELDS: [&str; 3] = ["center", "radius", "}"];

impl ShapeSyntax for SphereShape {
    const KEYWORDS: &'static [&'static str] = &["Sphere"];
    const KIND: u32 = contract::OBJECT_SPHERE;

    fn parse<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> syntax::Result<Self> {
        cur.open_block(keyword)?;
        let (mut center, mut radius) = (None, None);
        let close = loop {
            let key = cur.field()?;
            match key.text {
                "}" => break key,
                "center" => cur.once(&mut center, key, |c| c.vector("center").map(|(v, _)| v))?,
                "radius" => cur.once(&mut radius, key, |c| c.positive("radius"))?,
                _ => return Err(cur.unknown_field(key, keyword, &FIELDS)),
            }
        };
        Ok(SphereShape {
            center: cur.required(center, "center", keyword, close)?,
            radius: cur.required(radius, "radius", keyword, close)?,
        })
    }
}

impl HostShape for SphereShape {
    fn pack(
        &self,
        packed: &mut PackedScene,
        object: &ObjectPlace,
        _: &mut MeshFiles,
    ) -> Result<usize> {
        let at = &object.at;
        let (center, center_lo) = split_f32x3(self.center + at.shift);
        let (radius, radius_lo) = split_f32(self.radius);
        let transform = packed.push_transform(at.transform);
        packed.spheres.push(Sphere {
            center,
            radius,
            center_lo,
            radius_lo,
            material: object.material,
            transform,
        });
        Ok(packed.spheres.len() - 1)
    }

    fn texture_axes(&self) -> std::result::Result<(), String> {
        Ok(())
    }

    fn world_bounds(&self, packed: &PackedScene, index: usize, at: &Placement) -> Aabb {
        let s = &packed.spheres[index];
        cube_box(s.center_f64(), s.radius_f64(), at.transform)
    }

    fn finite(&self, packed: &PackedScene, index: usize) -> bool {
        let s = &packed.spheres[index];
        all_finite(
            s.center
                .iter()
                .chain(&s.center_lo)
                .chain([&s.radius, &s.radius_lo]),
        )
    }

    /// The emitting spheres of uniform scale (an ellipsoid is left to BSDF sampling), each
    /// with the power of what some path can see of it.
    fn emitters(scene: &LightSources, room: Option<&Room>, out: &mut Vec<(Light, f64)>) {
        for (i, s) in scene.spheres.iter().enumerate() {
            let Some(le) = constant_emission(scene.materials, s.material) else {
                continue;
            };
            let affine = Affine::of(scene.transforms, s.transform);
            let Some(scale) = affine.uniform_scale() else {
                continue; // an ellipsoid
            };
            let radius = s.radius_f64() * scale;
            let center = affine.point(s.center_f64());
            let mut light = Light {
                kind: contract::OBJECT_SPHERE,
                index: i as u32,
                material: s.material,
                corner: f32x3(center),
                radius: radius as f32,
                ..Light::default()
            };
            // What no path can see of it stays out of its samples (lights.rs' module doc).
            let mut area = 4.0 * PI * radius * radius;
            match visible_cap(scene, room, i, center, radius) {
                Visible::Nothing => continue,
                Visible::Whole => {}
                Visible::Cap { axis, height } => {
                    light.normal = f32x3(axis);
                    light.cap_height = height as f32;
                    area = 2.0 * PI * radius * height;
                    light.area = area as f32;
                }
            }
            out.push((light, PI * le * area));
        }
    }
}
