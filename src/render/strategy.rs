//! Which estimator a render runs, chosen by measured efficiency: light sampling on or off
//! (kernels/nee.h) and Russian roulette's threshold (kernels/pathtracer.cl), each fixed by the
//! user or left to `auto`.
//!
//! Why measure: no setting wins everywhere. On the H200 at the original's sizes, light sampling
//! doubles the time of the ceiling-lit showcases for the same error, yet reaches a small light's
//! error 17 times sooner; roulette below a throughput of 0.5 is the most efficient in rooms whose
//! albedo-1 lights keep paths bouncing, while in the original's closed rooms with black
//! emitters, where paths end anyway, roulette only adds variance and 0.3 wins (pbrt-v4's 1
//! reaches the same error 2.4 times later there, and was nowhere the best). BENCHMARKS.md has
//! the figures.
//!
//! How: before the render, every candidate renders the same samples of the same set of rows.
//! Each pixel's sample variance over the common denominator (the candidates' mean value
//! squared, plus ε, as relMSE has) is the relative variance of one sample; times the measured
//! seconds per sample it is relMSE × seconds, the figure `clpt plot` compares, whose lower
//! value reaches any error sooner.
//! - A short render's trial is one round ([`trial_plan`]: `TRIAL_SHARE` of its samples,
//!   on rows thinned out as far as that needs).
//! - A longer one scouts first ([`scout_plan`]: [`TRIAL_SPP`] samples on every fourth row's
//!   worth, on a GPU on about `GPU_SCOUT_PIXELS` in one launch ([`scouting`]), within
//!   `SCOUT_SHARE` of its samples) and drops the candidates that are clearly worse
//!   ([`Choice::survivors`]); only the rest render the full round ([`full_round_plan`]), sized
//!   to `FULL_ROUND_SHARE` of the render's time at the best one's speed, and on a GPU timed
//!   by the scouts where it is narrower ([`times_by_scouts`]). Light sampling can double a
//!   path's price, and a trial of fixed samples per candidate then cost 6-12% of a render on
//!   the H200; this one 1-2% of the showcases'.
//! - A render limited by time alone knows its samples only once a round has timed the
//!   candidates: it scouts at the device's floor of paths ([`time_limited_scout_plan`]) and
//!   sizes the full round by the samples its time left affords at the best one's speed ([`samples_within`]).
//! - Each round spends its budget on more samples rather than on more than about
//!   `TRIAL_PIXELS` pixels ([`plan_on_rows`]): more pixels add little precision. A GPU's
//!   scouts are the exception: a GPU keeps a work-item a pixel, and a lean program idles in a
//!   narrow launch, its seconds a path read high.
//! - The statistics ([`choose`] over [`TrialSums`]) are computed on the device
//!   (render/trial.rs): a read-back of the trial's rows and a host pass over them had cost a
//!   fast scene more than its candidates' renders.
//! - A full round takes at least `LEAST_FULL_ROUND_SPP` samples a pixel: quasi-random
//!   samples lower the relative variance by different shares for different settings, and a
//!   few samples read settings tied that the render has 12% apart. A CPU's first round takes
//!   those samples on a lattice of rows and columns ([`with_least_samples`]), its short
//!   renders affording no second round. The figures are the round's own, not extrapolated to
//!   the render's samples (why: `LEAST_FULL_ROUND_SPP`).
//!
//! The render then goes on with the winner from sample 0, or, when the winner rendered the
//! full round last and on every row, from the samples that round left in the film: either way
//! its image is exactly the one that setting gives when fixed by hand (tests/strategy.rs).
//! Sample variance is unbiased, so a strategy whose rare paths did not show up in a trial is
//! only under-read by chance, not by rule; the common denominator keeps a noisy strategy's
//! dark pixels from flattering it.

use crate::error::Result as ClptResult;
use std::fmt;

/// Samples per pixel each candidate renders in the trial: two groups of four, one from each of
/// the pixel's two independent quasi-random sequences (kernels/rng.h). The difference of the
/// two groups' sums measures the variance of the estimate the render makes; the plain sample
/// variance would count the spread within the pixel that the quasi-random samples integrate
/// away, and blur the contrast between candidates (on smallpt it read pure path tracing's
/// variance 1.3 times light sampling's where the render measures 1.9). Quasi-random samples
/// gain more with more samples, and by different shares for different settings, so a round
/// that affords it measures at more (`LEAST_FULL_ROUND_SPP`).
pub const TRIAL_SPP: u32 = 8;

/// The most samples per pixel a trial takes, however long the render.
const MAX_TRIAL_SPP: u32 = 64;

/// Roulette thresholds `auto` tries: 0.5 and 0.3, which let paths run on until their weight
/// has fallen below them (see kernels/pathtracer.cl). Measured at the original's samples
/// against 1 (pbrt-v4's throughput roulette) and 0.2 (BENCHMARKS.md): on the H200 and on PoCL
/// one of these two was the best on every scene; where 1 had been chosen (the lit rooms), 0.5
/// was 0.8 to 29% ahead of it on the H200 and 12 to 38% on PoCL, and 0.2 lost 2.6 to 3.9% to
/// 0.3 on the H200's showcases. Two close candidates also cost less when the trial errs between them.
pub const RR_THRESHOLDS: [f32; 2] = [0.5, 0.3];

/// A render given a sample count affords each candidate's first round this share of those
/// samples, divided among the candidates (only short renders' trials are that small: longer
/// ones scout first, [`scout_plan`]).
const TRIAL_SHARE: f64 = 0.06;

/// The full round after scouting takes about this share of the render's time
/// ([`full_round_plan`]). On the H200 (BENCHMARKS.md) 0.03 cost the short scenes 1.1 to 1.5
/// points more than 0.0075 behind the best fixed setting, and chose the same everywhere.
const FULL_ROUND_SHARE: f64 = 0.0075;

/// The scouting round takes at most this share of a render's samples, all candidates together
/// ([`scout_plan`]): every fourth row cost the goblet (256 samples, light sampling useless
/// and dear) 5.7% of its time.
const SCOUT_SHARE: f64 = 0.01;

/// ...but each candidate traces at least this many paths in it (or every row): fewer would
/// time a GPU's launch latency instead of the candidate (an H200 traces 2^20 of the goblet's
/// paths in about 20 ms, against its 0.1 ms latency), and leave most of its 270,336 resident
/// work-items idle.
const MIN_SCOUT_PATHS: f64 = (1 << 20) as f64;

/// The floor on a CPU device ([`min_scout_paths`]): a launch's latency (about 0.1 ms on PoCL)
/// needs no more than a few thousand paths, and more bought no better choices. PoCL on 2
/// cores, smallpt, meshes (160x120, 256 samples) and case0 (160x90, 128), three seeds each,
/// timed in parts ([`timing_parts`]): 2^13 paths chose a setting 8 to 23% worse than the best
/// 3 times in 9, 2^15 5 times (trials of 0.05 to 0.10 s against 0.11 to 0.21 s). Where they
/// err, the settings are close in the trial's 8 samples a pixel and apart in the render's
/// 256 (BENCHMARKS.md): more paths of 8 samples do not tell them apart.
const MIN_SCOUT_PATHS_CPU: f64 = (1 << 13) as f64;

/// A full round runs only where it measures each survivor on at least this many times the
/// scouting round's samples ([`full_round_plan`]): one barely larger repeats the scouts' noise
/// (its standard errors 10% smaller for 1.2 times the paths) at the price of every survivor's
/// launches again. Or where it takes [`LEAST_FULL_ROUND_SPP`] samples a pixel (fewer than the
/// render) and the scouts fewer: a GPU's scouts of [`TRIAL_SPP`] samples on 2^19 pixels (meshes, 1280x720: 4 samples'
/// worth each, against a full round's 6) read light sampling off's relative variance 1.34
/// times its render's and on's 1.15 times, and chose on, 8% behind.
const FULL_ROUND_GAIN: f64 = 2.0;

/// The samples a pixel of a full round, at the least ([`full_round_plan`]). A candidate's
/// relative variance of one sample falls with the samples a pixel (the quasi-random samples
/// gain more with more of them, and a ratio over a denominator of n samples carries a bias of
/// O(1/n)), by different shares for different settings: with few samples the trial can read
/// two settings tied where the render has one well ahead (PoCL, meshes at 160x120: with light
/// sampling off, roulette below 0.3, 0.48, 0.41 and 0.35 at 8, 32 and 256 samples, with it on
/// 0.30, 0.27 and 0.245; BENCHMARKS.md): the first 12% ahead at 256 where the two tie at 8,
/// 5% at 32.
///
/// The figures are those of the round's own samples, not extrapolated to the render's: a line
/// a + b n^-p through those at 8 and 32 samples (p = 1, as clpt had it) chose as they do on the
/// H200 (twelve scenes, four seeds, the same choices in all 48 trials; p = 0.5 worse on room)
/// and worse on PoCL (twelve scenes, 24 or 48 trials each, the same truth: 2.4% behind the
/// best fixed setting on average against 1.9%, case2 6.8% against 2.7%). The step from 8 to
/// 32 samples is mostly noise there (one to three of its standard deviations over seeds), and
/// where it is not the render's variance does not follow it: case2's light sampling on fell
/// 27% and off 16% from 8 to 32 in the trial, in the render both about 25%, and the two kept
/// their ratio to 512 samples (0.69 to 0.71; BENCHMARKS.md).
const LEAST_FULL_ROUND_SPP: u32 = 4 * TRIAL_SPP;

/// The pixels a GPU's full round keeps, at the least, where taking [`LEAST_FULL_ROUND_SPP`]
/// thins them out ([`full_round_least_pixels`]).
const GPU_FULL_ROUND_PIXELS: u64 = 1 << 16;

/// The pixels a full round on a device of `kind` keeps at the least when it raises its samples
/// to `LEAST_FULL_ROUND_SPP` ([`with_least_samples_on`]): none on a CPU, where fewer pixels
/// at the same cost cost nothing; `GPU_FULL_ROUND_PIXELS` on a GPU. A GPU's seconds a path
/// depend on how full its launches keep it, and a launch of a few thousand work-items takes
/// as long as its slowest lanes: H200, ceiling_room at 320x240 (4096 samples), 10 seeds, a
/// full round of 32 samples on 19,200 pixels read roulette below 0.3 at 1.16 times 0.5's
/// seconds a path, where one of 8 samples on all 76,800 read 1.08 to 1.12 and the renders
/// 1.08, and chose 0.5, 12% behind, in 2 or 3 of the 10. Its launches being mostly idle, 32
/// samples on all 76,800 pixels cost it about as long.
pub fn full_round_least_pixels(kind: &str) -> u64 {
    if kind == "CPU" {
        0
    } else {
        GPU_FULL_ROUND_PIXELS
    }
}

/// The samples a pixel of a CPU device's first round too, at the least
/// ([`least_trial_samples`]). Its launches cost no latency worth a mention (about 0.1 ms on
/// PoCL), so fewer pixels with more samples cost it nothing, while a CPU's short renders
/// afford no second round (BENCHMARKS.md).
const LEAST_TRIAL_SPP_CPU: u32 = LEAST_FULL_ROUND_SPP;

/// The least samples a pixel of a trial round on a device of `kind` (an OpenCL device type as
/// `clpt devices` lists it: "CPU", "GPU", ...): on a GPU [`TRIAL_SPP`], which keeps a round's
/// pixels enough to fill it; on a CPU `LEAST_TRIAL_SPP_CPU`.
pub fn least_trial_samples(kind: &str) -> u32 {
    if kind == "CPU" {
        LEAST_TRIAL_SPP_CPU
    } else {
        TRIAL_SPP
    }
}

/// `plan` with at least `least` samples a pixel (a multiple of [`TRIAL_SPP`], at most
/// `MAX_TRIAL_SPP`) at about the same cost on an image of `width` x `height`: its pixels
/// thinned out by the same factor f, in columns as far as the image is wide and in rows by the
/// rest, so that every row of the plan stays (a CPU's scouts at 32 samples on every 52nd row
/// of 160x120 kept 2 rows, which read light sampling's variance a quarter above the image's);
/// more than a work-group's rows in whole groups (`rows_in_whole_groups`); never fewer than
/// one row or column.
pub fn with_least_samples(plan: TrialPlan, least: u32, size: (u32, u32)) -> TrialPlan {
    with_least_samples_on(plan, least, size, 0)
}

/// [`with_least_samples`], thinning the plan's pixels no further than to `least_pixels` (where
/// it has more; none where it has fewer): the samples then cost more than the plan's.
pub fn with_least_samples_on(
    plan: TrialPlan,
    least: u32,
    (width, height): (u32, u32),
    least_pixels: u64,
) -> TrialPlan {
    if plan.samples >= least {
        return plan;
    }
    // How far the pixels may thin out: without a floor, as far as the samples ask.
    let room = match least_pixels {
        0 => f64::INFINITY,
        floor => (plan.pixels((width, height)) as f64 / floor as f64).max(1.0),
    };
    let factor = (f64::from(least) / f64::from(plan.samples.max(1))).min(room);
    let width_left = f64::from(width.max(1)) / f64::from(plan.col_step.max(1));
    let columns = factor.min(width_left).floor().max(1.0);
    let rows = factor / columns;
    let step = |step: u32, by: f64, most: u32| {
        (f64::from(step) * by)
            .round()
            .clamp(1.0, f64::from(most.max(1))) as u32
    };
    let row_step = step(plan.row_step, rows, height);
    let (row_step, more_rows) = rows_in_whole_groups(row_step, height);
    let (row_step, col_step) = spread_rows(
        row_step,
        step(plan.col_step, columns * more_rows, width),
        (width, height),
    );
    TrialPlan {
        row_step,
        col_step,
        samples: least.min(MAX_TRIAL_SPP),
    }
}

/// A lattice of fewer rows than this, on an image that has more, trades columns for rows
/// ([`spread_rows`]).
const LEAST_LATTICE_ROWS: u32 = 4;

/// A lattice of `row_step` and `col_step` on an image of `width` x `height` with fewer than
/// [`LEAST_LATTICE_ROWS`] rows given more rows, up to a work-group's (super::GROUP), and fewer
/// columns at about the same pixels: a round of a few thousand paths on a wide image (a
/// time-limited render's scouts at a CPU's floor of 2^13 paths, 1280x720) had measured the
/// middle row alone, every fourth pixel of it.
fn spread_rows(row_step: u32, col_step: u32, (width, height): (u32, u32)) -> (u32, u32) {
    let group = super::GROUP as u32;
    let rows = trial_rows(row_step, height);
    let columns = width.div_ceil(col_step.max(1));
    if rows == 0 || rows >= LEAST_LATTICE_ROWS || rows >= height {
        return (row_step, col_step);
    }
    let factor = (group / rows).min(columns).max(1);
    let mut spread = (row_step / factor).max(1);
    while trial_rows(spread, height) > group {
        spread += 1;
    }
    let grown = f64::from(trial_rows(spread, height)) / f64::from(rows);
    let col_step = (f64::from(col_step) * grown).round() as u32;
    (spread, col_step.clamp(1, width.max(1)))
}

/// The first row a trial round with a row step `step` takes: the middle of the first step
/// (and so its first column, `Rows::first_column`).
pub fn trial_first_row(step: u32) -> u32 {
    (step.max(1) - 1) / 2
}

/// The rows a trial round takes on an image `height` high with a row step `step`: every
/// `step`-th from [`trial_first_row`] (render/mod.rs, `trial_round`); its columns likewise
/// (`Rows::columns`).
pub fn trial_rows(step: u32, height: u32) -> u32 {
    height
        .saturating_sub(trial_first_row(step))
        .div_ceil(step.max(1))
}

/// A row step near `step` whose rows fill whole work-groups of the render kernel's launches
/// (super::GROUP rows each), and the factor by which it changes the rows (for the columns to
/// make up). More than a group of rows with one nearly empty group row beyond cost PoCL on 2
/// cores twice the seconds a path: case2 at 160x120, a lattice of 9 rows by 40 columns, 1.12
/// to 1.44 us a path against 0.45 to 0.79 at 8 rows (128x96), as its work-groups are shared
/// out between the threads in order and the second thread's are all but empty. At most a
/// group's rows keep their step, and so do rows that no step within a quarter of their
/// number puts in whole groups.
fn rows_in_whole_groups(step: u32, height: u32) -> (u32, f64) {
    let group = super::GROUP as u32;
    let rows = trial_rows(step, height);
    if rows <= group {
        return (step, 1.0);
    }
    (1..=height)
        .map(|s| (s, trial_rows(s, height)))
        .filter(|&(_, n)| n.is_multiple_of(group))
        .min_by_key(|&(_, n)| n.abs_diff(rows))
        .filter(|&(_, n)| n.abs_diff(rows) <= rows / 4)
        .map_or((step, 1.0), |(s, n)| (s, f64::from(n) / f64::from(rows)))
}

/// Parts a CPU device's trial round renders in ([`timing_parts`]).
const CPU_TIMING_PARTS: u32 = 5;

/// How many parts of its samples a trial round renders in on a device of `kind`: every
/// candidate renders a part on all the round's pixels before any renders the next
/// ([`sample_parts`], render/mod.rs `trial_round`), so that [`robust_seconds`] compares the
/// candidates part by part, on the same pixels. On a CPU, whose threads share the machine
/// with everything else, a trial's launches of 1 to 40 ms take up to twice as long as usual
/// at random. PoCL on 2 cores of a shared machine, light sampling on against off with
/// roulette below 0.3 (1.58 and 1.60 times the seconds in the renders), as the trial read it:
/// - case2 at 128x96, 24 trials each: each candidate's fastest of 3 parts of the rows (2, 1
///   and 1 rows) 1.11 to 2.06 (0.75 once in CI, which chose the slower); 5 parts of 8 rows
///   compared part by part 1.33 to 1.61; 5 parts of the samples 1.40 to 1.62 (12 trials);
/// - meshes at 160x120: 5 parts of 2 rows compared part by part 1.20 to 1.97 (14 trials), the
///   parts' own ratios 1.11 to 2.26 as their rows held more or less of the meshes; 5 parts of
///   the samples, every part on every pixel, 1.39 to 1.67 (12 trials).
///
/// On a CPU the parts' seconds are the process's CPU seconds (render/clock.rs, which says
/// why and how much steadier they read). The parts stay: their median outvotes a launch whose
/// own work ran slow (a cold cache, a page fault).
///
/// A GPU renders each round at once: parts would cost it launches and idle time, and its
/// timings repeat within 1% (BENCHMARKS.md).
pub fn timing_parts(kind: &str) -> u32 {
    if kind == "CPU" { CPU_TIMING_PARTS } else { 1 }
}

/// Every candidate's seconds on a whole round from its seconds on each part (`timed[k]`:
/// candidate k's seconds and samples on each part, the parts in the same order for every
/// candidate; `samples` the round's). In each part a candidate's seconds a sample are
/// compared with the geometric mean of all the candidates' on the same part; the median of
/// that ratio over the parts is its relative cost, and the fastest part's mean the scale. So a
/// slowdown over a whole part (something else ran) cancels and one candidate's slow launch is
/// outvoted. Interference only ever adds time: the fastest part's mean is the one it touched
/// least.
pub fn robust_seconds(timed: &[Vec<(f64, u32)>], samples: u32) -> Vec<f64> {
    let parts = timed.iter().map(Vec::len).min().unwrap_or(0);
    let usable: Vec<usize> = (0..parts)
        .filter(|&p| timed.iter().all(|t| t[p].1 > 0 && t[p].0 > 0.0))
        .collect();
    if usable.is_empty() {
        return timed
            .iter()
            .map(|t| t.iter().map(|&(s, _)| s).sum())
            .collect();
    }
    let log_rate = |k: usize, p: usize| (timed[k][p].0 / f64::from(timed[k][p].1)).ln();
    // Each usable part's mean log rate over the candidates.
    let means: Vec<f64> = usable
        .iter()
        .map(|&p| (0..timed.len()).map(|k| log_rate(k, p)).sum::<f64>() / timed.len() as f64)
        .collect();
    let scale = means.iter().copied().fold(f64::INFINITY, f64::min);
    (0..timed.len())
        .map(|k| {
            let mut shares: Vec<f64> = usable
                .iter()
                .zip(&means)
                .map(|(&p, mean)| log_rate(k, p) - mean)
                .collect();
            shares.sort_by(f64::total_cmp);
            let mid = shares.len() / 2;
            let share = if shares.len() % 2 == 1 {
                shares[mid]
            } else {
                (shares[mid - 1] + shares[mid]) / 2.0
            };
            (scale + share).exp() * f64::from(samples)
        })
        .collect()
}

/// The samples of each of a round's `parts` (ranges of its `samples` a pixel, from 0), shared
/// alike; never more parts than samples to share.
pub fn sample_parts(samples: u32, parts: u32) -> Vec<(u32, u32)> {
    let n = parts.clamp(1, samples.max(1));
    (0..n)
        .map(|i| (samples * i / n, samples * (i + 1) / n))
        .collect()
}

/// How a device of `kind` (an OpenCL device type as `clpt devices` lists it: "CPU", "GPU",
/// ...) scouts: the least paths a candidate traces (`MIN_SCOUT_PATHS_CPU`,
/// `MIN_SCOUT_PATHS`) and, on a GPU, the pixels its scouts fill (`GPU_SCOUT_PIXELS`).
pub fn scouting(kind: &str) -> Scouting {
    if kind == "CPU" {
        Scouting {
            min_paths: MIN_SCOUT_PATHS_CPU,
            fill: None,
        }
    } else {
        Scouting {
            min_paths: MIN_SCOUT_PATHS,
            fill: Some(GPU_SCOUT_PIXELS),
        }
    }
}

/// Whether a device of `kind` compares a full round's candidates (`full`, after scouts of
/// plan `scouts`, on an image of `size`) by the scouts' seconds a path rather than by its own
/// launches: on a GPU, where the full round takes fewer pixels ([`full_round_least_pixels`]:
/// 2^16 at the least, for its samples a pixel), and a lean program then idles in
/// its launches (`GPU_SCOUT_PIXELS`). The variances stay the full round's.
pub fn times_by_scouts(kind: &str, scouts: TrialPlan, full: TrialPlan, size: (u32, u32)) -> bool {
    kind != "CPU" && full.pixels(size) < scouts.pixels(size)
}

/// The rows of a trial round's first launch on a device of `kind`, of `rows` in all: on a GPU
/// all of them (the round's pixels at once: a narrower launch leaves a lean program's
/// work-items too few, `GPU_SCOUT_PIXELS`); on a CPU two work-groups' rows, the rest sized
/// by their rate.
pub fn first_trial_launch(kind: &str, rows: u32) -> u32 {
    if kind == "CPU" {
        super::GROUP as u32 * 2
    } else {
        rows
    }
}

/// The shape of a device's scouting round ([`scouting`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scouting {
    /// The least paths a candidate traces.
    pub min_paths: f64,
    /// Where set (a GPU), the widest scouting round takes [`TRIAL_SPP`] samples on about this
    /// many pixels (every row of a smaller image), as far as its share of the render affords;
    /// else (a CPU) on every fourth row, on about `TRIAL_PIXELS` at most.
    pub fill: Option<u64>,
}

/// The pixels a GPU's scouting round fills at the most ([`Scouting::fill`]). A GPU keeps one
/// work-item a pixel, and a lean program keeps more of them resident than a heavy one: it is
/// the one that idles in a narrow launch, and its seconds a path read high. H200, meshes with
/// light sampling off (roulette below 0.3) at 0.0033 us a path over 921,600 pixels, 0.0040
/// over 230,400 and 0.0100 over 57,600; with it on 0.0114, 0.0110 and 0.0134 (BENCHMARKS.md).
/// Scouts of 8 samples on every fourth row (two launches, 163,840 and 66,560 pixels) read
/// light sampling off at 1.41 times its render's seconds a path and on at 1.05, and dropped
/// the best setting; the full round's 2^16 pixels read it 1.19 to 1.47 times on meshes,
/// textures and the goblet. 2^19 pixels fill the H200's 132 units at 2048 work-items each
/// about twice.
const GPU_SCOUT_PIXELS: u64 = 1 << 19;

/// The row sampling of the shortest trials, and of the scouting round: every fourth row.
const MIN_ROW_STEP: u32 = 4;

/// After the scouting round a candidate is dropped when its relMSE × seconds exceeds the best
/// one's by more than this share, and by more than [`DROP_SIGMAS`] standard errors of the
/// two relative variances: the margin covers the timings' noise, which the standard errors
/// leave out.
const DROP_MARGIN: f64 = 0.2;

/// See [`DROP_MARGIN`].
const DROP_SIGMAS: f64 = 3.0;

/// `--light-sampling`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampling {
    /// Measured: on or off, whichever reaches a given error sooner.
    #[default]
    Auto,
    On,
    Off,
}

impl std::str::FromStr for LightSampling {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(LightSampling::Auto),
            "on" => Ok(LightSampling::On),
            "off" => Ok(LightSampling::Off),
            other => Err(format!(
                "unknown light sampling `{other}`: use auto, on or off"
            )),
        }
    }
}

/// `--rr-threshold`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Roulette {
    /// Measured among [`RR_THRESHOLDS`].
    #[default]
    Auto,
    /// Paths whose largest throughput component is below this play roulette.
    Threshold(f32),
}

impl std::str::FromStr for Roulette {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Roulette::Auto);
        }
        match s.parse::<f32>() {
            Ok(t) if t.is_finite() && t > 0.0 && t <= 1.0 => Ok(Roulette::Threshold(t)),
            _ => Err(format!(
                "roulette threshold `{s}`: use auto or a number in (0, 1]"
            )),
        }
    }
}

/// One estimator: what a render launch runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Strategy {
    /// Next-event estimation with MIS (a program built with `CLPT_NEE`).
    pub light_sampling: bool,
    /// Roulette's threshold (`RenderParams::rr_threshold`).
    pub rr_threshold: f32,
}

impl fmt::Display for Strategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "light sampling {}, roulette below {}",
            if self.light_sampling { "on" } else { "off" },
            self.rr_threshold
        )
    }
}

/// The strategies a render chooses among, the preferred first (ties and unmeasurable trials,
/// such as a black picture, go to it). Light sampling is a candidate only when the scene has a
/// listed light.
pub fn candidates(light: LightSampling, roulette: Roulette, has_lights: bool) -> Vec<Strategy> {
    let lights: &[bool] = match (light, has_lights) {
        (LightSampling::Off, _) | (_, false) => &[false],
        (LightSampling::On, true) => &[true],
        (LightSampling::Auto, true) => &[true, false],
    };
    let thresholds: Vec<f32> = match roulette {
        Roulette::Auto => RR_THRESHOLDS.to_vec(),
        Roulette::Threshold(t) => vec![t],
    };
    lights
        .iter()
        .flat_map(|&l| {
            thresholds.iter().map(move |&t| Strategy {
                light_sampling: l,
                rr_threshold: t,
            })
        })
        .collect()
}

/// Which rows and how many samples each candidate renders in the trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrialPlan {
    /// Every `row_step`-th row takes part...
    pub row_step: u32,
    /// ...and every `col_step`-th pixel on it (render/mod.rs, `Rows`).
    pub col_step: u32,
    /// Samples per pixel, a multiple of [`TRIAL_SPP`] (whole pairs of groups of four).
    pub samples: u32,
}

impl TrialPlan {
    /// Full-image samples per pixel.
    pub fn cost(&self) -> f64 {
        f64::from(self.samples) / (f64::from(self.row_step) * f64::from(self.col_step))
    }

    /// The pixels it takes on an image of `width` x `height`: its rows times its columns, both
    /// counted by [`trial_rows`] (as render/mod.rs's `Rows` counts them).
    pub fn pixels(&self, (width, height): (u32, u32)) -> u64 {
        u64::from(trial_rows(self.row_step, height)) * u64::from(trial_rows(self.col_step, width))
    }
}

/// The trial's size: each candidate gets `TRIAL_SHARE` of a render of `spp` samples divided
/// among the `candidates`, in full-image samples per pixel ([`plan_for_budget`]). Without a
/// sample count (a time limit or a target error) the trial is the shortest: TRIAL_SPP samples
/// on every fourth row.
pub fn trial_plan(candidates: usize, spp: Option<u32>, height: u32) -> TrialPlan {
    let budget = spp.map_or(0.0, |n| {
        TRIAL_SHARE * f64::from(n) / candidates.max(1) as f64
    });
    plan_for_budget(budget, height)
}

/// The plan of a candidate's share of the trial, `budget` full-image samples per pixel. Below
/// [`TRIAL_SPP`] samples on every fourth row's worth, the rows thin out (never fewer than one);
/// above it, every row takes part first, then the samples grow by whole [`TRIAL_SPP`]s up to
/// `MAX_TRIAL_SPP`: a long render affords a trial precise enough to tell estimators apart by
/// 10%. A budget of 0 gives the shortest trial.
pub fn plan_for_budget(budget: f64, height: u32) -> TrialPlan {
    let least = f64::from(TRIAL_SPP) / f64::from(MIN_ROW_STEP);
    let (row_step, samples) = if budget <= least {
        let step = if budget > 0.0 {
            (f64::from(TRIAL_SPP) / budget).ceil() as u32
        } else {
            MIN_ROW_STEP
        };
        (step, TRIAL_SPP)
    } else if budget < f64::from(TRIAL_SPP) {
        ((f64::from(TRIAL_SPP) / budget).ceil() as u32, TRIAL_SPP)
    } else {
        let groups = (budget / f64::from(TRIAL_SPP)) as u32;
        (1, (groups * TRIAL_SPP).min(MAX_TRIAL_SPP))
    };
    TrialPlan {
        row_step: row_step.clamp(1, height.max(1)),
        col_step: 1,
        samples,
    }
}

/// The plan of the full round after scouting, or `None` when it would take less than
/// `FULL_ROUND_GAIN` times the scouting round's (`scouted`) samples: the `survivors` share
/// `FULL_ROUND_SHARE` of the time a render of `spp` samples would take with the
/// fastest-converging of them (by the scouts' timings), so the round costs the same share
/// however slow the losers are. It spends that on more samples rather than on more than about
/// `TRIAL_PIXELS` pixels ([`plan_on_rows`]), and at least `LEAST_FULL_ROUND_SPP` samples
/// a pixel on any device, on pixels thinned out no further than to `least_pixels`
/// ([`with_least_samples_on`], [`full_round_least_pixels`]): a small image would otherwise
/// spend it on [`TRIAL_SPP`] samples on every row (and on a CPU replace the scouts' figures
/// at more samples).
/// - PoCL, smallpt at 96x72 and 4096 samples, 24 trials: light sampling on with roulette
///   below 1, 37% behind roulette below 0.3 in the render, chosen 15 times with 8 samples on
///   every pixel, 3 times with 32 on a quarter of them (BENCHMARKS.md, "At the original's
///   samples on PoCL").
/// - H200, ceiling_room (320x240, 4096 samples), 10 seeds: roulette below 0.5, 12% behind 0.3
///   in the render, chosen 9 times with 8 samples on every pixel, 2 to 3 times with 32 on a
///   quarter of them (whose timings were off: [`full_round_least_pixels`]), never with 32 on
///   every pixel; the trial took 0.008, 0.014 and 0.017 s of a 0.45-second render. The GPU's
///   scouts keep [`TRIAL_SPP`] ([`least_trial_samples`]): they need the pixels to fill it.
pub fn full_round_plan(
    scout: &Choice,
    scouted: TrialPlan,
    survivors: &[usize],
    spp: u32,
    (width, height): (u32, u32),
    least_pixels: u64,
) -> Option<TrialPlan> {
    let chosen = &scout.measured[scout.chosen];
    let total: f64 = survivors
        .iter()
        .map(|&i| scout.measured[i].seconds_per_sample)
        .sum();
    let budget = FULL_ROUND_SHARE * f64::from(spp) * chosen.seconds_per_sample / total;
    let plan = plan_on_rows(budget, row_step_for(width, height, TRIAL_PIXELS), height);
    let plan = with_least_samples_on(plan, LEAST_FULL_ROUND_SPP, (width, height), least_pixels);
    // A round of the full round's samples where the scouts took fewer (a GPU's, of TRIAL_SPP)
    // measures what they could not, whatever its cost against theirs; not where the render
    // itself takes no more.
    let deep = |p: TrialPlan| p.samples >= LEAST_FULL_ROUND_SPP && spp > p.samples;
    let new_figures = deep(plan) && !deep(scouted);
    let gain = plan.cost() >= FULL_ROUND_GAIN * scouted.cost() || new_figures;
    (survivors.len() > 1 && budget.is_finite() && gain).then_some(plan)
}

/// The pixels past which a trial round takes more samples on fewer rows. The trial's figures
/// are those of its samples per pixel (the quasi-random samples gain more with more of them),
/// and pixels beyond about 2^18 add little to their precision (a pixel's term spreads about as
/// much as its mean: 2^18 pixels give about 0.25%) but cost read-backs and host time (on the
/// H200 machine 22 ms a candidate for smallpt's 786,432 pixels). Fewer would leave a GPU idle,
/// a work-item a pixel: an H200 keeps 270,336 resident (132 units of 2048), and a scouting
/// round on 2^16 pixels took case1 1.48 s where every fourth row had taken 0.60 s.
const TRIAL_PIXELS: u64 = 1 << 18;

/// The plan of `budget` full-image samples per pixel on every `step`-th row: as many whole
/// [`TRIAL_SPP`]s as that affords there, up to `MAX_TRIAL_SPP` (past which the rows grow
/// closer); a budget of less than [`TRIAL_SPP`] on those rows thins them out
/// ([`plan_for_budget`]).
pub fn plan_on_rows(budget: f64, step: u32, height: u32) -> TrialPlan {
    let step = step.clamp(1, height.max(1));
    // A NaN budget counts as too small.
    if budget * f64::from(step) < f64::from(TRIAL_SPP) || budget.is_nan() {
        return plan_for_budget(budget, height);
    }
    let step = if budget * f64::from(step) > f64::from(MAX_TRIAL_SPP) {
        ((f64::from(MAX_TRIAL_SPP) / budget) as u32).clamp(1, step)
    } else {
        step
    };
    let groups = (budget * f64::from(step) / f64::from(TRIAL_SPP)) as u32;
    TrialPlan {
        row_step: step,
        col_step: 1,
        samples: (groups.max(1) * TRIAL_SPP).min(MAX_TRIAL_SPP),
    }
}

/// The scouting round of a long render's trial for `candidates` on an image of `width` x
/// `height`: [`TRIAL_SPP`] samples on every fourth row's worth, or less where that would cost
/// more than `SCOUT_SHARE` of a render of `spp` samples, but never fewer than `min_paths`
/// paths a candidate (`min_scout_paths`); spent on more samples rather than on more than
/// about `TRIAL_PIXELS` pixels.
pub fn scout_plan(
    candidates: usize,
    spp: Option<u32>,
    (width, height): (u32, u32),
    scouting: Scouting,
) -> TrialPlan {
    // No sample count: the widest round (scout_on's ceiling).
    let budget = spp.map_or(f64::INFINITY, |n| {
        SCOUT_SHARE * f64::from(n) / candidates.max(1) as f64
    });
    scout_on(budget, (width, height), scouting)
}

/// The first round of a render limited by time alone (`--time` without `--spp`): the
/// scouting round at the device's floor, `min_paths` paths a candidate. Its samples, and so
/// what its trial affords, are known only once a round has timed the candidates
/// ([`samples_within`]); the widest scouting round, which such a render had before, took a
/// 1280x720 render on PoCL (2 cores) 14 s of a 5-second limit.
pub fn time_limited_scout_plan((width, height): (u32, u32), scouting: Scouting) -> TrialPlan {
    scout_on(0.0, (width, height), scouting)
}

/// A scouting round of `budget` full-image samples per pixel a candidate, at least
/// `scouting.min_paths` paths and at most [`TRIAL_SPP`] samples on every fourth row's worth,
/// on about [`TRIAL_PIXELS`] pixels at most; on a GPU at most TRIAL_SPP samples on about its
/// `fill` pixels.
fn scout_on(budget: f64, (width, height): (u32, u32), scouting: Scouting) -> TrialPlan {
    let (widest_step, step) = match scouting.fill {
        Some(fill) => {
            let step = row_step_for(width, height, fill).max(1);
            (step, step)
        }
        None => (MIN_ROW_STEP, row_step_for(width, height, TRIAL_PIXELS)),
    };
    let widest = f64::from(TRIAL_SPP) / f64::from(widest_step);
    let pixels = f64::from(width) * f64::from(height);
    let budget = budget.max(scouting.min_paths / pixels.max(1.0)).min(widest);
    plan_on_rows(budget, step, height)
}

/// The samples per pixel a render of `pixels` pixels reaches in `seconds` at
/// `seconds_per_sample` a path (a time-limited render's best candidate, as its first trial
/// round timed it): the sample count its full round is sized by, at least one. A CPU's trial
/// reads up to twice the render's seconds a path (BENCHMARKS.md), so this errs low: a smaller
/// full round.
pub fn samples_within(seconds: f64, seconds_per_sample: f64, pixels: f64) -> u32 {
    let samples = seconds / (seconds_per_sample * pixels);
    if samples.is_finite() {
        samples.clamp(1.0, f64::from(u32::MAX >> 1)) as u32
    } else {
        1
    }
}

/// The row step that leaves about `cap` of an image's pixels.
fn row_step_for(width: u32, height: u32, cap: u64) -> u32 {
    let pixels = u64::from(width) * u64::from(height);
    pixels.div_ceil(cap).min(u64::from(u32::MAX)) as u32
}

/// What the trial measured of one candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measured {
    pub strategy: Strategy,
    /// Seconds per path sample.
    pub seconds_per_sample: f64,
    /// Relative variance of one sample, averaged over the trial's pixels and channels.
    pub relative_variance: f64,
    /// The standard error of `relative_variance` (from the spread of its pixels' terms).
    pub relative_variance_se: f64,
    /// Its image mean fell significantly below the most precise candidate's: its trial missed
    /// rare bright paths, so its variance reads low and it is not chosen.
    pub missed_rare_paths: bool,
    /// Dropped after the scouting round: these figures are that round's.
    pub dropped: bool,
    /// Samples per pixel of the round these figures come from.
    pub samples: u32,
}

impl Measured {
    /// relMSE × seconds of a render of `pixels` pixels with this strategy: lower reaches any
    /// error sooner.
    pub fn efficiency(&self, pixels: f64) -> f64 {
        self.relative_variance * self.seconds_per_sample * pixels
    }
}

/// The outcome of the trial.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    pub measured: Vec<Measured>,
    /// Index into `measured` of the strategy the render runs.
    pub chosen: usize,
    /// Wall time of the trial.
    pub seconds: f64,
    /// The image's pixel count, which relMSE × seconds scales with.
    pub pixels: f64,
    /// Samples per pixel of the chosen strategy that the trial left in the film (on every
    /// row, from sample 0): the render goes on from there. 0 when it starts afresh.
    pub film_samples: u32,
}

impl Choice {
    /// The choice when there is one candidate: nothing measured.
    pub fn only(strategy: Strategy) -> Choice {
        Choice {
            measured: vec![Measured {
                strategy,
                seconds_per_sample: f64::NAN,
                relative_variance: f64::NAN,
                relative_variance_se: f64::NAN,
                missed_rare_paths: false,
                dropped: false,
                samples: 0,
            }],
            chosen: 0,
            seconds: 0.0,
            pixels: f64::NAN,
            film_samples: 0,
        }
    }

    /// The candidates worth a full trial after a scouting round, by index into `measured`:
    /// the chosen one, and every trusted one whose relMSE × seconds is not clearly worse (by
    /// `DROP_MARGIN` and `DROP_SIGMAS` standard errors). The chosen one comes last, so
    /// that, when it wins again, its film is the last rendered and can be kept.
    pub fn survivors(&self) -> Vec<usize> {
        let best = &self.measured[self.chosen];
        let relative_se = |m: &Measured| m.relative_variance_se / m.relative_variance;
        let mut keep: Vec<usize> = (0..self.measured.len())
            .filter(|&i| {
                let m = &self.measured[i];
                let ratio = m.efficiency(self.pixels) / best.efficiency(self.pixels);
                let sigma = relative_se(m).hypot(relative_se(best));
                // A ratio that cannot be computed (NaN) is not clearly worse.
                let clearly_worse = ratio > 1.0 + DROP_MARGIN.max(DROP_SIGMAS * sigma);
                i != self.chosen && !m.missed_rare_paths && !clearly_worse
            })
            .collect();
        keep.push(self.chosen);
        keep
    }

    /// The choice of a two-round trial: `full`'s figures for the candidates it measured
    /// (`survivors`, indices into `scout.measured`), the scouts' for the dropped.
    pub fn merge(scout: &Choice, survivors: &[usize], full: Choice) -> Choice {
        let mut measured: Vec<Measured> = scout
            .measured
            .iter()
            .map(|m| Measured {
                dropped: true,
                ..*m
            })
            .collect();
        for (k, &i) in survivors.iter().enumerate() {
            measured[i] = full.measured[k];
        }
        Choice {
            measured,
            chosen: survivors[full.chosen],
            ..full
        }
    }

    pub fn strategy(&self) -> Strategy {
        self.measured[self.chosen].strategy
    }

    /// Whether a trial measured the candidates.
    pub fn was_measured(&self) -> bool {
        self.measured.len() > 1
    }

    /// One line per candidate: the strategy and its measured relMSE × seconds, relative
    /// variance per sample (at the round's samples a pixel) and microseconds per path, the
    /// chosen one marked.
    pub fn trial_lines(&self) -> Vec<String> {
        self.measured
            .iter()
            .enumerate()
            .map(|(i, m)| {
                format!(
                    "{}: relMSE x s {:.3e} (relative variance {:.3e} per sample at {} samples, {:.4} us per path){}{}{}",
                    m.strategy,
                    m.efficiency(self.pixels),
                    m.relative_variance,
                    m.samples,
                    m.seconds_per_sample * 1e6,
                    if m.missed_rare_paths {
                        ", image mean too low: rare paths missed"
                    } else {
                        ""
                    },
                    if m.dropped {
                        ", dropped after the scouting round"
                    } else {
                        ""
                    },
                    if i == self.chosen { ", chosen" } else { "" }
                )
            })
            .collect()
    }
}

/// One trial round's films as [`choose`] reads them: sums over the round's trial pixels, per
/// candidate, in the order the candidates rendered. The renderer computes them on the device
/// (render/trial.rs, kernels/trial.h), where a read-back of the films had cost a fast scene
/// more than its trial's renders; tests/common/trial.rs holds the same formulas on the host in
/// f64, the oracle.
///
/// A pixel's variance is measured from the sums of its n samples and of its odd groups of four
/// (n/2 of them): the two halves are independent and alike, so the difference of their means
/// squared, times n/4, is an unbiased estimate of n times the variance of the pixel's mean (the
/// "stratified variance": the variance per sample of the render's estimate, which the plain
/// sample variance would overstate by the spread the quasi-random samples integrate away).
pub trait TrialSums {
    /// Per film: the sum over trial pixels and channels of the pixel's mean, and of that mean's
    /// variance (the stratified variance over n).
    fn totals(&mut self) -> ClptResult<Vec<(f64, f64)>>;
    /// Per film: the sum over trial pixels of the pixel's relative variance of one sample (the
    /// channels' mean of the stratified variance over d² +
    /// [`REL_EPSILON`](super::metrics::REL_EPSILON), d the films' sums
    /// weighted by `weights`) and of its square.
    fn terms(&mut self, weights: &[f64]) -> ClptResult<Vec<(f64, f64)>>;
}

/// What a trial round measured besides its sums.
#[derive(Clone, Debug)]
pub struct Round {
    /// The candidates, in the order they rendered.
    pub strategies: Vec<Strategy>,
    /// Each candidate's seconds in launches.
    pub seconds: Vec<f64>,
    /// Samples per pixel each rendered.
    pub samples: u32,
    /// The trial pixels each rendered.
    pub pixels: usize,
}

/// How many standard errors a candidate's image mean may fall below the reference's before
/// its trial is taken to have missed rare paths. The standard errors are those of the channels'
/// sum (kernels/trial.cl, trial_pixel): summed channel by channel they had read 1.7 to 2.2
/// times low on case2 (PoCL, 96x72, 40 seeds), and light sampling off was taken to have missed
/// rare paths in 4 trials of 24 once light sampling's own estimate became precise (the walls
/// by solid angle); now each candidate's mean spreads 0.97 to 1.24 times its standard error
/// there. A trial that did miss rare paths falls short by far more (pure path tracing of a
/// small light).
const MISSED_SIGMAS: f64 = 3.0;

/// Each film's weight in the relative variance's denominator ([`TrialSums::terms`]): the
/// trusted candidates' films weighted by the precision of their image means (`totals`: each
/// film's mean and its standard error), summing to 1, and divided by the sample count. Pooling
/// lessens the noise of a few samples per pixel; the weights keep a noisy candidate's rare
/// bright sample from raising its own pixel's denominator and hiding its variance, and one
/// that missed rare paths from pulling the denominator down.
fn denominator_weights(totals: &[(f64, f64)], missed: &[bool], samples: u32) -> Vec<f64> {
    let weights: Vec<f64> = totals
        .iter()
        .zip(missed)
        .map(|(&(_, se), &missed)| {
            if missed {
                0.0
            } else if se > 0.0 {
                1.0 / (se * se)
            } else {
                1e300 // exact: it alone decides
            }
        })
        .collect();
    let total_weight: f64 = weights.iter().sum();
    weights
        .iter()
        .map(|&w| {
            let share = if total_weight > 0.0 {
                w / total_weight
            } else {
                1.0 / totals.len() as f64
            };
            share / f64::from(samples)
        })
        .collect()
}

/// Measures every candidate of a `round` and picks the one of least relMSE × seconds among
/// those whose trial can be trusted (the first among equals, and when none could be measured),
/// for a render of `pixels` pixels; `trial_seconds` is the trial's time so far.
///
/// Two guards against rare paths, whose samples are few but carry most of the variance (pure
/// path tracing of a small light, caustics):
/// - The denominator of the relative variance is the mean image of the most precise candidate
///   (least standard error of the image mean, relative to it), not an average: a rare bright
///   sample would raise its own pixel's denominator and hide its variance.
/// - A candidate whose image mean lies more than `MISSED_SIGMAS` standard errors below the
///   most precise one's has, by the two being unbiased estimates of the same image, missed
///   rare bright paths, and its variance reads low: it is not chosen.
pub fn choose(
    round: &Round,
    sums: &mut dyn TrialSums,
    pixels: f64,
    trial_seconds: f64,
) -> ClptResult<Choice> {
    let totals: Vec<(f64, f64)> = sums
        .totals()?
        .into_iter()
        .map(|(mean, var)| (mean, var.sqrt()))
        .collect();
    let mut reference = 0;
    for (i, &(mean, se)) in totals.iter().enumerate() {
        let (best_mean, best_se) = totals[reference];
        if mean > 0.0 && (best_mean.is_nan() || best_mean <= 0.0 || se / mean < best_se / best_mean)
        {
            reference = i;
        }
    }
    let (ref_mean, ref_se) = totals[reference];
    let missed: Vec<bool> = totals
        .iter()
        .map(|&(mean, se)| mean < ref_mean - MISSED_SIGMAS * se.hypot(ref_se))
        .collect();
    let weights = denominator_weights(&totals, &missed, round.samples);
    let np = round.pixels.max(1) as f64;
    let measured: Vec<Measured> = round
        .strategies
        .iter()
        .zip(&round.seconds)
        .zip(sums.terms(&weights)?)
        .enumerate()
        .map(|(i, ((&strategy, &seconds), (rel, rel_sq)))| {
            // The mean relative variance over the trial pixels and its standard error.
            let mean = rel / np;
            Measured {
                strategy,
                seconds_per_sample: seconds / (f64::from(round.samples) * np),
                relative_variance: mean,
                relative_variance_se: ((rel_sq / np - mean * mean).max(0.0) / np).sqrt(),
                missed_rare_paths: missed[i],
                dropped: false,
                samples: round.samples,
            }
        })
        .collect();
    let chosen = pick(&measured, pixels);
    Ok(Choice {
        measured,
        chosen,
        seconds: trial_seconds,
        pixels,
        film_samples: 0,
    })
}

/// The index of the least relMSE × seconds among the trusted candidates that were not dropped
/// (for `pixels` pixels); ties, and candidates that could not be measured (a non-finite
/// figure), keep the earlier.
fn pick(measured: &[Measured], pixels: f64) -> usize {
    let eligible = |m: &Measured| !m.missed_rare_paths && !m.dropped;
    let mut chosen = 0;
    for (i, m) in measured.iter().enumerate() {
        let (e, best) = (m.efficiency(pixels), measured[chosen].efficiency(pixels));
        if eligible(m)
            && e.is_finite()
            && (!eligible(&measured[chosen]) || !best.is_finite() || e < best)
        {
            chosen = i;
        }
    }
    chosen
}

impl fmt::Display for Choice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.strategy())?;
        if self.was_measured() {
            write!(f, " (chosen in a {:.3} s trial", self.seconds)?;
            if self.film_samples > 0 {
                write!(
                    f,
                    ", whose {} samples of it the render keeps",
                    self.film_samples
                )?;
            }
            write!(f, ")")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strategy(light_sampling: bool, rr_threshold: f32) -> Strategy {
        Strategy {
            light_sampling,
            rr_threshold,
        }
    }

    #[test]
    fn candidates_follow_the_options_and_the_light_list() {
        let all = candidates(LightSampling::Auto, Roulette::Auto, true);
        assert_eq!(
            all,
            [
                strategy(true, 0.5),
                strategy(true, 0.3),
                strategy(false, 0.5),
                strategy(false, 0.3)
            ]
        );
        // No listed light: nothing for light sampling to sample.
        assert_eq!(
            candidates(LightSampling::On, Roulette::Threshold(0.7), false),
            [strategy(false, 0.7)]
        );
        assert_eq!(
            candidates(LightSampling::Off, Roulette::Auto, true),
            [strategy(false, 0.5), strategy(false, 0.3)]
        );
        assert!("0".parse::<Roulette>().is_err() && "1.5".parse::<Roulette>().is_err());
        assert_eq!("0.25".parse::<Roulette>(), Ok(Roulette::Threshold(0.25)));
        assert!("maybe".parse::<LightSampling>().is_err());
    }

    #[test]
    fn the_trial_takes_a_small_share_of_a_render() {
        let plan = |spp, height| {
            let p = trial_plan(4, spp, height);
            (p.row_step, p.samples)
        };
        // No sample count: 8 samples on every 4th row.
        assert_eq!(plan(None, 480), (4, 8));
        // 64 samples: 6% of them, 0.96 samples' worth a candidate: every 9th row.
        assert_eq!(plan(Some(64), 480), (9, 8));
        // 300: 4.5 samples' worth, every second row; 800: 12, every row.
        assert_eq!(plan(Some(300), 480), (2, 8));
        assert_eq!(plan(Some(800), 480), (1, 8));
        // 4096: 61 samples' worth, 56 on every row; and never more than 64.
        assert_eq!(plan(Some(4096), 480), (1, 56));
        assert_eq!(plan(Some(1 << 20), 480), (1, 64));
        // Never more rows apart than the image has.
        assert_eq!(plan(Some(1), 5), (5, 8));
    }

    fn measured(light_sampling: bool, seconds: f64, variance: f64, se: f64) -> Measured {
        Measured {
            strategy: strategy(light_sampling, 1.0),
            seconds_per_sample: seconds,
            relative_variance: variance,
            relative_variance_se: se,
            missed_rare_paths: false,
            dropped: false,
            samples: 8,
        }
    }

    fn plan_of(row_step: u32, col_step: u32, samples: u32) -> TrialPlan {
        TrialPlan {
            row_step,
            col_step,
            samples,
        }
    }

    #[test]
    fn scouting_drops_the_clearly_worse_and_keeps_the_close() {
        let scout = Choice {
            measured: vec![
                measured(true, 2.0, 1.0, 0.01),  // 2.0: twice the best
                measured(true, 1.0, 1.15, 0.01), // 1.15: within the 20% margin
                measured(false, 1.0, 1.0, 0.01), // 1.0: the best
                measured(false, 1.0, 1.5, 0.3),  // 1.5, but too noisy to tell
            ],
            chosen: 2,
            seconds: 1.0,
            pixels: 100.0,
            film_samples: 0,
        };
        // The best comes last, so that its film is the one left when it wins again.
        assert_eq!(scout.survivors(), [1, 3, 2]);
        // The full round: 0.75% of a 4000-sample render at the best's speed, shared by three
        // candidates of equal speed: 10 samples' worth each; on every 2nd row of 640x480 (2^18
        // pixels at most), 16 samples.
        let scouted = scout_plan(4, Some(4000), (640, 480), scouting("CPU"));
        assert_eq!((scouted.row_step, scouted.samples), (4, 8));
        // 16 samples on every 2nd row of 640x480 (2^18 pixels at most) become the full
        // round's least samples (32) on every 4th column of those rows, at the same cost.
        let plan = full_round_plan(&scout, scouted, &[1, 3, 2], 4000, (640, 480), 0).unwrap();
        assert_eq!((plan.row_step, plan.col_step, plan.samples), (2, 2, 32));
        // On 512x512 pixels (2^18), 8 samples on every row become 32 on a quarter of the
        // pixels, every row kept.
        let plan = full_round_plan(&scout, scouted, &[1, 3, 2], 4000, (512, 512), 0).unwrap();
        assert_eq!((plan.row_step, plan.col_step, plan.samples), (1, 4, 32));
        // A GPU keeps 2^16 pixels at the least: on 320x240 (ceiling_room) every one of the
        // 76,800, at four times the cost; on 512x512 a quarter, as a CPU.
        let gpu = full_round_least_pixels("GPU");
        assert_eq!(full_round_least_pixels("CPU"), 0);
        let plan = |size, fill| full_round_plan(&scout, scouted, &[1, 3, 2], 4096, size, fill);
        assert_eq!(plan((320, 240), 0).unwrap(), plan_of(1, 4, 32));
        assert_eq!(plan((320, 240), gpu).unwrap(), plan_of(1, 1, 32));
        assert_eq!(plan((512, 512), gpu), plan((512, 512), 0));
        // A longer render's round has those samples already, on rows alone.
        let plan = full_round_plan(&scout, scouted, &[1, 3, 2], 40_000, (640, 480), 0).unwrap();
        assert_eq!((plan.col_step, plan.samples), (1, 64));
        // A shorter render affords no more than the scouting round: no full round, unless it
        // takes 32 samples where the scouts took 8; not where the render takes no more.
        let deep = plan_of(4, 4, 32);
        assert_eq!(deep.cost(), scouted.cost());
        assert_eq!(
            full_round_plan(&scout, deep, &[1, 3, 2], 600, (640, 480), 0),
            None
        );
        let plan = full_round_plan(&scout, scouted, &[1, 3, 2], 600, (640, 480), 0).unwrap();
        assert_eq!(plan.samples, 32);
        assert_eq!(
            full_round_plan(&scout, scouted, &[1, 3, 2], 32, (64, 48), 0),
            None
        );
        assert_eq!(
            full_round_plan(&scout, scouted, &[2], 4000, (640, 480), 0),
            None
        );
        // Nor one that would take less than twice the scouts' samples: at 1200 samples 3
        // samples' worth each, 8 samples on every third row (2.7 against the scouts' 2),
        // where both take 32.
        assert_eq!(
            full_round_plan(&scout, deep, &[1, 3, 2], 1200, (640, 480), 0),
            None
        );
        // Merged: the full round's figures for the survivors, the scouts' for the dropped.
        let full = Choice {
            measured: vec![
                measured(true, 1.0, 0.9, 0.01),
                measured(false, 1.0, 1.6, 0.01),
                measured(false, 1.0, 1.0, 0.01),
            ],
            chosen: 0,
            seconds: 2.0,
            pixels: 100.0,
            film_samples: 0,
        };
        let merged = Choice::merge(&scout, &[1, 3, 2], full);
        assert_eq!(merged.chosen, 1);
        assert!(merged.measured[0].dropped && !merged.measured[1].dropped);
        assert_eq!(merged.measured[1].relative_variance, 0.9);
        assert_eq!(merged.measured[3].relative_variance, 1.6);
        assert_eq!(merged.seconds, 2.0);
    }

    #[test]
    fn a_cpus_rounds_take_the_full_rounds_samples() {
        // A CPU's rounds take 32 samples at the least, on pixels thinned out alike: every 4th
        // row at 8 samples keeps its rows and every 4th column at 32; an image narrower than
        // that thins its rows for the rest; never fewer than one row or column; more than 8
        // rows in whole groups of 8.
        assert_eq!(
            (least_trial_samples("CPU"), least_trial_samples("GPU")),
            (32, 8)
        );
        let plan = plan_of;
        let size = (160, 120);
        // 30 rows become 24 (whole work-groups of 8 rows), the columns every 3rd to make up.
        assert_eq!(with_least_samples(plan(4, 1, 8), 32, size), plan(5, 3, 32));
        // 9 rows become 8.
        assert_eq!(
            with_least_samples(plan(13, 1, 8), 32, size),
            plan(15, 4, 32)
        );
        // 2 rows of 40 columns become 6 of 14 (fewer than 4 rows: spread_rows).
        assert_eq!(
            with_least_samples(plan(80, 1, 8), 32, size),
            plan(20, 12, 32)
        );
        // A 1280x720 round at a CPU's floor (2^13 paths: 8 samples on one row), which kept the
        // middle row alone: 8 rows of 40 columns.
        let floor = time_limited_scout_plan((1280, 720), scouting("CPU"));
        assert_eq!(floor, plan(720, 1, 8));
        let spread = with_least_samples(floor, 32, (1280, 720));
        assert_eq!(spread, plan(90, 32, 32));
        assert_eq!(trial_rows(spread.row_step, 720), 8);
        // An image of 2 rows keeps them; one column cannot give way to rows.
        assert_eq!(
            with_least_samples(plan(1, 1, 8), 32, (160, 2)),
            plan(1, 4, 32)
        );
        assert_eq!(
            with_least_samples(plan(120, 1, 8), 32, (1, 120)),
            plan(120, 1, 32)
        );
        assert_eq!(with_least_samples(plan(1, 1, 8), 64, size), plan(1, 8, 64));
        assert_eq!(
            with_least_samples(plan(4, 1, 8), 32, (3, 120)),
            plan(5, 3, 32)
        );
        assert_eq!(
            with_least_samples(plan(4, 1, 8), 32, (1, 2)),
            plan(2, 1, 32)
        );
        assert_eq!(with_least_samples(plan(2, 1, 48), 32, size), plan(2, 1, 48));
        assert_eq!(with_least_samples(plan(3, 1, 8), 8, size), plan(3, 1, 8));
        assert_eq!(plan(4, 4, 32).cost(), plan(4, 1, 8).cost());
    }

    #[test]
    fn candidates_are_timed_against_each_other_part_by_part() {
        let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);
        // Two candidates at 0.1 and 0.2 s a sample on three parts of 4, 3 and 3 samples; the
        // second part slowed for both, the third for the second candidate alone.
        let timed = [
            vec![(0.4, 4), (0.6, 3), (0.3, 3)],
            vec![(0.8, 4), (1.2, 3), (1.5, 3)],
        ];
        let expected = [1.0, 2.0];
        assert!(close(&robust_seconds(&timed, 10), &expected));
        // Parts of unlike cost (the second part's samples twice as dear): the same.
        let timed = [vec![(0.4, 4), (0.6, 3)], vec![(0.8, 4), (1.2, 3)]];
        assert!(close(&robust_seconds(&timed, 10), &expected));
        // One part: its seconds; no rows: the parts' seconds.
        assert!(close(&robust_seconds(&[vec![(0.7, 10)]], 10), &[0.7]));
        assert_eq!(robust_seconds(&[vec![(0.0, 0)]], 0), [0.0]);
        assert_eq!((timing_parts("CPU"), timing_parts("GPU")), (5, 1));
    }

    #[test]
    fn a_cpus_trial_rows_fill_whole_work_groups() {
        for height in [1, 7, 8, 9, 17, 90, 120, 1080, 4098] {
            for step in [1, 2, 3, 5, 13, 40, 500] {
                let rows = trial_rows(step, height);
                let (aligned, factor) = rows_in_whole_groups(step, height);
                let now = trial_rows(aligned, height);
                let possible = (1..=height).any(|s| {
                    let n = trial_rows(s, height);
                    n.is_multiple_of(8) && n.abs_diff(rows) <= rows / 4
                });
                assert!(
                    now <= 8 || now.is_multiple_of(8) || !possible,
                    "{height} rows, step {step}: {now} rows"
                );
                // The nearest whole groups, never more than a quarter off; at most a group's
                // rows untouched.
                if rows <= 8 {
                    assert_eq!((aligned, factor), (step, 1.0));
                } else {
                    assert_eq!(factor, f64::from(now) / f64::from(rows));
                    assert!(now.abs_diff(rows) <= rows / 4, "{rows} became {now}");
                }
            }
        }
        assert_eq!(trial_rows(13, 120), 9);
        assert_eq!(rows_in_whole_groups(13, 120), (15, 8.0 / 9.0));
    }

    #[test]
    fn a_round_in_parts_shares_its_samples_alike() {
        assert_eq!(
            sample_parts(32, 5),
            [(0, 6), (6, 12), (12, 19), (19, 25), (25, 32)]
        );
        assert_eq!(sample_parts(33, 3), [(0, 11), (11, 22), (22, 33)]);
        // One part: the whole round.
        assert_eq!(sample_parts(32, 1), [(0, 32)]);
        assert_eq!(sample_parts(8, 5), [(0, 1), (1, 3), (3, 4), (4, 6), (6, 8)]);
        // Never more parts than samples.
        assert_eq!(sample_parts(2, 5), [(0, 1), (1, 2)]);
    }

    #[test]
    fn a_full_round_takes_more_samples_on_fewer_rows() {
        let plan = |budget, step| {
            let p = plan_on_rows(budget, step, 1080);
            (p.row_step, p.samples)
        };
        // 15 samples' worth on every 3rd row: 40 samples (45 in whole groups of 8).
        assert_eq!(plan(15.0, 3), (3, 40));
        // Past 64 samples the rows grow closer: 40 samples' worth on every 3rd row would be
        // 120 samples, so every row takes 40, and 20 samples' worth on every 5th row 56 on
        // every 3rd.
        assert_eq!(plan(40.0, 3), (1, 40));
        assert_eq!(plan(20.0, 5), (3, 56));
        assert_eq!(plan(1000.0, 4), (1, 64));
        // Less than 8 samples on those rows: fewer rows.
        assert_eq!(plan(1.0, 3), (8, 8));
    }

    #[test]
    fn scouting_takes_a_share_of_short_renders_but_enough_paths() {
        let on = |kind, spp, width, height| {
            let p = scout_plan(4, spp, (width, height), scouting(kind));
            (p.row_step, p.samples)
        };
        let (gpu, cpu) = (|s, w, h| on("GPU", s, w, h), |s, w, h| on("CPU", s, w, h));
        // 256 samples, four candidates: 1% is 0.64 samples' worth each: 8 samples on every
        // 13th row.
        assert_eq!(gpu(Some(256), 1920, 1080), (13, 8));
        // ...but never fewer than 2^20 paths a candidate on a GPU: at 64 samples, 0.51
        // samples' worth (every 16th row), not 0.16.
        assert_eq!(gpu(Some(64), 1920, 1080), (16, 8));
        assert_eq!(gpu(Some(16), 4000, 4000), (123, 8));
        // A long render on a CPU: 8 samples on every fourth row's worth, on 2^18 pixels where
        // the image has more: 24 samples on every 15th row of 2560x1440.
        assert_eq!(cpu(Some(100_000), 2560, 1440), (15, 24));
        assert_eq!(cpu(None, 2560, 1440), (15, 24));
        assert_eq!(cpu(Some(100_000), 1024, 768), (4, 8));
        assert_eq!(cpu(Some(100_000), 320, 240), (4, 8));
        // A GPU's: 8 samples on about 2^19 pixels, every row of a smaller image: every 8th
        // row of 2560x1440, every 2nd of 1280x720 (meshes at 2048 samples: 5.12 samples'
        // worth a candidate) and of 1024x768, every row of 320x240.
        assert_eq!(gpu(Some(100_000), 2560, 1440), (8, 8));
        assert_eq!(gpu(None, 2560, 1440), (8, 8));
        assert_eq!(gpu(Some(2048), 1280, 720), (2, 8));
        assert_eq!(gpu(Some(100_000), 1024, 768), (2, 8));
        assert_eq!(gpu(Some(100_000), 320, 240), (1, 8));
        // A CPU's floor is 2^13 paths: 1% of 256 samples at 160x120 (every 13th row, where a
        // GPU's floor takes every row), 0.57 samples' worth at 64 on 160x90, not 0.16.
        assert_eq!(gpu(Some(256), 160, 120), (1, 8));
        assert_eq!(cpu(Some(256), 160, 120), (13, 8));
        assert_eq!(cpu(Some(64), 160, 90), (15, 8));
        assert_eq!(scouting("GPU").min_paths, MIN_SCOUT_PATHS);
        assert_eq!(scouting("CPU").min_paths, MIN_SCOUT_PATHS_CPU);
        // A GPU launches a round's rows at once, a CPU two work-groups' first.
        assert_eq!(first_trial_launch("GPU", 360), 360);
        assert_eq!(first_trial_launch("CPU", 360), 16);
    }

    #[test]
    fn a_gpu_times_a_narrower_full_round_by_its_scouts() {
        // meshes at 1280x720: scouts on every 2nd row (460,800 pixels), a full round of 32
        // samples on 2^16 of them or more.
        let size = (1280, 720);
        let scouts = plan_of(2, 1, 8);
        let full =
            with_least_samples_on(plan_of(2, 1, 8), 32, size, full_round_least_pixels("GPU"));
        assert!(full.pixels(size) < scouts.pixels(size), "{full:?}");
        assert!(times_by_scouts("GPU", scouts, full, size));
        assert!(!times_by_scouts("CPU", scouts, full, size));
        // Every pixel of 320x240 in both (ceiling_room): the full round's own timings.
        let all = plan_of(1, 1, 32);
        assert!(!times_by_scouts("GPU", plan_of(1, 1, 8), all, (320, 240)));
    }

    #[test]
    fn a_time_limited_render_sizes_its_trial_by_the_samples_it_affords() {
        // 10 s at 2 us a path on 1280x720: 5 samples a pixel; never fewer than 1, nor
        // non-finite (an unmeasured or instant candidate).
        assert_eq!(samples_within(10.0, 2e-6, 1280.0 * 720.0), 5);
        assert_eq!(samples_within(0.01, 2e-6, 1280.0 * 720.0), 1);
        assert_eq!(samples_within(-1.0, 2e-6, 1280.0 * 720.0), 1);
        assert_eq!(samples_within(10.0, 0.0, 1280.0 * 720.0), 1);
        assert_eq!(samples_within(10.0, f64::NAN, 100.0), 1);
        assert_eq!(samples_within(1e9, 1e-9, 1.0), u32::MAX >> 1);
        // Its first round: about the device's floor of paths (the row step rounded up: the
        // GPU's 2^20 become every 8th row of 720, 0.88 of it), where the widest scouting round
        // (8 samples on every 4th row) had cost a CPU 2^21 paths a candidate at 1280x720.
        for (kind, paths) in [("CPU", 1 << 13), ("GPU", 1 << 20)] {
            let plan = time_limited_scout_plan((1280, 720), scouting(kind));
            let traced = plan.cost() * 1280.0 * 720.0;
            assert!(
                traced >= 0.75 * f64::from(paths) && traced < 1.5 * f64::from(paths),
                "{plan:?}"
            );
        }
        let widest = scout_plan(4, None, (1280, 720), scouting("CPU"));
        assert_eq!(widest.cost() * 1280.0 * 720.0, 1280.0 * 180.0 * 8.0);
    }
}
