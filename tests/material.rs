//! The materials' sampling trios on the device (kernels/material.h: `bsdf_sample`, `bsdf_eval`,
//! `bsdf_pdf`, through probes.cl's `probe_bsdf`).
//!
//! - Lambertian directions follow `bsdf_pdf` (the chi-square harness of tests/common/chi2.rs,
//!   500000 directions in 40 × 40 bins of equal solid angle about the facing normal, four
//!   normals, paths arriving from either side), and `bsdf_pdf` is cos θ / π in f64.
//! - Under a bent shading normal (bump maps, smooth meshes) diffuse directions follow `bsdf_pdf`
//!   too, mirrored directions included (the harness), and `bsdf_pdf` equals its f64 form at
//!   random directions, the lower hemisphere included: light sampling's MIS weights rely on it.
//! - The trio agrees with itself: at every sampled direction the weight is
//!   `bsdf_eval / bsdf_pdf` and the reported pdf is `bsdf_pdf`; `bsdf_eval` is the colour times
//!   `bsdf_pdf` everywhere; mirror and glass are delta lobes (`bsdf_eval` and `bsdf_pdf` 0).
//! - The delta lobes, apart: mirror directions are exact reflections; glass reflects with
//!   Schlick's Fresnel probability (a binomial Z-test) and reports it as the lobe's pdf, refracts
//!   by Snell's law, and reflects totally past the critical angle. Every weight is the colour.
//! - The programs of 8 and 16 lanes a work-item (kernels/lanes.h) give the scalar program's
//!   records, lanes of all three materials mixed, to within a few roundings.

mod common;

use common::Probes;

use clpt::contract::{MATERIAL_DIFFUSE, MATERIAL_REFRACTIVE, MATERIAL_SPECULAR};
use clpt::device::kernel::NamedArgs;
use common::chi2;
use glam::DVec3;
use ocl::prm::Float4;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::f64::consts::PI;

/// The colour every test gives its materials: the weight must be exactly it.
const COLOR: DVec3 = DVec3::new(0.7, 0.3, 0.9);

/// One probe_bsdf input: the path's wo, the geometric and shading normals, and a direction w at
/// which bsdf_eval and bsdf_pdf are also evaluated.
#[derive(Clone, Copy)]
struct Query {
    wo: DVec3,
    n: DVec3,
    ns: DVec3,
    w: DVec3,
}

/// One probe_bsdf output (probes.cl).
#[derive(Clone, Copy, Debug)]
struct Record {
    wi: DVec3,
    weight: DVec3,
    pdf: f64,
    is_delta: bool,
    eval_wi: DVec3,
    pdf_wi: f64,
    eval_w: DVec3,
    pdf_w: f64,
}

impl Probes {
    /// Runs probe_bsdf on material `kind` for each query with its four uniforms.
    fn bsdf(&self, kind: u32, queries: &[Query], u: &[[f32; 4]]) -> Vec<Record> {
        self.bsdf_kinds(&vec![kind; queries.len()], queries, u)
    }

    /// Runs probe_bsdf on material `kinds[i]` for query i with its four uniforms (a multiple of
    /// the program's lanes).
    fn bsdf_kinds(&self, kinds: &[u32], queries: &[Query], u: &[[f32; 4]]) -> Vec<Record> {
        assert_eq!(queries.len(), u.len());
        assert_eq!(queries.len() % self.lanes as usize, 0);
        let flat: Vec<f32> = queries
            .iter()
            .flat_map(|q| [q.wo, q.n, q.ns, COLOR, q.w].map(|v| v.as_vec3().to_array()))
            .flatten()
            .collect();
        let u: Vec<Float4> = u.iter().map(|v| Float4::from(*v)).collect();
        let (kb, fb, ub) = (
            common::buffer(&self.device, kinds),
            common::buffer(&self.device, &flat),
            common::buffer(&self.device, &u),
        );
        let out = common::output::<f32>(&self.device, queries.len() * 16);
        let kernel = NamedArgs::new(&self.program, "probe_bsdf", &self.device.queue)
            .buffer("type", &kb)
            .buffer("frames", &fb)
            .buffer("u", &ub)
            .buffer("out", &out)
            .build()
            .unwrap();
        common::run(&kernel, queries.len() / self.lanes as usize);
        common::read(&out)
            .chunks_exact(16)
            .map(|c| {
                let v = |i: usize| DVec3::new(c[i].into(), c[i + 1].into(), c[i + 2].into());
                Record {
                    wi: v(0),
                    weight: v(3),
                    pdf: c[6].into(),
                    is_delta: c[7] == 1.0,
                    eval_wi: v(8),
                    pdf_wi: c[11].into(),
                    eval_w: v(12),
                    pdf_w: c[15].into(),
                }
            })
            .collect()
    }

    /// The device's bsdf_pdf from wo at each of `ws`.
    fn pdf_at(&self, kind: u32, wo: DVec3, n: DVec3, ns: DVec3, ws: &[DVec3]) -> Vec<f64> {
        let queries: Vec<Query> = ws.iter().map(|&w| Query { wo, n, ns, w }).collect();
        self.bsdf(kind, &queries, &vec![[0.5; 4]; ws.len()])
            .iter()
            .map(|r| r.pdf_w)
            .collect()
    }
}

fn uniforms(rng: &mut SmallRng, n: usize) -> Vec<[f32; 4]> {
    (0..n)
        .map(|_| [rng.random(), rng.random(), rng.random(), rng.random()])
        .collect()
}

/// The f64 form of bsdf_pdf's diffuse branch (material.h's diffuse_pdf): the cosine density
/// about the shading normal `facing`, plus that of the direction mirrored into w across the
/// geometric surface (normal `facing_g`); both turned to the side the path arrived on.
fn diffuse_pdf_f64(w: DVec3, facing: DVec3, facing_g: DVec3) -> f64 {
    let side = w.dot(facing_g);
    if side <= 0.0 {
        return 0.0;
    }
    let mirrored = w - 2.0 * side * facing_g;
    (w.dot(facing).max(0.0) + mirrored.dot(facing).max(0.0)) / PI
}

fn close3(a: DVec3, b: DVec3, rel: f64) -> bool {
    (a - b).abs().max_element() <= rel * a.abs().max(b.abs()).max_element()
}

/// The chi-square harness on `samples` diffuse directions from (wo, n, ns): the sphere about
/// the facing geometric normal, the device's bsdf_pdf integrated over each bin.
fn diffuse_chi2(
    probes: &Probes,
    name: &str,
    wo: DVec3,
    n: DVec3,
    ns: DVec3,
    rng: &mut SmallRng,
    samples: usize,
) -> chi2::Outcome {
    let query = Query { wo, n, ns, w: n };
    let out = probes.bsdf(
        MATERIAL_DIFFUSE,
        &vec![query; samples],
        &uniforms(rng, samples),
    );
    for r in &out {
        assert!(
            r.weight == COLOR.as_vec3().as_dvec3(),
            "{name}: weight {}",
            r.weight
        );
        assert!(
            !r.is_delta && (r.wi.length() - 1.0).abs() < 1e-5,
            "{name}: {r:?}"
        );
    }
    let facing_g = if wo.dot(n) >= 0.0 { n } else { -n };
    let grid = chi2::Grid::sphere(facing_g);
    let sub = 8;
    let (nodes, solid_angles) = grid.nodes(sub);
    let density = probes.pdf_at(MATERIAL_DIFFUSE, wo, n, ns, &nodes);
    let masses = chi2::bin_masses(&grid, &nodes, &solid_angles, &density);
    let wis: Vec<DVec3> = out.iter().map(|r| r.wi).collect();
    chi2::test(name, &grid, samples, &wis, &masses)
}

/// Lambertian directions (shading normal = geometric normal) follow bsdf_pdf, which is
/// cos θ / π about the normal turned to the path: four normals (axes, their negatives, a
/// generic one), the path arriving from either side. 8 chi-square tests.
#[test]
fn lambertian_directions_follow_bsdf_pdf() {
    let probes = Probes::new();
    let mut rng = SmallRng::seed_from_u64(21);
    let normals = [
        DVec3::Z,
        -DVec3::Z,
        DVec3::X,
        DVec3::new(0.3, -0.5, 0.81).normalize(),
    ];
    for n in normals {
        let (t, _) = n.any_orthonormal_pair();
        for front in [true, false] {
            let facing = if front { n } else { -n };
            let wo = (facing * 0.6 + t * 0.8).normalize();
            let name = format!(
                "lambertian n {n:.2} from the {}",
                if front { "front" } else { "back" }
            );
            diffuse_chi2(&probes, &name, wo, n, n, &mut rng, 500_000).assert_passes();
            // bsdf_pdf is cos θ / π about the facing normal, 0 below it.
            let ws: Vec<DVec3> = (0..2000).map(|_| common::random_unit(&mut rng)).collect();
            for (w, pdf) in ws
                .iter()
                .zip(probes.pdf_at(MATERIAL_DIFFUSE, wo, n, n, &ws))
            {
                let want = w.dot(facing).max(0.0) / PI;
                assert!(
                    (pdf - want).abs() <= 1e-6 * (1.0 + want),
                    "bsdf_pdf({w}) = {pdf}, cos / pi = {want}"
                );
            }
        }
    }
}

/// Under a bent shading normal (bump maps, smooth meshes), the diffuse branch's directions, the
/// ones it mirrors back above the surface included, follow bsdf_pdf, which light sampling's MIS
/// weights rely on (nee.h); and the device's bsdf_pdf equals the f64 density at random
/// directions, the lower hemisphere included. 4 chi-square tests.
#[test]
fn bent_normal_diffuse_directions_follow_bsdf_pdf() {
    let probes = Probes::new();
    let mut rng = SmallRng::seed_from_u64(22);
    let n = DVec3::new(0.2, -0.4, 0.9).normalize();
    let (t, _) = n.any_orthonormal_pair();
    for (tilt, front) in [(50f64, true), (50.0, false), (80.0, true), (0.0, true)] {
        let ns = (n * tilt.to_radians().cos() + t * tilt.to_radians().sin()).normalize();
        let (facing_g, facing) = if front { (n, ns) } else { (-n, -ns) };
        let wo = (facing_g * 0.3 - t * 0.9).normalize();
        let name = format!(
            "diffuse, shading normal tilted {tilt}°, from the {}",
            if front { "front" } else { "back" }
        );
        diffuse_chi2(&probes, &name, wo, n, ns, &mut rng, 500_000).assert_passes();
        let ws: Vec<DVec3> = (0..5000).map(|_| common::random_unit(&mut rng)).collect();
        for (w, pdf) in ws
            .iter()
            .zip(probes.pdf_at(MATERIAL_DIFFUSE, wo, n, ns, &ws))
        {
            let want = diffuse_pdf_f64(*w, facing, facing_g);
            assert!(
                (pdf - want).abs() <= 1e-5 * (1.0 + want),
                "tilt {tilt}: bsdf_pdf({w}) = {pdf}, f64 {want}"
            );
        }
    }
}

/// The trio agrees with itself. Diffuse, shading normals bent or not, paths from either side:
/// at each sampled direction the weight is bsdf_eval / bsdf_pdf there and bsdf_sample's pdf is
/// bsdf_pdf; at random directions bsdf_eval is the colour times bsdf_pdf. Mirror and glass:
/// delta lobes, bsdf_eval and bsdf_pdf 0 at every direction, the sampled one included.
#[test]
fn bsdf_eval_pdf_and_the_sampled_weight_agree() {
    let probes = Probes::new();
    let mut rng = SmallRng::seed_from_u64(24);
    let count = 100_000;
    let queries: Vec<Query> = (0..count)
        .map(|i| {
            let n = common::random_unit(&mut rng);
            let (t, _) = n.any_orthonormal_pair();
            let tilt = [0.0f64, 30.0, 70.0][i % 3].to_radians();
            Query {
                wo: common::random_unit(&mut rng),
                n,
                ns: n * tilt.cos() + t * tilt.sin(),
                w: common::random_unit(&mut rng),
            }
        })
        .collect();
    let u = uniforms(&mut rng, count);
    let out = probes.bsdf(MATERIAL_DIFFUSE, &queries, &u);
    let mut zero_pdf = 0;
    for (q, r) in queries.iter().zip(&out) {
        assert!(!r.is_delta);
        assert!(close3(r.eval_w, COLOR * r.pdf_w, 1e-6), "{r:?}");
        assert_eq!(r.pdf, r.pdf_wi, "bsdf_sample's pdf is bsdf_pdf: {r:?}");
        if r.pdf_wi > 0.0 {
            assert!(close3(r.weight, r.eval_wi / r.pdf_wi, 1e-5), "{r:?}");
        } else {
            zero_pdf += 1; // a direction exactly on the horizon
        }
        let facing_g = if q.wo.dot(q.n) >= 0.0 { q.n } else { -q.n };
        assert!(r.wi.dot(facing_g) >= -1e-6, "below the surface: {r:?}");
    }
    assert!(
        zero_pdf <= count / 10_000,
        "{zero_pdf} samples of density 0"
    );
    for kind in [MATERIAL_SPECULAR, MATERIAL_REFRACTIVE] {
        for r in probes.bsdf(kind, &queries, &u) {
            assert!(r.is_delta, "{r:?}");
            assert!(r.eval_w == DVec3::ZERO && r.pdf_w == 0.0, "{r:?}");
            assert!(r.eval_wi == DVec3::ZERO && r.pdf_wi == 0.0, "{r:?}");
            assert!(r.pdf > 0.0 && r.pdf <= 1.0, "the lobe's probability: {r:?}");
        }
    }
}

#[test]
fn mirror_reflects_exactly() {
    let probes = Probes::new();
    let mut rng = SmallRng::seed_from_u64(22);
    let count = 10_000;
    let queries: Vec<Query> = (0..count)
        .map(|_| {
            let n = common::random_unit(&mut rng);
            Query {
                wo: common::random_unit(&mut rng),
                n,
                ns: n,
                w: n,
            }
        })
        .collect();
    let out = probes.bsdf(MATERIAL_SPECULAR, &queries, &uniforms(&mut rng, count));
    for (q, r) in queries.iter().zip(&out) {
        let want = 2.0 * q.wo.dot(q.n) * q.n - q.wo;
        assert!((r.wi - want).length() < 1e-5, "{} vs {want}", r.wi);
        assert!(r.weight == COLOR.as_vec3().as_dvec3() && r.pdf == 1.0 && r.is_delta);
    }
}

fn schlick(cos: f64) -> f64 {
    let r0 = (0.5f64 / 2.5).powi(2);
    r0 + (1.0 - r0) * (1.0 - cos).powi(5)
}

#[test]
fn glass_follows_fresnel_and_snell() {
    let probes = Probes::new();
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
        let query = Query { wo, n, ns: n, w: n };
        let out = probes.bsdf(
            MATERIAL_REFRACTIVE,
            &vec![query; per_angle],
            &uniforms(&mut rng, per_angle),
        );
        let eta: f64 = if entering { 1.0 / 1.5 } else { 1.5 };
        let sin_t = eta * sin_i;
        let facing = if entering { n } else { -n };
        let mirror = 2.0 * wo.dot(facing) * facing - wo;
        let p = if sin_t >= 1.0 {
            1.0
        } else {
            let cos_t = (1.0 - sin_t * sin_t).sqrt();
            schlick(if entering { cos_i } else { cos_t })
        };
        let mut reflected = 0usize;
        for r in &out {
            assert!(r.weight == COLOR.as_vec3().as_dvec3() && r.is_delta);
            if (r.wi - mirror).length() < 1e-4 {
                reflected += 1;
                assert!(
                    (r.pdf - p).abs() < 1e-5,
                    "reflection's pdf {} vs {p}",
                    r.pdf
                );
                continue;
            }
            assert!(
                sin_t < 1.0,
                "refraction past the critical angle (cos_i {cos_i})"
            );
            assert!(
                (r.pdf - (1.0 - p)).abs() < 1e-5,
                "transmission's pdf {} vs {}",
                r.pdf,
                1.0 - p
            );
            // Snell: the transmitted direction is on the far side with sin_t = eta sin_i.
            let cos_t = -r.wi.dot(facing);
            assert!(cos_t > 0.0, "transmitted ray on the incident side");
            let got_sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            assert!(
                (got_sin_t - sin_t).abs() < 1e-4,
                "sin_t {got_sin_t} vs {sin_t}"
            );
        }
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

#[test]
fn wide_programs_sample_as_the_scalar_program() {
    let mut rng = SmallRng::seed_from_u64(77);
    let count = 4096;
    let kinds: Vec<u32> = (0..count)
        .map(|i| [MATERIAL_DIFFUSE, MATERIAL_SPECULAR, MATERIAL_REFRACTIVE][(i * 7 / 3) % 3])
        .collect();
    let queries: Vec<Query> = (0..count)
        .map(|i| {
            let n = common::random_unit(&mut rng);
            // Every other query under a bent shading normal.
            let ns = if i % 2 == 0 {
                n
            } else {
                (n + 0.4 * common::random_unit(&mut rng)).normalize()
            };
            Query {
                wo: common::random_unit(&mut rng),
                n,
                ns,
                w: common::random_unit(&mut rng),
            }
        })
        .collect();
    let u = uniforms(&mut rng, count);
    let scalar = Probes::new().bsdf_kinds(&kinds, &queries, &u);
    for lanes in [8, 16] {
        let wide = Probes::in_lanes(lanes).bsdf_kinds(&kinds, &queries, &u);
        for (i, (a, b)) in scalar.iter().zip(&wide).enumerate() {
            let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * (1.0 + x.abs().max(y.abs()));
            let close3 = |x: DVec3, y: DVec3| (0..3).all(|k| close(x[k], y[k]));
            assert!(
                a.is_delta == b.is_delta
                    && close3(a.wi, b.wi)
                    && close3(a.weight, b.weight)
                    && close(a.pdf, b.pdf)
                    && close3(a.eval_wi, b.eval_wi)
                    && close(a.pdf_wi, b.pdf_wi)
                    && close3(a.eval_w, b.eval_w)
                    && close(a.pdf_w, b.pdf_w),
                "{lanes} lanes, query {i} (material {}): {b:?}, the scalar program {a:?}",
                kinds[i]
            );
        }
    }
}
