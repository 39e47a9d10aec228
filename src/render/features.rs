//! What a scene needs of the renderer, and the program switches that follow from it: one
//! function derives the feature set from a loaded scene ([`Features::of`]), and one builds the
//! `-D` options from it ([`Features::defines`]). Kernel counterpart: kernels/features.h, which
//! documents each switch and defaults them all on.
//!
//! Why so few switches: LuxCore and Cycles both specialised kernels per scene and pulled back
//! to a few coarse switches, because every switch doubles the number of programs to build and
//! cache. Here a switch leaves out code that is large (a whole intersection routine, texture
//! fetches) or that sits on every ray's path (transforms, lens sampling); materials are not
//! switched, as their three branches are a few lines each. The measured gains are in
//! BENCHMARKS.md.

use super::ObjectBvh;
use crate::scene::{Scene, Shape};
use std::fmt;

/// A scene's feature set. Only materials that some object uses count.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Features {
    pub spheres: bool,
    pub planes: bool,
    pub meshes: bool,
    pub revsurfaces: bool,
    /// The one degree of all revolved surfaces, 0 when they differ (or there are none).
    pub rev_degree: usize,
    /// Objects tested through the object BVH rather than kind by kind.
    pub bvh: bool,
    /// Objects inside `Transform`.
    pub transforms: bool,
    /// Texture map kinds in use: colour, emission, type, bump.
    pub color_maps: bool,
    pub emission_maps: bool,
    pub type_maps: bool,
    pub bump_maps: bool,
    /// Depth of field (a thin lens, `flength > 0`).
    pub thin_lens: bool,
    /// Refractive materials (or type maps, which may pick glass).
    pub glass: bool,
    /// Objects whose material emits.
    pub emitters: usize,
    /// Next-event estimation: set by the renderer, which knows the light list it samples
    /// (device/lights.rs `collect_lights`) and whether `--no-nee` was given; `of` leaves it off.
    pub nee: bool,
}

impl Features {
    /// The feature set of `scene`; `object_bvh` says when the BVH is used ([`ObjectBvh`]).
    pub fn of(scene: &Scene, object_bvh: ObjectBvh) -> Features {
        let used: Vec<_> = scene
            .objects
            .iter()
            .filter_map(|o| scene.materials.get(o.material))
            .collect();
        let any_map =
            |f: fn(&crate::scene::TextureFiles) -> bool| used.iter().any(|m| f(&m.textures));
        let degrees: Vec<usize> = scene
            .objects
            .iter()
            .filter_map(|o| match &o.shape {
                Shape::RevSurface { curve } => Some(curve.degree()),
                _ => None,
            })
            .collect();
        let kind = |f: fn(&Shape) -> bool| scene.objects.iter().any(|o| f(&o.shape));
        Features {
            spheres: kind(|s| matches!(s, Shape::Sphere { .. })),
            planes: kind(|s| matches!(s, Shape::Plane { .. })),
            meshes: kind(|s| matches!(s, Shape::Mesh { .. })),
            revsurfaces: !degrees.is_empty(),
            rev_degree: match degrees.split_first() {
                Some((first, rest)) if rest.iter().all(|d| d == first) => *first,
                _ => 0,
            },
            bvh: match object_bvh {
                ObjectBvh::Auto => scene.objects.len() >= super::BVH_MIN_OBJECTS,
                ObjectBvh::On => true,
                ObjectBvh::Off => false,
            },
            transforms: scene.objects.iter().any(|o| o.transform.is_some()),
            color_maps: any_map(|t| t.color.is_some()),
            emission_maps: any_map(|t| t.emission.is_some()),
            type_maps: any_map(|t| t.kind.is_some()),
            bump_maps: any_map(|t| t.bump.is_some()),
            thin_lens: scene.camera.flength > 0.0,
            glass: used.iter().any(|m| {
                m.kind == crate::scene::MaterialKind::Refractive || m.textures.kind.is_some()
            }),
            emitters: scene
                .objects
                .iter()
                .filter(|o| {
                    scene.materials.get(o.material).is_some_and(|m| {
                        m.emission.max_element() > 0.0 || m.textures.emission.is_some()
                    })
                })
                .count(),
            nee: false,
        }
    }

    /// Every feature on: the program that renders any scene (`--all-features`), as the
    /// kernels build with no options. The BVH stays as `object_bvh` and `scene` decide.
    pub fn all(scene: &Scene, object_bvh: ObjectBvh) -> Features {
        Features {
            spheres: true,
            planes: true,
            meshes: true,
            revsurfaces: true,
            rev_degree: 0,
            transforms: true,
            color_maps: true,
            emission_maps: true,
            type_maps: true,
            bump_maps: true,
            thin_lens: true,
            glass: true,
            ..Features::of(scene, object_bvh)
        }
    }

    pub fn textures(&self) -> bool {
        self.color_maps || self.emission_maps || self.type_maps || self.bump_maps
    }

    /// The program switches and values for this feature set (kernels/features.h).
    pub fn defines(&self) -> Vec<(&'static str, String)> {
        let flag = |on: bool| (on as u32).to_string();
        vec![
            ("CLPT_SPHERES", flag(self.spheres)),
            ("CLPT_PLANES", flag(self.planes)),
            ("CLPT_MESHES", flag(self.meshes)),
            ("CLPT_REVSURFACES", flag(self.revsurfaces)),
            ("CLPT_REV_DEGREE", self.rev_degree.to_string()),
            ("CLPT_BVH", flag(self.bvh)),
            ("CLPT_TRANSFORMS", flag(self.transforms)),
            ("CLPT_TEXTURES", flag(self.textures())),
            ("CLPT_THIN_LENS", flag(self.thin_lens)),
            ("CLPT_NEE", flag(self.nee)),
        ]
    }
}

impl fmt::Display for Features {
    /// `spheres planes transforms color-maps thin-lens glass, 2 emitters` and the like.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let rev_degree = format!("revolved-surfaces(degree {})", self.rev_degree);
        let names = [
            (self.spheres, "spheres"),
            (self.planes, "planes"),
            (self.meshes, "meshes"),
            (
                self.revsurfaces && self.rev_degree == 0,
                "revolved-surfaces",
            ),
            (self.revsurfaces && self.rev_degree > 0, rev_degree.as_str()),
            (self.bvh, "bvh"),
            (self.transforms, "transforms"),
            (self.color_maps, "color-maps"),
            (self.emission_maps, "emission-maps"),
            (self.type_maps, "type-maps"),
            (self.bump_maps, "bump-maps"),
            (self.thin_lens, "thin-lens"),
            (self.glass, "glass"),
            (self.nee, "nee"),
        ];
        let on: Vec<&str> = names
            .iter()
            .filter(|(on, _)| *on)
            .map(|(_, n)| *n)
            .collect();
        write!(f, "{}, {} emitters", on.join(" "), self.emitters)
    }
}
