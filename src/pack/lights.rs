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
//! Each kind's entries are its own (`emitters` of `crate::shapes::HostShape`, in
//! `src/shapes/`); this module gathers them and picks among them, and holds the room they
//! are clipped to. Other emitters (emission maps, ellipsoids, tilted planes, surfaces of
//! revolution) are found by BSDF sampling alone, at full weight: the device looks every
//! emitting hit up in this list (nee.h `find_light`), so the list is the only rule.
//!
//! A light is picked in proportion to its power, π·Le·area (twice for two-sided triangles), with
//! Le the mean of the emission's channels: a scene's tiny lamp and its big glowing wall each get
//! samples in proportion to what they light (pbrt-v4's `PowerLightSampler`).
//!
//! # Emitters sampled where they can be seen: the closed room
//!
//! The original's rooms are 200 wide under ceilings of `range 1000`: sampled whole, 95% of a
//! ceiling's samples would land where no shading point sees it. So when the camera stands in a
//! closed room ([`closed_room`]), every emitter is clipped to that room.
//!
//! A *wall* is an untransformed plane whose normal lies along an axis and whose material can
//! only reflect: not refractive, or, with a type map (which sets the type texel by texel, at
//! the nearest texel), no texel of it glass. Its front half-space is the closed side its
//! normal points to. A room B is the box cut out by six walls, one per side (x ≥ ·, x ≤ ·,
//! y ≥ ·, ...), each of which has the camera's eye and, for a thin lens, the whole square of
//! half-size `lens_radius` around it on the lens plane (which holds the lens disk) strictly in
//! front, by more than the tolerance t below. The room is *closed* when each side's face (the
//! rectangle of its wall's plane spanned by B's four other sides) lies within that wall's range
//! square (`|p - n offset| <= range`, boundary included as in plane.h; the original's rooms
//! fit it exactly: case2's ceiling, floor and side walls end at z = 1000, the front wall's
//! plane).
//! Of the walls on a side, the one nearest the camera is tried first, and passed over for the
//! next while its square does not cover its face: a nearer wall only shrinks the other faces,
//! so a wall passed over never covers its face later, and this finds the smallest closed room
//! if there is one (a lamp panel hung under the ceiling leaves the ceiling to close the room).
//!
//! Claim: in a closed room, every ray a path follows starts in B and every point it reaches is
//! in B. Primary rays start on the eye or the lens square, inside B. A ray from inside B whose
//! segment to its first hit left B would cross, at the point where it first leaves, a face of
//! B inside its wall's square, from the wall's front: the one-sided plane is hit there
//! (plane.h), so the first hit was no later, in B. A path that reaches a wall arrives from its
//! front and leaves to its front (material.h reflects diffuse and mirror directions to the
//! arriving side of the geometric normal, bump maps included; walls do not refract), and its
//! spawn point is offset to that side (ray.h). Objects inside or poking through walls change
//! nothing: the proof is about where rays cross the walls, whatever they pass inside.
//!
//! Hence: a light sample at a point q outside B is occluded from every shading point p (in B):
//! the shadow ray meets a wall where it first leaves B, before q, and a ray meets a flat
//! emitter (plane square or triangle) at one point only, so the wall is not the emitter at q.
//! And BSDF sampling never reaches an emitter outside B. So each plane emitter is sampled over
//! the part of it in B only: its parallelogram (the square under its transform) is clipped to
//! B as a polygon, in its own edge parameters (a, b) of `corner + edge1·a + edge2·b`, and the
//! light becomes the parameter rectangle bounding that polygon: still a parallelogram, holding
//! every point of the emitter in B, with `area` the clipped area that nee.h's `light_pdf`
//! divides by. Light sampling then integrates over the clipped region only what it integrated
//! over the whole square (the rest is occluded), and the MIS weight of a BSDF hit uses that
//! density exactly, since BSDF hits outside the region cannot happen: no kernel change. An
//! emitter wholly outside B, or facing away from all of B (one-sided: seen from behind only),
//! is dropped; so is a mesh triangle wholly outside B (a triangle partly inside is kept whole:
//! its sampling is a triangle's).
//!
//! The tolerance: B is grown by t = 1e-5 × the largest coordinate among the candidate walls'
//! planes and the camera's points (at least 1e-5) on every side before clipping, and the camera
//! must be more than t in front of its walls; t is some 10 times the rounding-error bound of a
//! plane hit point (ray.h, plane.h) and some 100 f32 ulps, so hit points rounded off a face
//! and f32 light samples stay inside the grown box. The proof is in exact arithmetic apart from
//! that: a path can still slip through a wall where another surface lies within rounding error
//! of it (a ball touching the floor, a surface coplanar with a wall) or through a seam within
//! rounding error of a face's edge on its square's boundary, as it could before; only such
//! paths, of negligible measure, can reach what clipping leaves out. When no closed room holds
//! the camera, nothing is clipped.
//!
//! # Walls that emit: sampled by solid angle
//!
//! An emitting wall of the closed room (a lit ceiling, as in the original's rooms) is marked
//! `solid_angle`: nee.h samples it uniformly in the solid angle it subtends (Ureña, Fajardo
//! and King 2013) rather than by area, since shading points come right up to it, where
//! r² / cos varies most across it (ceiling_room's relMSE at equal samples about halves). A
//! wall is untransformed, so its clipped light is a rectangle, as the mapping needs. Other
//! rectangles (a panel hung in the room, lights of scenes without a closed room) keep area
//! sampling, which costs less: nee.h says why.
//!
//! # Sphere lights sunk into walls: the visible cap
//!
//! smallpt's light is a sphere of radius 600 sunk all but 0.27 into the ceiling: sampled by the
//! cone it subtends, nearly every light sample aims at the part buried in the ceiling. Two kinds
//! of surface hide part of a sphere light from every path, and each leaves it a cap:
//! - a wall of the closed room (above): no path vertex leaves the room, so what lies beyond a
//!   wall's plane is unseen; a plane cuts a sphere in a cap;
//! - another sphere S, untransformed, whose material only reflects (as a wall's), when the eye
//!   and the whole lens lie strictly on one side of it: a path reaching S is sent back to the
//!   side it came from (its spawn point offset to that side), so no vertex ever lies on the
//!   other side, and a segment from a vertex to a point of the light on the other side crosses
//!   S and is blocked. Two spheres meet in a circle, so what lies on the camera's side of S is a
//!   cap. smallpt's walls are such spheres, of radius 1e5, with the room inside them.
//!
//! Each such cap holds every point of the light that any path can see, so the smallest of them
//! does too (`visible_cap`); it is grown by the room's tolerance, or by 4 f32 ulps of S's
//! coordinates (the device's sphere is S rounded to f32), and a light no path can see is
//! dropped. A cap of at most a hemisphere is sampled uniformly by area (kernels/nee.h), its
//! `area` the cap's, its power π Le times it; the light's pdf for a BSDF hit there is the same
//! area density. Larger caps are sampled as the whole sphere, by its cone, which serves them
//! better (a cap's back side, seen from a point, is hidden by its front).

use crate::contract::{self, Light, Material, MeshDesc, TextureMap, Transform};
use crate::elements::camera::CameraBasis;
use glam::{DMat3, DVec3};

/// What the light list reads of a packed scene.
pub struct LightSources<'a> {
    /// Where primary rays start: the room emitters are clipped to must hold its eye and lens.
    pub camera: &'a CameraBasis,
    pub materials: &'a [Material],
    /// Texture maps and their texels: a wall's type map must hold no glass.
    pub maps: &'a [TextureMap],
    pub texels: &'a [u8],
    pub spheres: &'a [contract::Sphere],
    pub planes: &'a [contract::Plane],
    pub transforms: &'a [Transform],
    pub meshes: &'a [MeshDesc],
    pub mesh_instances: &'a [contract::MeshInstance],
    pub triangles: &'a [[u32; 3]],
    pub vertices: &'a [[f32; 3]],
}

/// What gathers every kind's light-list entries, each with its power (`crate::shapes::emitters`,
/// above this layer).
pub type Emitters = fn(&LightSources, Option<&Room>, &mut Vec<(Light, f64)>);

/// The light list, sorted by (kind, index, triangle), its `prob` and `cdf` filled in; its
/// plane emitters clipped to `room` and its emitters wholly outside it dropped (module doc).
pub fn collect_lights(scene: &LightSources, room: Option<&Room>, kinds: Emitters) -> Vec<Light> {
    let mut emitters = Vec::new();
    kinds(scene, room, &mut emitters);
    emitters.retain(|(_, power)| *power > 0.0 && power.is_finite());
    pick_by_power(emitters)
}

/// The light list: entries sorted by (kind, index, triangle), so that a hit finds its own by
/// binary search (nee.h), each picked with probability proportional to its power.
fn pick_by_power(emitters: Vec<(Light, f64)>) -> Vec<Light> {
    let (lights, powers): (Vec<Light>, Vec<f64>) = emitters.into_iter().unzip();
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

/// One line for `clpt render -v`: how many spheres, squares and triangles the list holds, and
/// the room its emitters are clipped to (in the scene's coordinates, the device's moved back by
/// the camera-relative `origin`).
pub fn report(lights: &[Light], room: Option<&Room>, origin: DVec3) -> String {
    let count = |kind| lights.iter().filter(|l| l.kind == kind).count();
    let clipped = match room {
        Some(r) => {
            // In the scene's coordinates: the device's are relative to `origin`.
            let (lo, hi) = (r.lo + origin, r.hi + origin);
            format!(
                "clipped to the closed room [{}, {}] x [{}, {}] x [{}, {}] (planes {:?})",
                lo.x, hi.x, lo.y, hi.y, lo.z, hi.z, r.walls
            )
        }
        None => "no closed room around the camera: emitters sampled whole".to_string(),
    };
    format!(
        "light list: {} spheres, {} plane squares, {} triangles; {clipped}",
        count(contract::OBJECT_SPHERE),
        count(contract::OBJECT_PLANE),
        count(contract::OBJECT_MESH)
    )
}

/// The room's tolerance, relative to the largest coordinate of its candidate walls and camera.
pub const ROOM_TOLERANCE: f64 = 1e-5;

/// The unit square and triangle in edge parameters (a, b) of `corner + edge1 a + edge2 b`.
pub(crate) const SQUARE: [[f64; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
pub(crate) const TRIANGLE: [[f64; 2]; 3] = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];

/// A closed room around the camera (module doc): no path leaves the box `lo..hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Room {
    pub lo: DVec3,
    pub hi: DVec3,
    /// How far the box is grown on every side before emitters are clipped to it.
    pub tolerance: f64,
    /// The walls' plane indices, sides in the order x ≥, x ≤, y ≥, y ≤, z ≥, z ≤.
    pub walls: [u32; 6],
}

impl Room {
    /// The rectangle [a0, a1] x [b0, b1] in [0, 1]^2 bounding the points `corner + e1 a + e2 b`
    /// of the convex `polygon` (given in (a, b)) inside the grown box, as [a0, a1, b0, b1], or
    /// None if no point is: the polygon clipped by the box's six sides (Sutherland-Hodgman),
    /// each side a linear function of (a, b). Corners inside are kept exactly, so an emitter
    /// wholly inside comes back as [0, 1, 0, 1].
    pub fn clip(
        &self,
        corner: DVec3,
        e1: DVec3,
        e2: DVec3,
        polygon: &[[f64; 2]],
    ) -> Option<[f64; 4]> {
        let mut poly = polygon.to_vec();
        for k in 0..3 {
            let sides = [
                (1.0, self.lo[k] - self.tolerance),
                (-1.0, self.hi[k] + self.tolerance),
            ];
            for (sign, bound) in sides {
                // f >= 0 inside this side.
                let f = |p: [f64; 2]| sign * (corner[k] + e1[k] * p[0] + e2[k] * p[1] - bound);
                let mut out = Vec::with_capacity(poly.len() + 1);
                for (i, &p) in poly.iter().enumerate() {
                    let q = poly[(i + 1) % poly.len()];
                    let (fp, fq) = (f(p), f(q));
                    if fp >= 0.0 {
                        out.push(p);
                    }
                    if (fp >= 0.0) != (fq >= 0.0) {
                        let s = fp / (fp - fq);
                        out.push([p[0] + (q[0] - p[0]) * s, p[1] + (q[1] - p[1]) * s]);
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return None;
                }
            }
        }
        let bound = |c: usize, pick: fn(f64, f64) -> f64, start: f64| {
            poly.iter().map(|p| p[c]).fold(start, pick).clamp(0.0, 1.0)
        };
        Some([
            bound(0, f64::min, f64::INFINITY),
            bound(0, f64::max, f64::NEG_INFINITY),
            bound(1, f64::min, f64::INFINITY),
            bound(1, f64::max, f64::NEG_INFINITY),
        ])
    }

    /// Whether the one-sided plane through `point` with front `normal` has every point of the
    /// box on or behind it, so that nothing in the room sees its front: light samples there
    /// have a cosine of at most 0 (up to rounding, at grazing angles, where they carry nothing).
    pub fn faces_away(&self, point: DVec3, normal: DVec3) -> bool {
        // The box's corner farthest along the normal.
        let far = DVec3::select(normal.cmpge(DVec3::ZERO), self.hi, self.lo);
        (far - point).dot(normal) <= 0.0
    }
}

/// The smallest closed room of walls around the camera, if there is one (module doc).
pub fn closed_room(scene: &LightSources) -> Option<Room> {
    let eye = eye_points(scene.camera);
    // Candidate walls: (side, plane coordinate, range, plane index); side 2k + 1 for x_k <= c.
    let mut walls = Vec::new();
    for (i, p) in scene.planes.iter().enumerate() {
        let Some(m) = scene.materials.get(p.material as usize) else {
            continue;
        };
        let Some(k) = p.axis() else {
            continue;
        };
        let nk = f64::from(p.normal[k]);
        let c = f64::from(p.offset) / nk;
        let range = f64::from(p.range);
        if p.transform != contract::TRANSFORM_NONE
            || !reflects_only(scene, m)
            || !c.is_finite()
            || range.is_nan()
            || range < 0.0
        {
            continue;
        }
        walls.push((
            2 * k + usize::from(nk < 0.0),
            c,
            range,
            dvec(p.center),
            i as u32,
        ));
    }
    let scale = eye
        .iter()
        .map(|p| p.abs().max_element())
        .chain(walls.iter().map(|w| w.1.abs()))
        .fold(1.0, f64::max);
    let tolerance = ROOM_TOLERANCE * scale;
    if !tolerance.is_finite() {
        return None;
    }
    // Per side, the walls with every eye point more than the tolerance in front, nearest first.
    let mut sides: [Vec<(f64, f64, DVec3, u32)>; 6] = Default::default();
    for (side, c, range, center, i) in walls {
        let k = side / 2;
        let upper = side % 2 == 1;
        if eye
            .iter()
            .all(|p| if upper { c - p[k] } else { p[k] - c } > tolerance)
        {
            sides[side].push((c, range, center, i));
        }
    }
    for (side, walls) in sides.iter_mut().enumerate() {
        walls.sort_by(|a, b| {
            if side % 2 == 1 {
                a.0.total_cmp(&b.0)
            } else {
                b.0.total_cmp(&a.0)
            }
        });
    }
    // Pass over each side's wall while its square does not cover its face: under looser walls
    // elsewhere the face only grows, so a wall passed over never becomes usable again.
    let mut pick = [0usize; 6];
    loop {
        let mut chosen = [(0.0, 0.0, DVec3::ZERO, 0u32); 6];
        for side in 0..6 {
            chosen[side] = *sides[side].get(pick[side])?;
        }
        let lo = DVec3::new(chosen[0].0, chosen[2].0, chosen[4].0);
        let hi = DVec3::new(chosen[1].0, chosen[3].0, chosen[5].0);
        let mut closed = true;
        for side in 0..6 {
            let (_, range, center, _) = chosen[side];
            let covered = (0..3)
                .filter(|&j| j != side / 2)
                .all(|j| lo[j] >= center[j] - range && hi[j] <= center[j] + range);
            if !covered {
                pick[side] += 1;
                closed = false;
            }
        }
        if closed {
            return Some(Room {
                lo,
                hi,
                tolerance,
                walls: chosen.map(|w| w.3),
            });
        }
    }
}

/// What paths can see of a sphere light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Visible {
    Nothing,
    Whole,
    /// The points q of the sphere with (q - centre)·axis >= radius - height, height < radius.
    Cap {
        axis: DVec3,
        height: f64,
    },
}

/// The part of sphere light `light` (centre c, radius r) that paths can see (module doc, "Sphere
/// lights sunk into walls"): the smallest of the caps that the room's walls and the other
/// opaque spheres leave it, when that is at most a hemisphere (larger caps are sampled as the
/// whole sphere, by the cone it subtends, which serves them better).
pub fn visible_cap(
    scene: &LightSources,
    room: Option<&Room>,
    light: usize,
    c: DVec3,
    r: f64,
) -> Visible {
    // (axis, a): the visible points are those with (q - c)·axis >= a.
    let mut best: Option<(DVec3, f64)> = None;
    let mut consider = |axis: DVec3, a: f64| {
        if best.is_none_or(|(_, b)| a > b) {
            best = Some((axis, a));
        }
    };
    if let Some(room) = room {
        // The room grown by its tolerance, as emitters are clipped to it.
        for k in 0..3 {
            let unit = DVec3::AXES[k];
            consider(unit, room.lo[k] - room.tolerance - c[k]);
            consider(-unit, c[k] - room.hi[k] - room.tolerance);
        }
    }
    let eye = eye_points(scene.camera);
    for (j, s) in scene.spheres.iter().enumerate() {
        let Some(m) = scene.materials.get(s.material as usize) else {
            continue;
        };
        if j == light || s.transform != contract::TRANSFORM_NONE || !reflects_only(scene, m) {
            continue;
        }
        let (c2, r2) = (s.center_f64(), s.radius_f64());
        // Rounding of the device's sphere (f32 centre, double-float distance test, refined
        // hits): a few f32 ulps of its coordinates.
        let tolerance = 4.0 * f64::from(f32::EPSILON) * (c2.abs().max_element() + r2);
        let inside = |p: &DVec3| (*p - c2).length() < r2 - tolerance;
        let outside = |p: &DVec3| (*p - c2).length() > r2 + tolerance;
        let d = (c2 - c).length();
        if d.is_nan() || d <= 0.0 {
            // Concentric: the light lies wholly on one side of S.
            let light_inside = r < r2 - tolerance;
            let light_outside = r > r2 + tolerance;
            if (light_inside && eye.iter().all(outside))
                || (light_outside && eye.iter().all(inside))
            {
                return Visible::Nothing;
            }
            continue;
        }
        let u = (c2 - c) / d;
        // A point q of the light is inside S iff (q - c)·u > a0 (|q - c2|² = r² + d² - 2 d (q - c)·u).
        let a0 = ((d - r2) * (d + r2) + r * r) / (2.0 * d);
        if eye.iter().all(inside) {
            consider(u, a0 - tolerance); // paths stay inside S
        } else if eye.iter().all(outside) {
            consider(-u, -a0 - tolerance); // paths stay outside S
        }
    }
    match best {
        Some((_, a)) if a >= r => Visible::Nothing,
        Some((axis, a)) if a > 0.0 => Visible::Cap {
            axis,
            height: r - a,
        },
        _ => Visible::Whole,
    }
}

/// The camera's eye point, and for a thin lens the corners of the square around it that holds
/// the lens: every primary ray starts in their convex hull.
fn eye_points(cam: &CameraBasis) -> Vec<DVec3> {
    let mut eye = vec![cam.origin];
    let r = cam.lens_radius.abs();
    if r > 0.0 {
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            eye.push(cam.origin + cam.lens_u * (r * su) + cam.lens_v * (r * sv));
        }
    }
    eye
}

/// Whether every point of a surface of material m reflects paths back to the side they came
/// from (diffuse or mirror, nowhere glass): its type, or every texel of its type map
/// (pathtracer.cl `material_at` reads type maps at the nearest texel, unfiltered).
fn reflects_only(scene: &LightSources, m: &Material) -> bool {
    if m.type_map == contract::MAP_NONE {
        return m.kind != contract::MATERIAL_REFRACTIVE;
    }
    let Some(map) = scene.maps.get(m.type_map as usize) else {
        return false;
    };
    let start = map.offset as usize;
    let end = start + map.width as usize * map.height as usize;
    map.format == contract::MAP_TYPE8
        && scene.texels.get(start..end).is_some_and(|types| {
            !types
                .iter()
                .any(|&t| u32::from(t) == contract::MATERIAL_REFRACTIVE)
        })
}

/// The mean channel of a material's emission, if it emits a constant (unmapped) radiance.
pub(crate) fn constant_emission(materials: &[Material], material: u32) -> Option<f64> {
    let m = materials.get(material as usize)?;
    let le = m.emission.iter().map(|&e| f64::from(e)).sum::<f64>() / 3.0;
    (m.emission.iter().any(|&e| e > 0.0) && m.emission_map == contract::MAP_NONE).then_some(le)
}

pub(crate) fn dvec(v: [f32; 3]) -> DVec3 {
    DVec3::from(v.map(f64::from))
}

/// An object's transform as the device applies it (its f32 rows, computed in f64).
pub(crate) struct Affine {
    linear: DMat3,
    translation: DVec3,
    inverse: DMat3,
}

impl Affine {
    pub(crate) fn of(transforms: &[Transform], index: u32) -> Affine {
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

    pub(crate) fn point(&self, p: DVec3) -> DVec3 {
        self.linear * p + self.translation
    }

    pub(crate) fn vector(&self, v: DVec3) -> DVec3 {
        self.linear * v
    }

    /// A normal's world direction (the inverse transpose), not normalised.
    pub(crate) fn normal(&self, n: DVec3) -> DVec3 {
        self.inverse.transpose() * n
    }

    /// The scale of a similarity (orthogonal columns of one length, to f32 rounding), or None.
    pub(crate) fn uniform_scale(&self) -> Option<f64> {
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
