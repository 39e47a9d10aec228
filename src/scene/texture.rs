//! Texture maps (host side of the original's texture part of material.cuh): finds the image
//! files a scene names, decodes them (PPM P3/P6 at 8 or 16 bits, PNG grey/RGB/RGBA at 8 or 16
//! bits, through the `image` crate), and packs every map into one byte buffer with an offset
//! table, each in the smallest format that holds it (`kernels/types.h`: MAP_RGB8, MAP_TYPE8,
//! MAP_BUMP8). Lookups happen in `kernels/texture.h`.
//!
//! Semantics are the original's: texel values are used as they are (value / 255, no sRGB
//! decoding); a type map picks, per texel, the largest of R (diffuse), G (mirror), B (glass), ties
//! going to the earlier of those; a bump map's red channel is differentiated centrally along u and
//! v into gradients in [-1, 1].

use super::{Scene, Shape};
use crate::device::layout::{self, MAP_BUMP8, MAP_RGB8, MAP_TYPE8, TextureMap};
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The default limit on one image's size, in pixels (8192 x 8192).
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 26;

/// Which use a map serves; the same file may serve several (case0 uses planet4.ppm as colour
/// and bump map), and is decoded once.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MapKind {
    Color,
    Emission,
    Type,
    Bump,
}

impl MapKind {
    fn format(self) -> u32 {
        match self {
            MapKind::Color | MapKind::Emission => MAP_RGB8,
            MapKind::Type => MAP_TYPE8,
            MapKind::Bump => MAP_BUMP8,
        }
    }

    /// Device bytes per texel.
    pub fn bytes_per_texel(self) -> usize {
        match self {
            MapKind::Color | MapKind::Emission => 3,
            MapKind::Type => 1,
            MapKind::Bump => 2,
        }
    }

    fn name(self) -> &'static str {
        match self {
            MapKind::Color => "color",
            MapKind::Emission => "emission",
            MapKind::Type => "type",
            MapKind::Bump => "bump",
        }
    }
}

/// A decoded image: 8-bit RGB, rows from the top of the picture.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[u8; 3]>,
}

impl RgbImage {
    fn at(&self, x: i64, row: i64) -> [u8; 3] {
        let x = x.rem_euclid(self.width as i64) as usize;
        let row = row.rem_euclid(self.height as i64) as usize;
        self.rgb[row * self.width as usize + x]
    }
}

/// Decodes an image file, refusing empty images and images over `max_pixels` before decoding.
/// 16-bit images are scaled to 8 bits; grey becomes R = G = B; alpha is dropped.
pub fn decode(path: &Path, max_pixels: u64) -> Result<RgbImage> {
    let fail = |message: String| Error::Texture {
        path: path.to_path_buf(),
        message,
    };
    let open = || -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
        image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| fail(e.to_string()))
    };
    let (width, height) = open()?.into_dimensions().map_err(|e| fail(e.to_string()))?;
    if width == 0 || height == 0 {
        return Err(fail(format!("the image is empty ({width}x{height})")));
    }
    let pixels = width as u64 * height as u64;
    if pixels > max_pixels {
        return Err(fail(format!(
            "{width}x{height} is {pixels} pixels, over the limit of {max_pixels} \
             (--max-texture-pixels)"
        )));
    }
    let mut reader = open()?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(pixels * 8 + (1 << 20));
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| fail(e.to_string()))?;
    let rgb = decoded.to_rgb8();
    Ok(RgbImage {
        width,
        height,
        rgb: rgb.pixels().map(|p| p.0).collect(),
    })
}

/// The original's type-map rule: the largest channel wins, R diffuse, G mirror, B glass; ties go
/// to the earlier of R, G, B (so black and grey texels are diffuse).
pub fn material_type_of(texel: [u8; 3]) -> u32 {
    let [r, g, b] = texel;
    if r >= g && r >= b {
        layout::MATERIAL_DIFFUSE
    } else if g >= b {
        layout::MATERIAL_SPECULAR
    } else {
        layout::MATERIAL_REFRACTIVE
    }
}

/// Bump gradients of texel (x, row): central differences of the red channel along u (to the
/// right) and v (up, towards row 0), in [-1, 1] as (R(+1) - R(-1)) / 255, wrapping at the
/// edges like the tiling. Stored as round(127 g) in a signed byte.
pub fn bump_gradient(image: &RgbImage, x: u32, row: u32) -> [i8; 2] {
    let (x, row) = (x as i64, row as i64);
    let red = |dx: i64, drow: i64| image.at(x + dx, row + drow)[0] as f64 / 255.0;
    let du = red(1, 0) - red(-1, 0);
    let dv = red(0, -1) - red(0, 1);
    let q = |g: f64| (g.clamp(-1.0, 1.0) * 127.0).round() as i8;
    [q(du), q(dv)]
}

/// One packed map, for reports.
#[derive(Clone, Debug)]
pub struct MapInfo {
    pub path: PathBuf,
    pub kind: MapKind,
    pub width: u32,
    pub height: u32,
    pub bytes: usize,
}

/// Every map of a scene in one buffer, and each material's map indices.
#[derive(Clone, Debug, Default)]
pub struct TexturePack {
    pub maps: Vec<TextureMap>,
    pub texels: Vec<u8>,
    pub info: Vec<MapInfo>,
    /// Per material: (color, emission, type, bump) map index or `layout::MAP_NONE`.
    pub material_maps: Vec<[u32; 4]>,
}

impl TexturePack {
    /// Loads the maps of the materials that objects use (unused materials' files are not even
    /// opened, as the original's scenes declare many).
    pub fn load(scene: &Scene, max_pixels: u64) -> Result<TexturePack> {
        let mut pack = TexturePack {
            material_maps: vec![[layout::MAP_NONE; 4]; scene.materials.len()],
            ..TexturePack::default()
        };
        let mut used = vec![false; scene.materials.len()];
        for object in &scene.objects {
            if let Some(u) = used.get_mut(object.material) {
                *u = true;
            }
        }
        let mut images: HashMap<PathBuf, RgbImage> = HashMap::new();
        let mut packed: HashMap<(PathBuf, MapKind), u32> = HashMap::new();
        for (index, material) in scene.materials.iter().enumerate() {
            if !used[index] {
                continue;
            }
            let files = [
                (MapKind::Color, &material.textures.color),
                (MapKind::Emission, &material.textures.emission),
                (MapKind::Type, &material.textures.kind),
                (MapKind::Bump, &material.textures.bump),
            ];
            for (slot, (kind, file)) in files.into_iter().enumerate() {
                let Some(file) = file else { continue };
                let path = super::resolve(
                    "texture",
                    file,
                    scene.base_dir.as_deref(),
                    &material.location,
                )?;
                if let Some(&map) = packed.get(&(path.clone(), kind)) {
                    pack.material_maps[index][slot] = map;
                    continue;
                }
                if !images.contains_key(&path) {
                    images.insert(path.clone(), decode(&path, max_pixels)?);
                }
                let image = &images[&path];
                let map = pack.push(&path, kind, image)?;
                packed.insert((path, kind), map);
                pack.material_maps[index][slot] = map;
            }
        }
        check_mapped_shapes(scene, &pack)?;
        Ok(pack)
    }

    fn push(&mut self, path: &Path, kind: MapKind, image: &RgbImage) -> Result<u32> {
        let offset = u32::try_from(self.texels.len()).map_err(|_| {
            Error::Invalid("the scene's texture maps exceed 4 GiB of device memory".into())
        })?;
        let start = self.texels.len();
        match kind {
            MapKind::Color | MapKind::Emission => {
                self.texels.extend(image.rgb.iter().flatten());
            }
            MapKind::Type => {
                self.texels
                    .extend(image.rgb.iter().map(|&t| material_type_of(t) as u8));
            }
            MapKind::Bump => {
                for row in 0..image.height {
                    for x in 0..image.width {
                        let [du, dv] = bump_gradient(image, x, row);
                        self.texels.extend([du as u8, dv as u8]);
                    }
                }
            }
        }
        self.maps.push(TextureMap {
            offset,
            width: image.width,
            height: image.height,
            format: kind.format(),
        });
        self.info.push(MapInfo {
            path: path.to_path_buf(),
            kind,
            width: image.width,
            height: image.height,
            bytes: self.texels.len() - start,
        });
        Ok(self.maps.len() as u32 - 1)
    }

    /// A line per map and a total, for `clpt render -v`.
    pub fn report(&self) -> String {
        if self.info.is_empty() {
            return "textures: none".into();
        }
        let texels: usize = self
            .info
            .iter()
            .map(|m| (m.width * m.height) as usize)
            .sum();
        let mut out = format!(
            "textures: {} maps, {} texels, {} bytes on the device ({:.2} bytes/texel)",
            self.info.len(),
            texels,
            self.texels.len(),
            self.texels.len() as f64 / texels.max(1) as f64
        );
        for m in &self.info {
            out.push_str(&format!(
                "\n  {} {} {}x{}: {} bytes ({} per texel)",
                m.kind.name(),
                m.path.display(),
                m.width,
                m.height,
                m.bytes,
                m.kind.bytes_per_texel()
            ));
        }
        out
    }
}

/// Plane texture coordinates run along dirU and dirV: a mapped plane needs both. Meshes have
/// no texture coordinates (the OBJ loader does not read them): maps on them are refused.
fn check_mapped_shapes(scene: &Scene, pack: &TexturePack) -> Result<()> {
    for object in &scene.objects {
        let mapped = pack
            .material_maps
            .get(object.material)
            .is_some_and(|m| m.iter().any(|&i| i != layout::MAP_NONE));
        if !mapped {
            continue;
        }
        match &object.shape {
            Shape::Plane { dir_u, dir_v, .. } if dir_u.length() == 0.0 || dir_v.length() == 0.0 => {
                return Err(Error::Invalid(format!(
                    "{}: this plane's material has texture maps, so the plane needs non-zero \
                     `dirU` and `dirV` (they set the texture's axes and tile size)",
                    object.location
                )));
            }
            Shape::Mesh { .. } | Shape::RevSurface { .. } => {
                return Err(Error::Invalid(format!(
                    "{}: this object's material has texture maps, but meshes and surfaces of \
                     revolution carry no texture coordinates in clpt (give it a material \
                     without `texture`)",
                    object.location
                )));
            }
            _ => {}
        }
    }
    Ok(())
}
