//! Hostile scene files (issue 14), end to end through the CLI: endless and huge input, bytes
//! that are not text, runaway nesting and numbers the device cannot hold end at once with one
//! short error (exit status 1), never a crash, a hang or a flood on stderr.

mod common;

use common::cli::{clpt, scratch};
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

/// Renders `scene` (8x8, one sample) to `dir`, and returns the run and how long it took.
fn render(scene: &Path, dir: &Path, extra: &[&str]) -> (Output, Duration) {
    let out = dir.join("out.pfm");
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend(extra);
    let started = Instant::now();
    let run = clpt(&args);
    (run, started.elapsed())
}

/// An error with exit status 1, one line on stderr that ends with `message`, and no panic.
fn refused_with(run: &Output, message: &str) {
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr:.2000}");
    assert!(
        stderr.trim_end().ends_with(message) && stderr.trim_end().lines().count() == 1,
        "{stderr:.2000}"
    );
}

const HEAD: &str = "PerspectiveCamera { center 0 0 0 direction 0 0 -1 angle 30 width 8 height 8 }\n\
                    Materials { numMaterials 1 Material { emission 1 1 1 } }\n";

fn with_group(dir: &Path, name: &str, group: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, format!("{HEAD}Group {{ numObjects 1 {group} }}\n")).unwrap();
    path
}

/// `render /dev/zero` read forever, and a scene of NUL bytes was echoed whole into the error
/// (1 GiB on stderr). Reading stops after the limit, whatever the source.
#[test]
fn endless_and_huge_scenes_end_at_the_size_limit() {
    let dir = scratch("size");
    let limit = "larger than the limit of 67108864 bytes (64.0 MiB); a larger file can be read \
                 with --max-scene-bytes N";
    let (run, took) = render(Path::new("/dev/zero"), &dir, &[]);
    refused_with(&run, &format!("scene /dev/zero: {limit}"));
    assert!(took < Duration::from_secs(30), "took {took:?}");
    // A sparse 1 GiB file of NULs: its size is real, its pages are not.
    let nuls = dir.join("nuls.txt");
    std::fs::File::create(&nuls)
        .unwrap()
        .set_len(1 << 30)
        .unwrap();
    let (run, _) = render(&nuls, &dir, &[]);
    refused_with(
        &run,
        &format!(
            "{}: the file is 1073741824 bytes (1024.0 MiB), {limit}",
            nuls.display()
        ),
    );
    // Under the limit, NULs are a token quoted short.
    std::fs::write(&nuls, vec![0u8; 1 << 20]).unwrap();
    let (run, _) = render(&nuls, &dir, &[]);
    refused_with(
        &run,
        &format!(
            "{}:1:1: expected `PerspectiveCamera`, `Materials` or `Group`, found `{}…`",
            nuls.display(),
            "\\0".repeat(30)
        ),
    );
    assert!(
        run.stderr.len() < 300,
        "{} bytes on stderr",
        run.stderr.len()
    );
    // The limit can be moved either way.
    let scene = with_group(&dir, "small.txt", "Sphere { center 0 0 -5 radius 1 }");
    let (run, _) = render(&scene, &dir, &["--max-scene-bytes", "100"]);
    refused_with(
        &run,
        &format!(
            "{}: the file is {} bytes, larger than the limit of 100 bytes; a larger file can be \
             read with --max-scene-bytes N",
            scene.display(),
            std::fs::metadata(&scene).unwrap().len()
        ),
    );
    let (run, _) = render(&scene, &dir, &["--max-scene-bytes", "1000"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Latin-1 byte in a comment gave "stream did not contain valid UTF-8", with no line.
#[test]
fn a_byte_that_is_not_utf8_is_an_error_at_its_line_and_column() {
    let dir = scratch("utf8");
    let path = dir.join("latin1.txt");
    let mut bytes = HEAD.as_bytes().to_vec();
    bytes.extend(b"Group { numObjects 1 # caf\xe9\n Sphere { center 0 0 -5 radius 1 } }\n");
    std::fs::write(&path, bytes).unwrap();
    let (run, _) = render(&path, &dir, &[]);
    refused_with(
        &run,
        &format!(
            "{}:3:27: expected UTF-8 text, found the byte 0xE9: not UTF-8 (is the file Latin-1 \
             or Windows-1252? save it as UTF-8)",
            path.display()
        ),
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// 10,000 nested `Transform` blocks overflowed the stack and aborted the process.
#[test]
fn ten_thousand_nested_transforms_are_an_error_not_a_stack_overflow() {
    let dir = scratch("nesting");
    let group = format!(
        "{}Sphere {{ center 0 0 -5 radius 1 }}{}",
        "Transform { ".repeat(10_000),
        " }".repeat(10_000)
    );
    let path = with_group(&dir, "deep.txt", &group);
    let (run, _) = render(&path, &dir, &[]);
    // Group at depth 1, so the 256th transform is the first block beyond the limit.
    let column = "Group { numObjects 1 ".len() + "Transform { ".len() * 255 + 1;
    refused_with(
        &run,
        &format!(
            "{}:3:{column}: expected blocks nested at most 256 deep, found `Transform` 257 deep",
            path.display()
        ),
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// One `UniformScale 1e39` was accepted and blacked out the whole image; two scales of 1e20
/// multiply to an entry f32 cannot hold.
#[test]
fn numbers_the_device_cannot_hold_are_errors_at_their_place() {
    let dir = scratch("numbers");
    let f32_range = "f32's range (0, or a magnitude from 1e-45 to 3.4028235e38, as the device \
                     computes in f32)";
    let one = with_group(
        &dir,
        "one.txt",
        "Transform { UniformScale 1e39 Sphere { center 0 0 -5 radius 1 } }",
    );
    let (run, _) = render(&one, &dir, &[]);
    refused_with(
        &run,
        &format!(
            "{}:3:47: expected `UniformScale` within {f32_range}, found `1e39`",
            one.display()
        ),
    );
    let two = with_group(
        &dir,
        "two.txt",
        "Transform { UniformScale 1e20 UniformScale 1e20 Sphere { center 0 0 -5 radius 1 } }",
    );
    let (run, _) = render(&two, &dir, &[]);
    refused_with(
        &run,
        &format!(
            "{}:3:22: expected this object's `Transform` matrix and its inverse to have entries \
             of at most 3.4028235e38 in magnitude, as the device holds them as f32s, found 1e40 \
             in its matrix",
            two.display()
        ),
    );
    let _ = std::fs::remove_dir_all(&dir);
}
