//! Plots of renders' error against time: a render's `--plot` (RMSE against seconds on
//! log-log axes, the estimate beside the error measured against a reference, and the ideal 1/√t
//! line of an unbiased Monte Carlo estimator through the first estimate) and `clpt plot`'s
//! relMSE × seconds of several runs (efficiency.rs).
//!
//! The drawing is the `plotters` crate's, so that clpt keeps no plotter of its own: the same
//! chart (title, whole-decade log-log axes labelled `1e-3`, grid, axis names, a legend, solid and
//! dashed lines) goes to SVG or to PNG. Text in a PNG is rasterised by `ab_glyph` from a font built
//! into the binary (`assets/fonts/DejaVuSans-ascii.ttf`, DejaVu Sans cut to printable ASCII), so
//! no system font is needed; an SVG names `sans-serif` and its viewer draws the text. Either is
//! drawn in memory and written atomically (output.rs): a failed plot leaves no partial file.

use super::PassReport;
use super::efficiency::{Run, relmse};
use crate::error::{Error, Result};
use crate::output::extension;
use plotters::backend::RGBPixel;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

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
    let format = match extension(path).as_str() {
        "svg" => Format::Svg,
        "png" => Format::Png,
        _ => return Err(crate::output::unknown_format(path, ".svg or .png")),
    };
    let bytes = render(format, series, title, y_label).map_err(|message| Error::Write {
        path: path.to_path_buf(),
        message,
    })?;
    crate::output::write_bytes(path, &bytes)
}

#[derive(Clone, Copy, Debug)]
enum Format {
    Svg,
    Png,
}

const W: u32 = 720;
const H: u32 = 480;

/// The family every text of a plot is set in; the embedded font is registered under it.
const FONT: &str = "sans-serif";

/// DejaVu Sans, printable ASCII only (assets/fonts/LICENSE-DejaVu.txt).
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-ascii.ttf");

/// Registers the embedded font with plotters, once per process.
fn register_font() -> std::result::Result<(), String> {
    static REGISTERED: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES)
                .map_err(|_| "the font built into clpt cannot be read".to_string())
        })
        .clone()
}

/// The plot as the bytes of an SVG or PNG file.
fn render(
    format: Format,
    series: &[Series],
    title: &str,
    y_label: &str,
) -> std::result::Result<Vec<u8>, String> {
    register_font()?;
    let failed = |e: &dyn std::fmt::Display| format!("cannot draw the plot: {e}");
    match format {
        Format::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (W, H)).into_drawing_area();
                chart(&root, series, title, y_label).map_err(|e| failed(&e))?;
            }
            Ok(svg.into_bytes())
        }
        Format::Png => {
            let mut rgb = vec![0u8; W as usize * H as usize * 3];
            {
                let backend = BitMapBackend::<RGBPixel>::with_buffer_and_format(&mut rgb, (W, H))
                    .map_err(|e| failed(&e))?;
                chart(&backend.into_drawing_area(), series, title, y_label)
                    .map_err(|e| failed(&e))?;
            }
            let image = image::RgbImage::from_raw(W, H, rgb)
                .ok_or_else(|| "the plot's pixels do not fill the image".to_string())?;
            let mut png = std::io::Cursor::new(Vec::new());
            image
                .write_to(&mut png, image::ImageFormat::Png)
                .map_err(|e| e.to_string())?;
            Ok(png.into_inner())
        }
    }
}

/// `1e-3` for 0.001: the label of a decade.
fn decade_label(value: &f64) -> String {
    format!("1e{}", value.log10().round() as i32)
}

/// Draws the whole chart on `root` (any plotters backend).
fn chart<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    series: &[Series],
    title: &str,
    y_label: &str,
) -> std::result::Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let axes = Axes::new(series);
    let decades = |(a, b): (i32, i32)| (a..=b).map(|d| 10f64.powi(d)).collect::<Vec<f64>>();
    let (x0, x1) = (10f64.powi(axes.x_decades.0), 10f64.powi(axes.x_decades.1));
    let (y0, y1) = (10f64.powi(axes.y_decades.0), 10f64.powi(axes.y_decades.1));
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(
            (x0..x1)
                .log_scale()
                .with_key_points(decades(axes.x_decades)),
            (y0..y1)
                .log_scale()
                .with_key_points(decades(axes.y_decades)),
        )?;
    chart
        .configure_mesh()
        .bold_line_style(RGBColor(221, 221, 221))
        .axis_style(BLACK)
        .x_label_formatter(&decade_label)
        .y_label_formatter(&decade_label)
        .label_style((FONT, 15))
        .x_desc("seconds")
        .y_desc(y_label)
        .axis_desc_style((FONT, 16))
        .draw()?;
    for s in series {
        let [r, g, b] = s.colour;
        let style = RGBColor(r, g, b).stroke_width(2);
        let parts = segments(&s.points);
        let dashed = s.dashed;
        let legend = move |(x, y): (i32, i32)| {
            let ends = vec![(x, y), (x + 24, y)];
            if dashed {
                DashedPathElement::new(ends, 6, 4, style).into_dyn()
            } else {
                PathElement::new(ends, style).into_dyn()
            }
        };
        if dashed {
            chart.draw_series(
                parts
                    .into_iter()
                    .map(|p| DashedPathElement::new(p, 6, 4, style)),
            )?
        } else {
            chart.draw_series(parts.into_iter().map(|p| PathElement::new(p, style)))?
        }
        .label(s.label.as_str())
        .legend(legend);
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(170, 170, 170))
        .label_font((FONT, 15))
        .draw()?;
    root.present()
}

/// Whether a log axis can place a point: both coordinates finite and above zero.
fn drawable(p: &(f64, f64)) -> bool {
    p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite()
}

/// The runs of consecutive drawable points of a polyline: a point a log axis cannot place
/// breaks the line rather than being drawn or joined across.
fn segments(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    points
        .split(|p| !drawable(p))
        .filter(|run| !run.is_empty())
        .map(<[_]>::to_vec)
        .collect()
}

/// Whole decades around every drawable point of every series (1 to 10 where there is none).
struct Axes {
    x_decades: (i32, i32),
    y_decades: (i32, i32),
}

impl Axes {
    fn new(series: &[Series]) -> Axes {
        // Only points a log axis can place: an infinite one made the axes span 2^31 decades.
        let points = series
            .iter()
            .flat_map(|s| &s.points)
            .filter(|p| drawable(p));
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for &(x, y) in points {
            x0 = x0.min(x.log10());
            x1 = x1.max(x.log10());
            y0 = y0.min(y.log10());
            y1 = y1.max(y.log10());
        }
        let span = |lo: f64, hi: f64| {
            if lo > hi {
                return (0, 1);
            }
            let (a, b) = (lo.floor() as i32, hi.ceil() as i32);
            (a, if b > a { b } else { a + 1 })
        };
        Axes {
            x_decades: span(x0, x1),
            y_decades: span(y0, y1),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(points: Vec<(f64, f64)>, dashed: bool) -> Series {
        Series {
            label: "run".into(),
            points,
            colour: [0, 0, 0],
            dashed,
        }
    }

    #[test]
    fn infinite_points_do_not_stretch_the_axes() {
        let points = vec![
            (0.5, 1e-2),
            (1.0, f64::INFINITY),
            (f64::INFINITY, 1e-3),
            (2.0, 1e-3),
            (3.0, 0.0),
            (f64::NAN, 1e-2),
            (-1.0, 1e-2),
            (4.0, 2e-3),
            (8.0, 3e-3),
        ];
        let axes = Axes::new(&[run(points.clone(), false)]);
        assert_eq!((axes.x_decades, axes.y_decades), ((-1, 1), (-3, -2)));
        // Nor are they drawn, nor joined across: the line breaks where one was.
        assert_eq!(
            segments(&points),
            vec![
                vec![(0.5, 1e-2)],
                vec![(2.0, 1e-3)],
                vec![(4.0, 2e-3), (8.0, 3e-3)],
            ]
        );
    }

    #[test]
    fn plots_draw_in_both_formats() {
        let series = [
            run(vec![(0.5, 1e-2), (f64::INFINITY, 1.0), (2.0, 1e-3)], false),
            run(vec![(0.5, 1e-2), (2.0, 5e-3)], true),
        ];
        let svg = render(Format::Svg, &series, "a title", "RMSE").unwrap();
        let svg = String::from_utf8(svg).unwrap();
        let texts: Vec<&str> = svg
            .split("</text>")
            .filter_map(|t| t.rsplit_once('>'))
            .map(|(_, text)| text.trim())
            .collect();
        for text in [
            "a title", "seconds", "RMSE", "1e-3", "1e-2", "1e-1", "1e1", "run",
        ] {
            assert!(
                texts.contains(&text),
                "no {text} in the SVG's texts {texts:?}"
            );
        }
        assert!(!svg.contains("inf") && !svg.contains("NaN"));
        let png = render(Format::Png, &series, "a title", "RMSE").unwrap();
        let image = image::load_from_memory(&png).unwrap().to_rgb8();
        assert_eq!(image.dimensions(), (W, H));
        // Text is drawn: black pixels in the title's band.
        let dark = (0..W)
            .flat_map(|x| (0..30).map(move |y| (x, y)))
            .filter(|&(x, y)| image.get_pixel(x, y).0.iter().all(|&c| c < 100))
            .count();
        assert!(dark > 50, "{dark} dark pixels in the title's band");
    }
}
