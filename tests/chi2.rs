//! The chi-square harness (tests/common/chi2.rs) on itself, and the emitters' sampling trios on
//! the device (kernels/nee.h: `light_sample`, `light_pdf`, through probes.cl's
//! `probe_light_sample` and `probe_light_pdf`).
//!
//! - The harness: its p-values against closed forms and tabled quantiles; an exact sampler
//!   passes, and a density twice too high, a cone 3% too wide or a density 10% lopsided fail.
//! - Sphere lights: cone sampling from distances of 1.0001 to 10000 radii follows `light_pdf`
//!   (500000 directions on a cap just past the cone, 20 × 40 bins of equal solid angle).
//! - Squares (a host-placed rotated square and a skewed parallelogram, as clipping and shears
//!   leave them) and triangles (the host's, of a scaled and rotated mesh, seen from both sides):
//!   uniform area sampling follows `light_pdf` from above, from close by at grazing angles, and
//!   from far away.
//! - A room's emitting wall, sampled by solid angle (Ureña et al. 2013): from the floor, from a
//!   wall beside it, from close below it near 2π sr, from a point where it subtends 0.02 sr,
//!   and, past the solid angles nee.h samples so, by area; near the origin and 1e5 from it.
//!   The quadrature of the expected bin masses is graded towards the point, so that cells close
//!   to it stay small.
//! - Every sample: its point lies on the light, its direction points at it, and its pdf is
//!   `light_pdf` there; `light_pdf` equals its f64 form; nothing is sampled from inside a sphere
//!   or behind a square.

mod common;

use common::Probes;

use clpt::contract::{Light, OBJECT_MESH, OBJECT_PLANE, OBJECT_SPHERE};
use clpt::device::kernel::NamedArgs;
use common::chi2;
use glam::DVec3;
use rand::rngs::SmallRng;
use rand::{RngExt, SeedableRng};
use std::f64::consts::TAU;

#[test]
fn p_values_match_closed_forms_and_tables() {
    // Even degrees of freedom k = 2m: Q(m, y) = e^-y sum_{i < m} y^i / i!.
    for m in [1usize, 2, 5, 50, 400, 800] {
        for scale in [0.5, 0.9, 1.0, 1.1, 1.3, 2.0] {
            let x = 2.0 * m as f64 * scale;
            let y = x / 2.0;
            let exact: f64 = (0..m)
                .map(|i| (-y + i as f64 * y.ln() - chi2::ln_gamma(i as f64 + 1.0)).exp())
                .sum();
            let got = chi2::chi2_sf(x, 2.0 * m as f64);
            assert!(
                (got - exact).abs() <= 1e-12 + 1e-9 * exact,
                "dof {}, x {x}: {got} vs {exact}",
                2 * m
            );
        }
    }
    // Tabled upper quantiles (odd degrees of freedom included).
    for (dof, x, p) in [
        (1.0, 3.841_458_820_694_124, 0.05),
        (1.0, 6.634_896_601_021_214, 0.01),
        (3.0, 11.344_866_730_144_373, 0.01),
        (10.0, 23.209_251_158_954_356, 0.01),
        (5.0, 15.086_272_469_388_987, 0.01),
    ] {
        let got = chi2::chi2_sf(x, dof);
        assert!((got - p).abs() < 1e-9, "dof {dof}, x {x}: {got} vs {p}");
    }
    // Wilson-Hilferty is close for many degrees of freedom.
    for x in [700.0, 800.0, 900.0, 950.0] {
        let (exact, approx) = (
            chi2::chi2_sf(x, 799.0),
            chi2::chi2_sf_wilson_hilferty(x, 799.0),
        );
        assert!(
            (exact - approx).abs() < 0.02 * exact + 1e-6,
            "{exact} vs {approx}"
        );
    }
}

/// Uniform directions in the cone 1 - cos θ <= v0 about z, sampled in f64 on the host, against
/// a density: the right one passes; twice it, that of a cone 3% wider in angle, and one 10%
/// lopsided in azimuth fail. 1 chi-square test (the passing one).
#[test]
fn the_harness_passes_an_exact_sampler_and_fails_wrong_densities() {
    let mut rng = SmallRng::seed_from_u64(31);
    let axis = DVec3::new(0.3, 0.4, -0.5).normalize();
    let (x, y) = axis.any_orthonormal_pair();
    let v0 = 0.2;
    let n = 500_000;
    let samples: Vec<DVec3> = (0..n)
        .map(|_| {
            let v = v0 * rng.random::<f64>();
            let phi = TAU * rng.random::<f64>();
            let s = (v * (2.0 - v)).sqrt();
            axis * (1.0 - v) + x * (s * phi.cos()) + y * (s * phi.sin())
        })
        .collect();
    let grid = chi2::Grid::cap(axis, v0);
    let sub = 8;
    let (nodes, solid_angles) = grid.nodes(sub);
    let cone = |v_max: f64, w: DVec3| {
        if 1.0 - w.dot(axis) <= v_max {
            1.0 / (TAU * v_max)
        } else {
            0.0
        }
    };
    let run = |name: &str, f: &dyn Fn(DVec3) -> f64| {
        let density: Vec<f64> = nodes.iter().map(|&w| f(w)).collect();
        let masses = chi2::bin_masses(&grid, &nodes, &solid_angles, &density);
        chi2::test(name, &grid, n, &samples, &masses)
    };
    run("host cone sampler", &|w| cone(v0, w)).assert_passes();
    run("host cone, density doubled", &|w| 2.0 * cone(v0, w)).assert_fails();
    let wider = 1.0 - (1.03 * (1.0 - v0).acos()).cos();
    run("host cone, cone 3% wider", &|w| cone(wider, w)).assert_fails();
    run("host cone, density lopsided", &|w| {
        cone(v0, w) * (1.0 + 0.1 * w.dot(x) / (1.0 - w.dot(axis).powi(2)).sqrt().max(1e-12))
    })
    .assert_fails();
}

/// One light_sample output (probes.cl).
#[derive(Clone, Copy, Debug)]
struct Sample {
    wi: DVec3,
    q: DVec3,
    q_error: DVec3,
    pdf: f64,
    ok: bool,
    /// light_pdf at wi and |q - p|.
    pdf_at_q: f64,
}

impl Probes {
    /// Runs probe `name` on light (as the light list's only entry) for `items` samples of
    /// `input` (the kernel's parameter `input_name`), each writing `width` floats.
    fn kernel(
        &self,
        (name, input_name): (&str, &'static str),
        light: &Light,
        input: &[f32],
        items: usize,
        width: usize,
    ) -> Vec<f32> {
        // Whole work-items of `lanes` samples: the input padded with copies of its last one.
        let lanes = self.lanes as usize;
        let padded_items = items.div_ceil(lanes) * lanes;
        let per_item = input.len() / items;
        let mut input = input.to_vec();
        for _ in items..padded_items {
            let last = input[input.len() - per_item..].to_vec();
            input.extend(last);
        }
        let lb = common::buffer(&self.device, bytemuck::bytes_of(light));
        let ib = common::buffer(&self.device, &input);
        let out = common::output::<f32>(&self.device, padded_items * width);
        let kernel = NamedArgs::new(&self.program, name, &self.device.queue)
            .buffer("lights", &lb)
            .buffer(input_name, &ib)
            .buffer("out", &out)
            .build()
            .unwrap();
        common::run(&kernel, padded_items / lanes);
        let mut out = common::read(&out);
        out.truncate(items * width);
        out
    }

    /// light_sample from p with each pair of uniforms.
    fn sample(&self, light: &Light, p: DVec3, u: &[[f32; 2]]) -> Vec<Sample> {
        let p = p.as_vec3().to_array();
        let input: Vec<f32> = u
            .iter()
            .flat_map(|u| [p[0], p[1], p[2], u[0], u[1]])
            .collect();
        self.kernel(("probe_light_sample", "p_u"), light, &input, u.len(), 12)
            .chunks_exact(12)
            .map(|c| {
                let v = |i: usize| DVec3::new(c[i].into(), c[i + 1].into(), c[i + 2].into());
                Sample {
                    wi: v(0),
                    q: v(3),
                    q_error: v(6),
                    pdf: c[9].into(),
                    ok: c[10] == 1.0,
                    pdf_at_q: c[11].into(),
                }
            })
            .collect()
    }

    /// light_pdf from p at each direction w that meets the light at distance t.
    fn pdf_at(&self, light: &Light, p: DVec3, ws: &[DVec3], ts: &[f64]) -> Vec<f64> {
        let input: Vec<f32> = ws
            .iter()
            .zip(ts)
            .flat_map(|(w, &t)| {
                let (p, w) = (p.as_vec3(), w.as_vec3());
                [p.x, p.y, p.z, w.x, w.y, w.z, t as f32]
            })
            .collect();
        self.kernel(("probe_light_pdf", "p_d_t"), light, &input, ws.len(), 1)
            .iter()
            .map(|&pdf| pdf.into())
            .collect()
    }

    /// light_pdf from p at each direction that meets the light (f64 hit test), 0 elsewhere.
    fn pdf(&self, light: &Light, p: DVec3, ws: &[DVec3]) -> Vec<f64> {
        let hits: Vec<Option<f64>> = ws.iter().map(|&w| hit(light, p, w)).collect();
        let ts: Vec<f64> = hits.iter().map(|t| t.unwrap_or(1.0)).collect();
        self.pdf_at(light, p, ws, &ts)
            .into_iter()
            .zip(&hits)
            .map(|(pdf, t)| if t.is_some() { pdf } else { 0.0 })
            .collect()
    }
}

fn v(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

/// The corners of a square's or a triangle's light entry.
fn corners(l: &Light) -> Vec<DVec3> {
    let (c, e1, e2) = (v(l.corner), v(l.edge1), v(l.edge2));
    if l.kind == OBJECT_MESH {
        vec![c, c + e1, c + e2]
    } else {
        vec![c, c + e1, c + e1 + e2, c + e2]
    }
}

/// Where the ray from p along unit d first meets light l, in f64 on the entry's f32 values.
fn hit(l: &Light, p: DVec3, d: DVec3) -> Option<f64> {
    if l.kind == OBJECT_SPHERE {
        let oc = p - v(l.corner);
        let b = oc.dot(d);
        let perp = oc - b * d;
        let r = f64::from(l.radius);
        let disc = r * r - perp.length_squared();
        let t = -b - disc.max(0.0).sqrt();
        // A visible cap: the hit must be on it.
        let on_cap = l.cap_height == 0.0
            || (p + t * d - v(l.corner)).dot(v(l.normal)) >= r - f64::from(l.cap_height);
        return (disc >= 0.0 && t > 0.0 && on_cap).then_some(t);
    }
    let (c, e1, e2) = (v(l.corner), v(l.edge1), v(l.edge2));
    let nrm = e1.cross(e2);
    let t = (c - p).dot(nrm) / d.dot(nrm);
    if !(t > 0.0 && t.is_finite()) {
        return None;
    }
    let (a, b) = edge_params(l, p + t * d);
    let inside = if l.kind == OBJECT_MESH {
        a >= 0.0 && b >= 0.0 && a + b <= 1.0
    } else {
        (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b)
    };
    inside.then_some(t)
}

/// The coordinates (a, b) of point x of the light's plane: x = corner + a edge1 + b edge2.
fn edge_params(l: &Light, x: DVec3) -> (f64, f64) {
    let (c, e1, e2) = (v(l.corner), v(l.edge1), v(l.edge2));
    let nrm = e1.cross(e2);
    let x = x - c;
    (
        x.cross(e2).dot(nrm) / nrm.length_squared(),
        e1.cross(x).dot(nrm) / nrm.length_squared(),
    )
}

/// The solid angle of the triangle (a, b, c) seen from p (Van Oosterom and Strackee 1983,
/// "The Solid Angle of a Plane Triangle"): accurate for small triangles, and a formula of its
/// own against the kernel's sum of a quadrilateral's angles.
fn triangle_solid_angle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// The solid angle a square light l subtends from p, if it is sampled so: marked for it (a
/// wall's rectangle), p in front of it, subtending between nee.h's SPH_RECT_MIN (0.01) and
/// SPH_RECT_MAX (6.2).
fn rectangle_solid_angle(l: &Light, p: DVec3) -> Option<f64> {
    let front = (p - v(l.corner)).dot(v(l.normal)) > 0.0;
    if l.solid_angle == 0 || !front {
        return None;
    }
    let cs = corners(l);
    let s =
        triangle_solid_angle(p, cs[0], cs[1], cs[2]) + triangle_solid_angle(p, cs[0], cs[2], cs[3]);
    (0.01..=6.2).contains(&s).then_some(s)
}

/// light_pdf in f64: a sphere's cone, uniformly; a rectangle's solid angle, uniformly where it
/// is sampled so; other squares' and triangles' area, uniformly, turned into solid angle
/// (t² / (cos A)); the light's pick probability `prob` times that.
fn light_pdf_f64(l: &Light, p: DVec3, d: DVec3, t: f64) -> f64 {
    let prob = f64::from(l.prob);
    if let Some(s) = rectangle_solid_angle(l, p) {
        return prob / s;
    }
    if l.kind == OBJECT_SPHERE && l.cap_height > 0.0 {
        let n = (p + t * d - v(l.corner)).normalize();
        return prob * t * t / (-n.dot(d) * f64::from(l.area));
    }
    if l.kind == OBJECT_SPHERE {
        let d2 = (v(l.corner) - p).length_squared();
        let r2 = f64::from(l.radius).powi(2);
        let sin2 = r2 / d2;
        return prob / (TAU * sin2 / (1.0 + (1.0 - sin2).sqrt()));
    }
    let c = -v(l.normal).dot(d);
    let c = if l.kind == OBJECT_MESH { c.abs() } else { c };
    if c > 0.0 {
        prob * t * t / (c * f64::from(l.area))
    } else {
        0.0
    }
}

/// The support of light l's density seen from p, as the grid's axis and largest 1 - cos θ.
fn support(l: &Light, p: DVec3) -> (DVec3, f64) {
    if l.kind == OBJECT_SPHERE && l.cap_height > 0.0 {
        // A cap of at most a hemisphere, seen from its side: its rim and apex bound it.
        let points: Vec<DVec3> = cap_nodes(l, 1, 256).0;
        let centre = points.iter().sum::<DVec3>() / points.len() as f64;
        let axis = (centre - p).normalize();
        let v_max = points
            .iter()
            .chain(&cap_nodes(l, 1, 256).1)
            .map(|&q| {
                let w = (q - p).normalize();
                1.0 - w.dot(axis)
            })
            .fold(0.0, f64::max);
        return (axis, v_max);
    }
    if l.kind == OBJECT_SPHERE {
        let pc = v(l.corner) - p;
        let sin2 = f64::from(l.radius).powi(2) / pc.length_squared();
        return (pc.normalize(), sin2 / (1.0 + (1.0 - sin2).sqrt()));
    }
    let cs = corners(l);
    let centre = cs.iter().sum::<DVec3>() / cs.len() as f64;
    let axis = (centre - p).normalize();
    let v_max = cs
        .iter()
        .map(|&c| {
            let w = (c - p).normalize();
            let s = w - axis * w.dot(axis);
            s.length_squared() / (1.0 + w.dot(axis))
        })
        .fold(0.0, f64::max);
    (axis, v_max)
}

/// Light l as light sampling's only entry: picked with probability 1.
fn alone(l: &Light) -> Light {
    Light {
        prob: 1.0,
        cdf: 1.0,
        ..*l
    }
}

/// The chi-square harness on `n` samples of light l from p, against the device's light_pdf
/// (first, so that a wrong density shows there); then per sample: its point on the light, its
/// direction towards the point, its pdf light_pdf there; and light_pdf equal to its f64 form at
/// the sampled directions.
fn check_light(probes: &Probes, name: &str, l: &Light, p: DVec3, rng: &mut SmallRng, n: usize) {
    let p = p.as_vec3().as_dvec3(); // the point as the device sees it
    let u: Vec<[f32; 2]> = (0..n).map(|_| [rng.random(), rng.random()]).collect();
    let samples = probes.sample(l, p, &u);
    let (axis, v_max) = support(l, p);
    let angle = (v_max * (2.0 - v_max)).sqrt(); // sin of the support's half-angle
    let grid = chi2::Grid::cap(axis, v_max);
    let masses = if l.kind == OBJECT_SPHERE && l.cap_height > 0.0 {
        let (nodes, solid_angles, ts) = cap_quadrature(l, p, 2000);
        let density = probes.pdf_at(l, p, &nodes, &ts);
        chi2::bin_masses(&grid, &nodes, &solid_angles, &density)
    } else if l.kind == OBJECT_SPHERE {
        // Over the sphere of directions: the cone's rim runs along a sub-cell boundary of the
        // cap's outer ring, so the midpoint rule is exact but for rounding.
        let (nodes, solid_angles) = grid.nodes(8);
        let density = probes.pdf(l, p, &nodes);
        chi2::bin_masses(&grid, &nodes, &solid_angles, &density)
    } else {
        let (nodes, solid_angles, ts) = area_nodes(l, p, 600);
        let density = probes.pdf_at(l, p, &nodes, &ts);
        chi2::bin_masses(&grid, &nodes, &solid_angles, &density)
    };
    let wis: Vec<DVec3> = samples.iter().map(|s| s.wi).collect();
    chi2::test(name, &grid, n, &wis, &masses).assert_passes();

    for s in &samples {
        assert!(s.ok && s.pdf > 0.0 && s.pdf.is_finite(), "{name}: {s:?}");
        assert!(
            (s.pdf - s.pdf_at_q).abs() <= 1e-5 * s.pdf,
            "{name}: light_sample's pdf {} vs light_pdf {}",
            s.pdf,
            s.pdf_at_q
        );
        let to_q = s.q - p;
        // (q rounds by about its error bound, which matters when q is near p.)
        let rounding = 4.0 * (s.q_error.length() + 1e-7 * s.q.length()) / to_q.length();
        assert!(
            s.wi.cross(to_q.normalize()).length() <= 1e-3 * angle + 1e-6 + rounding,
            "{name}: wi {} does not point at q {}",
            s.wi,
            s.q
        );
        // q on the light, within a few times its error bound (or f32 rounding of |q|).
        let slack = 4.0 * s.q_error.length() + 1e-6 * s.q.length();
        if l.kind == OBJECT_SPHERE {
            let off = ((s.q - v(l.corner)).length() - f64::from(l.radius)).abs();
            assert!(off <= slack, "{name}: q {} off the sphere by {off}", s.q);
        } else {
            let off = (s.q - v(l.corner)).dot(v(l.normal)).abs();
            assert!(off <= slack, "{name}: q {} off the plane by {off}", s.q);
            let (a, b) = edge_params(l, s.q);
            let e = 1e-5;
            let inside = if l.kind == OBJECT_MESH {
                a >= -e && b >= -e && a + b <= 1.0 + e
            } else {
                a >= -e && b >= -e && a <= 1.0 + e && b <= 1.0 + e
            };
            assert!(inside, "{name}: q {} not on the light ({a}, {b})", s.q);
        }
    }
    // light_pdf against f64 at the sampled directions (they meet the light).
    let ws: Vec<DVec3> = samples
        .iter()
        .take(5000)
        .map(|s| s.wi.normalize())
        .collect();
    for (w, pdf) in ws.iter().zip(probes.pdf(l, p, &ws)) {
        if let Some(t) = hit(l, p, *w) {
            let want = light_pdf_f64(l, p, *w, t);
            assert!(
                (pdf - want).abs() <= 1e-4 * want,
                "{name}: light_pdf({w}) = {pdf}, f64 {want}"
            );
        }
    }
}

/// Points of a sphere light's visible cap (uniform in depth below its top, as area is): m
/// depths by k angles at cell centres, and the k points of its rim.
fn cap_nodes(l: &Light, m: usize, k: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let (c, axis) = (v(l.corner), v(l.normal));
    let (r, h) = (f64::from(l.radius), f64::from(l.cap_height));
    let (t, b) = axis.any_orthonormal_pair();
    let at = |below: f64, phi: f64| {
        let rho = (below * (2.0 * r - below)).max(0.0).sqrt();
        c + axis * (r - below) + (t * phi.cos() + b * phi.sin()) * rho
    };
    let mut cells = Vec::with_capacity(m * k);
    for i in 0..m {
        for j in 0..k {
            cells.push(at(
                h * (i as f64 + 0.5) / m as f64,
                TAU * (j as f64 + 0.5) / k as f64,
            ));
        }
    }
    let rim = (0..k).map(|j| at(h, TAU * j as f64 / k as f64)).collect();
    (cells, rim)
}

/// Quadrature nodes for a density over the directions to a sphere light's cap from p: its
/// cells of equal area (cap_nodes), each the direction to its centre, its solid angle
/// cos dA / t², and t.
fn cap_quadrature(l: &Light, p: DVec3, m: usize) -> (Vec<DVec3>, Vec<f64>, Vec<f64>) {
    let da = f64::from(l.area) / (m * m) as f64;
    let c = v(l.corner);
    let (mut ws, mut solid_angles, mut ts) = (vec![], vec![], vec![]);
    for q in cap_nodes(l, m, m).0 {
        let to = q - p;
        let t = to.length();
        let w = to / t;
        ws.push(w);
        solid_angles.push((-(q - c).normalize().dot(w)).max(0.0) * da / (t * t));
        ts.push(t);
    }
    (ws, solid_angles, ts)
}

/// Quadrature nodes for a density over the directions to a square or triangle from p, placed
/// on the light itself (so its edges, where the density jumps to 0, are exact; over the sphere
/// of directions the midpoint rule converged only as 1 / sub there, and badly in the thin bins
/// by the grid's axis): the square cut into m × m equal parallelograms, the triangle into m²
/// equal triangles; for each, the direction to its centroid, its solid angle cos dA / t², and t.
fn area_nodes(l: &Light, p: DVec3, m: usize) -> (Vec<DVec3>, Vec<f64>, Vec<f64>) {
    let (c, e1, e2) = (v(l.corner), v(l.edge1), v(l.edge2));
    let normal = e1.cross(e2);
    let area = normal.length() * if l.kind == OBJECT_MESH { 0.5 } else { 1.0 };
    let normal = normal.normalize();
    // (a, b, share of the area) of each cell's centroid.
    let mut centroids = Vec::with_capacity(m * m);
    let step = 1.0 / m as f64;
    if l.kind != OBJECT_MESH {
        // Cells graded towards p's foot on the plane, so that none subtends much more than
        // the others from p close by (see graded).
        let height = (p - c).dot(normal).abs();
        let (a, b) = edge_params(l, p);
        let ka = graded(a, height / e1.length(), m);
        let kb = graded(b, height / e2.length(), m);
        for i in 0..m {
            for j in 0..m {
                let (da, db) = (ka[i + 1] - ka[i], kb[j + 1] - kb[j]);
                centroids.push((ka[i] + 0.5 * da, kb[j] + 0.5 * db, da * db));
            }
        }
    } else {
        for i in 0..m {
            for j in 0..m {
                let (a, b) = (i as f64 * step, j as f64 * step);
                let share = step * step;
                if i + j < m {
                    centroids.push((a + step / 3.0, b + step / 3.0, share));
                    if i + j + 1 < m {
                        centroids.push((a + 2.0 * step / 3.0, b + 2.0 * step / 3.0, share));
                    }
                }
            }
        }
    }
    assert_eq!(centroids.len(), m * m);
    let (mut ws, mut solid_angles, mut ts) = (vec![], vec![], vec![]);
    for (a, b, share) in centroids {
        let to = c + e1 * a + e2 * b - p;
        let t = to.length();
        let w = to / t;
        ws.push(w);
        solid_angles.push(w.dot(normal).abs() * area * share / (t * t));
        ts.push(t);
    }
    (ws, solid_angles, ts)
}

/// m + 1 breakpoints from 0 to 1 along an edge, spaced in proportion to the distance from a
/// point at `height` above `foot` (both in the edge's lengths): foot + height sinh(s) at equal
/// steps of s. Far away (height large) they are nearly equal steps; close by, the cells under
/// the point shrink as it approaches, so the midpoint rule stays accurate there.
fn graded(foot: f64, height: f64, m: usize) -> Vec<f64> {
    let h = height.max(1e-12);
    let (s0, s1) = ((-foot / h).asinh(), ((1.0 - foot) / h).asinh());
    let mut k: Vec<f64> = (0..=m)
        .map(|i| (foot + h * (s0 + (s1 - s0) * i as f64 / m as f64).sinh()).clamp(0.0, 1.0))
        .collect();
    (k[0], k[m]) = (0.0, 1.0);
    k
}

/// Cone sampling of a sphere light (radius 0.4) from 1.0001, 1.01, 1.5, 4, 100, 1000 and 10000
/// radii from its centre: 7 chi-square tests.
#[test]
fn sphere_light_cone_sampling_follows_light_pdf() {
    // The scalar program, and the wide program of 16 lanes a work-item (kernels/lanes.h).
    for lanes in [1, 16] {
        sphere_light_cone_sampling_follows_light_pdf_at(&Probes::in_lanes(lanes));
    }
}

fn sphere_light_cone_sampling_follows_light_pdf_at(probes: &Probes) {
    let mut rng = SmallRng::seed_from_u64(41);
    let l = alone(&common::every_light_scene_lights("sphere")[0]);
    assert_eq!(l.kind, OBJECT_SPHERE);
    let c = v(l.corner);
    let r = f64::from(l.radius);
    let dir = DVec3::new(0.6, -0.3, 0.74).normalize();
    for k in [1.0001, 1.01, 1.5, 4.0, 100.0, 1e3, 1e4] {
        // Near: p beside the sphere. Far: the sphere moved away from p, which stays at small
        // dyadic coordinates so that c - p is exact in f32 (the cone's axis then is too).
        let (l, p) = if k < 10.0 {
            (l, c + dir * (r * k))
        } else {
            let p = DVec3::new(0.25, -0.5, 0.125);
            let far = Light {
                corner: (p - dir * (r * k)).as_vec3().to_array(),
                ..l
            };
            (far, p)
        };
        let d = (v(l.corner) - p.as_vec3().as_dvec3()).length() / r;
        check_light(
            probes,
            &format!("sphere from {d:.4} radii"),
            &l,
            p,
            &mut rng,
            500_000,
        );
    }
}

/// Area sampling of a sphere light's visible cap (lights.rs `visible_cap`): caps of 0.05, 0.3 and
/// 0.6 times the radius, each from below on its axis, and the thinnest also from aside (every
/// point of each cap faces the point: from 4 radii, a sphere shows a cap 0.75 radii high): 4
/// chi-square tests.
#[test]
fn sphere_cap_sampling_follows_light_pdf() {
    // The scalar program, and the wide program of 16 lanes a work-item (kernels/lanes.h).
    for lanes in [1, 16] {
        sphere_cap_sampling_follows_light_pdf_at(&Probes::in_lanes(lanes));
    }
}

fn sphere_cap_sampling_follows_light_pdf_at(probes: &Probes) {
    let mut rng = SmallRng::seed_from_u64(43);
    let l = alone(&common::every_light_scene_lights("cap")[0]);
    assert_eq!(l.kind, OBJECT_SPHERE);
    let (c, r) = (v(l.corner), f64::from(l.radius));
    let axis = DVec3::new(0.2, -1.0, 0.1).normalize();
    for (h, from) in [
        (0.05, axis * 3.0),
        (0.3, axis * 3.0),
        (0.6, axis * 4.0),
        (
            0.05,
            (axis * 3.0 + axis.any_orthogonal_vector() * 1.5) * 1.0,
        ),
    ] {
        let cap = Light {
            normal: axis.as_vec3().to_array(),
            cap_height: (h * r) as f32,
            area: (TAU * r * h * r) as f32,
            ..l
        };
        check_light(
            probes,
            &format!("cap of {h} radii"),
            &cap,
            c + from * r,
            &mut rng,
            500_000,
        );
    }
}

/// Uniform area sampling of squares and triangles: the rotated square of every_light_scene, a
/// skewed parallelogram (a square under a shear, or clipped to a room), and a triangle of the
/// scaled quad mesh, each from above its centre, from close by beyond an edge (grazing), and
/// from far away; the two-sided triangle from behind. 9 chi-square tests.
#[test]
fn square_parallelogram_and_triangle_sampling_follows_light_pdf() {
    // The scalar program, and the wide program of 16 lanes a work-item (kernels/lanes.h).
    for lanes in [1, 16] {
        square_parallelogram_and_triangle_sampling_follows_light_pdf_at(&Probes::in_lanes(lanes));
    }
}

fn square_parallelogram_and_triangle_sampling_follows_light_pdf_at(probes: &Probes) {
    let mut rng = SmallRng::seed_from_u64(42);
    let lights = common::every_light_scene_lights("area");
    let square = alone(&lights[1]);
    let triangle = alone(&lights[2]);
    assert_eq!((square.kind, triangle.kind), (OBJECT_PLANE, OBJECT_MESH));
    let (e1, e2) = (DVec3::new(1.1, 0.1, 0.2), DVec3::new(0.6, 0.3, 0.9));
    let nrm = e1.cross(e2);
    let skewed = Light {
        kind: OBJECT_PLANE,
        index: 0,
        triangle: 0,
        material: 0,
        corner: [0.3, 1.2, -0.7],
        edge1: e1.as_vec3().to_array(),
        edge2: e2.as_vec3().to_array(),
        normal: nrm.normalize().as_vec3().to_array(),
        radius: 0.0,
        area: nrm.length() as f32,
        prob: 1.0,
        cdf: 1.0,
        cap_height: 0.0,
        solid_angle: 0,
    };
    for (what, l, back) in [
        ("square", square, false),
        ("parallelogram", skewed, false),
        ("triangle", triangle, true),
    ] {
        let (c, e1, e2) = (v(l.corner), v(l.edge1), v(l.edge2));
        let n = v(l.normal);
        let size = e1.length().max(e2.length());
        let centre = corners(&l).iter().sum::<DVec3>() / corners(&l).len() as f64;
        let slant = (n + e1.normalize() * 0.5 - e2.normalize() * 0.3).normalize();
        for (place, p) in [
            ("above", centre + n * (1.5 * size)),
            (
                if back {
                    "close, behind"
                } else {
                    "close, grazing"
                },
                c + e1 * 1.3 + e2 * 0.5 + n * (if back { -0.15 } else { 0.15 } * size),
            ),
            ("far", centre + slant * (200.0 * size)),
        ] {
            check_light(probes, &format!("{what} {place}"), &l, p, &mut rng, 500_000);
        }
    }
}

/// Sampling by solid angle (nee.h `sph_rect`): ceiling_room's ceiling, clipped to its room
/// (200 x 400 at y = 160, emitting downwards), from the floor, from a wall a rounding of the
/// ceiling's edge away (grazing), from 3 below it inside its footprint (6.15 sr, near
/// SPH_RECT_MAX), from 1 below it (6.24 sr, past SPH_RECT_MAX: sampled by area), from far away (0.02
/// sr, near SPH_RECT_MIN); and the same room moved 1e5 from the origin. The f64 density (two
/// triangles' solid angles) says which of the two ways each point is sampled.
#[test]
fn rectangle_sampling_by_solid_angle_follows_light_pdf() {
    // The scalar program, and the wide program of 16 lanes a work-item (kernels/lanes.h).
    for lanes in [1, 16] {
        rectangle_sampling_by_solid_angle_follows_light_pdf_at(&Probes::in_lanes(lanes));
    }
}

fn rectangle_sampling_by_solid_angle_follows_light_pdf_at(probes: &Probes) {
    let mut rng = SmallRng::seed_from_u64(44);
    for shift in [DVec3::ZERO, DVec3::new(1e5, -2e4, 3e4)] {
        let corner = DVec3::new(-100.0, 160.0, -100.0) + shift;
        let ceiling = Light {
            kind: OBJECT_PLANE,
            index: 0,
            triangle: 0,
            material: 0,
            corner: corner.as_vec3().to_array(),
            edge1: [200.0, 0.0, 0.0],
            edge2: [0.0, 0.0, 400.0],
            normal: [0.0, -1.0, 0.0],
            radius: 0.0,
            area: 80000.0,
            prob: 1.0,
            cdf: 1.0,
            cap_height: 0.0,
            solid_angle: 1,
        };
        for (place, p, solid_angle) in [
            ("floor", DVec3::new(0.0, 0.0, 100.0), true),
            ("wall by its edge", DVec3::new(-95.0, 150.0, 20.0), true),
            ("3 below", DVec3::new(10.0, 157.0, 80.0), true),
            ("1 below", DVec3::new(10.0, 159.0, 80.0), false),
            ("far", DVec3::new(300.0, -1800.0, 500.0), true),
        ] {
            let p = p + shift;
            let name = format!("ceiling from the {place}, shifted {shift}");
            let s = rectangle_solid_angle(&ceiling, p.as_vec3().as_dvec3());
            assert_eq!(s.is_some(), solid_angle, "{name}: solid angle {s:?}");
            check_light(probes, &name, &ceiling, p, &mut rng, 500_000);
        }
    }
}

/// Where a light offers nothing, light_sample says so: from inside a sphere, behind a square.
#[test]
fn nothing_is_sampled_from_inside_a_sphere_or_behind_a_square() {
    let probes = Probes::new();
    let mut rng = SmallRng::seed_from_u64(43);
    let lights = common::every_light_scene_lights("nothing");
    let u: Vec<[f32; 2]> = (0..1000).map(|_| [rng.random(), rng.random()]).collect();
    let sphere = alone(&lights[0]);
    let square = alone(&lights[1]);
    let centre = corners(&square).iter().sum::<DVec3>() / 4.0;
    for (l, p) in [
        (sphere, v(sphere.corner) + DVec3::new(0.1, 0.2, -0.1)),
        (square, centre - v(square.normal) * 0.5),
        (
            square,
            centre + v(square.edge1) * 3.0 - v(square.normal) * 0.01,
        ),
    ] {
        for s in probes.sample(&l, p, &u) {
            assert!(!s.ok, "sampled from {p}: {s:?}");
        }
    }
}
