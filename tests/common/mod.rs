//! Shared helpers for the integration tests.
#![allow(dead_code)]

pub mod cli;

use std::path::PathBuf;

/// `f` of every item, in order, the items spread over the cores in one chunk a core: the
/// tests' brute-force oracles and f64 references (tests/kdtree.rs, bvh.rs, revsurface.rs).
pub fn on_all_cores<I: Sync, T: Send>(items: &[I], f: impl Fn(&I) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let chunk = items.len().div_ceil(threads).max(1);
    std::thread::scope(|s| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .map(|part| s.spawn(|| part.iter().map(&f).collect::<Vec<T>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("worker"))
            .collect()
    })
}

/// The original project's data (`../shared/seed` beside the checkout, or `$CLPT_SEED_DIR`),
/// or `None` with a message on stderr when it is absent, so tests that need it skip visibly.
pub fn seed_dir(test: &str) -> Option<PathBuf> {
    let dir = std::env::var_os("CLPT_SEED_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/seed"));
    if dir.join("testcases").is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED {test}: the original's data is not at {} (set CLPT_SEED_DIR)",
            dir.display()
        );
        None
    }
}

/// The OpenCL device the tests run on: `$CLPT_DEVICE`, else the first GPU, else the first
/// device (PoCL in CI).
pub fn device() -> clpt::device::Device {
    match clpt::device::select(None) {
        Ok(d) => d,
        Err(e) => panic!("tests need an OpenCL device (run tools/setup-opencl): {e}"),
    }
}

pub mod chi2;
pub mod curve_reference;
pub mod procedural;
pub mod reference;
pub mod traversal;
pub mod trial;

use clpt::device::Device;
use clpt::device::program::{self, KernelSources};

/// The probes program (kernels/probes.cl) built for `device`.
pub fn probes(device: &Device) -> ocl::Program {
    program::build_entry(device, &KernelSources::Embedded, "probes.cl", &[], None)
        .unwrap_or_else(|e| panic!("{e}"))
        .program
}

/// The test device and the probes program built for it, once per test.
pub struct Probes {
    pub device: Device,
    pub program: ocl::Program,
    /// Lanes a work-item (kernels/lanes.h): probes that take them run `items / lanes`
    /// work-items.
    pub lanes: u32,
}

impl Probes {
    pub fn new() -> Probes {
        Probes::in_lanes(1)
    }

    /// The probes of the program of `lanes` lanes a work-item ([`probes_in_lanes`]).
    pub fn in_lanes(lanes: u32) -> Probes {
        let device = device();
        let program = probes_in_lanes(&device, lanes);
        Probes {
            device,
            program,
            lanes,
        }
    }
}

/// The light list of `every_light_scene`, its files under a folder of the test's own (`test`:
/// tests run in parallel), in the scene's coordinates.
pub fn every_light_scene_lights(test: &str) -> Vec<clpt::contract::Light> {
    let dir = std::env::temp_dir().join(format!("clpt-{}-{test}", std::process::id()));
    let scene = every_light_scene(&dir);
    let packed = clpt::pack::PackedScene::new(&scene, u64::MAX).unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_dir_all(&dir);
    in_scene_coordinates(packed).lights
}

/// `packed` with its light list and closed room moved from the device's camera-relative
/// coordinates back to the scene's (by `packed.origin`, in f64), for tests that check them
/// against the scene file's numbers.
pub fn in_scene_coordinates(mut packed: PackedScene) -> PackedScene {
    let origin = packed.origin;
    for l in &mut packed.lights {
        l.corner = (DVec3::from(l.corner.map(f64::from)) + origin)
            .as_vec3()
            .to_array();
    }
    if let Some(room) = &mut packed.room {
        room.lo += origin;
        room.hi += origin;
    }
    packed
}

/// A device buffer holding `data`.
pub fn buffer<T: ocl::OclPrm>(device: &Device, data: &[T]) -> ocl::Buffer<T> {
    ocl::Buffer::<T>::builder()
        .queue(device.queue.clone())
        .len(data.len())
        .copy_host_slice(data)
        .build()
        .expect("device buffer")
}

/// A zeroed device buffer of `len` elements.
pub fn output<T: ocl::OclPrm>(device: &Device, len: usize) -> ocl::Buffer<T> {
    ocl::Buffer::<T>::builder()
        .queue(device.queue.clone())
        .len(len)
        .fill_val(T::default())
        .build()
        .expect("device buffer")
}

/// Reads a whole buffer back.
pub fn read<T: ocl::OclPrm>(buffer: &ocl::Buffer<T>) -> Vec<T> {
    let mut out = vec![T::default(); buffer.len()];
    buffer.read(&mut out).enq().expect("read back");
    out
}

/// Runs `kernel` over `n` work-items and waits.
pub fn run(kernel: &ocl::Kernel, n: usize) {
    // Work-groups of at most 64, as the renderer's: left to PoCL 3.1, a 16-lane probe of 3,750
    // or 4,000 work-items crashed (SIGSEGV in the work-group function) where any group size
    // from 1 to 250 given here ran.
    let local = (1..=64).rev().find(|&l| n.is_multiple_of(l)).unwrap_or(1);
    // SAFETY: every probe writes only its own work-item's records, sized by the caller.
    unsafe {
        kernel
            .cmd()
            .global_work_size(n)
            .local_work_size(local)
            .enq()
    }
    .expect("probe launch");
    kernel
        .default_queue()
        .expect("queue")
        .finish()
        .expect("probe run");
}

use clpt::contract::{Material, OBJECT_PLANE, OBJECT_SPHERE, Plane, Sphere};
use clpt::device::kernel::NamedArgs;
use clpt::device::upload::SceneBuffers;
use clpt::pack::PackedScene;
use clpt::scene::CameraDesc;
use clpt::scene::camera::CameraBasis;
use clpt::shapes::cube_box;
use glam::DVec3;

/// A packed scene made in code (for probes), with a pinhole camera at the origin looking down -z.
pub fn packed(spheres: Vec<Sphere>, planes: Vec<Plane>, materials: Vec<Material>) -> PackedScene {
    let camera = CameraBasis::new(&CameraDesc {
        center: DVec3::ZERO,
        direction: DVec3::new(0.0, 0.0, -1.0),
        angle_deg: 30.0,
        width: 16,
        height: 16,
        flength: 0.0,
        aperture: 0.0,
    })
    .expect("camera");
    let mut packed = PackedScene {
        camera,
        materials,
        ..PackedScene::default()
    };
    // Untransformed, in device coordinates (origin 0); each plane's box centred on
    // `normal * offset`, as a scene file's is.
    for s in spheres {
        let world_box = cube_box(s.center_f64(), s.radius_f64(), None);
        packed.push_object(OBJECT_SPHERE, packed.spheres.len(), world_box);
        packed.spheres.push(s);
    }
    for mut p in planes {
        p.center = p.normal.map(|c| c * p.offset);
        let centre = DVec3::from(p.center.map(f64::from));
        let world_box = cube_box(centre, f64::from(p.range), None);
        packed.push_object(OBJECT_PLANE, packed.planes.len(), world_box);
        packed.planes.push(p);
    }
    packed.finish(clpt::shapes::emitters);
    packed
}

/// Runs a probe that takes the scene and rays of 9 floats (o, d, w) and writes `width` floats
/// per ray (probe_hit, probe_mapping in probes.cl). The rays are in the scene's coordinates:
/// their origins are moved to the device's, relative to `scene.origin`, in f64.
pub fn probe_scene_rays(
    device: &Device,
    scene: &PackedScene,
    kernel_name: &str,
    rays: &[[f32; 9]],
    width: usize,
) -> Vec<f32> {
    probe_scene_rays_with(&probes(device), device, scene, kernel_name, rays, width, 1)
}

/// The lane widths (kernels/lanes.h) whose programs the geometry tests run: the scalar
/// program's, and the wide programs' of AVX2 and AVX-512.
pub const LANE_WIDTHS: [u32; 3] = [1, 8, 16];

/// probes.cl built with `lanes` lanes a work-item: above 1, the features a wide program has
/// (kernels/objects.h: spheres and planes, no transforms, no BVH).
pub fn probes_in_lanes(device: &Device, lanes: u32) -> ocl::Program {
    if lanes == 1 {
        return probes(device);
    }
    // What the wide kernels are written for so far (render/features.rs `wide_lanes`): meshes
    // there walk 8-wide BVHs (PackedScene::with_limits' `mesh_tree`).
    let mut defines: Vec<(&str, String)> = [
        "CLPT_REVSURFACES",
        "CLPT_BVH",
        "CLPT_TEXTURES",
        "CLPT_THIN_LENS",
    ]
    .iter()
    .map(|&k| (k, "0".to_string()))
    .collect();
    defines.push(("CLPT_WIDE", "1".to_string()));
    defines.push(("CLPT_LANES", lanes.to_string()));
    build_without_warnings(device, "probes.cl", &defines)
}

/// Builds the kernel file `entry` with `defines`, and fails if the compiler warned: a wide
/// program's mixed-up lane and scalar types (a float* passed for a float8*) build with only a
/// warning, and then write past their variables.
pub fn build_without_warnings(
    device: &Device,
    entry: &str,
    defines: &[(&str, String)],
) -> ocl::Program {
    let built = program::build_entry(device, &KernelSources::Embedded, entry, defines, None)
        .unwrap_or_else(|e| panic!("{e}"));
    let log = built
        .program
        .build_info(device.device, ocl::enums::ProgramBuildInfo::BuildLog)
        .map(|l| l.to_string())
        .unwrap_or_default();
    assert!(
        !log.contains("warning"),
        "{entry} ({}) built with warnings:\n{}",
        built.options,
        built.source.annotate(&log)
    );
    built.program
}

/// As [`probe_scene_rays`], on `program`, built for `lanes` lanes (`rays.len()` a multiple of
/// it).
pub fn probe_scene_rays_with(
    program: &ocl::Program,
    device: &Device,
    scene: &PackedScene,
    kernel_name: &str,
    rays: &[[f32; 9]],
    width: usize,
    lanes: u32,
) -> Vec<f32> {
    let params = scene.params(0, 1, 1, 0);
    let buffers = SceneBuffers::new(device, scene, &params).expect("upload");
    let origin = scene.origin.to_array();
    let flat: Vec<f32> = rays
        .iter()
        .flat_map(|r| {
            let mut r = *r;
            for k in 0..3 {
                r[k] = (f64::from(r[k]) - origin[k]) as f32;
            }
            r
        })
        .collect();
    let input = buffer(device, &flat);
    let out = output::<f32>(device, rays.len() * width);
    let kernel = NamedArgs::new(program, kernel_name, &device.queue)
        .scene(&buffers)
        .buffer("rays", &input)
        .buffer("out", &out)
        .build()
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        rays.len() % lanes as usize,
        0,
        "whole work-items of {lanes} lanes"
    );
    run(&kernel, rays.len() / lanes as usize);
    read(&out)
}

/// probe_hit: for each (o, d, w), the device's first hit of (o, d) and of the ray it spawns
/// towards w. Records as documented in probes.cl (16 floats), the hit point moved back to the
/// scene's coordinates.
pub fn probe_hits(device: &Device, scene: &PackedScene, rays: &[[f32; 9]]) -> Vec<[f32; 16]> {
    probe_hits_in_lanes(device, scene, rays, 1)
}

/// As [`probe_hits`], on the program of `lanes` lanes a work-item.
pub fn probe_hits_in_lanes(
    device: &Device,
    scene: &PackedScene,
    rays: &[[f32; 9]],
    lanes: u32,
) -> Vec<[f32; 16]> {
    let program = probes_in_lanes(device, lanes);
    probe_hits_with(&program, device, scene, rays, lanes)
}

/// As [`probe_hits`], on the one-lane program whose meshes walk `scene`'s tree (render/mod.rs
/// `MeshTree`: the 8-wide BVH with `CLPT_WIDE_BVH`, a CPU's default; the binary BVH with
/// `CLPT_BVH2`, a GPU's).
pub fn probe_hits_mesh_tree(
    device: &Device,
    scene: &PackedScene,
    rays: &[[f32; 9]],
) -> Vec<[f32; 16]> {
    use clpt::render::MeshTree;
    let flag = |tree: MeshTree| if scene.mesh_tree == tree { "1" } else { "0" }.to_string();
    let defines = [
        ("CLPT_WIDE_BVH", flag(MeshTree::Wide)),
        ("CLPT_BVH2", flag(MeshTree::Bvh2)),
    ];
    let program = build_without_warnings(device, "probes.cl", &defines);
    probe_hits_on(&program, device, scene, rays)
}

/// As [`probe_hits`], on `program`: the one-lane probes built with other switches
/// ([`build_without_warnings`]).
pub fn probe_hits_on(
    program: &ocl::Program,
    device: &Device,
    scene: &PackedScene,
    rays: &[[f32; 9]],
) -> Vec<[f32; 16]> {
    probe_hits_with(program, device, scene, rays, 1)
}

fn probe_hits_with(
    program: &ocl::Program,
    device: &Device,
    scene: &PackedScene,
    rays: &[[f32; 9]],
    lanes: u32,
) -> Vec<[f32; 16]> {
    let origin = scene.origin.to_array();
    probe_scene_rays_with(program, device, scene, "probe_hit", rays, 16, lanes)
        .chunks_exact(16)
        .map(|c| {
            let mut hit: [f32; 16] = c.try_into().expect("16 floats");
            for k in 0..3 {
                hit[3 + k] = (f64::from(hit[3 + k]) + origin[k]) as f32;
            }
            hit
        })
        .collect()
}

/// A uniformly distributed unit vector (rejection sampling in the unit ball).
pub fn random_unit(rng: &mut impl rand::Rng) -> DVec3 {
    use rand::RngExt;
    loop {
        let v = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if (1e-3..=1.0).contains(&v.length()) {
            return v.normalize();
        }
    }
}

/// The original's goblet profile: case3_wineglass.txt's B-spline (x, y; z is 0 there).
pub const GOBLET: [[f64; 2]; 26] = [
    [0.000000, -0.459543],
    [0.000000, -0.459544],
    [0.000000, -0.459545],
    [-0.351882, -0.426747],
    [-0.848656, -0.278898],
    [-1.112097, 0.084005],
    [-1.164785, 1.105511],
    [-0.991667, 2.328629],
    [-1.029301, 2.503360],
    [-1.088800, 2.345600],
    [-1.278000, 1.162800],
    [-1.214800, 0.055200],
    [-0.915600, -0.381200],
    [-0.380400, -0.622000],
    [-0.144000, -0.968400],
    [-0.096800, -1.480000],
    [-0.128400, -2.112400],
    [-0.317200, -2.202800],
    [-0.994400, -2.262800],
    [-1.214800, -2.323200],
    [-1.199200, -2.398400],
    [-1.057600, -2.458800],
    [-0.711200, -2.458800],
    [0.000000, -2.458800],
    [0.000000, -2.458801],
    [0.000000, -2.458802],
];

/// A whole render of `scene` on the test device: the film and what the render measured.
pub fn render(
    scene: &clpt::scene::Scene,
    options: clpt::render::RenderOptions,
) -> (clpt::render::film::Film, clpt::render::RenderStats) {
    let device = device();
    let mut renderer =
        clpt::render::Renderer::new(&device, scene, &KernelSources::Embedded, options)
            .unwrap_or_else(|e| panic!("{e}"));
    renderer
        .render(&mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The original's dragon meshes in `mesh/` of the seed data, smallest first.
pub const DRAGONS: [&str; 5] = [
    "dragon_11k",
    "dragon_48k",
    "dragon_100k",
    "dragon_202k",
    "dragon_871k",
];

/// A room lit by every kind of emitter the light list takes, and one it leaves to BSDF
/// sampling, with diffuse surfaces whose shading normals are bent (a bump-mapped wall, a smooth
/// mesh ball), written to `dir` (its two OBJ files) and parsed:
/// - a sphere under a similarity (listed, as a world sphere of radius 0.4);
/// - an axis-aligned plane's square, rotated (listed, as a parallelogram facing down);
/// - a two-triangle quad mesh under a non-uniform scale and a rotation (listed, two-sided);
/// - an ellipsoid (not listed: BSDF sampling finds it at full weight).
pub fn every_light_scene(dir: &std::path::Path) -> clpt::scene::Scene {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    // An octahedron with vertex normals along its vertices: shading normals up to 55° off.
    let mut ball = String::new();
    for v in ["1 0 0", "-1 0 0", "0 1 0", "0 -1 0", "0 0 1", "0 0 -1"] {
        ball += &format!("v {v}\nvn {v}\n");
    }
    for [a, b, c] in [
        [1, 3, 5],
        [3, 2, 5],
        [2, 4, 5],
        [4, 1, 5],
        [3, 1, 6],
        [2, 3, 6],
        [4, 2, 6],
        [1, 4, 6],
    ] {
        ball += &format!("f {a}//{a} {b}//{b} {c}//{c}\n");
    }
    std::fs::write(dir.join("ball.obj"), ball).unwrap();
    let assets = concat!(env!("CARGO_MANIFEST_DIR"), "/assets");
    let text = format!(
        "PerspectiveCamera {{ center 0 0 9 direction 0 0 -1 angle 40 width 24 height 18 }}\n\
         Materials {{ numMaterials 8 \
         Material {{ emission 6 5 4 }} \
         Material {{ color 0.75 0.25 0.25 texture {{ bump {assets}/bricks_height.png }} }} \
         Material {{ color 0.25 0.25 0.75 }} \
         Material {{ color 0.75 0.75 0.75 }} \
         Material {{ emission 3 4 5 }} \
         Material {{ emission 4 4 4 }} \
         Material {{ emission 1 2 1 }} \
         Material {{ color 0.6 0.7 0.5 }} }}\n\
         Group {{ numObjects 12 \
         MaterialIndex 1 Plane {{ normal 1 0 0 offset -4 range 100 \
           centerp -4 0 0 dirU 0 0 0.5 dirV 0 0.5 0 }} \
         MaterialIndex 2 Plane {{ normal -1 0 0 offset -4 range 100 }} \
         MaterialIndex 3 Plane {{ normal 0 1 0 offset -3 range 100 }} \
         Plane {{ normal 0 -1 0 offset -3 range 100 }} \
         Plane {{ normal 0 0 1 offset -4 range 100 }} \
         Plane {{ normal 0 0 -1 offset -12 range 100 }} \
         MaterialIndex 7 Transform {{ Translate 1.5 -2 0 Mesh {{ obj_file {ball} }} }} \
         MaterialIndex 0 Transform {{ Translate -1.5 2.2 -1 XRotate 30 UniformScale 0.5 \
           Sphere {{ center 0 0 0 radius 0.8 }} }} \
         MaterialIndex 4 Transform {{ Translate 1.8 2.6 -1.5 XRotate 20 ZRotate 15 \
           Plane {{ normal 0 -1 0 offset 0 range 0.5 }} }} \
         MaterialIndex 5 Transform {{ Translate 0 2.7 1 ZRotate 160 Scale 0.8 1 0.3 \
           Mesh {{ obj_file {quad} }} }} \
         MaterialIndex 6 Transform {{ Translate -2.5 -2.4 1.5 Scale 1 0.4 0.6 \
           Sphere {{ center 0 0 0 radius 1 }} }} \
         MaterialIndex 3 Sphere {{ center -1 -2 -1 radius 1 }} }}\n",
        ball = dir.join("ball.obj").display(),
        quad = dir.join("quad.obj").display(),
    );
    clpt::scene::parse::parse_scene(&text, "every light").unwrap_or_else(|e| panic!("{e}"))
}

/// The six walls of the original's case2 room (seed data, textures left out), in its order:
/// planes 0 the ceiling y = 160 and 1 the front wall z = 1000 (both emitting, material 0),
/// 2 x = 100, 3 x = -100, 4 the back wall z = -100, 5 the floor y = 0; every range 1000.
pub fn room_walls() -> Vec<String> {
    [
        "MaterialIndex 0 Plane { normal 0 -1 0 offset -160 range 1000 }",
        "MaterialIndex 0 Plane { normal 0 0 -1 offset -1000 range 1000 }",
        "MaterialIndex 1 Plane { normal -1 0 0 offset -100 range 1000 }",
        "MaterialIndex 4 Plane { normal 1 0 0 offset -100 range 1000 }",
        "MaterialIndex 1 Plane { normal 0 0 1 offset -100 range 1000 }",
        "MaterialIndex 1 Plane { normal 0 1 0 offset 0 range 1000 }",
    ]
    .map(String::from)
    .to_vec()
}

/// A 24x18 scene of `objects` seen by a camera looking down -z (`camera`: its `center`, and
/// `flength` and `aperture` for a thin lens). Materials: 0 the case2 ceiling's emission
/// (0.42 0.41 0.4, colour 0), 1 grey 0.75, 2 glass, 3 emission 2 2 2 (colour 0), 4 red.
pub fn room_scene(camera: &str, objects: &[String]) -> clpt::scene::Scene {
    room_scene_with(camera, &[], objects)
}

/// [`room_scene`] with `materials` added after its five (as materials 5, 6, ...).
pub fn room_scene_with(
    camera: &str,
    materials: &[String],
    objects: &[String],
) -> clpt::scene::Scene {
    let text = format!(
        "PerspectiveCamera {{ {camera} direction 0 0 -1 angle 30 width 24 height 18 }}\n\
         Materials {{ numMaterials {} \
         Material {{ emission 0.42 0.41 0.4 color 0 0 0 }} \
         Material {{ color 0.75 0.75 0.75 }} \
         Material {{ color 0.999 0.999 0.999 type refr }} \
         Material {{ emission 2 2 2 color 0 0 0 }} \
         Material {{ color 0.75 0.25 0.25 }} {} }}\n\
         Group {{ numObjects {} {} }}\n",
        5 + materials.len(),
        materials.join(" "),
        objects.len(),
        objects.join(" ")
    );
    clpt::scene::parse::parse_scene(&text, "room").unwrap_or_else(|e| panic!("{e}"))
}

/// A rotated emitting square (material 3) through the room's wall x = 100, its ceiling and its
/// front wall: object-space square |x|, |z| <= 30 at y = 0, facing -y, under
/// [`room_panel_transform`].
pub const ROOM_PANEL: &str = "MaterialIndex 3 Transform { Translate 90 150 980 ZRotate 30 \
                              XRotate 20 Plane { normal 0 -1 0 offset 0 range 30 } }";

/// The transform of [`ROOM_PANEL`].
pub fn room_panel_transform() -> glam::DMat4 {
    glam::DMat4::from_translation(DVec3::new(90.0, 150.0, 980.0))
        * glam::DMat4::from_rotation_z(30f64.to_radians())
        * glam::DMat4::from_rotation_x(20f64.to_radians())
}

/// The case2 room made for clipping (written to `dir`, its quad mesh): [`room_walls`], the
/// [`ROOM_PANEL`] through three walls, an emitting quad mesh (material 3) twice, once inside
/// the room and once above its ceiling (dropped from the light list), and a red ball on the
/// floor. Its ceiling, front wall and panel are clipped to the room.
pub fn clipped_room_scene(dir: &std::path::Path) -> clpt::scene::Scene {
    std::fs::create_dir_all(dir).unwrap();
    let quad = dir.join("quad.obj");
    std::fs::write(
        &quad,
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let mut objects = room_walls();
    objects.push(ROOM_PANEL.to_string());
    for (at, turn) in [("-50 100 0", 160), ("0 200 0", 180)] {
        objects.push(format!(
            "MaterialIndex 3 Transform {{ Translate {at} ZRotate {turn} UniformScale 15 \
             Mesh {{ obj_file {} }} }}",
            quad.display()
        ));
    }
    objects.push("MaterialIndex 4 Sphere { center 30 25 100 radius 25 }".to_string());
    room_scene("center 0 60 500", &objects)
}

/// Mean radiance of the pixels of `film` in the quadrant `q` (0..4), per channel, and the
/// variance of that mean from the pixels' own sample variances.
pub fn quadrant_mean(film: &clpt::render::film::Film, q: u32) -> ([f64; 3], [f64; 3]) {
    let (w, h) = (film.width / 2, film.height / 2);
    let (x0, y0) = ((q % 2) * w, (q / 2) * h);
    let (mut mean, mut var) = ([0.0; 3], [0.0; 3]);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let (m, v) = (film.mean(x, y), film.variance_of_mean(x, y));
            for c in 0..3 {
                mean[c] += m[c];
                var[c] += v[c];
            }
        }
    }
    let n = (w * h) as f64;
    (mean.map(|m| m / n), var.map(|v| v / (n * n)))
}

/// Mean radiance of the whole film per channel, and the variance of that mean from the pixels'
/// own sample variances.
pub fn image_mean(film: &clpt::render::film::Film) -> ([f64; 3], [f64; 3]) {
    let (mut mean, mut var) = ([0.0; 3], [0.0; 3]);
    for y in 0..film.height {
        for x in 0..film.width {
            let (m, v) = (film.mean(x, y), film.variance_of_mean(x, y));
            for c in 0..3 {
                mean[c] += m[c];
                var[c] += v[c];
            }
        }
    }
    let n = f64::from(film.width * film.height);
    (mean.map(|m| m / n), var.map(|v| v / (n * n)))
}

/// Asserts that every value of `a` lies within `relative` of the value of `b` at its place:
/// two renders of the same samples that may differ only by the rounding of their compensated
/// sums (about 1e-7; merge, several devices, Slurm).
pub fn assert_close<'a>(
    a: impl IntoIterator<Item = &'a f32>,
    b: impl IntoIterator<Item = &'a f32>,
    relative: f32,
    what: &str,
) {
    for (i, (x, y)) in a.into_iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= relative * y.abs(),
            "{what}: value {i} is {x}, against {y}"
        );
    }
}
