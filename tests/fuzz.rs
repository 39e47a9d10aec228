//! A mutation fuzzer over everything clpt reads from a user (issue 14, item 8): scene files (parsed,
//! then packed for the device on the host: textures, meshes, trees, lights), OBJ meshes, PPM and
//! PNG textures, PFM images, `--report` CSV files and film files (`--resume`). Each input must
//! end, within seconds, in a value or an error: a panic, a hang or a stack overflow fails the
//! test, and so does an allocation of more than [`ALLOCATION_LIMIT`] in one piece, which the
//! counting allocator below refuses (so that an infallible one aborts the run where it
//! happens, and a fallible one becomes the reader's error).
//!
//! Deterministic: the mutations come from a seeded generator, so a failure repeats. The inputs
//! start from the checked-in corpus (`tests/fuzz/corpus/<target>/`: small valid files and the
//! hostile inputs found so far) and, for scenes, from the original's scene files when
//! `../shared/seed` is there. `CLPT_FUZZ_ITERATIONS` (default 300 a target) runs longer; the
//! input in flight is written to `CARGO_TARGET_TMPDIR/fuzz-<target>.in` first, so a run that
//! aborts leaves it behind. Findings worth keeping go into the corpus.

use clpt::scene::Scene;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The largest single allocation any reader may make on a fuzzed input: every reader sizes
/// what it holds from the file, and the corpus's inputs are kilobytes.
const ALLOCATION_LIMIT: usize = 1 << 30;

/// The longest one input may take to read (a debug build of a reader is slower, not 100 times).
const TIME_LIMIT: Duration = Duration::from_secs(10);

/// The system allocator, refusing single allocations over [`ALLOCATION_LIMIT`].
struct Bounded;

// SAFETY: forwards to the system allocator, or returns null, which GlobalAlloc allows.
unsafe impl GlobalAlloc for Bounded {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_LIMIT {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOCATION_LIMIT {
            return std::ptr::null_mut();
        }
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > ALLOCATION_LIMIT {
            return std::ptr::null_mut();
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Bounded = Bounded;

fn iterations() -> usize {
    std::env::var("CLPT_FUZZ_ITERATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(300)
}

fn corpus(target: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz/corpus")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    if target == "scene" {
        let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/seed/testcases");
        if let Ok(entries) = std::fs::read_dir(seed) {
            let mut more: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
            more.sort();
            files.extend(more);
        }
    }
    let inputs: Vec<Vec<u8>> = files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    assert!(!inputs.is_empty(), "no corpus for {target}");
    inputs
}

/// Numbers that have broken readers: past f32, past u32 and u64, denormal, negative, NaN.
const NUMBERS: [&str; 16] = [
    "1e39",
    "-1e39",
    "3.5e38",
    "1e-45",
    "1e308",
    "1e309",
    "nan",
    "inf",
    "-inf",
    "-0",
    "-1",
    "0",
    "4294967296",
    "18446744073709551616",
    "99999999999999999999999",
    "2147483647",
];

/// Words of the formats, spliced in to reach deeper than random bytes do.
const WORDS: [&str; 16] = [
    "Transform {",
    "Group {",
    "}",
    "{",
    "Sphere {",
    "numObjects",
    "MaterialIndex",
    "Matrix4f",
    "f 1 2 3\n",
    "v 1e39 0 0\n",
    "vn 0 0 0\n",
    "f -1 -2 -3\n",
    "P6\n",
    "65535\n",
    "\n",
    "#",
];

/// One mutation of `input`, chosen by `rng`; `others` are the target's other inputs to splice.
fn mutate(input: &mut Vec<u8>, rng: &mut SmallRng, others: &[Vec<u8>]) {
    let len = input.len();
    let at = |rng: &mut SmallRng| {
        if len == 0 {
            0
        } else {
            rng.random_range(0..=len)
        }
    };
    match rng.random_range(0..9) {
        0 if len > 0 => {
            let i = rng.random_range(0..len);
            input[i] ^= 1 << rng.random_range(0..8);
        }
        1 if len > 0 => {
            let i = rng.random_range(0..len);
            input[i] = *[
                0u8, 0xff, 0x7f, 0x80, b'\n', b'{', b'}', b'-', b'.', b'e', b'9',
            ]
            .get(rng.random_range(0..11))
            .unwrap();
        }
        2 => {
            let (a, b) = (at(rng), at(rng));
            input.drain(a.min(b)..a.max(b));
        }
        3 => {
            let (a, b) = (at(rng), at(rng));
            let chunk = input[a.min(b)..a.max(b)].to_vec();
            let i = at(rng);
            input.splice(i..i, chunk);
        }
        4 => input.truncate(at(rng)),
        5 => {
            // A number token replaced by an extreme one.
            let text = String::from_utf8_lossy(input).into_owned();
            let starts: Vec<usize> = text
                .char_indices()
                .filter(|&(i, c)| {
                    c.is_ascii_digit() && (i == 0 || text.as_bytes()[i - 1].is_ascii_whitespace())
                })
                .map(|(i, _)| i)
                .collect();
            if !starts.is_empty() {
                let s = starts[rng.random_range(0..starts.len())];
                let e = text[s..]
                    .find(|c: char| c.is_ascii_whitespace())
                    .map_or(text.len(), |n| s + n);
                let n = NUMBERS[rng.random_range(0..NUMBERS.len())];
                *input = [&text.as_bytes()[..s], n.as_bytes(), &text.as_bytes()[e..]].concat();
            }
        }
        6 => {
            let w = WORDS[rng.random_range(0..WORDS.len())];
            let i = at(rng);
            // Now and then thousands of times: nesting and counts past any sane bound.
            let times = match rng.random_range(0..16) {
                0 => 20_000,
                1 => 500,
                _ => 1,
            };
            input.splice(i..i, w.repeat(times).into_bytes());
        }
        7 => {
            let other = &others[rng.random_range(0..others.len())];
            if !other.is_empty() {
                let (a, b) = (
                    rng.random_range(0..other.len()),
                    rng.random_range(0..other.len()),
                );
                let i = at(rng);
                input.splice(i..i, other[a.min(b)..a.max(b)].iter().copied());
            }
        }
        _ => {
            let i = at(rng);
            let junk: Vec<u8> = (0..rng.random_range(1..16)).map(|_| rng.random()).collect();
            input.splice(i..i, junk);
        }
    }
}

/// Runs `read` on `path` on a thread of the CLI's stack size, within [`TIME_LIMIT`]: Err with
/// what went wrong when it panicked or did not end.
fn run_bounded(read: fn(&Path), path: &Path) -> Result<(), String> {
    let (tx, rx) = std::sync::mpsc::channel();
    let owned = path.to_path_buf();
    std::thread::Builder::new()
        .stack_size(8 << 20)
        .spawn(move || {
            let outcome = std::panic::catch_unwind(|| read(&owned));
            let _ = tx.send(outcome.map_err(|p| {
                p.downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            }));
        })
        .unwrap();
    match rx.recv_timeout(TIME_LIMIT) {
        Ok(Ok(())) => Ok(()),
        Ok(Err(message)) => Err(format!("panicked: {message}")),
        Err(_) => Err(format!("did not end within {TIME_LIMIT:?}")),
    }
}

/// Feeds `iterations()` mutants of the target's corpus (and the corpus itself) to `read`,
/// written to a file named like `file_name`, and fails on the first that panics or hangs.
fn fuzz(target: &str, file_name: &str, read: fn(&Path)) {
    let seeds = corpus(target);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-{target}"));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(file_name);
    let mut rng = SmallRng::seed_from_u64(0xc1_7f_00 ^ target.len() as u64);
    let total = seeds.len() + iterations();
    for n in 0..total {
        let input = if n < seeds.len() {
            seeds[n].clone()
        } else {
            let mut input = seeds[rng.random_range(0..seeds.len())].clone();
            for _ in 0..rng.random_range(1..5) {
                mutate(&mut input, &mut rng, &seeds);
            }
            input
        };
        std::fs::write(&path, &input).unwrap();
        std::fs::write(dir.with_extension("in"), &input).unwrap();
        if let Err(what) = run_bounded(read, &path) {
            let keep = dir.join(format!("failure-{n}-{file_name}"));
            std::fs::write(&keep, &input).unwrap();
            panic!("{target}: input {n} {what}; kept as {}", keep.display());
        }
    }
}

#[test]
fn scene_files_end_in_a_scene_or_an_error() {
    fuzz("scene", "scene.txt", |path| {
        if let Ok(scene) = Scene::load(path) {
            // Packing runs on the host: textures, meshes, kd-trees, the BVH and the lights.
            let _ = clpt::pack::PackedScene::new(&scene, 1 << 20);
        }
    });
}

#[test]
fn obj_meshes_end_in_a_mesh_or_an_error() {
    fuzz("obj", "mesh.obj", |path| {
        let _ = clpt::scene::mesh::TriangleMesh::load(path);
    });
}

#[test]
fn ppm_and_png_textures_end_in_an_image_or_an_error() {
    fuzz("ppm", "texture.ppm", |path| {
        let _ = clpt::scene::texture::decode(path, 1 << 20);
    });
    fuzz("png", "texture.png", |path| {
        let _ = clpt::scene::texture::decode(path, 1 << 20);
    });
}

#[test]
fn images_to_compare_end_in_an_image_or_an_error() {
    fuzz("pfm", "image.pfm", |path| {
        let _ = clpt::render::metrics::LinearImage::read(path);
    });
    fuzz("png", "image.png", |path| {
        let _ = clpt::render::metrics::LinearImage::read(path);
    });
}

#[test]
fn reports_end_in_passes_or_an_error() {
    fuzz("report", "report.csv", |path| {
        let _ = clpt::render::report::read_report(path);
    });
}

#[test]
fn film_files_end_in_a_film_or_an_error() {
    fuzz("film", "film.exr", |path| {
        let _ = clpt::render::film_file::FilmState::read(path);
    });
}

/// Every byte-truncation of two of the original's scenes (the hostile campaign's first class)
/// parses to a scene or an error, never a panic or a hang.
#[test]
fn every_truncation_of_the_original_scenes_ends() {
    let seed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/seed/testcases");
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-truncations");
    std::fs::create_dir_all(&dir).unwrap();
    for name in ["case0_texture.txt", "case3_wineglass.txt"] {
        let Ok(whole) = std::fs::read(seed.join(name)) else {
            eprintln!(
                "SKIPPED {name}: the original's data is not at {}",
                seed.display()
            );
            continue;
        };
        let path = dir.join(name);
        for cut in 0..=whole.len() {
            std::fs::write(&path, &whole[..cut]).unwrap();
            if let Err(what) = run_bounded(
                |p| {
                    let _ = Scene::load(p);
                },
                &path,
            ) {
                panic!("{name} cut to {cut} bytes: {what}");
            }
        }
    }
}
