//! Each kind of object, one module a kind holding all the host knows of it: its block in a
//! scene file and what it reads into (`ShapeSyntax`), how it becomes the device's data
//! ([`HostShape::pack`]), its box in device space for the object BVH
//! ([`HostShape::world_bounds`]), whether its numbers survived the move to the camera
//! ([`HostShape::finite`]), whether texture maps can go on it ([`HostShape::texture_axes`])
//! and, for a kind light sampling picks, its light-list entries ([`HostShape::emitters`]). The
//! kinds are listed once, in the `kinds!` list below, which makes [`Shape`] and every dispatch
//! over it; their device side is the contract's `OBJECT_KINDS` and each kind's header in
//! kernels/. docs/adding-a-shape.md says what a new kind adds.
//!
//! The layer between the scene's elements ([`crate::elements`]: its syntax, meshes, curves) and
//! the packed scene's arrays ([`crate::pack`]) below, and the whole scene ([`crate::scene`]),
//! which holds objects of these kinds and packs them, above.

use crate::accel::aabb::Aabb;
use crate::contract::Light;
use crate::elements::syntax::{self, Cursor, Token};
use crate::error::{Location, Result};
use crate::pack::PackedScene;
use crate::pack::lights::{LightSources, Room};
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

    /// Whether texture maps can go on it, and if not why, to follow "this object's material has
    /// texture maps, but": kernels/objects.h's `scene_mapping` gives spheres and planes texture
    /// coordinates, and no other kind.
    fn texture_axes(&self) -> std::result::Result<(), String> {
        Err(
            "objects of its kind carry no texture coordinates in clpt (only spheres and planes \
             do): give it a material without `texture`"
                .into(),
        )
    }

    /// The light-list entries of this kind's packed emitters, each with its power: what light
    /// sampling picks (kernels/nee.h has the kind's sample, density and hit test). None by
    /// default: BSDF sampling finds such emitters at full weight.
    fn emitters(_scene: &LightSources, _room: Option<&Room>, _out: &mut Vec<(Light, f64)>)
    where
        Self: Sized,
    {
    }
}

/// How one kind's objects are written in a scene file.
pub(crate) trait ShapeSyntax: Sized {
    /// The keywords that open its block (`Sphere`; `Mesh` or `TriangleMesh`).
    const KEYWORDS: &'static [&'static str];
    /// Its kind: the contract's `OBJECT_*`.
    const KIND: u32;
    /// Its block, after its keyword: every field checked, errors at file:line:column.
    fn parse<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> syntax::Result<Self>;
}

/// The one list of the host's kinds: each kind's variant of [`Shape`] and the module and
/// struct that hold it. Makes the enum, its `kind` and `host`, the keywords the scene's parser
/// knows objects by, the parser's dispatch on them, and the light list's [`emitters`].
macro_rules! kinds {
    ($($variant:ident($module:ident::$kind:ident)),+ $(,)?) => {
        $(
            mod $module;
            pub use $module::$kind;
        )+

        /// The geometric part of an object: one variant a kind of object (the contract's
        /// `OBJECT_KINDS`).
        #[derive(Clone, Debug, PartialEq)]
        pub enum Shape {
            $($variant($kind),)+
        }

        impl Shape {
            /// Its kind: the contract's `OBJECT_*`.
            pub fn kind(&self) -> u32 {
                match self {
                    $(Shape::$variant(_) => <$kind as ShapeSyntax>::KIND,)+
                }
            }

            /// The host side of its kind.
            pub fn host(&self) -> &dyn HostShape {
                match self {
                    $(Shape::$variant(shape) => shape,)+
                }
            }
        }

        /// Every kind's `OBJECT_*`, in the list's order (checked against the contract's).
        #[cfg(test)]
        const KINDS: &[u32] = &[$(<$kind as ShapeSyntax>::KIND,)+];

        /// The keywords of every kind's block, kind by kind in the list's order.
        pub(crate) const KEYWORDS: &[&[&str]] = &[$(<$kind as ShapeSyntax>::KEYWORDS,)+];

        /// The object block that `keyword` opens, read by its kind, or `None` for a word that
        /// opens no kind's block.
        pub(crate) fn parse<'a>(
            cur: &mut Cursor<'a>,
            keyword: Token<'a>,
        ) -> Option<syntax::Result<Shape>> {
            $(
                if <$kind as ShapeSyntax>::KEYWORDS.contains(&keyword.text) {
                    return Some(<$kind as ShapeSyntax>::parse(cur, keyword).map(Shape::$variant));
                }
            )+
            None
        }

        /// Every kind's emitters ([`HostShape::emitters`]), in no particular order: the light
        /// list sorts them (`lights::collect_lights`).
        pub fn emitters(scene: &LightSources, room: Option<&Room>, out: &mut Vec<(Light, f64)>) {
            $(<$kind as HostShape>::emitters(scene, room, out);)+
        }
    };
}

kinds! {
    Sphere(sphere::SphereShape),
    Plane(plane::PlaneShape),
    Mesh(mesh::MeshShape),
    RevSurface(revsurface::RevSurfaceShape),
}

/// Whether `word` opens an object's block.
pub(crate) fn is_keyword(word: &str) -> bool {
    KEYWORDS.iter().any(|words| words.contains(&word))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::OBJECT_KINDS;

    /// The host's list of kinds and the contract's are the same kinds, and no keyword opens
    /// two kinds' blocks.
    #[test]
    fn the_kinds_are_the_contracts() {
        let contract: Vec<u32> = OBJECT_KINDS.iter().map(|k| k.id).collect();
        assert_eq!(KINDS, contract.as_slice());
        let mut words: Vec<&str> = KEYWORDS.iter().flat_map(|w| w.iter().copied()).collect();
        let all = words.len();
        words.sort();
        words.dedup();
        assert_eq!(words.len(), all);
    }
}
