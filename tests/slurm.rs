//! The render farm on Slurm (tools/slurm/): `tools/slurm/submit` puts four shards of a render
//! (an array job) and their merge (a job depending on it with afterok) on the cluster that
//! `$SLURM_CONF` names, and the merged image is the image of one render (within the 1e-6 of the
//! compensated sums). `.ci/run` starts a one-node cluster first (`tools/slurm/local-cluster`);
//! elsewhere, with no cluster, the test says so and passes, except under CI, where a missing
//! cluster fails it.

mod common;

use clpt::render::metrics::LinearImage;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const RENDER: [&str; 8] = [
    "--width",
    "32",
    "--height",
    "24",
    "--light-sampling",
    "off",
    "--rr-threshold",
    "0.3",
];

fn cluster_up() -> bool {
    std::env::var_os("SLURM_CONF").is_some()
        && Command::new("sinfo")
            .args(["-h", "-o", "%t"])
            .output()
            .is_ok_and(|o| o.status.success() && !o.stdout.is_empty())
}

#[test]
fn a_four_shard_render_and_its_merge_on_slurm_give_one_render_s_image() {
    if !cluster_up() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI runs this test on the cluster that .ci/run starts (tools/slurm/local-cluster); \
             none answers at SLURM_CONF"
        );
        eprintln!(
            "no Slurm cluster (SLURM_CONF, sinfo): skipped; tools/slurm/local-cluster starts one"
        );
        return;
    }
    let clpt = env!("CARGO_BIN_EXE_clpt");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("clpt-slurm-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let mut args = vec![clpt, out.to_str().unwrap(), "4", "image.pfm", "--spp", "64"];
    args.extend(RENDER);
    let submitted = Command::new(root.join("tools/slurm/submit"))
        .args(&args)
        .output()
        .unwrap();
    assert!(
        submitted.status.success(),
        "submit: {}",
        String::from_utf8_lossy(&submitted.stderr)
    );
    let ids = String::from_utf8_lossy(&submitted.stdout)
        .trim()
        .to_string();
    let jobs = ids.replace(' ', ",");
    // Wait until neither job is queued or running.
    let start = Instant::now();
    loop {
        let q = Command::new("squeue")
            .args(["-h", "-j", &jobs])
            .output()
            .unwrap();
        if String::from_utf8_lossy(&q.stdout).trim().is_empty() {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(600),
            "jobs {ids} still queued after 10 minutes"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let log = |name: &str| std::fs::read_to_string(out.join(name)).unwrap_or_default();
    let merged = out.join("image.pfm");
    assert!(
        merged.exists(),
        "no merged image; merge log: {}; shard 1 log: {}",
        log("merge.log"),
        log("shard-1.log")
    );
    assert!(
        log("merge.log").contains("4 films, samples 0..64"),
        "{}",
        log("merge.log")
    );
    let single = out.join("single.pfm");
    let mut one = vec![
        "render",
        "--spp",
        "64",
        "-q",
        "-o",
        single.to_str().unwrap(),
    ];
    one.extend(RENDER);
    assert!(Command::new(clpt).args(&one).status().unwrap().success());
    let (a, b) = (
        LinearImage::read(&merged).unwrap(),
        LinearImage::read(&single).unwrap(),
    );
    common::assert_close(
        a.rgb.iter().flat_map(|p| &p[..3]),
        b.rgb.iter().flat_map(|p| &p[..3]),
        1e-6,
        "the merged image against one render's",
    );
    let _ = std::fs::remove_dir_all(&out);
}
