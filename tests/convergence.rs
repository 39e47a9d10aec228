//! The error a render reports about itself, and light sampling. On three small scenes (a room of
//! planes lit by a large sphere, smallpt, and the same room lit by one small bright sphere out of
//! the picture, the stiff case of the original's `case5_light_balls.txt`: scenes/room.txt,
//! the built-in smallpt and scenes/small_light.txt, at 24x18):
//! - renders of 8 to 8192 samples per pixel (three decades of run time) estimate their RMSE
//!   from the even and odd halves of their samples within a factor of 1.5 of their true RMSE:
//!   the RMSE measured against a 32768-sample reference, less the reference's own (the two
//!   renders are independent, so their squared errors add; the reference's MSE is its own
//!   estimate, a quarter of the 8192-sample render's at most), and the MSE falls at least as fast as 1/samples (the
//!   least-squares slope of ln MSE against ln spp at most -0.8): the error falls at least as
//!   1/√t, as an unbiased Monte Carlo estimator's does. (The samples are quasi-random,
//!   kernels/rng.h: on the room MSE × samples fell from 6.7e-3 at 8 spp to 3.3e-3 at 32 and
//!   about 2.3e-3 from 2048 on, faster than 1/t early, as randomized quasi-Monte Carlo does; an
//!   estimator that levels off, biased or stalled, still fails.)
//! - next-event estimation with MIS and pure path tracing converge to the same image: every
//!   quadrant's mean, per channel, agrees within 5 standard errors, on those three scenes and on
//!   one lit by every kind of listed emitter (a transformed sphere, a rotated square, the
//!   triangles of a scaled mesh) and an unlisted ellipsoid, with bump-mapped and smooth-normal
//!   diffuse surfaces (tests/common `every_light_scene`), and on the original's case2 room
//!   whose emitters light sampling clips to the room (src/pack/lights.rs): its ceiling and
//!   front wall of range 1000, a rotated panel through three walls, and a mesh lamp above the
//!   ceiling it drops (tests/common `clipped_room_scene`).
//!
//! The small light is kept out of the picture: seen directly, its few pixels of Bernoulli
//! coverage (0 or 400) carry nearly all of the image's RMSE, and with so few degrees of freedom
//! one render's error scatters by factors of 3 about its expectation. The estimate is right on
//! average there too: lit in view and without light sampling, 8 renders of 512 spp gave a mean
//! estimated MSE of 0.306 against 0.302 measured across them.

mod common;

use clpt::render::metrics::LinearImage;
use clpt::render::strategy::LightSampling;
use clpt::render::{PassReport, RenderOptions, settled};
use clpt::scene::Scene;
use std::sync::Arc;

/// How far the estimate may stray from the measured error, either way.
const FACTOR: f64 = 1.5;

/// The sample counts of the estimate's test: three decades of run time.
const SPPS: [u32; 6] = [8, 32, 128, 512, 2048, 8192];

/// The reference's samples in that test: four times the most of [`SPPS`]. Its own MSE (about a
/// quarter of the last render's, from its own estimate, which the test checks as it checks
/// every render's) is taken out of the measured one, where a reference of 131072 samples left
/// a sixteenth in and cost three quarters of the test's time.
const REFERENCE_SPP: u32 = 4 * SPPS[SPPS.len() - 1];

fn small(mut scene: Scene) -> Scene {
    scene.camera.width = 24;
    scene.camera.height = 18;
    scene
}

/// The three scenes, shrunk to 24x18: scenes/room.txt, smallpt and scenes/small_light.txt.
fn scenes() -> Vec<(&'static str, Scene)> {
    let load = |file: &str| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(file);
        small(Scene::load(&path).unwrap_or_else(|e| panic!("{e}")))
    };
    vec![
        ("room", load("room.txt")),
        ("smallpt", small(clpt::scene::builtin::scene().unwrap())),
        ("small light", load("small_light.txt")),
    ]
}

/// The last report row of a render of `spp` samples with `seed`.
fn render(
    scene: &Scene,
    spp: u32,
    seed: u64,
    reference: Option<Arc<LinearImage>>,
) -> (PassReport, LinearImage) {
    let (film, stats) = common::render(
        scene,
        RenderOptions {
            spp: Some(spp),
            seed,
            reference,
            ..RenderOptions::default()
        },
    );
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

/// The estimate's test on scene `k` of [`scenes`], one test a scene so that the three run side
/// by side (a render of 432 pixels keeps PoCL's two threads only partly busy).
fn the_estimate_tracks_the_true_error_on(k: usize) {
    let (name, scene) = scenes().swap_remove(k);
    let (reference_row, reference) = render(&scene, REFERENCE_SPP, 1, None);
    let reference = Arc::new(reference);
    let reference_mse = reference_row.estimate.rmse.powi(2);
    let mut scaled_mse = Vec::new();
    for (k, &spp) in SPPS.iter().enumerate() {
        let (row, image) = render(&scene, spp, 100 + k as u64, Some(reference.clone()));
        let measured = row.measured.expect("measured against the reference");
        // The device's measurement is the host's.
        let host = image.metrics(&reference).unwrap();
        assert!(
            (host.rmse - measured.rmse).abs() <= 1e-4 * host.rmse,
            "{name}: {host:?} {measured:?}"
        );
        let mse = measured.rmse.powi(2) - reference_mse;
        assert!(
            mse > 0.25 * measured.rmse.powi(2),
            "{name} at {spp} spp: the reference's estimated MSE {reference_mse:.3e} is most \
             of the measured {:.3e}",
            measured.rmse.powi(2)
        );
        let rmse = mse.sqrt();
        let ratio = row.estimate.rmse / rmse;
        eprintln!(
            "{name}: {spp} spp: estimated RMSE {:.4e}, true {rmse:.4e} (against the \
             reference {:.4e}; ratio {ratio:.3})",
            row.estimate.rmse, measured.rmse
        );
        assert!(
            (1.0 / FACTOR..=FACTOR).contains(&ratio),
            "{name} at {spp} spp: estimate {} against the true {rmse}",
            row.estimate.rmse,
        );
        scaled_mse.push(mse * spp as f64);
    }
    // The least-squares slope of ln MSE against ln spp: -1 for Monte Carlo, below for
    // quasi-random samples. One render's MSE scatters (ln sd about 0.4 on the small light),
    // which puts the slope's standard error near 0.07 over these three decades: 0.2 is
    // three of them. A biased or stalled estimator levels off far above.
    let xs: Vec<f64> = SPPS.iter().map(|&n| f64::from(n).ln()).collect();
    let ys: Vec<f64> = scaled_mse
        .iter()
        .zip(SPPS)
        .map(|(s, n)| (s / f64::from(n)).ln())
        .collect();
    let (mx, my) = (
        xs.iter().sum::<f64>() / xs.len() as f64,
        ys.iter().sum::<f64>() / ys.len() as f64,
    );
    let slope = xs
        .iter()
        .zip(&ys)
        .map(|(x, y)| (x - mx) * (y - my))
        .sum::<f64>()
        / xs.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    eprintln!("{name}: MSE falls as spp^{slope:.3} ({scaled_mse:?} as MSE x spp)");
    assert!(
        slope <= -0.8,
        "{name}: MSE falls as spp^{slope:.3}, slower than 1/t ({scaled_mse:?} as MSE x spp)"
    );
}

#[test]
fn the_estimate_tracks_the_true_error_and_mse_falls_at_least_as_one_over_time_room() {
    the_estimate_tracks_the_true_error_on(0);
}

#[test]
fn the_estimate_tracks_the_true_error_and_mse_falls_at_least_as_one_over_time_smallpt() {
    the_estimate_tracks_the_true_error_on(1);
}

#[test]
fn the_estimate_tracks_the_true_error_and_mse_falls_at_least_as_one_over_time_small_light() {
    the_estimate_tracks_the_true_error_on(2);
}

#[test]
fn light_sampling_and_pure_path_tracing_agree() {
    let film = |scene: &Scene, nee: bool, spp: u32, seed: u64| {
        let options = RenderOptions {
            spp: Some(spp),
            seed,
            light_sampling: if nee {
                LightSampling::On
            } else {
                LightSampling::Off
            },
            ..RenderOptions::default()
        };
        common::render(scene, options).0
    };
    let dir = std::env::temp_dir().join(format!("clpt-convergence-{}", std::process::id()));
    let mut all = scenes();
    all.push(("every light", common::every_light_scene(&dir)));
    all.push((
        "clipped room",
        common::clipped_room_scene(&dir.join("clipped")),
    ));
    for (name, scene) in all {
        let with = film(&scene, true, 2048, 7);
        let without = film(&scene, false, 8192, 8);
        for q in 0..4 {
            let (a, va) = common::quadrant_mean(&with, q);
            let (b, vb) = common::quadrant_mean(&without, q);
            for c in 0..3 {
                let z = (a[c] - b[c]) / (va[c] + vb[c]).sqrt();
                assert!(
                    z.abs() < 5.0,
                    "{name}, quadrant {q}, channel {c}: {} with NEE, {} without (z = {z:.2})",
                    a[c],
                    b[c]
                );
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--target-error` stops once the error is there, on the stiff scene (the small light, at
/// 64x48 so that the first passes hold few samples): against a 4096-spp reference (less its own
/// estimated relMSE), a render that stops on the target has a measured relMSE of at most 1.5
/// times it. With light sampling (target 3e-2) it must stop on the target within 30 s; pure path
/// tracing (target 0.1) needs about a minute there, and within 2 s must not stop on its first,
/// unsettled estimates (at 160x120 on PoCL the first estimate below 0.1 came at 25 spp, with
/// a true relMSE of 54). Stopping on the first estimate below the target fails this test.
#[test]
fn target_error_stops_when_the_error_is_reached() {
    let mut scene = scenes().remove(2).1;
    (scene.camera.width, scene.camera.height) = (64, 48);
    let (reference, reference_row) = {
        let (row, image) = render(&scene, 4096, 99, None);
        (Arc::new(image), row)
    };
    for (nee, target, seconds) in [(true, 3e-2, 30.0), (false, 0.1, 2.0)] {
        let options = RenderOptions {
            spp: None,
            time_limit: Some(std::time::Duration::from_secs_f64(seconds)),
            seed: 3,
            light_sampling: if nee {
                LightSampling::On
            } else {
                LightSampling::Off
            },
            target_error: Some(target),
            reference: Some(reference.clone()),
            ..RenderOptions::default()
        };
        let (_, stats) = common::render(&scene, options);
        let last = stats.report.last().expect("a report row");
        let measured = last.measured.expect("measured").relmse - reference_row.estimate.relmse;
        // The render's own rule (render/mod.rs `settled`): an estimate below the target when
        // the time ran out, not yet settled, is not a stop on the target. (Counted as one, a
        // pure path tracing render slowed by the tests beside it failed this test at 229 spp:
        // estimated relMSE 9.9e-2 as the 2 s ended.)
        let stopped_on_target = last.estimate.relmse <= target && settled(&stats.report);
        eprintln!(
            "NEE {nee}: {} spp, estimated relMSE {:.3e}, measured {measured:.3e} (target {target:e})",
            last.spp, last.estimate.relmse
        );
        assert!(
            stopped_on_target || !nee,
            "NEE {nee}: ran to {} spp without reaching the target",
            last.spp
        );
        assert!(
            !stopped_on_target || measured <= FACTOR * target,
            "NEE {nee}: stopped at {} spp, estimated relMSE {:.3e}, measured {measured:.3e}",
            last.spp,
            last.estimate.relmse
        );
    }
}

/// Light sampling and pure path tracing agree on every scene shipped in `scenes/` (rendered at
/// 16x12; the whole image's mean per channel, Z-test at 5 standard errors): whatever light
/// list, clipping or visible cap a scene's emitters get, the two estimate the same image.
#[test]
fn light_sampling_on_and_off_agree_on_every_shipped_scene() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "txt"))
        .collect();
    files.sort();
    assert!(files.len() >= 9, "scenes/ holds {} scenes", files.len());
    for file in files {
        let mut scene = Scene::load(&file).unwrap_or_else(|e| panic!("{e}"));
        (scene.camera.width, scene.camera.height) = (16, 12);
        let film = |light_sampling, spp, seed| {
            let options = RenderOptions {
                spp: Some(spp),
                seed,
                light_sampling,
                ..RenderOptions::default()
            };
            common::render(&scene, options).0
        };
        let (with, without) = (
            film(LightSampling::On, 2048, 11),
            film(LightSampling::Off, 8192, 12),
        );
        let (a, va) = common::image_mean(&with);
        let (b, vb) = common::image_mean(&without);
        for c in 0..3 {
            let z = (a[c] - b[c]) / (va[c] + vb[c]).sqrt();
            eprintln!(
                "{}: channel {c}: {:.5} against {:.5}, z {z:.2}",
                file.display(),
                a[c],
                b[c]
            );
            assert!(
                z.abs() < 5.0,
                "{}, channel {c}: {} with light sampling, {} without (z = {z:.2})",
                file.display(),
                a[c],
                b[c]
            );
        }
    }
}
