//! Host scene → device data: packs the f64 scene into the f32 structs of `kernels/types.h`
//! and its texture maps into one texel buffer ([`PackedScene`], testable without a device),
//! and uploads them ([`SceneBuffers`]).

use super::Device;
use super::layout::{self, Material, Plane, RenderParams, Sphere};
use crate::error::{Error, Result};
use crate::scene::camera::CameraBasis;
use crate::scene::texture::TexturePack;
use crate::scene::{MaterialKind, Scene, Shape};
use glam::DVec3;

/// The scene as the kernels read it.
#[derive(Clone, Debug)]
pub struct PackedScene {
    pub camera: CameraBasis,
    pub materials: Vec<Material>,
    pub spheres: Vec<Sphere>,
    pub planes: Vec<Plane>,
    pub textures: TexturePack,
}

fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

impl PackedScene {
    /// Packs `scene`, loading its texture maps (each image at most `max_texture_pixels`).
    pub fn new(scene: &Scene, max_texture_pixels: u64) -> Result<PackedScene> {
        let camera = CameraBasis::new(&scene.camera)?;
        let textures = TexturePack::load(scene, max_texture_pixels)?;
        let materials = scene
            .materials
            .iter()
            .zip(&textures.material_maps)
            .map(
                |(m, &[color_map, emission_map, type_map, bump_map])| Material {
                    emission: f32x3(m.emission),
                    color: f32x3(m.color),
                    kind: match m.kind {
                        MaterialKind::Diffuse => layout::MATERIAL_DIFFUSE,
                        MaterialKind::Specular => layout::MATERIAL_SPECULAR,
                        MaterialKind::Refractive => layout::MATERIAL_REFRACTIVE,
                    },
                    color_map,
                    emission_map,
                    type_map,
                    bump_map,
                },
            )
            .collect::<Vec<_>>();
        let mut spheres = Vec::new();
        let mut planes = Vec::new();
        for object in &scene.objects {
            if object.material >= materials.len() {
                return Err(Error::Invalid(format!(
                    "{}: material index {} but the scene has {} materials",
                    object.location,
                    object.material,
                    materials.len()
                )));
            }
            let material = object.material as u32;
            match &object.shape {
                Shape::Sphere { center, radius } => spheres.push(Sphere {
                    center: f32x3(*center),
                    radius: *radius as f32,
                    material,
                }),
                Shape::Plane {
                    normal,
                    offset,
                    range,
                    centerp,
                    dir_u,
                    dir_v,
                } => {
                    // n.p = offset with n as written; store the unit normal and scale the
                    // offset with it, so the plane is the same set of points.
                    let len = normal.length();
                    planes.push(Plane {
                        normal: f32x3(*normal / len),
                        offset: (*offset / len) as f32,
                        range: *range as f32,
                        centerp: f32x3(*centerp),
                        dir_u: f32x3(*dir_u),
                        dir_v: f32x3(*dir_v),
                        material,
                    })
                }
            }
        }
        Ok(PackedScene {
            camera,
            materials,
            spheres,
            planes,
            textures,
        })
    }

    pub fn params(
        &self,
        seed: u64,
        max_depth: u32,
        rr_depth: u32,
        texture_filter: u32,
    ) -> RenderParams {
        RenderParams {
            camera: self.camera.to_device(),
            num_spheres: self.spheres.len() as u32,
            num_planes: self.planes.len() as u32,
            seed_lo: seed as u32,
            seed_hi: (seed >> 32) as u32,
            max_depth,
            rr_depth,
            texture_filter,
        }
    }
}

/// A read-only device buffer holding `items` as bytes (at least one element: OpenCL has no
/// empty buffers).
pub fn upload_slice<T: bytemuck::Pod + Default>(
    device: &Device,
    items: &[T],
) -> Result<ocl::Buffer<u8>> {
    let fallback = [T::default()];
    let items = if items.is_empty() {
        &fallback[..]
    } else {
        items
    };
    let bytes: &[u8] = bytemuck::cast_slice(items);
    ocl::Buffer::<u8>::builder()
        .queue(device.queue.clone())
        .flags(ocl::flags::MEM_READ_ONLY)
        .len(bytes.len())
        .copy_host_slice(bytes)
        .build()
        .map_err(|e| Error::opencl("uploading scene data", e))
}

/// The scene's device buffers.
pub struct SceneBuffers {
    pub params: ocl::Buffer<u8>,
    pub materials: ocl::Buffer<u8>,
    pub spheres: ocl::Buffer<u8>,
    pub planes: ocl::Buffer<u8>,
    pub maps: ocl::Buffer<u8>,
    pub texels: ocl::Buffer<u8>,
}

impl SceneBuffers {
    pub fn new(device: &Device, packed: &PackedScene, params: &RenderParams) -> Result<Self> {
        Ok(SceneBuffers {
            params: upload_slice(device, std::slice::from_ref(params))?,
            materials: upload_slice(device, &packed.materials)?,
            spheres: upload_slice(device, &packed.spheres)?,
            planes: upload_slice(device, &packed.planes)?,
            maps: upload_slice(device, &packed.textures.maps)?,
            texels: upload_slice(device, &packed.textures.texels)?,
        })
    }
}
