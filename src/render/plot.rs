//! Plots of renders' error against time: a render's `--plot` (RMSE against seconds on
//! log-log axes, the estimate beside the error measured against a reference, and the ideal 1/√t
//! line of an unbiased Monte Carlo estimator through the first estimate) and `clpt plot`'s
//! relMSE × seconds of several runs (efficiency.rs). SVG carries labels; PNG draws the same with
//! a small built-in digit font, for viewers without SVG.

use super::PassReport;
use super::efficiency::{Run, relmse};
use crate::error::{Error, Result};
use crate::output::extension;
use std::fmt::Write as _;
use std::path::Path;

/// The formats of a plot, by extension.
pub const PLOT_FORMATS: &[&str] = &["svg", "png"];

/// A polyline of (seconds, value) and how to draw it.
struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    colour: [u8; 3],
    dashed: bool,
}

/// Draws RMSE against seconds (log-log) as SVG or PNG, by the extension of `path`.
pub fn write_plot(path: &Path, rows: &[PassReport], title: &str) -> Result<()> {
    let rows: Vec<&PassReport> = rows.iter().filter(|r| r.seconds > 0.0).collect();
    if rows.len() < 2 {
        return Err(Error::Invalid(
            "a plot needs at least two passes of 8 samples per pixel or more".into(),
        ));
    }
    let estimate: Vec<(f64, f64)> = rows.iter().map(|r| (r.seconds, r.estimate.rmse)).collect();
    let (t0, e0) = estimate[0];
    let t1 = rows[rows.len() - 1].seconds;
    let mut series = vec![Series {
        label: "estimated RMSE (even/odd halves)".into(),
        points: estimate,
        colour: [31, 119, 180],
        dashed: false,
    }];
    let measured: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.measured.map(|m| (r.seconds, m.rmse)))
        .collect();
    if !measured.is_empty() {
        series.push(Series {
            label: "RMSE against the reference".into(),
            points: measured,
            colour: [214, 39, 40],
            dashed: false,
        });
    }
    series.push(Series {
        label: "ideal: 1/sqrt(t)".into(),
        points: vec![(t0, e0), (t1, e0 * (t0 / t1).sqrt())],
        colour: [110, 110, 110],
        dashed: true,
    });
    draw(path, &series, title, "RMSE")
}

/// Colours of successive runs (matplotlib's first four).
const PALETTE: [[u8; 3]; 4] = [
    [31, 119, 180],
    [214, 39, 40],
    [44, 160, 44],
    [148, 103, 189],
];

/// Draws relMSE × seconds against seconds (log-log) for each run (efficiency.rs): the error
/// against the reference, less the reference's own, solid; the estimate, dashed. Flat lines
/// are what an unbiased renderer draws; the lower a line, the sooner it reaches any error.
pub fn write_efficiency_plot(
    path: &Path,
    runs: &[Run],
    reference_relmse: f64,
    title: &str,
) -> Result<()> {
    let mut series = Vec::new();
    for (i, run) in runs.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let timed = || run.rows.iter().filter(|r| r.seconds > 0.0);
        let measured: Vec<(f64, f64)> = timed()
            .filter(|r| r.measured.is_some())
            .map(|r| (r.seconds, relmse(r, reference_relmse) * r.seconds))
            .filter(|p| p.1 > 0.0)
            .collect();
        if !measured.is_empty() {
            series.push(Series {
                label: format!("{}: against the reference", run.label),
                points: measured,
                colour,
                dashed: false,
            });
        }
        series.push(Series {
            label: format!("{}: estimated", run.label),
            points: timed()
                .map(|r| (r.seconds, r.estimate.relmse * r.seconds))
                .filter(|p| p.1 > 0.0)
                .collect(),
            colour,
            dashed: true,
        });
    }
    if series.iter().all(|s| s.points.len() < 2) {
        return Err(Error::Invalid(
            "a plot needs at least two passes of 8 samples per pixel or more".into(),
        ));
    }
    draw(path, &series, title, "relMSE x seconds")
}

/// Writes `series` as SVG or PNG, by the extension of `path`.
fn draw(path: &Path, series: &[Series], title: &str, y_label: &str) -> Result<()> {
    let plot = Plot::new(series);
    match extension(path).as_str() {
        "svg" => crate::output::write_bytes(path, plot.svg(series, title, y_label).as_bytes()),
        "png" => crate::output::write_atomically(path, |out| {
            plot.png(series)
                .write_to(out, image::ImageFormat::Png)
                .map_err(|e| e.to_string())
        }),
        _ => Err(crate::output::unknown_format(path, ".svg or .png")),
    }
}

const W: f64 = 720.0;
const H: f64 = 480.0;
const LEFT: f64 = 80.0;
const RIGHT: f64 = 20.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;

/// Whole decades around every series, and the mapping to pixels.
struct Plot {
    x_decades: (i32, i32),
    y_decades: (i32, i32),
}

impl Plot {
    fn new(series: &[Series]) -> Plot {
        let points = series
            .iter()
            .flat_map(|s| &s.points)
            // Only points a log axis can place: an infinite one made the axes span 2^31
            // decades, drawn one by one.
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in points {
            x0 = x0.min(x.log10());
            x1 = x1.max(x.log10());
            y0 = y0.min(y.log10());
            y1 = y1.max(y.log10());
        }
        let span = |lo: f64, hi: f64| {
            let (a, b) = (lo.floor() as i32, hi.ceil() as i32);
            (a, if b > a { b } else { a + 1 })
        };
        Plot {
            x_decades: span(x0, x1),
            y_decades: span(y0, y1),
        }
    }

    fn to_px(&self, x: f64, y: f64) -> (f64, f64) {
        let (x0, x1) = (self.x_decades.0 as f64, self.x_decades.1 as f64);
        let (y0, y1) = (self.y_decades.0 as f64, self.y_decades.1 as f64);
        (
            LEFT + (x.log10() - x0) / (x1 - x0) * (W - LEFT - RIGHT),
            TOP + (y1 - y.log10()) / (y1 - y0) * (H - TOP - BOTTOM),
        )
    }

    fn svg(&self, series: &[Series], title: &str, y_label: &str) -> String {
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" \
             font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
        );
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"22\" font-size=\"14\">{}</text>",
            LEFT,
            escape(title)
        );
        for d in self.x_decades.0..=self.x_decades.1 {
            let (x, _) = self.to_px(10f64.powi(d), 1.0);
            let _ = writeln!(
                s,
                "<line x1=\"{x:.1}\" y1=\"{TOP}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"#ddd\"/>\
                 <text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">1e{d}</text>",
                H - BOTTOM,
                H - BOTTOM + 16.0
            );
        }
        for d in self.y_decades.0..=self.y_decades.1 {
            let (_, y) = self.to_px(1.0, 10f64.powi(d));
            let _ = writeln!(
                s,
                "<line x1=\"{LEFT}\" y1=\"{y:.1}\" x2=\"{}\" y2=\"{y:.1}\" stroke=\"#ddd\"/>\
                 <text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">1e{d}</text>",
                W - RIGHT,
                LEFT - 6.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">seconds</text>\
             <text x=\"18\" y=\"{}\" transform=\"rotate(-90 18 {})\" text-anchor=\"middle\">{}</text>",
            (LEFT + W - RIGHT) / 2.0,
            H - 20.0,
            (TOP + H - BOTTOM) / 2.0,
            (TOP + H - BOTTOM) / 2.0,
            escape(y_label)
        );
        for (i, line) in series.iter().enumerate() {
            let points: Vec<String> = line
                .points
                .iter()
                .map(|&(x, y)| {
                    let (px, py) = self.to_px(x, y);
                    format!("{px:.1},{py:.1}")
                })
                .collect();
            let [r, g, b] = line.colour;
            let dash = if line.dashed {
                " stroke-dasharray=\"6 4\""
            } else {
                ""
            };
            let _ = writeln!(
                s,
                "<polyline fill=\"none\" stroke=\"rgb({r},{g},{b})\" stroke-width=\"2\"{dash} points=\"{}\"/>\
                 <text x=\"{}\" y=\"{}\" fill=\"rgb({r},{g},{b})\">{}</text>",
                points.join(" "),
                W - RIGHT - 300.0,
                TOP + 16.0 + 16.0 * i as f64,
                escape(&line.label)
            );
        }
        s.push_str("</svg>\n");
        s
    }

    fn png(&self, series: &[Series]) -> image::RgbImage {
        let mut img = image::RgbImage::from_pixel(W as u32, H as u32, image::Rgb([255, 255, 255]));
        let grey = [221, 221, 221];
        for d in self.x_decades.0..=self.x_decades.1 {
            let (x, _) = self.to_px(10f64.powi(d), 1.0);
            line(&mut img, (x, TOP), (x, H - BOTTOM), grey, false);
            text(&mut img, x - 10.0, H - BOTTOM + 8.0, &format!("1e{d}"));
        }
        for d in self.y_decades.0..=self.y_decades.1 {
            let (_, y) = self.to_px(1.0, 10f64.powi(d));
            line(&mut img, (LEFT, y), (W - RIGHT, y), grey, false);
            text(&mut img, LEFT - 40.0, y - 3.0, &format!("1e{d}"));
        }
        text(&mut img, (LEFT + W - RIGHT) / 2.0 - 10.0, H - 24.0, "s");
        for (i, s) in series.iter().enumerate() {
            for pair in s.points.windows(2) {
                let a = self.to_px(pair[0].0, pair[0].1);
                let b = self.to_px(pair[1].0, pair[1].1);
                line(&mut img, a, b, s.colour, s.dashed);
            }
            // A legend swatch per series (labels are in the SVG).
            let y = TOP + 10.0 + 12.0 * i as f64;
            line(
                &mut img,
                (W - RIGHT - 60.0, y),
                (W - RIGHT - 20.0, y),
                s.colour,
                s.dashed,
            );
        }
        img
    }
}

/// A line two pixels wide, by steps of half a pixel; dashed: 6 on, 4 off.
fn line(img: &mut image::RgbImage, a: (f64, f64), b: (f64, f64), colour: [u8; 3], dashed: bool) {
    let steps = ((b.0 - a.0).hypot(b.1 - a.1) * 2.0).ceil().max(1.0) as usize;
    for i in 0..=steps {
        if dashed && (i / 2) % 10 >= 6 {
            continue;
        }
        let t = i as f64 / steps as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        for (dx, dy) in [(0.0, 0.0), (0.5, 0.0), (0.0, 0.5)] {
            let (px, py) = ((x + dx) as i64, (y + dy) as i64);
            if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height() {
                img.put_pixel(px as u32, py as u32, image::Rgb(colour));
            }
        }
    }
}

/// Digits, `e`, `-`, `.` and `s` in a 3x5 pixel font, drawn twice as large.
fn text(img: &mut image::RgbImage, x: f64, y: f64, s: &str) {
    const GLYPHS: &[(char, [u8; 5])] = &[
        ('0', [7, 5, 5, 5, 7]),
        ('1', [2, 6, 2, 2, 7]),
        ('2', [7, 1, 7, 4, 7]),
        ('3', [7, 1, 7, 1, 7]),
        ('4', [5, 5, 7, 1, 1]),
        ('5', [7, 4, 7, 1, 7]),
        ('6', [7, 4, 7, 5, 7]),
        ('7', [7, 1, 1, 1, 1]),
        ('8', [7, 5, 7, 5, 7]),
        ('9', [7, 5, 7, 1, 7]),
        ('e', [0, 7, 7, 4, 7]),
        ('-', [0, 0, 7, 0, 0]),
        ('.', [0, 0, 0, 0, 2]),
        ('s', [0, 7, 4, 1, 7]),
    ];
    for (k, c) in s.chars().enumerate() {
        let Some((_, rows)) = GLYPHS.iter().find(|(g, _)| *g == c) else {
            continue;
        };
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let px = x as i64 + (k as i64) * 8 + col * 2 + dx;
                    let py = y as i64 + r as i64 * 2 + dy;
                    if px >= 0 && py >= 0 && (px as u32) < img.width() && (py as u32) < img.height()
                    {
                        img.put_pixel(px as u32, py as u32, image::Rgb([0, 0, 0]));
                    }
                }
            }
        }
    }
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn infinite_points_do_not_stretch_the_axes() {
        let series = Series {
            label: "run".into(),
            points: vec![
                (0.5, 1e-2),
                (1.0, f64::INFINITY),
                (f64::INFINITY, 1e-3),
                (2.0, 1e-3),
            ],
            colour: [0, 0, 0],
            dashed: false,
        };
        let plot = Plot::new(&[series]);
        assert_eq!((plot.x_decades, plot.y_decades), ((-1, 1), (-3, -2)));
    }
}
