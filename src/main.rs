//! The `clpt` command line: `render`, `devices`, `bench`, `compare`, `plot`.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use clpt::device::program::{CacheUse, KernelSources};
use clpt::device::{self};
use clpt::output;
use clpt::render::bench::{BenchResult, bench_scene};
use clpt::render::film::Film;
use clpt::render::film_file::FilmState;
use clpt::render::metrics::{self, LinearImage};
use clpt::render::resume::{self, BackgroundWriter, FilmRecord};
use clpt::render::{
    Flow, MeshTree, ObjectBvh, Progress, RenderOptions, RenderStats, Renderer, TextureFilter,
    efficiency, film, report,
    strategy::{LightSampling, Roulette},
};
use clpt::render::{merge, multi, plot as plots};
use clpt::scene::{Scene, builtin};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "clpt",
    version,
    about = "A Monte Carlo path tracer on OpenCL (GPUs, or CPUs through PoCL)",
    long_about = "A Monte Carlo path tracer on OpenCL: renders scene files of the original CUDA \
                  course renderer's format, unbiased, on any OpenCL device.\n\nExamples:\n  \
                  clpt render                       # the built-in smallpt room -> smallpt.png\n  \
                  clpt render scene.txt --spp 256 -o out.exr\n  \
                  clpt devices                      # list OpenCL devices\n  \
                  clpt bench scenes/smallpt.txt     # samples/s and paths/s"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene file (the built-in smallpt room when none is given) to an image.
    Render(Box<RenderArgs>),
    /// List every OpenCL platform and device, with the index `--device` takes.
    Devices,
    /// Measure samples per second and paths per second on scenes.
    Bench(BenchArgs),
    /// Print RMSE, relMSE and MAE of an image against a reference (PFM, EXR, PNG, PPM).
    Compare(CompareArgs),
    /// Compare renders by their `--report` CSVs: relMSE x seconds (flat for an unbiased
    /// renderer), the time each needs to reach given errors, and a plot of it.
    Plot(PlotArgs),
    /// Join film files of shards of one render (`render --shard I/N --film F`) into its image
    /// and film.
    Merge(MergeArgs),
}

#[derive(Args)]
#[command(
    after_help = "Example:\n  for i in 1 2 3 4; do clpt render scene.txt --spp 4096 --shard $i/4 \\\n      --light-sampling off --rr-threshold 0.3 --film part$i.exr -o part$i.png; done\n  \
                  clpt merge part*.exr -o scene.png --film scene.exr"
)]
struct MergeArgs {
    /// Film files of one scene, seed and option set whose sample ranges join without overlap
    /// or gap.
    #[arg(required = true)]
    films: Vec<PathBuf>,
    /// The merged image (.png, .ppm, .pfm, .exr).
    #[arg(short, long, value_name = "FILE")]
    output: PathBuf,
    /// The merged film file.
    #[arg(long, value_name = "FILE.exr")]
    film: Option<PathBuf>,
}

#[derive(Args)]
#[command(
    after_help = "Example:\n  clpt render scene.txt --time 60 --reference ref.pfm --report nee.csv\n  \
    clpt render scene.txt --time 60 --reference ref.pfm --report pt.csv --no-nee\n  \
    clpt plot NEE=nee.csv 'path tracing=pt.csv' --reference-error 2e-5 -o efficiency.svg"
)]
struct PlotArgs {
    /// Reports as LABEL=FILE.csv (or FILE.csv, labelled by its name).
    #[arg(required = true)]
    runs: Vec<String>,
    /// The reference's own relMSE (the last relmse_estimate of its report), subtracted from
    /// every measured relMSE: a reference's variance adds to the error measured against it.
    #[arg(long, value_name = "E", default_value_t = 0.0)]
    reference_error: f64,
    /// The relMSE levels to give times for.
    #[arg(long, value_name = "E,...", value_delimiter = ',', default_values_t = [1e-2, 1e-3])]
    errors: Vec<f64>,
    /// Write the plot (SVG or PNG) of relMSE x seconds against seconds.
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// The plot's title.
    #[arg(
        long,
        default_value = "relMSE x seconds (flat: unbiased; lower: sooner to any error)"
    )]
    title: String,
}

#[derive(Args)]
struct CompareArgs {
    /// The image to measure.
    image: PathBuf,
    /// The reference it is measured against.
    reference: PathBuf,
    /// Write a false-colour picture of the per-pixel relative squared error (PNG).
    #[arg(long, value_name = "FILE")]
    error_image: Option<PathBuf>,
}

#[derive(Args)]
struct DeviceArgs {
    /// Device: an index from `clpt devices` or the start of a word of its name, 2 characters
    /// or more [env: CLPT_DEVICE]
    /// [default: the first GPU, else the first device]; `render` also takes `all` or a list
    /// (`0,2`) to split the samples over several devices.
    #[arg(short, long)]
    device: Option<String>,
    /// Read kernel sources from DIR instead of the copies built into the binary.
    #[arg(long, value_name = "DIR")]
    kernels: Option<PathBuf>,
}

impl DeviceArgs {
    /// `all` or a comma-separated list: several devices (each entry as --device takes it).
    fn several(&self) -> Option<Vec<String>> {
        match self.device.as_deref()? {
            "all" => Some(
                (0..device::list().map_or(0, |l| l.len()))
                    .map(|i| i.to_string())
                    .collect(),
            ),
            list if list.contains(',') => {
                Some(list.split(',').map(|s| s.trim().to_string()).collect())
            }
            _ => None,
        }
    }

    fn sources(&self) -> KernelSources {
        match &self.kernels {
            Some(dir) => KernelSources::Dir(dir.clone()),
            None => KernelSources::Embedded,
        }
    }

    fn open(&self) -> Result<(device::Device, KernelSources)> {
        let device = device::select(self.device.as_deref())?;
        let sources = match &self.kernels {
            Some(dir) => KernelSources::Dir(dir.clone()),
            None => KernelSources::Embedded,
        };
        Ok((device, sources))
    }
}

#[derive(Args)]
struct SamplingArgs {
    /// Random seed: the same seed on the same device gives the same image, bit for bit.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Override the scene's image width.
    #[arg(long)]
    width: Option<u32>,
    /// Override the scene's image height.
    #[arg(long)]
    height: Option<u32>,
    /// Safety cap on path length (bounces); Russian roulette ends paths without bias long before.
    #[arg(long, default_value_t = 65536)]
    max_depth: u32,
    /// Bounce from which Russian roulette may end a path.
    #[arg(long, default_value_t = 3)]
    rr_depth: u32,
    /// Roulette's threshold: paths whose largest throughput component is below T play
    /// roulette, survivors carry T; auto: 0.5 or 0.3, whichever a short trial finds reaches a
    /// given error sooner.
    #[arg(long, value_name = "auto|T", default_value = "auto")]
    rr_threshold: Roulette,
    /// Light sampling (next-event estimation with MIS): on, off (pure path tracing, as the
    /// original), or auto: whichever a short trial finds reaches a given error sooner.
    #[arg(long, value_name = "auto|on|off", default_value = "auto")]
    light_sampling: LightSampling,
    /// Texture lookups: bilinear, or nearest (the original's).
    #[arg(long, default_value = "bilinear")]
    texture_filter: TextureFilter,
    /// Largest texture image accepted, in pixels.
    #[arg(long, default_value_t = clpt::elements::texture::DEFAULT_MAX_PIXELS)]
    max_texture_pixels: u64,
    /// Largest scene file read, in bytes.
    #[arg(long, value_name = "BYTES", default_value_t = clpt::scene::DEFAULT_MAX_SCENE_BYTES)]
    max_scene_bytes: u64,
    /// Largest OBJ mesh file read, in bytes.
    #[arg(long, default_value_t = clpt::elements::mesh::DEFAULT_MAX_FILE_BYTES)]
    max_mesh_bytes: u64,
    /// Object BVH: auto (from 32 objects on), on, or off (test every object in turn).
    #[arg(long, default_value = "auto")]
    object_bvh: ObjectBvh,
    /// The same as --light-sampling off.
    #[arg(long, conflicts_with = "light_sampling")]
    no_nee: bool,
    /// How long one launch of the render runs, in milliseconds [default: 400 on a GPU, 1000 on a
    /// GPU without a kernel watchdog, 100 on a CPU]: shorter keeps a GPU that drives a display
    /// responsive (and within its watchdog), longer leaves its lanes less idle at the end of
    /// each launch.
    #[arg(long, value_name = "MS")]
    launch_ms: Option<f64>,
}

#[derive(Args)]
struct ProgramArgs {
    /// Build the program with every feature, not only those the scene uses.
    #[arg(long)]
    all_features: bool,
    /// Paths one work-item carries on a CPU device, in SIMD lanes: 1, 4, 8 or 16 [default:
    /// the device's native float vector width, where the scene's program has only what the
    /// wide kernels are written for so far (docs/cpu-lanes.md)]. GPUs always take 1.
    #[arg(long, value_name = "N", value_parser = parse_lanes)]
    lanes: Option<u32>,
    /// The tree meshes are walked through: kd (a SAH kd-tree), bvh2 (a binary BVH) or wide (an
    /// 8-wide BVH) [default: bvh2 on a GPU, wide on a CPU]. A CPU's wide program (--lanes above
    /// 1) takes only wide.
    #[arg(long, value_name = "TREE")]
    mesh_tree: Option<MeshTree>,
    /// Always build the program from source; neither read nor write the program cache.
    #[arg(long)]
    no_cache: bool,
    /// The program cache's folder [default: $CLPT_CACHE_DIR, else
    /// $XDG_CACHE_HOME/clpt/programs, else ~/.cache/clpt/programs]
    #[arg(long, value_name = "DIR")]
    cache_dir: Option<PathBuf>,
}

/// `--lanes`: 1, 4, 8 or 16 (the lane widths kernels/lanes.h builds).
fn parse_lanes(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n @ (1 | 4 | 8 | 16)) => Ok(n),
        _ => Err(format!("`{s}` is not 1, 4, 8 or 16")),
    }
}

impl ProgramArgs {
    fn cache_dir(&self) -> Option<PathBuf> {
        if self.no_cache {
            None
        } else {
            self.cache_dir
                .clone()
                .or_else(clpt::device::cache::default_dir)
        }
    }
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (seed dialect, see README); the built-in smallpt room if omitted.
    scene: Option<PathBuf>,
    /// Output image: .png, .ppm (8-bit, gamma 2.2), .pfm, .exr (linear float)
    /// [default: the scene's name with .png, in the current directory]
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Samples (paths) per pixel [default: 64, or no limit with --time]
    #[arg(long)]
    spp: Option<u32>,
    /// Stop within this many seconds: no pass starts that would end after it (the first pass,
    /// one sample a pixel at the least, always runs).
    #[arg(long, value_name = "SECONDS")]
    time: Option<f64>,
    /// Stop at the first pass whose estimated relMSE is at most E, once the estimate has
    /// settled (relMSE x spp grown by at most 25% since half the samples); at the latest at
    /// --spp, or --time, or without either at 65536 samples per pixel.
    #[arg(long, value_name = "E")]
    target_error: Option<f64>,
    /// A converged image of the same scene and size (PFM or EXR): the report then gives the
    /// true error too.
    #[arg(long, value_name = "FILE")]
    reference: Option<PathBuf>,
    /// Write the per-pass report (time, spp, spp/s, error) as CSV or JSON.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Plot error against time (log-log) as SVG or PNG.
    #[arg(long, value_name = "FILE")]
    plot: Option<PathBuf>,
    /// Write the film file (OpenEXR): the mean image for viewers, and every sum the render
    /// accumulated, bit for bit, with what made it (scene, options, seed, samples, device).
    #[arg(long, value_name = "FILE.exr")]
    film: Option<PathBuf>,
    /// Keep a checkpoint (a film file, OpenEXR) of the render, rewritten every
    /// --checkpoint-every seconds and at the end. Ctrl-C or SIGTERM finishes the pass in flight
    /// and writes the image and the checkpoint (by default SCENE.checkpoint.exr beside the
    /// image) before exiting; a second Ctrl-C exits at once.
    #[arg(long, value_name = "FILE.exr")]
    checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints.
    #[arg(long, value_name = "SECONDS", default_value_t = 60.0)]
    checkpoint_every: f64,
    /// Continue the render that wrote this checkpoint (or film file) from its next sample: the
    /// same scene file, seed and options, up to --spp samples in all; the image is bit for bit
    /// that of an uninterrupted render.
    #[arg(long, value_name = "FILE.exr")]
    resume: Option<PathBuf>,
    /// Render only samples START..END of each pixel (START a multiple of 8), one shard of a
    /// longer render; write it with --film and join the shards with `clpt merge`. Needs a
    /// fixed estimator (--light-sampling on|off, --rr-threshold T).
    #[arg(long, value_name = "START..END", conflicts_with_all = ["spp", "shard"])]
    samples: Option<String>,
    /// Render shard I of N (I from 1) of the --spp samples, split in whole groups of eight:
    /// as --samples with the range computed.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    #[command(flatten)]
    sampling: SamplingArgs,
    #[command(flatten)]
    program: ProgramArgs,
    #[command(flatten)]
    device: DeviceArgs,
    /// Write the exact program source that was built (includes expanded, switched-off code
    /// left out) to FILE.
    #[arg(long, value_name = "FILE")]
    dump_kernel: Option<PathBuf>,
    /// Print the device, the scene's features, the build options, the program cache and
    /// timings.
    #[arg(short, long)]
    verbose: bool,
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
}

#[derive(Args)]
struct BenchArgs {
    /// Scene files [default: the built-in smallpt room]
    scenes: Vec<PathBuf>,
    /// Samples per pixel of each measured render.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    #[command(flatten)]
    sampling: SamplingArgs,
    #[command(flatten)]
    program: ProgramArgs,
    #[command(flatten)]
    device: DeviceArgs,
}

fn load_scene(path: Option<&Path>, sampling: &SamplingArgs) -> Result<Scene> {
    let mut scene = match path {
        Some(p) => Scene::load_limited(p, sampling.max_scene_bytes)?,
        None => builtin::scene()?,
    };
    for w in &scene.warnings {
        eprintln!("{w}");
    }
    if let Some(w) = sampling.width {
        scene.camera.width = w;
    }
    if let Some(h) = sampling.height {
        scene.camera.height = h;
    }
    Ok(scene)
}

fn options(
    sampling: &SamplingArgs,
    program: &ProgramArgs,
    spp: Option<u32>,
    time: Option<f64>,
) -> Result<RenderOptions> {
    let time_limit = match time {
        Some(t) if t.is_finite() && t > 0.0 => Some(
            Duration::try_from_secs_f64(t)
                .map_err(|_| anyhow::anyhow!("--time {t}: too long a time limit"))?,
        ),
        Some(t) => bail!("--time must be a positive number of seconds, got {t}"),
        None => None,
    };
    if spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    if sampling.max_depth == 0 {
        bail!("--max-depth must be at least 1");
    }
    let launch_target = match sampling.launch_ms {
        Some(ms) if ms.is_finite() && (1.0..=60_000.0).contains(&ms) => {
            Some(Duration::from_secs_f64(ms / 1000.0))
        }
        Some(ms) => bail!("--launch-ms must be between 1 and 60000, got {ms}"),
        None => None,
    };
    Ok(RenderOptions {
        spp: spp.or(if time_limit.is_some() { None } else { Some(64) }),
        time_limit,
        seed: sampling.seed,
        max_depth: sampling.max_depth,
        rr_depth: sampling.rr_depth,
        texture_filter: sampling.texture_filter,
        max_texture_pixels: sampling.max_texture_pixels,
        max_mesh_bytes: sampling.max_mesh_bytes,
        object_bvh: sampling.object_bvh,
        light_sampling: if sampling.no_nee {
            LightSampling::Off
        } else {
            sampling.light_sampling
        },
        roulette: sampling.rr_threshold,
        launch_target,
        all_features: program.all_features,
        lanes: program.lanes,
        mesh_tree: program.mesh_tree,
        cache_dir: program.cache_dir(),
        ..RenderOptions::default()
    })
}

fn default_output(scene: Option<&Path>) -> PathBuf {
    let stem = scene
        .and_then(|p| p.file_stem())
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| builtin::NAME.to_string());
    PathBuf::from(format!("{stem}.png"))
}

/// The most samples per pixel `--target-error` renders when neither `--spp` nor `--time` bounds it.
const TARGET_ERROR_MAX_SPP: u32 = 1 << 16;

/// A render on a CPU device given neither `--spp`, `--time` nor `--target-error` stops at the
/// default samples or after this long, whichever comes first: the README's first render (the
/// built-in room at 1024x768, 64 samples) took 75 s on 2 cores, where a newcomer should see a
/// picture within 20 s. A GPU renders the 64 samples in well under a second.
const CPU_DEFAULT_SECONDS: u64 = 12;

/// Renders; the exit status: 0, or 130 (SIGINT) or 143 (SIGTERM) when a signal ended the
/// render after writing its image and checkpoint.
fn render(args: &RenderArgs) -> Result<u8> {
    let scene = load_scene(args.scene.as_deref(), &args.sampling)?;
    let (mut options, range) = render_options(args)?;
    let outputs = check_outputs(args)?;
    let resumed = read_checkpoint(args, &scene, &mut options)?;
    if let Some(list) = args.device.several() {
        return render_on_devices(args, &scene, &options, &outputs.image, &list);
    }
    let stop = stop_on_signals()?;
    let (device, sources) = args.device.open()?;
    if args.verbose {
        eprintln!("device: {}", device.description);
    }
    let open_ended = range.is_none() && resumed.is_none();
    if open_ended && device.description.kind == "CPU" {
        limit_cpu_render(args, &mut options);
    }
    let mut renderer = Renderer::new(&device, &scene, &sources, options.clone())?;
    if let Some(c) = &resumed {
        renderer.resume(&c.state, c.samples(), c.strategy)?;
        if args.verbose {
            eprintln!(
                "resuming {}: {} samples per pixel, {}, {:.2} s so far",
                args.resume.as_deref().unwrap_or(Path::new("")).display(),
                c.samples(),
                c.strategy,
                c.meta.seconds
            );
        }
    }
    let record = FilmRecord {
        scene_file: args.scene.as_deref(),
        options: &options,
        device: &device.description.name,
        seconds_before: resumed.as_ref().map_or(0.0, |c| c.meta.seconds),
    };
    if let Some(path) = &args.dump_kernel {
        dump_kernels(path, &renderer)?;
    }
    if args.verbose {
        print_setup(&scene, &renderer);
    } else {
        warn_uncached(&renderer);
    }
    let bar = progress_bar(args.quiet, options.spp)?;
    let (film, stats) = render_with_checkpoints(
        args,
        &outputs.checkpoint,
        &bar,
        &stop,
        &record,
        &mut renderer,
    )?;
    bar.finish_and_clear();
    let title = format!("{} on {}", scene.source, device.description.name);
    write_outputs(args, &outputs, &record, &renderer, (&film, &stats), &title)?;
    print_summary(args, &options, &outputs.image, &film, &stats);
    if stats.stopped {
        let (name, status) = stop.signal();
        let total = options.spp.map_or(String::new(), |n| format!(" of {n}"));
        eprintln!(
            "{name}: stopped after {}{total} samples per pixel; the image and the checkpoint {} \
             hold them. Resume with the same command and `--resume {}`.",
            film.spp,
            outputs.checkpoint.display(),
            outputs.checkpoint.display()
        );
        return Ok(status);
    }
    Ok(0)
}

/// `--resume FILE`: the checkpoint to continue, its estimator fixed in `options`.
fn read_checkpoint(
    args: &RenderArgs,
    scene: &Scene,
    options: &mut RenderOptions,
) -> Result<Option<resume::Checkpoint>> {
    let Some(path) = &args.resume else {
        return Ok(None);
    };
    let c = resume::read_for_resume(
        path,
        args.scene.as_deref(),
        options,
        (scene.camera.width, scene.camera.height),
    )?;
    c.fix_strategy(options);
    Ok(Some(c))
}

/// A CPU render given neither `--spp`, `--time` nor `--target-error` stops after
/// [`CPU_DEFAULT_SECONDS`], and says so.
fn limit_cpu_render(args: &RenderArgs, options: &mut RenderOptions) {
    if args.spp.is_some() || args.time.is_some() || args.target_error.is_some() {
        return;
    }
    options.time_limit = Some(Duration::from_secs(CPU_DEFAULT_SECONDS));
    if !args.quiet {
        eprintln!(
            "on a CPU device a render stops after {CPU_DEFAULT_SECONDS} s unless --spp or \
             --time says otherwise"
        );
    }
}

/// The render's options from the command line: sampling and program options, the shard's
/// sample range (`--samples`, `--shard`), `--target-error` and `--reference`.
fn render_options(args: &RenderArgs) -> Result<(RenderOptions, Option<(u32, u32)>)> {
    let mut options = options(&args.sampling, &args.program, args.spp, args.time)?;
    let range = match (&args.samples, &args.shard) {
        (Some(text), _) => Some(merge::parse_samples(text).map_err(anyhow::Error::msg)?),
        (None, Some(text)) => {
            let Some(total) = args.spp else {
                bail!("--shard needs --spp: the samples of the whole render that it splits");
            };
            Some(merge::shard_range(text, total).map_err(anyhow::Error::msg)?)
        }
        (None, None) => None,
    };
    if let Some((start, end)) = range {
        if options.light_sampling == LightSampling::Auto
            || matches!(options.roulette, Roulette::Auto)
        {
            bail!(
                "a shard needs a fixed estimator (--light-sampling on|off and --rr-threshold T): \
                 each shard's trial could choose differently, and films of different estimators \
                 do not merge. `clpt render SCENE --spp 64 -v` shows what the trial picks"
            );
        }
        options.first_sample = start;
        options.spp = Some(end - start);
    }
    if let Some(e) = args.target_error {
        if !(e.is_finite() && e > 0.0) {
            bail!("--target-error must be a positive number, got {e}");
        }
        options.target_error = Some(e);
        if args.spp.is_none() {
            // The target decides, within --time; without one, within a cap, so that an
            // unreachable target (1e-30) still ends.
            options.spp = if args.time.is_some() {
                None
            } else {
                Some(TARGET_ERROR_MAX_SPP)
            };
        }
    }
    if let Some(path) = &args.reference {
        options.reference = Some(std::sync::Arc::new(LinearImage::read(path)?));
    }
    Ok((options, range))
}

/// Where a render writes: the image, and its checkpoint (`--checkpoint`, or beside the image,
/// for when a signal ends the render).
struct RenderOutputs {
    image: PathBuf,
    checkpoint: PathBuf,
}

/// Every output a render names, checked before any work: a typo in a folder or format must not
/// cost a render.
fn check_outputs(args: &RenderArgs) -> Result<RenderOutputs> {
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(args.scene.as_deref()));
    output::check_writable(&output, film::FORMATS)?;
    if let Some(path) = &args.report {
        output::check_writable(path, report::REPORT_FORMATS)?;
    }
    if let Some(path) = &args.plot {
        output::check_writable(path, plots::PLOT_FORMATS)?;
    }
    if let Some(path) = &args.dump_kernel {
        output::check_writable(path, &[])?;
    }
    if let Some(path) = &args.film {
        output::check_writable(path, &["exr"])?;
    }
    if !(args.checkpoint_every.is_finite() && args.checkpoint_every > 0.0) {
        bail!(
            "--checkpoint-every must be a positive number of seconds, got {}",
            args.checkpoint_every
        );
    }
    let checkpoint = args.checkpoint.clone().unwrap_or_else(|| {
        let stem = output.file_stem().unwrap_or_default().to_string_lossy();
        output.with_file_name(format!("{stem}.checkpoint.exr"))
    });
    output::check_writable(&checkpoint, &["exr"])?;
    Ok(RenderOutputs {
        image: output,
        checkpoint,
    })
}

/// `--dump-kernel FILE`: the exact source of each program built.
fn dump_kernels(path: &Path, renderer: &Renderer) -> Result<()> {
    // The first program (with light sampling when that is a candidate); a second one
    // beside it, named FILE.no-nee, when the trial may choose either.
    for (i, e) in renderer.estimators().iter().enumerate() {
        let file = if i == 0 {
            path.to_path_buf()
        } else {
            let mut name = path.as_os_str().to_owned();
            name.push(".no-nee");
            PathBuf::from(name)
        };
        output::write_bytes(&file, e.program.source.text.as_bytes())?;
    }
    Ok(())
}

/// A program that could not be cached costs its build again next time: said once per reason
/// (`-v` says it of every program).
fn warn_uncached(renderer: &Renderer) {
    let mut not_cached: Vec<&str> = Vec::new();
    for (_, program) in renderer.programs() {
        if let CacheUse::NotStored(why) = &program.cache
            && !not_cached.contains(&why.as_str())
        {
            not_cached.push(why);
            eprintln!(
                "warning: the built program was not cached ({why}); the next run builds it again"
            );
        }
    }
}

/// `-v`: the features, programs, estimators and scene the render runs with.
fn print_setup(scene: &Scene, renderer: &Renderer) {
    for e in renderer.estimators() {
        eprintln!("features ({}): {}", e.label(), e.features);
    }
    for (which, program) in renderer.programs() {
        let seconds = program.build_time.as_secs_f64();
        let origin = match &program.cache {
            CacheUse::Off => format!("built in {seconds:.2} s (no program cache)"),
            CacheUse::Hit(path) => {
                format!(
                    "loaded from the cache in {seconds:.2} s ({})",
                    path.display()
                )
            }
            CacheUse::Stored(path) => {
                format!("built in {seconds:.2} s, cached as {}", path.display())
            }
            CacheUse::NotStored(why) => {
                format!("built in {seconds:.2} s, not cached: {why}")
            }
        };
        eprintln!("program ({which}): {origin}, options `{}`", program.options);
    }
    let candidates: Vec<String> = renderer
        .candidates()
        .iter()
        .map(|c| c.to_string())
        .collect();
    eprintln!("estimators tried: {}", candidates.join("; "));
    eprintln!(
        "scene: {} ({}x{}), {} materials, {} spheres, {} planes, {} mesh instances, {} transforms",
        scene.source,
        renderer.width(),
        renderer.height(),
        renderer.packed.materials.len(),
        renderer.packed.spheres.len(),
        renderer.packed.planes.len(),
        renderer.packed.mesh_instances.len(),
        renderer.packed.transforms.len()
    );
    eprintln!("{}", renderer.packed.textures.report());
    eprintln!("{}", renderer.packed.mesh_report());
}

/// The progress bar: samples done of `spp`, or a spinner when the render has no sample count.
fn progress_bar(quiet: bool, spp: Option<u32>) -> Result<ProgressBar> {
    Ok(if quiet {
        ProgressBar::hidden()
    } else {
        match spp {
            Some(n) => ProgressBar::new(n as u64).with_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} spp  {msg}  ETA {eta}",
                )?
                .progress_chars("=> "),
            ),
            None => ProgressBar::new_spinner().with_style(ProgressStyle::with_template(
                "{elapsed_precise} {spinner} {pos} spp  {msg}",
            )?),
        }
    })
}

/// The render's passes, with the progress bar and the checkpoint kept up as they end: every
/// `--checkpoint-every` seconds with `--checkpoint`, and at once when a signal stops the render.
fn render_with_checkpoints(
    args: &RenderArgs,
    checkpoint: &Path,
    bar: &ProgressBar,
    stop: &StopSignals,
    record: &FilmRecord,
    renderer: &mut Renderer,
) -> Result<(Film, RenderStats)> {
    let every = Duration::from_secs_f64(args.checkpoint_every);
    let mut last_checkpoint = Instant::now();
    let mut writer = BackgroundWriter::default();
    let done = renderer.render_with(&mut |p: &Progress, r: &Renderer| {
        bar.set_position(p.spp_done as u64);
        let spp_per_second = p.spp_done as f64 / p.elapsed.as_secs_f64().max(1e-9);
        let error = p.estimate.map_or(String::new(), |e| {
            format!(", est. RMSE {:.2e}, relMSE {:.2e}", e.rmse, e.relmse)
        });
        let s = p.strategy;
        bar.set_message(format!(
            "{spp_per_second:.1} spp/s, {:.2} Mpaths/s{error} [light sampling {}, rr < {}]",
            p.paths_per_second / 1e6,
            if s.light_sampling { "on" } else { "off" },
            s.rr_threshold
        ));
        let signalled = stop.interrupted();
        let seconds = p.elapsed.as_secs_f64();
        if signalled {
            // The last checkpoint before exiting: written here and now, after any in flight.
            writer.wait()?;
            record.write(checkpoint, r, p.strategy, p.spp_done, seconds)?;
        } else if args.checkpoint.is_some() && last_checkpoint.elapsed() >= every {
            record.write_in_background(
                &mut writer,
                checkpoint,
                r,
                p.strategy,
                p.spp_done,
                seconds,
            )?;
            last_checkpoint = Instant::now();
        }
        Ok(if signalled {
            Flow::Stop
        } else {
            Flow::Continue
        })
    })?;
    writer.wait()?;
    Ok(done)
}

/// The image and every other output asked for: the film file, the last checkpoint, the report
/// and the plot (titled `title`).
fn write_outputs(
    args: &RenderArgs,
    outputs: &RenderOutputs,
    record: &FilmRecord,
    renderer: &Renderer,
    (film, stats): (&Film, &RenderStats),
    title: &str,
) -> Result<()> {
    film.write(&outputs.image)?;
    let (strategy, seconds) = (stats.choice.strategy(), stats.elapsed.as_secs_f64());
    if let Some(path) = &args.film {
        record.write(path, renderer, strategy, film.spp, seconds)?;
    }
    if args.checkpoint.is_some() && !stats.stopped {
        record.write(&outputs.checkpoint, renderer, strategy, film.spp, seconds)?;
    }
    if let Some(path) = &args.report {
        report::write_report(path, &stats.report, &stats.choice)?;
    }
    if let Some(path) = &args.plot {
        plots::write_plot(path, &stats.report, title)?;
    }
    Ok(())
}

/// What the render did: its estimator, samples left out, the error reached, its figures.
fn print_summary(
    args: &RenderArgs,
    options: &RenderOptions,
    image: &Path,
    film: &Film,
    stats: &RenderStats,
) {
    eprintln!("estimator: {}", stats.choice);
    if args.verbose && stats.choice.was_measured() {
        for line in stats.choice.trial_lines() {
            eprintln!("  trial: {line}");
        }
    }
    if stats.nonfinite.count > 0 {
        let first = stats
            .nonfinite
            .first
            .map_or(String::new(), |(x, y, sample)| {
                format!("; the first at pixel ({x}, {y}) from the top left, sample {sample}")
            });
        eprintln!(
            "warning: {} path samples were infinite or NaN and were left out of the image (counted as 0){first}",
            stats.nonfinite.count
        );
    }
    if let Some((x, y)) = stats.overflowed.first {
        eprintln!(
            "warning: {} pixels are infinite in the image: their samples were finite, but their \
             sum overflowed f32 (an emission near f32's largest value, 3.4e38?); the first at \
             pixel ({x}, {y}) from the top left",
            stats.overflowed.pixels
        );
    }
    if let Some(last) = stats.report.last() {
        let measured = last.measured.map_or(String::new(), |m| {
            format!(
                "; against the reference RMSE {:.3e}, relMSE {:.3e}, MAE {:.3e}",
                m.rmse, m.relmse, m.mae
            )
        });
        eprintln!(
            "convergence: estimated RMSE {:.3e}, relMSE {:.3e}{measured}",
            last.estimate.rmse, last.estimate.relmse
        );
        if let Some(target) = options.target_error
            && last.estimate.relmse > target
            && !stats.stopped
        {
            eprintln!(
                "warning: the target relMSE {target:.3e} was not reached by {} samples per pixel{}",
                film.spp,
                if args.spp.is_none() && args.time.is_none() {
                    " (the cap without --spp or --time)"
                } else {
                    ""
                }
            );
        }
    }
    eprintln!(
        "{}: {}x{}, {} spp in {:.2} s ({:.2} Mpaths/s)",
        image.display(),
        film.width,
        film.height,
        film.spp,
        stats.elapsed.as_secs_f64(),
        stats.paths_per_second / 1e6
    );
    if args.verbose {
        eprintln!("{} passes, {} launches", stats.passes, stats.launches);
    }
}

/// `render --device all|A,B,...`: the samples split over several devices (render/multi.rs).
fn render_on_devices(
    args: &RenderArgs,
    scene: &Scene,
    options: &RenderOptions,
    output: &Path,
    list: &[String],
) -> Result<u8> {
    check_multi_args(args)?;
    let (list, devices) = open_devices(list)?;
    let total = options.spp.unwrap_or(64);
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(total as u64).with_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {pos}/{len} spp  {msg}  ETA {eta}",
            )?
            .progress_chars("=> "),
        )
    };
    let pixels = f64::from(scene.camera.width) * f64::from(scene.camera.height);
    let result = multi::render_on_devices(
        &devices,
        scene,
        &args.device.sources(),
        options,
        multi::Balance::default(),
        &|p: &multi::MultiProgress| show_multi_progress(&bar, p, pixels),
    )?;
    bar.finish_and_clear();
    let film = result.film.film(total);
    film.write(output)?;
    if let Some(path) = &args.film {
        let names: Vec<&str> = result.shares.iter().map(|s| s.device.as_str()).collect();
        FilmRecord {
            scene_file: args.scene.as_deref(),
            options,
            device: &names.join(", "),
            seconds_before: 0.0,
        }
        .write_state(
            path,
            &result.film,
            (scene.camera.width, scene.camera.height),
            result.choice.strategy(),
            total,
            result.elapsed.as_secs_f64(),
        )?;
    }
    eprintln!("estimator: {}", result.choice);
    for (i, s) in result.shares.iter().enumerate() {
        eprintln!(
            "device {}: {} ({} compute units), {} spp ({:.0}%) in {:.2} s",
            list[i],
            s.device,
            devices[i].description.compute_units,
            s.samples,
            100.0 * f64::from(s.samples) / f64::from(total.max(1)),
            s.seconds
        );
    }
    let e = result.film.estimated_error(total);
    eprintln!(
        "{}: {}x{}, {total} spp on {} device{} in {:.2} s ({:.2} Mpaths/s); estimated RMSE {:.3e}, relMSE {:.3e}",
        output.display(),
        film.width,
        film.height,
        devices.len(),
        if devices.len() == 1 { "" } else { "s" },
        result.elapsed.as_secs_f64(),
        pixels * f64::from(total) / result.elapsed.as_secs_f64().max(1e-9) / 1e6,
        e.rmse,
        e.relmse
    );
    Ok(0)
}

/// Refuses what several devices do not do (yet): they render a sample count to an image.
fn check_multi_args(args: &RenderArgs) -> Result<()> {
    for (given, flag) in [
        (args.resume.is_some(), "--resume"),
        (args.checkpoint.is_some(), "--checkpoint"),
        (args.report.is_some(), "--report"),
        (args.plot.is_some(), "--plot"),
        (args.reference.is_some(), "--reference"),
        (args.target_error.is_some(), "--target-error"),
        (args.time.is_some(), "--time"),
        (args.dump_kernel.is_some(), "--dump-kernel"),
    ] {
        if given {
            bail!("{flag} works with one device; several devices render a sample count (--spp)");
        }
    }
    Ok(())
}

/// The devices of `--device` `list`, each with its entry, GPUs first: the first device renders
/// the first chunk and the trial, and a CPU's would hold up the rest.
fn open_devices(list: &[String]) -> Result<(Vec<String>, Vec<device::Device>)> {
    if list.is_empty() {
        bail!("--device all: no OpenCL device found");
    }
    let mut devices = list
        .iter()
        .map(|d| {
            // One host thread for each other device's driver (device::select_reserving).
            device::select_reserving(Some(d), list.len() as u32 - 1)
                .with_context(|| format!("--device entry `{d}`"))
                .map(|device| (d.clone(), device))
        })
        .collect::<Result<Vec<_>>>()?;
    devices.sort_by_key(|(_, d)| d.description.kind == "CPU");
    Ok(devices.into_iter().unzip())
}

/// The progress bar of several devices: samples done, the rate, each device's share.
fn show_multi_progress(bar: &ProgressBar, p: &multi::MultiProgress, pixels: f64) {
    bar.set_position(p.spp_done as u64);
    let rate = pixels * f64::from(p.spp_done) / p.elapsed.as_secs_f64().max(1e-9);
    let shares: Vec<String> = p
        .shares
        .iter()
        .map(|s| {
            format!(
                "{}%",
                (100 * s.samples).checked_div(p.spp_done).unwrap_or(0)
            )
        })
        .collect();
    bar.set_message(format!(
        "{:.2} Mpaths/s, shares {}",
        rate / 1e6,
        shares.join(" ")
    ));
}

/// SIGINT and SIGTERM: the first sets the flag the render loop reads after each pass (it then
/// writes the image and the checkpoint and exits 130 or 143); a second exits at once with that
/// status.
struct StopSignals {
    stop: Arc<AtomicBool>,
    sigterm: Arc<AtomicBool>,
}

impl StopSignals {
    fn interrupted(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// The signal's name and the exit status it calls for.
    fn signal(&self) -> (&'static str, u8) {
        if self.sigterm.load(Ordering::Relaxed) {
            ("SIGTERM", 143)
        } else {
            ("interrupted", 130)
        }
    }
}

fn stop_on_signals() -> Result<StopSignals> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let stop = Arc::new(AtomicBool::new(false));
    let sigterm = Arc::new(AtomicBool::new(false));
    for (signal, status) in [(SIGINT, 130), (SIGTERM, 143)] {
        // In this order: a second signal finds `stop` set and exits before setting it again.
        signal_hook::flag::register_conditional_shutdown(signal, status, Arc::clone(&stop))?;
        signal_hook::flag::register(signal, Arc::clone(&stop))?;
    }
    signal_hook::flag::register(SIGTERM, Arc::clone(&sigterm))?;
    Ok(StopSignals { stop, sigterm })
}

fn merge_films(args: &MergeArgs) -> Result<()> {
    output::check_writable(&args.output, film::FORMATS)?;
    if let Some(path) = &args.film {
        output::check_writable(path, &["exr"])?;
    }
    let parts = args
        .films
        .iter()
        .map(|p| merge::Part::read(p))
        .collect::<clpt::error::Result<Vec<_>>>()?;
    let count = parts.len();
    let (state, meta): (FilmState, _) = merge::merge(parts)?;
    let spp = meta.samples.1 - meta.samples.0;
    state.film(spp).write(&args.output)?;
    if let Some(path) = &args.film {
        state.write(path, &meta)?;
    }
    let e = state.estimated_error(spp);
    eprintln!(
        "{}: {count} films, samples {}..{} ({spp} spp), {:.2} s of rendering on {}; estimated RMSE {:.3e}, relMSE {:.3e}",
        args.output.display(),
        meta.samples.0,
        meta.samples.1,
        meta.seconds,
        meta.device,
        e.rmse,
        e.relmse
    );
    Ok(())
}

fn compare(args: &CompareArgs) -> Result<()> {
    if let Some(path) = &args.error_image {
        output::check_writable(path, &["png"])?;
    }
    let image = LinearImage::read(&args.image)?;
    let reference = LinearImage::read(&args.reference)?;
    let m = image.metrics(&reference)?;
    println!(
        "RMSE {:.6e}\nrelMSE {:.6e} (eps {})\nMAE {:.6e}",
        m.rmse,
        m.relmse,
        metrics::REL_EPSILON,
        m.mae
    );
    if let Some(path) = &args.error_image {
        image.write_error_image(&reference, path)?;
    }
    Ok(())
}

fn plot(args: &PlotArgs) -> Result<()> {
    if let Some(path) = &args.output {
        output::check_writable(path, plots::PLOT_FORMATS)?;
    }
    let runs = args
        .runs
        .iter()
        .map(|arg| {
            let (label, file) = match arg.split_once('=') {
                Some((label, file)) => (label.to_string(), PathBuf::from(file)),
                None => {
                    let file = PathBuf::from(arg);
                    let stem = file
                        .file_stem()
                        .map_or(arg.clone(), |s| s.to_string_lossy().into());
                    (stem, file)
                }
            };
            let rows = report::read_report(&file)?;
            Ok(efficiency::Run { label, rows })
        })
        .collect::<Result<Vec<_>>>()?;
    print!("{:<24} {:>10} {:>14}", "run", "spp/s", "relMSE x s");
    for e in &args.errors {
        print!(" {:>14}", format!("s to {e:e}"));
    }
    println!();
    for run in &runs {
        let summary = efficiency::summarize(run, args.reference_error)?;
        print!(
            "{:<24} {:>10.1} {:>14.4e}",
            run.label, summary.spp_per_second, summary.level
        );
        for &e in &args.errors {
            let t = summary.time_to(e);
            let mark = if t > summary.seconds { "*" } else { "" };
            print!(" {:>14}", format!("{t:.3}{mark}"));
        }
        println!(
            "{}",
            if summary.measured {
                ""
            } else {
                "  (estimated error)"
            }
        );
    }
    println!(
        "relMSE x s: median over each run's last decade of time; * past the run's end (MSE x t flat)"
    );
    if let Some(path) = &args.output {
        plots::write_efficiency_plot(path, &runs, args.reference_error, &args.title)?;
    }
    Ok(())
}

fn devices() -> Result<()> {
    for (_, _, d) in device::list()? {
        println!("{d}");
    }
    Ok(())
}

fn bench(args: &BenchArgs) -> Result<()> {
    let (device, sources) = args.device.open()?;
    println!("device: {}", device.description);
    println!("{}", BenchResult::MARKDOWN_HEADER);
    let scenes: Vec<Option<&Path>> = if args.scenes.is_empty() {
        vec![None]
    } else {
        args.scenes.iter().map(|p| Some(p.as_path())).collect()
    };
    for path in scenes {
        let name = path.map_or(builtin::NAME.to_string(), |p| p.display().to_string());
        let scene = load_scene(path, &args.sampling).with_context(|| name.clone())?;
        let options = options(&args.sampling, &args.program, Some(args.spp), None)?;
        let result = bench_scene(&device, &sources, &name, &scene, options)?;
        println!("{}", result.markdown_row());
    }
    Ok(())
}

/// Runs the command; an error is printed as its message and its causes on one line, exit
/// status 1. A user's mistake is not a crash: no backtrace, whatever RUST_BACKTRACE says.
fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Render(args) => render(args),
        Command::Devices => devices().map(|()| 0),
        Command::Bench(args) => bench(args).map(|()| 0),
        Command::Compare(args) => compare(args).map(|()| 0),
        Command::Plot(args) => plot(args).map(|()| 0),
        Command::Merge(args) => merge_films(args).map(|()| 0),
    };
    match result {
        Ok(status) => std::process::ExitCode::from(status),
        Err(e) => {
            // The causes, each once: many messages already quote their source.
            let mut message = e.to_string();
            for cause in e.chain().skip(1).map(|c| c.to_string()) {
                if !message.contains(&cause) {
                    message = format!("{message}: {cause}");
                }
            }
            eprintln!("Error: {message}");
            std::process::ExitCode::FAILURE
        }
    }
}
