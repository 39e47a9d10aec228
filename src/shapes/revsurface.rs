//! Surfaces of revolution (kernels/revsurface.h): the profile's Bezier segments, heights
//! centred on 0 with the shift folded into the transform, so that the solver's tolerances are
//! relative to the profile's own size (the packing module's doc). Light sampling does not pick
//! them: BSDF sampling finds an emitting one.

use super::{HostShape, MeshFiles, ObjectPlace, Placement, ShapeSyntax, all_finite, transform_box};
use crate::accel::aabb::Aabb;
use crate::contract::{self, RevSurface};
use crate::elements::curve::Curve;
use crate::elements::syntax::{self, Cursor, Token};
use crate::error::Result;
use crate::pack::PackedScene;
use glam::{DMat4, DVec3};

/// `RevSurface { profile ... }`: the profile curve revolved about the y axis.
#[derive(Clone, Debug, PartialEq)]
pub struct RevSurfaceShape {
    pub curve: Curve,
}

impl ShapeSyntax for RevSurfaceShape {
    const KEYWORDS: &'static [&'static str] = &["RevSurface"];
    const KIND: u32 = contract::OBJECT_REVSURFACE;

    /// `RevSurface { profile BezierCurve|BsplineCurve { controls [ x y z ] ... } }`: a profile
    /// in the xy-plane, revolved about the y axis.
    fn parse<'a>(cur: &mut Cursor<'a>, keyword: Token<'a>) -> syntax::Result<Self> {
        cur.open_block(keyword)?;
        let mut curve = None;
        let close = loop {
            let key = cur.field()?;
            match key.text {
                "}" => break key,
                "profile" => cur.once(&mut curve, key, |c| c.curve())?,
                _ => return Err(cur.unknown_field(key, keyword, &["profile", "}"])),
            }
        };
        Ok(RevSurfaceShape {
            curve: cur.required(curve, "profile", keyword, close)?,
        })
    }
}

impl HostShape for RevSurfaceShape {
    fn pack(
        &self,
        packed: &mut PackedScene,
        object: &ObjectPlace,
        _: &mut MeshFiles,
    ) -> Result<usize> {
        let at = &object.at;
        let segments = self.curve.bezier_segments();
        let points = || segments.iter().flatten();
        let (y_min, y_max) = points().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.y), hi.max(p.y))
        });
        let y_mid = 0.5 * (y_min + y_max);
        let placement = DMat4::from_translation(DVec3::new(0.0, y_mid, 0.0));
        let centred = Some(at.transform.copied().unwrap_or(*at.to_device) * placement)
            .filter(|m| *m != DMat4::IDENTITY);
        let stored: Vec<[f32; 2]> = points()
            .map(|p| [p.x as f32, (p.y - y_mid) as f32])
            .collect();
        let (radius, y_lo, y_hi) = stored.iter().fold(
            (0.0f32, f32::INFINITY, f32::NEG_INFINITY),
            |(r, lo, hi), p| (r.max(p[0].abs()), lo.min(p[1]), hi.max(p[1])),
        );
        let first_point = packed.rev_points.len();
        let hulls = segment_hulls(&stored, self.curve.degree() + 1);
        let groups = group_hulls(&hulls, contract::REV_GROUP as usize);
        let revsurface = RevSurface {
            first_point: first_point as u32,
            first_hull: (first_point + stored.len()) as u32,
            num_segments: segments.len() as u32,
            degree: self.curve.degree() as u32,
            material: object.material,
            transform: packed.push_transform(centred.as_ref()),
            radius,
            y_lo,
            y_hi,
        };
        packed.rev_points.extend(stored);
        packed.rev_points.extend(hulls);
        packed.rev_points.extend(groups);
        packed.revsurfaces.push(revsurface);
        Ok(packed.revsurfaces.len() - 1)
    }

    /// The profile's box revolved, under the object's whole move to the device.
    fn world_bounds(&self, _: &PackedScene, _: usize, at: &Placement) -> Aabb {
        let world = at.transform.copied().unwrap_or(*at.to_device);
        transform_box(&self.curve.revolution_bounds(), Some(&world))
    }

    /// Its profile's points as stored.
    fn finite(&self, packed: &PackedScene, index: usize) -> bool {
        let r = &packed.revsurfaces[index];
        let first = r.first_point as usize;
        let count = r.num_segments as usize * (r.degree as usize + 1);
        all_finite(packed.rev_points[first..first + count].iter().flatten())
    }
}

/// Each segment's hull, the box of its `per_segment` control points (`points`, as stored), as
/// two float2: (x_lo, x_hi) and (y_lo, y_hi). The programs test a ray against a segment's
/// hull revolved before they set up the segment's root isolation, whose first step would test
/// the same box (kernels/revsurface.h, `rev_hull_reachable`).
fn segment_hulls(points: &[[f32; 2]], per_segment: usize) -> Vec<[f32; 2]> {
    points
        .chunks_exact(per_segment)
        .flat_map(|segment| {
            let hull = |axis: usize| {
                segment.iter().fold([f32::INFINITY, f32::NEG_INFINITY], |[lo, hi], p| {
                    [lo.min(p[axis]), hi.max(p[axis])]
                })
            };
            [hull(0), hull(1)]
        })
        .collect()
}

/// The hulls of groups of `per_group` consecutive segments (the last group's of those left),
/// each the union of its segments' `hulls` in their form. The programs test a group's hull
/// before its segments' (kernels/revsurface.h, `rev_group_reachable`): a ray that misses it
/// is spared their tests. The union's revolved solid holds each member's, so a group's test
/// passes wherever one of its segments' would.
fn group_hulls(hulls: &[[f32; 2]], per_group: usize) -> Vec<[f32; 2]> {
    hulls
        .chunks(2 * per_group)
        .flat_map(|group| {
            let union = |axis: usize| {
                group
                    .chunks_exact(2)
                    .fold([f32::INFINITY, f32::NEG_INFINITY], |[lo, hi], h| {
                        [lo.min(h[axis][0]), hi.max(h[axis][1])]
                    })
            };
            [union(0), union(1)]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{group_hulls, segment_hulls};

    #[test]
    fn each_segment_hull_is_its_control_points_box() {
        // Two quadratic segments sharing a point.
        let points = [[0.0, -1.0], [2.0, 0.5], [1.0, 1.0], [1.0, 1.0], [-0.5, 3.0], [0.25, 2.0]];
        assert_eq!(
            segment_hulls(&points, 3),
            vec![[0.0, 2.0], [-1.0, 1.0], [-0.5, 1.0], [1.0, 3.0]]
        );
    }

    #[test]
    fn each_group_hull_is_its_segments_hulls_union() {
        // Five segments' hulls in groups of two: the last group holds one.
        let hulls = [
            [[0.0, 1.0], [0.0, 1.0]],
            [[0.5, 3.0], [-2.0, 0.5]],
            [[-1.0, 0.0], [4.0, 5.0]],
            [[1.0, 2.0], [3.0, 6.0]],
            [[7.0, 8.0], [-9.0, -8.0]],
        ];
        let flat: Vec<[f32; 2]> = hulls.iter().flatten().copied().collect();
        assert_eq!(
            group_hulls(&flat, 2),
            vec![[0.0, 3.0], [-2.0, 1.0], [-1.0, 2.0], [3.0, 6.0], [7.0, 8.0], [-9.0, -8.0]]
        );
    }
}
