//! The few pieces the member crates share and none of them owns: the binary file container of photon-map
//! and cache files ([`container`]), Rec. 709 [`luminance`], and [`summable!`] for statistics structs
//! that merge field by field.
//!
//! A leaf below `photon` and `icache` (which stay leaves towards each other): it knows no renderer
//! type, only bytes, colours and sums.
#![forbid(unsafe_code)]
#![warn(unreachable_pub)]

pub mod container;
mod summable;

use glam::Vec3;

/// The floor of the squared reference value in the relMSE, (x − r)² / (r² + `REL_MSE_FLOOR`): every
/// accuracy figure is measured with it, and the noise estimates that predict those figures use it too.
pub const REL_MSE_FLOOR: f64 = 0.01;

/// Rec. 709 luminance of a linear RGB value.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_weights_sum_to_one() {
        assert_eq!(luminance(Vec3::ZERO), 0.0);
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert_eq!(luminance(Vec3::Y), 0.7152);
    }
}
