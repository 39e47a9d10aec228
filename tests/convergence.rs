//! The error a render reports about itself: on small scenes (a room of planes lit by a large
//! sphere, and smallpt), renders of 8 to 8192 samples per pixel (three decades of run time)
//! estimate their RMSE from the even and odd halves of their samples within a factor of 1.5 of
//! the RMSE measured against a 131072-sample reference, and MSE × samples stays within a factor
//! of 1.5 of its mean: the error falls as 1/√t, as an unbiased estimator's does.
//!
//! Not yet here: the third scene the error issue asks for, a room lit by one small bright sphere
//! (the stiff case of the original's `case5_light_balls.txt`). Without light sampling its error
//! is carried by a few rare paths: 20 pixel channels of 1296 hold half its variance. The
//! estimate is right on average (over 8 renders of 512 spp, a mean estimated MSE of 0.306
//! against 0.302 measured across the renders), but single renders scatter from 0.45 to 0.73 in
//! estimated RMSE, and against a reference the estimate came out 1.46 to 1.54 times the measured
//! error from 512 spp on. The scene joins this test with next-event estimation, which the same
//! issue brings.

mod common;

use clpt::device::program::KernelSources;
use clpt::render::metrics::LinearImage;
use clpt::render::{PassReport, RenderOptions, Renderer};
use clpt::scene::Scene;
use clpt::scene::parse::parse_scene;
use std::sync::Arc;

/// How far the estimate may stray from the measured error, either way.
const FACTOR: f64 = 1.5;

fn small(mut scene: Scene) -> Scene {
    scene.camera.width = 24;
    scene.camera.height = 18;
    scene
}

fn scenes() -> Vec<(&'static str, Scene)> {
    let room = |light: &str, height: f64, radius: f64| {
        format!(
            "PerspectiveCamera {{ center 0 0 9 direction 0 0 -1 angle 40 width 24 height 18 }}\n\
             Materials {{ numMaterials 4 Material {{ emission {light} }} \
             Material {{ color 0.75 0.25 0.25 }} Material {{ color 0.25 0.25 0.75 }} \
             Material {{ color 0.75 0.75 0.75 }} }}\n\
             Group {{ numObjects 8 \
             MaterialIndex 1 Plane {{ normal 1 0 0 offset -4 range 100 }} \
             MaterialIndex 2 Plane {{ normal -1 0 0 offset -4 range 100 }} \
             MaterialIndex 3 Plane {{ normal 0 1 0 offset -3 range 100 }} \
             Plane {{ normal 0 -1 0 offset -3 range 100 }} \
             Plane {{ normal 0 0 1 offset -4 range 100 }} \
             Sphere {{ center -1.5 -2 -1 radius 1 }} \
             Sphere {{ center 1.5 -2 0 radius 1 }} \
             MaterialIndex 0 Sphere {{ center 0 {height} -1 radius {radius} }} }}\n"
        )
    };
    let parse =
        |text: String, name: &str| parse_scene(&text, name).unwrap_or_else(|e| panic!("{e}"));
    vec![
        ("room", parse(room("1.5 1.5 1.5", 5.2, 2.5), "room")),
        ("smallpt", small(clpt::scene::builtin::scene().unwrap())),
        (
            "small light",
            parse(room("400 400 400", 2.8, 0.1), "small light"),
        ),
    ]
}

/// The last report row of a render of `spp` samples with `seed`.
fn render(
    scene: &Scene,
    spp: u32,
    seed: u64,
    reference: Option<Arc<LinearImage>>,
) -> (PassReport, LinearImage) {
    let device = common::device();
    let options = RenderOptions {
        spp: Some(spp),
        seed,
        reference,
        ..RenderOptions::default()
    };
    let mut renderer = Renderer::new(&device, scene, &KernelSources::Embedded, options)
        .unwrap_or_else(|e| panic!("{e}"));
    let (film, stats) = renderer
        .render(&mut |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let image = LinearImage {
        width: film.width,
        height: film.height,
        rgb: film
            .rgb_top_down()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
    };
    (*stats.report.last().expect("a report row"), image)
}

#[test]
fn the_estimate_tracks_the_true_error_and_mse_falls_as_one_over_time() {
    for (name, scene) in scenes() {
        let (_, reference) = render(&scene, 131072, 1, None);
        let reference = Arc::new(reference);
        let mut scaled_mse = Vec::new();
        for (k, spp) in [8u32, 32, 128, 512, 2048, 8192].into_iter().enumerate() {
            let (row, image) = render(&scene, spp, 100 + k as u64, Some(reference.clone()));
            let measured = row.measured.expect("measured against the reference");
            // The device's measurement is the host's.
            let host = image.metrics(&reference).unwrap();
            assert!(
                (host.rmse - measured.rmse).abs() <= 1e-4 * host.rmse,
                "{name}: {host:?} {measured:?}"
            );
            let ratio = row.estimate.rmse / measured.rmse;
            eprintln!(
                "{name}: {spp} spp: estimated RMSE {:.4e}, measured {:.4e} (ratio {ratio:.3})",
                row.estimate.rmse, measured.rmse
            );
            assert!(
                (1.0 / FACTOR..=FACTOR).contains(&ratio),
                "{name} at {spp} spp: estimate {} against measured {}",
                row.estimate.rmse,
                measured.rmse
            );
            scaled_mse.push(measured.rmse * measured.rmse * spp as f64);
        }
        let mean = scaled_mse.iter().sum::<f64>() / scaled_mse.len() as f64;
        for (s, spp) in scaled_mse.iter().zip([8, 32, 128, 512, 2048, 8192]) {
            assert!(
                (mean / FACTOR..=mean * FACTOR).contains(s),
                "{name}: MSE x spp {s:.4e} at {spp} spp, mean {mean:.4e}: not 1/t"
            );
        }
    }
}
