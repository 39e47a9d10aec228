//! The scene as the device reads it, without a device: the f32 structs of [`crate::contract`]
//! in [`PackedScene`]'s arrays (materials and their texture maps, each kind's objects,
//! transforms, meshes with their trees (kd-trees, binary or 8-wide BVHs), the object table and the BVH over it)
//! and the light list ([`lights`]). Each kind of object packs itself into these arrays
//! (`crate::shapes`, the layer above), and the whole scene is packed by `PackedScene::new`
//! (`crate::scene::packing`, above that); this module holds what the kinds share. Below the
//! device runtime, which uploads what it packs (`device::upload`).
//!
//! Precision. f32 spaces its values by 2^-24 of their size, so a scene stored as written
//! rounds a surface 1e6 from the scene's origin by 0.03, whatever the scene's own scale. Here
//! the device's coordinates are camera-relative (as in renderers for large worlds): the host
//! works in f64 and moves everything by minus the camera's position before rounding, through
//! untransformed objects' coordinates and transformed objects' transforms (object space itself
//! is left as it is), so rounding is relative to distances from the camera. Three stores go
//! further: sphere centres and radii are double-floats (a huge sphere's surface near the camera
//! is otherwise off by the rounding of its radius, 0.004 on smallpt's walls of radius 1e5); a
//! plane's offset is taken through its box centre, about which the rounding of its normal
//! tilts it; and a surface of revolution's profile is stored with its heights centred on 0,
//! the shift folded into its transform, so that its solver's tolerances are relative to the
//! profile's size (revsurface.h). Meshes without a transform have their vertices moved (those
//! with one keep them, and get the move in the transform); an OBJ file used both ways is
//! loaded once for each.

pub mod convert;
pub mod lights;

use crate::accel::MeshTree;
use crate::accel::aabb::Aabb;
use crate::accel::bvh::Bvh;
use crate::contract::{
    self, Bvh2Node, Bvh2Triangle, BvhNode, KdNode, Light, Material, MeshDesc, MeshInstance,
    ObjectRef, Plane, RenderParams, RevSurface, Sphere, Transform, WideBvhNode,
};
use crate::elements::camera::CameraBasis;
use crate::elements::texture::TexturePack;
use convert::rows3x4;
use glam::{DMat4, DVec3};
use std::path::PathBuf;
use std::time::Duration;

/// What `clpt render -v` reports about one mesh file.
#[derive(Clone, Debug)]
pub struct MeshInfo {
    pub path: PathBuf,
    pub triangles: usize,
    pub degenerate: usize,
    /// Triangles dropped as copies of an earlier one.
    pub duplicates: usize,
    pub instances: usize,
    pub build_time: Duration,
    /// Device bytes of its vertices, normals, triangles and tree.
    pub bytes: usize,
}

/// The scene as the kernels read it.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    /// Where the device's coordinates are centred, in the scene's: the camera's position.
    /// Every position, box, transform and light is moved by `-origin` in f64 before it is
    /// rounded to f32, so what the camera sees is stored with the precision of its distance
    /// from the camera, not of its distance from the scene's origin (module doc).
    pub origin: DVec3,
    /// The camera, at the device's origin.
    pub camera: CameraBasis,
    pub materials: Vec<Material>,
    pub spheres: Vec<Sphere>,
    pub planes: Vec<Plane>,
    pub textures: TexturePack,
    pub transforms: Vec<Transform>,
    pub meshes: Vec<MeshDesc>,
    pub mesh_instances: Vec<MeshInstance>,
    /// The tree meshes carry: kd-trees in `kd_nodes`, binary BVHs in `bvh2_nodes` or 8-wide
    /// BVHs in `wide_nodes`. The leaves' triangles are in `kd_indices`, as slots of
    /// `LEAF_SLOT` words, or a binary BVH's in `bvh2_triangles`; the kernels' mesh-node and
    /// leaf buffers hold the one kind.
    pub mesh_tree: MeshTree,
    pub kd_nodes: Vec<KdNode>,
    pub bvh2_nodes: Vec<Bvh2Node>,
    pub wide_nodes: Vec<WideBvhNode>,
    pub kd_indices: Vec<u32>,
    pub bvh2_triangles: Vec<Bvh2Triangle>,
    pub triangles: Vec<[u32; 3]>,
    pub vertices: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub mesh_info: Vec<MeshInfo>,
    /// The BVH's leaves index this table; entries from `first_unbounded` on are tested outside it.
    pub objects: Vec<ObjectRef>,
    pub first_unbounded: u32,
    pub bvh: Vec<BvhNode>,
    pub revsurfaces: Vec<RevSurface>,
    /// The emitters next-event estimation samples ([`lights::collect_lights`]).
    pub lights: Vec<Light>,
    /// The closed room around the camera they are clipped to ([`lights::closed_room`]).
    pub room: Option<lights::Room>,
    /// Control points (x, y) of every surface of revolution's Bezier segments.
    pub rev_points: Vec<[f32; 2]>,
    /// World boxes of `objects[..first_unbounded]`, as the BVH was built on them.
    pub object_boxes: Vec<Aabb>,
}

impl PackedScene {
    /// Whether the transforms packed from `before` on are finite: the host's f64 values are
    /// within f32's range (the parser checks), but their differences from the camera's position
    /// need not be (`crate::shapes::HostShape::finite` checks each kind's own numbers).
    pub fn transforms_finite_since(&self, before: usize) -> bool {
        self.transforms[before..]
            .iter()
            .all(|x| x.m.iter().chain(&x.inv).all(|v| v.is_finite()))
    }

    /// Pushes `m` and its inverse as a device transform, returning its index, or
    /// `TRANSFORM_NONE` for none.
    pub fn push_transform(&mut self, m: Option<&DMat4>) -> u32 {
        match m {
            None => contract::TRANSFORM_NONE,
            Some(m) => {
                self.transforms.push(Transform {
                    m: rows3x4(m),
                    inv: rows3x4(&m.inverse()),
                });
                self.transforms.len() as u32 - 1
            }
        }
    }

    /// Enters object `index` of kind `kind` (`OBJECT_*`), whose device struct is already in its
    /// kind's array, in the object table with its world box: what the object BVH is built on.
    pub fn push_object(&mut self, kind: u32, index: usize, world_box: Aabb) {
        self.objects.push(ObjectRef {
            kind,
            index: index as u32,
        });
        self.object_boxes.push(world_box);
    }

    /// Builds the object BVH over the object table and the light list from every kind's
    /// `emitters` (`crate::shapes::emitters`): the last step of packing, after every object's
    /// [`PackedScene::push_object`].
    pub fn finish(&mut self, emitters: lights::Emitters) {
        self.build_bvh();
        self.collect_lights(emitters);
    }

    fn build_bvh(&mut self) {
        let bvh = Bvh::build(&self.object_boxes);
        self.first_unbounded = self.objects.len() as u32;
        let unbounded: Vec<ObjectRef> = bvh
            .unbounded
            .iter()
            .map(|&i| self.objects[i as usize])
            .collect();
        self.objects.extend(unbounded);
        self.bvh = bvh.nodes;
    }

    /// A line per mesh, and one for the light list, for `clpt render -v`.
    pub fn mesh_report(&self) -> String {
        let mut out = format!(
            "objects: {} in a BVH of {} nodes, {} outside it",
            self.first_unbounded,
            self.bvh.len(),
            self.objects.len() as u32 - self.first_unbounded
        );
        let tree = match self.mesh_tree {
            MeshTree::Kd => "kd-tree",
            MeshTree::Bvh2 => "binary BVH",
            MeshTree::Wide => "8-wide BVH",
        };
        for m in &self.mesh_info {
            out.push_str(&format!(
                "\nmesh {}: {} triangles ({} degenerate and {} copies dropped), {} instance(s), {tree} built in {:.3} s, {} bytes ({:.1} per triangle)",
                m.path.display(),
                m.triangles,
                m.degenerate,
                m.duplicates,
                m.instances,
                m.build_time.as_secs_f64(),
                m.bytes,
                m.bytes as f64 / m.triangles.max(1) as f64
            ));
        }
        out.push('\n');
        out.push_str(&format!(
            "device coordinates centred on the camera at ({}, {}, {})\n",
            self.origin.x, self.origin.y, self.origin.z
        ));
        out.push_str(&lights::report(
            &self.lights,
            self.room.as_ref(),
            self.origin,
        ));
        out
    }

    pub fn params(
        &self,
        seed: u64,
        max_depth: u32,
        rr_depth: u32,
        texture_filter: u32,
    ) -> RenderParams {
        let walls = walls(&self.planes);
        RenderParams {
            camera: self.camera.to_device(),
            counts: self.counts_by_kind(),
            num_objects: self.objects.len() as u32,
            first_unbounded: self.first_unbounded,
            num_bvh_nodes: self.bvh.len() as u32,
            seed_lo: seed as u32,
            seed_hi: (seed >> 32) as u32,
            max_depth,
            rr_depth,
            texture_filter,
            num_lights: self.lights.len() as u32,
            rr_threshold: 1.0,
            walls: walls.0,
            wall_mask: walls.1,
        }
    }

    /// How many objects of each kind are packed, by `OBJECT_*`: the object table holds each
    /// object once before `first_unbounded`.
    fn counts_by_kind(&self) -> [u32; contract::OBJECT_SLOTS] {
        let mut counts = [0; contract::OBJECT_SLOTS];
        for object in &self.objects[..self.first_unbounded as usize] {
            counts[object.kind as usize] += 1;
        }
        counts
    }

    /// The light list of next-event estimation ([`lights::collect_lights`]), clipped to the
    /// closed room around the camera if there is one.
    fn collect_lights(&mut self, emitters: lights::Emitters) {
        let sources = lights::LightSources {
            camera: &self.camera,
            materials: &self.materials,
            maps: &self.textures.maps,
            texels: &self.textures.texels,
            spheres: &self.spheres,
            planes: &self.planes,
            transforms: &self.transforms,
            meshes: &self.meshes,
            mesh_instances: &self.mesh_instances,
            triangles: &self.triangles,
            vertices: &self.vertices,
        };
        let room = lights::closed_room(&sources);
        let list = lights::collect_lights(&sources, room.as_ref(), emitters);
        (self.room, self.lights) = (room, list);
    }
}

/// The planes that a program without an object BVH tests as walls (kernels/plane.h,
/// `walls_intersect`), as `RenderParams::walls` and `wall_mask`. For each axis and sign, the
/// first untransformed plane whose normal is exactly that signed axis, among planes 0 to 31
/// (the mask's bits). A one-sided plane meets only rays moving against its normal, so a ray
/// can meet only one of an axis's two walls. The kernel tests that one per lane, three tests
/// where a room's six walls took six. Other planes, a second one facing the same way included,
/// stay in the plane loop: any choice of walls finds the same hits.
pub fn walls(planes: &[Plane]) -> ([u32; 6], u32) {
    let mut slots = [contract::WALL_NONE; 6];
    let mut mask = 0u32;
    for (i, p) in planes.iter().enumerate().take(32) {
        if p.transform != contract::TRANSFORM_NONE {
            continue;
        }
        let Some(k) = p.axis() else {
            continue;
        };
        let slot = match p.normal[k] {
            1.0 => 2 * k,
            -1.0 => 2 * k + 1,
            _ => continue,
        };
        if slots[slot] == contract::WALL_NONE {
            slots[slot] = i as u32;
            mask |= 1 << i;
        }
    }
    (slots, mask)
}
