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
    // A user's mistake prints its message, not a backtrace, even with RUST_BACKTRACE set.
    let run = Command::new(env!("CARGO_BIN_EXE_clpt"))
        .args(["render", "missing-scene.txt"])
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(stderr.starts_with("Error: "), "{stderr}");
    assert!(!stderr.to_lowercase().contains("backtrace"), "{stderr}");
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

/// Reads a PFM as written by clpt (little-endian, rows bottom to top): rgb per pixel.
fn read_pfm(path: &Path) -> Vec<[f32; 3]> {
    let bytes = std::fs::read(path).unwrap();
    let header_end = bytes
        .iter()
        .enumerate()
        .filter(|&(_, &b)| b == b'\n')
        .nth(2)
        .unwrap()
        .0;
    bytes[header_end + 1..]
        .chunks_exact(12)
        .map(|c| {
            std::array::from_fn(|k| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap()))
        })
        .collect()
}

#[test]
fn the_film_file_holds_the_render_bit_for_bit() {
    use clpt::render::film_file::FilmState;
    let dir = scratch("film");
    let (image, film) = (dir.join("image.pfm"), dir.join("film.exr"));
    let run = render(&image, &["--film", film.to_str().unwrap(), "--seed", "9"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (state, meta) = FilmState::read(&film).unwrap();
    assert_eq!((state.width, state.height), (8, 6));
    assert_eq!(meta.samples, (0, 8));
    assert_eq!(meta.seed, 9);
    assert_eq!(meta.version, env!("CARGO_PKG_VERSION"));
    assert!(
        meta.options.starts_with("8x6; light sampling"),
        "{}",
        meta.options
    );
    assert_eq!(meta.scene_fingerprint.len(), 32);
    // The sums give the image clpt wrote, bit for bit (PFM rows run bottom to top, as the film).
    let from_film = state.film(8);
    let pfm = read_pfm(&image);
    for (i, p) in pfm.iter().enumerate() {
        let (x, y) = (i as u32 % 8, i as u32 / 8);
        let m = from_film.mean(x, y).map(|c| c as f32);
        assert_eq!(*p, m, "pixel ({x}, {y})");
    }
    assert!(state.sum.iter().any(|s| s[0] > 0.0), "an empty film");
    // A round trip keeps every bit, and an ordinary EXR reader sees the mean image.
    let again = dir.join("again.exr");
    state.write(&again, &meta).unwrap();
    assert_eq!(FilmState::read(&again).unwrap(), (state.clone(), meta));
    let viewer = image::open(&film).unwrap().to_rgb32f();
    for (i, p) in viewer.pixels().enumerate() {
        let (x, row) = (i as u32 % 8, i as u32 / 8);
        let m = from_film.mean(x, 5 - row).map(|c| c as f32);
        assert_eq!(p.0, m, "viewer pixel ({x}, row {row})");
    }
    // Not a clpt film: refused with the reason.
    let err = FilmState::read(&image).unwrap_err().to_string();
    assert!(err.contains("film file"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// On a CPU device a render given neither `--spp`, `--time` nor `--target-error` stops after
/// 12 s (the README's first render took 75 s on 2 cores) and says so as it starts; a tiny one
/// still renders its 64 samples, and `--spp` alone lifts the limit. On a GPU: nothing to say.
#[test]
fn a_cpu_render_without_bounds_says_it_stops_after_12_s() {
    let dir = scratch("cpu-default");
    let out = dir.join("x.pfm");
    let on_cpu = clpt::device::select(None)
        .map(|d| d.description.kind == "CPU")
        .unwrap_or(false);
    let note = "on a CPU device a render stops after 12 s unless --spp or --time says otherwise";
    let args = ["render", "--width", "8", "--height", "6", "-o"];
    let unbounded = clpt(&[&args[..], &[out.to_str().unwrap()]].concat());
    let stderr = String::from_utf8_lossy(&unbounded.stderr);
    assert!(unbounded.status.success(), "{stderr}");
    assert_eq!(stderr.contains(note), on_cpu, "{stderr}");
    assert!(stderr.contains("64 spp in"), "{stderr}");
    let counted = clpt(&[&args[..], &[out.to_str().unwrap(), "--spp", "16"]].concat());
    let stderr = String::from_utf8_lossy(&counted.stderr);
    assert!(counted.status.success(), "{stderr}");
    assert!(!stderr.contains(note), "{stderr}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--mesh-tree` takes kd, bvh2 or wide and refuses others before any work; a wide program
/// refuses the kd-tree and the binary BVH (it walks only 8-wide BVHs), and `-v` names the tree
/// a mesh scene's program walks: wide on a CPU by default, bvh2 on a GPU.
#[test]
fn mesh_trees_are_checked_and_reported() {
    let dir = scratch("mesh-tree");
    let image = dir.join("image.pfm");
    let run = render(&image, &["--mesh-tree", "bvh"]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "--mesh-tree bvh was accepted");
    assert!(err.contains("use kd, bvh2 or wide"), "{err}");
    assert!(!image.exists(), "--mesh-tree bvh wrote an image");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/meshes.txt");
    let out = image.to_str().unwrap();
    let at = |extra: &[&str]| {
        let args = [
            &[
                "render", scene, "--width", "8", "--height", "6", "--spp", "8", "-v", "-o", out,
            ],
            extra,
        ]
        .concat();
        let run = clpt(&args);
        (
            run.status.success(),
            String::from_utf8_lossy(&run.stderr).into_owned(),
        )
    };
    let (ok, err) = at(&[]);
    assert!(ok, "{err}");
    let on_cpu = err.contains("(CPU");
    assert_eq!(err.contains("wide-bvh"), on_cpu, "{err}");
    assert_eq!(err.contains("bvh2"), !on_cpu, "{err}");
    let (ok, err) = at(&["--mesh-tree", "wide", "--lanes", "1"]);
    assert!(
        ok && err.contains("wide-bvh")
            && err.contains("-DCLPT_WIDE_BVH=1")
            && err.contains("8-wide BVH built"),
        "{err}"
    );
    let (ok, err) = at(&["--mesh-tree", "bvh2", "--lanes", "1"]);
    assert!(
        ok && err.contains(" bvh2")
            && err.contains("-DCLPT_BVH2=1 -DCLPT_WIDE_BVH=0")
            && err.contains("binary BVH built"),
        "{err}"
    );
    let (ok, err) = at(&["--mesh-tree", "kd", "--lanes", "1"]);
    assert!(
        ok && !err.contains("wide-bvh")
            && !err.contains(" bvh2")
            && err.contains("-DCLPT_BVH2=0 -DCLPT_WIDE_BVH=0")
            && err.contains("kd-tree built"),
        "{err}"
    );
    if on_cpu {
        for tree in ["kd", "bvh2"] {
            std::fs::remove_file(&image).unwrap_or(());
            let (ok, err) = at(&["--mesh-tree", tree, "--lanes", "16"]);
            assert!(
                !ok && err.contains(&format!("--mesh-tree {tree} takes --lanes 1")),
                "{err}"
            );
            assert!(!image.exists(), "a refused render wrote an image");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--lanes` takes the widths the kernels build (1, 4, 8, 16) and refuses others before any
/// work, naming them; a CPU render at a given width says so under `-v`.
#[test]
fn lanes_are_checked_and_reported() {
    let dir = scratch("lanes");
    let image = dir.join("image.pfm");
    for bad in ["3", "32", "0", "x"] {
        let run = render(&image, &["--lanes", bad]);
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "--lanes {bad} was accepted");
        assert!(err.contains("1, 4, 8 or 16"), "--lanes {bad}: {err}");
        assert!(!image.exists(), "--lanes {bad} wrote an image");
    }
    let run = render(&image, &["--lanes", "8", "-v", "--light-sampling", "off"]);
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    let device_is_cpu = err.contains("(CPU");
    assert_eq!(
        err.contains("lanes(8)") && err.contains("-DCLPT_LANES=8"),
        device_is_cpu,
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
