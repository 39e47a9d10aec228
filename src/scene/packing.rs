//! Packing a whole scene for the device: [`PackedScene::new`], the step above the kinds of
//! object. The camera's basis and the move to the camera-relative origin (`crate::pack`'s doc,
//! on precision), the materials with their texture maps, then each object through its kind
//! ([`crate::shapes::HostShape`]), then the object BVH and the light list
//! ([`PackedScene::finish`]).

use super::{MaterialKind, Scene};
use crate::accel::MeshTree;
use crate::contract::{self, Material};
use crate::elements::Material as SceneMaterial;
use crate::elements::camera::CameraBasis;
use crate::elements::mesh;
use crate::elements::texture::TexturePack;
use crate::error::{Error, Result};
use crate::pack::PackedScene;
use crate::pack::convert::f32x3;
use crate::shapes::{self, MeshFiles, ObjectPlace, Placement};
use glam::{DMat4, DVec3};
use std::collections::HashMap;

impl PackedScene {
    /// Packs `scene` with OBJ files of at most [`mesh::DEFAULT_MAX_FILE_BYTES`], meshes in
    /// kd-trees ([`PackedScene::with_limits`]): the one-lane probes' and benchmarks' default.
    pub fn new(scene: &Scene, max_texture_pixels: u64) -> Result<PackedScene> {
        PackedScene::with_limits(
            scene,
            max_texture_pixels,
            mesh::DEFAULT_MAX_FILE_BYTES,
            MeshTree::Kd,
        )
    }

    /// Packs `scene`, loading its texture maps (each image at most `max_texture_pixels`) and
    /// meshes (each OBJ file at most `max_mesh_bytes`), and building the BVH and each mesh's
    /// `mesh_tree`.
    pub fn with_limits(
        scene: &Scene,
        max_texture_pixels: u64,
        max_mesh_bytes: u64,
        mesh_tree: MeshTree,
    ) -> Result<PackedScene> {
        let textures = TexturePack::load(
            &scene.materials,
            &used_materials(scene),
            scene.base_dir.as_deref(),
            max_texture_pixels,
        )?;
        check_texture_axes(scene, &textures)?;
        let mut camera = CameraBasis::new(&scene.camera)?;
        let origin = camera.origin;
        camera.origin = DVec3::ZERO;
        let mut packed = PackedScene {
            origin,
            camera,
            mesh_tree,
            ..PackedScene::default()
        };
        // Object-to-device transforms: the scene's, then the move to the camera-relative origin.
        let to_device = DMat4::from_translation(-origin);
        packed.materials = pack_materials(&scene.materials, &textures);
        packed.textures = textures;
        let mut files = MeshFiles {
            base_dir: scene.base_dir.as_deref(),
            max_bytes: max_mesh_bytes,
            loaded: HashMap::new(),
        };
        for object in &scene.objects {
            if object.material >= packed.materials.len() {
                return Err(Error::Invalid(format!(
                    "{}: material index {} but the scene has {} materials",
                    object.location,
                    object.material,
                    packed.materials.len()
                )));
            }
            let transforms_before = packed.transforms.len();
            let placed = object.transform.map(|m| to_device * m);
            let place = ObjectPlace {
                material: object.material as u32,
                at: Placement {
                    transform: placed.as_ref(),
                    to_device: &to_device,
                    // Where an untransformed object's coordinates go on the device.
                    shift: if placed.is_some() {
                        DVec3::ZERO
                    } else {
                        -origin
                    },
                },
                location: &object.location,
            };
            let shape = object.shape.host();
            let index = shape.pack(&mut packed, &place, &mut files)?;
            let world_box = shape.world_bounds(&packed, index, &place.at);
            packed.push_object(object.shape.kind(), index, world_box);
            if !(shape.finite(&packed, index) && packed.transforms_finite_since(transforms_before))
            {
                return Err(Error::Invalid(format!(
                    "{}: the object lies too far from the camera at ({:?}, {:?}, {:?}): the \
                     device's coordinates, relative to the camera, overflow f32 (3.4e38) there",
                    object.location, origin.x, origin.y, origin.z
                )));
            }
        }
        packed.finish(shapes::emitters);
        Ok(packed)
    }
}

/// Which materials objects use: only their texture maps are loaded (the original's scenes
/// declare many materials they never use).
fn used_materials(scene: &Scene) -> Vec<bool> {
    let mut used = vec![false; scene.materials.len()];
    for object in &scene.objects {
        if let Some(u) = used.get_mut(object.material) {
            *u = true;
        }
    }
    used
}

/// Refuses texture maps on an object that cannot carry them ([`shapes::HostShape::texture_axes`]).
fn check_texture_axes(scene: &Scene, textures: &TexturePack) -> Result<()> {
    for object in &scene.objects {
        let mapped = textures
            .material_maps
            .get(object.material)
            .is_some_and(|m| m.iter().any(|&i| i != contract::MAP_NONE));
        if let (true, Err(why)) = (mapped, object.shape.host().texture_axes()) {
            return Err(Error::Invalid(format!(
                "{}: this object's material has texture maps, but {why}",
                object.location
            )));
        }
    }
    Ok(())
}

/// The scene's materials, each with its texture maps' indices.
fn pack_materials(materials: &[SceneMaterial], textures: &TexturePack) -> Vec<Material> {
    materials
        .iter()
        .zip(&textures.material_maps)
        .map(
            |(m, &[color_map, emission_map, type_map, bump_map])| Material {
                emission: f32x3(m.emission),
                color: f32x3(m.color),
                kind: match m.kind {
                    MaterialKind::Diffuse => contract::MATERIAL_DIFFUSE,
                    MaterialKind::Specular => contract::MATERIAL_SPECULAR,
                    MaterialKind::Refractive => contract::MATERIAL_REFRACTIVE,
                },
                color_map,
                emission_map,
                type_map,
                bump_map,
            },
        )
        .collect()
}
