//! The command line's outputs (src/output.rs): checked before any work, written atomically.
//! A misspelt folder or format is refused before the render starts; a render replaces an
//! earlier output whole and leaves no temporary file beside it; a write that fails keeps the
//! earlier file.

use clpt::output;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn clpt(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_clpt"))
        .args(args)
        .output()
        .expect("clpt runs")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A render of the built-in room small enough for PoCL, writing `-o out` plus `extra`.
fn render(out: &Path, extra: &[&str]) -> Output {
    let out = out.to_str().unwrap();
    let mut args = vec![
        "render", "--width", "8", "--height", "6", "--spp", "8", "-q", "-o", out,
    ];
    args.extend_from_slice(extra);
    clpt(&args)
}

#[test]
fn bad_outputs_are_refused_before_the_render() {
    let dir = scratch("refused");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    for (out, extra, message) in [
        (path("missing/x.png"), vec![], "does not exist"),
        (path("x.jpg"), vec![], "unknown format `.jpg`"),
        (
            path("x.png"),
            vec!["--report".to_string(), path("r.txt")],
            "use .csv, .json",
        ),
        (
            path("x.png"),
            vec!["--plot".to_string(), path("missing/p.svg")],
            "does not exist",
        ),
        (dir.to_str().unwrap().to_string(), vec![], "is a folder"),
    ] {
        let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
        let run = render(Path::new(&out), &extra);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{out} {extra:?}: succeeded");
        assert!(stderr.contains(message), "{out} {extra:?}: {stderr}");
        // The render line ("estimator: ...") comes after the render: it must not be there.
        assert!(
            !stderr.contains("estimator:"),
            "{out} {extra:?}: rendered first: {stderr}"
        );
    }
    assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
    let compare = clpt(&[
        "compare",
        "missing-image.pfm",
        "missing-reference.pfm",
        "--error-image",
        &path("e.jpg"),
    ]);
    let stderr = String::from_utf8_lossy(&compare.stderr);
    assert!(!compare.status.success());
    assert!(stderr.contains("unknown format `.jpg`"), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_render_replaces_its_outputs_whole_and_leaves_nothing_else() {
    let dir = scratch("atomic");
    let image = dir.join("image.pfm");
    let report = dir.join("report.csv");
    std::fs::write(&image, b"an earlier render").unwrap();
    let run = render(&image, &["--report", report.to_str().unwrap()]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let written = std::fs::read(&image).unwrap();
    assert!(written.starts_with(b"PF\n8 6\n-1.0\n"));
    assert_eq!(written.len(), "PF\n8 6\n-1.0\n".len() + 8 * 6 * 3 * 4);
    assert!(
        std::fs::read_to_string(&report)
            .unwrap()
            .contains("pass,seconds")
    );
    assert_eq!(entries(&dir), ["image.pfm", "report.csv"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_failed_write_keeps_the_old_file_and_leaves_nothing_behind() {
    let dir = scratch("fail");
    let path = dir.join("image.pfm");
    output::write_bytes(&path, b"old").unwrap();
    let err = output::write_atomically(&path, |out| {
        out.write_all(b"half").map_err(|e| e.to_string())?;
        Err("disk full".into())
    })
    .unwrap_err();
    assert!(err.to_string().contains("disk full"), "{err}");
    assert!(err.to_string().contains("image.pfm"), "{err}");
    assert_eq!(std::fs::read(&path).unwrap(), b"old");
    assert_eq!(entries(&dir), ["image.pfm"]);
    output::write_bytes(&path, b"new").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
    assert_eq!(entries(&dir), ["image.pfm"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn outputs_are_checked_before_any_work() {
    let dir = scratch("check");
    output::check_writable(&dir.join("a.png"), &["png", "pfm"]).unwrap();
    output::check_writable(&dir.join("A.PFM"), &["png", "pfm"]).unwrap();
    let wrong = output::check_writable(&dir.join("a.jpg"), &["png", "pfm"]).unwrap_err();
    assert!(wrong.to_string().contains("use .png, .pfm"), "{wrong}");
    let missing = output::check_writable(&dir.join("missing/a.png"), &["png"]).unwrap_err();
    assert!(missing.to_string().contains("does not exist"), "{missing}");
    let bare = output::check_writable(&dir.join("image"), &["png"]).unwrap_err();
    assert!(bare.to_string().contains("no extension"), "{bare}");
    let folder = output::check_writable(&dir, &["png"]).unwrap_err();
    assert!(folder.to_string().contains("is a folder"), "{folder}");
    assert!(output::write_bytes(&dir, b"x").is_err());
    assert!(entries(&dir).is_empty(), "{:?}", entries(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}
