//! The device's random numbers (kernels/rng.h, kernels/sobol.h): Philox 4x32-10 known answers
//! (Random123's kat_vectors); the Sobol table against the Joe-Kuo recurrence; the net property
//! of a pixel's samples in every block of four dimensions, in each of the two independent
//! halves; uniformity of what rng_next4 returns (chi-square); and no correlation between
//! neighbouring pixels, the two halves, neighbouring seeds, or dimensions; and that the programs
//! of several lanes a work-item (kernels/lanes.h) draw in each lane exactly the numbers of its
//! sample.

mod common;

use clpt::device::Device;
use clpt::device::kernel::NamedArgs;
use ocl::prm::{Float4, Uint2, Uint4};
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// kernels/rng_probes.cl built with `lanes` lanes a work-item (kernels/lanes.h).
fn rng_probes(device: &Device, lanes: u32) -> ocl::Program {
    let defines = if lanes == 1 {
        vec![]
    } else {
        vec![("CLPT_LANES", lanes.to_string())]
    };
    common::build_without_warnings(device, "rng_probes.cl", &defines)
}

#[test]
fn philox_known_answers() {
    let device = common::device();
    let program = rng_probes(&device, 1);
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
    let kernel = NamedArgs::new(&program, "probe_philox", &device.queue)
        .buffer("ctr", &ctr)
        .buffer("key", &key)
        .buffer("out", &out)
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

/// Runs the probe `name` of the program of `lanes` lanes (arguments: the seed's two words, then
/// `args` by name, then the output) for `items` samples or pixels (`items / lanes` work-items) that write
/// `dims` blocks of four numbers each.
fn rng_probe(
    name: &str,
    lanes: u32,
    seed: u64,
    args: &[(&'static str, u32)],
    items: usize,
    dims: u32,
) -> Vec<[f32; 4]> {
    let device = common::device();
    let program = rng_probes(&device, lanes);
    let out = common::output::<Float4>(&device, items * dims as usize);
    let mut kernel = NamedArgs::new(&program, name, &device.queue);
    kernel
        .scalar("seed_lo", seed as u32)
        .scalar("seed_hi", (seed >> 32) as u32);
    for &(arg, value) in args {
        kernel.scalar(arg, value);
    }
    let kernel = kernel
        .scalar("dims", dims)
        .buffer("out", &out)
        .build()
        .unwrap();
    assert_eq!(items % lanes as usize, 0);
    common::run(&kernel, items / lanes as usize);
    common::read(&out)
        .iter()
        .map(|v| [v[0], v[1], v[2], v[3]])
        .collect()
}

/// `dims` blocks (4 numbers each) for `pixels` pixels of one sample index: the camera's and
/// the BSDF's (rng_next4).
fn stream(seed: u64, sample: u32, pixels: usize, dims: u32) -> Vec<[f32; 4]> {
    rng_probe(
        "probe_rng_stream",
        1,
        seed,
        &[("sample", sample), ("light", 0)],
        pixels,
        dims,
    )
}

/// As [`stream`], the light samples' blocks of the first `vertices` vertices (rng_light4).
fn light_stream(seed: u64, sample: u32, pixels: usize, vertices: u32) -> Vec<[f32; 4]> {
    rng_probe(
        "probe_rng_stream",
        1,
        seed,
        &[("sample", sample), ("light", 1)],
        pixels,
        vertices,
    )
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
    // The BSDF's blocks and the light's, each on its own.
    for values in [
        stream(0x5eed, 3, 8192, 16),
        light_stream(0x5eed, 3, 8192, 8),
    ] {
        uniform_in_one_and_two_dimensions(&values);
    }
}

fn uniform_in_one_and_two_dimensions(values: &[[f32; 4]]) {
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
    // The same pixels' first sample of the other half (sample 4), and the neighbouring seed.
    // (Samples of one half are negatively correlated by design: they form a net.)
    let other_half = flat(&stream(42, 4, pixels, dims));
    let next_seed = flat(&stream(43, 0, pixels, dims));
    // Dimension k against dimension k + 1 within one stream, and against the same dimension of
    // the next block (padding: each block's sequence is shuffled apart).
    let (a0, a1) = (&a[..a.len() - 1], &a[1..]);
    let (b0, b1) = (&a[..a.len() - 4], &a[4..]);
    // Each vertex's light numbers against its BSDF's (block k + 1: the camera's comes first)
    // and against the camera's, whose Sobol points they must not repeat.
    let light = flat(&light_stream(42, 0, pixels, dims - 1));
    let (light_len, vertices) = (light.len(), dims as usize - 1);
    let bsdf: Vec<f64> = a
        .chunks_exact(per_pixel * 4)
        .flat_map(|p| p[4..].iter().copied())
        .take(light_len)
        .collect();
    let camera: Vec<f64> = a
        .chunks_exact(per_pixel * 4)
        .flat_map(|p| p[..4].iter().copied())
        .collect();
    let first_light: Vec<f64> = light
        .chunks_exact(vertices * 4)
        .flat_map(|p| p[..4].iter().copied())
        .collect();
    let limit = 5.0 / (a.len() as f64).sqrt(); // five standard errors of r under independence
    let light_limit = 5.0 / (light_len as f64).sqrt();
    let camera_limit = 5.0 / (camera.len() as f64).sqrt();
    for (what, r, limit) in [
        (
            "a vertex's light and BSDF numbers",
            correlation(&light, &bsdf),
            light_limit,
        ),
        (
            "the first light and the camera",
            correlation(&first_light, &camera),
            camera_limit,
        ),
    ] {
        assert!(
            r.abs() < limit,
            "{what}: correlation {r:.5}, limit {limit:.5}"
        );
    }
    for (what, r) in [
        ("neighbouring pixels", correlation(&a, &b)),
        ("the two halves", correlation(&a, &other_half)),
        ("neighbouring seeds", correlation(&a, &next_seed)),
        ("consecutive dimensions", correlation(a0, a1)),
        (
            "the same dimension of consecutive blocks",
            correlation(b0, b1),
        ),
    ] {
        assert!(
            r.abs() < limit,
            "{what}: correlation {r:.5}, limit {limit:.5}"
        );
    }
    assert_ne!(a, next_seed, "another seed gave the same stream");
}

/// The Bratley-Fox recurrence for the direction numbers of a Sobol dimension with primitive
/// polynomial degree `s`, coefficients `a` and initial numbers `m` (Joe and Kuo's notation),
/// as 32-bit columns of the generator matrix.
fn sobol_columns(s: usize, a: u32, m: &[u32]) -> [u32; 32] {
    let mut mm: Vec<u64> = m.iter().map(|&v| v as u64).collect();
    for k in s..32 {
        let mut next = mm[k - s] ^ (mm[k - s] << s);
        for j in 1..s {
            if (a >> (s - 1 - j)) & 1 == 1 {
                next ^= mm[k - j] << j;
            }
        }
        mm.push(next);
    }
    std::array::from_fn(|k| ((mm[k] << (31 - k)) & 0xffff_ffff) as u32)
}

#[test]
fn sobol_points_follow_the_joe_kuo_direction_numbers() {
    let columns = [
        std::array::from_fn::<u32, 32, _>(|k| 1u32 << (31 - k)), // van der Corput
        sobol_columns(1, 0, &[1]),
        sobol_columns(2, 1, &[1, 3]),
        sobol_columns(3, 1, &[1, 3, 1]),
    ];
    let mut rng = SmallRng::seed_from_u64(5);
    let mut index: Vec<u32> = (0..32).map(|k| 1u32 << k).collect();
    index.extend((0..16u32).chain((0..1000).map(|_| rng.random::<u32>())));
    let device = common::device();
    let program = rng_probes(&device, 1);
    let input = common::buffer(&device, &index);
    let out = common::output::<Uint4>(&device, index.len());
    let kernel = NamedArgs::new(&program, "probe_sobol", &device.queue)
        .buffer("index", &input)
        .buffer("out", &out)
        .build()
        .unwrap();
    common::run(&kernel, index.len());
    for (got, &i) in common::read(&out).iter().zip(&index) {
        for (d, column) in columns.iter().enumerate() {
            let want = (0..32)
                .filter(|k| (i >> k) & 1 == 1)
                .fold(0u32, |x, k| x ^ column[k]);
            assert_eq!(got[d], want, "Sobol point {i}, dimension {d}");
        }
    }
    // The familiar start of the sequence: 0, 1/2, then 1/4 and 3/4 in some order.
    assert_eq!(columns[2][..3], [0x8000_0000, 0xc000_0000, 0x6000_0000]);
}

/// `dims` blocks of samples `start..start + count` of one pixel, the light's with `light`.
fn samples(
    seed: u64,
    (pixel, light): (u32, bool),
    start: u32,
    count: usize,
    dims: u32,
) -> Vec<[f32; 4]> {
    samples_in_lanes(1, seed, (pixel, light), start, count, dims)
}

/// As [`samples`], drawn by the program of `lanes` lanes a work-item, whose lanes stand at
/// different dimensions while they draw (kernels/rng_probes.cl).
fn samples_in_lanes(
    lanes: u32,
    seed: u64,
    (pixel, light): (u32, bool),
    start: u32,
    count: usize,
    dims: u32,
) -> Vec<[f32; 4]> {
    let args = [
        ("pixel", pixel),
        ("sample_start", start),
        ("light", u32::from(light)),
    ];
    rng_probe("probe_rng_samples", lanes, seed, &args, count, dims)
}

#[test]
fn each_lane_draws_exactly_the_numbers_of_its_sample() {
    // The BSDF side past the quasi-random blocks into Philox's, and the light's first vertex
    // (quasi-random) and later ones; lanes restart at different steps, so a draw mixes lanes
    // in quasi-random and plain blocks.
    for (seed, pixel, start) in [(1u64, 0u32, 0u32), (0xdead_beef_0000_0007, 123_457, 4093)] {
        for (light, dims) in [(false, 6u32), (true, 4)] {
            let one = samples(seed, (pixel, light), start, 64, dims);
            for lanes in [4u32, 8, 16] {
                let wide = samples_in_lanes(lanes, seed, (pixel, light), start, 64, dims);
                for (i, (a, b)) in one.iter().zip(&wide).enumerate() {
                    let (a, b) = (a.map(f32::to_bits), b.map(f32::to_bits));
                    assert_eq!(
                        a,
                        b,
                        "{lanes} lanes, seed {seed:#x}, pixel {pixel}, light {light}: sample \
                         {}, block {}",
                        start as usize + i / dims as usize,
                        i % dims as usize
                    );
                }
            }
        }
    }
}

/// True if the points put exactly one point in each box of a 2^a x 2^(m - a) grid, for every
/// a (a (0, m, 2)-net in base 2), given 2^m points.
fn is_net(points: &[(f32, f32)], m: u32) -> bool {
    (0..=m).all(|a| {
        let mut seen = vec![false; 1 << m];
        points.iter().all(|&(x, y)| {
            let (i, j) = (
                (x * (1u32 << a) as f32) as usize,
                (y * (1u32 << (m - a)) as f32) as usize,
            );
            !std::mem::replace(&mut seen[(i << (m - a)) | j], true)
        })
    })
}

#[test]
fn each_half_of_a_pixels_samples_is_a_net_in_every_block() {
    // Sample s is point (s >> 3) * 4 + (s & 3) of half (s >> 2) & 1: the first 2^m points of
    // each half are among the first 2^(m + 1) samples.
    // Every quasi-random block: SOBOL_BLOCKS in kernels/rng.h, and the first vertex's light
    // block after them.
    let (m, bsdf_blocks) = (10u32, 3u32);
    let dims = bsdf_blocks + 1;
    for (seed, pixel) in [(1u64, 0u32), (0xdead_beef_0000_0007, 123_457)] {
        let bsdf = samples(seed, (pixel, false), 0, 2 << m, bsdf_blocks);
        let light = samples(seed, (pixel, true), 0, 2 << m, 1);
        let all: Vec<[f32; 4]> = bsdf
            .chunks_exact(bsdf_blocks as usize)
            .zip(&light)
            .flat_map(|(blocks, light)| blocks.iter().chain(std::iter::once(light)).copied())
            .collect();
        for half in 0..2u32 {
            let of_half: Vec<&[[f32; 4]]> = all
                .chunks_exact(dims as usize)
                .enumerate()
                .filter(|(s, _)| (*s as u32 >> 2) & 1 == half)
                .map(|(_, blocks)| blocks)
                .collect();
            assert_eq!(of_half.len(), 1 << m);
            for b in 0..dims as usize {
                // Every coordinate alone: one point in each interval of length 2^-m.
                for d in 0..4 {
                    let mut seen = vec![false; 1 << m];
                    for blocks in &of_half {
                        let u = blocks[b][d];
                        assert!((0.0..1.0).contains(&u), "{u} left [0, 1)");
                        let cell = (u * (1u32 << m) as f32) as usize;
                        assert!(
                            !std::mem::replace(&mut seen[cell], true),
                            "seed {seed:x}, pixel {pixel}, half {half}, block {b}, dimension {d}: two points in one interval"
                        );
                    }
                }
                // The first two coordinates together: a (0, m, 2)-net.
                let xy: Vec<(f32, f32)> = of_half.iter().map(|v| (v[b][0], v[b][1])).collect();
                assert!(
                    is_net(&xy, m),
                    "seed {seed:x}, pixel {pixel}, half {half}, block {b}: not a (0, {m}, 2)-net"
                );
            }
        }
        // The two halves are different sequences, not one sequence twice.
        assert_ne!(all[0], all[4 * dims as usize]);
    }
}
