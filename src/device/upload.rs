//! Uploads what [`crate::pack`] packed: one read-only device buffer per scene buffer of
//! [`crate::contract::SCENE_BUFFERS`].

use super::Device;
use crate::accel::MeshTree;
use crate::contract::RenderParams;
use crate::error::{Error, Result};
use crate::pack::PackedScene;

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

/// The scene's device buffers, one per name of [`SCENE_BUFFERS`](crate::contract::SCENE_BUFFERS).
pub type SceneBuffers = crate::contract::SceneBuffers<ocl::Buffer<u8>>;

impl SceneBuffers {
    pub fn new(device: &Device, packed: &PackedScene, params: &RenderParams) -> Result<Self> {
        Ok(SceneBuffers {
            params: upload_slice(device, std::slice::from_ref(params))?,
            materials: upload_slice(device, &packed.materials)?,
            spheres: upload_slice(device, &packed.spheres)?,
            planes: upload_slice(device, &packed.planes)?,
            maps: upload_slice(device, &packed.textures.maps)?,
            texels: upload_slice(device, &packed.textures.texels)?,
            transforms: upload_slice(device, &packed.transforms)?,
            meshes: upload_slice(device, &packed.meshes)?,
            mesh_instances: upload_slice(device, &packed.mesh_instances)?,
            kd_nodes: match packed.mesh_tree {
                MeshTree::Kd => upload_slice(device, &packed.kd_nodes)?,
                MeshTree::Bvh2 => upload_slice(device, &packed.bvh2_nodes)?,
                MeshTree::Wide => upload_slice(device, &packed.wide_nodes)?,
            },
            kd_indices: match packed.mesh_tree {
                MeshTree::Bvh2 => upload_slice(device, &packed.bvh2_triangles)?,
                MeshTree::Kd | MeshTree::Wide => upload_slice(device, &packed.kd_indices)?,
            },
            triangles: upload_slice(device, &packed.triangles)?,
            vertices: upload_slice(device, &packed.vertices)?,
            normals: upload_slice(device, &packed.normals)?,
            objects: upload_slice(device, &packed.objects)?,
            bvh: upload_slice(device, &packed.bvh)?,
            revsurfaces: upload_slice(device, &packed.revsurfaces)?,
            rev_points: upload_slice(device, &packed.rev_points)?,
            lights: upload_slice(device, &packed.lights)?,
        })
    }
}
