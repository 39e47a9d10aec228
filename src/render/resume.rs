//! Checkpoints and resume (issue 13): a render's film written as a film file
//! ([`film_file`](super::film_file)) while it runs, and a later render that continues it.
//!
//! Why it is exact: every random number is a function of (seed, pixel, sample, dimension), and
//! the kernel adds samples one at a time onto the film's sums, so a render that loads the film
//! of samples 0 .. n bit for bit and goes on from sample n with the same strategy traces exactly
//! the paths, and adds exactly the numbers, that an uninterrupted render would. What may not
//! differ is checked before any work ([`read_for_resume`]): the clpt version (the kernels), the
//! scene file's bytes, the seed, every option that changes the image, and the strategy (a
//! resumed render runs the checkpoint's and skips the trial).

use super::film_file::{FilmMeta, FilmState};
use super::strategy::{LightSampling, Roulette, Strategy};
use super::{RenderOptions, Renderer};
use crate::error::{Error, Result};
use std::path::Path;

/// A film to continue, read and checked.
pub struct Checkpoint {
    pub state: FilmState,
    pub meta: FilmMeta,
    /// The strategy that rendered it, which the render continues with.
    pub strategy: Strategy,
}

impl Checkpoint {
    /// Samples per pixel it holds.
    pub fn samples(&self) -> u32 {
        self.meta.samples.1 - self.meta.samples.0
    }

    /// `options` with its strategy fixed to the checkpoint's.
    pub fn fix_strategy(&self, options: &mut RenderOptions) {
        options.pin(self.strategy);
    }
}

/// Reads the film file at `path` and checks that a render of `scene_file` (None: the built-in
/// scene) with `options` at `size` may continue it; the error names the file and the reason.
pub fn read_for_resume(
    path: &Path,
    scene_file: Option<&Path>,
    options: &RenderOptions,
    size: (u32, u32),
) -> Result<Checkpoint> {
    let refuse =
        |reason: String| Error::Invalid(format!("cannot resume from {}: {reason}", path.display()));
    let (state, meta) = FilmState::read(path)?;
    let strategy = meta
        .strategy()
        .ok_or_else(|| refuse(format!("its options `{}` name no strategy", meta.options)))?;
    let pinned = match options.light_sampling {
        LightSampling::On => Some(true),
        LightSampling::Off => Some(false),
        LightSampling::Auto => None,
    };
    if pinned.is_some_and(|on| on != strategy.light_sampling) {
        return Err(refuse(format!(
            "it was rendered with {strategy}, and --light-sampling asks otherwise"
        )));
    }
    if let Roulette::Threshold(t) = options.roulette
        && t != strategy.rr_threshold
    {
        return Err(refuse(format!(
            "it was rendered with {strategy}, and --rr-threshold asks {t}"
        )));
    }
    let first = options.first_sample;
    let expected = FilmMeta::of_render(
        scene_file,
        options,
        strategy,
        size,
        (first, meta.samples.1),
        "",
        0.0,
    )?;
    meta.check_continues(&expected).map_err(refuse)?;
    let held = meta.samples.1 - meta.samples.0;
    if let Some(total) = options.spp
        && total < held
    {
        return Err(refuse(format!(
            "it holds {held} samples per pixel, more than the {total} asked for"
        )));
    }
    Ok(Checkpoint {
        state,
        meta,
        strategy,
    })
}

/// What every film file of one render records besides its film: the scene file, the options,
/// the device, and the seconds spent before this run (a resumed render's earlier runs).
pub struct FilmRecord<'a> {
    pub scene_file: Option<&'a Path>,
    pub options: &'a RenderOptions,
    pub device: &'a str,
    pub seconds_before: f64,
}

impl FilmRecord<'_> {
    /// Writes `renderer`'s film, `samples` samples per pixel of `strategy` (from the options'
    /// first sample) after `seconds` of this run, as a film file at `path` (atomically: an
    /// earlier file stays whole until the new one is complete).
    pub fn write(
        &self,
        path: &Path,
        renderer: &Renderer,
        strategy: Strategy,
        samples: u32,
        seconds: f64,
    ) -> Result<()> {
        self.write_state(
            path,
            &renderer.film_state()?,
            (renderer.width(), renderer.height()),
            strategy,
            samples,
            seconds,
        )
    }

    /// [`Self::write`] for a film held on the host (`state`, of an image of `size`).
    pub fn write_state(
        &self,
        path: &Path,
        state: &FilmState,
        size: (u32, u32),
        strategy: Strategy,
        samples: u32,
        seconds: f64,
    ) -> Result<()> {
        state.write(path, &self.meta(size, strategy, samples, seconds)?)
    }

    /// [`Self::write`] on `writer`'s thread: the film is read back from the device now, and
    /// encoded, written and synced while the render goes on.
    pub fn write_in_background(
        &self,
        writer: &mut BackgroundWriter,
        path: &Path,
        renderer: &Renderer,
        strategy: Strategy,
        samples: u32,
        seconds: f64,
    ) -> Result<()> {
        let size = (renderer.width(), renderer.height());
        let meta = self.meta(size, strategy, samples, seconds)?;
        writer.start(path, renderer.film_state()?, meta)
    }

    /// The metadata of a film of `samples` samples per pixel (from the options' first) after
    /// `seconds` of this run.
    fn meta(
        &self,
        size: (u32, u32),
        strategy: Strategy,
        samples: u32,
        seconds: f64,
    ) -> Result<FilmMeta> {
        let first = self.options.first_sample;
        FilmMeta::of_render(
            self.scene_file,
            self.options,
            strategy,
            size,
            (first, first + samples),
            self.device,
            self.seconds_before + seconds,
        )
    }
}

/// Checkpoints written in the background. Encoding and syncing a film file takes 0.3 to 2.8 s
/// on the H200 machine from 720p to 4K (BENCHMARKS, "Checkpoints"), during which the render
/// waited; now only the read-back waits. One write at a time: the next one, and the end of
/// the render, wait for the one in flight (so an older checkpoint never lands after a newer
/// one), and its error surfaces there.
#[derive(Default)]
pub struct BackgroundWriter {
    pending: Option<std::thread::JoinHandle<Result<()>>>,
}

impl BackgroundWriter {
    /// Waits for the write in flight, then writes `state` with `meta` to `path` on a thread.
    pub fn start(&mut self, path: &Path, state: FilmState, meta: FilmMeta) -> Result<()> {
        self.wait()?;
        let path = path.to_path_buf();
        self.pending = Some(std::thread::spawn(move || state.write(&path, &meta)));
        Ok(())
    }

    /// Waits for the write in flight, if any, and returns its outcome.
    pub fn wait(&mut self) -> Result<()> {
        match self.pending.take() {
            None => Ok(()),
            Some(write) => write.join().unwrap_or_else(|_| {
                Err(Error::Invalid(
                    "the checkpoint writer's thread panicked".into(),
                ))
            }),
        }
    }
}
