//! Per-scene specialisation and the program cache: each of the original's test scenes maps to
//! the feature set its file describes; the program built for a sphere-only scene contains no
//! kd-tree, Newton, texture, transform or lens code (checked on the exact source built, as
//! `--dump-kernel` writes it); for the same seed the specialised and the all-features programs
//! render identical images; the cache returns what it stored, keyed so that other options miss,
//! and a damaged cache file is rebuilt from source.

mod common;

use clpt::contract::{OBJECT_MESH, OBJECT_PLANE, OBJECT_REVSURFACE, OBJECT_SPHERE};
use clpt::device::program::{self, CacheUse, KernelSources};
use clpt::render::features::Features;
use clpt::render::strategy::{LightSampling, Roulette};
use clpt::render::{ObjectBvh, RenderOptions, Renderer};
use clpt::scene::Scene;
use std::path::Path;

/// Code that only some scenes need: a function of each switchable part.
const SWITCHED_CODE: [(&str, &str); 7] = [
    ("kdtree_intersect(", "kd-tree"),
    ("rev_newton(", "Newton"),
    ("texture_lookup(", "texture"),
    ("xform_point(", "transform"),
    ("concentric_disk(", "thin lens"),
    ("bvh_intersect(", "BVH"),
    ("triangle_intersect(", "triangle"),
];

/// The text of the render program with `f`'s switches, as the loader expands it.
fn program_text(f: &Features) -> String {
    KernelSources::Embedded
        .expand("pathtracer.cl", &f.defines())
        .unwrap_or_else(|e| panic!("{e}"))
        .text
}

fn features(name: &str) -> Option<Features> {
    let dir = common::seed_dir("original_testcases_map_to_their_features")?;
    let scene = Scene::load(&dir.join("testcases").join(name)).unwrap_or_else(|e| panic!("{e}"));
    Some(Features::of(&scene, ObjectBvh::Auto))
}

#[test]
fn original_testcases_map_to_their_features() {
    // (file, spheres, planes, meshes, revolved surfaces, transforms, maps (colour, emission,
    // type, bump), thin lens, glass, emitters)
    type Row = (&'static str, [bool; 5], [bool; 4], bool, bool, usize);
    let expected: [Row; 7] = [
        (
            "case0_texture.txt",
            [true, true, false, false, false],
            [true, false, true, true],
            false,
            true,
            2,
        ),
        (
            "case1_dof_mesh.txt",
            [true, true, true, false, true],
            [true, false, true, false],
            true,
            true,
            2,
        ),
        (
            "case2_softshadows_colorbleeding.txt",
            [false, true, false, false, false],
            [false; 4],
            false,
            false,
            2,
        ),
        (
            "case3_wineglass.txt",
            [true, true, false, true, true],
            [true, false, true, false],
            false,
            true,
            2,
        ),
        (
            "case4_planets.txt",
            [true, false, false, false, false],
            [true, true, false, false],
            false,
            false,
            1,
        ),
        (
            "case5_light_balls.txt",
            [true, true, false, false, false],
            [false; 4],
            false,
            false,
            1,
        ),
        (
            "scene08_core.txt",
            [false, false, false, true, true],
            [false; 4],
            false,
            false,
            0,
        ),
    ];
    for (file, kinds, maps, thin_lens, glass, emitters) in expected {
        let Some(f) = features(file) else { return };
        let got = (
            [
                f.has(OBJECT_SPHERE),
                f.has(OBJECT_PLANE),
                f.has(OBJECT_MESH),
                f.has(OBJECT_REVSURFACE),
                f.transforms,
            ],
            [f.color_maps, f.emission_maps, f.type_maps, f.bump_maps],
            f.thin_lens,
            f.glass,
            f.emitters,
        );
        assert_eq!(
            got,
            (kinds, maps, thin_lens, glass, emitters),
            "{file}: {f}"
        );
        assert!(!f.bvh, "{file}: under 32 objects, no BVH");
        let degree = if f.has(OBJECT_REVSURFACE) { 3 } else { 0 };
        assert_eq!(f.rev_degree, degree, "{file}");
    }
}

#[test]
fn a_sphere_only_program_carries_no_other_code() {
    let scene = clpt::scene::builtin::scene().unwrap();
    let specialised = Features::of(&scene, ObjectBvh::Auto);
    let all = Features::all(&scene, ObjectBvh::On);
    let (small, full) = (program_text(&specialised), program_text(&all));
    for (code, what) in SWITCHED_CODE {
        assert!(
            full.contains(code),
            "the all-features program lacks {what} code `{code}`"
        );
        assert!(
            !small.contains(code),
            "smallpt's program has {what} code `{code}`"
        );
    }
    assert!(
        small.contains("sphere_intersect("),
        "smallpt's program lacks spheres"
    );
    // Lines of code: comments (which the two programs share), blank lines and `#line`
    // directives left out.
    let code_lines = |text: &str| {
        let mut in_comment = false;
        text.lines()
            .filter(|line| {
                let mut code = String::new();
                let mut rest = *line;
                while !rest.is_empty() {
                    if in_comment {
                        match rest.find("*/") {
                            Some(i) => (in_comment, rest) = (false, &rest[i + 2..]),
                            None => rest = "",
                        }
                    } else {
                        match rest.find("/*") {
                            Some(i) => {
                                code.push_str(&rest[..i]);
                                (in_comment, rest) = (true, &rest[i + 2..]);
                            }
                            None => (code, rest) = (code + rest, ""),
                        }
                    }
                }
                let code = code.trim();
                !code.is_empty() && !code.starts_with("//") && !code.starts_with("#line")
            })
            .count()
    };
    assert!(
        code_lines(&small) * 2 < code_lines(&full),
        "smallpt's program is {} lines of code, all features {}",
        code_lines(&small),
        code_lines(&full)
    );
    // The device compiles it, and what `-v` calls the options is what went in.
    let device = common::device();
    let built = program::build_entry(
        &device,
        &KernelSources::Embedded,
        "pathtracer.cl",
        &specialised.defines(),
        None,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(built.source.text, small);
    assert!(
        built.options.contains("-DCLPT_MESHES=0") && built.options.contains("-DCLPT_SPHERES=1")
    );
    assert_eq!(built.cache, CacheUse::Off);
}

/// A device of `platform` as the renderer describes it: a GPU or not, of native float width
/// `width`.
fn device(platform: &str, is_gpu: bool, width: u32) -> clpt::device::DeviceDescription {
    clpt::device::DeviceDescription {
        index: 0,
        platform: platform.into(),
        platform_version: String::new(),
        name: String::new(),
        kind: String::new(),
        compute_units: 1,
        global_mem_bytes: 0,
        max_alloc_bytes: 0,
        opencl_c_version: String::new(),
        driver_version: String::new(),
        is_gpu,
        native_float_width: width,
        watchdog: None,
        nv_compiler_options: false,
    }
}

/// The register cap is an NVIDIA compiler option: only a device whose compiler names
/// cl_nv_compiler_options is given it (another compiler would refuse the build), and the
/// program switches follow it unchanged.
#[test]
fn only_nvidia_compilers_get_the_register_cap() {
    let cap = format!("-cl-nv-maxrregcount={}", program::NV_MAX_REGISTERS);
    let defines = [("CLPT_NEE", "1".to_string())];
    let nvidia = clpt::device::DeviceDescription {
        nv_compiler_options: true,
        ..device("NVIDIA CUDA", true, 1)
    };
    let options = program::build_options(&nvidia, &defines);
    assert_eq!(
        options,
        format!("-cl-kernel-arg-info {cap} -DCLPT_NEE=1"),
        "{options}"
    );
    for other in [
        device("Portable Computing Language", false, 16),
        device("AMD Accelerated Parallel Processing", true, 1),
        device("NVIDIA CUDA", true, 1),
    ] {
        let options = program::build_options(&other, &defines);
        assert_eq!(
            options, "-cl-kernel-arg-info -DCLPT_NEE=1",
            "{}",
            other.platform
        );
    }
}

/// Path regeneration's warp vote is NVIDIA's inline PTX: only NVIDIA GPUs get the switch, and
/// only a program built with it carries the vote.
#[test]
fn only_nvidia_gpus_get_the_warp_vote() {
    let description =
        |platform: &str, is_gpu: bool| device(platform, is_gpu, if is_gpu { 1 } else { 16 });
    assert!(Features::regeneration_on(&description("NVIDIA CUDA", true)));
    for (platform, is_gpu) in [
        ("Portable Computing Language", false),
        ("AMD Accelerated Parallel Processing", true),
        ("Intel(R) OpenCL Graphics", true),
        ("NVIDIA CUDA", false),
    ] {
        assert!(
            !Features::regeneration_on(&description(platform, is_gpu)),
            "{platform}, GPU {is_gpu}"
        );
    }
    let scene = clpt::scene::builtin::scene().unwrap();
    let mut features = Features::of(&scene, ObjectBvh::Auto);
    assert!(
        !features.regenerate,
        "Features::of leaves it to the renderer"
    );
    for regenerate in [false, true] {
        features.regenerate = regenerate;
        let text = program_text(&features);
        assert_eq!(text.contains("vote.sync.ballot"), regenerate);
        assert_eq!(text.contains("warp_vote_half("), regenerate);
    }
}

/// A CPU device carries several paths a work-item (kernels/lanes.h) where the program has only
/// what the wide kernels are written for: its native float width, or `--lanes`; a GPU, texture
/// maps, meshes or the BVH keep one. The wide program has the wide types,
/// the scalar one none of their text.
#[test]
fn cpus_get_lanes_where_the_program_allows() {
    let device = |is_gpu: bool, width: u32| device("", is_gpu, width);
    let smallpt = clpt::scene::builtin::scene().unwrap();
    let plain = Features::of(&smallpt, ObjectBvh::Auto);
    assert_eq!(plain.lanes, 1, "Features::of leaves it to the renderer");
    assert_eq!(plain.wide_lanes(&device(false, 16), None), 16);
    assert_eq!(plain.wide_lanes(&device(false, 8), None), 8);
    assert_eq!(plain.wide_lanes(&device(false, 1), None), 1);
    assert_eq!(plain.wide_lanes(&device(false, 16), Some(4)), 4);
    assert_eq!(plain.wide_lanes(&device(false, 16), Some(1)), 1);
    assert_eq!(plain.wide_lanes(&device(true, 1), Some(16)), 1, "a GPU");
    // What the wide kernels are written for keeps the device's width; the rest takes one lane.
    type Set = fn(&mut Features);
    let cases: [(Set, u32, &str); 5] = [
        (|f| f.nee = true, 16, "light sampling"),
        (
            |f| {
                f.kinds[OBJECT_MESH as usize] = true;
                f.transforms = true;
            },
            16,
            "meshes and transforms",
        ),
        (
            |f| f.kinds[OBJECT_REVSURFACE as usize] = true,
            1,
            "surfaces of revolution",
        ),
        (|f| f.bvh = true, 1, "the BVH"),
        (|f| f.color_maps = true, 1, "texture maps"),
    ];
    for (set, lanes, what) in cases {
        let mut f = plain.clone();
        set(&mut f);
        assert_eq!(f.wide_lanes(&device(false, 16), None), lanes, "{what}");
    }
    for lanes in [1, 16] {
        let mut f = plain.clone();
        f.lanes = lanes;
        let text = program_text(&f);
        assert_eq!(
            text.contains("typedef struct LFloat3"),
            lanes > 1,
            "{lanes} lanes"
        );
        assert_eq!(text.contains("path_select("), lanes > 1, "{lanes} lanes");
    }
}

#[test]
fn switched_off_blocks_keep_line_numbers_true() {
    let dir = tempdir("lines");
    std::fs::write(
        dir.join("main.cl"),
        "a\n#if CLPT_X\nx1\nx2\n#else\ny\n#endif\n#ifdef OTHER\nz\n#endif\nb\n",
    )
    .unwrap();
    let sources = KernelSources::Dir(dir.clone());
    let off = sources
        .expand("main.cl", &[("CLPT_X", "0".into())])
        .unwrap();
    let lines: Vec<&str> = off.text.lines().collect();
    assert!(
        !off.text.contains("x1") && off.text.contains("y") && off.text.contains("#ifdef OTHER")
    );
    // Every kept line still maps to its own line of main.cl.
    for (i, line) in lines.iter().enumerate() {
        if let Some(n) = ["a", "y", "z", "b"].iter().position(|s| s == line) {
            assert_eq!(
                off.origin(i + 1),
                Some(("main.cl", [1, 6, 9, 11][n])),
                "{line}"
            );
        }
    }
    // `#line` markers after dropped text tell the compiler the same.
    let y = lines.iter().position(|l| *l == "y").unwrap();
    assert_eq!(lines[y - 1], "#line 6 \"main.cl\"");
    let on = sources
        .expand("main.cl", &[("CLPT_X", "1".into())])
        .unwrap();
    assert!(on.text.contains("x1") && !on.text.lines().any(|l| l == "y"));
    // Unknown switches are the compiler's business.
    let unknown = sources.expand("main.cl", &[]).unwrap();
    assert!(unknown.text.contains("#if CLPT_X") && unknown.text.contains("x1"));
    std::fs::write(dir.join("elif.cl"), "#if CLPT_X\n#elif FOO\n#endif\n").unwrap();
    let err = sources
        .expand("elif.cl", &[("CLPT_X", "0".into())])
        .unwrap_err();
    assert!(err.to_string().contains("elif.cl:2"), "{err}");
}

/// `scene` at 4 samples with light sampling `light` and roulette below 0.3, by the scene's own
/// program or the all-features one. The strategy is fixed: the trial of `auto` picks by timings,
/// which differ between programs and runs (on NVIDIA it chose differently for the two programs).
fn render(
    scene: &Scene,
    light: LightSampling,
    all_features: bool,
    cache_dir: Option<&Path>,
) -> (Vec<[f32; 4]>, CacheUse) {
    render_with(
        &KernelSources::Embedded,
        scene,
        light,
        all_features,
        cache_dir,
    )
}

/// [`render`] with the kernels of `sources`.
fn render_with(
    sources: &KernelSources,
    scene: &Scene,
    light: LightSampling,
    all_features: bool,
    cache_dir: Option<&Path>,
) -> (Vec<[f32; 4]>, CacheUse) {
    let device = common::device();
    let options = RenderOptions {
        spp: Some(4),
        seed: 11,
        light_sampling: light,
        roulette: Roulette::Threshold(0.3),
        all_features,
        // One path a work-item: a CPU's wide program (kernels/lanes.h) rounds differently
        // (tests/render.rs compares the two); here only leaving code out is under test.
        lanes: Some(1),
        cache_dir: cache_dir.map(Path::to_path_buf),
        ..RenderOptions::default()
    };
    let mut renderer =
        Renderer::new(&device, scene, sources, options).unwrap_or_else(|e| panic!("{e}"));
    let cache = renderer.program().cache.clone();
    let film = renderer
        .render(&mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"))
        .0;
    (film.sum, cache)
}

fn small(path: &str) -> Scene {
    // From the working folder where it has the file (a packed device-run/), else the checkout.
    let path = [
        Path::new(path).to_path_buf(),
        Path::new(env!("CARGO_MANIFEST_DIR")).join(path),
    ]
    .into_iter()
    .find(|p| p.is_file())
    .unwrap_or_else(|| panic!("{path} not found"));
    let mut scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    scene.camera.width = 40;
    scene.camera.height = 24;
    scene
}

/// The kernels (of the working folder where it has them, a packed device-run/, else the
/// checkout) copied to a temporary folder with floating-point contraction off everywhere:
/// `#pragma OPENCL FP_CONTRACT OFF` first, and triangle.h's own switch back to on turned off.
fn kernels_without_contraction() -> KernelSources {
    let from = [Path::new("kernels"), program::checkout_kernel_dir()]
        .into_iter()
        .find(|p| p.join("pathtracer.cl").is_file())
        .expect("a kernels folder");
    let dir = std::env::temp_dir().join(format!("clpt-no-contraction-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_owned();
        let mut text = std::fs::read_to_string(&path).unwrap();
        if name == "pathtracer.cl" {
            text = format!("#pragma OPENCL FP_CONTRACT OFF\n{text}");
        }
        let text = text.replace("FP_CONTRACT ON", "FP_CONTRACT OFF");
        std::fs::write(dir.join(name), text).unwrap();
    }
    KernelSources::Dir(dir)
}

/// Leaving code out of a program changes nothing it computes: a scene's own program and the
/// all-features one render the same bits. With floating-point contraction off this holds on
/// every device. As built it holds on PoCL; NVIDIA's compiler contracts a product and a sum
/// into one fma (OpenCL's FP_CONTRACT is on by default) in one program and not in the other,
/// so there `textures.txt` with light sampling differed in the last bits (relMSE 5e-17 on an
/// H100; the same bits with contraction off: BENCHMARKS.md, "A queue of pixels").
#[test]
fn specialised_and_all_features_programs_render_the_same_bits() {
    let mut smallpt = clpt::scene::builtin::scene().unwrap();
    smallpt.camera.width = 40;
    smallpt.camera.height = 30;
    let gpu = common::device().description.is_gpu;
    let exact = kernels_without_contraction();
    let as_built = KernelSources::Embedded;
    let builds: &[(&str, &KernelSources)] = if gpu {
        &[("contraction off", &exact)]
    } else {
        &[("contraction off", &exact), ("as built", &as_built)]
    };
    // A sphere room; maps, transforms and bump frames; meshes with a thin lens.
    for scene in [
        smallpt,
        small("scenes/textures.txt"),
        small("scenes/meshes.txt"),
    ] {
        for light in [LightSampling::On, LightSampling::Off] {
            for (build, sources) in builds {
                let (specialised, _) = render_with(sources, &scene, light, false, None);
                let (all, _) = render_with(sources, &scene, light, true, None);
                assert!(
                    specialised.iter().any(|p| p[..3] != [0.0; 3]),
                    "{}: black",
                    scene.source
                );
                assert!(
                    specialised == all,
                    "{}, light sampling {light:?}, {build}: the programs differ",
                    scene.source
                );
            }
        }
    }
    if let KernelSources::Dir(dir) = exact {
        std::fs::remove_dir_all(dir).unwrap();
    }
}

#[test]
fn the_cache_returns_what_it_stored_and_rebuilds_what_it_cannot_read() {
    let dir = tempdir("cache");
    let mut scene = clpt::scene::builtin::scene().unwrap();
    scene.camera.width = 16;
    scene.camera.height = 12;
    let (first, use1) = render(&scene, LightSampling::On, false, Some(&dir));
    let CacheUse::Stored(path) = use1 else {
        panic!("not stored: {use1:?}")
    };
    let (second, use2) = render(&scene, LightSampling::On, false, Some(&dir));
    assert_eq!(use2, CacheUse::Hit(path.clone()));
    assert!(first == second, "the cached program renders differently");
    // Other options, another key.
    let (_, use3) = render(&scene, LightSampling::On, true, Some(&dir));
    assert!(
        matches!(use3, CacheUse::Stored(ref p) if *p != path),
        "{use3:?}"
    );
    // A damaged file is rebuilt from source and replaced.
    std::fs::write(&path, b"not a program").unwrap();
    let (third, use4) = render(&scene, LightSampling::On, false, Some(&dir));
    assert_eq!(use4, CacheUse::Stored(path));
    assert!(first == third);
}

fn tempdir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A program tests walls (`CLPT_WALLS`, kernels/objects.h) where some axis has a wall on each
/// side and there is no object BVH, on a CPU: the ceiling-lit room, not smallpt (its one wall
/// plane), the room under the BVH nor on a GPU. The switch leaves the code out where it is off.
#[test]
fn walls_go_where_an_axis_has_a_wall_on_each_side() {
    let scene_of = |text: &str| clpt::scene::parse::parse_scene(text, "walls").unwrap();
    let room = scene_of(include_str!("../scenes/ceiling_room.txt"));
    let smallpt = clpt::scene::builtin::scene().unwrap();
    let packed = |s: &clpt::scene::Scene| clpt::pack::PackedScene::new(s, 1 << 20).unwrap();
    let slots = |s: &Scene| clpt::pack::walls(&packed(s).planes).0;
    let (room_slots, smallpt_slots) = (slots(&room), slots(&smallpt));
    let cpu = device("PoCL", false, 16);
    assert!(Features::of(&room, ObjectBvh::Off).walls_on(&room_slots, &cpu));
    assert!(
        !Features::of(&room, ObjectBvh::On).walls_on(&room_slots, &cpu),
        "under the BVH"
    );
    assert!(!Features::of(&smallpt, ObjectBvh::Off).walls_on(&smallpt_slots, &cpu));
    let gpu = device("NVIDIA CUDA", true, 1);
    assert!(
        !Features::of(&room, ObjectBvh::Off).walls_on(&room_slots, &gpu),
        "a GPU, where walls were not measured"
    );
    let mut f = Features::of(&room, ObjectBvh::Off);
    for walls in [false, true] {
        f.walls = walls;
        let text = program_text(&f);
        assert_eq!(
            text.contains("walls_intersect("),
            walls,
            "CLPT_WALLS={walls}"
        );
    }
}
