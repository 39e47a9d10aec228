//! Each kind of object on the host, one module a kind: how an object of the scene becomes the
//! device's data ([`HostShape::pack`]), its box in device space for the object BVH
//! ([`HostShape::world_bounds`]), whether its numbers survived the move to the camera
//! ([`HostShape::finite`]) and, for a kind light sampling picks, its light-list entries
//! ([`HostShape::emitters`]). The kinds are the contract's `OBJECT_KINDS`; their device side is
//! kernels/shapes.h and each kind's header. docs/adding-a-shape.md says what a new kind adds.

mod mesh;
mod plane;
mod revsurface;
mod sphere;

use super::PackedScene;
use super::lights::{LightSources, Room};
use crate::accel::aabb::Aabb;
use crate::contract::Light;
use crate::error::{Location, Result};
use crate::scene::Shape;
use glam::{DMat4, DVec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Where an object goes on the device: its transform there (the scene's, then the move to the
/// camera-relative origin), that move alone, and the shift of an untransformed object's own
/// coordinates (the packing module's doc).
pub struct Placement<'a> {
    pub transform: Option<&'a DMat4>,
    pub to_device: &'a DMat4,
    pub shift: DVec3,
}

/// One object to pack: its material, its placement and where the scene file declares it.
pub struct ObjectPlace<'a> {
    pub material: u32,
    pub at: Placement<'a>,
    pub location: &'a Location,
}

/// The OBJ files of a scene: where relative paths start, the largest file read, and each
/// file's mesh once packed, by whether its vertices were moved to the device's origin.
pub struct MeshFiles<'a> {
    pub base_dir: Option<&'a Path>,
    pub max_bytes: u64,
    pub loaded: HashMap<(PathBuf, bool), u32>,
}

/// One kind of object on the host.
pub trait HostShape {
    /// Packs the object into `packed`: its device struct, pushed onto its kind's array, and
    /// what that points to (its transform, its profile points, its mesh, loaded once through
    /// `files`). Returns its index among its kind.
    fn pack(
        &self,
        packed: &mut PackedScene,
        object: &ObjectPlace,
        files: &mut MeshFiles,
    ) -> Result<usize>;

    /// Its box in device space once packed as `index` at `at`: what the object BVH is built
    /// on (`crate::accel::bvh`).
    fn world_bounds(&self, packed: &PackedScene, index: usize, at: &Placement) -> Aabb;

    /// Whether the numbers packed for object `index` are finite: an object far from the camera
    /// can overflow f32 once moved to the camera-relative origin (the scene's numbers are
    /// checked by the parser). Its transform is checked with the others.
    fn finite(&self, packed: &PackedScene, index: usize) -> bool;

    /// The light-list entries of this kind's packed emitters, each with its power: what light
    /// sampling picks (kernels/nee.h has the kind's sample, density and hit test). None by
    /// default: BSDF sampling finds such emitters at full weight.
    fn emitters(_scene: &LightSources, _room: Option<&Room>, _out: &mut Vec<(Light, f64)>)
    where
        Self: Sized,
    {
    }
}

/// The host side of `shape`'s kind.
pub fn host(shape: &Shape) -> &dyn HostShape {
    match shape {
        Shape::Sphere(s) => s,
        Shape::Plane(p) => p,
        Shape::Mesh(m) => m,
        Shape::RevSurface(r) => r,
    }
}

/// Every kind's emitters ([`HostShape::emitters`]), in no particular order: the light list
/// sorts them (`lights::collect_lights`).
pub fn emitters(scene: &LightSources, room: Option<&Room>, out: &mut Vec<(Light, f64)>) {
    use crate::scene::{MeshShape, PlaneShape, RevSurfaceShape, SphereShape};
    SphereShape::emitters(scene, room, out);
    PlaneShape::emitters(scene, room, out);
    MeshShape::emitters(scene, room, out);
    RevSurfaceShape::emitters(scene, room, out);
}

/// The world box of an object-space box under `m` (all eight corners: the original took two).
pub fn transform_box(b: &Aabb, m: Option<&DMat4>) -> Aabb {
    let Some(m) = m else { return *b };
    Aabb::from_points((0..8).map(|i| {
        let corner = DVec3::new(
            if i & 1 == 0 { b.lo.x } else { b.hi.x },
            if i & 2 == 0 { b.lo.y } else { b.hi.y },
            if i & 4 == 0 { b.lo.z } else { b.hi.z },
        );
        m.transform_point3(corner)
    }))
}

/// Whether every number is finite.
fn all_finite<'a>(numbers: impl IntoIterator<Item = &'a f32>) -> bool {
    numbers.into_iter().all(|x| x.is_finite())
}

/// The box of half-size `half` about `centre`, under `m`.
pub fn cube_box(centre: DVec3, half: f64, m: Option<&DMat4>) -> Aabb {
    let r = DVec3::splat(half);
    transform_box(
        &Aabb {
            lo: centre - r,
            hi: centre + r,
        },
        m,
    )
}
