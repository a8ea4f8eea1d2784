//! The cache's part of the render report: the cache and the fill and shading that used it.
#![forbid(unsafe_code)]

use crate::cache::IrradianceCache;
use crate::stats::{FillStats, LookupStats, RadiusHistogram};

pmbase::summable! {
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
        /// Pass-B lookups whose records' irradiance a bump or normal map turned to its normal.
        pub bump_rotated_pass_b: u64,
        /// Pass-B lookups that found a usable record, and the sum of usable records over them (pass A
        /// asks only whether a record covers a point).
        pub n_hits: u64,
        pub n_records_used: u64,
        pub radius_px: RadiusHistogram,
        pub shrunk_by_clamping: u64,
        pub shrunk_by_gradient: u64,
        /// Halvings of R' by adaptive caching.
        pub shrunk_adaptive: u64,
        /// Validation gathers at covered pass-A points, those that found a record wrong, and the
        /// records they shrank ([`crate::Validation`]).
        pub validated: u64,
        pub validation_failed: u64,
        pub shrunk_validation: u64,
        pub clamped_min: u64,
        pub clamped_max: u64,
        pub memory_bytes: u64,
    }
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
            bump_rotated_pass_b: pass_b.n_bump_rotated,
            n_hits: pass_b.n_lookups - pass_b.n_misses,
            n_records_used: pass_b.n_records_used,
            radius_px,
            shrunk_by_clamping: totals.n_shrunk_by_neighbors,
            shrunk_by_gradient: totals.n_shrunk_by_gradient,
            shrunk_adaptive: totals.n_shrunk_adaptive,
            validated: fill.insert.n_validated,
            validation_failed: fill.insert.n_validation_failed,
            shrunk_validation: fill.insert.n_shrunk_validation,
            clamped_min: totals.n_clamped_min,
            clamped_max: totals.n_clamped_max,
            memory_bytes: cache.memory_bytes() as u64,
        }
    }

    /// Mean number of usable records per successful pass-B lookup.
    pub fn mean_records_per_lookup(&self) -> f64 {
        if self.n_hits == 0 {
            0.0
        } else {
            self.n_records_used as f64 / self.n_hits as f64
        }
    }
}
