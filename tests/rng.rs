//! The device's counter-based generator: Philox 4x32-10 known answers (Random123's kat_vectors),
//! uniformity of what rng_next4 returns (chi-square), and no correlation between the streams
//! of neighbouring pixels, of consecutive samples, or of neighbouring seeds.

mod common;

use ocl::prm::{Float4, Uint2, Uint4};

#[test]
fn philox_known_answers() {
    let device = common::device();
    let program = common::probes(&device);
    let cases: [([u32; 4], [u32; 2], [u32; 4]); 3] = [
        (
            [0; 4],
            [0; 2],
            [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8],
        ),
        (
            [u32::MAX; 4],
            [u32::MAX; 2],
            [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd],
        ),
        (
            [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
            [0xa4093822, 0x299f31d0],
            [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1],
        ),
    ];
    let ctr: Vec<Uint4> = cases.iter().map(|c| Uint4::from(c.0)).collect();
    let key: Vec<Uint2> = cases.iter().map(|c| Uint2::from(c.1)).collect();
    let ctr = common::buffer(&device, &ctr);
    let key = common::buffer(&device, &key);
    let out = common::output::<Uint4>(&device, cases.len());
    let kernel = ocl::Kernel::builder()
        .program(&program)
        .name("probe_philox")
        .queue(device.queue.clone())
        .arg(&ctr)
        .arg(&key)
        .arg(&out)
        .build()
        .unwrap();
    common::run(&kernel, cases.len());
    for (got, case) in common::read(&out).iter().zip(&cases) {
        let got: [u32; 4] = [got[0], got[1], got[2], got[3]];
        assert_eq!(
            got, case.2,
            "philox4x32-10 of ctr {:08x?} key {:08x?}",
            case.0, case.1
        );
    }
}

/// `dims` blocks (4 numbers each) for `pixels` pixels of one sample index.
fn stream(seed: u64, sample: u32, pixels: usize, dims: u32) -> Vec<[f32; 4]> {
    let device = common::device();
    let program = common::probes(&device);
    let out = common::output::<Float4>(&device, pixels * dims as usize);
    let kernel = ocl::Kernel::builder()
        .program(&program)
        .name("probe_rng_stream")
        .queue(device.queue.clone())
        .arg(seed as u32)
        .arg((seed >> 32) as u32)
        .arg(sample)
        .arg(dims)
        .arg(&out)
        .build()
        .unwrap();
    common::run(&kernel, pixels);
    common::read(&out)
        .iter()
        .map(|v| [v[0], v[1], v[2], v[3]])
        .collect()
}

/// Pearson's chi-square statistic of `counts` against a uniform expectation.
fn chi_square(counts: &[u64]) -> f64 {
    let total: u64 = counts.iter().sum();
    let expected = total as f64 / counts.len() as f64;
    counts
        .iter()
        .map(|&c| (c as f64 - expected).powi(2) / expected)
        .sum()
}

/// The chi-square quantile for `dof` degrees of freedom at tail probability 1e-6
/// (Wilson-Hilferty; accurate to a fraction of a percent at these dof).
fn chi_square_critical(dof: f64) -> f64 {
    let z = 4.753; // standard normal upper 1e-6 quantile
    let h = 2.0 / (9.0 * dof);
    dof * (1.0 - h + z * h.sqrt()).powi(3)
}

#[test]
fn numbers_are_uniform_in_one_and_two_dimensions() {
    let values = stream(0x5eed, 3, 8192, 16);
    let flat: Vec<f32> = values.iter().flatten().copied().collect();
    assert!(
        flat.iter().all(|&u| (0.0..1.0).contains(&u)),
        "a number left [0, 1)"
    );
    let bins = 256;
    let mut counts = vec![0u64; bins];
    for &u in &flat {
        counts[(u * bins as f32) as usize] += 1;
    }
    let chi = chi_square(&counts);
    let critical = chi_square_critical((bins - 1) as f64);
    assert!(chi < critical, "1D chi-square {chi:.1} >= {critical:.1}");
    // Pairs of consecutive numbers (x, y) on a 32x32 grid.
    let side = 32;
    let mut counts = vec![0u64; side * side];
    for pair in flat.chunks_exact(2) {
        let (i, j) = (
            (pair[0] * side as f32) as usize,
            (pair[1] * side as f32) as usize,
        );
        counts[i * side + j] += 1;
    }
    let chi = chi_square(&counts);
    let critical = chi_square_critical((side * side - 1) as f64);
    assert!(chi < critical, "2D chi-square {chi:.1} >= {critical:.1}");
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = a.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = b.iter().map(|y| (y - mb).powi(2)).sum();
    cov / (va * vb).sqrt()
}

#[test]
fn streams_of_neighbours_are_uncorrelated() {
    let pixels = 4096;
    let dims = 16;
    let base = stream(42, 0, pixels + 1, dims);
    let flat = |v: &[[f32; 4]]| v.iter().flatten().map(|&x| x as f64).collect::<Vec<f64>>();
    let per_pixel = dims as usize;
    // Pixel p against pixel p + 1, dimension by dimension.
    let a = flat(&base[..pixels * per_pixel]);
    let b = flat(&base[per_pixel..(pixels + 1) * per_pixel]);
    // Consecutive sample indices of the same pixels, and the neighbouring seed.
    let next_sample = flat(&stream(42, 1, pixels, dims));
    let next_seed = flat(&stream(43, 0, pixels, dims));
    // Dimension k against dimension k + 1 within one stream.
    let (a0, a1) = (&a[..a.len() - 1], &a[1..]);
    let limit = 5.0 / (a.len() as f64).sqrt(); // five standard errors of r under independence
    for (what, r) in [
        ("neighbouring pixels", correlation(&a, &b)),
        ("consecutive samples", correlation(&a, &next_sample)),
        ("neighbouring seeds", correlation(&a, &next_seed)),
        ("consecutive dimensions", correlation(a0, a1)),
    ] {
        assert!(
            r.abs() < limit,
            "{what}: correlation {r:.5}, limit {limit:.5}"
        );
    }
    assert_ne!(a, next_seed, "another seed gave the same stream");
}
