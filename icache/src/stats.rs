//! Statistics of insertion, lookups, the fill pass and the whole cache, as plain structs with `AddAssign`.
#![forbid(unsafe_code)]

use std::ops::AddAssign;

use crate::cache::{IrradianceCache, Lookup};

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
}

impl AddAssign for InsertStats {
    fn add_assign(&mut self, o: Self) {
        self.n_inserted += o.n_inserted;
        self.n_rejected += o.n_rejected;
        self.n_sanitized += o.n_sanitized;
        self.n_shrunk_by_gradient += o.n_shrunk_by_gradient;
        self.n_shrunk_by_neighbors += o.n_shrunk_by_neighbors;
        self.n_clamped_min += o.n_clamped_min;
        self.n_clamped_max += o.n_clamped_max;
        self.n_shrunk_adaptive += o.n_shrunk_adaptive;
    }
}

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

impl AddAssign for LookupStats {
    fn add_assign(&mut self, o: Self) {
        self.n_lookups += o.n_lookups;
        self.n_reused += o.n_reused;
        self.n_misses += o.n_misses;
        self.n_single_record += o.n_single_record;
        self.n_extrapolated += o.n_extrapolated;
        self.n_gathered += o.n_gathered;
        self.n_records_used += o.n_records_used;
    }
}

/// What the pass-A fill did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FillStats {
    pub n_pixels: u64,
    /// Pass A visited every `pass_a_stride`-th pixel in x and y (0: not a pass A).
    pub pass_a_stride: u32,
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

/// The cache's part of the render report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheStats {
    pub n_records: u64,
    pub records_pass_a: u64,
    /// Records created after the fill (lazily, by `get_or_insert_with`); 0 in a proper two-pass render.
    pub records_pass_b: u64,
    pub lookups: u64,
    /// Pass-B lookups (one per shading sample on a surface with a diffuse part).
    pub lookups_pass_b: u64,
    pub misses_pass_b: u64,
    /// Pass-B lookups answered by a single record.
    pub single_record_pass_b: u64,
    /// Pass-B misses answered by extrapolation across normals, and those that needed a full gather.
    pub extrapolated_pass_b: u64,
    pub gathered_pass_b: u64,
    /// Pass-B lookups answered by an earlier sample of the pixel on the same surface.
    pub reused_pass_b: u64,
    /// Lookups that found a usable record, and the sum of usable records over them.
    pub n_hits: u64,
    pub n_records_used: u64,
    pub radius_px: RadiusHistogram,
    pub shrunk_by_clamping: u64,
    pub shrunk_by_gradient: u64,
    /// Halvings of R' by adaptive caching.
    pub shrunk_adaptive: u64,
    pub clamped_min: u64,
    pub clamped_max: u64,
    pub memory_bytes: u64,
}

impl CacheStats {
    /// Summarise `cache` after a fill that produced `fill` and a shading pass that made `pass_b` lookups.
    pub fn collect(cache: &IrradianceCache, fill: &FillStats, pass_b: &LookupStats) -> Self {
        let p = cache.params();
        let mut radius_px =
            RadiusHistogram::new(p.min_spacing_px, p.max_spacing_px * p.start_scale());
        cache
            .records()
            .iter()
            .for_each(|r| radius_px.add(r.radius_px()));
        let totals = cache.insert_totals();
        let n_records = cache.len() as u64;
        CacheStats {
            n_records,
            records_pass_a: fill.insert.n_inserted,
            records_pass_b: n_records.saturating_sub(fill.insert.n_inserted),
            lookups: fill.lookups.n_lookups + pass_b.n_lookups,
            lookups_pass_b: pass_b.n_lookups,
            misses_pass_b: pass_b.n_misses,
            single_record_pass_b: pass_b.n_single_record,
            extrapolated_pass_b: pass_b.n_extrapolated,
            gathered_pass_b: pass_b.n_gathered,
            reused_pass_b: pass_b.n_reused,
            n_hits: (fill.lookups.n_lookups - fill.lookups.n_misses)
                + (pass_b.n_lookups - pass_b.n_misses),
            n_records_used: fill.lookups.n_records_used + pass_b.n_records_used,
            radius_px,
            shrunk_by_clamping: totals.n_shrunk_by_neighbors,
            shrunk_by_gradient: totals.n_shrunk_by_gradient,
            shrunk_adaptive: totals.n_shrunk_adaptive,
            clamped_min: totals.n_clamped_min,
            clamped_max: totals.n_clamped_max,
            memory_bytes: cache.memory_bytes() as u64,
        }
    }

    /// Mean number of usable records per successful lookup.
    pub fn mean_records_per_lookup(&self) -> f64 {
        if self.n_hits == 0 {
            0.0
        } else {
            self.n_records_used as f64 / self.n_hits as f64
        }
    }
}

impl AddAssign for CacheStats {
    fn add_assign(&mut self, o: Self) {
        self.n_records += o.n_records;
        self.records_pass_a += o.records_pass_a;
        self.records_pass_b += o.records_pass_b;
        self.lookups += o.lookups;
        self.lookups_pass_b += o.lookups_pass_b;
        self.misses_pass_b += o.misses_pass_b;
        self.reused_pass_b += o.reused_pass_b;
        self.single_record_pass_b += o.single_record_pass_b;
        self.extrapolated_pass_b += o.extrapolated_pass_b;
        self.gathered_pass_b += o.gathered_pass_b;
        self.n_hits += o.n_hits;
        self.n_records_used += o.n_records_used;
        self.radius_px += o.radius_px;
        self.shrunk_by_clamping += o.shrunk_by_clamping;
        self.shrunk_by_gradient += o.shrunk_by_gradient;
        self.shrunk_adaptive += o.shrunk_adaptive;
        self.clamped_min += o.clamped_min;
        self.clamped_max += o.clamped_max;
        self.memory_bytes += o.memory_bytes;
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
