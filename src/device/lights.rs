//! The light list next-event estimation samples (kernel counterpart: `kernels/nee.h`, struct
//! `Light` in `kernels/types.h`): every sphere, plane square and mesh triangle of constant
//! emission, placed in world space, with the probability that light sampling picks it.
//!
//! Which emitters are listed:
//! - spheres, untransformed or under a similarity (rotation, uniform scale, translation),
//!   which keeps them spheres;
//! - planes whose own normal lies along an axis: their visible part is then a square
//!   (`|p - n offset| <= range`), and any affine transform maps it to a parallelogram;
//! - every triangle of a mesh instance, under any transform.
//!
//! Other emitters (emission maps, ellipsoids, tilted planes, surfaces of revolution) are found
//! by BSDF sampling alone, at full weight: the device looks every emitting hit up in this list
//! (nee.h `find_light`), so this module is the only rule.
//!
//! A light is picked in proportion to its power, π·Le·area (twice for two-sided triangles), with
//! Le the mean of the emission's channels: a scene's tiny lamp and its big glowing wall each get
//! samples in proportion to what they light (pbrt-v4's `PowerLightSampler`).

use super::layout::{self, Light, Material, MeshDesc, Transform};
use super::upload::f32x3;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// What the light list reads of a packed scene.
pub struct LightSources<'a> {
    pub materials: &'a [Material],
    pub spheres: &'a [layout::Sphere],
    pub planes: &'a [layout::Plane],
    pub transforms: &'a [Transform],
    pub meshes: &'a [MeshDesc],
    pub mesh_instances: &'a [layout::MeshInstance],
    pub triangles: &'a [[u32; 3]],
    pub vertices: &'a [[f32; 3]],
}

/// The light list, sorted by (kind, index, triangle), its `prob` and `cdf` filled in.
pub fn collect_lights(scene: &LightSources) -> Vec<Light> {
    let mut lights = Vec::new();
    let mut powers = Vec::new();
    let mut push = |light: Light, power: f64| {
        if power > 0.0 && power.is_finite() {
            lights.push(light);
            powers.push(power);
        }
    };
    for (i, s) in scene.spheres.iter().enumerate() {
        let Some(le) = constant_emission(scene.materials, s.material) else {
            continue;
        };
        let affine = Affine::of(scene.transforms, s.transform);
        let Some(scale) = affine.uniform_scale() else {
            continue; // an ellipsoid
        };
        let radius = f64::from(s.radius) * scale;
        let light = Light {
            kind: layout::OBJECT_SPHERE,
            index: i as u32,
            material: s.material,
            corner: f32x3(affine.point(dvec(s.center))),
            radius: radius as f32,
            ..Light::default()
        };
        push(light, PI * le * 4.0 * PI * radius * radius);
    }
    for (i, p) in scene.planes.iter().enumerate() {
        let Some(le) = constant_emission(scene.materials, p.material) else {
            continue;
        };
        let n = dvec(p.normal);
        if p.normal.iter().filter(|&&c| c != 0.0).count() != 1 {
            continue; // tilted: its visible part is a polygon
        }
        // The square n offset + [-range, range] along the two other axes: what the plane's
        // range test (plane.h) keeps of it.
        let a = if n.x != 0.0 { DVec3::Y } else { DVec3::X };
        let b = if n.z != 0.0 { DVec3::Y } else { DVec3::Z };
        let range = f64::from(p.range);
        let corner = n * f64::from(p.offset) - (a + b) * range;
        let affine = Affine::of(scene.transforms, p.transform);
        let (mut e1, mut e2) = (
            affine.vector(a * 2.0 * range),
            affine.vector(b * 2.0 * range),
        );
        let cross = e1.cross(e2);
        let area = cross.length();
        let mut normal = cross / area;
        if normal.dot(affine.normal(n)) < 0.0 {
            std::mem::swap(&mut e1, &mut e2);
            normal = -normal;
        }
        let light = Light {
            kind: layout::OBJECT_PLANE,
            index: i as u32,
            material: p.material,
            corner: f32x3(affine.point(corner)),
            edge1: f32x3(e1),
            edge2: f32x3(e2),
            normal: f32x3(normal),
            area: area as f32,
            ..Light::default()
        };
        push(light, PI * le * area);
    }
    for (i, inst) in scene.mesh_instances.iter().enumerate() {
        let Some(le) = constant_emission(scene.materials, inst.material) else {
            continue;
        };
        let affine = Affine::of(scene.transforms, inst.transform);
        let mesh = &scene.meshes[inst.mesh as usize];
        let end = scene
            .meshes
            .get(inst.mesh as usize + 1)
            .map_or(scene.triangles.len(), |next| next.first_triangle as usize);
        let first = mesh.first_triangle as usize;
        for (t, tri) in scene.triangles[first..end].iter().enumerate() {
            let v =
                tri.map(|k| affine.point(dvec(scene.vertices[(mesh.first_vertex + k) as usize])));
            let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
            let cross = e1.cross(e2);
            let area = 0.5 * cross.length();
            if area.is_nan() || area <= 0.0 {
                continue; // degenerate: nothing to sample, and no ray hits it
            }
            let light = Light {
                kind: layout::OBJECT_MESH,
                index: i as u32,
                triangle: t as u32,
                material: inst.material,
                corner: f32x3(v[0]),
                edge1: f32x3(e1),
                edge2: f32x3(e2),
                normal: f32x3(cross.normalize()),
                area: area as f32,
                ..Light::default()
            };
            push(light, 2.0 * PI * le * area);
        }
    }
    let mut order: Vec<usize> = (0..lights.len()).collect();
    order.sort_by_key(|&i| (lights[i].kind, lights[i].index, lights[i].triangle));
    let total: f64 = powers.iter().sum();
    let mut running = 0.0;
    let mut previous = 0.0f32;
    let mut sorted: Vec<Light> = order
        .iter()
        .map(|&i| {
            running += powers[i];
            let cdf = (running / total) as f32;
            let light = Light {
                prob: cdf - previous,
                cdf,
                ..lights[i]
            };
            previous = cdf;
            light
        })
        .collect();
    // The sum of f64 powers rounds to 1 at the end; make it exact, so no u is left above it.
    if let Some(last) = sorted.last_mut() {
        last.prob += 1.0 - last.cdf;
        last.cdf = 1.0;
    }
    sorted
}

/// One line for `clpt render -v`: how many spheres, squares and triangles the list holds.
pub fn report(lights: &[Light]) -> String {
    let count = |kind| lights.iter().filter(|l| l.kind == kind).count();
    format!(
        "light list: {} spheres, {} plane squares, {} triangles",
        count(layout::OBJECT_SPHERE),
        count(layout::OBJECT_PLANE),
        count(layout::OBJECT_MESH)
    )
}

/// The mean channel of a material's emission, if it emits a constant (unmapped) radiance.
fn constant_emission(materials: &[Material], material: u32) -> Option<f64> {
    let m = materials.get(material as usize)?;
    let le = m.emission.iter().map(|&e| f64::from(e)).sum::<f64>() / 3.0;
    (m.emission.iter().any(|&e| e > 0.0) && m.emission_map == layout::MAP_NONE).then_some(le)
}

fn dvec(v: [f32; 3]) -> DVec3 {
    DVec3::from(v.map(f64::from))
}

/// An object's transform as the device applies it (its f32 rows, computed in f64).
struct Affine {
    linear: DMat3,
    translation: DVec3,
    inverse: DMat3,
}

impl Affine {
    fn of(transforms: &[Transform], index: u32) -> Affine {
        let Some(t) = transforms.get(index as usize) else {
            return Affine {
                linear: DMat3::IDENTITY,
                translation: DVec3::ZERO,
                inverse: DMat3::IDENTITY,
            };
        };
        // Rows of three columns and a translation, as types.h's Transform stores them.
        let rows = |m: &[f32; 12]| {
            let col = |c: usize| DVec3::new(m[c].into(), m[4 + c].into(), m[8 + c].into());
            DMat3::from_cols(col(0), col(1), col(2))
        };
        Affine {
            linear: rows(&t.m),
            translation: DVec3::new(f64::from(t.m[3]), f64::from(t.m[7]), f64::from(t.m[11])),
            inverse: rows(&t.inv),
        }
    }

    fn point(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.translation
    }

    fn vector(&self, v: DVec3) -> DVec3 {
        self.linear * v
    }

    /// A normal's world direction (the inverse transpose), not normalised.
    fn normal(&self, n: DVec3) -> DVec3 {
        self.inverse.transpose() * n
    }

    /// The scale of a similarity (orthogonal columns of one length, to f32 rounding), or None.
    fn uniform_scale(&self) -> Option<f64> {
        let cols = [self.linear.x_axis, self.linear.y_axis, self.linear.z_axis];
        let s2 = cols[0].length_squared();
        let tol = 1e-5 * s2;
        let similar = cols.iter().all(|c| (c.length_squared() - s2).abs() <= tol)
            && (cols[0].dot(cols[1]).abs() <= tol)
            && (cols[0].dot(cols[2]).abs() <= tol)
            && (cols[1].dot(cols[2]).abs() <= tol);
        (similar && s2 > 0.0).then(|| s2.sqrt())
    }
}
