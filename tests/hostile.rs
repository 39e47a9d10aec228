//! Hostile input (issue 14): inputs that crashed, hung or printed NaN now end with a clear
//! error (exit status 1) or, for an unreachable target error, a bounded render and a warning.

mod common;

use common::cli::{clpt, refused, scratch};
use std::path::PathBuf;
use std::process::Command;

fn pfm(pixels: &[[f32; 3]], width: u32) -> Vec<u8> {
    let height = pixels.len() as u32 / width;
    let mut bytes = format!("PF\n{width} {height}\n-1.0\n").into_bytes();
    for p in pixels {
        for c in p {
            bytes.extend(c.to_le_bytes());
        }
    }
    bytes
}

#[test]
fn absurd_and_non_finite_images_are_errors() {
    let dir = scratch("images");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    std::fs::write(path("one.pfm"), pfm(&[[1.0; 3]], 1)).unwrap();
    // Headers claiming 2^62 pixels, with no data: no allocation, no overflow.
    std::fs::write(path("huge.pfm"), b"PF\n2147483648 2147483648\n-1.0\n").unwrap();
    std::fs::write(path("huge2.pfm"), b"PF\n2147483647 2147483647\n-1.0\nAAAA").unwrap();
    std::fs::write(path("nan.pfm"), pfm(&[[1.0; 3], [f32::NAN, 1.0, 1.0]], 2)).unwrap();
    std::fs::write(path("inf.pfm"), pfm(&[[f32::INFINITY; 3]], 1)).unwrap();
    for (image, reason) in [
        ("huge.pfm", "pixels need more than 2^64"),
        ("huge2.pfm", "pixels need more than 2^64"),
        (
            "nan.pfm",
            "1 pixels are not finite (NaN or infinite), the first at (1, 0)",
        ),
        ("inf.pfm", "not finite"),
    ] {
        refused(&clpt(&["compare", &path(image), &path("one.pfm")]), reason);
        let (out, reference) = (path("x.pfm"), path(image));
        let render = [
            "render", "--width", "1", "--height", "1", "--spp", "8", "-q",
        ];
        let mut a = render.to_vec();
        a.extend(["--reference", &reference, "-o", &out]);
        refused(&clpt(&a), reason);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_absurd_time_limit_is_an_error() {
    refused(
        &clpt(&["render", "--time", "1e20", "-o", "x.pfm"]),
        "too long a time limit",
    );
}

#[test]
fn an_absurd_launch_length_is_an_error() {
    for ms in ["0", "-5", "NaN", "inf", "1e9"] {
        refused(
            &clpt(&["render", &format!("--launch-ms={ms}"), "-o", "x.pfm"]),
            "--launch-ms must be between 1 and 60000",
        );
    }
}

#[test]
fn an_unreachable_target_error_alone_still_ends() {
    let dir = scratch("target");
    let out = dir.join("x.pfm");
    let r = clpt(&[
        "render",
        "--width",
        "2",
        "--height",
        "2",
        "--target-error",
        "1e-30",
        "--light-sampling",
        "off",
        "--rr-threshold",
        "0.3",
        "-q",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(
        stderr.contains("65536 spp") && stderr.contains("was not reached by 65536 samples"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cached program cut to half its length (which once made PoCL crash on every later run of
/// the scene) is noticed before the driver sees it: the program is rebuilt and the file
/// replaced, and the next run loads it again.
#[test]
fn a_cut_cached_program_is_rebuilt_and_replaced() {
    let dir = scratch("cache");
    let cache = dir.join("programs");
    let out = dir.join("x.pfm");
    let render = || {
        clpt(&[
            "render",
            "--width",
            "4",
            "--height",
            "4",
            "--spp",
            "8",
            "--light-sampling",
            "off",
            "--rr-threshold",
            "0.3",
            "-v",
            "-q",
            "--cache-dir",
            cache.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
    };
    let first = render();
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let files: Vec<PathBuf> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    let whole = std::fs::read(&files[0]).unwrap();
    std::fs::write(&files[0], &whole[..whole.len() / 2]).unwrap();
    let second = render();
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{stderr}");
    assert!(stderr.contains("built in"), "rebuilt: {stderr}");
    // Replaced by a whole file (PoCL's binaries differ a little in size from build to build);
    // that the next run loads it shows its frame is whole.
    assert!(
        std::fs::read(&files[0]).unwrap().len() > whole.len() / 2,
        "replaced"
    );
    let third = render();
    let stderr = String::from_utf8_lossy(&third.stderr);
    assert!(stderr.contains("loaded from the cache"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A program cache that cannot be written is a warning without -v (once), not silence; the
/// render goes on.
#[test]
fn an_unwritable_program_cache_is_a_warning() {
    let dir = scratch("unwritable");
    let file = dir.join("a-file");
    std::fs::write(&file, b"not a folder").unwrap();
    let out = dir.join("x.pfm");
    let r = clpt(&[
        "render",
        "--width",
        "4",
        "--height",
        "4",
        "--spp",
        "8",
        "-q",
        "--cache-dir",
        file.join("programs").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success() && out.exists(), "{stderr}");
    assert_eq!(
        stderr
            .matches("warning: the built program was not cached")
            .count(),
        1,
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_film_larger_than_the_device_or_host_is_an_error_before_the_render() {
    let dir = scratch("film");
    let out = dir.join("x.png");
    let started = std::time::Instant::now();
    // 65536 x 65536 pixels need 352 GiB of device memory: refused before any texture, tree
    // or sample (it once passed the size check and aborted reading the film back).
    refused(
        &clpt(&[
            "render",
            "--width",
            "65536",
            "--height",
            "65536",
            "--spp",
            "1",
            "-q",
            "-o",
            out.to_str().unwrap(),
        ]),
        "a 65536x65536 film needs 352.0 GiB",
    );
    assert!(started.elapsed().as_secs() < 30, "refused only after work");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_device_name_says_where_it_came_from_and_is_no_stray_letter() {
    let run = |env: Option<&str>, args: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_clpt"));
        c.args(args).env_remove("CLPT_DEVICE");
        if let Some(v) = env {
            c.env("CLPT_DEVICE", v);
        }
        c.output().unwrap()
    };
    let render = [
        "render", "--width", "4", "--height", "4", "--spp", "1", "-q", "-o",
    ];
    let out = std::env::temp_dir().join(format!("clpt-device-{}.pfm", std::process::id()));
    let out = out.to_str().unwrap();
    let mut args = render.to_vec();
    args.push(out);
    refused(&run(Some("no-such-device"), &args), "(from CLPT_DEVICE");
    args.extend(["--device", "no-such-device"]);
    refused(&run(None, &args), "(from --device");
    // One letter names no device, even where it begins a word of one.
    let mut args = render.to_vec();
    args.extend([out, "--device", "p"]);
    refused(&run(None, &args), "no OpenCL device matches `p`");
}

#[test]
fn pixels_whose_sums_overflow_are_named_not_silent() {
    let dir = scratch("overflow");
    let scene = dir.join("bright.txt");
    // An emission that fits f32 (the parser takes it), whose sum over a few samples does not.
    std::fs::write(
        &scene,
        "PerspectiveCamera { center 0 0 0 direction 0 0 -1 angle 30 width 4 height 4 }\n\
         Materials { numMaterials 1 Material { emission 1e38 1e38 1e38 color 0 0 0 } }\n\
         Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 -10 radius 100 } }\n",
    )
    .unwrap();
    let out = dir.join("x.pfm");
    let run = clpt(&[
        "render",
        scene.to_str().unwrap(),
        "--spp",
        "8",
        "--light-sampling",
        "off",
        "--rr-threshold",
        "1",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(
        stderr.contains("16 pixels are infinite in the image")
            && stderr.contains("overflowed f32")
            && stderr.contains("the first at pixel (0, 0)"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
