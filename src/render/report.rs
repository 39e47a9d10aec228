//! The per-pass report of a render (`--report`), written as CSV or JSON, and read back from CSV
//! (`clpt plot`, efficiency.rs): seconds, samples, the estimated error and the error measured
//! against a reference, pass by pass, with the estimator the render ran.

use super::PassReport;
use super::metrics::Metrics;
use super::strategy::Choice;
use crate::error::{Error, Result};
use crate::output::extension;
use std::fmt::Write as _;
use std::path::Path;

/// The first line of a CSV report; [`read_report`] reads the rows back by these columns.
pub const CSV_HEADER: &str =
    "pass,seconds,spp,spp_per_second,rmse_estimate,relmse_estimate,rmse,relmse,mae";

/// The formats of a report, by extension.
pub const REPORT_FORMATS: &[&str] = &["csv", "json"];

/// Writes `rows` as CSV or JSON, by the extension of `path` (atomically), with the estimator the render ran
/// and what its trial measured (CSV: `#` lines before the header; JSON: an object).
pub fn write_report(path: &Path, rows: &[PassReport], choice: &Choice) -> Result<()> {
    let measured = |r: &PassReport, f: fn(&super::Metrics) -> f64| {
        r.measured.map(|m| f(&m).to_string()).unwrap_or_default()
    };
    let text = match extension(path).as_str() {
        "csv" => {
            let mut out = format!("# estimator: {choice}\n");
            if choice.was_measured() {
                for line in choice.trial_lines() {
                    let _ = writeln!(out, "# trial: {line}");
                }
            }
            let _ = writeln!(out, "{CSV_HEADER}");
            for r in rows {
                let _ = writeln!(
                    out,
                    "{},{},{},{},{},{},{},{},{}",
                    r.pass,
                    r.seconds,
                    r.spp,
                    r.spp_per_second,
                    r.estimate.rmse,
                    r.estimate.relmse,
                    measured(r, |m| m.rmse),
                    measured(r, |m| m.relmse),
                    measured(r, |m| m.mae)
                );
            }
            out
        }
        "json" => {
            let items: Vec<String> = rows
                .iter()
                .map(|r| {
                    let m = r.measured.map_or(String::new(), |m| {
                        format!(
                            ", \"rmse\": {}, \"relmse\": {}, \"mae\": {}",
                            json_number(m.rmse),
                            json_number(m.relmse),
                            json_number(m.mae)
                        )
                    });
                    format!(
                        "    {{\"pass\": {}, \"seconds\": {}, \"spp\": {}, \"spp_per_second\": {}, \
                         \"rmse_estimate\": {}, \"relmse_estimate\": {}{m}}}",
                        r.pass,
                        json_number(r.seconds),
                        r.spp,
                        json_number(r.spp_per_second),
                        json_number(r.estimate.rmse),
                        json_number(r.estimate.relmse)
                    )
                })
                .collect();
            let trial: Vec<String> = if choice.was_measured() {
                choice
                    .measured
                    .iter()
                    .enumerate()
                    .map(|(i, m)| {
                        format!(
                            "    {{\"light_sampling\": {}, \"rr_threshold\": {}, \
                             \"relmse_x_seconds\": {}, \"relative_variance\": {}, \
                             \"trial_samples\": {}, \
                             \"seconds_per_path\": {}, \"missed_rare_paths\": {}, \
                             \"dropped_after_scouting\": {}, \"chosen\": {}}}",
                            m.strategy.light_sampling,
                            m.strategy.rr_threshold,
                            json_number(m.efficiency(choice.pixels)),
                            json_number(m.relative_variance),
                            m.samples,
                            json_number(m.seconds_per_sample),
                            m.missed_rare_paths,
                            m.dropped,
                            i == choice.chosen
                        )
                    })
                    .collect()
            } else {
                Vec::new()
            };
            let s = choice.strategy();
            format!(
                "{{\n  \"estimator\": {{\"light_sampling\": {}, \"rr_threshold\": {}, \
                 \"trial_seconds\": {}}},\n  \"trial\": [\n{}\n  ],\n  \"passes\": [\n{}\n  ]\n}}\n",
                s.light_sampling,
                s.rr_threshold,
                choice.seconds,
                trial.join(",\n"),
                items.join(",\n")
            )
        }
        _ => return Err(crate::output::unknown_format(path, ".csv or .json")),
    };
    crate::output::write_bytes(path, text.as_bytes())
}

/// A JSON number, or null for a value JSON cannot hold (NaN, infinities).
fn json_number(v: f64) -> String {
    if v.is_finite() {
        v.to_string()
    } else {
        "null".into()
    }
}

/// Reads a report that `--report` wrote as CSV.
pub fn read_report(path: &Path) -> Result<Vec<PassReport>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::Read {
        path: path.to_path_buf(),
        source: e,
    })?;
    let bad = |line: usize, what: &str| {
        Error::Invalid(format!("{}:{}: {what}", path.display(), line + 1))
    };
    let columns = CSV_HEADER.split(',').count();
    // `#` lines: the estimator and its trial, before the header.
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.starts_with('#'));
    match lines.next() {
        Some((_, header)) if header.starts_with("pass,seconds,spp,") => {}
        _ => return Err(bad(0, "not a clpt report (CSV, as --report writes it)")),
    }
    lines
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(n, line)| {
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != columns {
                return Err(bad(n, &format!("expected {columns} fields")));
            }
            // A non-finite value has no place on a log-log plot (it once made the axes span
            // 2^31 decades): an error naming it, never a silent skip.
            let num = |i: usize| -> Result<f64> {
                let name = CSV_HEADER.split(',').nth(i).unwrap_or("a column");
                match fields[i].parse::<f64>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    Ok(_) => Err(bad(
                        n,
                        &format!("{name} is `{}`, not a finite number", fields[i]),
                    )),
                    Err(_) => Err(bad(n, &format!("{name} `{}` is not a number", fields[i]))),
                }
            };
            let measured = if fields[6].is_empty() {
                None
            } else {
                Some(Metrics {
                    rmse: num(6)?,
                    relmse: num(7)?,
                    mae: num(8)?,
                })
            };
            Ok(PassReport {
                pass: num(0)? as u32,
                seconds: num(1)?,
                spp: num(2)? as u32,
                spp_per_second: num(3)?,
                estimate: super::ErrorEstimate {
                    rmse: num(4)?,
                    relmse: num(5)?,
                },
                measured,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reports_round_trip_through_csv_and_bad_files_are_errors() {
        let rows: Vec<PassReport> = (1..=3)
            .map(|i| PassReport {
                pass: i,
                seconds: f64::from(i) * 0.7,
                spp: 8 * i,
                spp_per_second: 11.4,
                estimate: crate::render::ErrorEstimate {
                    rmse: 0.1 / f64::from(i),
                    relmse: 0.3 / f64::from(i),
                },
                measured: (i > 1).then(|| Metrics {
                    rmse: 0.2,
                    relmse: 0.01 / f64::from(i),
                    mae: 0.05,
                }),
            })
            .collect();
        let dir = std::env::temp_dir();
        let path = dir.join(format!("clpt-report-{}.csv", std::process::id()));
        // A report of a render whose trial measured two strategies: its `#` lines are skipped.
        let strategy = |light_sampling| crate::render::strategy::Strategy {
            light_sampling,
            rr_threshold: 1.0,
        };
        let measured = |light_sampling| crate::render::strategy::Measured {
            strategy: strategy(light_sampling),
            seconds_per_sample: 1e-6,
            relative_variance: 0.5,
            relative_variance_se: 0.01,
            missed_rare_paths: false,
            samples: 8,
            dropped: false,
        };
        let choice = crate::render::strategy::Choice {
            measured: vec![measured(true), measured(false)],
            chosen: 1,
            seconds: 0.25,
            pixels: 100.0,
            film_samples: 0,
        };
        write_report(&path, &rows, &choice).unwrap();
        assert!(
            std::fs::read_to_string(&path)
                .unwrap()
                .starts_with("# estimator: ")
        );
        let back = read_report(&path).unwrap();
        assert_eq!(back.len(), rows.len());
        for (a, b) in back.iter().zip(&rows) {
            assert_eq!((a.pass, a.spp, a.seconds), (b.pass, b.spp, b.seconds));
            assert_eq!(a.measured, b.measured);
            assert_eq!(a.estimate.relmse, b.estimate.relmse);
        }
        for bad in ["", "seconds,rmse\n1,2\n", "pass,seconds,spp,x\n1,2,3\n"] {
            std::fs::write(&path, bad).unwrap();
            assert!(read_report(&path).is_err(), "{bad:?}");
        }
        std::fs::write(&path, "pass,seconds,spp,\n1,x,3,4,5,6,,,\n").unwrap();
        let err = read_report(&path).unwrap_err().to_string();
        assert!(err.contains(":2:") && err.contains("`x`"), "{err}");
        // Infinite or NaN values are errors that name the column: an `inf` once made `plot`
        // loop over 2^31 decades of axis.
        for value in ["inf", "-inf", "NaN"] {
            std::fs::write(
                &path,
                format!("pass,seconds,spp,\n1,0.5,8,16,1e-2,{value},,,\n"),
            )
            .unwrap();
            let err = read_report(&path).unwrap_err().to_string();
            assert!(
                err.contains(":2:") && err.contains("relmse_estimate") && err.contains(value),
                "{err}"
            );
        }
        std::fs::remove_file(&path).ok();
    }
}
