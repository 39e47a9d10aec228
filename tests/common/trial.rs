//! The strategy trial's statistics on the host in f64 (the formulas of kernels/trial.cl and
//! `clpt::render::strategy::TrialSums`): the oracle the device's sums are held against.

use clpt::render::metrics::REL_EPSILON;
use clpt::render::strategy::TrialSums;

/// One candidate's trial film: per trial pixel, the sum of its samples and the sum of those of
/// its odd groups of four (red, green, blue and a fourth value the trial does not read).
#[derive(Clone, Debug)]
pub struct HostFilm {
    pub sum: Vec<[f32; 4]>,
    pub sum_odd: Vec<[f32; 4]>,
}

/// A round's films, all of `samples` samples a pixel.
#[derive(Clone)]
pub struct HostRound {
    pub films: Vec<HostFilm>,
    pub samples: u32,
}

impl HostRound {
    /// The sums of `terms`: over the denominator of the films weighted by `weights`.
    fn terms_of(&self, weights: &[f64]) -> Vec<(f64, f64)> {
        let (films, n) = (&self.films, f64::from(self.samples));
        let pixels = films.first().map_or(0, |f| f.sum.len());
        let mut sums = vec![(0.0f64, 0.0f64); films.len()];
        for p in 0..pixels {
            let mut denominator = [0.0f64; 3];
            for (film, &w) in films.iter().zip(weights) {
                for (d, &v) in denominator.iter_mut().zip(&film.sum[p][..3]) {
                    *d += w * f64::from(v);
                }
            }
            let denominator = denominator.map(|m| m * m + f64::from(REL_EPSILON));
            for (film, sum) in films.iter().zip(&mut sums) {
                let (s, o) = (film.sum[p], film.sum_odd[p]);
                let term = (0..3)
                    .map(|c| {
                        stratified_variance(f64::from(s[c]), f64::from(o[c]), n) / denominator[c]
                    })
                    .sum::<f64>()
                    / 3.0;
                sum.0 += term;
                sum.1 += term * term;
            }
        }
        sums
    }
}

/// n times the variance of the mean of n samples, from the sum of the n samples and of those
/// of the odd groups of four: each half's mean has variance σ² / (n/2), so their difference
/// squared has expectation 4σ² / n.
pub fn stratified_variance(sum: f64, sum_odd: f64, n: f64) -> f64 {
    let half = n / 2.0;
    let difference = (sum - 2.0 * sum_odd) / half;
    difference * difference * n / 4.0
}

impl TrialSums for HostRound {
    fn totals(&mut self) -> clpt::error::Result<Vec<(f64, f64)>> {
        let n = f64::from(self.samples);
        Ok(self
            .films
            .iter()
            .map(|film| {
                let (mut mean, mut var) = (0.0, 0.0);
                for (s, o) in film.sum.iter().zip(&film.sum_odd) {
                    // The channels' sum and its own variance (kernels/trial.cl, trial_pixel).
                    let total = |p: &[f32; 4]| p[..3].iter().map(|&c| f64::from(c)).sum::<f64>();
                    mean += total(s) / n;
                    var += stratified_variance(total(s), total(o), n) / n;
                }
                (mean, var)
            })
            .collect())
    }

    fn terms(&mut self, weights: &[f64]) -> clpt::error::Result<Vec<(f64, f64)>> {
        Ok(self.terms_of(weights))
    }
}
