//! Bit-identical images across refactors: every scene in `scenes/` and every one of the
//! original's testcases, rendered small at a fixed seed with light sampling on and off, hashed
//! and compared with the hashes recorded for this device in `tests/data/image-hashes.txt`.
//!
//! The same seed on the same device gives the same bits (README, "Deterministic"), so a change
//! that moves code around without meaning to change what it computes (issue 16: one definition
//! of every host-kernel contract) must leave every hash as it was. Another device or driver
//! rounds differently, so hashes are recorded per device: where none are recorded for the device
//! the test says so and checks only that every scene renders; `CLPT_RECORD_HASHES=1` records
//! them (for the device the tests run on) from the code as it is. Record them before a change,
//! and the test holds the change to them. `CLPT_IMAGE_HASHES=FILE` reads and records another
//! table than the checkout's (a GPU machine's run: tools/pack-device-run carries the test and
//! `scenes/`, found in the working folder there).

mod common;

use clpt::render::RenderOptions;
use clpt::render::strategy::{LightSampling, Roulette};
use clpt::scene::Scene;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const HASHES: &str = "tests/data/image-hashes.txt";

/// Where `scenes/` is: the working folder where it has one (a packed device-run/), else the
/// checkout.
fn root() -> PathBuf {
    if Path::new("scenes").is_dir() {
        PathBuf::from(".")
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }
}

/// The hash table: `$CLPT_IMAGE_HASHES`, else the checkout's.
fn table_path() -> PathBuf {
    std::env::var_os("CLPT_IMAGE_HASHES")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join(HASHES))
}

/// FNV-1a over the film's sums, bit for bit: every sample of every pixel goes into them.
fn film_hash(film: &clpt::render::film::Film) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in film.sum.iter().chain(&film.sum_sq).flatten() {
        for b in v.to_bits().to_le_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// What names the rounding of a device: platform, device and driver versions.
fn device_key(device: &clpt::device::Device) -> String {
    let d = &device.description;
    format!("{} | {} | {}", d.platform_version, d.name, d.driver_version).replace('\t', " ")
}

fn scenes() -> Vec<PathBuf> {
    let root = root();
    let mut files: Vec<PathBuf> = Vec::new();
    let mut dirs = vec![root.join("scenes")];
    if let Some(seed) = common::seed_dir("every_scene_renders_the_bits_recorded_for_this_device") {
        dirs.push(seed.join("testcases"));
    }
    for dir in dirs {
        let mut these: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("directory entry").path())
            .filter(|p| p.extension().is_some_and(|e| e == "txt"))
            .collect();
        these.sort();
        files.extend(these);
    }
    files
}

/// `scenes/NAME` or `seed/testcases/NAME`, wherever the folders are.
fn label(path: &Path) -> String {
    let name = path.file_name().unwrap().to_string_lossy();
    if path.parent().is_some_and(|d| d.ends_with("testcases")) {
        format!("seed/testcases/{name}")
    } else {
        format!("scenes/{name}")
    }
}

fn read_table() -> BTreeMap<(String, String), String> {
    let text = std::fs::read_to_string(table_path()).unwrap_or_default();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(
                f.len(),
                3,
                "{HASHES}: a line is device<TAB>render<TAB>hash: {l}"
            );
            ((f[0].to_string(), f[1].to_string()), f[2].to_string())
        })
        .collect()
}

fn write_table(table: &BTreeMap<(String, String), String>) {
    let mut text = String::from(
        "# Image hashes per device (tests/images.rs); CLPT_RECORD_HASHES=1 cargo test --release \
         --test images records the device the tests run on.\n",
    );
    for ((device, render), hash) in table {
        text.push_str(&format!("{device}\t{render}\t{hash}\n"));
    }
    let path = table_path();
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).unwrap();
    }
    std::fs::write(&path, text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

#[test]
fn every_scene_renders_the_bits_recorded_for_this_device() {
    let device = common::device();
    let key = device_key(&device);
    // The scenes spread over the cores: building each scene's programs is most of the time.
    let got: BTreeMap<String, String> = common::on_all_cores(&scenes(), |path| {
        let mut scene = Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        scene.camera.width = 24;
        scene.camera.height = 18;
        [("on", LightSampling::On), ("off", LightSampling::Off)].map(|(name, light_sampling)| {
            let options = RenderOptions {
                spp: Some(2),
                seed: 0x5eed,
                light_sampling,
                roulette: Roulette::Threshold(0.5),
                ..RenderOptions::default()
            };
            let (film, _) = common::render(&scene, options);
            let render = format!("{} light-sampling {name}", label(path));
            (render, format!("{:016x}", film_hash(&film)))
        })
    })
    .into_iter()
    .flatten()
    .collect();
    let mut table = read_table();
    if std::env::var_os("CLPT_RECORD_HASHES").is_some() {
        table.retain(|(d, _), _| *d != key);
        for (render, hash) in &got {
            table.insert((key.clone(), render.clone()), hash.clone());
        }
        write_table(&table);
        eprintln!("recorded {} hashes for {key}", got.len());
        return;
    }
    let recorded: BTreeMap<&String, &String> = table
        .iter()
        .filter(|((d, _), _)| *d == key)
        .map(|((_, r), h)| (r, h))
        .collect();
    if recorded.is_empty() {
        eprintln!(
            "NOT COMPARED: no image hashes recorded for {key} in {HASHES}; every scene rendered \
             ({} renders)",
            got.len()
        );
        return;
    }
    let mut wrong = Vec::new();
    for (render, hash) in &got {
        match recorded.get(render) {
            Some(want) if *want == hash => {}
            Some(want) => wrong.push(format!("{render}: {hash}, recorded {want}")),
            None => wrong.push(format!("{render}: {hash}, none recorded")),
        }
    }
    for render in recorded.keys() {
        if !got.contains_key(*render) {
            wrong.push(format!("{render}: recorded but not rendered"));
        }
    }
    assert!(wrong.is_empty(), "on {key}:\n{}", wrong.join("\n"));
}
