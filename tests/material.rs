//! Material sampling on the device (kernels/material.h) against its distributions: Lambertian
//! directions are cosine-distributed (chi-square on cos^2 theta and phi, both uniform under
//! that law), mirror directions are exact reflections, and glass reflects with Schlick's Fresnel
//! probability (a binomial Z-test), refracts by Snell's law, and reflects totally past the
//! critical angle. Every weight is the colour (here 1).

mod common;

use clpt::device::layout::{MATERIAL_DIFFUSE, MATERIAL_REFRACTIVE, MATERIAL_SPECULAR};
use glam::DVec3;
use ocl::prm::Float4;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};

/// Runs probe_material on (type, wo, n, u) records; returns (wi, weight) per record.
fn sample(kinds: &[u32], wo_n: &[(DVec3, DVec3)], u: &[[f32; 4]]) -> Vec<(DVec3, DVec3)> {
    let device = common::device();
    let program = common::probes(&device);
    let flat: Vec<f32> = wo_n
        .iter()
        .flat_map(|(wo, n)| [wo.as_vec3().to_array(), n.as_vec3().to_array()])
        .flatten()
        .collect();
    let u: Vec<Float4> = u.iter().map(|v| Float4::from(*v)).collect();
    let (kb, wb, ub) = (
        common::buffer(&device, kinds),
        common::buffer(&device, &flat),
        common::buffer(&device, &u),
    );
    let out = common::output::<f32>(&device, kinds.len() * 6);
    let kernel = ocl::Kernel::builder()
        .program(&program)
        .name("probe_material")
        .queue(device.queue.clone())
        .arg(&kb)
        .arg(&wb)
        .arg(&ub)
        .arg(&out)
        .build()
        .unwrap();
    common::run(&kernel, kinds.len());
    common::read(&out)
        .chunks_exact(6)
        .map(|c| {
            let v = |i: usize| DVec3::new(c[i] as f64, c[i + 1] as f64, c[i + 2] as f64);
            (v(0), v(3))
        })
        .collect()
}

fn uniforms(rng: &mut SmallRng, n: usize) -> Vec<[f32; 4]> {
    (0..n)
        .map(|_| [rng.random(), rng.random(), rng.random(), rng.random()])
        .collect()
}

#[test]
fn lambertian_directions_are_cosine_distributed() {
    let mut rng = SmallRng::seed_from_u64(21);
    let n_samples = 200_000;
    // A few fixed normals (axes, their negatives, a generic one), wo on either side.
    let normals = [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::new(0.3, -0.5, 0.81).normalize(),
    ];
    for n in normals {
        let wo_n: Vec<(DVec3, DVec3)> = (0..n_samples)
            .map(|i| {
                let wo = common::random_unit(&mut rng);
                // Half the paths arrive from behind the surface.
                let wo = if (wo.dot(n) >= 0.0) == (i % 2 == 0) {
                    wo
                } else {
                    -wo
                };
                (wo, n)
            })
            .collect();
        let kinds = vec![MATERIAL_DIFFUSE; n_samples];
        let out = sample(&kinds, &wo_n, &uniforms(&mut rng, n_samples));
        let (t, b) = n.any_orthonormal_pair();
        let side = 16;
        let mut counts = vec![0u64; side * side];
        for ((wo, _), (wi, weight)) in wo_n.iter().zip(&out) {
            assert!((weight - DVec3::ONE).length() < 1e-6, "weight {weight}");
            assert!((wi.length() - 1.0).abs() < 1e-5, "wi not unit: {wi}");
            let facing = if wo.dot(n) >= 0.0 { n } else { -n };
            let cos = wi.dot(facing);
            assert!(
                cos >= -1e-6,
                "diffuse direction on the wrong side: cos {cos}"
            );
            // In the frame of `facing`; flip b with it to keep the frame right-handed.
            let (tx, by) = if facing == n { (t, b) } else { (t, -b) };
            let phi = wi
                .dot(by)
                .atan2(wi.dot(tx))
                .rem_euclid(std::f64::consts::TAU);
            let i = ((cos * cos).clamp(0.0, 1.0 - 1e-12) * side as f64) as usize;
            let j = ((phi / std::f64::consts::TAU) * side as f64).min(side as f64 - 1.0) as usize;
            counts[i * side + j] += 1;
        }
        let expected = n_samples as f64 / counts.len() as f64;
        let chi: f64 = counts
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum();
        // chi-square, 255 dof, upper 1e-6 quantile (Wilson-Hilferty) ~ 367.
        assert!(chi < 367.0, "normal {n}: chi-square {chi:.1}");
    }
}

#[test]
fn mirror_reflects_exactly() {
    let mut rng = SmallRng::seed_from_u64(22);
    let count = 10_000;
    let wo_n: Vec<(DVec3, DVec3)> = (0..count)
        .map(|_| (common::random_unit(&mut rng), common::random_unit(&mut rng)))
        .collect();
    let out = sample(
        &vec![MATERIAL_SPECULAR; count],
        &wo_n,
        &uniforms(&mut rng, count),
    );
    for ((wo, n), (wi, weight)) in wo_n.iter().zip(&out) {
        let want = 2.0 * wo.dot(*n) * *n - *wo;
        assert!((wi - want).length() < 1e-5, "{wi} vs {want}");
        assert!((weight - DVec3::ONE).length() < 1e-6);
    }
}

fn schlick(cos: f64) -> f64 {
    let r0 = (0.5f64 / 2.5).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos).powi(5)
}

#[test]
fn glass_follows_fresnel_and_snell() {
    let mut rng = SmallRng::seed_from_u64(23);
    let n = DVec3::new(0.2, 0.9, -0.1).normalize();
    let (t, _) = n.any_orthonormal_pair();
    let per_angle = 40_000;
    // Entering (wo on the normal's side) and leaving (inside the glass), at several angles.
    for &(entering, cos_i) in &[
        (true, 1.0),
        (true, 0.7),
        (true, 0.2),
        (true, 0.02),
        (false, 0.95),
        (false, 0.8),
        (false, 0.7),
        (false, 0.6),
    ] {
        let sin_i = (1.0f64 - cos_i * cos_i).max(0.0).sqrt();
        let wo = if entering {
            n * cos_i + t * sin_i
        } else {
            -n * cos_i + t * sin_i
        };
        let wo_n = vec![(wo, n); per_angle];
        let out = sample(
            &vec![MATERIAL_REFRACTIVE; per_angle],
            &wo_n,
            &uniforms(&mut rng, per_angle),
        );
        let eta: f64 = if entering { 1.0 / 1.5 } else { 1.5 };
        let sin_t = eta * sin_i;
        let facing = if entering { n } else { -n };
        let mirror = 2.0 * wo.dot(facing) * facing - wo;
        let mut reflected = 0usize;
        for (wi, weight) in &out {
            assert!((weight - DVec3::ONE).length() < 1e-6);
            if (wi - mirror).length() < 1e-4 {
                reflected += 1;
                continue;
            }
            assert!(
                sin_t < 1.0,
                "refraction past the critical angle (cos_i {cos_i})"
            );
            // Snell: the transmitted direction is on the far side with sin_t = eta sin_i.
            let cos_t = -wi.dot(facing);
            assert!(cos_t > 0.0, "transmitted ray on the incident side");
            let got_sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            assert!(
                (got_sin_t - sin_t).abs() < 1e-4,
                "sin_t {got_sin_t} vs {sin_t}"
            );
        }
        let p = if sin_t >= 1.0 {
            1.0
        } else {
            let cos_t = (1.0 - sin_t * sin_t).sqrt();
            schlick(if entering { cos_i } else { cos_t })
        };
        let frac = reflected as f64 / per_angle as f64;
        let se = (p * (1.0 - p) / per_angle as f64).sqrt().max(1e-9);
        if p == 1.0 {
            assert_eq!(
                reflected, per_angle,
                "total internal reflection expected at cos_i {cos_i}"
            );
        } else {
            let z = (frac - p) / se;
            assert!(
                z.abs() < 5.0,
                "entering {entering}, cos_i {cos_i}: reflected {frac:.4}, Schlick {p:.4}, z {z:.2}"
            );
        }
    }
}
