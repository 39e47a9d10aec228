//! Several devices in one run (issue 13): the samples of every pixel split in chunks of whole
//! groups of eight, which the devices take from one shared queue as each finishes the last.
//! Each device traces its chunks into its own film, in increasing sample order; at the end
//! each film is read back once and added on the host
//! ([`super::merge::Accumulator`]). Reading a chunk's film back each time cost an
//! H200 12% of case0's time at 2560x1440 (BENCHMARKS.md).
//!
//! Devices differ in speed by two orders of magnitude (an H200 against PoCL on its host's
//! CPU), so a chunk is sized to the device that claims it, by guided self-scheduling
//! (Polychronopoulos and Kuck 1987) weighted by measured rates: before its first chunk a
//! device probes its rate ([`Renderer::probe_rate`]: one sample on every eighth row), then
//! claims [`Balance::share_fraction`] of its share of what is left at every device's rate, but
//! no less than [`Balance::min_chunk_seconds`] of its work; a device with no other still
//! claiming takes all that is left. Chunks start large and shrink towards the end, so that all
//! devices end together. A device whose smallest chunk (one group) would outlast the others'
//! time for everything left takes no more: a slow device helps a long render and never holds
//! up the end by more than its rate's error. One not measured at all (its probe failed)
//! joins only while the others have [`Balance::join_seconds`] of work left.
//!
//! Why the image does not depend on the split: every random number is a function of (seed,
//! pixel, sample, dimension), so a chunk traces the same paths on any device, and the sum of
//! the devices' compensated sums (in f64) is the sum of all samples to far below f32's
//! precision: the image is one device's render's to within the 1e-6 of the compensated sums
//! (tests/multi_device.rs; bit-identical when only one device rendered), and its error
//! estimate carries over as in a merge. Devices of other vendors round differently, so their
//! samples differ in the last bits. The strategy is chosen once: the first chunk runs on the
//! first device with the options' candidates (the trial, when there is one), and every later
//! chunk on every device runs what it chose.

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
    /// larger: each chunk ends on a pass shorter than the others and pays a queue's round
    /// trip, and halving alone would give a device about log2(samples / 8) chunks however
    /// short the render.
    pub min_chunk_seconds: f64,
    /// Seconds of work the measured devices must have left for a device not yet measured to
    /// take its first group (whose time is unknown until it has rendered it).
    pub join_seconds: f64,
}

/// The CLI's balance: half of a device's share but at least [`MIN_CHUNK_SECONDS`] of its
/// work, devices joining while [`JOIN_SECONDS`] are left.
impl Default for Balance {
    fn default() -> Balance {
        Balance {
            share_fraction: 0.5,
            min_chunk_seconds: MIN_CHUNK_SECONDS,
            join_seconds: JOIN_SECONDS,
        }
    }
}

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
    /// their measured rates) finish all that is left sooner than it would finish one group, or
    /// it is not measured yet and they have less than [`Balance::join_seconds`] of work left.
    /// What is left only shrinks, so a device told to stop is not needed later; the last one
    /// still claiming never stops before the end, and takes all that is left at once.
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
            Some(rate) => others > 0.0 && 8.0 / rate > f64::from(left) / others,
        };
        if stop {
            self.active[device] = false;
            return None;
        }
        let alone = (0..self.active.len()).all(|d| d == device || !self.active[d]);
        let n = match self.rates[device] {
            // Nothing to balance against: everything left (progress comes from the passes).
            _ if alone => left,
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
    let mut first = Renderer::new(first_device, scene, sources, options.clone())?;
    let shared = Shared {
        total,
        first_sample: options.first_sample,
        start,
        queue: Mutex::new(Queue::new(total, devices.len(), first_chunk, balance)),
        accumulator: Mutex::new(Accumulator::new(first.width(), first.height())),
        shares: Mutex::new(
            devices
                .iter()
                .map(|d| Share {
                    device: d.description.name.clone(),
                    ..Share::default()
                })
                .collect(),
        ),
        done: AtomicU32::new(0),
        in_flight: Mutex::new(vec![0; devices.len()]),
        failed: AtomicBool::new(false),
        error: Mutex::new(None),
        on_progress,
    };
    // The first chunk chooses the strategy; every other device renders with it.
    let t0 = Instant::now();
    let choice = first.render_chunk(options.first_sample, first_chunk, &mut |n| {
        shared.report(0, n)
    })?;
    shared.finish(0, first_chunk, t0.elapsed().as_secs_f64());
    let strategy = choice.strategy();
    first.fix_strategy(strategy)?;
    let mut pinned = options.clone();
    pinned.pin(strategy);
    std::thread::scope(|scope| {
        for (i, device) in devices.iter().enumerate().skip(1) {
            let (shared, pinned) = (&shared, &pinned);
            scope.spawn(move || shared.join(i, device, scene, sources, pinned));
        }
        shared.run(0, first, true);
    });
    shared.into_render(choice)
}

/// What the devices of one render share while they render: the queue of chunks, the sum of
/// their films, each device's share and the first error, and the progress they report.
struct Shared<'a> {
    total: u32,
    first_sample: u32,
    start: Instant,
    queue: Mutex<Queue>,
    accumulator: Mutex<Accumulator>,
    shares: Mutex<Vec<Share>>,
    /// Samples per pixel of the chunks done.
    done: AtomicU32,
    /// Samples per pixel of each device's chunk in flight, after its last pass.
    in_flight: Mutex<Vec<u32>>,
    failed: AtomicBool,
    error: Mutex<Option<Error>>,
    on_progress: &'a (dyn Fn(&MultiProgress) + Sync),
}

impl Shared<'_> {
    /// After every pass the progress callback sees every device's share, chunks in flight
    /// counted as far as they have come (`chunk_done` samples of `device`'s).
    fn report(&self, device: usize, chunk_done: u32) {
        let mut in_flight = self.in_flight.lock().expect("no thread panicked");
        in_flight[device] = chunk_done;
        let mut shares = self.shares.lock().expect("no thread panicked").clone();
        for (share, &n) in shares.iter_mut().zip(in_flight.iter()) {
            share.samples += n;
        }
        (self.on_progress)(&MultiProgress {
            spp_done: self.done.load(Ordering::Relaxed) + in_flight.iter().sum::<u32>(),
            spp_total: self.total,
            elapsed: self.start.elapsed(),
            shares: &shares,
        });
    }

    /// `device` finished a chunk of `samples` in `seconds`: the queue learns its rate, the
    /// chunk leaves the in-flight count as it joins the done one.
    fn finish(&self, device: usize, samples: u32, seconds: f64) {
        (self.queue.lock().expect("no thread panicked")).measured(device, samples, seconds);
        {
            let mut in_flight = self.in_flight.lock().expect("no thread panicked");
            in_flight[device] = 0;
            let mut shares = self.shares.lock().expect("no thread panicked");
            shares[device].samples += samples;
            shares[device].seconds += seconds;
            self.done.fetch_add(samples, Ordering::Relaxed);
        }
        self.report(device, 0);
    }

    /// The render's first error; every device stops claiming.
    fn fail(&self, e: Error) {
        self.failed.store(true, Ordering::Relaxed);
        self.error
            .lock()
            .expect("no thread panicked")
            .get_or_insert(e);
    }

    /// Device `device` after the first: its renderer with the chosen strategy (`pinned`),
    /// whose probe measures the device's rate before it claims, so that a slow one stays out
    /// without holding up the end with a group of eight samples.
    fn join(
        &self,
        device: usize,
        on: &Device,
        scene: &Scene,
        sources: &KernelSources,
        pinned: &RenderOptions,
    ) {
        let probed = Renderer::new(on, scene, sources, pinned.clone()).and_then(|mut r| {
            let rate = r.probe_rate()?;
            self.queue
                .lock()
                .expect("no thread panicked")
                .probed(device, rate);
            Ok(r)
        });
        match probed {
            Ok(r) => self.run(device, r, false),
            Err(e) => self.fail(e),
        }
    }

    /// `device` renders chunks until the queue is empty or a device failed.
    fn run(&self, device: usize, mut renderer: Renderer, rendered: bool) {
        if let Err(e) = self.work(device, &mut renderer, rendered) {
            self.fail(e);
        }
    }

    /// A device renders its chunks into its own film, read back and added once at the end.
    fn work(&self, device: usize, renderer: &mut Renderer, mut rendered: bool) -> Result<()> {
        loop {
            let claim = self.queue.lock().expect("no thread panicked").claim(device);
            let Some((a, n)) = claim.filter(|_| !self.failed.load(Ordering::Relaxed)) else {
                break;
            };
            let t0 = Instant::now();
            renderer.render_chunk(self.first_sample + a, n, &mut |k| self.report(device, k))?;
            self.finish(device, n, t0.elapsed().as_secs_f64());
            rendered = true;
        }
        if rendered && !self.failed.load(Ordering::Relaxed) {
            let state = renderer.film_state()?;
            self.accumulator
                .lock()
                .expect("no thread panicked")
                .add(&state);
        }
        Ok(())
    }

    /// The render: the first error if any; else the summed film, unless a sample is missing.
    fn into_render(self, choice: Choice) -> Result<MultiRender> {
        if let Some(e) = self.error.into_inner().expect("no thread panicked") {
            return Err(e);
        }
        // The queue hands every sample out once and its last claimant never stops early: say
        // so rather than write an image of fewer samples than asked.
        let rendered = self.done.into_inner();
        if rendered != self.total {
            return Err(Error::Invalid(format!(
                "several devices rendered {rendered} of {} samples per pixel (a bug)",
                self.total
            )));
        }
        Ok(MultiRender {
            film: self
                .accumulator
                .into_inner()
                .expect("no thread panicked")
                .film(),
            choice,
            shares: self.shares.into_inner().expect("no thread panicked"),
            elapsed: self.start.elapsed(),
        })
    }
}
