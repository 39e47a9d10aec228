//! Throughput measurement shared by `clpt bench` and `benches/render.rs`: build (timed), a
//! one-sample warm-up render, then a timed render.

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
    /// The first build of the program in this process (cold unless the driver cached it).
    pub build_seconds: f64,
    pub render_seconds: f64,
    /// Samples per pixel per second.
    pub samples_per_second: f64,
    pub paths_per_second: f64,
}

impl BenchResult {
    pub const MARKDOWN_HEADER: &'static str = "| scene | size | spp | first build s | render s | samples/s (spp/s) | Mpaths/s |\n|---|---|---|---|---|---|---|";

    pub fn markdown_row(&self) -> String {
        format!(
            "| {} | {}x{} | {} | {:.2} | {:.3} | {:.2} | {:.2} |",
            self.name,
            self.width,
            self.height,
            self.spp,
            self.build_seconds,
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
    let warm_up = RenderOptions {
        spp: Some(1),
        time_limit: None,
        ..options.clone()
    };
    let mut renderer = Renderer::new(device, scene, sources, warm_up)?;
    let build_seconds = renderer.program.build_time.as_secs_f64();
    renderer.render(&mut |_| {})?;
    drop(renderer);
    let (film, stats) = Renderer::new(device, scene, sources, options)?.render(&mut |_| {})?;
    let render_seconds = stats.elapsed.as_secs_f64();
    Ok(BenchResult {
        name: name.to_string(),
        width: film.width,
        height: film.height,
        spp: film.spp,
        build_seconds,
        render_seconds,
        samples_per_second: film.spp as f64 / render_seconds,
        paths_per_second: stats.paths_per_second,
    })
}
