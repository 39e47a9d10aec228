//! The f64 → f32 conversions packing rounds through: plain, and double-float (a value and
//! the f32 rounding of what its f32 rounding leaves).

use glam::{DMat4, DVec3};

pub fn f32x3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

/// `v` as a double-float: its f32 rounding and the f32 rounding of what that leaves.
pub fn split_f32(v: f64) -> (f32, f32) {
    let hi = v as f32;
    (hi, (v - f64::from(hi)) as f32)
}

pub fn split_f32x3(v: DVec3) -> ([f32; 3], [f32; 3]) {
    let [(x, xl), (y, yl), (z, zl)] = v.to_array().map(split_f32);
    ([x, y, z], [xl, yl, zl])
}

/// The top three rows of a 4x4 matrix, row by row.
pub fn rows3x4(m: &DMat4) -> [f32; 12] {
    let mut out = [0.0f32; 12];
    for r in 0..3 {
        for c in 0..4 {
            out[r * 4 + c] = m.col(c)[r] as f32;
        }
    }
    out
}
