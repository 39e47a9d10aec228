//! `#[repr(C)]` mirrors of the structs in `kernels/types.h`, field for field.
//!
//! Each type asserts its size at compile time, as `types.h` does on the device; the layout
//! probe (`tests/layout.rs`) builds `offsetof` for every field listed in [`LAYOUT`] on the
//! device and compares it with Rust's `offset_of!`. Only 4-byte scalars and arrays of them:
//! no `float3` (16 bytes on the device), so no padding can differ between compilers.

use bytemuck::{Pod, Zeroable};
use std::mem::{offset_of, size_of};

/// `MATERIAL_DIFFUSE` in `types.h`.
pub const MATERIAL_DIFFUSE: u32 = 0;
/// `MATERIAL_SPECULAR` in `types.h`.
pub const MATERIAL_SPECULAR: u32 = 1;
/// `MATERIAL_REFRACTIVE` in `types.h`.
pub const MATERIAL_REFRACTIVE: u32 = 2;

/// `MAP_NONE` in `types.h`: a material without this map.
pub const MAP_NONE: u32 = u32::MAX;
/// `MAP_RGB8` in `types.h`.
pub const MAP_RGB8: u32 = 0;
/// `MAP_TYPE8` in `types.h`.
pub const MAP_TYPE8: u32 = 1;
/// `MAP_BUMP8` in `types.h`.
pub const MAP_BUMP8: u32 = 2;
/// `FILTER_BILINEAR` in `types.h`.
pub const FILTER_BILINEAR: u32 = 0;
/// `FILTER_NEAREST` in `types.h`.
pub const FILTER_NEAREST: u32 = 1;

/// `TextureMap` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TextureMap {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub format: u32,
}
const _: () = assert!(size_of::<TextureMap>() == 16);

/// `KD_LEAF` in `types.h`: the axis bits of a kd-tree leaf.
pub const KD_LEAF: u32 = 3;
/// `BVH_LEAF` in `types.h`: marks a BVH child that is an object.
pub const BVH_LEAF: u32 = 0x8000_0000;
/// `BVH_EMPTY` in `types.h`: the missing second child of a one-object BVH.
pub const BVH_EMPTY: u32 = u32::MAX;

/// `WIDE_BVH_LEAF` in `types.h`: marks a wide BVH child that is a leaf (count less one in bits
/// 28 to 30, first index below).
pub const WIDE_BVH_LEAF: u32 = 0x8000_0000;
/// `WIDE_BVH_EMPTY` in `types.h`: an unused child slot.
pub const WIDE_BVH_EMPTY: u32 = u32::MAX;
/// `WIDE_BVH_SLOT` in `types.h`: the words of a wide BVH leaf's triangle slot (its three
/// vertices' numbers in the scene's vertex array, its number in its mesh).
pub const WIDE_BVH_SLOT: u32 = 4;

/// `KdNode` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct KdNode {
    pub flags: u32,
    pub data: u32,
}
const _: () = assert!(size_of::<KdNode>() == 8);

impl KdNode {
    pub fn interior(axis: usize, split: f32, above_child: u32) -> KdNode {
        KdNode {
            flags: axis as u32 | (above_child << 2),
            data: split.to_bits(),
        }
    }

    pub fn leaf(first_index: u32, count: u32) -> KdNode {
        KdNode {
            flags: KD_LEAF | (count << 2),
            data: first_index,
        }
    }

    pub fn is_leaf(&self) -> bool {
        self.flags & 3 == KD_LEAF
    }

    /// Interior nodes: the split axis.
    pub fn axis(&self) -> usize {
        (self.flags & 3) as usize
    }

    /// Interior nodes: the split coordinate.
    pub fn split(&self) -> f32 {
        f32::from_bits(self.data)
    }

    /// Interior nodes: the index of the child above the split (the child below is the next).
    pub fn above_child(&self) -> u32 {
        self.flags >> 2
    }

    /// Leaves: how many triangles, and the first of them in the index list.
    pub fn count(&self) -> u32 {
        self.flags >> 2
    }

    pub fn first_index(&self) -> u32 {
        self.data
    }
}

/// `BvhNode` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub lo0: [f32; 3],
    pub hi0: [f32; 3],
    pub lo1: [f32; 3],
    pub hi1: [f32; 3],
    pub child: [u32; 2],
}
const _: () = assert!(size_of::<BvhNode>() == 56);

/// `Camera` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Camera {
    pub origin: [f32; 3],
    pub forward: [f32; 3],
    pub cx: [f32; 3],
    pub cy: [f32; 3],
    pub lens_u: [f32; 3],
    pub lens_v: [f32; 3],
    pub lens_radius: f32,
    pub focus_distance: f32,
    pub width: u32,
    pub height: u32,
}
const _: () = assert!(size_of::<Camera>() == 88);

/// `Material` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Material {
    pub emission: [f32; 3],
    pub color: [f32; 3],
    pub kind: u32,
    pub color_map: u32,
    pub emission_map: u32,
    pub type_map: u32,
    pub bump_map: u32,
}
const _: () = assert!(size_of::<Material>() == 44);

/// `TRANSFORM_NONE` in `types.h`.
pub const TRANSFORM_NONE: u32 = u32::MAX;
/// `OBJECT_SPHERE` in `types.h`.
pub const OBJECT_SPHERE: u32 = 0;
/// `OBJECT_PLANE` in `types.h`.
pub const OBJECT_PLANE: u32 = 1;
/// `OBJECT_MESH` in `types.h`.
pub const OBJECT_MESH: u32 = 2;
/// `OBJECT_REVSURFACE` in `types.h`.
pub const OBJECT_REVSURFACE: u32 = 3;

/// `RevSurface` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RevSurface {
    pub first_point: u32,
    pub num_segments: u32,
    pub degree: u32,
    pub material: u32,
    pub transform: u32,
    pub radius: f32,
    pub y_lo: f32,
    pub y_hi: f32,
}
const _: () = assert!(size_of::<RevSurface>() == 32);

/// `Transform` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Transform {
    pub m: [f32; 12],
    pub inv: [f32; 12],
}
const _: () = assert!(size_of::<Transform>() == 96);

/// `Sphere` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Sphere {
    pub center: [f32; 3],
    pub radius: f32,
    pub center_lo: [f32; 3],
    pub radius_lo: f32,
    pub material: u32,
    pub transform: u32,
}
const _: () = assert!(size_of::<Sphere>() == 40);

impl Default for Sphere {
    fn default() -> Self {
        Sphere {
            center: [0.0; 3],
            radius: 1.0,
            center_lo: [0.0; 3],
            radius_lo: 0.0,
            material: 0,
            transform: TRANSFORM_NONE,
        }
    }
}

impl Sphere {
    /// The double-float centre `center + center_lo`, in f64.
    pub fn center_f64(&self) -> glam::DVec3 {
        glam::DVec3::from(self.center.map(f64::from))
            + glam::DVec3::from(self.center_lo.map(f64::from))
    }

    /// The double-float radius `radius + radius_lo`, in f64.
    pub fn radius_f64(&self) -> f64 {
        f64::from(self.radius) + f64::from(self.radius_lo)
    }
}

/// `WideBvhNode` in `types.h` (accel/wide_bvh.rs).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct WideBvhNode {
    pub lo_x: [f32; 8],
    pub hi_x: [f32; 8],
    pub lo_y: [f32; 8],
    pub hi_y: [f32; 8],
    pub lo_z: [f32; 8],
    pub hi_z: [f32; 8],
    pub child: [u32; 8],
}
const _: () = assert!(size_of::<WideBvhNode>() == 224);

/// `MeshDesc` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MeshDesc {
    pub first_node: u32,
    pub first_index: u32,
    pub first_triangle: u32,
    pub first_vertex: u32,
    pub has_normals: u32,
    pub lo: [f32; 3],
    pub hi: [f32; 3],
}
const _: () = assert!(size_of::<MeshDesc>() == 44);

/// `MeshInstance` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct MeshInstance {
    pub mesh: u32,
    pub transform: u32,
    pub material: u32,
}
const _: () = assert!(size_of::<MeshInstance>() == 12);

/// `ObjectRef` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ObjectRef {
    pub kind: u32,
    pub index: u32,
}
const _: () = assert!(size_of::<ObjectRef>() == 8);

/// `Light` in `types.h`: an emitter of next-event estimation's light list, in world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Light {
    pub kind: u32,
    pub index: u32,
    pub triangle: u32,
    pub material: u32,
    pub corner: [f32; 3],
    pub edge1: [f32; 3],
    pub edge2: [f32; 3],
    pub normal: [f32; 3],
    pub radius: f32,
    pub area: f32,
    pub prob: f32,
    pub cdf: f32,
    /// A sphere's visible cap: its height along `normal` from the sphere's far side towards
    /// it; 0 for the whole sphere (src/device/lights.rs, `visible_cap`).
    pub cap_height: f32,
    /// 1: a rectangle sampled by the solid angle it subtends (`kernels/nee.h` `sph_rect`): a
    /// wall of the closed room (src/device/lights.rs); 0: sampled by area.
    pub solid_angle: u32,
}
const _: () = assert!(size_of::<Light>() == 88);

/// `Plane` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Plane {
    pub normal: [f32; 3],
    pub offset: f32,
    pub range: f32,
    pub center: [f32; 3],
    pub centerp: [f32; 3],
    pub dir_u: [f32; 3],
    pub dir_v: [f32; 3],
    pub material: u32,
    pub transform: u32,
}
const _: () = assert!(size_of::<Plane>() == 76);

impl Plane {
    /// The axis its normal lies along, where exactly one of the normal's components is not 0:
    /// the walls of a closed room (device/lights.rs) and of `walls_intersect` (upload.rs).
    pub fn axis(&self) -> Option<usize> {
        let mut axes = (0..3).filter(|&k| self.normal[k] != 0.0);
        match (axes.next(), axes.next()) {
            (Some(k), None) => Some(k),
            _ => None,
        }
    }
}

impl Default for Plane {
    fn default() -> Self {
        Plane {
            normal: [0.0, 0.0, 1.0],
            offset: 0.0,
            range: 1.0,
            center: [0.0; 3],
            centerp: [0.0; 3],
            dir_u: [0.0; 3],
            dir_v: [0.0; 3],
            material: 0,
            transform: TRANSFORM_NONE,
        }
    }
}

/// `RenderParams` in `types.h`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct RenderParams {
    pub camera: Camera,
    pub num_spheres: u32,
    pub num_planes: u32,
    pub num_mesh_instances: u32,
    pub num_revsurfaces: u32,
    pub num_objects: u32,
    pub first_unbounded: u32,
    pub num_bvh_nodes: u32,
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub max_depth: u32,
    pub rr_depth: u32,
    pub texture_filter: u32,
    pub num_lights: u32,
    /// Roulette's threshold: paths whose largest throughput component is below it play.
    pub rr_threshold: f32,
    /// The planes tested as walls without an object BVH ([`walls`](super::upload)): at 2k the
    /// one whose normal is +axis k, at 2k + 1 the one whose normal is -axis k, or [`WALL_NONE`].
    pub walls: [u32; 6],
    /// Bit i: plane i is one of `walls`.
    pub wall_mask: u32,
}
const _: () = assert!(size_of::<RenderParams>() == 172);

/// `WALL_NONE` in `types.h`: an empty slot of `RenderParams::walls`.
pub const WALL_NONE: u32 = u32::MAX;

/// Zero, but with no walls: a zeroed slot would name plane 0.
impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            walls: [WALL_NONE; 6],
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

/// One struct's layout as Rust sees it: its C name, size, and (field name, offset) pairs.
pub struct StructLayout {
    pub name: &'static str,
    pub size: usize,
    pub fields: &'static [(&'static str, usize)],
}

macro_rules! layout {
    ($rust:ty, $c:literal, { $($rf:ident => $cf:literal),* $(,)? }) => {
        StructLayout {
            name: $c,
            size: size_of::<$rust>(),
            fields: &[$(($cf, offset_of!($rust, $rf))),*],
        }
    };
}

/// Every constant `types.h` and this file share, by its C name: the device layout probe checks
/// each value on the device.
pub const CONSTANTS: &[(&str, u32)] = &[
    ("MATERIAL_DIFFUSE", MATERIAL_DIFFUSE),
    ("MATERIAL_SPECULAR", MATERIAL_SPECULAR),
    ("MATERIAL_REFRACTIVE", MATERIAL_REFRACTIVE),
    ("MAP_NONE", MAP_NONE),
    ("MAP_RGB8", MAP_RGB8),
    ("MAP_TYPE8", MAP_TYPE8),
    ("MAP_BUMP8", MAP_BUMP8),
    ("FILTER_BILINEAR", FILTER_BILINEAR),
    ("FILTER_NEAREST", FILTER_NEAREST),
    ("KD_LEAF", KD_LEAF),
    ("BVH_LEAF", BVH_LEAF),
    ("BVH_EMPTY", BVH_EMPTY),
    ("WIDE_BVH_LEAF", WIDE_BVH_LEAF),
    ("WIDE_BVH_EMPTY", WIDE_BVH_EMPTY),
    ("WIDE_BVH_SLOT", WIDE_BVH_SLOT),
    ("TRANSFORM_NONE", TRANSFORM_NONE),
    ("WALL_NONE", WALL_NONE),
    ("OBJECT_SPHERE", OBJECT_SPHERE),
    ("OBJECT_PLANE", OBJECT_PLANE),
    ("OBJECT_MESH", OBJECT_MESH),
    ("OBJECT_REVSURFACE", OBJECT_REVSURFACE),
];

/// Every shared struct and field: the single list both the size asserts above and the device
/// layout probe are checked against. The C field names are compiled by the probe, the Rust
/// ones by `offset_of!`, so a renamed or reordered field fails on one side or the other.
pub const LAYOUT: &[StructLayout] = &[
    layout!(Camera, "Camera", {
        origin => "origin", forward => "forward", cx => "cx", cy => "cy", lens_u => "lens_u",
        lens_v => "lens_v", lens_radius => "lens_radius", focus_distance => "focus_distance",
        width => "width", height => "height",
    }),
    layout!(KdNode, "KdNode", { flags => "flags", data => "data" }),
    layout!(WideBvhNode, "WideBvhNode", {
        lo_x => "lo_x", hi_x => "hi_x", lo_y => "lo_y", hi_y => "hi_y", lo_z => "lo_z",
        hi_z => "hi_z", child => "child",
    }),
    layout!(BvhNode, "BvhNode", {
        lo0 => "lo0", hi0 => "hi0", lo1 => "lo1", hi1 => "hi1", child => "child",
    }),
    layout!(TextureMap, "TextureMap", {
        offset => "offset", width => "width", height => "height", format => "format",
    }),
    layout!(Material, "Material", {
        emission => "emission", color => "color", kind => "type", color_map => "color_map",
        emission_map => "emission_map", type_map => "type_map", bump_map => "bump_map",
    }),
    layout!(Transform, "Transform", { m => "m", inv => "inv" }),
    layout!(Sphere, "Sphere", {
        center => "center", radius => "radius", center_lo => "center_lo",
        radius_lo => "radius_lo", material => "material", transform => "transform",
    }),
    layout!(MeshDesc, "MeshDesc", {
        first_node => "first_node", first_index => "first_index",
        first_triangle => "first_triangle", first_vertex => "first_vertex",
        has_normals => "has_normals", lo => "lo", hi => "hi",
    }),
    layout!(MeshInstance, "MeshInstance", {
        mesh => "mesh", transform => "transform", material => "material",
    }),
    layout!(ObjectRef, "ObjectRef", { kind => "kind", index => "index" }),
    layout!(Light, "Light", {
        kind => "kind", index => "index", triangle => "triangle", material => "material",
        corner => "corner", edge1 => "edge1", edge2 => "edge2", normal => "normal",
        radius => "radius", area => "area", prob => "prob", cdf => "cdf",
        cap_height => "cap_height", solid_angle => "solid_angle",
    }),
    layout!(RevSurface, "RevSurface", {
        first_point => "first_point", num_segments => "num_segments", degree => "degree",
        material => "material", transform => "transform", radius => "radius", y_lo => "y_lo",
        y_hi => "y_hi",
    }),
    layout!(Plane, "Plane", {
        normal => "normal", offset => "offset", range => "range", center => "center",
        centerp => "centerp",
        dir_u => "dir_u", dir_v => "dir_v", material => "material", transform => "transform",
    }),
    layout!(RenderParams, "RenderParams", {
        camera => "camera", num_spheres => "num_spheres", num_planes => "num_planes",
        num_mesh_instances => "num_mesh_instances", num_revsurfaces => "num_revsurfaces",
        num_objects => "num_objects",
        first_unbounded => "first_unbounded",
        num_bvh_nodes => "num_bvh_nodes",
        seed_lo => "seed_lo", seed_hi => "seed_hi", max_depth => "max_depth",
        rr_depth => "rr_depth", texture_filter => "texture_filter", num_lights => "num_lights",
        rr_threshold => "rr_threshold", walls => "walls", wall_mask => "wall_mask",
    }),
];

/// The OpenCL source of the layout probe: one kernel writing, for every struct of [`LAYOUT`],
/// its `sizeof` and then each field's offset.
pub fn probe_source() -> String {
    let mut src = String::from(
        "#include \"types.h\"\n\
         #define CLPT_OFFSETOF(T, f) ((uint)(size_t)&(((T*)0)->f))\n\
         __kernel void probe_layout(__global uint* out) {\n    uint i = 0u;\n",
    );
    for s in LAYOUT {
        src.push_str(&format!("    out[i++] = (uint)sizeof({});\n", s.name));
        for (field, _) in s.fields {
            src.push_str(&format!(
                "    out[i++] = CLPT_OFFSETOF({}, {field});\n",
                s.name
            ));
        }
    }
    for (name, _) in CONSTANTS {
        src.push_str(&format!("    out[i++] = (uint)({name});\n"));
    }
    src.push_str("}\n");
    src
}

/// Builds and runs the layout probe on `device` and compares every size, offset and shared
/// constant with Rust's.
pub fn verify(
    device: &super::Device,
    sources: &super::program::KernelSources,
) -> crate::Result<()> {
    use crate::Error;
    let expected: Vec<(String, usize)> = LAYOUT
        .iter()
        .flat_map(|s| {
            std::iter::once((format!("sizeof({})", s.name), s.size)).chain(
                s.fields
                    .iter()
                    .map(move |(f, o)| (format!("offsetof({}, {f})", s.name), *o)),
            )
        })
        .chain(
            CONSTANTS
                .iter()
                .map(|(name, value)| (name.to_string(), *value as usize)),
        )
        .collect();
    let source = sources.expand_text("layout_probe.cl", &probe_source())?;
    let built = super::program::build(device, source, super::program::build_options(&[]), None)?;
    let out = ocl::Buffer::<u32>::builder()
        .queue(device.queue.clone())
        .len(expected.len())
        .fill_val(u32::MAX)
        .build()
        .map_err(|e| Error::opencl("allocating the layout probe", e))?;
    let kernel = ocl::Kernel::builder()
        .program(&built.program)
        .name("probe_layout")
        .queue(device.queue.clone())
        .global_work_size(1)
        .arg(&out)
        .build()
        .map_err(|e| Error::opencl("creating the layout probe", e))?;
    // SAFETY: one work-item writes expected.len() words into a buffer of that length.
    unsafe { kernel.enq() }.map_err(|e| Error::opencl("running the layout probe", e))?;
    let mut got = vec![0u32; expected.len()];
    out.read(&mut got)
        .enq()
        .map_err(|e| Error::opencl("reading the layout probe", e))?;
    let wrong: Vec<String> = expected
        .iter()
        .zip(&got)
        .filter(|((_, want), have)| *want as u32 != **have)
        .map(|((what, want), have)| format!("{what}: host {want}, device {have}"))
        .collect();
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(Error::Layout(wrong.join("; ")))
    }
}
