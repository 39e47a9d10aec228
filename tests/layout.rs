//! The shared structs have the same size and field offsets on the device as in Rust, and the
//! kernel loader's output compiles and names files and lines in build errors.

mod common;

use clpt::device::layout;
use clpt::device::program::{self, KernelSources};

#[test]
fn device_layout_matches_rust() {
    let device = common::device();
    layout::verify(&device, &KernelSources::Embedded).expect("layout probe");
}

#[test]
fn every_kernel_program_builds() {
    let device = common::device();
    for entry in ["pathtracer.cl", "probes.cl"] {
        program::build_entry(&device, &KernelSources::Embedded, entry, &[], None)
            .unwrap_or_else(|e| panic!("{entry}: {e}"));
    }
}

#[test]
fn build_errors_name_the_kernel_file_and_line() {
    let dir = std::env::temp_dir().join(format!("clpt-loader-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("good.h"),
        "/* line 1 */\ninline float ok(void) { return 1.0f; }\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("bad.h"),
        "/* line 1 */\n/* line 2 */\ninline float broken(void) { return undeclared_name; }\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("main.cl"),
        "#include \"good.h\"\n#include \"bad.h\"\n__kernel void k(__global float* o) { o[0] = ok() + broken(); }\n",
    )
    .unwrap();
    let device = common::device();
    let sources = KernelSources::Dir(dir.clone());
    let err = match program::build_entry(&device, &sources, "main.cl", &[], None) {
        Ok(_) => panic!("a kernel using an undeclared name built"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("bad.h:3"),
        "error does not name bad.h:3:\n{err}"
    );
    assert!(err.contains("undeclared_name"), "build log missing:\n{err}");

    std::fs::write(dir.join("cycle.h"), "#include \"cycle.h\"\n").unwrap();
    let err = sources.expand("cycle.h", &[]).unwrap_err().to_string();
    assert!(err.contains("cycle"), "{err}");
    let err = sources.expand("missing.cl", &[]).unwrap_err().to_string();
    assert!(err.contains("missing.cl"), "{err}");
    std::fs::write(dir.join("angle.cl"), "#include <stdio.h>\n").unwrap();
    let err = sources.expand("angle.cl", &[]).unwrap_err().to_string();
    assert!(err.contains("angle.cl:1"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn expansion_emits_line_markers_and_includes_each_file_once() {
    let expanded = KernelSources::Embedded
        .expand("pathtracer.cl", &[])
        .unwrap();
    let src = &expanded.text;
    assert!(src.starts_with("#line 1 \"pathtracer.cl\"\n"));
    assert_eq!(src.matches("#line 1 \"types.h\"").count(), 1);
    assert!(src.contains("#line 1 \"sphere.h\""));
    assert!(!src.contains("#include"));
    // The line map: every line of the expanded text names its file and line.
    for (n, line) in src.lines().enumerate() {
        let (file, at) = expanded.origin(n + 1).expect("mapped");
        if !line.starts_with("#line") {
            let original = clpt::device::program::checkout_kernel_dir().join(file);
            let text = std::fs::read_to_string(original).unwrap();
            assert_eq!(text.lines().nth(at - 1), Some(line), "{file}:{at}");
        }
    }
}

#[test]
fn logs_of_compilers_that_ignore_line_markers_are_mapped_back() {
    let expanded = KernelSources::Embedded
        .expand("pathtracer.cl", &[])
        .unwrap();
    let n = expanded
        .text
        .lines()
        .position(|l| l.contains("PHILOX_M0 *"))
        .unwrap()
        + 1;
    let (file, at) = expanded.origin(n).unwrap();
    assert_eq!(file, "rng.h");
    let log = format!("<kernel>:{n}:20: error: something\nnote: unrelated: text\nrng.h:3:1: kept");
    let mapped = expanded.annotate(&log);
    assert_eq!(
        mapped,
        format!("rng.h:{at}:20: error: something\nnote: unrelated: text\nrng.h:3:1: kept")
    );
}
