//! Record weights (Ward 1988, Tabellion–Lamorlette 2004) and the tests that make a record usable at a point:
//! facing the same way, not in front of the point (Ward's behind test), weight above the acceptance threshold.
#![forbid(unsafe_code)]

use glam::Vec3;

use crate::params::{CacheParams, Pass, Weighting};
use crate::record::Record;

/// Behind-test tolerance as a fraction of R'ᵢ: small enough to reject a record clearly in front of p,
/// large enough that records on a gently curved surface (where p sits slightly off the tangent plane) pass.
pub(crate) const BEHIND_EPS_FRACTION: f32 = 0.05;

/// √(1 − cos 10°): TL's normalisation of the normal-deviation term (10° of deviation gives ε_n = 1).
pub(crate) fn tl_normal_scale() -> f32 {
    (1.0 - 10f32.to_radians().cos()).sqrt()
}

/// Ward's weight bound at the record itself (the formula is infinite there): the denominator is floored.
const WARD_MIN_DENOM: f32 = 1e-6;

/// Ward 1988: w = 1 / (d/R' + √(1 − n·nᵢ)); unbounded, floored at 1/`WARD_MIN_DENOM`.
pub(crate) fn ward_weight(dist: f32, r_clamped: f32, n_dot: f32) -> f32 {
    let denom = dist / r_clamped + (1.0 - n_dot).max(0.0).sqrt();
    1.0 / denom.max(WARD_MIN_DENOM)
}

/// Tabellion–Lamorlette 2004: w = 1 − κ max(ε_p, ε_n), ε_p = d/(R'/2), ε_n = √(1 − n·nᵢ)/√(1 − cos 10°).
/// Bounded by 1 and reaching 0 at the border of the record's area of influence.
pub(crate) fn tl_weight(dist: f32, r_clamped: f32, n_dot: f32, kappa: f32) -> f32 {
    let eps_p = dist / (0.5 * r_clamped);
    let eps_n = (1.0 - n_dot).max(0.0).sqrt() / tl_normal_scale();
    1.0 - kappa * eps_p.max(eps_n)
}

/// Ward's behind test: true when record `rec` lies in front of p, i.e. p is below the mean tangent plane
/// of the record by more than `BEHIND_EPS_FRACTION` R'ᵢ — the record's hemisphere saw another environment.
pub(crate) fn is_in_front(rec: &Record, p: Vec3, n: Vec3) -> bool {
    let d = (p - rec.pos).dot(0.5 * (n + rec.normal));
    d < -BEHIND_EPS_FRACTION * rec.r_clamped
}

/// Above-test fraction of R: a point higher over the record's plane than `ABOVE_FRACTION` R (the
/// harmonic mean distance of what its gather saw, before any pixel clamp) is another layer — the next
/// slat of a blind, 3 cm over a record whose gather looked into that slat. The pixel clamp makes such
/// records reach across several slats; without this test the slats came out 4 % too bright. Pass B's
/// last resort (`Pass::Extrapolate`) waives it: a sample on a sub-pixel slat with no record of its own
/// takes its neighbours' rather than a gather of its own.
pub(crate) const ABOVE_FRACTION: f32 = 0.5;

/// True when p lies above the record's tangent plane by more than [`ABOVE_FRACTION`] of its R.
pub(crate) fn is_above(rec: &Record, p: Vec3) -> bool {
    (p - rec.pos).dot(rec.normal) > ABOVE_FRACTION * rec.r_harmonic
}

/// The record's weight at (p, n) if it is usable there for `pass`, else `None`.
pub(crate) fn usable_weight(
    params: &CacheParams,
    pass: Pass,
    rec: &Record,
    p: Vec3,
    n: Vec3,
) -> Option<f32> {
    let n_dot = n.dot(rec.normal);
    if n_dot <= 0.0 || is_in_front(rec, p, n) || (pass != Pass::Extrapolate && is_above(rec, p)) {
        return None;
    }
    let dist = (p - rec.pos).length();
    // Extrapolation keeps the distance term only (full normal agreement in the weight).
    let n_dot = if pass == Pass::Extrapolate {
        if n_dot < crate::params::EXTRAPOLATE_MIN_COS {
            return None;
        }
        1.0
    } else {
        n_dot
    };
    let w = match params.weight {
        Weighting::TabellionLamorlette => {
            let w = tl_weight(dist, rec.r_clamped, n_dot, params.kappa(pass));
            (w > 0.0).then_some(w)
        }
        Weighting::Ward => {
            let w = ward_weight(dist, rec.r_clamped, n_dot);
            (w > 1.0 / params.a(pass)).then_some(w)
        }
    }?;
    w.is_finite().then_some(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec_at(pos: Vec3, normal: Vec3, r: f32) -> Record {
        Record {
            pos,
            normal,
            e: Vec3::ONE,
            grad_r: [Vec3::ZERO; 3],
            grad_t: [Vec3::ZERO; 3],
            r_harmonic: r,
            r_clamped: r,
            dir: normal,
            pixel_world: r / 10.0,
            rel_err: 0.0,
            at: crate::record::NO_PIXEL,
        }
    }

    #[test]
    fn tl_bounded_and_zero_at_border() {
        let k = 1.0;
        // At the record: exactly 1.
        assert_eq!(tl_weight(0.0, 2.0, 1.0, k), 1.0);
        // Never above 1 anywhere.
        for i in 0..100 {
            let d = i as f32 * 0.02;
            let w = tl_weight(d, 2.0, 1.0 - i as f32 * 1e-4, k);
            assert!(w <= 1.0);
        }
        // Border of influence at d = R'/(2κ) = 1: weight 0 (to f32 rounding).
        assert!(tl_weight(1.0, 2.0, 1.0, k).abs() < 1e-6);
        // κ = 0.5 reaches twice as far.
        assert!(tl_weight(2.0, 2.0, 1.0, 0.5).abs() < 1e-6);
        // Normal deviation of 10° alone is the border too.
        let c = 10f32.to_radians().cos();
        assert!(tl_weight(0.0, 2.0, c, k).abs() < 1e-5);
    }

    #[test]
    fn ward_unbounded_with_hard_edge() {
        assert!(ward_weight(0.0, 1.0, 1.0) >= 1e5);
        // Decreasing with distance.
        assert!(ward_weight(0.1, 1.0, 1.0) > ward_weight(0.2, 1.0, 1.0));
        // Acceptance at w > 1/a is a hard edge: the weight just inside is ≈ 1/a, not 0.
        let p = CacheParams {
            weight: Weighting::Ward,
            accuracy: 0.5,
            ..Default::default()
        };
        let r = rec_at(Vec3::ZERO, Vec3::Z, 1.0);
        let inside = usable_weight(&p, Pass::A, &r, Vec3::new(0.499, 0.0, 0.0), Vec3::Z).unwrap();
        assert!((inside - 2.0).abs() < 0.01);
        assert!(usable_weight(&p, Pass::A, &r, Vec3::new(0.501, 0.0, 0.0), Vec3::Z).is_none());
    }

    #[test]
    fn behind_test_rejects_record_in_front() {
        let p = CacheParams::default();
        // Query on the floor z = 0; a record 0.3 above the floor within reach lies in front of the query.
        let r = rec_at(Vec3::new(0.1, 0.0, 0.3), Vec3::Z, 4.0);
        assert!(is_in_front(&r, Vec3::ZERO, Vec3::Z));
        assert!(usable_weight(&p, Pass::A, &r, Vec3::ZERO, Vec3::Z).is_none());
        // A record below the query (query in front of it) is accepted.
        let r = rec_at(Vec3::new(0.1, 0.0, -0.05), Vec3::Z, 4.0);
        assert!(!is_in_front(&r, Vec3::ZERO, Vec3::Z));
        assert!(usable_weight(&p, Pass::A, &r, Vec3::ZERO, Vec3::Z).is_some());
    }

    #[test]
    fn extrapolation_waives_the_normal_term_down_to_60_degrees() {
        let p = CacheParams::default();
        let r = rec_at(Vec3::ZERO, Vec3::Z, 4.0);
        let tilted = |deg: f32| Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos());
        // 30°: beyond pass B's ~20° normal reach, within extrapolation's 60°.
        assert!(usable_weight(&p, Pass::B, &r, Vec3::new(0.1, 0.0, 0.0), tilted(30.0)).is_none());
        let w = usable_weight(
            &p,
            Pass::Extrapolate,
            &r,
            Vec3::new(0.1, 0.0, 0.0),
            tilted(30.0),
        )
        .unwrap();
        // The weight is pass B's for the distance alone.
        assert_eq!(
            Some(w),
            usable_weight(&p, Pass::B, &r, Vec3::new(0.1, 0.0, 0.0), Vec3::Z)
        );
        assert!(usable_weight(
            &p,
            Pass::Extrapolate,
            &r,
            Vec3::new(0.1, 0.0, 0.0),
            tilted(65.0)
        )
        .is_none());
        // The reach is pass B's: 4 · a_B = 4 (TL weight zero at the border).
        assert!(usable_weight(
            &p,
            Pass::Extrapolate,
            &r,
            Vec3::new(4.1, 0.0, 0.0),
            tilted(30.0)
        )
        .is_none());
    }

    #[test]
    fn a_point_far_above_the_record_is_another_layer() {
        let p = CacheParams::default();
        // R = 0.06 (a gather that saw a slat 3 cm over it), reach clamped up to 0.4.
        let mut r = rec_at(Vec3::ZERO, Vec3::Z, 0.06);
        r.r_clamped = 0.4;
        assert!(usable_weight(&p, Pass::B, &r, Vec3::new(0.05, 0.0, 0.02), Vec3::Z).is_some());
        assert!(usable_weight(&p, Pass::B, &r, Vec3::new(0.05, 0.0, 0.04), Vec3::Z).is_none());
        assert!(usable_weight(&p, Pass::A, &r, Vec3::new(0.05, 0.0, 0.04), Vec3::Z).is_none());
        // The last resort before a gather of its own still takes it.
        assert!(usable_weight(
            &p,
            Pass::Extrapolate,
            &r,
            Vec3::new(0.05, 0.0, 0.04),
            Vec3::Z
        )
        .is_some());
    }

    #[test]
    fn opposite_facing_rejected() {
        let p = CacheParams::default();
        let r = rec_at(Vec3::ZERO, -Vec3::Z, 4.0);
        assert!(usable_weight(&p, Pass::B, &r, Vec3::ZERO, Vec3::Z).is_none());
    }
}
