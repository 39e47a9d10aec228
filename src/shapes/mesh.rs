//! Triangle meshes (kernels/triangle.h, kdtree.h, bvh2.h, wide_bvh.h): each OBJ file loaded
//! once for each way it is placed, its tree (a GPU's binary BVH, a CPU's 8-wide BVH, or a
//! kd-tree: `PackedScene::mesh_tree`) built once however many instances use it, and one
//! instance an object; an emitting mesh's triangles that some path can see are light-list
//! entries.

use super::{HostShape, MeshFiles, ObjectPlace, Placement, ShapeSyntax, all_finite, transform_box};
use crate::accel::aabb::Aabb;
use crate::accel::kdtree::{KdParams, KdTree};
use crate::accel::MeshTree;
use crate::accel::bvh2::Bvh2;
use crate::accel::wide_bvh::WideBvh;
use crate::contract::{
    self, Bvh2Node, Bvh2Triangle, KdNode, Light, MeshDesc, MeshInstance, WideBvhNode,
};
use crate::error::{Error, Result};
use crate::pack::convert::f32x3;
use crate::pack::lights::{Affine, LightSources, Room, TRIANGLE, constant_emission, dvec};
use crate::pack::{MeshInfo, PackedScene};
use crate::elements::mesh::TriangleMesh;
use crate::elements::syntax::{self, Cursor, Token};
use glam::DVec3;
use std::f64::consts::PI;
use std::path::PathBuf;
use std::time::Instant;

/// `Mesh { obj_file PATH }` or `TriangleMesh { obj_file PATH }`: the path as written,
/// resolved like texture paths when the mesh is loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshShape {
    pub file: PathBuf,
}

impl ShapeSyntax for MeshShape {
    const KEYWORDS: &'static [&'static str] = &["Mesh", "TriangleMesh"];
    const KIND: u32 = contract::OBJECT_MESH;

    fn parse<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> syntax::Result<Self> {
        cur.open_block(keyword)?;
        let mut file = None;
        let close = loop {
            let key = cur.field()?;
            match key.text {
                "}" => break key,
                "obj_file" => cur.once(&mut file, key, |c| c.path("obj_file"))?,
                _ => return Err(cur.unknown_field(key, keyword, &["obj_file", "}"])),
            }
        };
        Ok(MeshShape {
            file: cur.required(file, "obj_file", keyword, close)?,
        })
    }
}

impl HostShape for MeshShape {
    /// An instance of the OBJ file's mesh, loaded and pushed once for each way it is placed
    /// (its vertices moved to the device's origin, or left for a transform to move).
    fn pack(
        &self,
        packed: &mut PackedScene,
        object: &ObjectPlace,
        files: &mut MeshFiles,
    ) -> Result<usize> {
        let at = &object.at;
        let path = crate::elements::resolve("mesh", &self.file, files.base_dir, object.location)?;
        let key = (path, at.transform.is_none());
        let mesh = match files.loaded.get(&key) {
            Some(&m) => m,
            None => {
                let mut mesh = TriangleMesh::load_within(&key.0, files.max_bytes)?;
                if at.shift != DVec3::ZERO {
                    for v in &mut mesh.positions {
                        *v = f32x3(DVec3::from(v.map(f64::from)) + at.shift);
                    }
                }
                let m = push_mesh(packed, mesh)?;
                files.loaded.insert(key, m);
                m
            }
        };
        packed.mesh_info[mesh as usize].instances += 1;
        let transform = packed.push_transform(at.transform);
        packed.mesh_instances.push(MeshInstance {
            mesh,
            transform,
            material: object.material,
        });
        Ok(packed.mesh_instances.len() - 1)
    }

    /// Its mesh's box (the tree's, rounded outward to f32) under the instance's transform.
    fn world_bounds(&self, packed: &PackedScene, index: usize, at: &Placement) -> Aabb {
        let desc = &packed.meshes[packed.mesh_instances[index].mesh as usize];
        let bounds = Aabb {
            lo: dvec(desc.lo),
            hi: dvec(desc.hi),
        };
        transform_box(&bounds, at.transform)
    }

    /// Its mesh's vertices, once: when this is the mesh's first instance (a mesh moved to the
    /// device's origin is pushed once for each way it is placed).
    fn finite(&self, packed: &PackedScene, index: usize) -> bool {
        let mesh = packed.mesh_instances[index].mesh as usize;
        if packed.mesh_info[mesh].instances != 1 {
            return true;
        }
        let first = packed.meshes[mesh].first_vertex as usize;
        let end = packed
            .meshes
            .get(mesh + 1)
            .map_or(packed.vertices.len(), |next| next.first_vertex as usize);
        all_finite(packed.vertices[first..end].iter().flatten())
    }

    /// Every triangle of the emitting meshes that some path can see, with its power (both sides).
    fn emitters(scene: &LightSources, room: Option<&Room>, out: &mut Vec<(Light, f64)>) {
        for (i, inst) in scene.mesh_instances.iter().enumerate() {
            let Some(le) = constant_emission(scene.materials, inst.material) else {
                continue;
            };
            let affine = Affine::of(scene.transforms, inst.transform);
            let mesh = &scene.meshes[inst.mesh as usize];
            let end = scene
                .meshes
                .get(inst.mesh as usize + 1)
                .map_or(scene.triangles.len(), |next| next.first_triangle as usize);
            let first = mesh.first_triangle as usize;
            for (t, tri) in scene.triangles[first..end].iter().enumerate() {
                let v = tri
                    .map(|k| affine.point(dvec(scene.vertices[(mesh.first_vertex + k) as usize])));
                let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
                let cross = e1.cross(e2);
                let area = 0.5 * cross.length();
                if area.is_nan() || area <= 0.0 {
                    continue; // degenerate: nothing to sample, and no ray hits it
                }
                if room.is_some_and(|room| room.clip(v[0], e1, e2, &TRIANGLE).is_none()) {
                    continue; // wholly outside the room: no path sees it
                }
                let light = Light {
                    kind: contract::OBJECT_MESH,
                    index: i as u32,
                    triangle: t as u32,
                    material: inst.material,
                    corner: f32x3(v[0]),
                    edge1: f32x3(e1),
                    edge2: f32x3(e2),
                    normal: f32x3(cross.normalize()),
                    area: area as f32,
                    ..Light::default()
                };
                out.push((light, 2.0 * PI * le * area));
            }
        }
    }
}

/// Pushes a tree's leaf slots, one for each of its triangle numbers `indices`: the triangle's
/// vertices, numbered in the scene's vertex array (where the mesh's vertices go next), and its
/// number in the mesh. A leaf's triangle then costs one load of its slot before its vertices,
/// where a list of triangle numbers cost two (kernels/triangle.h, `slots_intersect`).
fn push_slots(
    packed: &mut PackedScene,
    mesh: &TriangleMesh,
    indices: &[u32],
) -> std::result::Result<(), std::num::TryFromIntError> {
    const { assert!(contract::LEAF_SLOT == 4) };
    let first_vertex = packed.vertices.len();
    packed.kd_indices.reserve(indices.len() * 4);
    for &number in indices {
        for v in mesh.triangles[number as usize] {
            packed.kd_indices.push(u32::try_from(first_vertex + v as usize)?);
        }
        packed.kd_indices.push(number);
    }
    Ok(())
}

/// Pushes a binary BVH's leaf triangles (`indices`, triangle numbers of `mesh` in the leaves'
/// order) with their vertices: a leaf's walk reads them at once (kernels/bvh2.h), where slots
/// of vertex numbers cost a dependent load of each vertex (H100: case1 1 to 3%, the dragon room
/// 3 to 4% faster; BENCHMARKS.md, "A binary BVH's triangles in its leaves").
fn push_bvh2_triangles(packed: &mut PackedScene, mesh: &TriangleMesh, indices: &[u32]) {
    packed.bvh2_triangles.reserve(indices.len());
    for &number in indices {
        let [a, b, c] = mesh.triangles[number as usize].map(|v| mesh.positions[v as usize]);
        packed.bvh2_triangles.push(Bvh2Triangle {
            vertices: [a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]],
            number,
            pad: [0; 2],
        });
    }
}

/// Pushes a loaded mesh: its tree, triangles, vertices and normals; its number.
fn push_mesh(packed: &mut PackedScene, mesh: TriangleMesh) -> Result<u32> {
    let start = Instant::now();
    let too_big = |what: &str| Error::Mesh {
        path: mesh.path.clone(),
        message: format!("the scene's meshes exceed 2^32 {what}"),
    };
    let (first_node, first_index) = match packed.mesh_tree {
        MeshTree::Kd => (packed.kd_nodes.len(), packed.kd_indices.len()),
        MeshTree::Bvh2 => (packed.bvh2_nodes.len(), packed.bvh2_triangles.len()),
        MeshTree::Wide => (packed.wide_nodes.len(), packed.kd_indices.len()),
    };
    let first_node = u32::try_from(first_node).map_err(|_| too_big("tree nodes"))?;
    let first_index = u32::try_from(first_index).map_err(|_| too_big("indices"))?;
    let bvh_too_big = |what: &str| Error::Mesh {
        path: mesh.path.clone(),
        message: format!(
            "2^28 triangles or more: too many for {what} (--lanes 1 --mesh-tree kd renders it \
             with a kd-tree)"
        ),
    };
    // The tree's bounds and device bytes: its nodes and its leaves' entries.
    let slot_bytes = 4 * contract::LEAF_SLOT as usize;
    let (bounds, tree_bytes) = match packed.mesh_tree {
        MeshTree::Kd => {
            let tree = KdTree::build(&mesh.positions, &mesh.triangles, &KdParams::default());
            packed.kd_nodes.extend(&tree.nodes);
            push_slots(packed, &mesh, &tree.indices).map_err(|_| too_big("vertices"))?;
            let bytes = tree.nodes.len() * size_of::<KdNode>() + tree.indices.len() * slot_bytes;
            (tree.bounds, bytes)
        }
        MeshTree::Bvh2 => {
            let tree = Bvh2::build(&mesh.positions, &mesh.triangles)
                .ok_or_else(|| bvh_too_big("a binary BVH"))?;
            packed.bvh2_nodes.extend(&tree.nodes);
            push_bvh2_triangles(packed, &mesh, &tree.indices);
            let leaves = tree.indices.len() * size_of::<Bvh2Triangle>();
            (tree.bounds, tree.nodes.len() * size_of::<Bvh2Node>() + leaves)
        }
        MeshTree::Wide => {
            let tree = WideBvh::build(&mesh.positions, &mesh.triangles)
                .ok_or_else(|| bvh_too_big("an 8-wide BVH"))?;
            packed.wide_nodes.extend(&tree.nodes);
            push_slots(packed, &mesh, &tree.indices).map_err(|_| too_big("vertices"))?;
            let leaves = tree.indices.len() * slot_bytes;
            (tree.bounds, tree.nodes.len() * size_of::<WideBvhNode>() + leaves)
        }
    };
    let (lo, hi) = bounds.to_f32_outward();
    let desc = MeshDesc {
        first_node,
        first_index,
        first_triangle: u32::try_from(packed.triangles.len()).map_err(|_| too_big("triangles"))?,
        first_vertex: u32::try_from(packed.vertices.len()).map_err(|_| too_big("vertices"))?,
        has_normals: mesh.normals.is_some() as u32,
        lo,
        hi,
    };
    let bytes = tree_bytes
        + mesh.triangles.len() * 12
        + mesh.positions.len() * 12
        + mesh.normals.as_ref().map_or(0, |n| n.len() * 12);
    packed.triangles.extend(&mesh.triangles);
    packed.vertices.extend(&mesh.positions);
    if let Some(normals) = &mesh.normals {
        packed.normals.extend(normals);
    } else {
        // Keep vertex and normal numbers aligned: normals of this mesh are never read.
        packed.normals.resize(packed.vertices.len(), [0.0; 3]);
    }
    packed.meshes.push(desc);
    packed.mesh_info.push(MeshInfo {
        path: mesh.path,
        triangles: mesh.triangles.len(),
        degenerate: mesh.degenerate,
        duplicates: mesh.duplicates,
        instances: 0,
        build_time: start.elapsed(),
        bytes,
    });
    Ok(packed.meshes.len() as u32 - 1)
}
