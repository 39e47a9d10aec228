//! Shadow rays to a point (kernels/nee.h `segment_unblocked`): a light sample counts unless
//! something lies on the segment to the sampled point, whatever the rounding of the light's own
//! intersection. Each test renders a floor lit by direct light alone (nothing above it to bounce
//! from), light sampling on, and compares two versions of one light that must give the same
//! picture; a Z-test on the image mean, with standard errors from the samples themselves.
//! The old rule (the shadow ray must hit the very primitive sampled) lost 32% of a radius-1e-4
//! sphere's light seen from 300 units, and 4% of a 2048-triangle ceiling's 1e6 from the origin.

mod common;

use clpt::render::RenderOptions;
use clpt::render::film::Film;
use clpt::render::strategy::{LightSampling, Roulette};
use clpt::scene::Scene;
use clpt::scene::parse::parse_scene;

const Z_LIMIT: f64 = 5.0;

fn render(scene: &Scene, spp: u32, seed: u64) -> Film {
    let options = RenderOptions {
        spp: Some(spp),
        seed,
        light_sampling: LightSampling::On,
        roulette: Roulette::Threshold(1.0),
        ..RenderOptions::default()
    };
    common::render(scene, options).0
}

/// Relative difference allowed on top of Z_LIMIT standard errors: f32 rounding of the light's
/// geometry (a radius-1e-4 sphere 300 away subtends a cone whose cosine, 1 - 5.6e-14, rounds
/// to 1, and its samples, nearly all alike, have a standard error near 1e-5 relative). It is
/// 200 times below the 2% loss these tests must see.
const ROUNDING: f64 = 1e-4;

/// Asserts that two renders' image means agree within Z_LIMIT standard errors (and rounding),
/// and that the test is sharp enough to see a 2% loss.
fn assert_same_light(what: &str, a: &Film, b: &Film) {
    let ((ma, va), (mb, vb)) = (common::image_mean(a), common::image_mean(b));
    let (sa, sb) = (va.map(f64::sqrt), vb.map(f64::sqrt));
    for c in 0..3 {
        let se = sa[c].hypot(sb[c]) + ROUNDING * mb[c].abs() / Z_LIMIT;
        let z = (ma[c] - mb[c]) / se;
        eprintln!(
            "{what} channel {c}: {:.6} +- {:.6} against {:.6} +- {:.6}, z {z:.2}",
            ma[c], sa[c], mb[c], sb[c]
        );
        assert!(mb[c] > 0.0, "{what}: no light arrived");
        assert!(se < 0.004 * mb[c], "{what}: too noisy to see a 2% loss");
        assert!(z.abs() < Z_LIMIT, "{what} channel {c}: z = {z:.2}");
    }
}

/// A grey floor at y = 0 seen from 10 above, lit by a sphere of radius r 300 above it whose
/// emission is scaled by 1 / r², so that its power, and the floor's light, do not depend on r
/// (to within (r / 300)²), all moved by `offset`.
fn sphere_lit_floor(radius: f64, offset: [f64; 3]) -> Scene {
    let le = 1e4 / (radius * radius);
    let [x, y, z] = offset;
    let text = format!(
        "PerspectiveCamera {{ center {x} {} {z} direction 0.0001 -1 0 angle 60 width 32 height 32 }}\n\
         Materials {{ numMaterials 2 Material {{ color 0.5 0.5 0.5 }} \
           Material {{ emission {le} {le} {le} color 0 0 0 }} }}\n\
         Group {{ numObjects 2 MaterialIndex 0 \
           Transform {{ Translate {x} {y} {z} Plane {{ normal 0 1 0 offset 0 range 400 }} }} \
           MaterialIndex 1 Sphere {{ center {} {} {} radius {radius} }} }}\n",
        y + 10.0,
        x + 40.0,
        y + 300.0,
        z - 30.0
    );
    parse_scene(&text, "sphere-lit floor").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_tiny_sphere_light_gives_the_light_of_a_big_one() {
    let big = render(&sphere_lit_floor(1.0, [0.0; 3]), 256, 1);
    let tiny = render(&sphere_lit_floor(1e-4, [0.0; 3]), 256, 2);
    assert_same_light("radius 1e-4 against radius 1", &tiny, &big);
}

/// A square ceiling light 4 above a grey floor, made of `cells`² x 2 triangles of one OBJ mesh,
/// the whole scene moved by `offset`; its OBJ goes to `dir`.
fn ceiling_lit_floor(dir: &std::path::Path, cells: usize, offset: f64) -> Scene {
    std::fs::create_dir_all(dir).unwrap();
    let mut obj = String::new();
    for i in 0..=cells {
        for j in 0..=cells {
            let (x, z) = (
                -2.0 + 4.0 * i as f64 / cells as f64,
                -2.0 + 4.0 * j as f64 / cells as f64,
            );
            obj += &format!("v {x} 0 {z}\n");
        }
    }
    let at = |i: usize, j: usize| i * (cells + 1) + j + 1;
    for i in 0..cells {
        for j in 0..cells {
            obj += &format!("f {} {} {}\n", at(i, j), at(i + 1, j), at(i + 1, j + 1));
            obj += &format!("f {} {} {}\n", at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
    let file = dir.join(format!("ceiling{cells}.obj"));
    std::fs::write(&file, obj).unwrap();
    let o = offset;
    let text = format!(
        "PerspectiveCamera {{ center {o} 3 {} direction 0 -0.6 -1 angle 50 width 32 height 32 }}\n\
         Materials {{ numMaterials 2 Material {{ color 0.5 0.5 0.5 }} \
           Material {{ emission 2 2 2 color 0 0 0 }} }}\n\
         Group {{ numObjects 2 MaterialIndex 0 \
           Transform {{ Translate {o} 0 {o} Plane {{ normal 0 1 0 offset 0 range 50 }} }} \
           MaterialIndex 1 Transform {{ Translate {o} 4 {o} Mesh {{ obj_file {} }} }} }}\n",
        o + 6.0,
        file.display()
    );
    parse_scene(&text, "ceiling-lit floor").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn thousands_of_emitting_triangles_far_away_give_the_light_of_two() {
    let dir = std::env::temp_dir().join(format!("clpt-shadow-rays-{}", std::process::id()));
    for offset in [0.0, 1e6] {
        let two = render(&ceiling_lit_floor(&dir, 1, offset), 512, 3);
        let many = render(&ceiling_lit_floor(&dir, 32, offset), 512, 4);
        assert_same_light(
            &format!("2048 triangles against 2, {offset} from the origin"),
            &many,
            &two,
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A sphere light sunk into the ceiling of a closed room and into an opaque ball is sampled over
/// its visible cap (lights.rs `visible_cap`, nee.h): light sampling and pure path tracing give
/// the same picture, quadrant by quadrant.
#[test]
fn a_sunk_sphere_light_sampled_over_its_cap_matches_path_tracing() {
    let text = "PerspectiveCamera { center 0 1.5 3.5 direction 0 -0.2 -1 angle 50 width 24 height 18 }\n\
                Materials { numMaterials 4 Material { color 0.6 0.6 0.6 } \
                  Material { emission 6 6 6 color 0.2 0.2 0.2 } \
                  Material { color 0.7 0.3 0.3 } Material { color 0.3 0.3 0.7 } }\n\
                Group { numObjects 10 MaterialIndex 0 \
                  Plane { normal 0 1 0 offset 0 range 10 } Plane { normal 0 -1 0 offset -3 range 10 } \
                  Plane { normal 0 0 1 offset -2 range 10 } Plane { normal 0 0 -1 offset -4 range 10 } \
                  MaterialIndex 2 Plane { normal 1 0 0 offset -2 range 10 } \
                  MaterialIndex 3 Plane { normal -1 0 0 offset -2 range 10 } \
                  MaterialIndex 0 Sphere { center 1 0.5 -1 radius 0.5 } \
                  MaterialIndex 1 Sphere { center 0 3.5 -0.5 radius 0.7 } \
                  Sphere { center 1.25 0.75 -1 radius 0.2 } \
                  MaterialIndex 0 Sphere { center -1 0.4 0 radius 0.4 } }\n";
    let scene = parse_scene(text, "sunk lights").unwrap_or_else(|e| panic!("{e}"));
    let packed = clpt::pack::PackedScene::new(&scene, u64::MAX).unwrap();
    let caps: Vec<f32> = packed.lights.iter().map(|l| l.cap_height).collect();
    assert!(
        caps.len() == 2 && caps.iter().all(|&h| h > 0.0),
        "both lights should be sampled over caps: {caps:?}"
    );
    let film = |light_sampling, spp, seed| {
        let options = RenderOptions {
            spp: Some(spp),
            seed,
            light_sampling,
            roulette: Roulette::Threshold(1.0),
            ..RenderOptions::default()
        };
        common::render(&scene, options).0
    };
    let with = film(LightSampling::On, 1024, 5);
    let without = film(LightSampling::Off, 4096, 6);
    for q in 0..4u32 {
        let ((a, va), (b, vb)) = (
            common::quadrant_mean(&with, q),
            common::quadrant_mean(&without, q),
        );
        for c in 0..3 {
            let z = (a[c] - b[c]) / (va[c] + vb[c]).sqrt();
            eprintln!(
                "quadrant {q} channel {c}: {:.4} against {:.4}, z {z:.2}",
                a[c], b[c]
            );
            assert!(z.abs() < Z_LIMIT, "quadrant {q} channel {c}: z = {z:.2}");
        }
    }
}
