//! Cache parameters, and how the one `accuracy` knob maps onto Ward's `a` and
//! Tabellion–Lamorlette's κ.
//!
//! `accuracy` *is* Ward's `a`: with Ward's weight a record is usable where
//! |p − pᵢ|/R'ᵢ + √(1 − n·nᵢ) < a, so on a flat surface it reaches a·R'ᵢ. With the TL weight a record
//! reaches R'ᵢ/(2κ) (ε_p = d/(R'/2)). We set κ = 1/(2a) so both weightings reach the same distance
//! for the same `accuracy`. Defaults: a = 0.5 in pass A (κ = 1, the TL fill value) and [`PASS_B_REACH`] = 1.5
//! times that in pass B (a = 0.75, κ = 2/3: some smoothing). Records reaching twice their pass-A
//! distance (κ = 0.5) are extrapolated by their gradients too far: against reference renders they
//! left walls visibly bright; 1.5 times keeps the smoothing without that bias. With Ward's weight
//! those `a` are loose in the normal term (√(1 − n·nᵢ) < 0.5 accepts 41°); Ward users should lower
//! `accuracy` (e.g. 0.2–0.3).
#![forbid(unsafe_code)]

use crate::error::{Error, Result};

/// Which weighting function interpolation uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weighting {
    /// Tabellion & Lamorlette 2004: bounded, zero at the border (default).
    TabellionLamorlette,
    /// Ward, Rubinstein & Clear 1988: unbounded at the record, hard edge at w = 1/a.
    Ward,
}

/// Which pass a lookup serves: the fill pass (A) or the shading pass (B, larger `a`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    A,
    B,
    /// Pass B's fallback where no record interpolates: the same reach, but the normal term waived
    /// down to `EXTRAPOLATE_MIN_COS`. At the silhouette of a curved surface the normal turns by
    /// tens of degrees within a pixel, past what any record of the pixel lattice allows; such
    /// samples were most of the pass-B misses, each a full gather.
    Extrapolate,
}

/// The least cosine between a record's normal and the query's that [`Pass::Extrapolate`] accepts
/// (60°).
pub(crate) const EXTRAPOLATE_MIN_COS: f32 = 0.5;

/// Irradiance cache settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheParams {
    /// Ward's `a` for pass A (see the module header for the TL mapping). Default 0.5 (κ = 1).
    pub accuracy: f32,
    pub weight: Weighting,
    /// Křivánek 2006 neighbor clamping of R on insertion. Default on.
    pub neighbor_clamping: bool,
    /// Use the rotational and translational gradients in interpolation. Default on.
    pub gradients: bool,
    /// R'ᵢ ≥ this many pixels (projected at the record). Default 3 (TL's production value).
    pub min_spacing_px: f32,
    /// R'ᵢ ≤ this many pixels. Default 20 (TL's production value).
    pub max_spacing_px: f32,
    /// Ward's `a` for pass B; `None` means the pass-A value. Default `Some(0.75)` (κ = 2/3).
    pub pass_b_accuracy: Option<f32>,
    /// Adaptive caching (Křivánek et al. 2006): `Some(τ)` starts every record with `ADAPTIVE_START`
    /// times its reach and halves a record's reach (down to the plain one) where the records usable
    /// at a pass-A point disagree by more than the Weber fraction τ of their mean luminance; `None`
    /// is off.
    pub adaptive: Option<f32>,
}

/// Reach of a new record under adaptive caching, as a multiple of its plain reach (R' and both
/// pixel spacing bounds).
pub(crate) const ADAPTIVE_START: f32 = 2.0;
/// Pass B's default `a` as a multiple of pass A's: records reach 1.5 times as far when shading as
/// when filling.
pub const PASS_B_REACH: f32 = 1.5;
/// Default `accuracy` (pass A's `a`).
pub(crate) const DEFAULT_ACCURACY: f32 = 0.5;
/// Default Weber threshold of adaptive caching (`[render.icache] adaptive_threshold`).
pub const DEFAULT_WEBER: f32 = 0.1;

impl Default for CacheParams {
    fn default() -> Self {
        CacheParams {
            accuracy: DEFAULT_ACCURACY,
            weight: Weighting::TabellionLamorlette,
            neighbor_clamping: true,
            gradients: true,
            min_spacing_px: 3.0,
            max_spacing_px: 20.0,
            pass_b_accuracy: Some(PASS_B_REACH * DEFAULT_ACCURACY),
            adaptive: None,
        }
    }
}

impl CacheParams {
    /// Reject values that would make the cache meaningless (NaN, non-positive, inverted ranges).
    /// Pass B must be at least as loose as pass A, so that pass-A coverage implies pass-B coverage.
    pub fn validate(&self) -> Result<()> {
        let bad = |s: String| Err(Error::InvalidParams(s));
        if !(self.accuracy.is_finite() && self.accuracy > 0.0) {
            return bad(format!(
                "accuracy must be finite and > 0, got {}",
                self.accuracy
            ));
        }
        if !(self.min_spacing_px.is_finite() && self.min_spacing_px > 0.0) {
            return bad(format!(
                "min_spacing_px must be finite and > 0, got {}",
                self.min_spacing_px
            ));
        }
        if !(self.max_spacing_px.is_finite() && self.max_spacing_px >= self.min_spacing_px) {
            return bad(format!(
                "max_spacing_px must be finite and ≥ min_spacing_px ({}), got {}",
                self.min_spacing_px, self.max_spacing_px
            ));
        }
        if let Some(t) = self.adaptive {
            if !(t.is_finite() && t > 0.0) {
                return bad(format!(
                    "adaptive threshold must be finite and > 0, got {t}"
                ));
            }
        }
        if let Some(b) = self.pass_b_accuracy {
            if !(b.is_finite() && b >= self.accuracy) {
                return bad(format!(
                    "pass_b_accuracy must be finite and ≥ accuracy ({}), got {b}",
                    self.accuracy
                ));
            }
        }
        Ok(())
    }

    /// Ward's `a` for a pass.
    pub(crate) fn a(&self, pass: Pass) -> f32 {
        match pass {
            Pass::A => self.accuracy,
            Pass::B | Pass::Extrapolate => self.pass_b_accuracy.unwrap_or(self.accuracy),
        }
    }

    /// Tabellion–Lamorlette κ for a pass: κ = 1/(2a).
    pub(crate) fn kappa(&self, pass: Pass) -> f32 {
        0.5 / self.a(pass)
    }

    /// How far a record reaches on its tangent plane, as a multiple of R'ᵢ, in the loosest pass.
    pub(crate) fn support_factor(&self) -> f32 {
        // Ward: d < a R'; TL: d < R'/(2κ) = a R'. The same by construction of κ.
        self.a(Pass::A).max(self.a(Pass::B))
    }

    /// Radius factor the spatial index uses: the support, and at least R' itself because neighbor
    /// clamping looks for records whose R' spheres overlap.
    /// Reach multiple of a new record: [`ADAPTIVE_START`] under adaptive caching, else 1.
    pub(crate) fn start_scale(&self) -> f32 {
        if self.adaptive.is_some() {
            ADAPTIVE_START
        } else {
            1.0
        }
    }

    pub(crate) fn index_factor(&self) -> f32 {
        self.support_factor().max(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_kappas() {
        let p = CacheParams::default();
        p.validate().unwrap();
        assert_eq!(p.kappa(Pass::A), 1.0);
        assert!((p.kappa(Pass::B) - 2.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn invalid_params_rejected() {
        let mut p = CacheParams {
            accuracy: f32::NAN,
            ..Default::default()
        };
        assert!(p.validate().is_err());
        p.accuracy = 0.5;
        p.pass_b_accuracy = Some(0.25);
        assert!(p.validate().is_err());
        p.pass_b_accuracy = None;
        p.max_spacing_px = 1.0;
        assert!(p.validate().is_err());
    }
}
