//! The host-side scene: what a scene file describes, in f64, before anything is packed for the
//! device. Parsing lives in [`parse`]; the camera's basis in [`camera`]; the built-in default
//! scene in [`builtin`].

pub mod builtin;
pub mod camera;
pub mod curve;
pub mod mesh;
pub mod parse;
pub mod texture;

use crate::contract;
use crate::error::{Location, Warning};
use glam::{DMat4, DVec3};
use std::path::{Path, PathBuf};

/// `PerspectiveCamera { center direction angle width height flength aperture }`.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    pub center: DVec3,
    pub direction: DVec3,
    /// `angle`, in degrees as written; smallpt's basis uses it in radians as a scale.
    pub angle_deg: f64,
    pub width: u32,
    pub height: u32,
    /// Focus distance; 0 means a pinhole camera.
    pub flength: f64,
    /// Lens radius (the original's half-size of its square aperture).
    pub aperture: f64,
}

/// `type diff|spec|refr`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum MaterialKind {
    #[default]
    Diffuse,
    Specular,
    Refractive,
}

/// Image files named in a material's `texture { }` block, as written in the scene file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TextureFiles {
    pub color: Option<PathBuf>,
    pub emission: Option<PathBuf>,
    pub kind: Option<PathBuf>,
    pub bump: Option<PathBuf>,
}

impl TextureFiles {
    pub fn is_empty(&self) -> bool {
        self.color.is_none()
            && self.emission.is_none()
            && self.kind.is_none()
            && self.bump.is_none()
    }
}

/// `Material { [emission V] [color V] [type T] [texture { ... }] }`; defaults: emission 0,
/// colour 1, diffuse.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub emission: DVec3,
    pub color: DVec3,
    pub kind: MaterialKind,
    pub textures: TextureFiles,
    pub location: Location,
}

/// `Sphere { center V radius F }`.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereShape {
    pub center: DVec3,
    pub radius: f64,
}

/// `Plane { normal V offset F range F [centerp V] [dirU V] [dirV V] }`: the points p with
/// normal.p = offset (the normal as written, or for a normal whose length would overflow or
/// underflow f64, normal and offset times one power of two ([`length_safe_scale`]); packing
/// divides normal and offset by its length), visible from the side the normal points to.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaneShape {
    pub normal: DVec3,
    pub offset: f64,
    pub range: f64,
    pub centerp: DVec3,
    pub dir_u: DVec3,
    pub dir_v: DVec3,
}

/// `Mesh { obj_file PATH }` or `TriangleMesh { obj_file PATH }`: the path as written,
/// resolved like texture paths when the mesh is loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshShape {
    pub file: PathBuf,
}

/// `RevSurface { profile ... }`: the profile curve revolved about the y axis.
#[derive(Clone, Debug, PartialEq)]
pub struct RevSurfaceShape {
    pub curve: curve::Curve,
}

/// The geometric part of an object: one variant a kind of object (the contract's
/// `OBJECT_KINDS`), each packed for the device by its `pack::shapes` module.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere(SphereShape),
    Plane(PlaneShape),
    Mesh(MeshShape),
    RevSurface(RevSurfaceShape),
}

impl Shape {
    /// Its kind: the contract's `OBJECT_*`.
    pub fn kind(&self) -> u32 {
        match self {
            Shape::Sphere(_) => contract::OBJECT_SPHERE,
            Shape::Plane(_) => contract::OBJECT_PLANE,
            Shape::Mesh(_) => contract::OBJECT_MESH,
            Shape::RevSurface(_) => contract::OBJECT_REVSURFACE,
        }
    }
}

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

/// A power of two by which `v` can be multiplied so that its length neither overflows nor
/// underflows in f64 (components beyond 2^±500 have squares beyond f64's range: a normal
/// `1e-200 0 0` had length 0): 1 for every ordinary vector, which so stays bit for bit as it is.
/// Scaling by a power of two is exact; only components under 2^-900 of the largest may lose
/// bits, far below any rounding of the result.
pub fn length_safe_scale(v: DVec3) -> f64 {
    let largest = v.abs().max_element();
    if largest > 2f64.powi(500) {
        2f64.powi(-600)
    } else if largest > 0.0 && largest < 2f64.powi(-500) {
        2f64.powi(600)
    } else {
        1.0
    }
}

/// The unit vector along `v` (any finite length), or `None` for the zero vector or a non-finite
/// one.
pub fn unit_vector(v: DVec3) -> Option<DVec3> {
    let unit = (v * length_safe_scale(v)).normalize_or_zero();
    (unit != DVec3::ZERO && unit.is_finite()).then_some(unit)
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

/// Finds a file a scene names (`what`: "texture", "mesh"): as written if absolute, else
/// relative to the scene file's folder, then that folder's parent (the original's files name
/// `texture/x.ppm` from their project root), then the working directory. The first regular
/// file wins; when there is none, a directory (or device, pipe) of that name is named as such
/// rather than reported missing.
pub fn resolve(
    what: &'static str,
    written: &Path,
    base_dir: Option<&Path>,
    at: &Location,
) -> crate::Result<PathBuf> {
    // A relative name in the scene's folder, its parent, then as written (once each: the
    // parent of `.` is the working directory).
    let folders = base_dir.filter(|_| written.is_relative());
    let places = folders
        .into_iter()
        .flat_map(|base| [Some(base), base.parent()])
        .flatten()
        .map(|folder| folder.join(written))
        .chain([written.to_path_buf()]);
    let mut tried: Vec<PathBuf> = Vec::new();
    for place in places {
        if !tried.contains(&place) {
            tried.push(place);
        }
    }
    let mut not_a_file = None;
    for place in &tried {
        match std::fs::metadata(place) {
            Ok(meta) if meta.is_file() => return Ok(place.clone()),
            Ok(meta) => {
                not_a_file.get_or_insert((place, meta.file_type()));
            }
            Err(_) => {}
        }
    }
    let written_text = written.display().to_string();
    Err(match not_a_file {
        Some((path, file_type)) => crate::Error::NotAFile {
            what,
            location: at.clone(),
            written: written_text,
            path: path.clone(),
            kind: crate::error::file_kind(file_type),
        },
        None => crate::Error::FileNotFound {
            what,
            location: at.clone(),
            written: written_text,
            tried,
        },
    })
}
