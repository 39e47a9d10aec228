//! The camera's basis (host side of camera.cuh): smallpt's image plane, computed in f64 from the
//! scene file's `PerspectiveCamera` and handed to the device as `contract::Camera`.
//!
//! d = normalize(direction), a = angle in radians, cx = (w a / h, 0, 0) (always world +x),
//! cy = normalize(cx x d) a. The vertical field of view is therefore 2 atan(a / 2), not `angle`:
//! that is the original's (and smallpt's) model, kept so its scene files frame the same picture.

use super::CameraDesc;
use crate::contract;
use crate::error::{Error, Result};
use glam::DVec3;

/// The largest image clpt renders, in pixels.
pub const MAX_PIXELS: u64 = 1 << 30;

/// The unit viewing direction of a camera's `direction`, or why it cannot frame an image (the
/// parser reports this at the scene's `direction`, [`CameraBasis::new`] for cameras made in
/// code): it must be nonzero (of any finite length) and not parallel to the x axis, as
/// smallpt's basis takes cx along world +x and cy = normalize(cx x d).
pub fn forward(direction: DVec3) -> std::result::Result<DVec3, String> {
    let forward = super::unit_vector(direction)
        .ok_or_else(|| "camera direction must be a non-zero vector".to_string())?;
    if DVec3::X.cross(forward).length() < 1e-9 {
        return Err(
            "camera direction is parallel to the x axis: smallpt's camera basis \
                    (cx along world +x) cannot frame it"
                .into(),
        );
    }
    Ok(forward)
}

/// The image-plane vectors of a camera, in f64 (the f64 reference in the tests uses them too).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraBasis {
    pub origin: DVec3,
    pub forward: DVec3,
    pub cx: DVec3,
    pub cy: DVec3,
    pub lens_u: DVec3,
    pub lens_v: DVec3,
    pub lens_radius: f64,
    pub focus_distance: f64,
    pub width: u32,
    pub height: u32,
}

impl CameraBasis {
    pub fn new(desc: &CameraDesc) -> Result<CameraBasis> {
        let forward = forward(desc.direction).map_err(Error::Invalid)?;
        if desc.width == 0 || desc.height == 0 {
            return Err(Error::Invalid(
                "image width and height must be positive".into(),
            ));
        }
        // Kernels index pixels with 32-bit integers; 2^30 pixels is also 32 GiB of film.
        if desc.width as u64 * desc.height as u64 > MAX_PIXELS {
            return Err(Error::Invalid(format!(
                "image of {}x{} pixels is larger than clpt's limit of {MAX_PIXELS} pixels",
                desc.width, desc.height
            )));
        }
        let a = desc.angle_deg.to_radians();
        let cx = DVec3::new(desc.width as f64 * a / desc.height as f64, 0.0, 0.0);
        let up = cx.cross(forward);
        let cy = up.normalize() * a;
        let thin_lens = desc.flength > 0.0;
        Ok(CameraBasis {
            origin: desc.center,
            forward,
            cx,
            cy,
            lens_u: (cx - forward * cx.dot(forward)).normalize(),
            lens_v: cy.normalize(),
            lens_radius: if thin_lens { desc.aperture } else { 0.0 },
            focus_distance: if thin_lens { desc.flength } else { 0.0 },
            width: desc.width,
            height: desc.height,
        })
    }

    /// The f32 copy the kernels read.
    pub fn to_device(&self) -> contract::Camera {
        let v = |d: DVec3| d.as_vec3().to_array();
        contract::Camera {
            origin: v(self.origin),
            forward: v(self.forward),
            cx: v(self.cx),
            cy: v(self.cy),
            lens_u: v(self.lens_u),
            lens_v: v(self.lens_v),
            lens_radius: self.lens_radius as f32,
            focus_distance: self.focus_distance as f32,
            width: self.width,
            height: self.height,
        }
    }
}
