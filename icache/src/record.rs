//! Irradiance records: what a final gather returns ([`NewRecord`]), what the cache stores ([`Record`])
//! and what a lookup interpolates from them ([`Lookup`]).
//!
//! Three shapes of nearly the same fields, each for a reason. The gather crate's `GatherResult` is what
//! the hemisphere says (irradiance, gradients, distances, noise) and knows no pixel; a [`NewRecord`] is
//! that result placed: position, normal, pixel footprint and where to gather again. The cache is a
//! leaf that cannot see the gather crate, so the root crate makes that one conversion, in the one
//! function that gathers for a record. A [`Record`] is a `NewRecord` after insertion: repaired, its R
//! limited by the gradient and neighbor clamping, R' clamped to the pixel spacing, ∇t scaled to R', and
//! `r_min` (informational) dropped; its 33 floats are what cache files hold.
#![forbid(unsafe_code)]

use glam::Vec3;

/// The result of one final gather at a shading point, plus the pixel footprint there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewRecord {
    pub pos: Vec3,
    /// Unit surface normal on the side the gather sampled.
    pub normal: Vec3,
    /// RGB irradiance.
    pub e: Vec3,
    /// Rotational gradient, one vector per colour channel (Ward & Heckbert 1992).
    pub grad_r: [Vec3; 3],
    /// Translational gradient, one vector per colour channel.
    pub grad_t: [Vec3; 3],
    /// Harmonic mean of the gather's hit distances (infinite when every ray missed).
    pub r_harmonic: f32,
    /// Smallest hit distance of the gather (informational; spacing uses `r_harmonic`).
    pub r_min: f32,
    /// Dominant incoming direction (radiance-weighted mean of the gather directions).
    pub dir: Vec3,
    /// World-space size of one pixel projected on the tangent plane at `pos`.
    pub pixel_world: f32,
    /// The gather's own estimate of E's relative standard error (luminance; 0 when unknown).
    pub rel_err: f32,
    /// Where the gather was made: pixel x, y and the index of the pixel's shading point ([`NO_PIXEL`]
    /// when the caller does not say), so that it can gather there again ([`crate::IrradianceCache::refine`]).
    pub at: [u32; 3],
}

/// [`NewRecord::at`] of a gather made nowhere the caller can find again.
pub const NO_PIXEL: [u32; 3] = [u32::MAX; 3];

/// A record as stored in the cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    pub pos: Vec3,
    pub normal: Vec3,
    pub e: Vec3,
    pub grad_r: [Vec3; 3],
    /// Translational gradient, already scaled by R/R' where R < R' (so extrapolation stays ≥ 0).
    pub grad_t: [Vec3; 3],
    /// R: the harmonic-mean distance after the gradient limit and neighbor clamping, unclamped.
    pub r_harmonic: f32,
    /// R' in world units: `r_harmonic` clamped to the pixel-based spacing bounds.
    pub r_clamped: f32,
    pub dir: Vec3,
    pub pixel_world: f32,
    /// As [`NewRecord::rel_err`]: lowered by [`crate::IrradianceCache::refine`]; not kept in files (0 there).
    pub rel_err: f32,
    /// As [`NewRecord::at`]; not kept in files ([`NO_PIXEL`] there).
    pub at: [u32; 3],
}

impl Record {
    /// Spacing radius in pixels at the record's depth (for statistics and record images).
    pub fn radius_px(&self) -> f32 {
        self.r_clamped / self.pixel_world
    }

    /// The record's bits, for exact comparisons (determinism tests) and files.
    pub fn to_bits(&self) -> [u32; RECORD_FLOATS] {
        let mut out = [0u32; RECORD_FLOATS];
        for (o, f) in out.iter_mut().zip(self.to_floats()) {
            *o = f.to_bits();
        }
        out
    }

    /// Flattened fields in file order.
    pub(crate) fn to_floats(self) -> [f32; RECORD_FLOATS] {
        let mut v = [0.0f32; RECORD_FLOATS];
        let mut i = 0;
        let mut put = |x: Vec3| {
            v[i..i + 3].copy_from_slice(&x.to_array());
            i += 3;
        };
        put(self.pos);
        put(self.normal);
        put(self.e);
        self.grad_r.iter().for_each(|g| put(*g));
        self.grad_t.iter().for_each(|g| put(*g));
        put(self.dir);
        v[i] = self.r_harmonic;
        v[i + 1] = self.r_clamped;
        v[i + 2] = self.pixel_world;
        v
    }

    /// Inverse of [`Record::to_floats`].
    pub(crate) fn from_floats(v: &[f32; RECORD_FLOATS]) -> Record {
        let at = |i: usize| Vec3::new(v[i], v[i + 1], v[i + 2]);
        Record {
            pos: at(0),
            normal: at(3),
            e: at(6),
            grad_r: [at(9), at(12), at(15)],
            grad_t: [at(18), at(21), at(24)],
            dir: at(27),
            r_harmonic: v[30],
            r_clamped: v[31],
            pixel_world: v[32],
            rel_err: 0.0,
            at: NO_PIXEL,
        }
    }
}

/// Number of f32 values in a serialised record.
pub(crate) const RECORD_FLOATS: usize = 33;

/// An interpolated irradiance and what it was made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    /// RGB irradiance, every channel ≥ 0.
    pub e: Vec3,
    /// Number of usable records.
    pub n_used: u32,
    pub weight_sum: f32,
}

/// A gather's noise estimate as a record keeps it: 0 (unknown) unless finite and non-negative.
pub(crate) fn finite_rel_err(x: f32) -> f32 {
    if x.is_finite() && x >= 0.0 {
        x
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_round_trip() {
        let r = Record {
            pos: Vec3::new(1.0, 2.0, 3.0),
            normal: Vec3::Z,
            e: Vec3::splat(0.5),
            grad_r: [Vec3::X, Vec3::Y, Vec3::Z],
            grad_t: [Vec3::ONE, -Vec3::ONE, Vec3::splat(2.0)],
            r_harmonic: f32::INFINITY,
            r_clamped: 0.25,
            dir: Vec3::Y,
            pixel_world: 0.01,
            rel_err: 0.0,
            at: NO_PIXEL,
        };
        assert_eq!(Record::from_floats(&r.to_floats()), r);
    }
}
