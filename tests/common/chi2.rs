//! A chi-square goodness-of-fit test for samplers of directions (pbrt-v4's `Chi2Test` in
//! `bsdfs_test.cpp`, Mitsuba 3's `ChiSquareTest`): the one harness that checks every sampler of
//! the kernels' sampling trios (material.h's `bsdf_sample` against `bsdf_pdf`, nee.h's
//! `light_sample` against `light_pdf`).
//!
//! The sphere of directions is cut into bins of equal solid angle on a [`Grid`] about an axis:
//! `v = 1 - cos θ` (θ the angle to the axis) in equal steps, so a narrow cone can be binned as
//! finely as the whole sphere, times the azimuth φ in equal steps. Each bin's expected count is
//! the number of sampling attempts times the density integrated over the bin in f64
//! ([`bin_masses`]: the midpoint rule on `sub × sub` sub-cells of every bin, [`Grid::nodes`],
//! or on a partition of the surface the density lives on, such as a light's area, whose edges
//! then cost no accuracy; the density itself may come from the device). The density is not
//! renormalised: a sampler that reports twice its density, or loses samples, fails as surely as
//! one that puts them in the wrong place. Directions outside the grid (and attempts that gave
//! no direction) form one more bin, expected `attempts × (1 - ∫ density)`, or none where the
//! grid holds the whole density to the quadrature's accuracy (1e-3).
//!
//! As pbrt-v4: bins are sorted by expected count; a bin whose expected count is 0 may hold at
//! most `attempts × 1e-5` samples (rounding at a boundary), and is otherwise left out; bins
//! expected below [`MIN_EXPECTED`] are pooled (in increasing order, until the pool reaches it)
//! into one; the statistic `Σ (observed − expected)² / expected` has one degree of freedom less
//! than the number of bins kept. Its p-value is the regularized upper incomplete gamma function
//! `Q(dof / 2, χ² / 2)`, computed exactly (series or continued fraction, Numerical Recipes
//! §6.2; not the Wilson–Hilferty approximation, which tests/chi2.rs compares it with). A test
//! fails below `SIGNIFICANCE / TESTS`: Bonferroni's correction for the [`TESTS`] chi-square
//! tests the suite runs, so that all of them together fail by chance with probability at most
//! [`SIGNIFICANCE`].

use glam::DVec3;
use std::f64::consts::TAU;

/// The chance that any of the suite's chi-square tests fails although every sampler is right.
pub const SIGNIFICANCE: f64 = 0.01;

/// The chi-square tests of the suite, each run with level `SIGNIFICANCE / TESTS` (Bonferroni):
/// tests/material.rs 8 (Lambertian, 4 normals × 2 sides) + 4 (bent shading normals);
/// tests/chi2.rs 1 (the harness on an exact host sampler) + 7 (sphere lights) + 4 (sphere caps) +
/// 9 (squares, parallelograms and triangles) + 10 (a room's emitting wall by solid angle).
pub const TESTS: usize = 43;

/// Bins expected to hold fewer samples than this are pooled.
pub const MIN_EXPECTED: f64 = 5.0;

/// Bins of equal solid angle on the cap `1 - cos θ <= v_max` about `axis` (`v_max = 2`: the
/// whole sphere), `n_v` steps of `v` times `n_phi` steps of the azimuth.
#[derive(Clone, Debug)]
pub struct Grid {
    pub axis: DVec3,
    x: DVec3,
    y: DVec3,
    pub v_max: f64,
    pub n_v: usize,
    pub n_phi: usize,
}

impl Grid {
    pub fn new(axis: DVec3, v_max: f64, n_v: usize, n_phi: usize) -> Grid {
        let axis = axis.normalize();
        let (x, y) = axis.any_orthonormal_pair();
        assert!(v_max > 0.0 && v_max <= 2.0, "v_max {v_max}");
        Grid {
            axis,
            x,
            y,
            v_max,
            n_v,
            n_phi,
        }
    }

    /// The whole sphere, 40 steps of cos θ by 40 of φ.
    pub fn sphere(axis: DVec3) -> Grid {
        Grid::new(axis, 2.0, 40, 40)
    }

    /// 20 steps of `v` by 40 of φ over a cap reaching a little past `support` (the largest
    /// `1 - cos θ` of the density's support): half a step past it, so the support's rim runs
    /// through the middle of the outer ring, and f32 rounding that moves a sample across the
    /// rim does not move it to another bin.
    pub fn cap(axis: DVec3, support: f64) -> Grid {
        let n_v = 20;
        let v_max = (support * n_v as f64 / (n_v as f64 - 0.5)).min(2.0);
        Grid::new(axis, v_max, n_v, 40)
    }

    pub fn bins(&self) -> usize {
        self.n_v * self.n_phi
    }

    /// `1 - cos θ` of w (accurate for tiny θ: sin²θ / (1 + cos θ)) and its azimuth in [0, 2π).
    pub fn coords(&self, w: DVec3) -> (f64, f64) {
        let w = w.normalize();
        let (a, b, c) = (w.dot(self.x), w.dot(self.y), w.dot(self.axis));
        let v = if c > 0.0 {
            (a * a + b * b) / (1.0 + c)
        } else {
            1.0 - c
        };
        (v, b.atan2(a).rem_euclid(TAU))
    }

    /// The bin of direction w, or `None` outside the cap (or for a non-finite w).
    pub fn bin(&self, w: DVec3) -> Option<usize> {
        let (v, phi) = self.coords(w);
        if !(v <= self.v_max && phi.is_finite()) {
            return None;
        }
        let i = ((v / self.v_max * self.n_v as f64) as usize).min(self.n_v - 1);
        let j = ((phi / TAU * self.n_phi as f64) as usize).min(self.n_phi - 1);
        Some(i * self.n_phi + j)
    }

    /// The unit direction at (v, φ).
    pub fn direction(&self, v: f64, phi: f64) -> DVec3 {
        let sin = (v * (2.0 - v)).max(0.0).sqrt();
        self.axis * (1.0 - v) + self.x * (sin * phi.cos()) + self.y * (sin * phi.sin())
    }

    /// Quadrature nodes over the grid, bin after bin: the centres of `sub × sub` sub-cells of
    /// equal steps in `v` and φ in every bin, and each one's solid angle (all equal).
    pub fn nodes(&self, sub: usize) -> (Vec<DVec3>, Vec<f64>) {
        let (dv, dphi) = (self.v_max / self.n_v as f64, TAU / self.n_phi as f64);
        let mut nodes = Vec::with_capacity(self.bins() * sub * sub);
        for i in 0..self.n_v {
            for j in 0..self.n_phi {
                for a in 0..sub {
                    for b in 0..sub {
                        let v = (i as f64 + (a as f64 + 0.5) / sub as f64) * dv;
                        let phi = (j as f64 + (b as f64 + 0.5) / sub as f64) * dphi;
                        nodes.push(self.direction(v, phi));
                    }
                }
            }
        }
        let weight = dv * dphi / (sub * sub) as f64;
        let weights = vec![weight; nodes.len()];
        (nodes, weights)
    }
}

/// The outcome of one test.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub name: String,
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Sampling attempts, and the directions of them that landed on the grid.
    pub attempts: usize,
    pub on_grid: usize,
    /// Bins pooled into one, and samples found in bins of expected count 0.
    pub pooled: usize,
    pub in_empty_bins: u64,
    /// The density integrated over the grid (1 when the grid covers the whole support).
    pub mass: f64,
    /// The bins that add most to the statistic, for the message of a failure.
    pub worst: Vec<BinCount>,
}

/// One bin's counts: its (v step, φ step), or `None` for off the grid.
#[derive(Clone, Copy, Debug)]
pub struct BinCount {
    pub bin: Option<(usize, usize)>,
    pub observed: u64,
    pub expected: f64,
}

impl BinCount {
    /// What it adds to the statistic (its count, where none is expected).
    fn excess(&self) -> f64 {
        let (o, e) = (self.observed as f64, self.expected);
        if e > 0.0 { (o - e).powi(2) / e } else { o }
    }
}

impl Outcome {
    /// The level each test is held to.
    pub fn level() -> f64 {
        SIGNIFICANCE / TESTS as f64
    }

    /// Whether the sampler passes: p at least the level, and no more than attempts × 1e-5
    /// samples where the density is 0.
    pub fn passes(&self) -> bool {
        self.p_value >= Outcome::level() && self.in_empty_bins as f64 <= self.attempts as f64 * 1e-5
    }

    /// Prints the outcome and panics if the sampler fails.
    pub fn assert_passes(&self) {
        println!("{self}");
        assert!(
            self.passes(),
            "chi-square test failed: {self}; the bins (v step, phi step) adding most: {:?}",
            self.worst
        );
    }

    /// Prints the outcome and panics if the sampler passes (the harness's own checks).
    pub fn assert_fails(&self) {
        println!("{self} (meant to fail)");
        assert!(!self.passes(), "a wrong density passed: {self}");
    }
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "chi2 {}: statistic {:.1}, dof {}, p {:.3e} (level {:.1e}); {} of {} attempts on the \
             grid, density mass {:.6}, {} bins pooled, {} samples where the density is 0",
            self.name,
            self.statistic,
            self.dof,
            self.p_value,
            Outcome::level(),
            self.on_grid,
            self.attempts,
            self.mass,
            self.pooled,
            self.in_empty_bins
        )
    }
}

/// Each bin's share of a density given at quadrature nodes (directions, each with the solid
/// angle of its patch): the sum of density × solid angle over the nodes in the bin. Nodes off
/// the grid are left out. The nodes may be [`Grid::nodes`], or a partition of any surface the
/// density lives on (tests/chi2.rs: a light's area, where a polygon's edges cost no accuracy).
pub fn bin_masses(grid: &Grid, nodes: &[DVec3], solid_angles: &[f64], density: &[f64]) -> Vec<f64> {
    assert!(nodes.len() == solid_angles.len() && nodes.len() == density.len());
    let mut mass = vec![0.0; grid.bins()];
    for ((w, a), d) in nodes.iter().zip(solid_angles).zip(density) {
        assert!(d.is_finite() && *d >= 0.0, "density {d} at {w}");
        if let Some(k) = grid.bin(*w) {
            mass[k] += d * a;
        }
    }
    mass
}

/// The chi-square test of `samples` (the directions that `attempts` sampling attempts gave;
/// fewer where some gave none) against a density whose integral over each bin of `grid` is
/// `masses` ([`bin_masses`]).
pub fn test(
    name: &str,
    grid: &Grid,
    attempts: usize,
    samples: &[DVec3],
    masses: &[f64],
) -> Outcome {
    let bins = grid.bins();
    assert_eq!(masses.len(), bins, "{name}: one mass per bin");
    assert!(samples.len() <= attempts);
    // Observed: the grid's bins, then one for everything off it.
    let mut observed = vec![0u64; bins + 1];
    for w in samples {
        observed[grid.bin(*w).unwrap_or(bins)] += 1;
    }
    observed[bins] += (attempts - samples.len()) as u64;
    let on_grid = attempts - observed[bins] as usize;
    // Expected: attempts × the density integrated over each bin.
    let mut expected: Vec<f64> = masses.iter().map(|m| m * attempts as f64).collect();
    let mass = expected.iter().sum::<f64>() / attempts as f64;
    // Off the grid: what the density leaves; none where the grid holds all of it to the
    // quadrature's accuracy (then any sample there is one where the density is 0).
    let rest = 1.0 - mass;
    expected.push(if rest > 1e-3 {
        rest * attempts as f64
    } else {
        0.0
    });

    let mut order: Vec<usize> = (0..=bins).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_obs, mut pool_exp, mut pooled) = (0.0, 0.0, 0usize);
    let (mut statistic, mut kept, mut in_empty_bins) = (0.0, 0usize, 0u64);
    for k in order {
        let (o, e) = (observed[k] as f64, expected[k]);
        if e == 0.0 {
            in_empty_bins += observed[k];
        } else if e < MIN_EXPECTED || (pool_exp > 0.0 && pool_exp < MIN_EXPECTED) {
            pool_obs += o;
            pool_exp += e;
            pooled += 1;
        } else {
            statistic += (o - e) * (o - e) / e;
            kept += 1;
        }
    }
    if pool_exp > 0.0 {
        statistic += (pool_obs - pool_exp) * (pool_obs - pool_exp) / pool_exp;
        kept += 1;
    }
    assert!(kept >= 2, "{name}: too few bins ({kept}) for a test");
    let mut worst: Vec<BinCount> = (0..=bins)
        .map(|k| BinCount {
            bin: (k < bins).then_some((k / grid.n_phi, k % grid.n_phi)),
            observed: observed[k],
            expected: expected[k],
        })
        .collect();
    worst.sort_by(|a, b| b.excess().total_cmp(&a.excess()));
    worst.truncate(8);
    let dof = kept - 1;
    Outcome {
        name: name.to_string(),
        statistic,
        dof,
        p_value: chi2_sf(statistic, dof as f64),
        attempts,
        on_grid,
        pooled,
        in_empty_bins,
        mass,
        worst,
    }
}

/// The probability that a chi-square variable of `dof` degrees of freedom exceeds x.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    gamma_q(dof / 2.0, x / 2.0)
}

/// The Wilson–Hilferty approximation of [`chi2_sf`] (a cube root of a chi-square variable is
/// nearly normal), for comparison.
pub fn chi2_sf_wilson_hilferty(x: f64, dof: f64) -> f64 {
    let s = 2.0 / (9.0 * dof);
    let z = ((x / dof).cbrt() - (1.0 - s)) / s.sqrt();
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// erfc by Numerical Recipes' Chebyshev fit `erfcc` (|error| < 1.2e-7): enough for the
/// approximation it serves.
fn erfc(x: f64) -> f64 {
    const C: [f64; 10] = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = C.iter().rev().fold(0.0, |acc, c| acc * t + c);
    let r = t * (-z * z + poly).exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// ln Γ(x) for x >= 0.5 (Lanczos, g = 7, 9 terms: relative error below 1e-14).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    assert!(x >= 0.5, "ln_gamma({x})");
    let x = x - 1.0;
    let t = x + 7.5;
    let a = C[0]
        + C[1..]
            .iter()
            .enumerate()
            .map(|(i, c)| c / (x + i as f64 + 1.0))
            .sum::<f64>();
    0.5 * TAU.ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The regularized upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a): by its series
/// below x = a + 1 (as 1 − P), by Lentz's continued fraction above (Numerical Recipes §6.2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    assert!(a > 0.0 && x >= 0.0, "gamma_q({a}, {x})");
    if x == 0.0 {
        return 1.0;
    }
    let front = (-x + a * x.ln() - ln_gamma(a)).exp();
    if x < a + 1.0 {
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * front).max(0.0)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        front * h
    }
}
