//! Comparing renders by their reports (`clpt plot`): the error of each pass times its seconds,
//! which an unbiased renderer holds flat (the MSE of a Monte Carlo mean falls as 1/t), the level
//! it holds (the smaller, the more efficient: Veach's efficiency is its inverse), and from it
//! the time each render needs to reach a given relMSE. No kernel counterpart: it reads what
//! `--report` wrote (report.rs).
//!
//! The measured relMSE of a render against a reference carries the reference's own variance:
//! E\[relMSE\] ≈ relMSE of the render + relMSE of the reference. Given the reference's own
//! estimated relMSE (the last `relmse_estimate` of its report), that part is subtracted, so a
//! reference need not be a hundred times longer than the runs it judges.

use super::PassReport;
use crate::error::{Error, Result};

/// One render's report rows, under a label.
#[derive(Clone, Debug)]
pub struct Run {
    pub label: String,
    pub rows: Vec<PassReport>,
}

/// What `clpt plot` prints of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Samples per pixel per second at the end.
    pub spp_per_second: f64,
    /// The median of relMSE × seconds over the run's last decade of time.
    pub level: f64,
    /// Whether `level` comes from the measured error (else from the estimate).
    pub measured: bool,
    /// The render's seconds at its last pass.
    pub seconds: f64,
}

impl Summary {
    /// Seconds to reach relMSE `e`: level / e (MSE × t being flat), beyond `seconds` an
    /// extrapolation.
    pub fn time_to(&self, e: f64) -> f64 {
        self.level / e
    }
}

/// The relMSE of a pass: measured against the reference less the reference's own
/// (`reference_relmse`), or the estimate when the run had no reference.
pub fn relmse(row: &PassReport, reference_relmse: f64) -> f64 {
    match row.measured {
        Some(m) => m.relmse - reference_relmse,
        None => row.estimate.relmse,
    }
}

/// The run's summary, from its passes with at least a tenth of its seconds.
pub fn summarize(run: &Run, reference_relmse: f64) -> Result<Summary> {
    let last =
        run.rows.iter().rfind(|r| r.seconds > 0.0).ok_or_else(|| {
            Error::Invalid(format!("{}: the report has no timed pass", run.label))
        })?;
    let mut products: Vec<f64> = run
        .rows
        .iter()
        .filter(|r| r.seconds >= last.seconds / 10.0)
        .map(|r| relmse(r, reference_relmse) * r.seconds)
        .collect();
    products.sort_by(f64::total_cmp);
    let level = products[products.len() / 2];
    if level.is_nan() || level <= 0.0 {
        return Err(Error::Invalid(format!(
            "{}: relMSE x seconds is {level} (the reference's own relMSE is too large to subtract?)",
            run.label
        )));
    }
    Ok(Summary {
        spp_per_second: last.spp_per_second,
        level,
        measured: last.measured.is_some(),
        seconds: last.seconds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::ErrorEstimate;
    use crate::render::metrics::Metrics;

    /// Passes at 1..=20 seconds of a renderer whose relMSE is exactly level / t, measured
    /// against a reference of relMSE `reference`.
    fn run(level: f64, reference: f64) -> Run {
        let rows = (1..=20)
            .map(|i| {
                let seconds = i as f64;
                PassReport {
                    pass: i,
                    seconds,
                    spp: 8 * i,
                    spp_per_second: 8.0,
                    estimate: ErrorEstimate {
                        rmse: 0.1,
                        relmse: 2.0 * level / seconds,
                    },
                    measured: Some(Metrics {
                        rmse: 0.1,
                        relmse: level / seconds + reference,
                        mae: 0.05,
                    }),
                }
            })
            .collect();
        Run {
            label: "flat".into(),
            rows,
        }
    }

    #[test]
    fn a_flat_run_gives_its_level_and_times_less_the_reference_s_error() {
        let summary = summarize(&run(0.5, 1e-3), 1e-3).unwrap();
        assert!((summary.level - 0.5).abs() < 1e-12, "{summary:?}");
        assert!((summary.time_to(1e-2) - 50.0).abs() < 1e-9);
        assert!(summary.measured && summary.seconds == 20.0);
        // Left in, the reference's error bends the line up and the level with it.
        assert!(summarize(&run(0.5, 1e-3), 0.0).unwrap().level > 0.5);
        // Without a reference the estimate is used.
        let mut unmeasured = run(0.5, 0.0);
        unmeasured.rows.iter_mut().for_each(|r| r.measured = None);
        let summary = summarize(&unmeasured, 0.0).unwrap();
        assert!((summary.level - 1.0).abs() < 1e-12 && !summary.measured);
        // Subtracting more than was there is an error, not a negative time.
        assert!(summarize(&run(0.5, 0.0), 1.0).is_err());
    }
}
