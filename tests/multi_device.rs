//! Several devices in one run (src/render/multi.rs, `clpt render --device all|A,B`): the test
//! device opened twice (PoCL's CPU where there is only one) renders the image of one device,
//! its film's sums within the 1e-6 of the compensated sums, with the same error estimate; the
//! trial runs once and every chunk runs its choice.

mod common;

use clpt::device::program::KernelSources;
use clpt::render::multi::{self, MultiProgress};
use clpt::render::strategy::{LightSampling, Roulette};
use clpt::render::{RenderOptions, Renderer};

fn scene() -> clpt::scene::Scene {
    let mut scene = clpt::scene::builtin::scene().unwrap();
    (scene.camera.width, scene.camera.height) = (24, 18);
    scene
}

#[test]
fn two_devices_render_the_image_of_one() {
    let options = RenderOptions {
        spp: Some(200),
        seed: 3,
        light_sampling: LightSampling::Off,
        roulette: Roulette::Threshold(0.3),
        ..RenderOptions::default()
    };
    let device = common::device();
    let mut one =
        Renderer::new(&device, &scene(), &KernelSources::Embedded, options.clone()).unwrap();
    let (_, stats) = one.render(&mut |_| {}).unwrap();
    let single = one.film_state().unwrap();
    let single_relmse = stats.report.last().unwrap().estimate.relmse;
    let devices = [common::device(), common::device()];
    let progress = std::sync::Mutex::new(Vec::new());
    let two = multi::render_on_devices(
        &devices,
        &scene(),
        &KernelSources::Embedded,
        &options,
        &|p: &MultiProgress| progress.lock().unwrap().push(p.spp_done),
    )
    .unwrap();
    let seen = progress.into_inner().unwrap();
    assert_eq!(seen.last(), Some(&200), "{seen:?}");
    assert_eq!(two.shares.iter().map(|s| s.samples).sum::<u32>(), 200);
    let (a, b) = (two.film.film(200), single.film(200));
    common::assert_close(
        a.sum.iter().flat_map(|p| &p[..3]),
        b.sum.iter().flat_map(|p| &p[..3]),
        1e-6,
        "the image of several devices against one",
    );
    let relmse = two.film.estimated_error(200).relmse;
    assert!(
        (relmse / single_relmse - 1.0).abs() < 1e-4,
        "{relmse} against {single_relmse}"
    );
}

#[test]
fn the_trial_runs_once_and_every_chunk_runs_its_choice() {
    let options = RenderOptions {
        spp: Some(256),
        light_sampling: LightSampling::Auto,
        roulette: Roulette::Auto,
        ..RenderOptions::default()
    };
    let devices = [common::device(), common::device()];
    let two = multi::render_on_devices(
        &devices,
        &scene(),
        &KernelSources::Embedded,
        &options,
        &|_: &MultiProgress| {},
    )
    .unwrap();
    assert!(two.choice.was_measured(), "auto: a trial");
    // The same samples with that strategy fixed, on one device.
    let mut fixed = options.clone();
    fixed.pin(two.choice.strategy());
    let device = common::device();
    let mut one = Renderer::new(&device, &scene(), &KernelSources::Embedded, fixed).unwrap();
    one.render(&mut |_| {}).unwrap();
    let (a, b) = (two.film.film(256), one.film_state().unwrap().film(256));
    common::assert_close(
        a.sum.iter().flat_map(|p| &p[..3]),
        b.sum.iter().flat_map(|p| &p[..3]),
        1e-6,
        "the image of several devices against one",
    );
}
