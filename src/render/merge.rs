//! Merging films (issue 13): shards of one render, each a film file of a range of sample
//! indices (`clpt render --shard I/N` or `--samples A..B`), joined into the film of the whole
//! range.
//!
//! Why it is the render of the whole range: every random number is a function of (seed, pixel,
//! sample, dimension), so the shards trace exactly the paths one run would, and a pixel's sum
//! over the range is the sum of the shards' sums. Each shard's sums are compensated pairs
//! (hi + lo, kernels/pathtracer.cl `add_compensated`) within about 1e-7 of their exact value;
//! the pairs are added in f64 and split into a pair again, so the merged film is as exact as
//! one run's (its mean image may differ from one run's in the last bit of f32). Ranges start at
//! multiples of 8, so each shard's even and odd groups of four are whole and the merged odd sum
//! is the odd half of the whole range: the error estimate carries over.

use super::film_file::{FilmMeta, FilmState};
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// A film file read for merging.
pub struct Part {
    pub path: PathBuf,
    pub state: FilmState,
    pub meta: FilmMeta,
}

impl Part {
    pub fn read(path: &Path) -> Result<Part> {
        let (state, meta) = FilmState::read(path)?;
        Ok(Part {
            path: path.to_path_buf(),
            state,
            meta,
        })
    }
}

fn refuse(message: String) -> Error {
    Error::Invalid(format!("cannot merge: {message}"))
}

/// The film of the parts' joined ranges, and its metadata (the seconds and devices of all).
/// Refused, with the reason: parts of another clpt version, scene, seed, options or size than
/// the first; overlapping ranges; and gaps between them (named).
pub fn merge(mut parts: Vec<Part>) -> Result<(FilmState, FilmMeta)> {
    let Some(first) = parts.first() else {
        return Err(refuse("no films given".into()));
    };
    for p in &parts[1..] {
        let differs = |what: &str| {
            refuse(format!(
                "{} has another {what} than {}",
                p.path.display(),
                first.path.display()
            ))
        };
        if p.meta.version != first.meta.version {
            return Err(differs("clpt version"));
        }
        if p.meta.scene_fingerprint != first.meta.scene_fingerprint {
            return Err(differs("scene"));
        }
        if p.meta.seed != first.meta.seed {
            return Err(differs("seed"));
        }
        if p.meta.options != first.meta.options {
            return Err(differs(
                "option set (size, estimator, depths or texture filter)",
            ));
        }
    }
    parts.sort_by_key(|p| p.meta.samples);
    for pair in parts.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let (ra, rb) = (a.meta.samples, b.meta.samples);
        if rb.0 < ra.1 {
            return Err(refuse(format!(
                "{} (samples {}..{}) and {} (samples {}..{}) overlap",
                a.path.display(),
                ra.0,
                ra.1,
                b.path.display(),
                rb.0,
                rb.1
            )));
        }
        if rb.0 > ra.1 {
            return Err(refuse(format!(
                "samples {}..{} are missing between {} and {}",
                ra.1,
                rb.0,
                a.path.display(),
                b.path.display()
            )));
        }
    }
    let mut total = Accumulator::new(parts[0].state.width, parts[0].state.height);
    for p in &parts {
        total.add(&p.state);
    }
    let out = total.film();
    let mut devices: Vec<&str> = Vec::new();
    for p in &parts {
        if !devices.contains(&p.meta.device.as_str()) {
            devices.push(&p.meta.device);
        }
    }
    let meta = FilmMeta {
        samples: (
            parts[0].meta.samples.0,
            parts[parts.len() - 1].meta.samples.1,
        ),
        device: devices.join(", "),
        seconds: parts.iter().map(|p| p.meta.seconds).sum(),
        ..parts[0].meta.clone()
    };
    Ok((out, meta))
}

/// Films of disjoint sample sets of one render added up: each pixel's compensated pairs
/// (hi + lo) summed in f64 (exact to about 1e-16 of the sum, far below the pairs' own 1e-7),
/// the squares in f64, the non-finite counts added and the first such sample the least.
pub struct Accumulator {
    width: u32,
    height: u32,
    sum: Vec<[f64; 4]>,
    odd: Vec<[f64; 4]>,
    sq: Vec<[f64; 4]>,
    bad: Vec<u32>,
    bad_first: Vec<u32>,
}

impl Accumulator {
    pub fn new(width: u32, height: u32) -> Accumulator {
        let n = width as usize * height as usize;
        Accumulator {
            width,
            height,
            sum: vec![[0.0; 4]; n],
            odd: vec![[0.0; 4]; n],
            sq: vec![[0.0; 4]; n],
            bad: vec![0; n],
            bad_first: vec![0; n],
        }
    }

    /// Adds a film of the same size.
    pub fn add(&mut self, s: &FilmState) {
        for i in 0..self.sum.len() {
            for c in 0..4 {
                self.sum[i][c] += f64::from(s.sum[i][c]) + f64::from(s.sum_lo[i][c]);
                self.odd[i][c] += f64::from(s.sum_odd[i][c]) + f64::from(s.sum_odd_lo[i][c]);
                self.sq[i][c] += f64::from(s.sum_sq[i][c]);
            }
            if s.bad[i] > 0 {
                self.bad_first[i] = if self.bad[i] == 0 {
                    s.bad_first[i]
                } else {
                    self.bad_first[i].min(s.bad_first[i])
                };
                self.bad[i] = self.bad[i].saturating_add(s.bad[i]);
            }
        }
    }

    /// The sums as a film: each f64 sum back into a pair, hi its nearest f32 and lo the rest's.
    pub fn film(&self) -> FilmState {
        let split = |v: f64| {
            let hi = v as f32;
            (hi, (v - f64::from(hi)) as f32)
        };
        let n = self.sum.len();
        let mut out = FilmState {
            width: self.width,
            height: self.height,
            sum: vec![[0.0; 4]; n],
            sum_lo: vec![[0.0; 4]; n],
            sum_sq: vec![[0.0; 4]; n],
            sum_odd: vec![[0.0; 4]; n],
            sum_odd_lo: vec![[0.0; 4]; n],
            bad: self.bad.clone(),
            bad_first: self.bad_first.clone(),
        };
        for i in 0..n {
            for c in 0..4 {
                (out.sum[i][c], out.sum_lo[i][c]) = split(self.sum[i][c]);
                (out.sum_odd[i][c], out.sum_odd_lo[i][c]) = split(self.odd[i][c]);
                out.sum_sq[i][c] = self.sq[i][c] as f32;
            }
        }
        out
    }
}

/// Samples `A..B` (`--samples`): A a multiple of 8, B past it.
pub fn parse_samples(text: &str) -> std::result::Result<(u32, u32), String> {
    let (a, b) = text
        .split_once("..")
        .and_then(|(a, b)| Some((a.trim().parse::<u32>().ok()?, b.trim().parse::<u32>().ok()?)))
        .ok_or_else(|| format!("--samples `{text}`: use START..END, as in 0..256"))?;
    if !a.is_multiple_of(8) {
        return Err(format!(
            "--samples {a}..{b}: the start must be a multiple of 8 (shards hold whole groups of eight samples)"
        ));
    }
    if b <= a {
        return Err(format!(
            "--samples {a}..{b}: the end must come after the start"
        ));
    }
    Ok((a, b))
}

/// Shard `i` of `n` (`--shard I/N`, I from 1) of a render of `total` samples per pixel: the
/// samples split in whole groups of eight, as evenly as they go (the last group may be short).
pub fn shard_range(text: &str, total: u32) -> std::result::Result<(u32, u32), String> {
    let (i, n) = text
        .split_once('/')
        .and_then(|(i, n)| Some((i.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)))
        .filter(|&(i, n)| i >= 1 && i <= n)
        .ok_or_else(|| format!("--shard `{text}`: use I/N with 1 <= I <= N, as in 2/4"))?;
    let groups = u64::from(total.div_ceil(8));
    let (g0, g1) = (
        groups * u64::from(i - 1) / u64::from(n),
        groups * u64::from(i) / u64::from(n),
    );
    if g0 == g1 {
        return Err(format!(
            "--shard {i}/{n}: {total} samples make {groups} groups of eight, too few for {n} shards"
        ));
    }
    let end = (g1 * 8).min(u64::from(total));
    Ok(((g0 * 8) as u32, end as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_the_samples_in_whole_groups_of_eight() {
        assert_eq!(parse_samples("8..100"), Ok((8, 100)));
        assert!(parse_samples("4..100").is_err() && parse_samples("16..16").is_err());
        assert!(parse_samples("x").is_err());
        for (total, n) in [(64, 4), (100, 3), (8, 1), (1000, 7)] {
            let ranges: Vec<(u32, u32)> = (1..=n)
                .map(|i| shard_range(&format!("{i}/{n}"), total).unwrap())
                .collect();
            assert_eq!(ranges[0].0, 0);
            assert_eq!(ranges[ranges.len() - 1].1, total);
            for w in ranges.windows(2) {
                assert_eq!(w[0].1, w[1].0, "{ranges:?}");
                assert_eq!(w[1].0 % 8, 0);
            }
        }
        assert_eq!(shard_range("2/4", 64), Ok((16, 32)));
        assert!(shard_range("3/2", 64).is_err() && shard_range("0/2", 64).is_err());
        assert!(shard_range("1/5", 16).is_err(), "two groups, five shards");
    }
}
