//! The strategy trial's statistics on the device (kernels/trial.cl): after each candidate of a
//! round renders, its trial rows of the film are copied into a round buffer on the device;
//! then two reductions give [`choose`](super::strategy::choose) its sums ([`TrialSums`]), a few kilobytes
//! read back where the rows themselves (4 MiB a candidate on 2^18 pixels) and the host's pass
//! over them had cost a fast scene more than the trial's renders.

use super::Rows;
use super::strategy::TrialSums;
use crate::device::Device;
use crate::device::kernel::NamedArgs;
use crate::device::program::{self, BuiltProgram, KernelSources};
use crate::error::{Error, Result};
use std::path::Path;

/// Work-items of a reduction group (a power of two).
const GROUP: u32 = 64;

/// Trial pixels a reduction group sums: each work-item adds 16 in order, the group the 64
/// partial sums as a tree, so a chunk's float sums carry about 22 roundings however large the
/// image (kernels/trial.cl); the host adds the chunks in f64.
const CHUNK: u32 = 1024;

/// The trial's program and kernels, bound to one film's `sum` and `sum_odd` buffers.
pub struct TrialKernels {
    program: BuiltProgram,
    keep: ocl::Kernel,
    totals: ocl::Kernel,
    terms: ocl::Kernel,
    queue: ocl::Queue,
    width: u32,
}

fn fail(what: &'static str) -> impl Fn(ocl::Error) -> Error {
    move |e| Error::opencl(what, e)
}

impl TrialKernels {
    /// Builds kernels/trial.cl (through the program cache at `cache`) for a film `width`
    /// pixels wide held in `film`: its sums `sum`, `sum_odd`, `sum_lo`, `sum_sq` and
    /// `sum_odd_lo` (float4 a pixel each, in that order), of which the trial reads the first
    /// two and clears all five ([`KeptRound::keep`]).
    pub fn new(
        device: &Device,
        sources: &KernelSources,
        cache: Option<&Path>,
        film: [&ocl::Buffer<f32>; 5],
        width: u32,
    ) -> Result<Self> {
        let [sum, sum_odd, sum_lo, sum_sq, sum_odd_lo] = film;
        let defines = [
            ("TRIAL_GROUP", format!("{GROUP}u")),
            ("TRIAL_CHUNK", format!("{CHUNK}u")),
        ];
        let program = program::build_entry(device, sources, "trial.cl", &defines, cache)?;
        let queue = device.queue.clone();
        let keep = NamedArgs::new(&program.program, "trial_keep", &queue)
            .buffer("sum", sum)
            .buffer("sum_odd", sum_odd)
            .buffer("sum_lo", sum_lo)
            .buffer("sum_sq", sum_sq)
            .buffer("sum_odd_lo", sum_odd_lo)
            .scalar("width", width)
            .scalar("row_start", 0u32)
            .scalar("row_step", 1u32)
            .scalar("row_count", 0u32)
            .scalar("slot", 0u32)
            .scalar("col_start", 0u32)
            .scalar("col_step", 1u32)
            .scalar("columns", 0u32)
            .scalar("clear", 0u32)
            .buffer_later::<f32>("kept")
            .build()?;
        let reduction = |name: &'static str, terms: bool| {
            let mut args = NamedArgs::new(&program.program, name, &queue);
            args.buffer_later::<f32>("kept")
                .scalar("pixels", 0u32)
                .scalar("films", 0u32)
                .scalar("samples", 0u32);
            if terms {
                args.buffer_later::<f32>("weights")
                    .scalar("eps", super::metrics::REL_EPSILON);
            }
            args.buffer_later::<f32>("out").build()
        };
        let totals = reduction("trial_totals", false)?;
        let terms = reduction("trial_terms", true)?;
        Ok(TrialKernels {
            program,
            keep,
            totals,
            terms,
            queue,
            width,
        })
    }

    /// The built trial program (for `-v`).
    pub fn program(&self) -> &BuiltProgram {
        &self.program
    }

    /// A round of `films` candidates of `samples` samples a pixel on `rows`: room on the
    /// device for every candidate's rows, zeroed.
    pub fn round(&self, rows: Rows, films: usize, samples: u32) -> Result<KeptRound<'_>> {
        let pixels = rows.columns(self.width) as usize * rows.count as usize;
        let chunks = pixels.div_ceil(CHUNK as usize);
        let bad = fail("allocating the trial's buffers");
        let buffer = |len: usize| {
            ocl::Buffer::<f32>::builder()
                .queue(self.queue.clone())
                .len(len.max(1))
                .build()
                .map_err(&bad)
        };
        let kept = buffer(films * 2 * pixels * 4)?;
        kept.cmd().fill(0.0f32, None).enq().map_err(&bad)?;
        Ok(KeptRound {
            kernels: self,
            rows,
            films,
            samples,
            pixels,
            chunks,
            kept,
            out: buffer(chunks * films * 2)?,
            weights: buffer(films)?,
        })
    }
}

/// One round's kept films on the device.
pub struct KeptRound<'k> {
    kernels: &'k TrialKernels,
    rows: Rows,
    films: usize,
    samples: u32,
    pixels: usize,
    chunks: usize,
    kept: ocl::Buffer<f32>,
    out: ocl::Buffer<f32>,
    weights: ocl::Buffer<f32>,
}

impl KeptRound<'_> {
    /// Trial pixels a candidate rendered.
    pub fn pixels(&self) -> usize {
        self.pixels
    }

    /// Adds the film's trial rows to candidate `slot`'s sums (enqueued: the next command on
    /// the queue sees them): once for a candidate that rendered the round at once, once a part
    /// for one that rendered its samples in parts. With `clear`, the round's pixels of the
    /// film are then zeroed, which is all the clearing the next candidate or part needs where
    /// the round renders only them (render/mod.rs, `trial_round`).
    pub fn keep(&mut self, slot: usize, clear: bool) -> Result<()> {
        assert!(slot < self.films, "slot {slot} of {} films", self.films);
        let rows = self.rows;
        let k = &self.kernels.keep;
        let bad = fail("keeping the trial's rows");
        k.set_arg("row_start", rows.start).map_err(&bad)?;
        k.set_arg("row_step", rows.step).map_err(&bad)?;
        k.set_arg("row_count", rows.count).map_err(&bad)?;
        k.set_arg("slot", slot as u32).map_err(&bad)?;
        let columns = rows.columns(self.kernels.width);
        k.set_arg("col_start", rows.first_column()).map_err(&bad)?;
        k.set_arg("col_step", rows.col_step.max(1)).map_err(&bad)?;
        k.set_arg("columns", columns).map_err(&bad)?;
        k.set_arg("clear", u32::from(clear)).map_err(&bad)?;
        k.set_arg("kept", &self.kept).map_err(&bad)?;
        if rows.count == 0 {
            return Ok(());
        }
        let round_up = |n: u32| n.div_ceil(8) as usize * 8;
        // SAFETY: the film holds every row of the round (the renderer's trial rows lie in the
        // image) and every column it takes (fewer than `columns(width)` steps from the first);
        // `kept` holds `films` slots of the round's pixels (`slot` is below that); the kernel
        // skips padded work-items.
        unsafe {
            k.cmd()
                .global_work_size([round_up(columns), round_up(rows.count)])
                .local_work_size([8, 8])
                .enq()
        }
        .map_err(&bad)
    }

    /// Runs a reduction over the films and adds its chunks' sums in f64, in order: per film,
    /// two sums.
    fn reduce(&self, kernel: &ocl::Kernel) -> Result<Vec<(f64, f64)>> {
        let bad = fail("reducing the trial's rows");
        kernel.set_arg("kept", &self.kept).map_err(&bad)?;
        kernel.set_arg("pixels", self.pixels as u32).map_err(&bad)?;
        kernel.set_arg("films", self.films as u32).map_err(&bad)?;
        kernel.set_arg("samples", self.samples).map_err(&bad)?;
        kernel.set_arg("out", &self.out).map_err(&bad)?;
        let mut sums = vec![(0.0, 0.0); self.films];
        if self.chunks == 0 {
            return Ok(sums);
        }
        // SAFETY: `kept` holds `films` slots of `pixels` pixels (two float4 each), `out` two
        // floats per chunk and film, `weights` one per film; one group a chunk.
        unsafe {
            kernel
                .cmd()
                .global_work_size(self.chunks * GROUP as usize)
                .local_work_size(GROUP as usize)
                .enq()
        }
        .map_err(&bad)?;
        let mut out = vec![0.0f32; self.chunks * self.films * 2];
        self.out.read(&mut out).enq().map_err(&bad)?;
        for chunk in out.chunks_exact(self.films * 2) {
            for (sum, pair) in sums.iter_mut().zip(chunk.chunks_exact(2)) {
                sum.0 += f64::from(pair[0]);
                sum.1 += f64::from(pair[1]);
            }
        }
        Ok(sums)
    }
}

impl TrialSums for KeptRound<'_> {
    fn totals(&mut self) -> Result<Vec<(f64, f64)>> {
        self.reduce(&self.kernels.totals)
    }

    fn terms(&mut self, weights: &[f64]) -> Result<Vec<(f64, f64)>> {
        let bad = fail("writing the trial's weights");
        let weights: Vec<f32> = weights.iter().map(|&w| w as f32).collect();
        self.weights.write(&weights).enq().map_err(&bad)?;
        let terms = &self.kernels.terms;
        terms.set_arg("weights", &self.weights).map_err(&bad)?;
        self.reduce(terms)
    }
}
