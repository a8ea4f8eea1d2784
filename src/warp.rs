//! Mappings from the unit square to directions and points, with their densities.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Orthonormal basis around a unit vector (Duff et al. 2017).
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Expresses a local direction (z up) in the frame of `n`.
pub fn to_world(n: Vec3, local: Vec3) -> Vec3 {
    let (t, b) = onb(n);
    t * local.x + b * local.y + n * local.z
}

pub fn concentric_disk(u: [f32; 2]) -> Vec2 {
    let o = Vec2::new(2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, PI / 4.0 * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y))
    };
    Vec2::new(r * theta.cos(), r * theta.sin())
}

/// Cosine-weighted direction about +z; pdf = cos θ / π.
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Uniform direction on the sphere; pdf = 1 / 4π.
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction inside the cone of half-angle acos(cos_max) about +z; pdf = 1 / (2π (1 − cos_max)).
pub fn uniform_cone(u: [f32; 2], cos_max: f32) -> Vec3 {
    let cos_t = 1.0 - u[0] * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Uniform barycentrics (b0, b1) on a triangle.
pub fn uniform_triangle(u: [f32; 2]) -> (f32, f32) {
    let s = u[0].sqrt();
    (1.0 - s, u[1] * s)
}

pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Rec. 709 luminance of a linear RGB value (one definition for the whole workspace).
pub use pmbase::luminance;
