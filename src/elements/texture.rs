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

use super::Material;
use crate::contract::{self, MAP_BUMP8, MAP_RGB8, MAP_TYPE8, TextureMap};
use crate::error::{Error, Result};
use crate::input::{gib, host_available_bytes};
use bytemuck::Zeroable;
use image::{DynamicImage, ImageBuffer, ImageDecoder, Pixel};
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
///
/// Sizes come from the file's header, so nothing is allocated before they are checked: the
/// file must be a regular file of at most [`max_file_bytes`], long enough for the image its
/// header claims (`fewest_file_bytes`: a 69-byte PPM claiming 100000x100000 pixels is cut
/// short), and decoding must fit the memory the machine has available (`decoding_bytes`);
/// the pixel buffers are then reserved fallibly (the image crate's own `vec!` would abort the
/// process when an allocation fails).
pub fn decode(path: &Path, max_pixels: u64) -> Result<RgbImage> {
    let fail = |message: String| Error::Texture {
        path: path.to_path_buf(),
        message,
    };
    let limit = max_file_bytes(max_pixels);
    let (file, len) =
        crate::input::open_regular(path, limit, "--max-texture-pixels").map_err(fail)?;
    let mut reader = image::ImageReader::new(std::io::BufReader::new(file));
    if let Ok(format) = image::ImageFormat::from_path(path) {
        reader.set_format(format);
    }
    let mut reader = reader
        .with_guessed_format()
        .map_err(|e| fail(e.to_string()))?;
    let format = reader.format();
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(max_pixels.saturating_mul(8).saturating_add(1 << 20));
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| fail(e.to_string()))?;
    let (width, height) = decoder.dimensions();
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
    let decoded = decoder.total_bytes();
    let fewest = fewest_file_bytes(format, decoder.color_type(), decoded);
    if len < fewest {
        return Err(fail(format!(
            "the file is {len} bytes, too short for the {width}x{height} image its header \
             claims (at least {fewest} bytes): it is cut short, or the header is wrong"
        )));
    }
    check_memory(width, height, decoded, host_available_bytes(), max_pixels).map_err(fail)?;
    let rgb = read_pixels(decoder).map_err(fail)?.into_rgb8().into_raw();
    let mut texels = Vec::new();
    texels
        .try_reserve_exact(rgb.len() / 3)
        .map_err(|e| fail(format!("no memory for its {width}x{height} pixels: {e}")))?;
    texels.extend(rgb.chunks_exact(3).map(|p| [p[0], p[1], p[2]]));
    Ok(RgbImage {
        width,
        height,
        rgb: texels,
    })
}

/// The largest image file read when images may have `max_pixels` pixels: 32 bytes a pixel
/// (the widest encoding clpt reads, a 16-bit P3 PPM, takes at most 18: `65535 ` three times;
/// more can only be comments or data a texture does not use) and 64 MiB for headers and
/// metadata. `--max-texture-pixels` raises both limits together; the default allows 2 GiB.
pub fn max_file_bytes(max_pixels: u64) -> u64 {
    max_pixels.saturating_mul(32).saturating_add(64 << 20)
}

/// The fewest bytes a file in `format` can hold an image in, whose decoded pixels (of
/// `color`) take `decoded` bytes: PNM stores every sample in at least a byte, as text or
/// binary, except bitmaps (P4: 8 pixels to a byte of an 8-bit grey image); PNG deflates its
/// rows at most 1032 to 1 (deflate's limit), rows whose samples can be 1/32 of the decoded
/// pixels (1-bit palette indices decoded to RGBA). Other formats are not bounded here.
fn fewest_file_bytes(
    format: Option<image::ImageFormat>,
    color: image::ColorType,
    decoded: u64,
) -> u64 {
    match format {
        Some(image::ImageFormat::Pnm) if color == image::ColorType::L8 => decoded / 8,
        Some(image::ImageFormat::Pnm) => decoded,
        Some(image::ImageFormat::Png) => decoded / (1032 * 32),
        _ => 0,
    }
}

/// Host bytes decoding an image of `pixels` takes at its peak: the decoder's pixels
/// (`decoded` bytes) with the 8-bit RGB copy made from them, or that copy with the texel list
/// made from it (3 bytes a pixel each).
fn decoding_bytes(pixels: u64, decoded: u64) -> u64 {
    decoded
        .saturating_add(pixels.saturating_mul(3))
        .max(pixels.saturating_mul(6))
}

/// Refuses a `width` x `height` image whose decoded pixels take `decoded` bytes when decoding
/// it would need more than the `available` bytes of memory the system reports (if it does).
fn check_memory(
    width: u32,
    height: u32,
    decoded: u64,
    available: Option<u64>,
    max_pixels: u64,
) -> std::result::Result<(), String> {
    let need = decoding_bytes(u64::from(width) * u64::from(height), decoded);
    match available {
        Some(have) if need > have => Err(format!(
            "decoding its {width}x{height} pixels needs {need} bytes ({}) of memory, more than \
             the {} available (--max-texture-pixels, now {max_pixels}, refuses such images \
             before any memory is used)",
            gib(need),
            gib(have)
        )),
        _ => Ok(()),
    }
}

/// `DynamicImage::from_decoder` with the pixel buffer reserved fallibly.
fn read_pixels(decoder: impl ImageDecoder) -> std::result::Result<DynamicImage, String> {
    use image::ColorType as C;
    Ok(match decoder.color_type() {
        C::L8 => DynamicImage::ImageLuma8(read_buffer(decoder)?),
        C::La8 => DynamicImage::ImageLumaA8(read_buffer(decoder)?),
        C::Rgb8 => DynamicImage::ImageRgb8(read_buffer(decoder)?),
        C::Rgba8 => DynamicImage::ImageRgba8(read_buffer(decoder)?),
        C::L16 => DynamicImage::ImageLuma16(read_buffer(decoder)?),
        C::La16 => DynamicImage::ImageLumaA16(read_buffer(decoder)?),
        C::Rgb16 => DynamicImage::ImageRgb16(read_buffer(decoder)?),
        C::Rgba16 => DynamicImage::ImageRgba16(read_buffer(decoder)?),
        C::Rgb32F => DynamicImage::ImageRgb32F(read_buffer(decoder)?),
        C::Rgba32F => DynamicImage::ImageRgba32F(read_buffer(decoder)?),
        other => return Err(format!("{other:?} images are not supported")),
    })
}

/// The decoder's pixels in a buffer of `P`, reserved with `try_reserve_exact`.
fn read_buffer<P: Pixel>(
    decoder: impl ImageDecoder,
) -> std::result::Result<ImageBuffer<P, Vec<P::Subpixel>>, String>
where
    P::Subpixel: bytemuck::Pod,
{
    let (width, height) = decoder.dimensions();
    let bytes = decoder.total_bytes();
    let len = usize::try_from(bytes / size_of::<P::Subpixel>() as u64)
        .map_err(|_| format!("{bytes} bytes of pixels do not fit this machine's memory"))?;
    let mut samples = Vec::new();
    samples.try_reserve_exact(len).map_err(|e| {
        format!(
            "no memory for {bytes} bytes of pixels ({}): {e}",
            gib(bytes)
        )
    })?;
    samples.resize(len, P::Subpixel::zeroed());
    decoder
        .read_image(bytemuck::cast_slice_mut(&mut samples))
        .map_err(|e| match e {
            image::ImageError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                "the file ends before its last pixel: it is cut short".to_string()
            }
            e => e.to_string(),
        })?;
    ImageBuffer::from_raw(width, height, samples)
        .ok_or_else(|| "the decoder's pixels do not fill the image".to_string())
}

/// The original's type-map rule: the largest channel wins, R diffuse, G mirror, B glass; ties go
/// to the earlier of R, G, B (so black and grey texels are diffuse).
pub fn material_type_of(texel: [u8; 3]) -> u32 {
    let [r, g, b] = texel;
    if r >= g && r >= b {
        contract::MATERIAL_DIFFUSE
    } else if g >= b {
        contract::MATERIAL_SPECULAR
    } else {
        contract::MATERIAL_REFRACTIVE
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
    /// Per material: (color, emission, type, bump) map index or `contract::MAP_NONE`.
    pub material_maps: Vec<[u32; 4]>,
}

impl TexturePack {
    /// Loads the maps of the materials marked `used` (unused materials' files are not even
    /// opened, as the original's scenes declare many), their relative paths looked up from
    /// `base_dir` ([`super::resolve`]).
    pub fn load(
        materials: &[Material],
        used: &[bool],
        base_dir: Option<&Path>,
        max_pixels: u64,
    ) -> Result<TexturePack> {
        let mut pack = TexturePack {
            material_maps: vec![[contract::MAP_NONE; 4]; materials.len()],
            ..TexturePack::default()
        };
        let mut images: HashMap<PathBuf, RgbImage> = HashMap::new();
        let mut packed: HashMap<(PathBuf, MapKind), u32> = HashMap::new();
        for (index, material) in materials.iter().enumerate() {
            if !used.get(index).copied().unwrap_or(false) {
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
                let path = super::resolve("texture", file, base_dir, &material.location)?;
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
        Ok(pack)
    }

    fn push(&mut self, path: &Path, kind: MapKind, image: &RgbImage) -> Result<u32> {
        let offset = u32::try_from(self.texels.len()).map_err(|_| {
            Error::Invalid("the scene's texture maps exceed 4 GiB of device memory".into())
        })?;
        let start = self.texels.len();
        let bytes = image.rgb.len() * kind.bytes_per_texel();
        self.texels
            .try_reserve_exact(bytes)
            .map_err(|e| Error::Texture {
                path: path.to_path_buf(),
                message: format!(
                    "no memory for its {} map of {bytes} bytes: {e}",
                    kind.name()
                ),
            })?;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decoding_more_than_the_memory_available_is_refused_with_the_figures() {
        let (w, h) = (60000, 60000);
        // 16-bit RGBA: 8 bytes a pixel decoded, 3 more for the RGB copy.
        let decoded = 8 * 3_600_000_000;
        let err = check_memory(w, h, decoded, Some(8 << 30), 1 << 40).unwrap_err();
        assert!(
            err.contains("needs 39600000000 bytes (36.9 GiB)")
                && err.contains("the 8.0 GiB available")
                && err.contains("--max-texture-pixels, now 1099511627776"),
            "{err}"
        );
        assert!(check_memory(w, h, decoded, Some(40 << 30), 1 << 40).is_ok());
        assert!(check_memory(w, h, decoded, None, 1 << 40).is_ok());
        // An 8-bit RGB image needs 6 bytes a pixel: its pixels with the RGB copy (the same
        // buffer here), then that copy with the texel list; an 8-bit grey one as many.
        for decoded in [3_000_000, 1_000_000] {
            assert!(check_memory(1000, 1000, decoded, Some(5_999_999), 1 << 26).is_err());
            assert!(check_memory(1000, 1000, decoded, Some(6_000_000), 1 << 26).is_ok());
        }
    }

    #[test]
    fn files_too_short_for_their_header_are_told_apart_by_format() {
        use image::{ColorType, ImageFormat};
        let pnm = Some(ImageFormat::Pnm);
        assert_eq!(fewest_file_bytes(pnm, ColorType::Rgb8, 30_000), 30_000);
        assert_eq!(fewest_file_bytes(pnm, ColorType::L8, 8_000), 1_000);
        assert_eq!(
            fewest_file_bytes(Some(ImageFormat::Png), ColorType::Rgba16, 33_024_000),
            1000
        );
        assert_eq!(fewest_file_bytes(None, ColorType::Rgb8, 1 << 40), 0);
    }
}
