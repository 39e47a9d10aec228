//! Throughput measurement shared by `clpt bench` and `benches/render.rs`: a build from source
//! (cold unless the driver caches programs itself: `CUDA_CACHE_DISABLE=1`,
//! `POCL_KERNEL_CACHE=0`), one small warm-up launch, the timed render, then a warm start (the
//! whole setup of a render with the program in clpt's cache).

use super::{RenderOptions, Renderer};
use crate::device::Device;
use crate::device::program::KernelSources;
use crate::error::Result;
use crate::scene::Scene;

/// One scene's measurement.
#[derive(Clone, Debug)]
pub struct BenchResult {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// "scene" for the program specialised to the scene, "all" for the all-features one.
    pub program: &'static str,
    /// The estimator the render ran (chosen by the strategy trial unless fixed).
    pub strategy: String,
    /// The first build of the program(s) in this process (cold unless the driver cached it).
    pub build_seconds: f64,
    /// Setting up a render (scene packing and upload, program from clpt's cache).
    pub warm_start_seconds: f64,
    pub render_seconds: f64,
    /// Samples per pixel per second.
    pub samples_per_second: f64,
    pub paths_per_second: f64,
}

impl BenchResult {
    pub const MARKDOWN_HEADER: &'static str = "| scene | program | estimator | size | spp | first build s | warm start s | render s | samples/s (spp/s) | Mpaths/s |\n|---|---|---|---|---|---|---|---|---|---|";

    pub fn markdown_row(&self) -> String {
        format!(
            "| {} | {} | {} | {}x{} | {} | {:.2} | {:.3} | {:.3} | {:.2} | {:.2} |",
            self.name,
            self.program,
            self.strategy,
            self.width,
            self.height,
            self.spp,
            self.build_seconds,
            self.warm_start_seconds,
            self.render_seconds,
            self.samples_per_second,
            self.paths_per_second / 1e6
        )
    }
}

/// Measures `scene` rendered with `options` (its `spp` is the measured sample count).
pub fn bench_scene(
    device: &Device,
    sources: &KernelSources,
    name: &str,
    scene: &Scene,
    options: RenderOptions,
) -> Result<BenchResult> {
    // Cold: from source, and no cache of clpt's.
    let uncached = RenderOptions {
        cache_dir: None,
        ..options.clone()
    };
    let program = if options.all_features { "all" } else { "scene" };
    let mut renderer = Renderer::new(device, scene, sources, uncached.clone())?;
    let build_seconds: f64 = renderer
        .programs()
        .iter()
        .map(|(_, p)| p.build_time.as_secs_f64())
        .sum();
    renderer.warm_up()?;
    let (film, stats) = renderer.render(&mut |_| {})?;
    drop(renderer);
    // Warm: a cache of its own, so that the first setup stores and the second, timed, loads.
    let cache_dir = std::env::temp_dir().join(format!("clpt-bench-cache-{}", std::process::id()));
    let cached = RenderOptions {
        cache_dir: Some(cache_dir.clone()),
        ..uncached
    };
    drop(Renderer::new(device, scene, sources, cached.clone())?);
    let start = std::time::Instant::now();
    drop(Renderer::new(device, scene, sources, cached)?);
    let warm_start_seconds = start.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&cache_dir);
    let render_seconds = stats.elapsed.as_secs_f64();
    Ok(BenchResult {
        name: name.to_string(),
        width: film.width,
        height: film.height,
        spp: film.spp,
        program,
        strategy: stats.choice.to_string(),
        build_seconds,
        warm_start_seconds,
        render_seconds,
        samples_per_second: film.spp as f64 / render_seconds,
        paths_per_second: stats.paths_per_second,
    })
}
