//! Validation gathers: pass A gathers at some points its records already cover, compares the gather
//! with what each of those records says there, and shrinks the records that are wrong by more than
//! the gathers' noise allows, so that they no longer reach that point (the repair sweeps then cover
//! what they gave up).
//!
//! Interpolation is biased where a record cannot see what changes its light within its reach: a
//! ceiling running into the 2 cm gap over a light panel is read from a record outside the gap, whose
//! hemisphere barely sees the panel's back, at twice the gap's true irradiance. Such a bias is no
//! noise: averaging passes of a progressive render does not remove it. A gather at a covered point
//! measures it, and where it exceeds the noise of the two gathers the records that made it retreat.
//! Which points are checked is a hash of the seed and the point, so a fill stays deterministic and
//! another seed checks other points.
#![forbid(unsafe_code)]

use glam::Vec3;

use crate::cache::{IrradianceCache, Shrink};
use crate::params::Pass;
use crate::record::{NewRecord, Record};
use crate::stats::InsertStats;

/// Validation of pass A's covered points (off unless set with [`IrradianceCache::set_validation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Validation {
    /// Share of covered points gathered to check their records, in [0, 1].
    pub fraction: f32,
    /// Chooses the points: another seed, other points.
    pub seed: u64,
    /// Relative difference allowed beyond the gathers' noise (3 standard errors of both).
    pub tolerance: f32,
}

/// Standard errors of the two gathers' difference a record may be off by before it retreats.
const NOISE_SIGMAS: f32 = 3.0;
/// A record off by this many times its allowed error has its other points checked too.
const SPREAD_ERRORS: f32 = 4.0;
/// A retreating record reaches to this fraction of the distance where its error was last allowed.
const RETREAT: f32 = 0.95;

impl Validation {
    /// Whether shading point `i` of pixel (x, y) is checked.
    pub(crate) fn selects(&self, x: u32, y: u32, i: usize) -> bool {
        let key = (u64::from(x) << 40) ^ (u64::from(y) << 16) ^ i as u64;
        let h = mix(self.seed ^ mix(key));
        ((h >> 40) as f32) < self.fraction * (1u64 << 24) as f32
    }
}

/// SplitMix64's finaliser.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

fn luminance(e: Vec3) -> f32 {
    pmbase::luminance(e.max(Vec3::ZERO))
}

impl IrradianceCache {
    /// Checks pass A's covered points as `v` says from now on (`None`: never).
    pub fn set_validation(&mut self, v: Option<Validation>) {
        self.validation = v.filter(|v| v.fraction > 0.0);
    }

    /// The validation set, if any.
    pub(crate) fn validation(&self) -> Option<Validation> {
        self.validation
    }

    /// Compares gather `new`, made at a point the cache already covered, with each record that pass B
    /// would read there (those `visible` accepts), and shrinks every one that is off by more than the
    /// noise of both gathers and the tolerance, so that it no longer reaches the point in either pass.
    /// Returns the statistics (a check, whether it failed, the records shrunk) and the records shrunk
    /// that were off by [`SPREAD_ERRORS`] times what is allowed or more: a gap that no record of the
    /// lattice sees into, whose other points the repair sweeps check (those of a smaller error would
    /// spread the checks over every crease of the image for a few per cent).
    pub(crate) fn validate_with(
        &mut self,
        new: &NewRecord,
        visible: impl Fn(u32, &Record) -> bool,
    ) -> (InsertStats, Vec<u32>) {
        let mut stats = InsertStats {
            n_validated: 1,
            ..InsertStats::default()
        };
        let Some(v) = self.validation else {
            return (stats, Vec::new());
        };
        let (p, n) = (new.pos, new.normal);
        let l_new = luminance(new.e);
        // (record, the distance from it within which its error stays allowed, whether it is off by
        // so much that its other points are checked too).
        let mut wrong: Vec<(u32, f32, bool)> = Vec::new();
        self.each_used(p, n, Pass::B, usize::MAX, visible, |id, _, e| {
            let rec = &self.records[id as usize];
            let l = luminance(e);
            let noise = (l_new * new.rel_err).hypot(l * rec.rel_err);
            let allowed = v.tolerance * l.max(l_new) + NOISE_SIGMAS * noise;
            let error = (l - l_new).abs();
            if error > allowed {
                // An extrapolation's error grows about linearly with the distance from its record.
                let reach = (p - rec.pos).length() * allowed / error;
                wrong.push((id, reach, error > SPREAD_ERRORS * allowed));
            }
        });
        if wrong.is_empty() {
            return (stats, Vec::new());
        }
        stats.n_validation_failed = 1;
        // Out of reach in the loosest pass: TL reaches R'/(2κ) = a·R', Ward a·R' (see `params`).
        let reach = self.params.support_factor();
        let mut suspects = Vec::new();
        for (id, dist, far_off) in wrong {
            if self.shrink_to(id, RETREAT * dist / reach) {
                stats.n_shrunk_validation += 1;
                if far_off {
                    suspects.push(id);
                }
            }
        }
        (stats, suspects)
    }

    /// Lowers record `id`'s R' to `r` (not below its least spacing), logging the shrink for the
    /// repair sweeps; false when it is frozen or no larger already.
    fn shrink_to(&mut self, id: u32, r: f32) -> bool {
        if (id as usize) < self.frozen {
            return false;
        }
        let floor = self.params.min_spacing_px * self.records[id as usize].pixel_world;
        let rec = &mut self.records[id as usize];
        let r = r.max(floor);
        if !(r < rec.r_clamped) {
            return false;
        }
        if let Some(log) = &mut self.shrink_log {
            log.push(Shrink::of(id, rec));
        }
        rec.r_clamped = r;
        self.reindex(id);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cache_tests::new_rec;
    use crate::CacheParams;

    /// A cache holding one record of irradiance 1 at the origin, reaching 1.5 in pass B (R' 2, 20
    /// pixels of 0.1), with 2 % gather noise.
    fn one_record() -> IrradianceCache {
        let mut c =
            IrradianceCache::new(Vec3::splat(-5.0), Vec3::splat(5.0), CacheParams::default())
                .unwrap();
        c.set_validation(Some(Validation {
            fraction: 1.0,
            seed: 0,
            tolerance: 0.05,
        }));
        c.insert(NewRecord {
            rel_err: 0.02,
            ..new_rec(Vec3::ZERO, Vec3::Z, Vec3::ONE, 2.0, 0.1)
        });
        c
    }

    fn check(c: &mut IrradianceCache, at: Vec3, e: f32) -> (InsertStats, Vec<u32>) {
        let new = NewRecord {
            rel_err: 0.02,
            ..new_rec(at, Vec3::Z, Vec3::splat(e), 1.0, 0.1)
        };
        c.validate_with(&new, |_, _| true)
    }

    #[test]
    fn a_record_within_the_noise_keeps_its_reach() {
        let mut c = one_record();
        let p = Vec3::new(0.8, 0.0, 0.0);
        // 1.08 against 1: inside 5 % + 3 standard errors of the two gathers (about 8.4 %).
        let (stats, shrunk) = check(&mut c, p, 1.08);
        assert_eq!((stats.n_validated, stats.n_validation_failed), (1, 0));
        assert!(shrunk.is_empty());
        assert_eq!(c.records()[0].r_clamped, 2.0);
        assert!(c.lookup(p, Vec3::Z, Pass::B).is_some());
    }

    #[test]
    fn a_record_wrong_at_a_point_retreats_from_it_in_both_passes() {
        let mut c = one_record();
        let p = Vec3::new(0.8, 0.0, 0.0);
        // The gap's case: a quarter of what the record says.
        let (stats, suspects) = check(&mut c, p, 0.25);
        assert_eq!(stats.n_validation_failed, 1);
        assert_eq!(stats.n_shrunk_validation, 1);
        // Off by far more than allowed: its other points are to be checked too.
        assert_eq!(suspects, vec![0]);
        for pass in [Pass::A, Pass::B] {
            assert!(c.lookup(p, Vec3::Z, pass).is_none(), "{pass:?}");
        }
        // It keeps the points near it, where its error is within what is allowed.
        assert!(c
            .lookup(Vec3::new(0.1, 0.0, 0.0), Vec3::Z, Pass::B)
            .is_some());
    }

    #[test]
    fn a_record_at_its_least_spacing_stays_there() {
        let mut c = one_record();
        // The least spacing, 3 pixels of 0.1, stops it at 0.3.
        let (_, _) = check(&mut c, Vec3::new(0.01, 0.0, 0.0), 0.0);
        assert!((c.records()[0].r_clamped - 0.3).abs() < 1e-6);
    }

    #[test]
    fn a_fraction_of_the_points_is_chosen_and_the_seed_moves_them() {
        let v = Validation {
            fraction: 0.25,
            seed: 7,
            tolerance: 0.05,
        };
        let w = Validation { seed: 8, ..v };
        let (mut n, mut same) = (0, 0);
        for y in 0..100 {
            for x in 0..100 {
                n += v.selects(x, y, 0) as u32;
                same += (v.selects(x, y, 0) && w.selects(x, y, 0)) as u32;
            }
        }
        assert!((2300..2700).contains(&n), "{n} of 10000 chosen");
        // Independent choices share a quarter of the chosen points.
        assert!((450..800).contains(&same), "{same} chosen by both seeds");
    }
}
