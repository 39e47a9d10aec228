//! Several devices in one run (issue 13): the samples of every pixel split in chunks of whole
//! groups of eight, which the devices take from one shared queue as each finishes the last;
//! each chunk is rendered into a cleared film and added on the host
//! ([`Accumulator`](super::merge::Accumulator)).
//!
//! Why the image does not depend on the split: every random number is a function of (seed,
//! pixel, sample, dimension), so a chunk traces the same paths on any device, and the sum of
//! the chunks' compensated sums (in f64) is the sum of all samples to far below f32's
//! precision: the image is one device's render's to within the 1e-6 of the compensated sums
//! (tests/multi_device.rs), and its error estimate carries over as in a merge. The strategy is
//! chosen once: the first chunk runs on the first device with the options' candidates (the
//! trial, when there is one), and every later chunk on every device runs what it chose.

use super::film_file::FilmState;
use super::merge::Accumulator;
use super::strategy::Choice;
use super::{RenderOptions, Renderer};
use crate::device::Device;
use crate::device::program::KernelSources;
use crate::error::{Error, Result};
use crate::scene::Scene;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// What one device rendered.
#[derive(Clone, Debug, Default)]
pub struct Share {
    pub device: String,
    /// Samples per pixel it rendered.
    pub samples: u32,
    /// Seconds it spent rendering them.
    pub seconds: f64,
}

/// The state of a run on several devices, after each chunk.
pub struct MultiProgress<'a> {
    pub spp_done: u32,
    pub spp_total: u32,
    pub elapsed: Duration,
    pub shares: &'a [Share],
}

/// A finished run on several devices.
pub struct MultiRender {
    /// All samples' film.
    pub film: FilmState,
    /// The strategy, as the first chunk's trial chose it.
    pub choice: Choice,
    pub shares: Vec<Share>,
    pub elapsed: Duration,
}

/// Samples per pixel of a chunk: about an eighth of each device's share of `total`, in whole
/// groups of eight, so the queue balances devices of different speeds while each chunk stays
/// long enough to keep a device busy.
pub fn chunk_samples(total: u32, devices: usize) -> u32 {
    let share = total / (devices.max(1) as u32 * 8);
    share.div_ceil(8).max(1) * 8
}

/// Renders `options.spp` samples per pixel of `scene` (from `options.first_sample`) on every
/// device of `devices`, calling `on_progress` after every chunk.
pub fn render_on_devices(
    devices: &[Device],
    scene: &Scene,
    sources: &KernelSources,
    options: &RenderOptions,
    on_progress: &(dyn Fn(&MultiProgress) + Sync),
) -> Result<MultiRender> {
    let Some(total) = options.spp else {
        return Err(Error::Invalid(
            "several devices render a sample count (--spp), not a time limit or a target error"
                .into(),
        ));
    };
    let Some(first_device) = devices.first() else {
        return Err(Error::Invalid("no device to render on".into()));
    };
    let start = Instant::now();
    let chunk = chunk_samples(total, devices.len());
    let chunks = total.div_ceil(chunk);
    let range = |c: u32| {
        let a = c * chunk;
        (options.first_sample + a, (total - a).min(chunk))
    };
    let mut first = Renderer::new(first_device, scene, sources, options.clone())?;
    let accumulator = Mutex::new(Accumulator::new(first.width(), first.height()));
    let shares = Mutex::new(
        devices
            .iter()
            .map(|d| Share {
                device: d.description.name.clone(),
                ..Share::default()
            })
            .collect::<Vec<_>>(),
    );
    let done = AtomicU32::new(0);
    // A finished chunk goes into the film; the progress callback sees every device's share.
    let finish = |device: usize, state: &FilmState, samples: u32, seconds: f64| {
        accumulator.lock().expect("no thread panicked").add(state);
        let mut shares = shares.lock().expect("no thread panicked");
        shares[device].samples += samples;
        shares[device].seconds += seconds;
        let spp_done = done.fetch_add(samples, Ordering::Relaxed) + samples;
        on_progress(&MultiProgress {
            spp_done,
            spp_total: total,
            elapsed: start.elapsed(),
            shares: &shares,
        });
    };
    // The first chunk chooses the strategy.
    let (a, n) = range(0);
    first.set_range(a, n)?;
    let t0 = Instant::now();
    let (_, stats) = first.render(&mut |_| {})?;
    finish(0, &first.film_state()?, n, t0.elapsed().as_secs_f64());
    let strategy = stats.choice.strategy();
    first.fix_strategy(strategy)?;
    let next = AtomicU32::new(1);
    let failed = AtomicBool::new(false);
    let error: Mutex<Option<Error>> = Mutex::new(None);
    let work = |device: usize, renderer: &mut Renderer| -> Result<()> {
        loop {
            let c = next.fetch_add(1, Ordering::Relaxed);
            if c >= chunks || failed.load(Ordering::Relaxed) {
                return Ok(());
            }
            let (a, n) = range(c);
            renderer.set_range(a, n)?;
            let t0 = Instant::now();
            renderer.render(&mut |_| {})?;
            finish(
                device,
                &renderer.film_state()?,
                n,
                t0.elapsed().as_secs_f64(),
            );
        }
    };
    let run = |device: usize, mut renderer: Renderer| {
        if let Err(e) = work(device, &mut renderer) {
            failed.store(true, Ordering::Relaxed);
            error.lock().expect("no thread panicked").get_or_insert(e);
        }
    };
    std::thread::scope(|scope| {
        for (i, device) in devices.iter().enumerate().skip(1) {
            let (run, error, failed) = (&run, &error, &failed);
            scope.spawn(move || {
                let mut pinned = options.clone();
                pinned.pin(strategy);
                match Renderer::new(device, scene, sources, pinned) {
                    Ok(r) => run(i, r),
                    Err(e) => {
                        failed.store(true, Ordering::Relaxed);
                        error.lock().expect("no thread panicked").get_or_insert(e);
                    }
                }
            });
        }
        run(0, first);
    });
    if let Some(e) = error.into_inner().expect("no thread panicked") {
        return Err(e);
    }
    Ok(MultiRender {
        film: accumulator.into_inner().expect("no thread panicked").film(),
        choice: stats.choice,
        shares: shares.into_inner().expect("no thread panicked"),
        elapsed: start.elapsed(),
    })
}
