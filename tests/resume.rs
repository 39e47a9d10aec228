//! Checkpoints and resume (src/render/resume.rs, `clpt render --checkpoint/--resume`): a
//! signal ends a render with its image and a checkpoint written and exit status 130 (SIGINT) or
//! 143 (SIGTERM); the render resumed from that checkpoint gives bit for bit the image of an
//! uninterrupted one; checkpoints are rewritten while a render runs; a checkpoint of another
//! seed, scene or option set is refused with the reason.

mod common;

use clpt::render::film_file::FilmState;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_clpt");

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-resume-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The built-in room, small, its strategy pinned (so that a render and its resumption run the
/// same one without a trial; `extra` may pin light sampling otherwise), with `extra` arguments.
fn args(extra: &[&str]) -> Vec<String> {
    let mut v: Vec<String> = ["render", "--width", "16", "--height", "12"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    if !extra.contains(&"--light-sampling") {
        v.extend(["--light-sampling".to_string(), "off".to_string()]);
    }
    v.extend(["--rr-threshold", "0.3", "-q"].map(String::from));
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

fn run(extra: &[&str]) -> Output {
    Command::new(BIN).args(args(extra)).output().unwrap()
}

fn spawn(extra: &[&str]) -> Child {
    Command::new(BIN)
        .args(args(extra))
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn signal(child: &Child, name: &str) {
    let status = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success(), "kill -{name}");
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn a_signal_writes_a_checkpoint_that_resumes_to_the_uninterrupted_image() {
    for (name, status) in [("INT", 130), ("TERM", 143)] {
        let dir = scratch(name);
        let (first, resumed, whole) = (dir.join("a.pfm"), dir.join("b.pfm"), dir.join("c.pfm"));
        // Far more samples than it can render before the signal.
        let child = spawn(&["--spp", "4000000", "-o", path(&first)]);
        std::thread::sleep(Duration::from_secs(2));
        signal(&child, name);
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(status), "SIG{name}: {stderr}");
        let checkpoint = dir.join("a.checkpoint.exr");
        assert!(
            stderr.contains("--resume") && stderr.contains(path(&checkpoint)),
            "SIG{name}: no line on how to resume: {stderr}"
        );
        assert!(first.exists(), "SIG{name}: no image written");
        let (_, meta) = FilmState::read(&checkpoint).unwrap();
        let held = meta.samples.1;
        assert!(held > 0 && meta.samples.0 == 0, "{meta:?}");
        // Resumed to a few more samples, against the same count in one run.
        let total = (held + 37).to_string();
        let r = run(&[
            "--spp",
            &total,
            "--resume",
            path(&checkpoint),
            "-o",
            path(&resumed),
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let w = run(&["--spp", &total, "-o", path(&whole)]);
        assert!(w.status.success(), "{}", String::from_utf8_lossy(&w.stderr));
        assert!(
            std::fs::read(&resumed).unwrap() == std::fs::read(&whole).unwrap(),
            "SIG{name}: resumed from {held} samples to {total}, the image differs from one run's"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn checkpoints_are_rewritten_while_the_render_runs() {
    let dir = scratch("periodic");
    let checkpoint = dir.join("k.exr");
    let out = dir.join("x.pfm");
    let child = spawn(&[
        "--spp",
        "4000000",
        "--checkpoint",
        path(&checkpoint),
        "--checkpoint-every",
        "0.2",
        "-o",
        path(&out),
    ]);
    let start = Instant::now();
    let mut seen = Vec::new();
    while seen.len() < 2 && start.elapsed() < Duration::from_secs(120) {
        if let Ok((_, meta)) = FilmState::read(&checkpoint)
            && seen.last() != Some(&meta.samples.1)
        {
            seen.push(meta.samples.1);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    signal(&child, "TERM");
    let status = child.wait_with_output().unwrap().status;
    assert_eq!(status.code(), Some(143));
    assert!(
        seen.len() == 2 && seen[0] < seen[1],
        "checkpoints seen while rendering: {seen:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_of_another_seed_scene_or_options_is_refused() {
    let dir = scratch("refused");
    let checkpoint = dir.join("k.exr");
    let out = dir.join("x.pfm");
    let r = run(&[
        "--spp",
        "16",
        "--checkpoint",
        path(&checkpoint),
        "-o",
        path(&out),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/room.txt");
    let cases: [(Vec<&str>, &str); 6] = [
        (vec!["--seed", "2"], "seed"),
        (vec!["--rr-depth", "5"], "options"),
        (
            vec!["--light-sampling", "on"],
            "--light-sampling asks otherwise",
        ),
        (vec!["--spp", "8"], "more than the 8 asked for"),
        (vec![path(&room)], "another scene"),
        (vec![], ""),
    ];
    for (extra, reason) in cases {
        let mut a = vec!["--resume", path(&checkpoint), "-o", path(&out)];
        if !extra.contains(&"--spp") {
            a.extend(["--spp", "32"]);
        }
        a.extend(extra.iter().copied());
        let r = run(&a);
        let stderr = String::from_utf8_lossy(&r.stderr);
        if reason.is_empty() {
            assert!(r.status.success(), "the same render resumes: {stderr}");
        } else {
            assert_eq!(r.status.code(), Some(1), "{extra:?}: {stderr}");
            assert!(
                stderr.contains("cannot resume") && stderr.contains(reason),
                "{extra:?}: {stderr}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Background checkpoints (resume::BackgroundWriter): the next write waits for the one in
/// flight, which lands whole, and a write that fails is an error at the wait, not lost.
#[test]
fn a_background_write_lands_whole_and_its_failure_is_an_error() {
    use clpt::device::program::KernelSources;
    use clpt::render::resume::{BackgroundWriter, FilmRecord};
    use clpt::render::strategy::{LightSampling, Roulette, Strategy};
    use clpt::render::{RenderOptions, Renderer};
    let mut scene = clpt::scene::builtin::scene().unwrap();
    (scene.camera.width, scene.camera.height) = (8, 6);
    let options = RenderOptions {
        spp: Some(16),
        light_sampling: LightSampling::Off,
        roulette: Roulette::Threshold(0.3),
        ..RenderOptions::default()
    };
    let device = common::device();
    let mut renderer =
        Renderer::new(&device, &scene, &KernelSources::Embedded, options.clone()).unwrap();
    renderer.render(&mut |_| {}).unwrap();
    let record = FilmRecord {
        scene_file: None,
        options: &options,
        device: &device.description.name,
        seconds_before: 0.0,
    };
    let strategy = Strategy {
        light_sampling: false,
        rr_threshold: 0.3,
    };
    let dir = scratch("background");
    let (good, bad) = (dir.join("k.exr"), dir.join("missing").join("k.exr"));
    let mut writer = BackgroundWriter::default();
    record
        .write_in_background(&mut writer, &good, &renderer, strategy, 16, 1.0)
        .unwrap();
    record
        .write_in_background(&mut writer, &bad, &renderer, strategy, 16, 1.0)
        .unwrap();
    let (state, meta) = FilmState::read(&good).expect("the first write landed whole");
    assert_eq!(meta.samples, (0, 16));
    assert!(
        state == renderer.film_state().unwrap(),
        "the film, bit for bit"
    );
    assert!(writer.wait().is_err(), "the failed write surfaces");
    assert!(writer.wait().is_ok(), "and only once");
    let _ = std::fs::remove_dir_all(&dir);
}
