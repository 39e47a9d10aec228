//! The progressive render loop (host side of pathtracer.cuh and main.cu): build the program,
//! upload the scene, then launch passes of samples until `--spp` or `--time` is reached, and
//! read the film back.
//!
//! Each launch covers a band of rows and a run of sample indices, sized from the measured rate
//! so that one launch takes about `launch_target` (by default 400 ms on a GPU, 4000 ms on one
//! without a kernel watchdog, 100 ms on a CPU: [`default_launch_target`]): long enough to keep
//! a GPU busy, short enough that a display GPU's watchdog (about 2 s) never fires. Every pass
//! ends with all pixels at the same sample count, and the kernel adds samples one at a time
//! onto the running sums, so the image does not depend on how the work was split.

pub mod bench;
pub mod clock;
pub mod efficiency;
pub mod features;
pub mod film;
pub mod film_file;
pub mod memory;
pub mod merge;
pub mod metrics;
pub mod multi;
pub mod plot;
pub mod report;
pub mod resume;
pub mod strategy;
pub mod trial;

use crate::contract::{self, ErrorRow, RenderParams};
use crate::device::kernel::NamedArgs;
use crate::device::program::{self, BuiltProgram, KernelSources};
use crate::device::upload::SceneBuffers;
use crate::device::{Device, DeviceDescription};
use crate::error::{Error, Result};
use crate::pack::PackedScene;
use crate::scene::Scene;
use features::Features;
use film::Film;
use metrics::{LinearImage, Metrics};
use std::time::{Duration, Instant};
use strategy::{Choice, LightSampling, Roulette, Strategy};

/// Work-group edge on a GPU: launches are padded to whole 8x8 groups. Also the rows of a
/// band (the first launch's probe, a CPU trial's first launch) and of a trial lattice's whole
/// groups (render/strategy.rs), on any device.
const GROUP: usize = 8;

/// The work-group edge of the render kernel's launches on a device of `kind`: [`GROUP`], but 2
/// on a CPU. PoCL runs a work-group on one thread and shares the groups out between threads in
/// order, so a small image's few 8x8 groups left a core idle: a 4x4-pixel render of 2^22
/// samples (tests/render.rs) ran on one of 2 cores, 33 s against 16 s in 2x2 groups; the
/// convergence tests' 24x18 and 16x12 renders took 113 s against 93. Larger images render at
/// the same rate in either (PoCL, 2 cores, smallpt, meshes and case0 at 192x108).
fn local_edge(kind: &str) -> usize {
    if kind == "CPU" { 2 } else { GROUP }
}

/// The error is estimated from this many samples per pixel on: two groups of four, one for
/// each half (kernels/pathtracer.cl, `render_pass`).
const MIN_SPP_FOR_ESTIMATE: u32 = 8;

/// `target_error` stops a render only once the estimated relMSE × spp has grown by at most this
/// factor since half as many samples ([`settled`]).
const SETTLED_GROWTH: f64 = 1.25;

/// How texture maps are sampled between texel centres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TextureFilter {
    /// Bilinear interpolation of the four nearest texels (type maps are always nearest).
    #[default]
    Bilinear,
    /// The texel the point falls in: the original's lookup.
    Nearest,
}

impl std::str::FromStr for TextureFilter {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "bilinear" => Ok(TextureFilter::Bilinear),
            "nearest" => Ok(TextureFilter::Nearest),
            other => Err(format!(
                "unknown texture filter `{other}`: use bilinear or nearest"
            )),
        }
    }
}

/// Whether the kernels traverse the object BVH or test every object in turn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ObjectBvh {
    /// The BVH above [`BVH_MIN_OBJECTS`] objects, a loop below.
    #[default]
    Auto,
    On,
    Off,
}

impl std::str::FromStr for ObjectBvh {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(ObjectBvh::Auto),
            "on" => Ok(ObjectBvh::On),
            "off" => Ok(ObjectBvh::Off),
            other => Err(format!("unknown BVH mode `{other}`: use auto, on or off")),
        }
    }
}

pub use crate::accel::MeshTree;

impl MeshTree {
    /// The tree a device walks by default: the 8-wide BVH on a CPU, whose scalar programs it
    /// speeds as it does the wide ones (PoCL, 2 cores: case1 22 to 32% less user CPU, the
    /// dragon room 29%); the binary BVH on a GPU, which walked case1 2 to 6% faster than the
    /// kd-tree and the dragon room 7 to 15% (H100, BENCHMARKS.md, "A binary BVH for GPUs"),
    /// where the 8-wide BVH walked as written for the CPU was 9 to 43% slower than the kd-tree
    /// with light sampling ("The 8-wide BVH everywhere on a CPU").
    pub fn default_on(device: &DeviceDescription) -> MeshTree {
        if device.is_gpu {
            MeshTree::Bvh2
        } else {
            MeshTree::Wide
        }
    }
}

impl MeshTree {
    /// Every tree, in the order `--mesh-tree`'s help names them.
    const ALL: [MeshTree; 3] = [MeshTree::Kd, MeshTree::Bvh2, MeshTree::Wide];

    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            MeshTree::Kd => "kd",
            MeshTree::Bvh2 => "bvh2",
            MeshTree::Wide => "wide",
        }
    }
}

impl std::str::FromStr for MeshTree {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        MeshTree::ALL
            .into_iter()
            .find(|tree| tree.name() == s)
            .ok_or_else(|| format!("unknown mesh tree `{s}`: use kd, bvh2 or wide"))
    }
}

/// With fewer objects than this, testing each in turn beats traversing the BVH: on an H200
/// the loop rendered smallpt (9 objects) 1.7 times and case1 (13, three of them 100k-triangle
/// meshes) 1.3 times faster, since most of their boxes (walls, planes) span the whole scene.
pub const BVH_MIN_OBJECTS: usize = 32;

/// How a render samples and when it stops.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Samples (paths) per pixel; `None`: no limit (then `time_limit` must be set).
    pub spp: Option<u32>,
    /// The index of the first sample the render traces (a multiple of 8, so that the samples
    /// come in whole groups of eight, each half of the error estimate's four): it renders
    /// samples `first_sample .. first_sample + spp`, one shard of a longer render
    /// (`clpt merge` joins shards).
    pub first_sample: u32,
    /// Stop within this much rendering time: no pass starts that its predecessor's rate says
    /// would end after it, and the last one takes the samples that fit ([`pass_within`]);
    /// the first pass always runs.
    pub time_limit: Option<Duration>,
    /// The 64-bit key of every random number.
    pub seed: u64,
    /// Safety cap on bounces. Russian roulette ends paths long before it; the default (65536)
    /// biases only paths whose throughput survived 65536 bounces.
    pub max_depth: u32,
    /// Russian roulette applies from this bounce on.
    pub rr_depth: u32,
    /// Roulette's threshold: fixed, or chosen by measured efficiency ([`strategy`]).
    pub roulette: Roulette,
    /// Wanted duration of one kernel launch; `None`: the device's
    /// ([`default_launch_target`]).
    pub launch_target: Option<Duration>,
    pub texture_filter: TextureFilter,
    /// Largest texture image accepted, in pixels.
    pub max_texture_pixels: u64,
    /// Largest OBJ file read, in bytes.
    pub max_mesh_bytes: u64,
    pub object_bvh: ObjectBvh,
    /// Build the program with every feature instead of only the scene's (benchmarks, tests).
    pub all_features: bool,
    /// Paths a work-item carries on a CPU device (`--lanes`); `None`: the device's native
    /// float width ([`Features::wide_lanes`]).
    pub lanes: Option<u32>,
    /// The tree meshes are walked through; `None`: the device's ([`MeshTree::default_on`]). A
    /// wide program takes only the 8-wide BVH.
    pub mesh_tree: Option<MeshTree>,
    /// The program cache's folder ([`crate::device::cache`]); `None`: always build.
    pub cache_dir: Option<std::path::PathBuf>,
    /// A converged image of the same scene and size: the per-pass report then measures the
    /// true error too.
    pub reference: Option<std::sync::Arc<LinearImage>>,
    /// Stop at the first pass whose estimated relMSE is at most this, once the estimate has
    /// settled ([`settled`]).
    pub target_error: Option<f64>,
    /// Next-event estimation with MIS (kernels/nee.h): on, off (pure path tracing, the
    /// original's), or chosen by measured efficiency ([`strategy`]).
    pub light_sampling: LightSampling,
}

impl RenderOptions {
    /// Fixes the estimator to `strategy` (no trial).
    pub fn pin(&mut self, strategy: Strategy) {
        self.light_sampling = if strategy.light_sampling {
            LightSampling::On
        } else {
            LightSampling::Off
        };
        self.roulette = Roulette::Threshold(strategy.rr_threshold);
    }
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            spp: Some(64),
            first_sample: 0,
            time_limit: None,
            seed: 0,
            max_depth: 65536,
            rr_depth: 3,
            // The library renders one fixed estimator unless asked to choose, so that two
            // renders of one seed are the same bit for bit; the command line's default is
            // auto for both.
            roulette: Roulette::Threshold(1.0),
            launch_target: None,
            texture_filter: TextureFilter::Bilinear,
            max_texture_pixels: crate::elements::texture::DEFAULT_MAX_PIXELS,
            max_mesh_bytes: crate::elements::mesh::DEFAULT_MAX_FILE_BYTES,
            object_bvh: ObjectBvh::Auto,
            all_features: false,
            lanes: None,
            mesh_tree: None,
            cache_dir: None,
            reference: None,
            target_error: None,
            light_sampling: LightSampling::On,
        }
    }
}

/// What the progress callback sees after each pass.
#[derive(Clone, Debug)]
pub struct Progress {
    pub spp_done: u32,
    pub spp_total: Option<u32>,
    pub elapsed: Duration,
    /// Paths (pixel samples) per second so far.
    pub paths_per_second: f64,
    /// The estimated error of the image so far (from 8 samples per pixel on).
    pub estimate: Option<ErrorEstimate>,
    /// The estimator the render runs.
    pub strategy: Strategy,
}

/// The error of the mean image estimated from the film alone: the samples of even and of odd
/// groups of four (each group covers the pixel's four sub-pixels) are two independent estimates
/// of each pixel, and their difference squared (times n_even n_odd / n^2) estimates the
/// variance of the mean without bias.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorEstimate {
    /// Estimated root-mean-square error, over pixels and channels.
    pub rmse: f64,
    /// Estimated relMSE, with the image itself in place of the reference.
    pub relmse: f64,
}

/// One row of the per-pass report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassReport {
    pub pass: u32,
    /// Rendering time since the start, in seconds.
    pub seconds: f64,
    pub spp: u32,
    /// Samples per pixel per second, over the whole render so far.
    pub spp_per_second: f64,
    pub estimate: ErrorEstimate,
    /// The error measured against the reference, when there is one.
    pub measured: Option<Metrics>,
}

/// The samples of the next pass of a time-limited render that end within the `left` seconds
/// at `rate` pixel samples a second on `pixels` pixels: `count`, or as many as fit, 0 to stop.
/// A pass's samples cover every pixel, so a pass cannot be cut short in time; the rate is the
/// previous pass's, its error estimate and callback included. Before, a render stopped at the end
/// of the pass running when its time was up: on PoCL (2 cores) a 5-second render of 1280x720
/// took 6.1 s, its passes 1.4 s each.
pub fn pass_within(count: u32, left: f64, rate: f64, pixels: f64) -> u32 {
    let fit = left * rate / pixels;
    if fit.is_nan() || fit < 1.0 {
        0
    } else {
        count.min(fit.min(f64::from(u32::MAX)) as u32)
    }
}

/// Whether the estimated relMSE of the last pass can be trusted to stop on: relMSE × spp, flat
/// for an unbiased renderer, has grown by at most `SETTLED_GROWTH` since the last pass with at
/// most half its samples. While a scene's rare paths (a small light found by BSDF sampling,
/// caustics) have not yet shown up in both halves, the estimate reads low, the more so the
/// fewer the samples, and the product climbs: stopping then would stop far too early (pure path
/// tracing of tests/convergence.rs's small light read relMSE 1e-2 at 11 spp, with the true
/// error above 0.5).
pub fn settled(report: &[PassReport]) -> bool {
    let Some(last) = report.last() else {
        return false;
    };
    let product = |r: &PassReport| r.estimate.relmse * f64::from(r.spp);
    report
        .iter()
        .rev()
        .find(|r| 2 * r.spp <= last.spp)
        .is_some_and(|half| product(last) <= SETTLED_GROWTH * product(half))
}

/// What a finished render measured.
#[derive(Clone, Debug)]
pub struct RenderStats {
    pub elapsed: Duration,
    pub launches: u32,
    pub passes: u32,
    pub paths_per_second: f64,
    /// After every pass from 8 samples per pixel on.
    pub report: Vec<PassReport>,
    /// The estimator the render ran, and what the trial measured when there was one.
    pub choice: Choice,
    /// Samples that were not finite, left out of the film (each counts as 0).
    pub nonfinite: NonFinite,
    /// Pixels whose samples were finite but whose sum is not: it overflowed f32 (an emission
    /// near f32's largest value), so the pixel is infinite in the image.
    pub overflowed: Overflowed,
    /// The pass callback ended the render before its sample count or time limit.
    pub stopped: bool,
    /// Paths a work-item of the chosen estimator's program carried (kernels/lanes.h).
    pub lanes: u32,
}

/// What the render loop did ([`Renderer::trace`]), before the film is read back.
struct Traced {
    elapsed: Duration,
    launches: u32,
    passes: u32,
    /// Samples per pixel the film holds at the end.
    spp_done: u32,
    report: Vec<PassReport>,
    choice: Choice,
    stopped: bool,
}

/// Path samples that came out infinite or NaN (kernels/pathtracer.cl, `render_pass`): never
/// added to the film, counted as 0, and reported.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NonFinite {
    pub count: u64,
    /// The first: (x, y from the top row, sample index), by sample index then pixel.
    pub first: Option<(u32, u32, u32)>,
}

/// Pixels of a film whose sum is not finite though every sample added to it was.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Overflowed {
    pub pixels: u64,
    /// The first, from the top left: (x, y from the top row).
    pub first: Option<(u32, u32)>,
}

impl Overflowed {
    /// The pixels of `film` whose sum is infinite or NaN.
    pub fn of(film: &Film) -> Overflowed {
        let width = film.width as usize;
        let mut out = Overflowed::default();
        // Top row first, as the image is written and as `first` is given.
        for row in (0..film.height as usize).rev() {
            for x in 0..width {
                let sum = film.sum[row * width + x];
                if !sum[..3].iter().all(|c| c.is_finite()) {
                    out.pixels += 1;
                    out.first = out.first.or(Some((x as u32, film.height - 1 - row as u32)));
                }
            }
        }
        out
    }
}

/// One program of the render kernel: with light sampling compiled in, or without.
pub struct Estimator {
    pub light_sampling: bool,
    pub features: Features,
    pub program: BuiltProgram,
    kernel: ocl::Kernel,
}

impl Estimator {
    /// What sets this program apart, as `-v` prints it.
    pub fn label(&self) -> &'static str {
        if self.light_sampling {
            "with light sampling"
        } else {
            "without light sampling"
        }
    }
}

/// A set of image rows a launch covers: `count` rows from `start`, every `step`-th (row 0 is the
/// bottom of the image; kernels/pathtracer.cl `render_pass`), and on them every `col_step`-th
/// pixel from [`Rows::first_column`] (a strategy trial's lattice; 1 elsewhere).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rows {
    pub start: u32,
    pub count: u32,
    pub step: u32,
    pub col_step: u32,
}

impl Rows {
    /// `count` consecutive rows from `start`, every pixel.
    fn band(start: u32, count: u32) -> Rows {
        Rows {
            start,
            count,
            step: 1,
            col_step: 1,
        }
    }

    /// The first column taken: the middle of the first `col_step` (as a trial's first row is
    /// the middle of its first `step`). The one definition: the kernels take it as `col_start`.
    pub fn first_column(&self) -> u32 {
        strategy::trial_first_row(self.col_step)
    }

    /// The columns taken on an image `width` wide: every `col_step`-th from the first, counted
    /// as a trial's rows are.
    pub fn columns(&self, width: u32) -> u32 {
        strategy::trial_rows(self.col_step, width)
    }
}

/// A scene loaded on a device, ready to render.
pub struct Renderer<'d> {
    device: &'d Device,
    /// One program for each light-sampling setting among the candidates, light sampling first.
    estimators: Vec<Estimator>,
    candidates: Vec<Strategy>,
    /// The strategy the next launch runs.
    strategy: Strategy,
    pub packed: PackedScene,
    params: RenderParams,
    errors: ErrorKernel,
    /// The strategy trial's statistics (kernels/trial.cl), when there is a trial.
    trial: Option<trial::TrialKernels>,
    // The kernels hold these buffers' handles; they live as long as the kernels do.
    scene_buffers: SceneBuffers,
    /// The film on the device.
    film: DeviceFilm,
    /// Samples per pixel the film already holds when the next render starts ([`Self::resume`]).
    start_samples: u32,
    /// How the last render launched its passes, and for which strategy: the next render of
    /// that strategy starts from it instead of probing again (a chunk of several devices'
    /// render would otherwise spend its first pass on launches of one sample: render/multi.rs).
    launch_plan: Option<(Strategy, LaunchPlan)>,
    options: RenderOptions,
}

/// The launch target on `device` when the options leave it ([`RenderOptions::launch_target`]):
/// 100 ms on a CPU; on a GPU 4000 ms where the driver says it has no kernel watchdog
/// ([`DeviceDescription::watchdog`]: a compute GPU), else 400 ms. A GPU's work-item renders its
/// pixel's samples of a launch one after another, a lane whose path has ended starting the next
/// (path regeneration, kernels/pathtracer.cl): at the end of a launch its lanes idle until the
/// longest path of their warp ends, about one path's time a launch, and every pass ends in an
/// error estimate and a wait. On the H200 400 ms against 100 (BENCHMARKS.md): case0
/// (2560x1440, 64 samples) with light sampling 2.73 s against 3.70, without 0.64 against 0.80;
/// case1 without, 2.74 against 3.30; and 1000 ms against 400 lowered relMSE × s by 2 to 17% on
/// every showcase and GPU-heavy scene (case1 with light sampling 17%, case0 14%). On the H100
/// at the original's sizes and samples, 4000 ms against 1000 rendered case1 in 25.26 s against
/// 26.04 (-3.0%) and case3 in 15.87 against 16.37 (-3.1%), 2500 ms in 25.35 and 15.97; on
/// renders of 160 and 250 samples 12000 ms gained under 0.5% on 5000. The price is the wait for
/// the launch in flight at a time limit, a target error, a progress line or Ctrl-C: up to 4 s on
/// a GPU that drives no display. Launches sized by the slowest of the pass before stay well
/// within a display watchdog's 2 s at 400 ms. A CPU keeps 100 ms, not measured at 400: a CPU's
/// trial sizes its launches by the target too (`render_rows`), and its timing was tuned at 100.
pub fn default_launch_target(device: &DeviceDescription) -> Duration {
    Duration::from_millis(match (device.kind.as_str(), device.watchdog) {
        ("CPU", _) => 100,
        (_, Some(false)) => 4000,
        _ => 400,
    })
}

/// The shape of a pass's launches: `rows` rows of `spp` samples each.
#[derive(Clone, Copy, Debug, PartialEq)]
struct LaunchPlan {
    rows: u32,
    spp: u32,
}

impl LaunchPlan {
    /// The plan whose launches take `target` seconds at `rate` pixel samples per second (the
    /// slowest launch of the last pass) on a `width` x `height` image: whole images of several
    /// samples, or bands of rows of one.
    fn for_rate(rate: f64, target: f64, width: u32, height: u32) -> LaunchPlan {
        let pixels = f64::from(width) * f64::from(height);
        let budget = rate * target; // pixel samples per launch
        if budget >= pixels {
            LaunchPlan {
                rows: height,
                spp: ((budget / pixels) as u32).clamp(1, 1 << 16),
            }
        } else {
            LaunchPlan {
                rows: band_rows(rate, target, width, 1).min(height),
                spp: 1,
            }
        }
    }
}

/// The rows of a band of `count` samples a pixel that take `target` seconds at `rate` pixel
/// samples per second on an image `width` wide: at least one.
fn band_rows(rate: f64, target: f64, width: u32, count: u32) -> u32 {
    (rate * target / (f64::from(width) * f64::from(count.max(1)))).clamp(1.0, f64::from(u32::MAX))
        as u32
}

/// What the render loop does after a pass ([`Renderer::render_with`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Continue,
    /// End the render now: the film holds every finished pass.
    Stop,
}

/// The error figures of the film after a pass (kernels/pathtracer.cl, `error_rows`).
struct ErrorKernel {
    kernel: ocl::Kernel,
    rows: ocl::Buffer<f32>,
    has_reference: bool,
    _reference: ocl::Buffer<f32>,
}

impl ErrorKernel {
    fn new(
        device: &Device,
        program: &ocl::Program,
        packed: &PackedScene,
        film: [&ocl::Buffer<f32>; 4],
        options: &RenderOptions,
    ) -> Result<Self> {
        let (width, height) = (packed.camera.width, packed.camera.height);
        // The reference, bottom row first as the film.
        let mut reference = vec![0.0f32; 4];
        if let Some(r) = &options.reference {
            if (r.width, r.height) != (width, height) {
                return Err(Error::Invalid(format!(
                    "the reference is {}x{}, the render {width}x{height}",
                    r.width, r.height
                )));
            }
            reference = (0..height)
                .rev()
                .flat_map(|row| {
                    let start = (row * width) as usize;
                    r.rgb[start..start + width as usize]
                        .iter()
                        .flat_map(|p| [p[0], p[1], p[2], 0.0])
                })
                .collect();
        }
        let fail = |e: ocl::Error| Error::opencl("preparing the error estimate", e);
        let reference = ocl::Buffer::<f32>::builder()
            .queue(device.queue.clone())
            .len(reference.len())
            .copy_host_slice(&reference)
            .build()
            .map_err(fail)?;
        // One ErrorRow (kernels/types.h) a row, as the floats it is made of.
        let row_floats = size_of::<ErrorRow>() / size_of::<f32>();
        let rows = ocl::Buffer::<f32>::builder()
            .queue(device.queue.clone())
            .len(height as usize * row_floats)
            .build()
            .map_err(fail)?;
        let [sum, sum_lo, sum_odd, sum_odd_lo] = film;
        let kernel = NamedArgs::new(program, "error_rows", &device.queue)
            .global_work_size(height as usize)
            .buffer("sum", sum)
            .buffer("sum_lo", sum_lo)
            .buffer("sum_odd", sum_odd)
            .buffer("sum_odd_lo", sum_odd_lo)
            .buffer("reference", &reference)
            .scalar("has_reference", options.reference.is_some() as u32)
            .scalar("width", width)
            .scalar("spp", 0u32)
            .scalar("eps", metrics::REL_EPSILON)
            .buffer("out", &rows)
            .build()?;
        Ok(ErrorKernel {
            kernel,
            rows,
            has_reference: options.reference.is_some(),
            _reference: reference,
        })
    }

    /// The estimate (and with a reference the measured error) after `spp` samples.
    fn measure(&self, spp: u32, pixels: f64) -> Result<(ErrorEstimate, Option<Metrics>)> {
        let fail = |e: ocl::Error| Error::opencl("estimating the error", e);
        self.kernel.set_arg("spp", spp).map_err(fail)?;
        // SAFETY: every buffer is alive and sized for the image's rows; one work-item a row.
        unsafe { self.kernel.enq() }.map_err(fail)?;
        let mut floats = vec![0.0f32; self.rows.len()];
        self.rows.read(&mut floats).enq().map_err(fail)?;
        let rows: &[ErrorRow] = bytemuck::cast_slice(&floats);
        let sum =
            |field: fn(&ErrorRow) -> f32| rows.iter().map(|r| f64::from(field(r))).sum::<f64>();
        let n = pixels * 3.0;
        let estimate = ErrorEstimate {
            rmse: (sum(|r| r.estimate) / n).sqrt(),
            relmse: sum(|r| r.estimate_rel) / n,
        };
        let measured = self.has_reference.then(|| Metrics {
            rmse: (sum(|r| r.squared) / n).sqrt(),
            relmse: sum(|r| r.squared_rel) / n,
            mae: sum(|r| r.absolute) / n,
        });
        Ok((estimate, measured))
    }
}

/// Refuses a render that could not end or not fit before any work: one with no sample count,
/// time limit or target error, a shard not starting at a group of eight, a film too large.
fn check_request(device: &Device, scene: &Scene, options: &RenderOptions) -> Result<()> {
    if options.spp.is_none() && options.time_limit.is_none() && options.target_error.is_none() {
        return Err(Error::Invalid(
            "a render needs a sample count, a time limit or a target error".into(),
        ));
    }
    if !options.first_sample.is_multiple_of(8) {
        return Err(Error::Invalid(format!(
            "the first sample {} is not a multiple of 8: a shard holds whole groups of eight",
            options.first_sample
        )));
    }
    memory::check_film_fits(
        &device.description,
        scene.camera.width,
        scene.camera.height,
        crate::input::host_available_bytes(),
    )
}

/// What the program holds: the scene's features (or all), the lanes a work-item carries and
/// the tree meshes are walked through.
fn program_shape(
    device: &Device,
    scene: &Scene,
    options: &RenderOptions,
) -> Result<(Features, u32, MeshTree)> {
    // Leave out what the scene does not need (features.rs, kernels/features.h); the mesh
    // tree is packed for the program (MeshTree).
    let base_features = if options.all_features {
        Features::all(scene, options.object_bvh)
    } else {
        Features::of(scene, options.object_bvh)
    };
    let lanes = base_features.wide_lanes(&device.description, options.lanes);
    let mesh_tree = match options.mesh_tree {
        Some(tree) if tree != MeshTree::Wide && lanes > 1 => {
            return Err(Error::Invalid(format!(
                "a wide program ({lanes} lanes) walks meshes through 8-wide BVHs: \
                 --mesh-tree {} takes --lanes 1",
                tree.name()
            )));
        }
        Some(tree) => tree,
        None if lanes > 1 => MeshTree::Wide,
        None => MeshTree::default_on(&device.description),
    };
    Ok((base_features, lanes, mesh_tree))
}

/// The film on the device: per pixel the sums of the samples (`sum` + `sum_lo`, compensated),
/// of their squares, and of the odd groups' samples (`sum_odd` + `sum_odd_lo`), float4 each,
/// and the counts of non-finite samples left out (`bad`, with the first one's index in
/// `bad_first`).
struct DeviceFilm {
    sum: ocl::Buffer<f32>,
    sum_lo: ocl::Buffer<f32>,
    sum_sq: ocl::Buffer<f32>,
    sum_odd: ocl::Buffer<f32>,
    sum_odd_lo: ocl::Buffer<f32>,
    bad: ocl::Buffer<u32>,
    bad_first: ocl::Buffer<u32>,
}

impl DeviceFilm {
    /// A cleared film of `width` x `height` pixels.
    fn new(device: &Device, width: u32, height: u32) -> Result<DeviceFilm> {
        let pixels = width as usize * height as usize;
        let fail = |e: ocl::Error| Error::opencl("allocating the film", e);
        let sums = || {
            ocl::Buffer::<f32>::builder()
                .queue(device.queue.clone())
                .len(pixels * 4)
                .fill_val(0.0f32)
                .build()
                .map_err(fail)
        };
        let counters = || {
            ocl::Buffer::<u32>::builder()
                .queue(device.queue.clone())
                .len(pixels)
                .fill_val(0u32)
                .build()
                .map_err(fail)
        };
        Ok(DeviceFilm {
            sum: sums()?,
            sum_lo: sums()?,
            sum_sq: sums()?,
            sum_odd: sums()?,
            sum_odd_lo: sums()?,
            bad: counters()?,
            bad_first: counters()?,
        })
    }
}

/// `render_pass` of `program` bound to the scene and the film; the launch's rows and samples
/// are set before each launch.
fn render_kernel(
    device: &Device,
    program: &ocl::Program,
    scene: &SceneBuffers,
    film: &DeviceFilm,
) -> Result<ocl::Kernel> {
    NamedArgs::new(program, "render_pass", &device.queue)
        .global_work_size([GROUP, GROUP])
        .scene(scene)
        .buffer("sum", &film.sum)
        .buffer("sum_lo", &film.sum_lo)
        .buffer("sum_sq", &film.sum_sq)
        .buffer("sum_odd", &film.sum_odd)
        .buffer("sum_odd_lo", &film.sum_odd_lo)
        .buffer("bad", &film.bad)
        .buffer("bad_first", &film.bad_first)
        .scalar("sample_start", 0u32)
        .scalar("sample_count", 0u32)
        .scalar("row_start", 0u32)
        .scalar("row_count", 0u32)
        .scalar("row_step", 1u32)
        .scalar("col_start", 0u32)
        .scalar("col_step", 1u32)
        .build()
}

impl<'d> Renderer<'d> {
    pub fn new(
        device: &'d Device,
        scene: &Scene,
        sources: &KernelSources,
        options: RenderOptions,
    ) -> Result<Self> {
        check_request(device, scene, &options)?;
        let (base_features, lanes, mesh_tree) = program_shape(device, scene, &options)?;
        let packed = PackedScene::with_limits(
            scene,
            options.max_texture_pixels,
            options.max_mesh_bytes,
            mesh_tree,
        )?;
        let filter = match options.texture_filter {
            TextureFilter::Bilinear => contract::FILTER_BILINEAR,
            TextureFilter::Nearest => contract::FILTER_NEAREST,
        };
        let params: RenderParams =
            packed.params(options.seed, options.max_depth, options.rr_depth, filter);
        let candidates = strategy::candidates(
            options.light_sampling,
            options.roulette,
            !packed.lights.is_empty(),
        );
        let scene_buffers = SceneBuffers::new(device, &packed, &params)?;
        let film = DeviceFilm::new(device, packed.camera.width, packed.camera.height)?;
        // One program per light-sampling setting the candidates need, light sampling first.
        let mut estimators = Vec::new();
        for light_sampling in [true, false] {
            if !candidates
                .iter()
                .any(|c| c.light_sampling == light_sampling)
            {
                continue;
            }
            let mut features = base_features.clone();
            features.nee = light_sampling;
            features.regenerate = Features::regeneration_on(&device.description);
            features.lanes = lanes;
            features.mesh_tree = mesh_tree;
            features.prefetch = Features::prefetch_on(&device.description);
            features.walls |= features.walls_on(&params.walls, &device.description);
            let program = program::build_entry(
                device,
                sources,
                "pathtracer.cl",
                &features.defines(),
                options.cache_dir.as_deref(),
            )?;
            let kernel = render_kernel(device, &program.program, &scene_buffers, &film)?;
            estimators.push(Estimator {
                light_sampling,
                features,
                program,
                kernel,
            });
        }
        let errors = ErrorKernel::new(
            device,
            &estimators[0].program.program,
            &packed,
            [&film.sum, &film.sum_lo, &film.sum_odd, &film.sum_odd_lo],
            &options,
        )?;
        let trial = if candidates.len() > 1 {
            Some(trial::TrialKernels::new(
                device,
                sources,
                options.cache_dir.as_deref(),
                [
                    &film.sum,
                    &film.sum_odd,
                    &film.sum_lo,
                    &film.sum_sq,
                    &film.sum_odd_lo,
                ],
                packed.camera.width,
            )?)
        } else {
            None
        };
        let strategy = candidates[0];
        let mut renderer = Renderer {
            device,
            estimators,
            candidates,
            strategy,
            packed,
            params,
            errors,
            trial,
            scene_buffers,
            film,
            start_samples: 0,
            launch_plan: None,
            options,
        };
        renderer.select(strategy)?;
        Ok(renderer)
    }

    pub fn width(&self) -> u32 {
        self.packed.camera.width
    }

    pub fn height(&self) -> u32 {
        self.packed.camera.height
    }

    /// The programs built for this render, light sampling first.
    pub fn estimators(&self) -> &[Estimator] {
        &self.estimators
    }

    /// The first program built (with light sampling when that is a candidate).
    pub fn program(&self) -> &BuiltProgram {
        &self.estimators[0].program
    }

    /// Every program built for this render, each with what it is for: the render's, light
    /// sampling first, then the trial's statistics when there is a trial.
    pub fn programs(&self) -> Vec<(&'static str, &BuiltProgram)> {
        let mut all: Vec<(&'static str, &BuiltProgram)> = self
            .estimators
            .iter()
            .map(|e| (e.label(), &e.program))
            .collect();
        if let Some(trial) = &self.trial {
            all.push(("the trial's statistics", trial.program()));
        }
        all
    }

    /// The strategies the render chooses among, the preferred first.
    pub fn candidates(&self) -> &[Strategy] {
        &self.candidates
    }

    /// Makes the next launches run `strategy`: its program, and its roulette threshold in the
    /// parameters.
    fn select(&mut self, strategy: Strategy) -> Result<()> {
        self.params.rr_threshold = strategy.rr_threshold;
        self.scene_buffers
            .params
            .write(bytemuck::bytes_of(&self.params))
            .enq()
            .map_err(|e| Error::opencl("writing the render parameters", e))?;
        self.strategy = strategy;
        Ok(())
    }

    fn estimator(&self) -> &Estimator {
        let light_sampling = self.strategy.light_sampling;
        self.estimators
            .iter()
            .find(|e| e.light_sampling == light_sampling)
            .expect("a program for every candidate")
    }

    fn kernel(&self) -> &ocl::Kernel {
        &self.estimator().kernel
    }

    /// One launch of the current strategy: the rows of `rows` x samples [sample_start, +count).
    fn launch(&self, rows: Rows, sample_start: u32, count: u32) -> Result<()> {
        let edge = local_edge(&self.device.description.kind);
        let round_up = |n: usize| n.div_ceil(edge) * edge;
        let kernel = self.kernel();
        let set = |name: &'static str, v: u32| {
            kernel
                .set_arg(name, v)
                .map_err(|e| Error::opencl("setting a kernel argument", e))
        };
        set("sample_start", sample_start)?;
        set("sample_count", count)?;
        set("row_start", rows.start)?;
        set("row_count", rows.count)?;
        set("row_step", rows.step)?;
        set("col_start", rows.first_column())?;
        set("col_step", rows.col_step.max(1))?;
        // SAFETY: the kernel's buffers are alive (owned by self) and sized for the whole
        // image; the kernel bounds-checks the padded work-items, and every row of `rows` is in
        // the image.
        unsafe {
            kernel
                .cmd()
                .global_work_size([
                    // A work-item takes `lanes` consecutive columns (kernels/lanes.h).
                    round_up(
                        rows.columns(self.width())
                            .div_ceil(self.estimator().features.lanes)
                            as usize,
                    ),
                    round_up(rows.count as usize),
                ])
                .local_work_size([edge, edge])
                .enq()
        }
        .map_err(|e| Error::opencl("launching the render kernel", e))?;
        self.device
            .queue
            .finish()
            .map_err(|e| Error::opencl("running the render kernel", e))
    }

    /// Zeroes the film and the non-finite counters.
    fn clear_film(&self) -> Result<()> {
        let fail = |e: ocl::Error| Error::opencl("clearing the film", e);
        for film in [
            &self.film.sum,
            &self.film.sum_lo,
            &self.film.sum_sq,
            &self.film.sum_odd,
            &self.film.sum_odd_lo,
        ] {
            film.cmd().fill(0.0f32, None).enq().map_err(fail)?;
        }
        for counter in [&self.film.bad, &self.film.bad_first] {
            counter.cmd().fill(0u32, None).enq().map_err(fail)?;
        }
        self.device.queue.finish().map_err(fail)
    }

    /// One small launch of every program (a band of rows, one sample) whose result is then
    /// cleared: it leaves the programs compiled (PoCL generates machine code at the first
    /// launch) and the device awake, so that a timed render, or the strategy trial, measures
    /// rendering alone.
    pub fn warm_up(&mut self) -> Result<()> {
        let current = self.strategy;
        for light_sampling in self
            .estimators
            .iter()
            .map(|e| e.light_sampling)
            .collect::<Vec<_>>()
        {
            self.select(Strategy {
                light_sampling,
                ..current
            })?;
            self.launch(Rows::band(0, self.height().min(GROUP as u32 * 2)), 0, 1)?;
        }
        self.select(current)?;
        self.clear_film()
    }

    /// Samples per pixel per second of the current strategy, from one sample on every eighth
    /// row (after [`Self::warm_up`], whose film it clears): what a device offers before it
    /// renders a chunk of several devices' render (render/multi.rs).
    pub fn probe_rate(&mut self) -> Result<f64> {
        self.warm_up()?;
        let height = self.height();
        let step = 8.min(height);
        let rows = Rows {
            count: height.div_ceil(step),
            step,
            ..Rows::band(0, 0)
        };
        let seconds = self
            .render_rows(rows, self.options.first_sample, 1, GROUP as u32 * 2)?
            .wall;
        self.clear_film()?;
        Ok(f64::from(rows.count) / f64::from(height) / seconds)
    }

    /// The wanted duration of a launch, in seconds: the options', or the device's default.
    fn launch_target(&self) -> f64 {
        self.options
            .launch_target
            .unwrap_or_else(|| default_launch_target(&self.device.description))
            .as_secs_f64()
            .max(1e-3)
    }

    /// Renders `rows` x samples [sample_start, +count) in launches of about the launch target
    /// (the first of at most `first` rows, the rest sized from its rate): returns the seconds
    /// spent in launches, wall and CPU ([`clock::Spent`]).
    fn render_rows(
        &self,
        rows: Rows,
        sample_start: u32,
        count: u32,
        first: u32,
    ) -> Result<clock::Spent> {
        let target = self.launch_target();
        let mut per_launch = rows.count.min(first).max(1);
        let (mut done, mut spent) = (0u32, clock::Spent::default());
        while done < rows.count {
            let n = per_launch.min(rows.count - done);
            let part = Rows {
                start: rows.start + done * rows.step,
                count: n,
                ..rows
            };
            let (launched, this) = clock::measure(|| self.launch(part, sample_start, count));
            launched?;
            spent += this;
            done += n;
            per_launch = ((n as f64 / this.wall.max(1e-6) * target) as u32).clamp(1, rows.count);
        }
        Ok(spent)
    }

    /// The strategy trial ([`strategy`]): every candidate renders the same rows, the film is
    /// read back and cleared after each, and the most efficient is selected; a long render's
    /// trial first scouts and then measures the survivors in full ([`strategy::scout_plan`]).
    /// A render limited by time alone scouts at the device's floor of paths and sizes its full
    /// round by the samples the time left affords at the scouts' best speed
    /// ([`strategy::samples_within`]), as a render of that sample count would. When the
    /// winner rendered the last round on every row, its samples stay in the film
    /// (`Choice::film_samples`). With one candidate there is nothing to measure.
    fn choose_strategy(&mut self) -> Result<Choice> {
        if self.candidates.len() < 2 {
            let only = self.candidates[0];
            self.select(only)?;
            return Ok(Choice::only(only));
        }
        let start = Instant::now();
        self.warm_up()?;
        let (width, height) = (self.width(), self.height());
        let all: Vec<usize> = (0..self.candidates.len()).collect();
        let kind = self.device.description.kind.clone();
        let scouting = strategy::scouting(&kind);
        // A render limited by time alone learns its samples from the first round's timings.
        let time_only = self
            .options
            .time_limit
            .filter(|_| self.options.spp.is_none());
        let first = if time_only.is_some() {
            strategy::time_limited_scout_plan((width, height), scouting)
        } else {
            // A short render's trial is one round, as large as it affords; a longer one
            // scouts.
            let scout =
                strategy::scout_plan(all.len(), self.options.spp, (width, height), scouting);
            let first = strategy::trial_plan(all.len(), self.options.spp, height);
            if first.cost() > scout.cost() {
                scout
            } else {
                first
            }
        };
        // A CPU's first round takes the full round's samples, on fewer rows.
        let least = strategy::least_trial_samples(&kind);
        let first = strategy::with_least_samples(first, least, (width, height));
        let (scouted, _) = self.trial_round(&all, first, None, &start)?;
        let survivors = scouted.survivors();
        let spp = self.options.spp.or_else(|| {
            let best = &scouted.measured[scouted.chosen];
            let left = time_only?.as_secs_f64() - start.elapsed().as_secs_f64();
            let pixels = f64::from(width) * f64::from(height);
            Some(strategy::samples_within(
                left,
                best.seconds_per_sample,
                pixels,
            ))
        });
        let full = spp.and_then(|spp| {
            let fill = strategy::full_round_least_pixels(&kind);
            strategy::full_round_plan(&scouted, first, &survivors, spp, (width, height), fill)
        });
        let mut choice = match full {
            None => scouted,
            Some(plan) => {
                self.clear_film()?;
                // On a GPU a full round narrower than the scouts times its candidates by the
                // scouts' seconds a path.
                let timing =
                    strategy::times_by_scouts(&kind, first, plan, (width, height)).then(|| {
                        survivors
                            .iter()
                            .map(|&i| scouted.measured[i].seconds_per_sample)
                            .collect()
                    });
                let (round, parts) = self.trial_round(&survivors, plan, timing, &start)?;
                let mut choice = Choice::merge(&scouted, &survivors, round);
                // The last film rendered is still there: the winner's when it rendered last
                // (survivors() puts the scouts' best last) on every row, in one part. The
                // render goes on from it.
                let whole = plan.row_step == 1 && plan.col_step == 1 && parts == 1;
                if whole && survivors.last() == Some(&choice.chosen) {
                    choice.film_samples = plan.samples;
                }
                choice
            }
        };
        if choice.film_samples == 0 {
            self.clear_film()?;
        }
        self.select(choice.strategy())?;
        // The trial's time as the render counts it, its host statistics included.
        choice.seconds = start.elapsed().as_secs_f64();
        Ok(choice)
    }

    /// One round of the trial: the candidates `which` (indices into the candidate list) each
    /// render the plan's rows and samples, on a CPU in parts of the samples
    /// ([`strategy::sample_parts`]: every candidate renders a part on all the rows, in the
    /// order of `which`, before the next part), each part added on the device to the
    /// candidate's sums (render/trial.rs) before the film is cleared for the next. The film is left
    /// holding the last render: with one part, the last candidate's whole round. With
    /// `timing` (seconds a path, one per candidate of `which`) the candidates are compared by
    /// those instead of this round's launches.
    fn trial_round(
        &mut self,
        which: &[usize],
        plan: strategy::TrialPlan,
        timing: Option<Vec<f64>>,
        start: &Instant,
    ) -> Result<(Choice, usize)> {
        let (width, height) = (self.width(), self.height());
        let step = plan.row_step;
        let rows = Rows {
            start: strategy::trial_first_row(step),
            count: strategy::trial_rows(step, height),
            step,
            col_step: plan.col_step.clamp(1, width.max(1)),
        };
        let strategies: Vec<Strategy> = which.iter().map(|&i| self.candidates[i]).collect();
        let parts = strategy::sample_parts(
            plan.samples,
            strategy::timing_parts(&self.device.description.kind),
        );
        let kernels = self
            .trial
            .take()
            .expect("trial kernels wherever there are several candidates");
        let round = (|| {
            let mut kept = kernels.round(rows, strategies.len(), plan.samples)?;
            let launch = strategy::first_trial_launch(&self.device.description.kind, rows.count);
            let first = self.options.first_sample;
            let mut timed = vec![Vec::new(); strategies.len()];
            // A round on part of the image clears its own pixels as it keeps them; one on
            // every pixel clears the whole film (its counters too), and leaves the last
            // candidate's render in it.
            let lattice = rows.step > 1 || rows.col_step > 1;
            for (part, &(from, to)) in parts.iter().enumerate() {
                for (k, &candidate) in strategies.iter().enumerate() {
                    if (k > 0 || part > 0) && !lattice {
                        self.clear_film()?;
                    }
                    self.select(candidate)?;
                    let seconds = self.render_rows(rows, first + from, to - from, launch)?;
                    timed[k].push((seconds, to - from));
                    // The trial's few samples (at most 64) need no compensation: `sum` alone
                    // is exact enough.
                    kept.keep(k, lattice)?;
                }
            }
            // A CPU's candidates compared by their work, which its launches' wall time blurs.
            let cpu_device = self.device.description.kind == "CPU";
            let timed = clock::comparable(&timed, cpu_device);
            let seconds = match timing {
                Some(per_path) => {
                    let paths = f64::from(plan.samples) * kept.pixels() as f64;
                    per_path.iter().map(|s| s * paths).collect()
                }
                None => strategy::robust_seconds(&timed, plan.samples),
            };
            let round = strategy::Round {
                strategies: strategies.clone(),
                seconds,
                samples: plan.samples,
                pixels: kept.pixels(),
            };
            let pixels = width as f64 * height as f64;
            strategy::choose(&round, &mut kept, pixels, start.elapsed().as_secs_f64())
        })();
        self.trial = Some(kernels);
        round.map(|choice| (choice, parts.len()))
    }

    /// Renders until the sample count or time limit, calling `on_progress` after every pass.
    /// With several candidate strategies, a short trial first picks the most efficient; its
    /// time counts in the render's.
    pub fn render(
        &mut self,
        on_progress: &mut dyn FnMut(&Progress),
    ) -> Result<(Film, RenderStats)> {
        self.render_with(&mut |p, _| {
            on_progress(p);
            Ok(Flow::Continue)
        })
    }

    /// [`Self::render`], with a callback after every pass that sees the renderer (to write a
    /// checkpoint of its film) and may end the render ([`Flow::Stop`]; the film then holds
    /// every finished pass, `RenderStats::stopped` says so). An error from it ends the render
    /// with that error.
    pub fn render_with(
        &mut self,
        on_pass: &mut dyn FnMut(&Progress, &Renderer) -> Result<Flow>,
    ) -> Result<(Film, RenderStats)> {
        let traced = self.trace(on_pass, true)?;
        // One read-back of the whole film: the image and the counters both come from it.
        let state = self.film_state()?;
        let film = state.film(traced.spp_done);
        let nonfinite = self.nonfinite(&state);
        let overflowed = Overflowed::of(&film);
        let pixels = f64::from(self.width()) * f64::from(self.height());
        Ok((
            film,
            RenderStats {
                elapsed: traced.elapsed,
                launches: traced.launches,
                passes: traced.passes,
                paths_per_second: pixels * f64::from(traced.spp_done - self.start_samples)
                    / traced.elapsed.as_secs_f64().max(1e-9),
                report: traced.report,
                choice: traced.choice,
                nonfinite,
                overflowed,
                stopped: traced.stopped,
                lanes: self.estimator().features.lanes,
            },
        ))
    }

    /// Traces samples `first .. first + spp` (`first` a multiple of 8) into the film as it
    /// stands, without reading it back or estimating its error: a chunk of a render that
    /// several devices split (render/multi.rs). A device's chunks come in increasing order, so
    /// its film sums its samples in the order one render would; [`Self::film_state`] reads it
    /// once after the last. The first chunk runs the trial when there is one: the choice.
    /// `on_pass` gets the samples per pixel of the chunk done after every pass.
    pub fn render_chunk(
        &mut self,
        first: u32,
        spp: u32,
        on_pass: &mut dyn FnMut(u32),
    ) -> Result<Choice> {
        if !first.is_multiple_of(8) {
            return Err(Error::Invalid(format!(
                "the first sample {first} is not a multiple of 8"
            )));
        }
        self.options.first_sample = first;
        self.options.spp = Some(spp);
        self.start_samples = 0;
        let mut pass = |p: &Progress, _: &Renderer| {
            on_pass(p.spp_done);
            Ok(Flow::Continue)
        };
        Ok(self.trace(&mut pass, false)?.choice)
    }

    /// One pass: the image's rows in bands, each launched with `count` samples from the film's
    /// sample `spp_done` on; the slowest launch's rate (pixel samples per second) and the
    /// launches made. The first band has `plan`'s rows, each later one as many as the launch
    /// target affords at the slowest rate so far: the first pass's bands of one sample, sized
    /// for a probe, would otherwise cover the image in dozens of launches too narrow to fill a
    /// GPU (case1: 90 launches of 16 rows).
    fn run_pass(&mut self, plan: LaunchPlan, spp_done: u32, count: u32) -> Result<(f64, u32)> {
        let (width, height) = (self.width(), self.height());
        let target = self.launch_target();
        let mut rate = f64::INFINITY;
        let mut launches = 0;
        let mut row = 0;
        let mut band = plan.rows;
        while row < height {
            let rows = band.min(height - row);
            let t0 = Instant::now();
            self.launch(
                Rows::band(row, rows),
                self.options.first_sample + spp_done,
                count,
            )?;
            let secs = t0.elapsed().as_secs_f64().max(1e-6);
            rate = rate.min(rows as f64 * width as f64 * count as f64 / secs);
            launches += 1;
            row += rows;
            band = band_rows(rate, target, width, count);
        }
        Ok((rate, launches))
    }

    /// The report's row of pass `pass`, ended with `spp_done` samples a pixel: its error
    /// estimate (and with a reference the measured error) and its pace since `start`.
    fn pass_report(&self, pass: u32, spp_done: u32, start: Instant) -> Result<PassReport> {
        let pixels = f64::from(self.width()) * f64::from(self.height());
        let (estimate, measured) = self.errors.measure(spp_done, pixels)?;
        let seconds = start.elapsed().as_secs_f64();
        Ok(PassReport {
            pass,
            seconds,
            spp: spp_done,
            spp_per_second: (spp_done - self.start_samples) as f64 / seconds.max(1e-9),
            estimate,
            measured,
        })
    }

    /// The render loop: the trial, then passes until the sample count, the time limit, the
    /// target error or the callback's stop. With `estimate`, the film's error is estimated
    /// after every pass (the report, the target error and the progress line need it).
    fn trace(
        &mut self,
        on_pass: &mut dyn FnMut(&Progress, &Renderer) -> Result<Flow>,
        estimate_errors: bool,
    ) -> Result<Traced> {
        let (width, height) = (self.width(), self.height());
        let pixels = width as f64 * height as f64;
        let target = self.launch_target();
        let total = self.options.spp;
        let start = Instant::now();
        let choice = self.choose_strategy()?;
        let mut spp_done = self.start_samples + choice.film_samples;
        let mut stopped = false;
        let mut report = Vec::new();
        let mut launches = 0u32;
        let mut passes = 0u32;
        // The first launch is a small probe (a band of rows, one sample) to measure the rate,
        // unless the last render measured this strategy's.
        let probe = LaunchPlan {
            rows: height.min(GROUP as u32 * 2),
            spp: 1,
        };
        let mut plan = match self.launch_plan {
            Some((strategy, plan)) if strategy == self.strategy => plan,
            _ => probe,
        };
        // Pixel samples per second of the last pass, its error estimate and callback included,
        // once there is one.
        let mut last_rate = None;
        loop {
            let remaining = total.map_or(u32::MAX, |t| t.saturating_sub(spp_done));
            if remaining == 0 {
                break;
            }
            let mut count = plan.spp.min(remaining);
            if let Some(limit) = self.options.time_limit
                && spp_done > 0
            {
                let left = limit.as_secs_f64() - start.elapsed().as_secs_f64();
                count = match last_rate {
                    Some(rate) => pass_within(count, left, rate, pixels),
                    None if left > 0.0 => count,
                    None => 0,
                };
                if count == 0 {
                    break;
                }
            }
            let pass_start = Instant::now();
            let (pass_rate, pass_launches) = self.run_pass(plan, spp_done, count)?;
            launches += pass_launches;
            spp_done += count;
            passes += 1;
            if self.options.first_sample + spp_done > u32::MAX - (1 << 16) {
                break; // sample indices are 32-bit
            }
            let mut estimate = None;
            if estimate_errors && spp_done >= MIN_SPP_FOR_ESTIMATE {
                let row = self.pass_report(passes, spp_done, start)?;
                estimate = Some(row.estimate);
                report.push(row);
            }
            let elapsed = start.elapsed();
            let progress = Progress {
                spp_done,
                spp_total: total,
                elapsed,
                paths_per_second: pixels * (spp_done - self.start_samples) as f64
                    / elapsed.as_secs_f64().max(1e-9),
                estimate,
                strategy: self.strategy,
            };
            if on_pass(&progress, self)? == Flow::Stop {
                stopped = true;
                break;
            }
            if let (Some(target), Some(e)) = (self.options.target_error, estimate)
                && e.relmse <= target
                && settled(&report)
            {
                break;
            }
            last_rate = Some(pixels * f64::from(count) / pass_start.elapsed().as_secs_f64());
            // Plan the next pass from the slowest launch of this one.
            plan = LaunchPlan::for_rate(pass_rate, target, width, height);
        }
        self.launch_plan = Some((self.strategy, plan));
        Ok(Traced {
            elapsed: start.elapsed(),
            launches,
            passes,
            spp_done,
            report,
            choice,
            stopped,
        })
    }

    /// A film buffer read back, a pixel a row of four.
    fn read(&self, buffer: &ocl::Buffer<f32>) -> Result<Vec<[f32; 4]>> {
        let mut flat = vec![0.0f32; buffer.len()];
        buffer
            .read(&mut flat)
            .enq()
            .map_err(|e| Error::opencl("reading the film back", e))?;
        Ok(flat
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect())
    }

    /// Continues a render from a film that holds `samples` samples per pixel of `strategy`
    /// (indices `first_sample ..` of the options; a checkpoint, read by
    /// [`film_file::FilmState::read`]): the film goes onto the device bit for bit, and the next
    /// render runs `strategy` (no trial) from the next sample, so its image is the one an
    /// uninterrupted render gives.
    pub fn resume(
        &mut self,
        state: &film_file::FilmState,
        samples: u32,
        strategy: Strategy,
    ) -> Result<()> {
        if (state.width, state.height) != (self.width(), self.height()) {
            return Err(Error::Invalid(format!(
                "the film is {}x{}, the render {}x{}",
                state.width,
                state.height,
                self.width(),
                self.height()
            )));
        }
        if !self
            .estimators
            .iter()
            .any(|e| e.light_sampling == strategy.light_sampling)
        {
            return Err(Error::Invalid(format!(
                "the film was rendered with {strategy}, which these options leave out"
            )));
        }
        let fail = |e: ocl::Error| Error::opencl("writing the film to the device", e);
        for (buffer, values) in [
            (&self.film.sum, &state.sum),
            (&self.film.sum_lo, &state.sum_lo),
            (&self.film.sum_sq, &state.sum_sq),
            (&self.film.sum_odd, &state.sum_odd),
            (&self.film.sum_odd_lo, &state.sum_odd_lo),
        ] {
            buffer.write(values.as_flattened()).enq().map_err(fail)?;
        }
        self.film.bad.write(&state.bad).enq().map_err(fail)?;
        self.film
            .bad_first
            .write(&state.bad_first)
            .enq()
            .map_err(fail)?;
        self.fix_strategy(strategy)?;
        self.start_samples = samples;
        Ok(())
    }

    /// Makes every later render run `strategy`, without a trial.
    pub fn fix_strategy(&mut self, strategy: Strategy) -> Result<()> {
        self.candidates = vec![strategy];
        self.select(strategy)
    }

    /// The whole film as the device holds it (to write a film file).
    pub fn film_state(&self) -> Result<film_file::FilmState> {
        Ok(film_file::FilmState {
            width: self.width(),
            height: self.height(),
            sum: self.read(&self.film.sum)?,
            sum_lo: self.read(&self.film.sum_lo)?,
            sum_sq: self.read(&self.film.sum_sq)?,
            sum_odd: self.read(&self.film.sum_odd)?,
            sum_odd_lo: self.read(&self.film.sum_odd_lo)?,
            bad: read_counters(&self.film.bad)?,
            bad_first: read_counters(&self.film.bad_first)?,
        })
    }

    /// The non-finite samples the kernel counted (in `state`, read back), and the first of
    /// them.
    fn nonfinite(&self, state: &film_file::FilmState) -> NonFinite {
        let (bad, first) = (&state.bad, &state.bad_first);
        let width = self.width() as usize;
        let height = self.height() as usize;
        let mut out = NonFinite::default();
        let mut earliest: Option<(u32, usize)> = None;
        for (pixel, (&n, &f)) in bad.iter().zip(first).enumerate() {
            if n > 0 {
                out.count += u64::from(n);
                if earliest.is_none_or(|e| (f, pixel) < e) {
                    earliest = Some((f, pixel));
                }
            }
        }
        out.first = earliest.map(|(sample, pixel)| {
            let (x, row) = (pixel % width, pixel / width);
            (x as u32, (height - 1 - row) as u32, sample)
        });
        out
    }
}

/// A per-pixel counter buffer read back.
fn read_counters(buffer: &ocl::Buffer<u32>) -> Result<Vec<u32>> {
    let mut v = vec![0u32; buffer.len()];
    buffer
        .read(&mut v)
        .enq()
        .map_err(|e| Error::opencl("reading the sample counters back", e))?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::{default_launch_target, pass_within};
    use crate::device::{DeviceDescription, test_description};
    use std::time::Duration;

    #[test]
    fn launches_are_longest_on_a_gpu_without_a_watchdog() {
        let ms = |kind: &str, watchdog| {
            let device = DeviceDescription {
                watchdog,
                ..test_description(kind, "d")
            };
            default_launch_target(&device)
        };
        assert_eq!(ms("CPU", None), Duration::from_millis(100));
        assert_eq!(ms("CPU", Some(false)), Duration::from_millis(100));
        assert_eq!(ms("GPU", Some(false)), Duration::from_millis(4000));
        assert_eq!(ms("GPU", Some(true)), Duration::from_millis(400));
        assert_eq!(ms("GPU", None), Duration::from_millis(400));
    }

    #[test]
    fn a_time_limited_pass_takes_the_samples_that_fit() {
        let pixels = 1000.0;
        // 10,000 pixel samples a second: 10 samples a pixel a second.
        assert_eq!(pass_within(4, 1.0, 1e4, pixels), 4);
        assert_eq!(pass_within(40, 1.0, 1e4, pixels), 10);
        assert_eq!(pass_within(40, 0.15, 1e4, pixels), 1);
        // Less than one sample's time left, none, or past the limit: stop.
        assert_eq!(pass_within(4, 0.05, 1e4, pixels), 0);
        assert_eq!(pass_within(4, 0.0, 1e4, pixels), 0);
        assert_eq!(pass_within(4, -3.0, 1e4, pixels), 0);
        assert_eq!(pass_within(4, f64::NAN, 1e4, pixels), 0);
        // An unmeasurably fast pass runs whole.
        assert_eq!(pass_within(4, 1.0, f64::INFINITY, pixels), 4);
    }
}
