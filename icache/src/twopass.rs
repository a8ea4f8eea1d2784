//! Pass A of the two-pass traversal: fill the cache so every shading point of the image is covered,
//! deterministically whatever the thread count. Pass B is the caller's: `lookup(.., Pass::B)` per pixel.
//!
//! Pixels are visited in [`HierarchicalOrder`], in chunks. Each chunk's shading points and coverage
//! lookups run in parallel against the cache as it stood when the current wave began; uncovered points
//! accumulate until a wave holds `WAVE_GATHERS` of them (or the image ends). Then the wave's gathers run in
//! parallel and the records are inserted sequentially in visiting order, each re-checked against records
//! inserted earlier in the wave. Chunk and wave boundaries depend only on the data, never on timing.
//! Neighbor clamping can shrink a record after it covered a point, so full-image repair sweeps follow
//! until one inserts nothing (at most `MAX_REPAIR_SWEEPS`).
#![forbid(unsafe_code)]

use glam::Vec3;
use rayon::prelude::*;

use crate::cache::IrradianceCache;
use crate::order::HierarchicalOrder;
use crate::params::Pass;
use crate::record::NewRecord;
use crate::stats::{FillStats, LookupStats};

/// A visible surface point of a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingPoint {
    pub pos: Vec3,
    /// Unit normal facing the viewer.
    pub normal: Vec3,
    /// World-space size of one pixel projected on the tangent plane at `pos`.
    pub pixel_world: f32,
}

/// Pixels whose coverage is looked up together (then possibly gathered as one wave): small, so the first
/// waves of an empty cache do not gather many points that would have covered each other.
const CHUNK_PIXELS: usize = 64;
/// Uncovered points gathered together; large enough to keep many threads busy, small enough that the
/// records of one wave seldom overlap (they are spread over the image by the visiting order).
const WAVE_GATHERS: usize = 64;
/// Repair sweeps after the hierarchical pass; each one typically inserts a handful of records.
const MAX_REPAIR_SWEEPS: u64 = 4;

pub type ShadingPointsFn<'a> = dyn Fn(u32, u32) -> Vec<ShadingPoint> + Sync + 'a;
pub type GatherFn<'a> = dyn Fn(u32, u32, usize, &ShadingPoint) -> NewRecord + Sync + 'a;
pub type ProgressFn<'a> = dyn Fn(u64, u64) + Sync + 'a;

/// An uncovered shading point waiting for its gather.
struct Candidate {
    x: u32,
    y: u32,
    i: usize,
    sp: ShadingPoint,
}

/// Fill the cache for a `width` × `height` image. `progress(done_pixels, total_pixels)` is called from
/// the calling thread after each chunk of the hierarchical pass.
pub fn fill_pass_a(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    shading_points: &ShadingPointsFn,
    gather: &GatherFn,
    progress: &ProgressFn,
) -> FillStats {
    let mut stats = FillStats::default();
    let total = width as u64 * height as u64;
    let inserted = sweep(cache, width, height, shading_points, gather, &mut stats, &|done| progress(done, total));
    stats.n_pixels = total;
    if inserted > 0 {
        repair(cache, width, height, shading_points, gather, &mut stats);
    }
    progress(total, total);
    stats
}

/// Sweep again until a sweep inserts nothing; count what is left uncovered if the limit is reached.
fn repair(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    shading_points: &ShadingPointsFn,
    gather: &GatherFn,
    stats: &mut FillStats,
) {
    loop {
        if stats.n_repair_sweeps == MAX_REPAIR_SWEEPS {
            stats.n_uncovered_after = count_uncovered(cache, width, height, shading_points);
            return;
        }
        stats.n_repair_sweeps += 1;
        if sweep(cache, width, height, shading_points, gather, stats, &|_| {}) == 0 {
            return;
        }
    }
}

/// One pass over every pixel in hierarchical order; returns the number of records inserted.
fn sweep(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    shading_points: &ShadingPointsFn,
    gather: &GatherFn,
    stats: &mut FillStats,
    progress: &(dyn Fn(u64) + Sync),
) -> u64 {
    let before = stats.insert.n_inserted;
    let mut order = HierarchicalOrder::new(width, height);
    let mut pending: Vec<Candidate> = Vec::new();
    let mut done = 0u64;
    loop {
        let chunk: Vec<(u32, u32)> = order.by_ref().take(CHUNK_PIXELS).collect();
        if chunk.is_empty() {
            break;
        }
        done += chunk.len() as u64;
        let cache_ref: &IrradianceCache = cache;
        let found: Vec<(LookupStats, Vec<Candidate>)> = chunk
            .par_iter()
            .map(|&(x, y)| {
                let mut lookups = LookupStats::default();
                let mut misses = Vec::new();
                for (i, sp) in shading_points(x, y).into_iter().enumerate() {
                    let hit = cache_ref.lookup(sp.pos, sp.normal, Pass::A);
                    lookups.record(hit.as_ref());
                    if hit.is_none() {
                        misses.push(Candidate { x, y, i, sp });
                    }
                }
                (lookups, misses)
            })
            .collect();
        for (lookups, misses) in found {
            stats.n_points += lookups.n_lookups;
            stats.lookups += lookups;
            pending.extend(misses);
        }
        if pending.len() >= WAVE_GATHERS {
            run_wave(cache, &mut pending, gather, stats);
        }
        progress(done);
    }
    if !pending.is_empty() {
        run_wave(cache, &mut pending, gather, stats);
    }
    stats.insert.n_inserted - before
}

/// Gather every pending point in parallel, then insert in visiting order, skipping points covered by
/// records inserted earlier in this wave.
fn run_wave(cache: &mut IrradianceCache, pending: &mut Vec<Candidate>, gather: &GatherFn, stats: &mut FillStats) {
    stats.n_waves += 1;
    stats.n_gathers += pending.len() as u64;
    let records: Vec<NewRecord> = pending
        .par_iter()
        .map(|c| NewRecord { pixel_world: c.sp.pixel_world, ..gather(c.x, c.y, c.i, &c.sp) })
        .collect();
    for (c, rec) in pending.drain(..).zip(records) {
        let hit = cache.lookup(c.sp.pos, c.sp.normal, Pass::A);
        stats.lookups.record(hit.as_ref());
        if hit.is_some() {
            stats.n_skipped_covered += 1;
            continue;
        }
        stats.insert += cache.insert(rec);
    }
}

/// Shading points with no usable pass-A record.
fn count_uncovered(cache: &IrradianceCache, width: u32, height: u32, shading_points: &ShadingPointsFn) -> u64 {
    let pixels: Vec<(u32, u32)> = HierarchicalOrder::new(width, height).collect();
    pixels
        .par_iter()
        .map(|&(x, y)| {
            let points = shading_points(x, y);
            points.iter().filter(|sp| cache.lookup(sp.pos, sp.normal, Pass::A).is_none()).count() as u64
        })
        .sum()
}
