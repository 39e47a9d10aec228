//! Several devices in one run (src/render/multi.rs, `clpt render --device all|A,B`): the test
//! device opened twice (PoCL's CPU where there is only one) renders the image of one device,
//! its film's sums within the 1e-6 of the compensated sums, with the same error estimate; the
//! trial runs once and every chunk runs its choice.

mod common;

use clpt::device::program::KernelSources;
use clpt::render::multi::{self, Balance, MultiProgress};
use clpt::render::strategy::{LightSampling, Roulette};
use clpt::render::{RenderOptions, Renderer};

/// Chunks of one group, and every device joining at once: both devices share even these
/// small renders.
const EVERY_GROUP: Balance = Balance {
    share_fraction: 0.0,
    min_chunk_seconds: 0.0,
    join_seconds: 0.0,
};

fn scene() -> clpt::scene::Scene {
    let mut scene = clpt::scene::builtin::scene().unwrap();
    (scene.camera.width, scene.camera.height) = (24, 18);
    scene
}

/// The samples of the two-device render: enough that the second device joins before the first
/// has claimed them all (at 1024, 0.2 s of rendering on PoCL after the kernels got faster, one
/// device once took every chunk).
const SPP: u32 = 4096;

#[test]
fn two_devices_render_the_image_of_one() {
    let options = RenderOptions {
        spp: Some(SPP),
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
        EVERY_GROUP,
        &|p: &MultiProgress| progress.lock().unwrap().push(p.spp_done),
    )
    .unwrap();
    let seen = progress.into_inner().unwrap();
    assert_eq!(seen.last(), Some(&SPP), "{seen:?}");
    assert!(
        seen.windows(2).all(|w| w[0] <= w[1]),
        "progress after every pass, never back: {seen:?}"
    );
    assert_eq!(two.shares.iter().map(|s| s.samples).sum::<u32>(), SPP);
    assert!(
        two.shares.iter().all(|s| s.samples > 0),
        "both devices rendered: {:?}",
        two.shares
    );
    let (a, b) = (two.film.film(SPP), single.film(SPP));
    common::assert_close(
        a.sum.iter().flat_map(|p| &p[..3]),
        b.sum.iter().flat_map(|p| &p[..3]),
        1e-6,
        "the image of several devices against one",
    );
    let relmse = two.film.estimated_error(SPP).relmse;
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
        EVERY_GROUP,
        &|_: &MultiProgress| {},
    )
    .unwrap();
    assert!(two.choice.was_measured(), "auto: a trial");
    assert_eq!(two.shares.iter().map(|s| s.samples).sum::<u32>(), 256);
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

/// The queue sizes chunks to the claiming device: one group while its rate is unknown, then
/// half of its share of what is left at its rate; it hands out every sample once, in order.
#[test]
fn the_queue_sizes_chunks_to_each_device() {
    let mut queue = multi::Queue::new(100_000, 2, 1024, Balance::default());
    assert_eq!(queue.claim(1), Some((1024, 8)), "unmeasured: one group");
    queue.measured(0, 1024, 0.5); // 2048 samples a second
    // With less than JOIN_SECONDS of the fast device's work left, an unmeasured one stays out.
    let mut short = multi::Queue::new(20_000, 2, 1024, Balance::default());
    short.measured(0, 1024, 0.5);
    assert_eq!(
        short.claim(1),
        None,
        "18976 samples: 9.3 s of the fast device"
    );
    queue.measured(1, 8, 0.8); // 10 a second
    // 98968 left: the fast device's share is 98487, half of it 49243.5, in whole groups.
    assert_eq!(queue.claim(0), Some((1032, 49248)));
    // 49720 left: the slow one's share 241.6, half of it 120.8.
    assert_eq!(queue.claim(1), Some((50280, 128)));
    // Every sample once, in order, until the slow device would outlast the fast one.
    let mut next = 50408;
    let mut slow_stopped_with = None;
    loop {
        let fast = queue.claim(0);
        let slow = queue.claim(1);
        for claim in [fast, slow].into_iter().flatten() {
            assert_eq!(claim.0, next);
            next += claim.1;
        }
        if slow.is_none() && slow_stopped_with.is_none() {
            slow_stopped_with = Some(100_000 - next);
        }
        if fast.is_none() {
            break;
        }
    }
    assert_eq!(next, 100_000);
    // The slow device stops while what is left takes the fast one less than one of its
    // groups (0.8 s): under 0.8 * 2048 samples.
    let left = slow_stopped_with.expect("the slow device stopped before the end");
    assert!(left < 1639, "{left}");
}

/// Chunks shrink as the render goes on (guided self-scheduling), each device's in proportion
/// to its rate, so the devices end together; a few chunks cover the whole.
#[test]
fn chunks_shrink_towards_the_end_in_proportion_to_rates() {
    let guided = Balance {
        min_chunk_seconds: 0.0,
        ..Balance::default()
    };
    let mut queue = multi::Queue::new(1000, 2, 0, guided);
    queue.measured(0, 300, 1.0);
    queue.measured(1, 100, 1.0);
    // 1000 left: shares 750 and then (of 624) 156, halved, in whole groups.
    assert_eq!(queue.claim(0), Some((0, 376)));
    assert_eq!(queue.claim(1), Some((376, 80)));
    let (mut next, mut chunks) = (456, 2);
    let mut last = [376, 80];
    for device in [0, 1].into_iter().cycle() {
        let Some((first, n)) = queue.claim(device) else {
            if device == 0 {
                break;
            }
            continue;
        };
        assert_eq!(first, next);
        assert!(
            n % 8 == 0 && n <= last[device],
            "{n} after {}",
            last[device]
        );
        (next, last[device], chunks) = (next + n, n, chunks + 1);
    }
    assert_eq!(next, 1000);
    assert!(chunks <= 16, "{chunks} chunks");
}

/// A device that stops is not counted on: the last one still claiming takes all that is
/// left, in one chunk, however its rate compares with the stopped one's (rates of tiny chunks
/// are noisy).
#[test]
fn the_last_device_claiming_never_stops() {
    let mut queue = multi::Queue::new(1000, 2, 0, Balance::default());
    queue.measured(0, 8, 1.0);
    queue.measured(1, 8000, 1.0);
    assert_eq!(queue.claim(0), None, "the slow device stops");
    queue.measured(1, 8, 1.0); // now slower than device 0 was
    assert_eq!(
        queue.claim(1),
        Some((0, 1000)),
        "alone: all that is left at once"
    );
    assert_eq!(queue.claim(1), None);
    assert_eq!(queue.claim(0), None);
}

/// A chunk holds at least MIN_CHUNK_SECONDS of the device's work while its share is larger: a
/// fast device whose partner has not claimed yet renders in a few chunks, not log2(samples /
/// 8) of them.
#[test]
fn a_chunk_holds_at_least_two_seconds_of_work() {
    let mut queue = multi::Queue::new(16384, 2, 0, Balance::default());
    queue.measured(0, 1000, 1.0);
    let mut chunks = Vec::new();
    while let Some((_, n)) = queue.claim(0) {
        chunks.push(n);
    }
    assert_eq!(chunks, [8192, 4096, 2048, 2000, 48]);
}

/// Beside other devices a CPU device keeps a core of the host free for each of their drivers
/// (device::select_reserving: an OpenCL sub-device), and renders the same image with the
/// cores it has. On a GPU there is nothing to reserve: its compute units stay.
#[test]
fn a_cpu_beside_other_devices_leaves_the_host_a_core_for_each() {
    let whole = common::device();
    let index = whole.description.index.to_string();
    let reserved = clpt::device::select_reserving(Some(&index), 1).unwrap();
    let units = whole.description.compute_units;
    let expected = if whole.description.kind == "CPU" {
        units.saturating_sub(1).max(1)
    } else {
        units
    };
    assert_eq!(reserved.description.compute_units, expected);
    let options = RenderOptions {
        spp: Some(16),
        light_sampling: LightSampling::Off,
        roulette: Roulette::Threshold(0.3),
        ..RenderOptions::default()
    };
    let render = |device: &clpt::device::Device| {
        let mut r =
            Renderer::new(device, &scene(), &KernelSources::Embedded, options.clone()).unwrap();
        r.render(&mut |_| {}).unwrap().0.sum
    };
    assert!(render(&reserved) == render(&whole), "the same image");
}

/// Near u32::MAX samples a chunk rounded up to whole groups does not overflow, and a chunk
/// timed at (next to) zero seconds leaves the rate unmeasured instead of infinite.
#[test]
fn the_queue_holds_at_the_limits() {
    let mut queue = multi::Queue::new(u32::MAX, 2, 0, Balance::default());
    queue.measured(0, 8, 0.0);
    queue.measured(0, 8, 1e-320);
    assert_eq!(queue.claim(0), Some((0, 8)), "still unmeasured: one group");
    queue.measured(0, u32::MAX, 1e-9);
    let mut next = 8u64;
    while let Some((first, n)) = queue.claim(0) {
        assert_eq!(u64::from(first), next);
        next += u64::from(n);
    }
    assert_eq!(next, u64::from(u32::MAX));
    // The whole range at once: u32::MAX rounds up past u32 in whole groups.
    let mut whole = multi::Queue::new(u32::MAX, 1, 0, Balance::default());
    whole.measured(0, u32::MAX, 1e-9);
    assert_eq!(whole.claim(0), Some((0, u32::MAX)));
}
