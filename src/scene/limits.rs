//! The physical range of every scene value, checked when the scene is loaded (README: "What is
//! validated, and the limits"). The bounds keep every derived quantity finite in f32: differences of
//! positions, the scene's extent squared, light power and photon power.

use glam::{DVec3, Vec3};

/// Largest |coordinate| of a vertex (after its mesh transform), the camera eye, a light position.
/// Two such points differ by at most 2e15 per axis; the extent squared (≈ 1.2e31) stays finite.
pub const MAX_COORD: f32 = 1e15;
/// Largest emission (`Ke`, `emission`), point or spot `intensity` or directional `irradiance`, per channel.
pub(crate) const MAX_EMISSION: f32 = 1e20;
/// Largest total emitted power of the scene (W), so that photon powers and their sums stay finite.
pub(crate) const MAX_POWER: f64 = 1e35;
/// Largest Phong exponent (`Ns`, `exponent`); the lobe is a delta well before.
pub(crate) const MAX_EXPONENT: f32 = 1e6;
/// Largest index of refraction (`Ni`, `ior`); diamond is 2.42.
pub(crate) const MAX_IOR: f32 = 10.0;

/// Why a reflectance-like colour (albedo, Kd, Ks, reflectance, transmittance, Tf) is out of [0, 1].
pub(crate) fn unit_interval(v: [f32; 3]) -> Option<String> {
    v.iter()
        .find(|x| !(**x >= 0.0 && **x <= 1.0))
        .map(|x| format!("{x} is outside [0, 1] (a fraction of the light that arrives)"))
}

/// Why an emission-like colour is not finite, negative, or above [`MAX_EMISSION`].
pub(crate) fn emission(v: [f32; 3]) -> Option<String> {
    v.iter()
        .find(|x| !(**x >= 0.0 && **x <= MAX_EMISSION))
        .map(|x| format!("{x} is outside [0, {MAX_EMISSION:e}]"))
}

/// Why a position is not finite or beyond ±[`MAX_COORD`].
pub(crate) fn position(v: Vec3) -> Option<String> {
    if v.is_finite() && v.abs().max_element() <= MAX_COORD {
        None
    } else {
        Some(format!(
            "({}, {}, {}) is beyond the coordinate limit ±{MAX_COORD:e}",
            v.x, v.y, v.z
        ))
    }
}

/// `b − a` normalised in f64, so that any two finite f32 points give a unit vector (their difference or
/// its square may overflow f32); `None` when they are equal or not finite.
pub(crate) fn direction_between(a: Vec3, b: Vec3) -> Option<Vec3> {
    unit(b.as_dvec3() - a.as_dvec3())
}

/// `v` normalised in f64 (`[0, -1e20, -1e20]` is fine); `None` for a zero or non-finite vector.
pub(crate) fn direction(v: Vec3) -> Option<Vec3> {
    unit(v.as_dvec3())
}

fn unit(d: DVec3) -> Option<Vec3> {
    let len = d.length();
    (d.is_finite() && len > 0.0 && len.is_finite()).then(|| (d / len).as_vec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_survive_overflowing_f32() {
        let d = direction(Vec3::new(0.0, -1e20, -1e20)).unwrap();
        assert!((d - Vec3::new(0.0, -1.0, -1.0).normalize()).length() < 1e-6);
        let d = direction_between(Vec3::new(0.0, 0.0, 3e38), Vec3::new(0.0, 0.0, -3e38)).unwrap();
        assert_eq!(d, Vec3::new(0.0, 0.0, -1.0));
        assert!(direction(Vec3::ZERO).is_none());
        assert!(
            position(Vec3::new(0.0, 1e19, 0.0)).is_some() && position(Vec3::splat(1e15)).is_none()
        );
        assert!(
            unit_interval([0.0, 1.0, 0.5]).is_none() && unit_interval([0.0, 1.0001, 0.5]).is_some()
        );
        assert!(
            unit_interval([f32::NAN, 0.0, 0.0]).is_some()
                && emission([f32::INFINITY, 0.0, 0.0]).is_some()
        );
    }
}
