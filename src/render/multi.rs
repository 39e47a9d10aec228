//! Several devices in one run (issue 13): the samples of every pixel split in chunks of whole
//! groups of eight, which the devices take from one shared queue as each finishes the last;
//! each chunk is rendered into a cleared film and added on the host
//! ([`Accumulator`](super::merge::Accumulator)).
//!
//! Devices differ in speed by two orders of magnitude (an H200 against PoCL on its host's
//! CPU), so a chunk is sized to the device that claims it, by guided self-scheduling
//! (Polychronopoulos and Kuck 1987) weighted by measured rates: one group while its rate is
//! unknown, then [`Balance::share_fraction`] of its share of what is left at every device's
//! rate, but no less than [`Balance::min_chunk_seconds`] of its work. Chunks start large (a
//! chunk's fixed cost, clearing and reading back the film and adding it on the host, stays
//! small: chunks of one second of work cost an H200 19% on smallpt and more on larger films)
//! and shrink towards the end, so that all devices end together. A device whose smallest chunk
//! would outlast the others' time for everything left takes no more, and a device not yet
//! measured joins only while the others have [`Balance::join_seconds`] of work left: a slow
//! device helps a long render, and delays one only where its first group takes longer than
//! that.
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

/// Samples per pixel of the first chunk, which runs the trial on the first device: about an
/// eighth of each device's share of `total`, in whole groups of eight.
pub fn chunk_samples(total: u32, devices: usize) -> u32 {
    let share = total / (devices.max(1) as u32 * 8);
    share.div_ceil(8).max(1) * 8
}

/// How the queue sizes chunks.
#[derive(Clone, Copy, Debug)]
pub struct Balance {
    /// The share of what is left that a measured device claims, of its part at its rate:
    /// less than 1 leaves room to balance against rates measured again later; 0 makes every
    /// chunk one group.
    pub share_fraction: f64,
    /// The least seconds of a measured device's work a chunk holds while its share is
    /// larger: each chunk costs a probe pass, a read-back of the whole film and its sum on
    /// the host, and halving alone would give a lone GPU about log2(samples / 8) chunks
    /// however short the render (one-second chunks cost an H200 19% on smallpt).
    pub min_chunk_seconds: f64,
    /// Seconds of work the measured devices must have left for a device not yet measured to
    /// take its first group (whose time is unknown until it has rendered it).
    pub join_seconds: f64,
    /// A device whose rate is below this share of all claiming devices' rates stops: a CPU
    /// device beside a GPU loads the host that the GPU's driver runs on. On the H200 machine
    /// (BENCHMARKS.md) PoCL on 15 of its 16 cores rendered 1% of case0's samples and slowed the
    /// GPU by 12%.
    pub min_share: f64,
}

/// The CLI's balance: half of a device's share but at least [`MIN_CHUNK_SECONDS`] of its
/// work, devices joining while [`JOIN_SECONDS`] are left.
impl Default for Balance {
    fn default() -> Balance {
        Balance {
            share_fraction: 0.5,
            min_chunk_seconds: MIN_CHUNK_SECONDS,
            join_seconds: JOIN_SECONDS,
            min_share: MIN_SHARE,
        }
    }
}

/// The default [`Balance::min_share`].
pub const MIN_SHARE: f64 = 0.1;

/// The default [`Balance::min_chunk_seconds`].
pub const MIN_CHUNK_SECONDS: f64 = 2.0;

/// The default [`Balance::join_seconds`].
pub const JOIN_SECONDS: f64 = 10.0;

/// The queue the devices take their chunks from: samples `[next, total)` are left.
#[derive(Debug)]
pub struct Queue {
    next: u32,
    total: u32,
    balance: Balance,
    /// Each device's samples per second in its last chunk, once it has rendered one.
    rates: Vec<Option<f64>>,
    /// Whether each device may still claim: one that was told to stop is not counted on.
    active: Vec<bool>,
}

impl Queue {
    /// `total` samples for `devices` devices, the first `taken` of them already claimed.
    pub fn new(total: u32, devices: usize, taken: u32, balance: Balance) -> Queue {
        Queue {
            next: taken.min(total),
            total,
            balance,
            rates: vec![None; devices],
            active: vec![true; devices],
        }
    }

    /// Records that `device` rendered `samples` in `seconds`.
    pub fn measured(&mut self, device: usize, samples: u32, seconds: f64) {
        if samples > 0 {
            self.probed(device, f64::from(samples) / seconds);
        }
    }

    /// Records `device`'s rate in samples per second, as its probe measured it before its
    /// first chunk ([`Renderer::probe_rate`]) or a chunk did.
    pub fn probed(&mut self, device: usize, rate: f64) {
        if rate.is_finite() && rate > 0.0 {
            self.rates[device] = Some(rate);
        }
    }

    /// The next chunk for `device`, as (first sample relative to the render's start, samples),
    /// or None when it should stop: nothing is left, the other devices still claiming (at
    /// their measured rates) finish all that is left sooner than it would finish one group, its
    /// rate is under [`Balance::min_share`] of theirs and its own, or it is not measured yet and
    /// they have less than [`Balance::join_seconds`] of work left.
    /// What is left only shrinks, so a device told to stop is not needed later; the last one
    /// still claiming never stops before the end.
    pub fn claim(&mut self, device: usize) -> Option<(u32, u32)> {
        let left = self.total - self.next;
        if left == 0 || !self.active[device] {
            return None;
        }
        let others: f64 = (0..self.rates.len())
            .filter(|&d| d != device && self.active[d])
            .filter_map(|d| self.rates[d])
            .sum();
        let stop = match self.rates[device] {
            None => others > 0.0 && f64::from(left) / others < self.balance.join_seconds,
            Some(rate) => {
                others > 0.0
                    && (8.0 / rate > f64::from(left) / others
                        || rate < self.balance.min_share * (rate + others))
            }
        };
        if stop {
            self.active[device] = false;
            return None;
        }
        let n = match self.rates[device] {
            None => 8,
            Some(rate) => {
                let share = f64::from(left) * rate / (rate + others);
                let n = (share * self.balance.share_fraction)
                    .max(rate * self.balance.min_chunk_seconds)
                    .min(share);
                // Whole groups of eight; f64 to u32 saturates.
                ((n / 8.0).ceil().max(1.0) as u32).saturating_mul(8)
            }
        };
        let n = n.min(left);
        let first = self.next;
        self.next += n;
        Some((first, n))
    }
}

/// Renders `options.spp` samples per pixel of `scene` (from `options.first_sample`) on every
/// device of `devices`, chunks sized by `balance`, calling `on_progress` after every chunk.
pub fn render_on_devices(
    devices: &[Device],
    scene: &Scene,
    sources: &KernelSources,
    options: &RenderOptions,
    balance: Balance,
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
    let first_chunk = chunk_samples(total, devices.len()).min(total);
    let queue = Mutex::new(Queue::new(total, devices.len(), first_chunk, balance));
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
        (queue.lock().expect("no thread panicked")).measured(device, samples, seconds);
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
    first.set_range(options.first_sample, first_chunk)?;
    let t0 = Instant::now();
    let (_, stats) = first.render(&mut |_| {})?;
    finish(
        0,
        &chunk_film(&mut first)?,
        first_chunk,
        t0.elapsed().as_secs_f64(),
    );
    let strategy = stats.choice.strategy();
    first.fix_strategy(strategy)?;
    let failed = AtomicBool::new(false);
    let error: Mutex<Option<Error>> = Mutex::new(None);
    let work = |device: usize, renderer: &mut Renderer| -> Result<()> {
        loop {
            let claim = queue.lock().expect("no thread panicked").claim(device);
            let Some((a, n)) = claim.filter(|_| !failed.load(Ordering::Relaxed)) else {
                return Ok(());
            };
            renderer.set_range(options.first_sample + a, n)?;
            let t0 = Instant::now();
            renderer.render(&mut |_| {})?;
            finish(
                device,
                &chunk_film(renderer)?,
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
            let (run, error, failed, queue) = (&run, &error, &failed, &queue);
            scope.spawn(move || {
                let mut pinned = options.clone();
                pinned.pin(strategy);
                // A probe measures the device's rate before it claims: a slow one stays
                // out without holding up the end with a group of eight samples.
                let probed = Renderer::new(device, scene, sources, pinned).and_then(|mut r| {
                    let rate = r.probe_rate()?;
                    queue.lock().expect("no thread panicked").probed(i, rate);
                    Ok(r)
                });
                match probed {
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
    // The queue hands every sample out once and its last claimant never stops early: say so
    // rather than write an image of fewer samples than asked.
    let rendered = done.into_inner();
    if rendered != total {
        return Err(Error::Invalid(format!(
            "several devices rendered {rendered} of {total} samples per pixel (a bug)"
        )));
    }
    Ok(MultiRender {
        film: accumulator.into_inner().expect("no thread panicked").film(),
        choice: stats.choice,
        shares: shares.into_inner().expect("no thread panicked"),
        elapsed: start.elapsed(),
    })
}

/// The film of the chunk `renderer` has just rendered, as its render read it back.
fn chunk_film(renderer: &mut Renderer) -> Result<FilmState> {
    match renderer.take_film_state() {
        Some(state) => Ok(state),
        None => renderer.film_state(),
    }
}
