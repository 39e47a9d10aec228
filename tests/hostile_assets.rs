//! Hostile meshes, textures and file names (issue 14), end to end through the command line:
//! each ends with a clear error (exit status 1) naming the file, or renders in bounded time,
//! never with a crash, an abort or a hang.

mod common;

use common::cli::{clpt_within, refused, scratch};
use std::path::Path;
use std::process::Output;
use std::time::Duration;

/// A small render of `scene` in `dir`, with a fixed estimator (no trial), and `extra` options.
fn render(dir: &Path, scene: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        scene,
        "--spp",
        "8",
        "--light-sampling",
        "off",
        "--rr-threshold",
        "0.3",
        "-q",
        "-o",
        "out.pfm",
    ];
    args.extend(extra);
    clpt_within(dir, &args, Duration::from_secs(120))
}

/// A scene file `name` in `dir` with one grey material (mapped by `texture`, if given) and
/// `object`.
fn scene(dir: &Path, name: &str, texture: &str, object: &str) {
    let text = format!(
        "PerspectiveCamera {{ center 0 0 10 direction 0 0 -1 angle 30 width 8 height 8 }}\n\
         Materials {{ numMaterials 1 Material {{ color 0.5 0.5 0.5 {texture} }} }}\n\
         Group {{ numObjects 1 {object} }}\n"
    );
    std::fs::write(dir.join(name), text).unwrap();
}

fn mesh_scene(dir: &Path, name: &str, obj: &str) {
    scene(dir, name, "", &format!("Mesh {{ obj_file {obj} }}"));
}

fn texture_scene(dir: &Path, name: &str, image: &str) {
    scene(
        dir,
        name,
        &format!("texture {{ color {image} }}"),
        "Sphere { center 0 0 0 radius 1 }",
    );
}

fn rendered(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

/// A directory or a device given as a mesh or a texture is named as such: it was "not found",
/// and `/dev/zero` as a file would be read forever.
#[test]
fn a_directory_or_device_as_a_mesh_or_texture_says_what_it_is() {
    let dir = scratch("names");
    std::fs::create_dir_all(dir.join("x.obj")).unwrap();
    std::fs::create_dir_all(dir.join("tex.ppm")).unwrap();
    mesh_scene(&dir, "mesh.txt", "x.obj");
    texture_scene(&dir, "texture.txt", "tex.ppm");
    mesh_scene(&dir, "zero.txt", "/dev/zero");
    texture_scene(&dir, "zero_texture.txt", "/dev/zero");
    for (scene, reason) in [
        (
            "mesh.txt",
            "mesh.txt:3:22: mesh file `x.obj` is a directory (",
        ),
        ("texture.txt", "texture file `tex.ppm` is a directory ("),
        ("zero.txt", "mesh file `/dev/zero` is a device (/dev/zero)"),
        (
            "zero_texture.txt",
            "texture file `/dev/zero` is a device (/dev/zero)",
        ),
    ] {
        refused(&render(&dir, scene, &[]), reason);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 69-byte PPM whose header claims 100000x100000 pixels, with the pixel limit raised: it
/// aborted the process allocating 30 GB; now it is too short for its header, before any
/// allocation.
#[test]
fn a_huge_image_header_in_a_tiny_file_is_an_error_not_an_abort() {
    let dir = scratch("header");
    let mut ppm = b"P6\n100000 100000\n255\n".to_vec();
    ppm.resize(69, 7);
    std::fs::write(dir.join("huge.ppm"), ppm).unwrap();
    texture_scene(&dir, "scene.txt", "huge.ppm");
    refused(
        &render(&dir, "scene.txt", &[]),
        "10000000000 pixels, over the limit of 67108864 (--max-texture-pixels)",
    );
    let out = render(&dir, "scene.txt", &["--max-texture-pixels", "100000000000"]);
    refused(
        &out,
        "the file is 69 bytes, too short for the 100000x100000 image its header claims \
         (at least 30000000000 bytes)",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// OBJ errors name the line (and column), and quote what is wrong.
#[test]
fn obj_errors_on_the_command_line_name_their_line() {
    let dir = scratch("obj");
    std::fs::write(
        dir.join("latin1.obj"),
        [TRIANGLE.as_bytes(), b"# caf\xe9\nf 1 2 3\n"].concat(),
    )
    .unwrap();
    std::fs::write(
        dir.join("big.obj"),
        "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("range.obj"),
        format!("{TRIANGLE}f 1 2 3\nf 1 2 9\n"),
    )
    .unwrap();
    for (obj, reason) in [
        ("latin1.obj", "latin1.obj:4:6: byte 0xE9 is not UTF-8 text"),
        ("big.obj", "big.obj:2: `1e39` is beyond the range of f32"),
        ("range.obj", "range.obj:5: corner `9` names vertex 9"),
    ] {
        mesh_scene(&dir, "scene.txt", obj);
        refused(&render(&dir, "scene.txt", &[]), reason);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `mtllib /dev/zero` made tobj read the device forever; clpt uses no OBJ materials and opens
/// no material library.
#[test]
fn a_material_library_is_never_opened() {
    let dir = scratch("mtllib");
    std::fs::write(
        dir.join("m.obj"),
        format!("mtllib /dev/zero\n{TRIANGLE}f 1 2 3\n"),
    )
    .unwrap();
    mesh_scene(&dir, "scene.txt", "m.obj");
    rendered(&render(&dir, "scene.txt", &[]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// 2 million copies of one triangle made one kd-tree leaf that every ray through it tested
/// whole; the copies are dropped at load and counted in -v.
#[test]
fn two_million_copies_of_a_triangle_are_one_triangle() {
    let dir = scratch("copies");
    let mut obj = TRIANGLE.to_string();
    obj.push_str(&"f 1 2 3\n".repeat(2_000_000));
    std::fs::write(dir.join("copies.obj"), obj).unwrap();
    mesh_scene(&dir, "scene.txt", "copies.obj");
    let stderr = rendered(&render(&dir, "scene.txt", &["-v"]));
    assert!(
        stderr.contains("copies.obj: 1 triangles (0 degenerate and 1999999 copies dropped)"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// OBJ files are read up to --max-mesh-bytes (1 GiB by default), which says so when it binds.
#[test]
fn the_obj_size_limit_names_its_option() {
    let dir = scratch("size");
    let obj = format!("{TRIANGLE}f 1 2 3\n");
    std::fs::write(dir.join("m.obj"), &obj).unwrap();
    mesh_scene(&dir, "scene.txt", "m.obj");
    rendered(&render(&dir, "scene.txt", &[]));
    let small = (obj.len() - 1).to_string();
    refused(
        &render(&dir, "scene.txt", &["--max-mesh-bytes", &small]),
        &format!(
            "the file is {} bytes, larger than the limit of {small} bytes; a larger file can be \
             read with --max-mesh-bytes N",
            obj.len()
        ),
    );
    let _ = std::fs::remove_dir_all(&dir);
}
