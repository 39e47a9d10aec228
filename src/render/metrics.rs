//! Error metrics between images, and the linear images they are measured on: RMSE, relMSE
//! (squared error over reference² + ε, ε = [`REL_EPSILON`], as is usual since Rousselle et al.)
//! and MAE, averaged over pixels and colour channels. Images are read from PFM and EXR
//! (linear radiance), and from PNG and PPM (8-bit, undone from the original's gamma 2.2).
//! `clpt render --reference` measures these per pass on the device (kernels/pathtracer.cl,
//! `error_rows`); `clpt compare` measures them here, on the host, the same way.

use crate::error::{Error, Result};
use std::path::Path;

/// ε of relMSE: keeps dark pixels from dominating it.
pub const REL_EPSILON: f32 = 0.01;

/// The error of an image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    pub rmse: f64,
    pub relmse: f64,
    pub mae: f64,
}

/// A linear RGB image, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<[f32; 3]>,
}

impl LinearImage {
    /// Reads `.pfm`, `.exr`, `.png` or `.ppm` (by extension).
    pub fn read(path: &Path) -> Result<LinearImage> {
        let fail = |message: String| Error::Image {
            path: path.to_path_buf(),
            message,
        };
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        let bytes = std::fs::read(path).map_err(|source| Error::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let image = match ext.as_str() {
            "pfm" => read_pfm(&bytes).map_err(fail),
            "exr" | "png" | "ppm" => {
                let image = image::load_from_memory(&bytes).map_err(|e| fail(e.to_string()))?;
                let linear = ext == "exr";
                let rgb = image.to_rgb32f();
                let (width, height) = rgb.dimensions();
                let rgb = rgb
                    .pixels()
                    .map(|p| {
                        // 8-bit files hold the original's tone map: clamp and gamma 2.2.
                        let f = |c: f32| if linear { c } else { c.powf(2.2) };
                        [f(p[0]), f(p[1]), f(p[2])]
                    })
                    .collect();
                Ok(LinearImage { width, height, rgb })
            }
            _ => Err(fail(format!(
                "unknown image format `.{ext}`: use .pfm, .exr, .png or .ppm"
            ))),
        }?;
        // A NaN or infinity would make every metric NaN and say nothing: name it instead.
        let bad: Vec<usize> = (0..image.rgb.len())
            .filter(|&i| !image.rgb[i].iter().all(|c| c.is_finite()))
            .collect();
        if let Some(&first) = bad.first() {
            let w = image.width.max(1) as usize;
            return Err(fail(format!(
                "{} pixels are not finite (NaN or infinite), the first at ({}, {}) from the top left",
                bad.len(),
                first % w,
                first / w
            )));
        }
        Ok(image)
    }

    /// The metrics of `self` against `reference`, which must have the same size.
    pub fn metrics(&self, reference: &LinearImage) -> Result<Metrics> {
        self.check_size(reference)?;
        let (mut se, mut rel, mut ae) = (0.0f64, 0.0f64, 0.0f64);
        for (a, r) in self.rgb.iter().zip(&reference.rgb) {
            for c in 0..3 {
                let e = (a[c] - r[c]) as f64;
                se += e * e;
                rel += e * e / ((r[c] * r[c]) as f64 + REL_EPSILON as f64);
                ae += e.abs();
            }
        }
        let n = (self.rgb.len() * 3).max(1) as f64;
        Ok(Metrics {
            rmse: (se / n).sqrt(),
            relmse: rel / n,
            mae: ae / n,
        })
    }

    /// Writes a false-colour picture of the per-pixel relative squared error against
    /// `reference`, on a log scale from 1e-6 (dark blue) to 1 and above (yellow).
    pub fn write_error_image(&self, reference: &LinearImage, path: &Path) -> Result<()> {
        self.check_size(reference)?;
        let bytes: Vec<u8> = self
            .rgb
            .iter()
            .zip(&reference.rgb)
            .flat_map(|(a, r)| {
                let rel: f32 = (0..3)
                    .map(|c| (a[c] - r[c]).powi(2) / (r[c] * r[c] + REL_EPSILON))
                    .sum::<f32>()
                    / 3.0;
                false_colour(((rel.max(1e-6).log10() + 6.0) / 6.0).clamp(0.0, 1.0))
            })
            .collect();
        let image = image::RgbImage::from_raw(self.width, self.height, bytes)
            .ok_or_else(|| Error::Invalid("image size mismatch".into()))?;
        crate::output::write_atomically(path, |out| {
            image
                .write_to(out, image::ImageFormat::Png)
                .map_err(|e| e.to_string())
        })
    }

    fn check_size(&self, other: &LinearImage) -> Result<()> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(Error::Invalid(format!(
                "images differ in size: {}x{} and {}x{}",
                self.width, self.height, other.width, other.height
            )));
        }
        Ok(())
    }
}

/// A perceptually ordered ramp (dark blue, teal, green, yellow) at t in [0, 1].
fn false_colour(t: f32) -> [u8; 3] {
    const STOPS: [[f32; 3]; 4] = [
        [0.07, 0.03, 0.33],
        [0.13, 0.56, 0.55],
        [0.37, 0.79, 0.38],
        [0.99, 0.91, 0.14],
    ];
    let x = t * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    let f = x - i as f32;
    let mut out = [0u8; 3];
    for (c, o) in out.iter_mut().enumerate() {
        *o = ((STOPS[i][c] * (1.0 - f) + STOPS[i + 1][c] * f) * 255.0 + 0.5) as u8;
    }
    out
}

/// PFM: `PF`, width and height, a scale whose sign gives the byte order, then rows bottom to
/// top.
fn read_pfm(bytes: &[u8]) -> std::result::Result<LinearImage, String> {
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 {
        while at < bytes.len() && bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while at < bytes.len() && !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        if start == at {
            return Err("truncated header".into());
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).into_owned());
    }
    at += 1; // the single whitespace byte before the data
    if fields[0] != "PF" {
        return Err(format!("not a colour PFM (`{}`)", fields[0]));
    }
    let parse = |s: &str| s.parse::<u32>().map_err(|_| format!("bad size `{s}`"));
    let (width, height) = (parse(&fields[1])?, parse(&fields[2])?);
    let scale: f32 = fields[3]
        .parse()
        .map_err(|_| format!("bad scale `{}`", fields[3]))?;
    // In u64, checked: a header may claim any size, and no allocation comes before the check.
    let expected = u64::from(width)
        .checked_mul(u64::from(height))
        .and_then(|n| n.checked_mul(12));
    let data = bytes.get(at..).unwrap_or_default();
    if expected.is_none_or(|e| (data.len() as u64) < e) {
        return Err(format!(
            "{} bytes of pixel data, {width} x {height} pixels need {}",
            data.len(),
            expected.map_or("more than 2^64".to_string(), |e| e.to_string())
        ));
    }
    let count = width as usize * height as usize;
    let value = |i: usize| {
        let b = [
            data[4 * i],
            data[4 * i + 1],
            data[4 * i + 2],
            data[4 * i + 3],
        ];
        if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let mut rgb = vec![[0.0f32; 3]; count];
    for row in 0..height as usize {
        for x in 0..width as usize {
            let i = row * width as usize + x; // bottom row first in the file
            let top = (height as usize - 1 - row) * width as usize + x;
            rgb[top] = [value(3 * i), value(3 * i + 1), value(3 * i + 2)];
        }
    }
    Ok(LinearImage { width, height, rgb })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pfm_round_trips_and_metrics_are_exact_on_known_images() {
        let film = crate::render::film::Film {
            width: 3,
            height: 2,
            spp: 1,
            sum: (0..6).map(|i| [i as f32, 0.5, 2.0, 0.0]).collect(),
            sum_sq: vec![[0.0; 4]; 6],
        };
        let path = std::env::temp_dir().join(format!("clpt-metrics-{}.pfm", std::process::id()));
        film.write(&path).unwrap();
        let image = LinearImage::read(&path).unwrap();
        std::fs::remove_file(&path).ok();
        // Film row 0 is the bottom: pixels 3..5 are the top row.
        assert_eq!(image.rgb[0], [3.0, 0.5, 2.0]);
        assert_eq!(image.rgb[5], [2.0, 0.5, 2.0]);
        let mut other = image.clone();
        other.rgb[0][0] += 1.0;
        let m = other.metrics(&image).unwrap();
        assert!((m.rmse - (1.0f64 / 18.0).sqrt()).abs() < 1e-12);
        assert!((m.mae - 1.0 / 18.0).abs() < 1e-12);
        assert!((m.relmse - 1.0 / (9.0 + REL_EPSILON as f64) / 18.0).abs() < 1e-9);
        assert_eq!(image.metrics(&image).unwrap().rmse, 0.0);
        let small = LinearImage {
            width: 1,
            height: 1,
            rgb: vec![[0.0; 3]],
        };
        assert!(small.metrics(&image).is_err());
    }

    #[test]
    fn malformed_pfm_files_are_errors_not_panics() {
        let good: Vec<u8> = b"PF\n2 1\n-1.0\n"
            .iter()
            .copied()
            .chain([0u8; 24])
            .collect();
        assert!(read_pfm(&good).is_ok());
        for len in 0..good.len() {
            assert!(
                read_pfm(&good[..len]).is_err(),
                "{len} bytes read as an image"
            );
        }
        for header in [
            "Pf\n2 1\n-1\n",
            "PF\n-2 1\n-1\n",
            "PF\n2 x\n-1\n",
            "PF\n2 1\nscale\n",
        ] {
            let bytes: Vec<u8> = header.bytes().chain([0u8; 24]).collect();
            assert!(read_pfm(&bytes).is_err(), "{header:?}");
        }
    }
}
