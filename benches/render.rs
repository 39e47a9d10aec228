//! `cargo bench`: samples/s and paths/s of the built-in smallpt room, and of the original's
//! case2 when `../shared/seed` is there, on the default device (`CLPT_DEVICE` picks another).
//! The same measurement as `clpt bench`; BENCHMARKS.md records both with their machines.

use clpt::device::{self, program::KernelSources};
use clpt::render::RenderOptions;
use clpt::render::bench::{BenchResult, bench_scene};
use clpt::scene::{Scene, builtin};
use std::path::Path;

fn main() -> Result<(), clpt::Error> {
    let device = device::select(None)?;
    println!("device: {}", device.description);
    println!("{}", BenchResult::MARKDOWN_HEADER);
    let options = RenderOptions {
        spp: Some(16),
        ..RenderOptions::default()
    };
    let mut scenes = vec![(builtin::NAME.to_string(), builtin::scene()?)];
    let case2 = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/seed/testcases/case2_softshadows_colorbleeding.txt");
    if case2.is_file() {
        scenes.push(("case2".to_string(), Scene::load(&case2)?));
    } else {
        eprintln!("SKIPPED case2: {} not found", case2.display());
    }
    for (name, scene) in scenes {
        let result = bench_scene(
            &device,
            &KernelSources::Embedded,
            &name,
            &scene,
            options.clone(),
        )?;
        println!("{}", result.markdown_row());
    }
    Ok(())
}
