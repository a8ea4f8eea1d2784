//! Statistics of insertion, lookups and the fill pass, as plain structs with `AddAssign`.
#![forbid(unsafe_code)]

use std::ops::AddAssign;

use crate::record::Lookup;

pmbase::summable! {
    /// What happened to records on insertion (summed over insertions).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct InsertStats {
        pub n_inserted: u64,
        /// Rejected: non-finite position or normal, zero normal, or a non-positive pixel footprint.
        pub n_rejected: u64,
        /// Inputs with NaN/Inf/negative irradiance, gradients or distance that were repaired.
        pub n_sanitized: u64,
        /// New records whose R the gradient limit R ≤ E/|∇t E| lowered.
        pub n_shrunk_by_gradient: u64,
        /// Records (new or existing) whose R neighbor clamping lowered, counted once per insertion.
        pub n_shrunk_by_neighbors: u64,
        /// New records whose R was below R_min (R' = R_min) or above R_max (R' = R_max).
        pub n_clamped_min: u64,
        pub n_clamped_max: u64,
        /// Halvings of a record's R' by adaptive caching (records disagreeing at a pass-A point).
        pub n_shrunk_adaptive: u64,
        /// Gathers at covered pass-A points that checked the records there ([`crate::Validation`]).
        pub n_validated: u64,
        /// Checks that found a record off by more than the gathers' noise.
        pub n_validation_failed: u64,
        /// Records those checks shrunk out of reach of the point.
        pub n_shrunk_validation: u64,
    }
}

pmbase::summable! {
    /// Lookups made by a caller (pass B): fold per thread and merge.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct LookupStats {
        pub n_lookups: u64,
        pub n_misses: u64,
        /// Lookups answered by a single record: extrapolated, not interpolated (the blotches of a sparse cache).
        pub n_single_record: u64,
        /// Misses answered by records whose normal differs more than interpolation allows (`Pass::Extrapolate`).
        pub n_extrapolated: u64,
        /// Misses that no record could answer: the caller gathered for the sample alone.
        pub n_gathered: u64,
        /// Sum over lookups of the usable records used.
        pub n_records_used: u64,
        /// Of the lookups, those the caller answered from an earlier sample of the same pixel on the same
        /// surface (counted as that sample's lookup was: hit, miss, extrapolated, …).
        pub n_reused: u64,
        /// Lookups answered at a bumped normal: records weighted by the smooth normal, their
        /// irradiance turned to the bumped one ([`crate::IrradianceCache::each_used_turned`]).
        pub n_bump_rotated: u64,
    }
}

impl LookupStats {
    /// What happened since `before` (field by field).
    pub fn since(&self, before: &LookupStats) -> LookupStats {
        LookupStats {
            n_lookups: self.n_lookups - before.n_lookups,
            n_misses: self.n_misses - before.n_misses,
            n_single_record: self.n_single_record - before.n_single_record,
            n_extrapolated: self.n_extrapolated - before.n_extrapolated,
            n_gathered: self.n_gathered - before.n_gathered,
            n_records_used: self.n_records_used - before.n_records_used,
            n_reused: self.n_reused - before.n_reused,
            n_bump_rotated: self.n_bump_rotated - before.n_bump_rotated,
        }
    }

    /// Counts `earlier` again, as lookups answered by reuse.
    pub fn replay(&mut self, earlier: &LookupStats) {
        *self += *earlier;
        self.n_reused += earlier.n_lookups;
    }

    pub fn record(&mut self, hit: Option<&Lookup>) {
        self.n_lookups += 1;
        match hit {
            Some(l) => {
                self.n_records_used += l.n_used as u64;
                self.n_single_record += (l.n_used == 1) as u64;
            }
            None => self.n_misses += 1,
        }
    }
}

/// What the pass-A fill did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FillStats {
    pub n_pixels: u64,
    /// Pass A visited every `pass_a_stride`-th pixel in x and y (0: not a pass A).
    pub pass_a_stride: u32,
    /// Pixels pass A did not visit between covered lattice pixels ([`crate::PassAPixels::LatticeThenGaps`]).
    pub n_pixels_skipped: u64,
    /// Shading points examined (a pixel may have several, or none).
    pub n_points: u64,
    /// Coverage lookups, including the re-checks before insertion and the repair sweeps.
    pub lookups: LookupStats,
    pub n_gathers: u64,
    /// Gathered, but covered by a record inserted earlier in the same wave, so not inserted.
    pub n_skipped_covered: u64,
    pub n_waves: u64,
    /// Full-image sweeps after the hierarchical pass that re-covered points uncovered by neighbor clamping.
    pub n_repair_sweeps: u64,
    /// Points still uncovered when the sweep limit was reached (should be 0).
    pub n_uncovered_after: u64,
    pub insert: InsertStats,
}

impl AddAssign for FillStats {
    fn add_assign(&mut self, o: Self) {
        self.n_pixels += o.n_pixels;
        self.pass_a_stride = self.pass_a_stride.max(o.pass_a_stride);
        self.n_pixels_skipped += o.n_pixels_skipped;
        self.n_points += o.n_points;
        self.lookups += o.lookups;
        self.n_gathers += o.n_gathers;
        self.n_skipped_covered += o.n_skipped_covered;
        self.n_waves += o.n_waves;
        self.n_repair_sweeps += o.n_repair_sweeps;
        self.n_uncovered_after += o.n_uncovered_after;
        self.insert += o.insert;
    }
}

/// Number of logarithmic bins of the radius histogram.
pub const RADIUS_BINS: usize = 10;

/// Distribution of R' in pixels, log-spaced bins over [lo, hi] (values outside go to the end bins).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusHistogram {
    pub lo_px: f32,
    pub hi_px: f32,
    pub counts: [u64; RADIUS_BINS],
    pub n: u64,
    pub min_px: f32,
    pub max_px: f32,
    pub sum_px: f64,
}

impl RadiusHistogram {
    pub fn new(lo_px: f32, hi_px: f32) -> Self {
        RadiusHistogram {
            lo_px,
            hi_px: hi_px.max(lo_px * 1.0001),
            counts: [0; RADIUS_BINS],
            n: 0,
            min_px: f32::INFINITY,
            max_px: 0.0,
            sum_px: 0.0,
        }
    }

    /// Lower edge of bin `i` (bin i spans [edge(i), edge(i + 1))).
    pub fn edge(&self, i: usize) -> f32 {
        self.lo_px * (self.hi_px / self.lo_px).powf(i as f32 / RADIUS_BINS as f32)
    }

    pub fn add(&mut self, radius_px: f32) {
        if !radius_px.is_finite() {
            return;
        }
        let t = (radius_px / self.lo_px).ln() / (self.hi_px / self.lo_px).ln();
        let bin = ((t * RADIUS_BINS as f32).floor().max(0.0) as usize).min(RADIUS_BINS - 1);
        self.counts[bin] += 1;
        self.n += 1;
        self.min_px = self.min_px.min(radius_px);
        self.max_px = self.max_px.max(radius_px);
        self.sum_px += radius_px as f64;
    }

    pub fn mean_px(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.sum_px / self.n as f64
        }
    }
}

impl AddAssign for RadiusHistogram {
    /// Adds bin by bin; both histograms are expected to share their edges (same cache parameters).
    fn add_assign(&mut self, o: Self) {
        self.counts
            .iter_mut()
            .zip(o.counts)
            .for_each(|(a, b)| *a += b);
        self.n += o.n;
        self.min_px = self.min_px.min(o.min_px);
        self.max_px = self.max_px.max(o.max_px);
        self.sum_px += o.sum_px;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_bins_and_extremes() {
        let mut h = RadiusHistogram::new(3.0, 20.0);
        h.add(3.0);
        h.add(20.0);
        h.add(1.0); // below range: first bin
        h.add(7.7);
        assert_eq!(h.n, 4);
        assert_eq!(h.counts[0], 2);
        assert_eq!(h.counts[RADIUS_BINS - 1], 1);
        assert_eq!(h.min_px, 1.0);
        assert_eq!(h.max_px, 20.0);
        assert!((h.edge(RADIUS_BINS) - 20.0).abs() < 1e-4);
        let mut g = h;
        g += h;
        assert_eq!(g.n, 8);
    }
}
