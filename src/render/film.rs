//! The film: per-pixel sums read back from the device, their mean, and the image files written
//! from it (chosen by extension): `.png` and `.ppm` (8-bit, the original's tone map: clamp to
//! [0, 1] and gamma 2.2), `.pfm` and `.exr` (linear float radiance, for comparison and merging).

use crate::error::Result;
use std::io::Write;
use std::path::Path;

/// Accumulated samples of a whole image. Row 0 is the bottom row (the camera's y = 0).
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel accumulated (equal for every pixel).
    pub spp: u32,
    /// Per pixel: the sum of the samples' radiance (rgb; w unused).
    pub sum: Vec<[f32; 4]>,
    /// Per pixel: the sum of the squares of the samples' radiance (rgb; w unused).
    pub sum_sq: Vec<[f32; 4]>,
}

impl Film {
    fn index(&self, x: u32, y_from_bottom: u32) -> usize {
        y_from_bottom as usize * self.width as usize + x as usize
    }

    /// The mean radiance of pixel (x, y), y counted from the bottom.
    pub fn mean(&self, x: u32, y_from_bottom: u32) -> [f64; 3] {
        let s = self.sum[self.index(x, y_from_bottom)];
        let n = self.spp.max(1) as f64;
        [s[0] as f64 / n, s[1] as f64 / n, s[2] as f64 / n]
    }

    /// The estimated variance of the mean of pixel (x, y) (per channel): the sample variance
    /// over spp, from the sums of values and squares.
    pub fn variance_of_mean(&self, x: u32, y_from_bottom: u32) -> [f64; 3] {
        let i = self.index(x, y_from_bottom);
        let n = self.spp as f64;
        if n < 2.0 {
            return [f64::INFINITY; 3];
        }
        let mut v = [0.0; 3];
        for (c, out) in v.iter_mut().enumerate() {
            let mean = self.sum[i][c] as f64 / n;
            let var = (self.sum_sq[i][c] as f64 / n - mean * mean).max(0.0) * n / (n - 1.0);
            *out = var / n;
        }
        v
    }

    /// Mean radiance in reading order (top row first), rgb interleaved.
    pub fn rgb_top_down(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity((self.width * self.height * 3) as usize);
        for row in 0..self.height {
            for x in 0..self.width {
                let m = self.mean(x, self.height - 1 - row);
                out.extend(m.iter().map(|&c| c as f32));
            }
        }
        out
    }

    /// The 8-bit tone map of the original (smallpt's toInt): clamp, gamma 2.2, round.
    pub fn to_8bit(value: f32) -> u8 {
        let clamped = if value.is_nan() {
            0.0
        } else {
            value.clamp(0.0, 1.0)
        };
        (clamped.powf(1.0 / 2.2) * 255.0 + 0.5) as u8
    }

    /// Writes the film atomically (crate::output); the format follows the extension, one of
    /// [`FORMATS`].
    pub fn write(&self, path: &Path) -> Result<()> {
        let ext = crate::output::extension(path);
        let encode =
            |out: &mut std::io::BufWriter<std::fs::File>| -> std::result::Result<(), String> {
                match ext.as_str() {
                    "png" => {
                        let bytes: Vec<u8> =
                            self.rgb_top_down().into_iter().map(Film::to_8bit).collect();
                        image::RgbImage::from_raw(self.width, self.height, bytes)
                            .ok_or("image size mismatch")?
                            .write_to(out, image::ImageFormat::Png)
                            .map_err(|e| e.to_string())
                    }
                    "ppm" => {
                        let mut data =
                            format!("P6\n{} {}\n255\n", self.width, self.height).into_bytes();
                        data.extend(self.rgb_top_down().into_iter().map(Film::to_8bit));
                        out.write_all(&data).map_err(|e| e.to_string())
                    }
                    "pfm" => {
                        // PFM stores rows bottom to top; a negative scale means little-endian.
                        let mut data =
                            format!("PF\n{} {}\n-1.0\n", self.width, self.height).into_bytes();
                        for y in 0..self.height {
                            for x in 0..self.width {
                                for c in self.mean(x, y) {
                                    data.extend_from_slice(&(c as f32).to_le_bytes());
                                }
                            }
                        }
                        out.write_all(&data).map_err(|e| e.to_string())
                    }
                    _ => image::Rgb32FImage::from_raw(self.width, self.height, self.rgb_top_down())
                        .ok_or("image size mismatch")?
                        .write_to(out, image::ImageFormat::OpenExr)
                        .map_err(|e| e.to_string()),
                }
            };
        if !FORMATS.contains(&ext.as_str()) {
            return Err(crate::output::unknown_format(path, FORMATS_LISTED));
        }
        crate::output::write_atomically(path, encode)
    }
}

/// The image formats a film is written in, by extension.
pub const FORMATS: &[&str] = &["png", "ppm", "pfm", "exr"];
const FORMATS_LISTED: &str = ".png, .ppm, .pfm or .exr";

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3x2 film whose pixel (x, y) has mean radiance (x, y, 0.25) / 2 at 2 spp.
    fn film() -> Film {
        let (width, height, spp) = (3u32, 2u32, 2u32);
        let sum = (0..height)
            .flat_map(|y| (0..width).map(move |x| [x as f32, y as f32, 0.25, 0.0]))
            .collect();
        Film {
            width,
            height,
            spp,
            sum_sq: vec![[0.0; 4]; 6],
            sum,
        }
    }

    fn temp(name: &str) -> std::path::PathBuf {
        std::env::temp_dir().join(format!("clpt-film-{}-{name}", std::process::id()))
    }

    #[test]
    fn tone_map_is_the_originals() {
        assert_eq!(Film::to_8bit(0.0), 0);
        assert_eq!(Film::to_8bit(1.0), 255);
        assert_eq!(Film::to_8bit(7.0), 255);
        assert_eq!(Film::to_8bit(-1.0), 0);
        assert_eq!(Film::to_8bit(f32::NAN), 0);
        assert_eq!(
            Film::to_8bit(0.5),
            (0.5f32.powf(1.0 / 2.2) * 255.0 + 0.5) as u8
        );
    }

    #[test]
    fn png_and_ppm_hold_the_top_row_first() {
        let film = film();
        let png = temp("a.png");
        film.write(&png).unwrap();
        let img = image::open(&png).unwrap().to_rgb8();
        // Top-left of the picture is pixel (0, height - 1): mean (0, 0.5, 0.125).
        assert_eq!(
            img.get_pixel(0, 0).0,
            [0, Film::to_8bit(0.5), Film::to_8bit(0.125)]
        );
        assert_eq!(img.get_pixel(2, 1).0, [255, 0, Film::to_8bit(0.125)]);
        let ppm = temp("a.ppm");
        film.write(&ppm).unwrap();
        let bytes = std::fs::read(&ppm).unwrap();
        let header = b"P6\n3 2\n255\n";
        assert_eq!(&bytes[..header.len()], header);
        assert_eq!(&bytes[header.len()..], img.as_raw().as_slice());
        std::fs::remove_file(png).ok();
        std::fs::remove_file(ppm).ok();
    }

    #[test]
    fn pfm_and_exr_hold_linear_radiance() {
        let film = film();
        let pfm = temp("a.pfm");
        film.write(&pfm).unwrap();
        let bytes = std::fs::read(&pfm).unwrap();
        let header = b"PF\n3 2\n-1.0\n";
        assert_eq!(&bytes[..header.len()], header);
        let floats: Vec<f32> = bytes[header.len()..]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        // PFM rows run bottom to top: the first pixel is (0, 0).
        assert_eq!(&floats[..3], &[0.0, 0.0, 0.125]);
        assert_eq!(&floats[15..], &[1.0, 0.5, 0.125]);
        let exr = temp("a.exr");
        film.write(&exr).unwrap();
        let img = image::open(&exr).unwrap().to_rgb32f();
        assert_eq!(img.get_pixel(2, 0).0, [1.0, 0.5, 0.125]);
        assert_eq!(img.get_pixel(0, 1).0, [0.0, 0.0, 0.125]);
        std::fs::remove_file(pfm).ok();
        std::fs::remove_file(exr).ok();
    }

    #[test]
    fn unknown_extension_is_an_error() {
        let err = film()
            .write(std::path::Path::new("out.jpeg"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(".jpeg") && err.contains(".png"), "{err}");
    }
}
