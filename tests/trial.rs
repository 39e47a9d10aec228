//! The strategy trial's statistics on the device (kernels/trial.cl, `clpt::render::trial`)
//! against the host's f64 formulas (tests/common/trial.rs), on random films and on adversarial
//! pixels (black, without variance, fireflies, tiny and huge values), several chunks with a
//! partial last one, rows thinned out and rows that end at the image's top; and `choose` on
//! either source reads the same: the least relMSE × seconds wins, a candidate that missed
//! rare paths is not chosen.

mod common;

use clpt::device::Device;
use clpt::device::program::KernelSources;
use clpt::render::Rows;
use clpt::render::metrics::REL_EPSILON;
use clpt::render::strategy::{self, Choice, Round, Strategy, TRIAL_SPP, TrialSums};
use clpt::render::trial::TrialKernels;
use common::trial::{HostFilm, HostRound};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// The device's float sums hold about 22 roundings of f32 per chunk (kernels/trial.cl) and
/// every summand is positive, so they keep that relative error: 22 × 2^-24 ≈ 1.3e-6. Allowed
/// eight times that.
const RELATIVE: f64 = 1e-5;

/// Renders nothing: puts each of the round's films (the pixels of `rows`, row by row) into a
/// film of `width` x `height` whose other pixels are NaN, keeps it as a trial round's
/// candidate on the device, and hands the round to `f`.
fn on_device<T>(
    device: &Device,
    round: &HostRound,
    size: (u32, u32),
    rows: Rows,
    f: impl FnOnce(&mut dyn TrialSums) -> T,
) -> T {
    in_parts(device, round, size, rows, 1, f)
}

/// A round of `films` of `samples` samples a pixel.
fn plain(films: &[HostFilm], samples: u32) -> HostRound {
    HostRound {
        films: films.to_vec(),
        samples,
    }
}

/// [`on_device`], each film kept in `parts` parts of its samples, every film's first part
/// before any film's second, as a CPU's trial keeps them (each part added to the film's sums
/// on the device): the first part holds each value rounded to 12 bits, the second the rest,
/// any others nothing, so that the parts add up to the film exactly.
fn in_parts<T>(
    device: &Device,
    host: &HostRound,
    (width, height): (u32, u32),
    rows: Rows,
    parts: u32,
    f: impl FnOnce(&mut dyn TrialSums) -> T,
) -> T {
    let films = &host.films;
    let len = (width * height) as usize * 4;
    let buffer = || {
        ocl::Buffer::<f32>::builder()
            .queue(device.queue.clone())
            .len(len)
            .build()
            .unwrap()
    };
    let (sum, sum_odd, rest) = (buffer(), buffer(), [buffer(), buffer(), buffer()]);
    let kernels = TrialKernels::new(
        device,
        &KernelSources::Embedded,
        None,
        [&sum, &sum_odd, &rest[0], &rest[1], &rest[2]],
        width,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut round = kernels.round(rows, films.len(), host.samples).unwrap();
    let columns = rows.columns(width);
    assert_eq!(round.pixels(), (columns * rows.count) as usize);
    // Part `part` of a value (None: the whole): hi + lo == v exactly (lo is v - hi, exact in
    // f32).
    let share = |v: f32, part: Option<u32>| {
        let hi = f32::from_bits(v.to_bits() & !0xfff);
        match (parts, part) {
            (1, _) | (_, None) => v,
            (_, Some(0)) => hi,
            (_, Some(1)) => v - hi,
            _ => 0.0,
        }
    };
    let image = |pixels: &[[f32; 4]], part: Option<u32>| {
        let mut flat = vec![f32::NAN; len];
        for (i, p) in pixels.iter().enumerate() {
            let (x, r) = (i as u32 % columns, i as u32 / columns);
            let column = rows.first_column() + x * rows.col_step;
            let at = ((rows.start + r * rows.step) * width + column) as usize * 4;
            for c in 0..4 {
                flat[at + c] = share(p[c], part);
            }
        }
        flat
    };
    for part in 0..parts {
        for (k, film) in films.iter().enumerate() {
            sum.write(&image(&film.sum, Some(part))).enq().unwrap();
            sum_odd
                .write(&image(&film.sum_odd, Some(part)))
                .enq()
                .unwrap();
            round.keep(k, false).unwrap();
        }
    }
    f(&mut round)
}

/// A round on part of the image clears its pixels of the film's five sums as it keeps them
/// (render/mod.rs, `trial_round`, clears no more than that between candidates), and no
/// other pixel.
#[test]
fn keeping_a_lattice_round_clears_its_pixels_and_no_other() {
    let device = common::device();
    let (width, height) = (20u32, 9u32);
    let rows = Rows {
        start: 1,
        count: 3,
        step: 3,
        col_step: 4,
    };
    let len = (width * height) as usize * 4;
    let values: Vec<f32> = (0..len).map(|i| i as f32 + 1.0).collect();
    let film: Vec<ocl::Buffer<f32>> = (0..5)
        .map(|_| {
            ocl::Buffer::<f32>::builder()
                .queue(device.queue.clone())
                .len(len)
                .copy_host_slice(&values)
                .build()
                .unwrap()
        })
        .collect();
    let kernels = TrialKernels::new(
        &device,
        &KernelSources::Embedded,
        None,
        [&film[0], &film[1], &film[2], &film[3], &film[4]],
        width,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut round = kernels.round(rows, 1, 32).unwrap();
    let read = |b: &ocl::Buffer<f32>| {
        let mut v = vec![0.0f32; len];
        b.read(&mut v).enq().unwrap();
        v
    };
    round.keep(0, true).unwrap();
    let columns = rows.columns(width);
    let taken = |pixel: u32| {
        let (x, y) = (pixel % width, pixel / width);
        y >= rows.start
            && (y - rows.start).is_multiple_of(rows.step)
            && (y - rows.start) / rows.step < rows.count
            && x >= rows.first_column()
            && (x - rows.first_column()).is_multiple_of(rows.col_step)
            && (x - rows.first_column()) / rows.col_step < columns
    };
    for (b, buffer) in film.iter().enumerate() {
        let after = read(buffer);
        for (i, (&v, &before)) in after.iter().zip(&values).enumerate() {
            let expected = if taken(i as u32 / 4) { 0.0 } else { before };
            assert_eq!(v, expected, "sum {b}, pixel {}, channel {}", i / 4, i % 4);
        }
    }
    assert_eq!((0..width * height).filter(|&p| taken(p)).count(), 15);
}

/// One pixel channel's (sum, odd groups' sum) of `n` samples: mostly ordinary values, with
/// every kind of adversarial one.
fn channel(rng: &mut SmallRng, n: u32) -> (f32, f32) {
    let half = n as f32 / 2.0;
    let (even, odd) = match rng.random_range(0..10) {
        0 => (0.0, 0.0),
        1 => {
            let v = rng.random::<f32>() * half;
            (v, v) // no variance
        }
        2 => (rng.random::<f32>() * 1e-6, rng.random::<f32>() * 1e-6),
        3 => (1e4 * half, 1e4 * half + rng.random::<f32>()), // huge, close halves
        4 => (rng.random::<f32>() * 1e6, rng.random::<f32>()), // a firefly
        _ => (rng.random::<f32>() * half, rng.random::<f32>() * half),
    };
    (even + odd, odd)
}

fn random_film(rng: &mut SmallRng, pixels: usize, n: u32) -> HostFilm {
    let mut film = HostFilm {
        sum: vec![[0.0; 4]; pixels],
        sum_odd: vec![[0.0; 4]; pixels],
    };
    for p in 0..pixels {
        for c in 0..3 {
            (film.sum[p][c], film.sum_odd[p][c]) = channel(rng, n);
        }
        film.sum[p][3] = f32::NAN; // the fourth value is never read
    }
    film
}

fn close(device: f64, host: f64) -> bool {
    (device - host).abs() <= RELATIVE * device.abs().max(host.abs())
}

#[test]
fn device_sums_match_the_f64_formulas() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(12);
    // 131 x 100 trial pixels: 12 whole chunks of 1024 and a partial one; every third row
    // from row 2, the last trial row the image's top row, and every third column from column
    // 1 of 393. Then one narrow row, and one film.
    for (width, height, rows, films, samples) in [
        (
            393,
            300,
            Rows {
                start: 2,
                count: 100,
                step: 3,
                col_step: 3,
            },
            4,
            16,
        ),
        (
            7,
            1,
            Rows {
                start: 0,
                count: 1,
                step: 1,
                col_step: 1,
            },
            3,
            8,
        ),
        (
            64,
            64,
            Rows {
                start: 0,
                count: 64,
                step: 1,
                col_step: 1,
            },
            1,
            64,
        ),
    ] {
        let pixels = (rows.columns(width) * rows.count) as usize;
        let films: Vec<HostFilm> = (0..films)
            .map(|_| random_film(&mut rng, pixels, samples))
            .collect();
        let weights: Vec<f64> = (0..films.len())
            .map(|k| (k as f64 + 0.5) / f64::from(samples))
            .collect();
        let mut host = plain(&films, samples);
        let sums = |d: &mut dyn TrialSums| (d.totals().unwrap(), d.terms(&weights).unwrap());
        let (host_totals, host_terms) = sums(&mut host);
        let (totals, terms) = on_device(&device, &host, (width, height), rows, sums);
        for k in 0..films.len() {
            for (what, device, host) in [
                ("mean", totals[k].0, host_totals[k].0),
                ("variance", totals[k].1, host_totals[k].1),
                ("relative variance", terms[k].0, host_terms[k].0),
                ("its square", terms[k].1, host_terms[k].1),
            ] {
                assert!(
                    close(device, host),
                    "{width}x{height}, film {k}: {what} {device:e} on the device, {host:e} in f64"
                );
            }
        }
    }
}

#[test]
fn a_round_kept_in_parts_sums_as_one_kept_whole() {
    let device = common::device();
    let mut rng = SmallRng::seed_from_u64(5);
    // Every 2nd row from row 1 and every 2nd column from column 0 of 66: 33 x 10 pixels.
    let rows = Rows {
        start: 1,
        count: 10,
        step: 2,
        col_step: 2,
    };
    let films: Vec<HostFilm> = (0..2).map(|_| random_film(&mut rng, 330, 32)).collect();
    let round = plain(&films, 32);
    let sums = |parts| {
        in_parts(&device, &round, (66, 21), rows, parts, |d| {
            let weights = [0.05, 0.07];
            (d.totals().unwrap(), d.terms(&weights).unwrap())
        })
    };
    let whole = sums(1);
    // Each film in two parts (each value's first 12 bits, then the rest), and in five (the
    // three after those add nothing): each part is added to the film's sums.
    assert_eq!(sums(2), whole);
    assert_eq!(sums(5), whole);
}

#[test]
fn a_black_round_sums_to_zero() {
    let device = common::device();
    let rows = Rows {
        start: 0,
        count: 3,
        step: 2,
        col_step: 1,
    };
    let black = HostFilm {
        sum: vec![[0.0; 4]; 30],
        sum_odd: vec![[0.0; 4]; 30],
    };
    let round = plain(&[black.clone(), black], 8);
    let (totals, terms) = on_device(&device, &round, (10, 6), rows, |d| {
        (d.totals().unwrap(), d.terms(&[0.1, 0.1]).unwrap())
    });
    assert_eq!(totals, [(0.0, 0.0); 2]);
    assert_eq!(terms, [(0.0, 0.0); 2]);
}

fn strategy(light_sampling: bool) -> Strategy {
    Strategy {
        light_sampling,
        rr_threshold: 1.0,
    }
}

/// A trial film of `pixels` pixels whose two groups of four sum to `even` and `odd` in every
/// channel.
fn film(pixels: usize, even: f32, odd: f32) -> HostFilm {
    HostFilm {
        sum: vec![[even + odd; 4]; pixels],
        sum_odd: vec![[odd; 4]; pixels],
    }
}

/// `choose` over `films` (of one row, seconds each) with the host's sums and with the
/// device's; the two choices agree, the host's is returned.
fn choose_both(films: &[HostFilm], seconds: &[f64]) -> Choice {
    choose_round(&plain(films, TRIAL_SPP), seconds)
}

/// [`choose_both`] for a round of its own samples a pixel.
fn choose_round(host: &HostRound, seconds: &[f64]) -> Choice {
    let films = &host.films;
    let pixels = films[0].sum.len();
    let round = Round {
        strategies: (0..films.len()).map(|k| strategy(k % 2 == 0)).collect(),
        seconds: seconds.to_vec(),
        samples: host.samples,
        pixels,
    };
    let on_host = strategy::choose(&round, &mut host.clone(), pixels as f64, 1.0).unwrap();
    let rows = Rows {
        start: 0,
        count: 1,
        step: 1,
        col_step: 1,
    };
    let device = common::device();
    let size = (pixels as u32, 1);
    let on_device = on_device(&device, host, size, rows, |d| {
        strategy::choose(&round, d, pixels as f64, 1.0).unwrap()
    });
    assert_eq!(
        on_host.chosen, on_device.chosen,
        "{on_host:?}\n{on_device:?}"
    );
    for (h, d) in on_host.measured.iter().zip(&on_device.measured) {
        assert_eq!(h.missed_rare_paths, d.missed_rare_paths);
        assert!(
            close(d.relative_variance, h.relative_variance),
            "{h:?}\n{d:?}"
        );
    }
    on_host
}

#[test]
fn the_least_variance_times_time_wins() {
    // Mean 1 in both; the first has 4 times the second's variance and half its time.
    let (a, b) = (film(100, 6.0, 2.0), film(100, 5.0, 3.0));
    let choice = choose_both(&[a.clone(), b.clone()], &[1.0, 2.0]);
    let m = &choice.measured;
    assert!((m[0].relative_variance / m[1].relative_variance - 4.0).abs() < 1e-9);
    assert_eq!(choice.chosen, 1, "{choice:?}");
    // Four times as fast turns it round.
    assert_eq!(choose_both(&[a, b], &[0.4, 2.0]).chosen, 0);
    // Equal figures (a black picture): the first.
    let black = film(100, 0.0, 0.0);
    assert_eq!(choose_both(&[black.clone(), black], &[1.0, 1.0]).chosen, 0);
}

#[test]
fn a_candidate_whose_mean_fell_short_missed_rare_paths_and_is_not_chosen() {
    // Pixel means 1 with a little noise, against means of 0.5 with less noise: by the two
    // being unbiased estimates of one image, the second missed its rare bright samples.
    let precise: Vec<[f32; 4]> = (0..400).map(|i| [4.0 + (i % 3) as f32 * 0.1; 4]).collect();
    let a = HostFilm {
        sum: precise.iter().map(|p| p.map(|v| v * 2.0)).collect(),
        sum_odd: precise.clone(),
    };
    let b = film(400, 2.0, 2.0);
    let choice = choose_both(&[a, b], &[10.0, 0.1]);
    assert!(choice.measured[1].missed_rare_paths, "{choice:?}");
    assert!(!choice.measured[0].missed_rare_paths);
    assert_eq!(choice.chosen, 0);
}

/// A film of `n` samples a pixel, mean 1 in every channel, whose relative variance of one
/// sample (over a denominator of 1, before [`REL_EPSILON`]) is `v`: halves apart by d, (d / (n/2))^2 n/4 = v.
fn of_variance(pixels: usize, n: u32, v: f64) -> HostFilm {
    let d = (v * f64::from(n)).sqrt() as f32;
    let half = n as f32 / 2.0;
    film(pixels, half + d / 2.0, half - d / 2.0)
}

#[test]
fn a_round_reads_each_candidate_at_its_own_samples() {
    // At 32 samples the second reads better (0.47 against 0.48): its own figures, not carried
    // to the render's samples, decide.
    let films = [of_variance(64, 32, 0.48), of_variance(64, 32, 0.47)];
    let choice = choose_round(&plain(&films, 32), &[1.0, 1.0]);
    assert_eq!(choice.chosen, 1, "{choice:?}");
    // Over the denominator 1 + ε.
    let over = |v: f64| v / (1.0 + f64::from(REL_EPSILON));
    for (m, v) in choice.measured.iter().zip([0.48, 0.47]) {
        assert_eq!(m.samples, 32);
        assert!((m.relative_variance - over(v)).abs() < 1e-6, "{m:?}");
    }
}
