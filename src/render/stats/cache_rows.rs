//! The report's rows of each phase's statistics that need no more than that phase's part: the
//! irradiance cache, the media radiance cache, the glossy radiance cache.

use super::*;

pub(super) fn cache_rows(
    r: &mut Report,
    s: &CacheStats,
    fill: &icache::FillStats,
    gather_rays: u64,
    shade: &ShadeStats,
) {
    for (title, key, n) in [
        (
            "Records created in pass A",
            "icache.records_pass_a",
            s.records_pass_a,
        ),
        (
            "Records created in pass B (for missed samples)",
            "icache.records_pass_b",
            s.records_pass_b,
        ),
        (
            "Pass-B rounds that made records",
            "icache.rounds_with_records",
            shade.grown.rounds,
        ),
        (
            "Pass-B samples taken again with the new records",
            "icache.samples_redone",
            shade.samples.redone,
        ),
        (
            "Pass-B pixel rounds taken again",
            "icache.pixel_rounds_redone",
            shade.samples.redone_pixels,
        ),
        ("Lookups", "icache.lookups", s.lookups),
        ("Pass-B lookups", "icache.lookups_pass_b", s.lookups_pass_b),
        (
            "Pass-B misses (no record interpolates)",
            "icache.misses_pass_b",
            s.misses_pass_b,
        ),
        (
            "Pass-B misses extrapolated across normals",
            "icache.extrapolated_pass_b",
            s.extrapolated_pass_b,
        ),
        (
            "Pass-B misses gathered (no record at all)",
            "icache.gathered_pass_b",
            s.gathered_pass_b,
        ),
        (
            "Pass-B lookups from one record",
            "icache.single_record_pass_b",
            s.single_record_pass_b,
        ),
        (
            "Pass-B lookups reused within a pixel",
            "icache.reused_pass_b",
            s.reused_pass_b,
        ),
        (
            "Pass-B lookups turned to a bumped normal",
            "icache.bump_rotated_pass_b",
            s.bump_rotated_pass_b,
        ),
    ] {
        r.count("Irradiance cache", title, key, n);
    }
    r.number(
        "Irradiance cache",
        "Mean usable records per pass-B lookup",
        "icache.mean_records_per_lookup",
        s.mean_records_per_lookup(),
    );
    r.count(
        "Irradiance cache",
        "Gather rays",
        "icache.gather_rays",
        gather_rays,
    );
    spacing_rows(r, s, fill);
}

/// The irradiance cache's rows on record spacing: radii, what shrank or clamped them, pass A's
/// lattice, and the cache's memory.
pub(super) fn spacing_rows(r: &mut Report, s: &CacheStats, fill: &icache::FillStats) {
    radius_row(r, "Irradiance cache", "icache.radius_px", &s.radius_px);
    for (title, key, n) in [
        (
            "Shrunk by neighbor clamping",
            "icache.shrunk_by_clamping",
            s.shrunk_by_clamping,
        ),
        (
            "Shrunk by the gradient limit",
            "icache.shrunk_by_gradient",
            s.shrunk_by_gradient,
        ),
        (
            "Shrunk by adaptive caching (halvings)",
            "icache.shrunk_adaptive",
            s.shrunk_adaptive,
        ),
        (
            "Validation gathers at covered points",
            "icache.validated",
            s.validated,
        ),
        (
            "Validation gathers that found a record wrong",
            "icache.validation_failed",
            s.validation_failed,
        ),
        (
            "Records shrunk by validation",
            "icache.shrunk_validation",
            s.shrunk_validation,
        ),
        (
            "Clamped to min spacing",
            "icache.clamped_min",
            s.clamped_min,
        ),
        (
            "Clamped to max spacing",
            "icache.clamped_max",
            s.clamped_max,
        ),
        (
            "Pass-A pixel lattice (every n-th pixel in x and y)",
            "icache.pass_a_stride",
            fill.pass_a_stride as u64,
        ),
        (
            "Pass-A pixels skipped between covered lattice pixels",
            "icache.pass_a_pixels_skipped",
            fill.n_pixels_skipped,
        ),
        ("Pass-A waves", "icache.waves", fill.n_waves),
        (
            "Points left uncovered after pass A",
            "icache.uncovered_after_fill",
            fill.n_uncovered_after,
        ),
    ] {
        r.count("Irradiance cache", title, key, n);
    }
    r.bytes(
        "Irradiance cache",
        "Memory",
        "icache.memory_bytes",
        s.memory_bytes,
    );
}

/// A radius histogram as one row: mean [min–max] shown, the bins in the JSON.
pub(super) fn radius_row(r: &mut Report, category: &str, key: &str, h: &icache::RadiusHistogram) {
    r.value(
        category,
        "Record radius (px) avg [min–max]",
        key,
        serde_json::json!({"min": h.min_px, "avg": h.mean_px(), "max": h.max_px, "counts": h.counts.to_vec(), "edges": (0..=icache::stats::RADIUS_BINS).map(|i| h.edge(i)).collect::<Vec<_>>()}),
        format!("{:.1} [{:.1}–{:.1}]", h.mean_px(), h.min_px, h.max_px),
    );
}

/// The media radiance cache: pass A's work, pass B's lookups and misses, the radii.
pub(super) fn media_cache_rows(
    r: &mut Report,
    f: &icache::media::MediaFillStats,
    records: u64,
    bytes: u64,
    shade: &SampleCounters,
) {
    let c = "Media cache";
    r.count(
        c,
        "Records (pass A; pass B makes none)",
        "media.records",
        records,
    );
    r.count(
        c,
        "Pass-A points along camera rays",
        "media.points",
        f.n_points,
    );
    r.count(
        c,
        "Pass-A pixel lattice (every n-th pixel in x and y)",
        "media.lattice_stride",
        f.stride as u64,
    );
    r.count(
        c,
        "Estimates made in pass A",
        "media.estimates",
        f.n_estimates,
    );
    r.count(
        c,
        "Estimates covered by an earlier one of their wave",
        "media.skipped_covered",
        f.n_skipped_covered,
    );
    r.count(
        c,
        "Shrunk by neighbour clamping",
        "media.shrunk_by_clamping",
        f.n_shrunk_by_neighbours,
    );
    r.count(
        c,
        "Repair sweeps",
        "media.repair_sweeps",
        f.n_repair_sweeps as u64,
    );
    r.count(
        c,
        "Points left uncovered after pass A",
        "media.uncovered_after_fill",
        f.n_uncovered_after,
    );
    r.count(c, "Pass-B lookups", "media.lookups", shade.media_lookups);
    r.count(
        c,
        "Pass-B misses (estimated from the volume map)",
        "media.misses",
        shade.media_misses,
    );
    r.percent(
        c,
        "Pass-B miss ratio",
        "media.miss_ratio",
        shade.media_misses as f64 / shade.media_lookups.max(1) as f64,
    );
    radius_row(r, c, "media.radius_px", &f.radius_px);
    r.bytes(c, "Memory", "media.memory_bytes", bytes);
}

pub(super) fn glossy_rows(r: &mut Report, g: &GlossyStats) {
    let c = "Glossy";
    let rc = &g.radiance;
    r.count(c, "Radiance-cache records", "glossy.records", rc.records);
    r.count(
        c,
        "Harmonic bands kept (most of any lobe)",
        "glossy.order",
        rc.max_order as u64,
    );
    r.count(c, "Radiance-cache lookups", "glossy.lookups", rc.lookups);
    r.count(
        c,
        "Lookups without records: lobe sampled",
        "glossy.fallbacks",
        rc.fallbacks,
    );
    r.bytes(
        c,
        "Radiance-cache memory",
        "glossy.memory_bytes",
        rc.memory_bytes,
    );
    r.count(
        c,
        "Glossy texels estimated (gather rays, lobe samples)",
        "glossy.texels",
        g.texels.0,
    );
    r.bytes(
        c,
        "Texel harmonics memory",
        "glossy.texel_memory_bytes",
        g.texels.1,
    );
}
