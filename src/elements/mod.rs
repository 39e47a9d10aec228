//! What a scene is made of below its objects: the camera ([`camera`]), materials and their
//! texture maps ([`texture`]), triangle meshes read from OBJ files ([`mesh`]), profile curves
//! ([`curve`]), and the scene file's syntax ([`syntax`]: its tokens and field readers). The
//! kinds of object ([`crate::shapes`]) and the whole scene ([`crate::scene`]) are built on
//! these; nothing here knows either.

pub mod camera;
pub mod curve;
pub mod mesh;
pub mod syntax;
pub mod texture;

use crate::error::Location;
use glam::DVec3;
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
