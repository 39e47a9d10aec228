//! The host-side scene: what a scene file describes, in f64, before anything is packed for the
//! device, and the packing of it ([`packing`]: `PackedScene::new`). Its grammar lives in
//! [`parse`]; the built-in default scene in [`builtin`]; what it is made of in
//! [`crate::elements`] (re-exported here: the camera, materials, textures, meshes, curves) and
//! [`crate::shapes`] (its objects' kinds).

pub mod builtin;
pub mod packing;
pub mod parse;

pub use crate::elements::{
    CameraDesc, Material, MaterialKind, TextureFiles, camera, curve, length_safe_scale, mesh,
    resolve, texture, unit_vector,
};
pub use crate::shapes::Shape;

use crate::error::{Location, Warning};
use glam::DMat4;
use std::path::{Path, PathBuf};

/// An object of the `Group` with the material index in force where it was declared.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub shape: Shape,
    pub material: usize,
    /// Object-to-world matrix of the `Transform` blocks around it (composed outer · inner);
    /// `None` when the object is not inside any.
    pub transform: Option<DMat4>,
    pub location: Location,
}

/// A whole scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Where the scene came from (a path, or `<builtin>`), for messages and output names.
    pub source: String,
    pub camera: CameraDesc,
    pub materials: Vec<Material>,
    pub objects: Vec<Object>,
    /// Slips that did not stop the scene from loading, in file order.
    pub warnings: Vec<Warning>,
    /// The folder of the scene file, where texture paths are looked up first (`None` for
    /// scenes not read from a file).
    pub base_dir: Option<PathBuf>,
}

/// The bytes of a scene file (a file, a pipe or a device), at most `max_bytes` of them
/// (crate::input).
fn read_bounded(path: &Path, max_bytes: u64) -> crate::Result<Vec<u8>> {
    let failed = |source| crate::Error::Read {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(failed)?;
    // The file's size, where it has one (devices and pipes have none).
    let size = file
        .metadata()
        .ok()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    crate::input::read_at_most(file, size.unwrap_or(0), max_bytes)
        .map_err(failed)?
        .ok_or_else(|| crate::Error::FileTooLarge {
            what: "scene",
            path: path.to_path_buf(),
            size,
            limit: max_bytes,
            flag: "--max-scene-bytes",
        })
}

/// The largest scene file [`Scene::load`] reads, in bytes (64 MiB: the largest scene shipped
/// or in the original's testcases is a few kilobytes; meshes live in OBJ files of their own).
pub const DEFAULT_MAX_SCENE_BYTES: u64 = 64 << 20;

impl Scene {
    /// Reads and parses a scene file of at most [`DEFAULT_MAX_SCENE_BYTES`].
    pub fn load(path: &Path) -> crate::Result<Scene> {
        Scene::load_limited(path, DEFAULT_MAX_SCENE_BYTES)
    }

    /// Reads and parses a scene file of at most `max_bytes` (`--max-scene-bytes`).
    pub fn load_limited(path: &Path, max_bytes: u64) -> crate::Result<Scene> {
        let bytes = read_bounded(path, max_bytes)?;
        let mut scene = parse::parse_scene_bytes(&bytes, &path.display().to_string())?;
        scene.base_dir = Some(
            path.parent()
                .map(|p| {
                    if p.as_os_str().is_empty() {
                        Path::new(".")
                    } else {
                        p
                    }
                })
                .unwrap_or(Path::new("."))
                .to_path_buf(),
        );
        Ok(scene)
    }
}
