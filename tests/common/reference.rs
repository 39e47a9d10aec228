//! An f64 reference of what the kernels compute, written independently of them: ray/sphere and
//! ray/plane intersection, the camera, and a path tracer with the same estimator (smallpt's
//! materials, Russian roulette) but its own random numbers. The intersection routines take the
//! device's structs, widened exactly to f64 (double-float sphere centres and radii summed), so
//! differences are the device's rounding alone; the path tracer takes the scene as parsed
//! ([`World`]), in f64 from its decimals, so it sees what the scene file says rather than what
//! the host made of it.
#![allow(dead_code)]

use clpt::contract::{Plane, Sphere};
use clpt::scene::camera::CameraBasis;
use clpt::scene::{MaterialKind, Scene};
use clpt::shapes::{PlaneShape, Shape, SphereShape};
use glam::DVec3;
use rand::{Rng, RngExt};

pub fn v3(a: [f32; 3]) -> DVec3 {
    DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

/// Both roots of |o + t d - c| = r for the device's sphere (d unit), in f64 (the double-float
/// centre and radius summed); None if the ray's line misses.
pub fn sphere_roots(s: &Sphere, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    roots(s.center_f64(), s.radius_f64(), o, d)
}

/// Both roots of |o + t d - c| = r (d unit), computed with the stable formulas, in order.
fn roots(c: DVec3, r: f64, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let f = o - c;
    let b = f.dot(d);
    let perp = f - b * d;
    let disc = r * r - perp.length_squared();
    if disc < 0.0 {
        return None;
    }
    let cc = (f.length() - r) * (f.length() + r);
    let q = -(b + disc.sqrt().copysign(b));
    let (t0, t1) = (cc / q, q);
    Some(if t0 < t1 { (t0, t1) } else { (t1, t0) })
}

pub fn sphere_hit(s: &Sphere, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
    first_root(s.center_f64(), s.radius_f64(), o, d, t_max)
}

/// The nearest t in (0, t_max) where o + t d meets the sphere (c, r).
fn first_root(c: DVec3, r: f64, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
    let (t0, t1) = roots(c, r, o, d)?;
    [t0, t1].into_iter().find(|&t| t > 0.0 && t < t_max)
}

/// The device's plane, widened exactly to f64.
pub fn plane_hit(p: &Plane, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
    let plane = WorldPlane {
        normal: v3(p.normal),
        offset: p.offset as f64,
        range: p.range as f64,
        center: v3(p.center),
        material: p.material as usize,
    };
    plane.hit(o, d, t_max)
}

/// A scene of untransformed spheres and planes as its file says, in f64 and in the scene's
/// own coordinates (not the device's camera-relative ones).
pub struct World {
    pub camera: CameraBasis,
    /// (centre, radius, material)
    pub spheres: Vec<(DVec3, f64, usize)>,
    pub planes: Vec<WorldPlane>,
    pub materials: Vec<clpt::scene::Material>,
}

/// n.p = offset (n unit) within `range` of `center` in every coordinate, seen from n's side.
pub struct WorldPlane {
    pub normal: DVec3,
    pub offset: f64,
    pub range: f64,
    pub center: DVec3,
    pub material: usize,
}

impl WorldPlane {
    /// The t in (0, t_max) where o + t d meets the plane from its front, inside its box.
    fn hit(&self, o: DVec3, d: DVec3, t_max: f64) -> Option<f64> {
        let denom = self.normal.dot(d);
        if denom >= 0.0 {
            return None;
        }
        let t = (self.offset - self.normal.dot(o)) / denom;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        ((o + t * d - self.center).abs().max_element() <= self.range).then_some(t)
    }
}

impl World {
    pub fn new(scene: &Scene) -> World {
        let mut world = World {
            camera: CameraBasis::new(&scene.camera).expect("camera"),
            spheres: vec![],
            planes: vec![],
            materials: scene.materials.clone(),
        };
        for object in &scene.objects {
            assert!(
                object.transform.is_none(),
                "the reference takes no transforms"
            );
            match object.shape {
                Shape::Sphere(SphereShape { center, radius }) => {
                    world.spheres.push((center, radius, object.material))
                }
                Shape::Plane(PlaneShape {
                    normal,
                    offset,
                    range,
                    ..
                }) => {
                    let len = normal.length();
                    world.planes.push(WorldPlane {
                        normal: normal / len,
                        offset: offset / len,
                        range,
                        center: normal * (offset / (len * len)),
                        material: object.material,
                    })
                }
                _ => panic!("the reference takes spheres and planes only"),
            }
        }
        world
    }

    /// The object a ray meets first: (t, kind as in objects.h: 1 sphere, 2 plane, index).
    pub fn nearest(&self, o: DVec3, d: DVec3) -> Option<(f64, u32, usize)> {
        let mut best: Option<(f64, u32, usize)> = None;
        for (i, &(c, r, _)) in self.spheres.iter().enumerate() {
            if let Some(t) = first_root(c, r, o, d, best.map_or(f64::INFINITY, |b| b.0)) {
                best = Some((t, 1, i));
            }
        }
        for (i, p) in self.planes.iter().enumerate() {
            if let Some(t) = p.hit(o, d, best.map_or(f64::INFINITY, |b| b.0)) {
                best = Some((t, 2, i));
            }
        }
        best
    }
}

/// smallpt's tent filter.
pub fn tent(u: f64) -> f64 {
    let r = 2.0 * u;
    if r < 1.0 {
        r.sqrt() - 1.0
    } else {
        1.0 - (2.0 - r).sqrt()
    }
}

/// The unnormalised direction through the image point that u picks in pixel (px, py): the
/// top bit of each number picks the 2x2 sub-pixel, the rest jitters with the tent (pinhole).
pub fn camera_direction(cam: &CameraBasis, px: u32, py: u32, u: [f64; 2]) -> DVec3 {
    let sx = if u[0] < 0.5 { 0.0 } else { 1.0 };
    let sy = if u[1] < 0.5 { 0.0 } else { 1.0 };
    let fx = ((sx + 0.5 + tent(2.0 * u[0] - sx)) * 0.5 + px as f64) / cam.width as f64 - 0.5;
    let fy = ((sy + 0.5 + tent(2.0 * u[1] - sy)) * 0.5 + py as f64) / cam.height as f64 - 0.5;
    cam.cx * fx + cam.cy * fy + cam.forward
}

/// Shirley and Chiu's concentric disk map.
pub fn concentric_disk(u: [f64; 2]) -> (f64, f64) {
    let (x, y) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if x == 0.0 && y == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if x.abs() > y.abs() {
        (x, std::f64::consts::FRAC_PI_4 * (y / x))
    } else {
        (
            y,
            std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (x / y),
        )
    };
    (r * phi.cos(), r * phi.sin())
}

/// A primary ray (origin, unit direction) as camera.h defines it.
pub fn camera_ray(cam: &CameraBasis, px: u32, py: u32, u: [f64; 4]) -> (DVec3, DVec3) {
    let d = camera_direction(cam, px, py, [u[0], u[1]]);
    if cam.focus_distance <= 0.0 {
        return (cam.origin, d.normalize());
    }
    let focus = cam.origin + d * (cam.focus_distance / d.dot(cam.forward));
    let (lx, ly) = concentric_disk([u[2], u[3]]);
    let lens =
        cam.origin + cam.lens_u * (lx * cam.lens_radius) + cam.lens_v * (ly * cam.lens_radius);
    (lens, (focus - lens).normalize())
}

fn cosine_direction(n: DVec3, u1: f64, u2: f64) -> DVec3 {
    let (t, b) = n.any_orthonormal_pair();
    let phi = 2.0 * std::f64::consts::PI * u1;
    let r = u2.sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u2).max(0.0).sqrt()).normalize()
}

/// Light from sphere `light` arriving at p (diffuse, unit normal `facing`, albedo `color`), by
/// one sample uniform in the cone the sphere subtends (its nearer side), the sample's point
/// seen from p (nothing nearer along the ray): f cos Le / pdf.
fn sphere_light_sample(
    scene: &World,
    light: usize,
    p: DVec3,
    facing: DVec3,
    color: DVec3,
    rng: &mut impl Rng,
) -> DVec3 {
    let (c, r, material) = scene.spheres[light];
    let pc = c - p;
    let d2 = pc.length_squared();
    if d2 <= r * r {
        return DVec3::ZERO;
    }
    let one_minus_cos_max = (r * r / d2) / (1.0 + (1.0 - r * r / d2).sqrt());
    let v = rng.random::<f64>() * one_minus_cos_max;
    let (cos_t, sin_t) = (1.0 - v, (v * (2.0 - v)).sqrt());
    let phi = 2.0 * std::f64::consts::PI * rng.random::<f64>();
    let w = pc / d2.sqrt();
    let (t, b) = w.any_orthonormal_pair();
    let wi = (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + w * cos_t).normalize();
    let cos_p = wi.dot(facing);
    if cos_p <= 0.0 {
        return DVec3::ZERO;
    }
    let o = p + facing * 1e-7 * (1.0 + p.abs().max_element());
    match scene.nearest(o, wi) {
        Some((_, 1, i)) if i == light => {
            let pdf = 1.0 / (2.0 * std::f64::consts::PI * one_minus_cos_max);
            color / std::f64::consts::PI * cos_p * scene.materials[material].emission / pdf
        }
        _ => DVec3::ZERO,
    }
}

/// One path sample through pixel (px, py), in f64 with `rng`: pure path tracing, or with
/// `light` the index of a sphere light, next-event estimation of it at diffuse vertices (and its
/// emission found by their BSDF samples left out; that of every other emitter kept).
pub fn trace_path(
    scene: &World,
    px: u32,
    py: u32,
    rr_depth: u32,
    light: Option<usize>,
    rng: &mut impl Rng,
) -> DVec3 {
    let cam = &scene.camera;
    let u: [f64; 4] = [rng.random(), rng.random(), rng.random(), rng.random()];
    let (mut o, mut d) = camera_ray(cam, px, py, u);
    let mut radiance = DVec3::ZERO;
    let mut throughput = DVec3::ONE;
    let mut after_diffuse = false;
    for depth in 0..100_000u32 {
        let Some((t, kind, index)) = scene.nearest(o, d) else {
            break;
        };
        let p = o + t * d;
        let (n, material) = if kind == 1 {
            let (c, _, material) = scene.spheres[index];
            ((p - c).normalize(), material)
        } else {
            let pl = &scene.planes[index];
            (pl.normal, pl.material)
        };
        let m = &scene.materials[material];
        if !(after_diffuse && kind == 1 && light == Some(index)) {
            radiance += throughput * m.emission;
        }
        let color = m.color;
        let wo = -d;
        let cos_o = wo.dot(n);
        let facing = if cos_o >= 0.0 { n } else { -n };
        let reflected = 2.0 * wo.dot(facing) * facing - wo;
        let wi = match m.kind {
            MaterialKind::Specular => reflected,
            MaterialKind::Refractive => {
                let entering = cos_o > 0.0;
                let eta = if entering { 1.0 / 1.5 } else { 1.5 };
                let cos_i = cos_o.abs();
                let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
                if sin2_t >= 1.0 {
                    reflected
                } else {
                    let cos_t = (1.0 - sin2_t).sqrt();
                    let refracted = (-wo * eta + facing * (eta * cos_i - cos_t)).normalize();
                    let r0 = (0.5f64 / 2.5).powi(2);
                    let c = 1.0 - if entering { cos_i } else { cos_t };
                    let fresnel = r0 + (1.0 - r0) * c.powi(5);
                    if rng.random::<f64>() < fresnel {
                        reflected
                    } else {
                        refracted
                    }
                }
            }
            _ => {
                if let Some(light) = light {
                    radiance +=
                        throughput * sphere_light_sample(scene, light, p, facing, color, rng);
                }
                cosine_direction(facing, rng.random(), rng.random())
            }
        };
        after_diffuse = m.kind == MaterialKind::Diffuse;
        throughput *= color;
        let survive = throughput.max_element().min(1.0);
        if depth + 1 >= rr_depth || survive <= 0.0 {
            if rng.random::<f64>() >= survive {
                break;
            }
            throughput /= survive;
        }
        // f64 leaves room for a plain epsilon at these scales.
        let side = if wi.dot(n) >= 0.0 { n } else { -n };
        o = p + side * 1e-7 * (1.0 + p.abs().max_element());
        d = wi;
    }
    radiance
}
