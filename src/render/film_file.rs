//! The film file: everything a render accumulated, as one OpenEXR file that ordinary viewers open
//! as the mean image and that clpt can read back bit for bit (to continue or merge a render).
//!
//! One part, its channels sorted by name: `R`, `G`, `B` the mean radiance (what a viewer shows);
//! `film.sum.{R,G,B}` and `film.sum_lo.{R,G,B}` the compensated sum of the samples (the device's
//! double-float pair, kernels/pathtracer.cl `add_compensated`), `film.sum_sq.*` the sum of their
//! squares, `film.odd.*` and `film.odd_lo.*` the compensated sum of the odd groups of four (the
//! error estimate's second half), all f32 as on the device; `film.bad` and `film.bad_first` (u32)
//! the non-finite samples counted per pixel and the first one's index. Every pixel holds the
//! same samples: their range is metadata. Rows run top to bottom, as in every EXR file.
//!
//! Metadata, as text attributes of the part: `clpt.version`, `clpt.scene` (the path) and
//! `clpt.scene_fingerprint` (of its bytes), `clpt.options` (every setting that changes the
//! image), `clpt.seed`, `clpt.samples` (`START..END`), `clpt.device`, `clpt.seconds`.

use super::RenderOptions;
use super::film::Film;
use super::strategy::Strategy;
use crate::error::{Error, Result};
use exr::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// What a film file says about the render that made it.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmMeta {
    pub version: String,
    pub scene: String,
    pub scene_fingerprint: String,
    pub options: String,
    pub seed: u64,
    /// Sample indices `start..end` every pixel holds.
    pub samples: (u32, u32),
    pub device: String,
    pub seconds: f64,
}

impl FilmMeta {
    /// The metadata of a render of `scene_file` (None: the built-in scene) with `options`,
    /// whose trial chose `strategy`, holding samples `samples` after `seconds` on `device`.
    /// The options string names every setting that changes the image.
    pub fn of_render(
        scene_file: Option<&Path>,
        options: &RenderOptions,
        strategy: Strategy,
        size: (u32, u32),
        samples: (u32, u32),
        device: &str,
        seconds: f64,
    ) -> Result<FilmMeta> {
        let (scene, bytes) = match scene_file {
            Some(p) => (
                p.display().to_string(),
                std::fs::read(p).map_err(|e| Error::Read {
                    path: p.to_path_buf(),
                    source: e,
                })?,
            ),
            None => (
                crate::scene::builtin::NAME.to_string(),
                crate::scene::builtin::NAME.as_bytes().to_vec(),
            ),
        };
        Ok(FilmMeta {
            version: env!("CARGO_PKG_VERSION").to_string(),
            scene,
            scene_fingerprint: crate::device::cache::fingerprint(&[&bytes]),
            options: format!(
                "{}x{}; light sampling {}; rr_threshold {}; rr_depth {}; max_depth {}; \
                 texture filter {:?}",
                size.0,
                size.1,
                strategy.light_sampling,
                strategy.rr_threshold,
                options.rr_depth,
                options.max_depth,
                options.texture_filter,
            ),
            seed: options.seed,
            samples,
            device: device.to_string(),
            seconds,
        })
    }
}

impl FilmMeta {
    /// The strategy its options name (`light sampling B; rr_threshold T`, as [`Self::of_render`]
    /// writes them).
    pub fn strategy(&self) -> Option<Strategy> {
        let field = |key: &str| {
            self.options
                .split("; ")
                .find_map(|part| part.strip_prefix(key))
                .map(str::trim)
        };
        Some(Strategy {
            light_sampling: field("light sampling ")?.parse().ok()?,
            rr_threshold: field("rr_threshold ")?.parse().ok()?,
        })
    }

    /// Whether a render described by `expected` (this clpt, this scene file, these options,
    /// with this film's strategy) may continue this film: the reason when not.
    pub fn check_continues(&self, expected: &FilmMeta) -> std::result::Result<(), String> {
        let differs = |what: &str, film: &dyn std::fmt::Display, now: &dyn std::fmt::Display| {
            Err(format!(
                "it was rendered with {what} {film}, this render has {now}"
            ))
        };
        if self.version != expected.version {
            return differs("clpt", &self.version, &expected.version);
        }
        if self.scene_fingerprint != expected.scene_fingerprint {
            return Err(format!(
                "it is a film of another scene ({}, or that file since changed)",
                self.scene
            ));
        }
        if self.seed != expected.seed {
            return differs("seed", &self.seed, &expected.seed);
        }
        if self.options != expected.options {
            return differs("options", &self.options, &expected.options);
        }
        if self.samples.0 != expected.samples.0 {
            return Err(format!(
                "it holds samples {}..{}, this render starts at sample {}",
                self.samples.0, self.samples.1, expected.samples.0
            ));
        }
        Ok(())
    }
}

/// The device's film, pixel for pixel (row 0 at the bottom, as the device keeps it): float4
/// sums (.w unused) and the non-finite counters.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmState {
    pub width: u32,
    pub height: u32,
    pub sum: Vec<[f32; 4]>,
    pub sum_lo: Vec<[f32; 4]>,
    pub sum_sq: Vec<[f32; 4]>,
    pub sum_odd: Vec<[f32; 4]>,
    pub sum_odd_lo: Vec<[f32; 4]>,
    pub bad: Vec<u32>,
    pub bad_first: Vec<u32>,
}

const SUMS: [&str; 5] = ["sum", "sum_lo", "sum_sq", "odd", "odd_lo"];
const RGB: [&str; 3] = ["R", "G", "B"];

fn invalid(path: &Path, message: impl std::fmt::Display) -> Error {
    Error::Invalid(format!("film file {}: {message}", path.display()))
}

impl FilmState {
    fn sums(&self) -> [&Vec<[f32; 4]>; 5] {
        [
            &self.sum,
            &self.sum_lo,
            &self.sum_sq,
            &self.sum_odd,
            &self.sum_odd_lo,
        ]
    }

    /// The error of the mean image of `spp` samples (from a multiple of 8) estimated from the
    /// film alone, in f64: the formula of kernels/pathtracer.cl `error_rows` (the even and odd
    /// groups' means differ by the error's spread; squared, times n_even n_odd / n², they
    /// estimate the variance of the mean). For films that never were on a device (`clpt
    /// merge`); tests/resume.rs checks it against the kernel's figure.
    pub fn estimated_error(&self, spp: u32) -> super::ErrorEstimate {
        let n = f64::from(spp);
        let rest = spp % 8;
        let n_odd = f64::from((spp / 8) * 4 + rest.saturating_sub(4));
        let n_even = n - n_odd;
        let k = n_even * n_odd / (n * n);
        let eps = f64::from(super::metrics::REL_EPSILON);
        let (mut est, mut rel) = (0.0, 0.0);
        for i in 0..self.sum.len() {
            for c in 0..3 {
                let all = f64::from(self.sum[i][c]) + f64::from(self.sum_lo[i][c]);
                let odd = f64::from(self.sum_odd[i][c]) + f64::from(self.sum_odd_lo[i][c]);
                let mean = all / n;
                let diff = (all - odd) / n_even - odd / n_odd;
                let var = diff * diff * k;
                est += var;
                rel += var / (mean * mean + eps);
            }
        }
        let count = 3.0 * self.sum.len() as f64;
        super::ErrorEstimate {
            rmse: (est / count).sqrt(),
            relmse: rel / count,
        }
    }

    /// The film these sums make after `spp` samples: its sum the pair added in f64.
    pub fn film(&self, spp: u32) -> Film {
        Film {
            width: self.width,
            height: self.height,
            spp,
            sum: self
                .sum
                .iter()
                .zip(&self.sum_lo)
                .map(|(h, l)| std::array::from_fn(|c| (f64::from(h[c]) + f64::from(l[c])) as f32))
                .collect(),
            sum_sq: self.sum_sq.clone(),
        }
    }

    /// The index of pixel `i` of the file (top row first) in the device's order.
    fn device_index(&self, i: usize) -> usize {
        let (w, h) = (self.width as usize, self.height as usize);
        (h - 1 - i / w) * w + i % w
    }

    /// Writes the film file atomically (crate::output).
    pub fn write(&self, path: &Path, meta: &FilmMeta) -> Result<()> {
        let n = self.width as usize * self.height as usize;
        let film = self.film(meta.samples.1 - meta.samples.0);
        let top_down = |i: usize| self.device_index(i);
        let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
        for (c, name) in RGB.iter().enumerate() {
            let mean: Vec<f32> = (0..n)
                .map(|i| {
                    let d = top_down(i);
                    film.mean(d as u32 % self.width, d as u32 / self.width)[c] as f32
                })
                .collect();
            channels.push(AnyChannel::new(*name, FlatSamples::F32(mean)));
        }
        for (sum, prefix) in self.sums().into_iter().zip(SUMS) {
            for (c, name) in RGB.iter().enumerate() {
                let values = (0..n).map(|i| sum[top_down(i)][c]).collect();
                channels.push(AnyChannel::new(
                    format!("film.{prefix}.{name}").as_str(),
                    FlatSamples::F32(values),
                ));
            }
        }
        for (counter, name) in [(&self.bad, "film.bad"), (&self.bad_first, "film.bad_first")] {
            let values = (0..n).map(|i| counter[top_down(i)]).collect();
            channels.push(AnyChannel::new(name, FlatSamples::U32(values)));
        }
        let mut attributes = LayerAttributes::default();
        for (key, value) in [
            ("clpt.version", meta.version.clone()),
            ("clpt.scene", meta.scene.clone()),
            ("clpt.scene_fingerprint", meta.scene_fingerprint.clone()),
            ("clpt.options", meta.options.clone()),
            ("clpt.seed", meta.seed.to_string()),
            (
                "clpt.samples",
                format!("{}..{}", meta.samples.0, meta.samples.1),
            ),
            ("clpt.device", meta.device.clone()),
            ("clpt.seconds", meta.seconds.to_string()),
        ] {
            // EXR text is 8-bit; anything past ASCII (a path's accents) becomes `?`.
            let ascii: String = value
                .chars()
                .map(|c| if c.is_ascii() { c } else { '?' })
                .collect();
            attributes.other.insert(
                Text::from(key),
                AttributeValue::Text(Text::from(ascii.as_str())),
            );
        }
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            attributes,
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(channels.into()),
        );
        let image = Image::from_layer(layer);
        crate::output::write_atomically(path, |out| {
            image.write().to_buffered(out).map_err(|e| e.to_string())
        })
    }

    /// Reads a film file that clpt wrote: its film, bit for bit, and its metadata.
    pub fn read(path: &Path) -> Result<(FilmState, FilmMeta)> {
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .from_file(path)
            .map_err(|e| invalid(path, e))?;
        let layer = &image.layer_data;
        let (width, height) = (layer.size.width(), layer.size.height());
        let n = width * height;
        let channel = |name: &str| {
            layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name == *name)
                .map(|c| &c.sample_data)
                .ok_or_else(|| invalid(path, format!("no channel `{name}`: not a clpt film")))
        };
        let mut state = FilmState {
            width: u32::try_from(width).map_err(|_| invalid(path, "too wide"))?,
            height: u32::try_from(height).map_err(|_| invalid(path, "too tall"))?,
            sum: vec![[0.0; 4]; n],
            sum_lo: vec![[0.0; 4]; n],
            sum_sq: vec![[0.0; 4]; n],
            sum_odd: vec![[0.0; 4]; n],
            sum_odd_lo: vec![[0.0; 4]; n],
            bad: vec![0; n],
            bad_first: vec![0; n],
        };
        for (s, prefix) in SUMS.into_iter().enumerate() {
            for (c, name) in RGB.iter().enumerate() {
                let FlatSamples::F32(values) = channel(&format!("film.{prefix}.{name}"))? else {
                    return Err(invalid(path, format!("film.{prefix}.{name} is not f32")));
                };
                for (i, &v) in values.iter().enumerate() {
                    let d = state.device_index(i);
                    let target = match s {
                        0 => &mut state.sum,
                        1 => &mut state.sum_lo,
                        2 => &mut state.sum_sq,
                        3 => &mut state.sum_odd,
                        _ => &mut state.sum_odd_lo,
                    };
                    target[d][c] = v;
                }
            }
        }
        for (k, name) in ["film.bad", "film.bad_first"].into_iter().enumerate() {
            let FlatSamples::U32(values) = channel(name)? else {
                return Err(invalid(path, format!("{name} is not u32")));
            };
            for (i, &v) in values.iter().enumerate() {
                let d = state.device_index(i);
                if k == 0 {
                    state.bad[d] = v;
                } else {
                    state.bad_first[d] = v;
                }
            }
        }
        let attributes: &HashMap<Text, AttributeValue> = &layer.attributes.other;
        let text = |key: &str| -> Result<String> {
            match attributes.get(&Text::from(key)) {
                Some(AttributeValue::Text(t)) => Ok(t.to_string()),
                _ => Err(invalid(path, format!("no `{key}`: not a clpt film"))),
            }
        };
        let number = |key: &str| -> Result<u64> {
            text(key)?
                .parse()
                .map_err(|_| invalid(path, format!("`{key}` is not a number")))
        };
        let samples = text("clpt.samples")?;
        let range = samples
            .split_once("..")
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .filter(|(a, b): &(u32, u32)| a <= b)
            .ok_or_else(|| invalid(path, format!("`clpt.samples` {samples} is not START..END")))?;
        let meta = FilmMeta {
            version: text("clpt.version")?,
            scene: text("clpt.scene")?,
            scene_fingerprint: text("clpt.scene_fingerprint")?,
            options: text("clpt.options")?,
            seed: number("clpt.seed")?,
            samples: range,
            device: text("clpt.device")?,
            seconds: text("clpt.seconds")?
                .parse()
                .map_err(|_| invalid(path, "`clpt.seconds` is not a number"))?,
        };
        Ok((state, meta))
    }
}
