//! Host scene → device data, without a device: packs the f64 scene into the f32 structs of
//! [`crate::contract`] ([`PackedScene`]): materials and their texture maps, spheres, planes,
//! transforms, meshes (each OBJ file loaded and its kd-tree, or its 8-wide BVH on a CPU, built
//! once, however many instances use it), the object table and the BVH over it, and the light
//! list ([`lights`]). The layer between [`crate::scene`]/[`crate::accel`] and the device
//! runtime, which uploads what it packs (`device::upload`).
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

use crate::accel::aabb::Aabb;
use crate::accel::bvh::Bvh;
use crate::accel::kdtree::{KdParams, KdTree};
use crate::accel::wide_bvh::WideBvh;
use crate::contract::{
    self, BvhNode, KdNode, Light, Material, MeshDesc, MeshInstance, ObjectRef, Plane, RenderParams,
    RevSurface, Sphere, Transform, WideBvhNode,
};
use crate::error::{Error, Result};
use crate::scene::camera::CameraBasis;
use crate::scene::curve::Curve;
use crate::scene::mesh::{self, TriangleMesh};
use crate::scene::texture::TexturePack;
use crate::scene::{MaterialKind, Scene, Shape};
use convert::{f32x3, rows3x4, split_f32, split_f32x3};
use glam::{DMat4, DVec3};
use std::collections::HashMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

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
    /// Device bytes of its vertices, normals, triangles and kd-tree (or wide BVH).
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
    /// Whether meshes carry 8-wide BVHs ([`WideBvh`], on a CPU: kernels/wide_bvh.h)
    /// in `wide_nodes`, instead of kd-trees in `kd_nodes`; either way their leaves' triangles
    /// are in `kd_indices` (a kd-tree's as numbers, a wide BVH's as slots of
    /// `WIDE_BVH_SLOT` words), and the kernels' mesh-node buffer holds the one kind.
    pub wide_bvh: bool,
    pub kd_nodes: Vec<KdNode>,
    pub wide_nodes: Vec<WideBvhNode>,
    pub kd_indices: Vec<u32>,
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

/// The world box of an object-space box under `m` (all eight corners: the original took two).
fn transform_box(b: &Aabb, m: Option<&DMat4>) -> Aabb {
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

/// Where an object goes on the device: its transform there (the scene's, then the move to the
/// camera-relative origin), that move alone, and the shift of an untransformed object's own
/// coordinates (module doc).
struct Placement<'a> {
    transform: Option<&'a DMat4>,
    to_device: &'a DMat4,
    shift: DVec3,
}

/// A scene plane as written (`Shape::Plane`).
struct PlaneShape {
    normal: DVec3,
    offset: f64,
    range: f64,
    centerp: DVec3,
    dir_u: DVec3,
    dir_v: DVec3,
}

/// The scene's materials, each with its texture maps' indices.
fn pack_materials(scene: &Scene, textures: &TexturePack) -> Vec<Material> {
    scene
        .materials
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

impl PackedScene {
    /// Packs `scene` with OBJ files of at most [`mesh::DEFAULT_MAX_FILE_BYTES`], meshes in
    /// kd-trees ([`PackedScene::with_limits`]).
    pub fn new(scene: &Scene, max_texture_pixels: u64) -> Result<PackedScene> {
        PackedScene::with_limits(
            scene,
            max_texture_pixels,
            mesh::DEFAULT_MAX_FILE_BYTES,
            false,
        )
    }

    /// Packs `scene`, loading its texture maps (each image at most `max_texture_pixels`) and
    /// meshes (each OBJ file at most `max_mesh_bytes`), and building the BVH and each mesh's
    /// kd-tree, or its 8-wide BVH with `wide_bvh` (on a CPU).
    pub fn with_limits(
        scene: &Scene,
        max_texture_pixels: u64,
        max_mesh_bytes: u64,
        wide_bvh: bool,
    ) -> Result<PackedScene> {
        let textures = TexturePack::load(scene, max_texture_pixels)?;
        let mut camera = CameraBasis::new(&scene.camera)?;
        let origin = camera.origin;
        camera.origin = DVec3::ZERO;
        let mut packed = PackedScene {
            origin,
            camera,
            wide_bvh,
            ..PackedScene::default()
        };
        // Object-to-device transforms: the scene's, then the move to the camera-relative origin.
        let to_device = DMat4::from_translation(-origin);
        packed.materials = pack_materials(scene, &textures);
        packed.textures = textures;
        // Each OBJ file's mesh, by whether its vertices are moved to the device's origin.
        let mut loaded: HashMap<(PathBuf, bool), u32> = HashMap::new();
        for object in &scene.objects {
            if object.material >= packed.materials.len() {
                return Err(Error::Invalid(format!(
                    "{}: material index {} but the scene has {} materials",
                    object.location,
                    object.material,
                    packed.materials.len()
                )));
            }
            let material = object.material as u32;
            let before = packed.counts();
            let placed = object.transform.map(|m| to_device * m);
            let at = Placement {
                transform: placed.as_ref(),
                to_device: &to_device,
                // Where an untransformed object's coordinates go on the device.
                shift: if placed.is_some() {
                    DVec3::ZERO
                } else {
                    -origin
                },
            };
            match &object.shape {
                Shape::Sphere { center, radius } => {
                    packed.pack_sphere(*center, *radius, material, &at);
                }
                Shape::Plane {
                    normal,
                    offset,
                    range,
                    centerp,
                    dir_u,
                    dir_v,
                } => {
                    let plane = PlaneShape {
                        normal: *normal,
                        offset: *offset,
                        range: *range,
                        centerp: *centerp,
                        dir_u: *dir_u,
                        dir_v: *dir_v,
                    };
                    packed.pack_plane(&plane, material, &at);
                }
                Shape::RevSurface { curve } => packed.pack_revsurface(curve, material, &at),
                Shape::Mesh { file } => {
                    let path = crate::scene::resolve(
                        "mesh",
                        file,
                        scene.base_dir.as_deref(),
                        &object.location,
                    )?;
                    let mesh = packed.mesh_once(path, &at, &mut loaded, max_mesh_bytes)?;
                    packed.pack_mesh_instance(mesh, material, &at);
                }
            }
            if !packed.finite_since(before) {
                return Err(Error::Invalid(format!(
                    "{}: the object lies too far from the camera at ({:?}, {:?}, {:?}): the \
                     device's coordinates, relative to the camera, overflow f32 (3.4e38) there",
                    object.location, origin.x, origin.y, origin.z
                )));
            }
        }
        packed.build_bvh();
        packed.collect_lights();
        Ok(packed)
    }

    /// How many spheres, planes, transforms, vertices and profile points are packed.
    fn counts(&self) -> [usize; 5] {
        [
            self.spheres.len(),
            self.planes.len(),
            self.transforms.len(),
            self.vertices.len(),
            self.rev_points.len(),
        ]
    }

    /// Whether every number packed since `counts` was `before` is finite: the host's f64 values
    /// are within f32's range (the parser checks), but their differences from the camera's
    /// position need not be.
    fn finite_since(&self, before: [usize; 5]) -> bool {
        let [s, p, t, v, r] = before;
        let finite = |x: &f32| x.is_finite();
        self.spheres[s..].iter().all(|x| {
            x.center
                .iter()
                .chain(&x.center_lo)
                .chain([&x.radius, &x.radius_lo])
                .all(finite)
        }) && self.planes[p..].iter().all(|x| {
            x.normal
                .iter()
                .chain(&x.center)
                .chain(&x.centerp)
                .chain([&x.offset, &x.range])
                .all(finite)
        }) && self.transforms[t..]
            .iter()
            .all(|x| x.m.iter().chain(&x.inv).all(finite))
            && self.vertices[v..].iter().flatten().all(finite)
            && self.rev_points[r..].iter().flatten().all(finite)
    }

    /// A sphere: centre and radius as double-floats, the centre moved to the device's origin
    /// (module doc).
    fn pack_sphere(&mut self, center: DVec3, radius: f64, material: u32, at: &Placement) {
        let (center, center_lo) = split_f32x3(center + at.shift);
        let (radius, radius_lo) = split_f32(radius);
        let sphere = Sphere {
            center,
            radius,
            center_lo,
            radius_lo,
            material,
            transform: self.push_transform(at.transform),
        };
        self.push_sphere(sphere, at.transform);
    }

    /// A plane: its unit normal and, through its box centre, its offset (module doc).
    fn pack_plane(&mut self, p: &PlaneShape, material: u32, at: &Placement) {
        // n.p = offset with n as written: the unit normal, and the offset through
        // the box centre with that normal as rounded, so that its rounding tilts
        // the plane about the centre (on the part a ray can meet) rather than about
        // the origin (module doc).
        let len = p.normal.length();
        let unit = f32x3(p.normal / len);
        let center = (p.normal / len) * (p.offset / len) + at.shift;
        let plane = Plane {
            normal: unit,
            offset: DVec3::from(unit.map(f64::from)).dot(center) as f32,
            range: p.range as f32,
            center: f32x3(center),
            centerp: f32x3(p.centerp + at.shift),
            dir_u: f32x3(p.dir_u),
            dir_v: f32x3(p.dir_v),
            material,
            transform: self.push_transform(at.transform),
        };
        self.push_plane(plane, at.transform);
    }

    /// A surface of revolution: its profile's Bezier segments, heights centred on 0.
    fn pack_revsurface(&mut self, curve: &Curve, material: u32, at: &Placement) {
        let segments = curve.bezier_segments();
        let points = || segments.iter().flatten();
        // Heights centred on 0, the shift folded into the transform (module doc).
        let (y_min, y_max) = points().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
        let y_mid = 0.5 * (y_min + y_max);
        let placement = DMat4::from_translation(DVec3::new(0.0, y_mid, 0.0));
        let centred = Some(at.transform.copied().unwrap_or(*at.to_device) * placement)
            .filter(|m| *m != DMat4::IDENTITY);
        let stored: Vec<[f32; 2]> = points()
            .map(|p| [p.x as f32, (p.y - y_mid) as f32])
            .collect();
        let (radius, y_lo, y_hi) = stored.iter().fold(
            (0.0f32, f32::INFINITY, f32::NEG_INFINITY),
            |(r, lo, hi), p| (r.max(p[0].abs()), lo.min(p[1]), hi.max(p[1])),
        );
        let revsurface = RevSurface {
            first_point: self.rev_points.len() as u32,
            num_segments: segments.len() as u32,
            degree: curve.degree() as u32,
            material,
            transform: self.push_transform(centred.as_ref()),
            radius,
            y_lo,
            y_hi,
        };
        self.rev_points.extend(stored);
        let world = at.transform.copied().unwrap_or(*at.to_device);
        let b = transform_box(&curve.revolution_bounds(), Some(&world));
        self.push_object(contract::OBJECT_REVSURFACE, self.revsurfaces.len(), b);
        self.revsurfaces.push(revsurface);
    }

    /// The mesh of OBJ file `path`, loaded and pushed once for each way it is placed (its
    /// vertices moved to the device's origin, or left for a transform to move): `loaded` holds
    /// those already pushed.
    fn mesh_once(
        &mut self,
        path: PathBuf,
        at: &Placement,
        loaded: &mut HashMap<(PathBuf, bool), u32>,
        max_mesh_bytes: u64,
    ) -> Result<u32> {
        let key = (path, at.transform.is_none());
        if let Some(&m) = loaded.get(&key) {
            return Ok(m);
        }
        let mut mesh = TriangleMesh::load_within(&key.0, max_mesh_bytes)?;
        if at.shift != DVec3::ZERO {
            for v in &mut mesh.positions {
                *v = f32x3(DVec3::from(v.map(f64::from)) + at.shift);
            }
        }
        let m = self.push_mesh(mesh)?;
        loaded.insert(key, m);
        Ok(m)
    }

    /// An instance of mesh `mesh` (already pushed), with its world box in the object table.
    fn pack_mesh_instance(&mut self, mesh: u32, material: u32, at: &Placement) {
        self.mesh_info[mesh as usize].instances += 1;
        let instance = MeshInstance {
            mesh,
            transform: self.push_transform(at.transform),
            material,
        };
        let desc = &self.meshes[mesh as usize];
        let bounds = Aabb {
            lo: DVec3::from(desc.lo.map(f64::from)),
            hi: DVec3::from(desc.hi.map(f64::from)),
        };
        self.push_object(
            contract::OBJECT_MESH,
            self.mesh_instances.len(),
            transform_box(&bounds, at.transform),
        );
        self.mesh_instances.push(instance);
    }

    /// A scene of untransformed spheres and planes made in code (tests, probes), in device
    /// coordinates (origin 0); each plane's box is centred on `normal * offset`, as a scene
    /// file's is.
    pub fn from_parts(
        camera: CameraBasis,
        materials: Vec<Material>,
        spheres: Vec<Sphere>,
        planes: Vec<Plane>,
    ) -> PackedScene {
        let mut packed = PackedScene {
            camera,
            materials,
            ..PackedScene::default()
        };
        for s in spheres {
            packed.push_sphere(s, None);
        }
        for mut p in planes {
            p.center = p.normal.map(|c| c * p.offset);
            packed.push_plane(p, None);
        }
        packed.build_bvh();
        packed.collect_lights();
        packed
    }

    fn push_transform(&mut self, m: Option<&DMat4>) -> u32 {
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

    fn push_object(&mut self, kind: u32, index: usize, world_box: Aabb) {
        self.objects.push(ObjectRef {
            kind,
            index: index as u32,
        });
        self.object_boxes.push(world_box);
    }

    fn push_sphere(&mut self, s: Sphere, transform: Option<&DMat4>) {
        let c = s.center_f64();
        let r = DVec3::splat(s.radius_f64());
        let b = transform_box(
            &Aabb {
                lo: c - r,
                hi: c + r,
            },
            transform,
        );
        self.push_object(contract::OBJECT_SPHERE, self.spheres.len(), b);
        self.spheres.push(s);
    }

    fn push_plane(&mut self, p: Plane, transform: Option<&DMat4>) {
        // The original's finite plane: the cube of half-size `range` around its centre.
        let c = DVec3::from(p.center.map(f64::from));
        let r = DVec3::splat(p.range as f64);
        let b = transform_box(
            &Aabb {
                lo: c - r,
                hi: c + r,
            },
            transform,
        );
        self.push_object(contract::OBJECT_PLANE, self.planes.len(), b);
        self.planes.push(p);
    }

    fn push_mesh(&mut self, mesh: TriangleMesh) -> Result<u32> {
        let start = Instant::now();
        let too_big = |what: &str| Error::Mesh {
            path: mesh.path.clone(),
            message: format!("the scene's meshes exceed 2^32 {what}"),
        };
        let first_node = if self.wide_bvh {
            self.wide_nodes.len()
        } else {
            self.kd_nodes.len()
        };
        let first_node = u32::try_from(first_node).map_err(|_| too_big("tree nodes"))?;
        let first_index = u32::try_from(self.kd_indices.len()).map_err(|_| too_big("indices"))?;
        let (bounds, node_bytes) = if self.wide_bvh {
            let tree =
                WideBvh::build(&mesh.positions, &mesh.triangles).ok_or_else(|| Error::Mesh {
                    path: mesh.path.clone(),
                    message: "more than 2^28 triangles: too many for an 8-wide BVH (--lanes 1 \
                              --mesh-tree kd renders it with a kd-tree)"
                        .into(),
                })?;
            self.wide_nodes.extend(&tree.nodes);
            // Each leaf slot: the triangle's vertices, numbered in the scene's vertex array,
            // and its number in the mesh (kernels/wide_bvh.h reads them at once).
            const { assert!(contract::WIDE_BVH_SLOT == 4) };
            let first_vertex = self.vertices.len();
            for &number in &tree.indices {
                let tri = mesh.triangles[number as usize];
                for v in tri {
                    let v = u32::try_from(first_vertex + v as usize)
                        .map_err(|_| too_big("vertices"))?;
                    self.kd_indices.push(v);
                }
                self.kd_indices.push(number);
            }
            (tree.bounds, tree.nodes.len() * size_of::<WideBvhNode>())
        } else {
            let tree = KdTree::build(&mesh.positions, &mesh.triangles, &KdParams::default());
            self.kd_nodes.extend(&tree.nodes);
            self.kd_indices.extend(&tree.indices);
            (tree.bounds, tree.nodes.len() * size_of::<KdNode>())
        };
        let (lo, hi) = bounds.to_f32_outward();
        let desc = MeshDesc {
            first_node,
            first_index,
            first_triangle: u32::try_from(self.triangles.len())
                .map_err(|_| too_big("triangles"))?,
            first_vertex: u32::try_from(self.vertices.len()).map_err(|_| too_big("vertices"))?,
            has_normals: mesh.normals.is_some() as u32,
            lo,
            hi,
        };
        let bytes = node_bytes
            + (self.kd_indices.len() - first_index as usize) * 4
            + mesh.triangles.len() * 12
            + mesh.positions.len() * 12
            + mesh.normals.as_ref().map_or(0, |n| n.len() * 12);
        self.triangles.extend(&mesh.triangles);
        self.vertices.extend(&mesh.positions);
        if let Some(normals) = &mesh.normals {
            self.normals.extend(normals);
        } else {
            // Keep vertex and normal numbers aligned: normals of this mesh are never read.
            self.normals.resize(self.vertices.len(), [0.0; 3]);
        }
        self.meshes.push(desc);
        self.mesh_info.push(MeshInfo {
            path: mesh.path,
            triangles: mesh.triangles.len(),
            degenerate: mesh.degenerate,
            duplicates: mesh.duplicates,
            instances: 0,
            build_time: start.elapsed(),
            bytes,
        });
        Ok(self.meshes.len() as u32 - 1)
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
        let tree = if self.wide_bvh {
            "8-wide BVH"
        } else {
            "kd-tree"
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
    fn collect_lights(&mut self) {
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
        let list = lights::collect_lights(&sources, room.as_ref());
        (self.room, self.lights) = (room, list);
    }
}

/// The planes that a program without an object BVH tests as walls (kernels/objects.h,
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
