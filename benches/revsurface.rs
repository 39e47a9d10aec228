//! `cargo bench --bench revsurface`: rays per second against the goblet of scenes/goblet.txt
//! alone (its profile in object space, no room), and what each ray cost: the histogram of
//! solver iterations (Newton steps on F(u) or on (t, u), kernels/revsurface.h) and the mean
//! number of sub-segments visited. Two ray sets of 2^20 rays: a pinhole camera's primary rays
//! framing the goblet (coherent), and rays between random points around it and inside its
//! bounds (incoherent). Runs on the default device (`CLPT_DEVICE` picks another); BENCHMARKS.md
//! records the figures with their machines.

#[path = "../tests/common/mod.rs"]
mod common;

use clpt::device::kernel::NamedArgs;
use clpt::device::program::{self, KernelSources};
use clpt::device::upload::SceneBuffers;
use clpt::device::{self, Device};
use clpt::pack::PackedScene;
use clpt::scene::Scene;
use clpt::shapes::{RevSurfaceShape, Shape};
use glam::{DVec3, Vec3};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::path::Path;
use std::time::Instant;

const RAYS: usize = 1 << 20;
const REPEATS: usize = 5;
/// Histogram buckets of solver iterations per ray: upper bounds, inclusive.
const BUCKETS: [u32; 9] = [0, 4, 8, 12, 16, 24, 32, 64, u32::MAX];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let device = device::select(None)?;
    println!("device: {}", device.description);
    // From the working folder where there is one (a packed device-run/), else the checkout's.
    let path = [
        Path::new("scenes/goblet.txt").to_path_buf(),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/goblet.txt"),
    ]
    .into_iter()
    .find(|p| p.is_file())
    .ok_or("scenes/goblet.txt not found")?;
    let mut scene = Scene::load(&path)?;
    let Some(goblet) = scene
        .objects
        .iter()
        .find(|o| matches!(o.shape, Shape::RevSurface(_)))
        .cloned()
    else {
        panic!("{} has no RevSurface", path.display());
    };
    let Shape::RevSurface(RevSurfaceShape { curve }) = &goblet.shape else {
        unreachable!()
    };
    let bounds = curve.revolution_bounds();
    scene.objects = vec![clpt::scene::Object {
        transform: None,
        ..goblet.clone()
    }];
    let packed = PackedScene::new(&scene, u64::MAX)?;
    let params = packed.params(0, 1, 1, 0);
    let buffers = SceneBuffers::new(&device, &packed, &params)?;
    // As a render of this scene builds it: the goblet is a cubic B-spline, its degree compiled
    // in (CLPT_BENCH_REV_DEGREE=0 reads it at run time instead).
    let degree = std::env::var("CLPT_BENCH_REV_DEGREE").unwrap_or_else(|_| "3".into());
    let probes = program::build_entry(
        &device,
        &KernelSources::Embedded,
        "probes.cl",
        &[("CLPT_REV_DEGREE", degree)],
        None,
    )?;

    let (c, size) = (bounds.center(), bounds.extent().length());
    // Rays are made in the goblet's coordinates and given to the device in its own, relative to
    // the camera (the probe takes them on into the profile's stored space).
    let origin = packed.origin;
    let mut rng = SmallRng::seed_from_u64(1);
    let side = (RAYS as f64).sqrt() as usize;
    let eye = c + DVec3::new(0.0, 0.0, 2.0 * size);
    let camera: Vec<[Vec3; 2]> = (0..RAYS)
        .map(|i| {
            let (x, y) = ((i % side) as f64, (i / side) as f64);
            let target = c + DVec3::new(
                (x / side as f64 - 0.5) * size * 0.6,
                (0.5 - y / side as f64) * size * 1.0,
                0.0,
            );
            [
                (eye - origin).as_vec3(),
                (target - eye).normalize().as_vec3(),
            ]
        })
        .collect();
    let random: Vec<[Vec3; 2]> = (0..RAYS)
        .map(|_| {
            let o = c + common::random_unit(&mut rng) * size * rng.random_range(0.8..2.0);
            let target = DVec3::new(
                rng.random_range(bounds.lo.x..bounds.hi.x),
                rng.random_range(bounds.lo.y..bounds.hi.y),
                rng.random_range(bounds.lo.z..bounds.hi.z),
            );
            [(o - origin).as_vec3(), (target - o).normalize().as_vec3()]
        })
        .collect();

    println!(
        "| rays | Mrays/s | hit | iterations/ray | sub-segments/ray | iterations: {} |",
        BUCKETS
            .iter()
            .map(|b| match *b {
                0 => "0".to_string(),
                u32::MAX => ">64".to_string(),
                b => format!("≤{b}"),
            })
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|---|---|---|---|{}", "---|".repeat(BUCKETS.len()));
    for (name, rays) in [("camera", &camera), ("random", &random)] {
        let (rate, out) = measure(&device, &probes.program, &buffers, rays)?;
        let hits = out.chunks_exact(3).filter(|r| r[0].is_finite()).count();
        let iterations: Vec<u32> = out.chunks_exact(3).map(|r| r[1] as u32).collect();
        let nodes: f64 = out.chunks_exact(3).map(|r| r[2] as f64).sum::<f64>() / RAYS as f64;
        let mean = iterations.iter().map(|&i| i as f64).sum::<f64>() / RAYS as f64;
        let mut histogram = [0usize; BUCKETS.len()];
        for &i in &iterations {
            let bucket = BUCKETS
                .iter()
                .position(|&b| i <= b)
                .unwrap_or(BUCKETS.len() - 1);
            histogram[bucket] += 1;
        }
        println!(
            "| {name} | {:.1} | {:.1}% | {mean:.2} | {nodes:.1} | {} |",
            rate / 1e6,
            100.0 * hits as f64 / RAYS as f64,
            histogram
                .iter()
                .map(|&h| format!("{:.2}%", 100.0 * h as f64 / RAYS as f64))
                .collect::<Vec<_>>()
                .join(" | ")
        );
    }
    Ok(())
}

/// Rays per second of probe_rev_work (the best of REPEATS launches) and its output.
fn measure(
    device: &Device,
    program: &ocl::Program,
    buffers: &SceneBuffers,
    rays: &[[Vec3; 2]],
) -> Result<(f64, Vec<f32>), Box<dyn std::error::Error>> {
    let flat: Vec<f32> = rays
        .iter()
        .flat_map(|[o, d]| o.to_array().into_iter().chain(d.to_array()))
        .collect();
    let input = ocl::Buffer::<f32>::builder()
        .queue(device.queue.clone())
        .len(flat.len())
        .copy_host_slice(&flat)
        .build()?;
    let output = ocl::Buffer::<f32>::builder()
        .queue(device.queue.clone())
        .len(rays.len() * 3)
        .build()?;
    let kernel = NamedArgs::new(program, "probe_rev_work", &device.queue)
        .global_work_size(rays.len())
        .buffer("revsurfaces", &buffers.revsurfaces)
        .buffer("transforms", &buffers.transforms)
        .buffer("rev_points", &buffers.rev_points)
        .buffer("rays", &input)
        .buffer("out", &output)
        .build()?;
    let mut best = f64::INFINITY;
    for _ in 0..=REPEATS {
        let start = Instant::now();
        // SAFETY: the kernel reads rays.len() rays and writes 3 floats for each, the sizes of
        // the buffers bound above.
        unsafe { kernel.enq()? };
        device.queue.finish()?;
        best = best.min(start.elapsed().as_secs_f64());
    }
    let mut out = vec![0.0f32; rays.len() * 3];
    output.read(&mut out).enq()?;
    Ok((rays.len() as f64 / best, out))
}
