//! Shards and merge (src/render/merge.rs, `clpt render --shard/--samples`, `clpt merge`): the
//! shards of a render, merged, give the film of one render of the whole range (its sums within
//! 1e-6, the exactness of the compensated sums) with the same error estimate; a merge of films
//! that do not make one range of one render is refused with the reason.

mod common;

use clpt::device::program::KernelSources;
use clpt::render::film_file::{FilmMeta, FilmState};
use clpt::render::merge::{self, Part};
use clpt::render::strategy::{LightSampling, Roulette, Strategy};
use clpt::render::{RenderOptions, Renderer};
use std::path::{Path, PathBuf};
use std::process::Command;

fn options(first_sample: u32, spp: u32) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        first_sample,
        seed: 7,
        light_sampling: LightSampling::Off,
        roulette: Roulette::Threshold(0.3),
        ..RenderOptions::default()
    }
}

/// The film of samples `first .. first + spp` of the built-in room at 24x18, with the error the
/// kernel estimated at the end.
fn film(first: u32, spp: u32) -> (FilmState, f64) {
    let mut scene = clpt::scene::builtin::scene().unwrap();
    (scene.camera.width, scene.camera.height) = (24, 18);
    let device = common::device();
    let mut renderer = Renderer::new(
        &device,
        &scene,
        &KernelSources::Embedded,
        options(first, spp),
    )
    .unwrap();
    let (_, stats) = renderer.render(&mut |_| {}).unwrap();
    let relmse = stats.report.last().map_or(f64::NAN, |r| r.estimate.relmse);
    (renderer.film_state().unwrap(), relmse)
}

#[test]
fn shards_merge_to_the_film_of_one_render() {
    let total = 100;
    let (whole, whole_relmse) = film(0, total);
    let strategy = Strategy {
        light_sampling: false,
        rr_threshold: 0.3,
    };
    let parts: Vec<Part> = (1..=3)
        .map(|i| {
            let (a, b) = merge::shard_range(&format!("{i}/3"), total).unwrap();
            let (state, _) = film(a, b - a);
            let meta = FilmMeta::of_render(
                None,
                &options(a, b - a),
                strategy,
                (24, 18),
                (a, b),
                "test",
                1.0,
            )
            .unwrap();
            Part {
                path: PathBuf::from(format!("shard{i}")),
                state,
                meta,
            }
        })
        .rev() // any order
        .collect();
    let (merged, meta) = merge::merge(parts).unwrap();
    assert_eq!(meta.samples, (0, total));
    assert_eq!(meta.seconds, 3.0);
    let (m, w) = (merged.film(total), whole.film(total));
    common::assert_close(
        m.sum.iter().flat_map(|p| &p[..3]),
        w.sum.iter().flat_map(|p| &p[..3]),
        1e-6,
        "merged sums against one render's",
    );
    // The host's estimate of the merged film is the kernel's of one render (f32 sums there).
    let merged_relmse = merged.estimated_error(total).relmse;
    assert!(
        (merged_relmse / whole_relmse - 1.0).abs() < 1e-4,
        "merged estimate {merged_relmse}, one render's {whole_relmse}"
    );
}

fn clpt(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_clpt"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn shard(dir: &Path, name: &str, extra: &[&str]) -> String {
    let film = dir.join(format!("{name}.exr"));
    let film = film.to_str().unwrap();
    let image = dir.join(format!("{name}.pfm"));
    let mut a = vec![
        "render",
        "--width",
        "8",
        "--height",
        "6",
        "--light-sampling",
        "off",
        "--rr-threshold",
        "0.3",
        "-q",
        "--film",
        film,
        "-o",
        image.to_str().unwrap(),
    ];
    a.extend_from_slice(extra);
    let (ok, stderr) = clpt(&a);
    assert!(ok, "{stderr}");
    film.to_string()
}

#[test]
fn merge_refuses_films_that_are_not_one_range_of_one_render() {
    let dir = std::env::temp_dir().join(format!("clpt-merge-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let a = shard(&dir, "a", &["--samples", "0..16"]);
    let b = shard(&dir, "b", &["--samples", "16..32"]);
    let c = shard(&dir, "c", &["--samples", "40..48"]);
    let d = shard(&dir, "d", &["--samples", "8..24"]);
    let e = shard(&dir, "e", &["--samples", "16..32", "--seed", "9"]);
    let f = shard(&dir, "f", &["--samples", "16..32", "--rr-depth", "4"]);
    let out = dir.join("m.pfm");
    let out = out.to_str().unwrap();
    let (ok, stderr) = clpt(&["merge", &a, &b, "-o", out]);
    assert!(ok && stderr.contains("samples 0..32"), "{stderr}");
    for (films, reason) in [
        (vec![&a, &b, &c], "samples 32..40 are missing"),
        (vec![&a, &d], "overlap"),
        (vec![&a, &e], "another seed"),
        (vec![&a, &f], "another option set"),
    ] {
        let mut args = vec!["merge"];
        args.extend(films.iter().map(|s| s.as_str()));
        args.extend(["-o", out]);
        let (ok, stderr) = clpt(&args);
        assert!(!ok && stderr.contains(reason), "{films:?}: {stderr}");
    }
    // A shard's start is a multiple of 8, and its estimator fixed.
    let (ok, stderr) = clpt(&["render", "--samples", "4..16", "-o", out]);
    assert!(!ok && stderr.contains("multiple of 8"), "{stderr}");
    let (ok, stderr) = clpt(&["render", "--spp", "64", "--shard", "1/2", "-o", out]);
    assert!(!ok && stderr.contains("fixed estimator"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
