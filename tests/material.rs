//! Material sampling on the device (kernels/material.h) against its distributions: Lambertian
//! directions are cosine-distributed (chi-square on cos^2 theta and phi, both uniform under
//! that law), mirror directions are exact reflections, and glass reflects with Schlick's Fresnel
//! probability (a binomial Z-test), refracts by Snell's law, and reflects totally past the
//! critical angle. Every weight is the colour (here 1). Under a bent shading normal, diffuse
//! directions follow the density `diffuse_pdf` states (chi-square), which light sampling uses.

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

/// diffuse_pdf in f64: the cosine density about the shading normal `facing`, plus that of the
/// direction mirrored into w across the geometric surface (normal `facing_g`).
fn diffuse_pdf_f64(w: DVec3, facing: DVec3, facing_g: DVec3) -> f64 {
    let side = w.dot(facing_g);
    if side <= 0.0 {
        return 0.0;
    }
    let mirrored = w - 2.0 * side * facing_g;
    (w.dot(facing).max(0.0) + mirrored.dot(facing).max(0.0)) / std::f64::consts::PI
}

/// Runs probe_diffuse on (wo, n, ns, w) records: the sampled wi and the device's diffuse_pdf(w).
fn sample_bent(records: &[[DVec3; 4]], u: &[[f32; 4]]) -> Vec<(DVec3, f64)> {
    let device = common::device();
    let program = common::probes(&device);
    let flat: Vec<f32> = records
        .iter()
        .flat_map(|r| r.map(|v| v.as_vec3().to_array()))
        .flatten()
        .collect();
    let u: Vec<Float4> = u.iter().map(|v| Float4::from(*v)).collect();
    let (rb, ub) = (common::buffer(&device, &flat), common::buffer(&device, &u));
    let out = common::output::<f32>(&device, records.len() * 4);
    let kernel = ocl::Kernel::builder()
        .program(&program)
        .name("probe_diffuse")
        .queue(device.queue.clone())
        .arg(&rb)
        .arg(&ub)
        .arg(&out)
        .build()
        .unwrap();
    common::run(&kernel, records.len());
    common::read(&out)
        .chunks_exact(4)
        .map(|c| {
            (
                DVec3::new(c[0].into(), c[1].into(), c[2].into()),
                c[3].into(),
            )
        })
        .collect()
}

/// Under a bent shading normal (bump maps, smooth meshes), the diffuse branch's directions
/// follow the density diffuse_pdf states, which light sampling's MIS weights rely on (nee.h):
/// a chi-square test of 200000 directions in 256 bins of equal solid angle over the geometric
/// hemisphere, against the f64 density integrated over each bin; and the device's diffuse_pdf
/// equals the f64 one at random directions, the lower hemisphere included.
#[test]
fn bent_normal_diffuse_directions_follow_diffuse_pdf() {
    let mut rng = SmallRng::seed_from_u64(22);
    let n_samples = 200_000;
    let n = DVec3::new(0.2, -0.4, 0.9).normalize();
    let (t, b) = n.any_orthonormal_pair();
    for (tilt, from_front) in [(50f64, true), (50.0, false), (80.0, true), (0.0, true)] {
        let ns = (n * tilt.to_radians().cos() + t * tilt.to_radians().sin()).normalize();
        let records: Vec<[DVec3; 4]> = (0..n_samples)
            .map(|_| {
                let wo = common::random_unit(&mut rng);
                let wo = if (wo.dot(n) >= 0.0) == from_front {
                    wo
                } else {
                    -wo
                };
                [wo, n, ns, common::random_unit(&mut rng)]
            })
            .collect();
        let out = sample_bent(&records, &uniforms(&mut rng, n_samples));
        let (facing_g, facing) = if from_front { (n, ns) } else { (-n, -ns) };
        // Bins: z = cos about facing_g in 16 equal steps, phi in 16 (equal solid angle).
        let side = 16usize;
        let frame_b = if from_front { b } else { -b };
        let bin = |w: DVec3| {
            let z = w.dot(facing_g).clamp(0.0, 1.0 - 1e-12);
            let phi = w
                .dot(frame_b)
                .atan2(w.dot(t))
                .rem_euclid(std::f64::consts::TAU);
            let j = ((phi / std::f64::consts::TAU) * side as f64).min(side as f64 - 1.0);
            (z * side as f64) as usize * side + j as usize
        };
        let mut counts = vec![0u64; side * side];
        for (record, (wi, pdf)) in records.iter().zip(&out) {
            assert!(
                wi.dot(facing_g) >= -1e-6,
                "tilt {tilt}: below the surface: {wi}"
            );
            counts[bin(*wi)] += 1;
            let expected = diffuse_pdf_f64(record[3], facing, facing_g);
            assert!(
                (pdf - expected).abs() <= 1e-5 * (1.0 + expected),
                "tilt {tilt}: diffuse_pdf({}) = {pdf}, f64 {expected}",
                record[3]
            );
        }
        // Each bin's probability by midpoint quadrature of the f64 density (32 x 32 points).
        let q = 32usize;
        let cell = std::f64::consts::TAU / (side * side) as f64 / (q * q) as f64;
        let mut chi = 0.0;
        for (k, &count) in counts.iter().enumerate() {
            let (i, j) = (k / side, k % side);
            let mut p = 0.0;
            for a in 0..q {
                for c in 0..q {
                    let z = (i as f64 + (a as f64 + 0.5) / q as f64) / side as f64;
                    let phi = (j as f64 + (c as f64 + 0.5) / q as f64) / side as f64
                        * std::f64::consts::TAU;
                    let r = (1.0 - z * z).sqrt();
                    let w = facing_g * z + t * (r * phi.cos()) + frame_b * (r * phi.sin());
                    p += diffuse_pdf_f64(w, facing, facing_g) * cell;
                }
            }
            let expected = p * n_samples as f64;
            if expected > 0.0 {
                chi += (count as f64 - expected).powi(2) / expected;
            } else {
                assert_eq!(count, 0, "tilt {tilt}: directions where the density is 0");
            }
        }
        // chi-square, 255 dof, upper 1e-6 quantile (Wilson-Hilferty) ~ 367.
        assert!(
            chi < 367.0,
            "tilt {tilt}, front {from_front}: chi-square {chi:.1}"
        );
    }
}
