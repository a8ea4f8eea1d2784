//! Pass A of the two-pass traversal: fill the cache so every shading point of the image is covered,
//! deterministically whatever the thread count. Pass B is the caller's: `lookup(.., Pass::B)` per pixel.
//!
//! Pixels are visited in [`HierarchicalOrder`], in chunks. Each chunk's shading points and coverage
//! lookups run in parallel against the cache as it stood when the current wave began; uncovered points
//! accumulate until a wave holds `WAVE_GATHERS` of them (or the image ends). Then the wave's gathers run in
//! parallel and the records are inserted sequentially in visiting order, each re-checked against records
//! inserted earlier in the wave. Chunk and wave boundaries depend only on the data, never on timing.
//! Neighbor clamping can shrink a record after it covered a point, so repair sweeps follow: each looks up
//! again only the points that a record shrunk since the last sweep could interpolate before and cannot
//! now (the cache logs the shrinks; points are kept from the first sweep, not traced again), until a
//! sweep shrinks nothing (at most `MAX_REPAIR_SWEEPS`).
//!
//! Each shading point comes with the caller's payload `P` (the hit it traced to find the point), handed
//! back to the gather there, and each gather returns the caller's statistics `S`, summed by the fill:
//! the caller traces nothing twice and shares no counter between threads.
#![forbid(unsafe_code)]

use std::ops::AddAssign;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use crate::cache::IrradianceCache;
use crate::index::Octree;
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
const MAX_REPAIR_SWEEPS: u64 = 8;

pub type ShadingPointsFn<'a> = dyn Fn(u32, u32) -> Vec<ShadingPoint> + Sync + 'a;
pub type GatherFn<'a> = dyn Fn(u32, u32, usize, &ShadingPoint) -> NewRecord + Sync + 'a;
pub type ProgressFn<'a> = dyn Fn(u64, u64) + Sync + 'a;
/// The shading points of pixel (x, y), each with the caller's payload for its gather.
pub type PointsWithFn<'a, P> = dyn Fn(u32, u32) -> Vec<(ShadingPoint, P)> + Sync + 'a;
/// The gather at point `i` of pixel (x, y), given its payload: the record and the caller's statistics.
pub type GatherWithFn<'a, P, S> = dyn Fn(u32, u32, usize, &ShadingPoint, &P) -> (NewRecord, S) + Sync + 'a;

/// Caller statistics for the closures without any ([`fill_pass_a`], [`crate::fill_one_pass`]).
#[derive(Default)]
pub(crate) struct NoStats;

impl AddAssign for NoStats {
    fn add_assign(&mut self, _: NoStats) {}
}

/// An uncovered shading point waiting for its gather.
struct Candidate<P> {
    x: u32,
    y: u32,
    i: usize,
    sp: ShadingPoint,
    payload: P,
}

/// A pixel's lookups, uncovered points, points (kept for the repair sweeps) and the records adaptive
/// caching found deviant there.
type PixelFound<P> = (LookupStats, Vec<Candidate<P>>, Vec<(ShadingPoint, P)>, Vec<u32>);

/// What a fill counts: its own statistics and the sum of the caller's.
struct Tally<S> {
    fill: FillStats,
    gathers: S,
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
    let points = |x, y| shading_points(x, y).into_iter().map(|sp| (sp, ())).collect();
    let gather = |x, y, i, sp: &ShadingPoint, _: &()| (gather(x, y, i, sp), NoStats);
    fill_pass_a_cancellable(cache, width, height, &points, &gather, progress, &AtomicBool::new(false)).0
}

/// [`fill_pass_a`] with a payload per shading point and statistics per gather (see the module header),
/// returning early, with the cache partly filled, soon after `cancel` is set: it is read before every
/// chunk of pixels. (The caller makes its long gathers return early too.) Returns the fill's statistics
/// and the sum of the gathers'.
pub fn fill_pass_a_cancellable<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    shading_points: &PointsWithFn<P>,
    gather: &GatherWithFn<P, S>,
    progress: &ProgressFn,
    cancel: &AtomicBool,
) -> (FillStats, S) {
    let mut tally = Tally { fill: FillStats::default(), gathers: S::default() };
    let total = width as u64 * height as u64;
    let mut store = PointStore::new(width, height);
    cache.log_shrinks(true);
    let order = HierarchicalOrder::new(width, height);
    let first = sweep(cache, order, shading_points, &mut store, gather, &mut tally, &|done| progress(done, total), cancel);
    tally.fill.n_pixels = total;
    if first > 0 {
        repair(cache, width, height, &store, gather, &mut tally, cancel);
    }
    cache.log_shrinks(false);
    progress(total, total);
    (tally.fill, tally.gathers)
}

/// Every shading point of the first sweep with its payload, by pixel, so repair sweeps need not trace
/// them again.
struct PointStore<P> {
    width: u32,
    /// Pixel y·width + x → its range in `points`.
    ranges: Vec<(u32, u32)>,
    points: Vec<(ShadingPoint, P)>,
}

impl<P: Clone> PointStore<P> {
    fn new(width: u32, height: u32) -> Self {
        PointStore { width, ranges: vec![(0, 0); width as usize * height as usize], points: Vec::new() }
    }

    fn push(&mut self, x: u32, y: u32, points: Vec<(ShadingPoint, P)>) {
        let start = self.points.len() as u32;
        self.points.extend(points);
        self.ranges[(y * self.width + x) as usize] = (start, self.points.len() as u32);
    }

    fn get(&self, x: u32, y: u32) -> &[(ShadingPoint, P)] {
        let (a, b) = self.ranges[(y * self.width + x) as usize];
        &self.points[a as usize..b as usize]
    }
}

/// Neighbor clamping can shrink a record after it covered a point. Only the points that a shrunk record
/// could interpolate before its shrink and cannot after it can have lost their cover, so each repair
/// sweep looks up just those (in parallel, against the cache as the sweep finds it) and gathers the
/// uncovered ones in visiting order, in waves, each point checked again before its gather; until a sweep
/// shrinks nothing (at most `MAX_REPAIR_SWEEPS`). On Sibenik at 1000² the first sweep used to revisit
/// every pixel inside the old spheres of shrunk records — all of them, 2.3 s of a 13 s fill.
fn repair<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    store: &PointStore<P>,
    gather: &GatherWithFn<P, S>,
    tally: &mut Tally<S>,
    cancel: &AtomicBool,
) {
    let pixels: Vec<(u32, u32)> = HierarchicalOrder::new(width, height).collect();
    loop {
        if cancel.load(Ordering::Relaxed) {
            return;
        }
        let log = cache.take_shrink_log();
        if log.is_empty() {
            return;
        }
        if tally.fill.n_repair_sweeps == MAX_REPAIR_SWEEPS {
            tally.fill.n_uncovered_after = count_uncovered(cache, &pixels, store);
            return;
        }
        tally.fill.n_repair_sweeps += 1;
        let (lo, hi) = cache.bounds();
        let mut spheres = Octree::new(lo, hi);
        for (i, shrink) in log.iter().enumerate() {
            let (pos, reach) = cache.reach_before(shrink);
            spheres.insert(i as u32, pos, reach);
        }
        let cache_ref: &IrradianceCache = cache;
        let found: Vec<(LookupStats, Vec<Candidate<P>>)> = pixels
            .par_iter()
            .with_max_len(1024)
            .map(|&(x, y)| {
                let mut lookups = LookupStats::default();
                let mut uncovered = Vec::new();
                for (i, (sp, payload)) in store.get(x, y).iter().enumerate() {
                    let mut lost = false;
                    spheres.for_each_candidate(sp.pos, |k| lost = lost || cache_ref.lost_cover(&log[k as usize], sp.pos, sp.normal));
                    if !lost {
                        continue;
                    }
                    let hit = cache_ref.lookup(sp.pos, sp.normal, Pass::A);
                    lookups.record(hit.as_ref());
                    if hit.is_none() {
                        uncovered.push(Candidate { x, y, i, sp: *sp, payload: payload.clone() });
                    }
                }
                (lookups, uncovered)
            })
            .collect();
        let mut waiting = Vec::new();
        for (lookups, uncovered) in found {
            tally.fill.lookups += lookups;
            waiting.extend(uncovered);
        }
        let mut waiting = waiting.into_iter().peekable();
        while waiting.peek().is_some() {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            let cache_ref: &IrradianceCache = cache;
            let mut wave: Vec<Candidate<P>> = Vec::with_capacity(WAVE_GATHERS);
            for c in waiting.by_ref() {
                let hit = cache_ref.lookup(c.sp.pos, c.sp.normal, Pass::A);
                tally.fill.lookups.record(hit.as_ref());
                if hit.is_none() {
                    wave.push(c);
                    if wave.len() == WAVE_GATHERS {
                        break;
                    }
                }
            }
            if !wave.is_empty() {
                run_wave(cache, &mut wave, gather, tally);
            }
        }
    }
}

/// One pass over `order`'s pixels, keeping every pixel's shading points in `store`; returns the number
/// of records inserted.
#[allow(clippy::too_many_arguments)]
fn sweep<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    mut order: impl Iterator<Item = (u32, u32)>,
    shading_points: &PointsWithFn<P>,
    store: &mut PointStore<P>,
    gather: &GatherWithFn<P, S>,
    tally: &mut Tally<S>,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> u64 {
    let before = tally.fill.insert.n_inserted;
    let mut pending: Vec<Candidate<P>> = Vec::new();
    let mut done = 0u64;
    loop {
        if cancel.load(Ordering::Relaxed) {
            return tally.fill.insert.n_inserted - before;
        }
        let chunk: Vec<(u32, u32)> = order.by_ref().take(CHUNK_PIXELS).collect();
        if chunk.is_empty() {
            break;
        }
        done += chunk.len() as u64;
        let cache_ref: &IrradianceCache = cache;
        let found: Vec<PixelFound<P>> = chunk
            .par_iter()
            .with_max_len(4)
            .map(|&(x, y)| {
                let mut lookups = LookupStats::default();
                let mut misses = Vec::new();
                let mut shrink = Vec::new();
                let points = shading_points(x, y);
                for (i, (sp, payload)) in points.iter().enumerate() {
                    let (hit, deviant) = cache_ref.lookup_adaptive(sp.pos, sp.normal);
                    lookups.record(hit.as_ref());
                    shrink.extend(deviant);
                    if hit.is_none() {
                        misses.push(Candidate { x, y, i, sp: *sp, payload: payload.clone() });
                    }
                }
                (lookups, misses, points, shrink)
            })
            .collect();
        // Adaptive caching: the records that disagreed somewhere in the chunk shrink once each, in id
        // order, before the chunk's uncovered points are gathered (each re-checked then).
        let mut shrink: Vec<u32> = found.iter().flat_map(|f| f.3.iter().copied()).collect();
        shrink.sort_unstable();
        shrink.dedup();
        let n_shrunk = shrink.into_iter().filter(|&id| cache.shrink_adaptive(id)).count() as u64;
        tally.fill.insert.n_shrunk_adaptive += n_shrunk;
        let shrunk = n_shrunk > 0;
        for (&(x, y), (lookups, misses, points, _)) in chunk.iter().zip(found) {
            store.push(x, y, points);
            tally.fill.n_points += lookups.n_lookups;
            tally.fill.lookups += lookups;
            // A point that only the deviant records made uncovered may be covered by the rest now.
            let cache_ref: &IrradianceCache = cache;
            pending.extend(misses.into_iter().filter(|c| !shrunk || cache_ref.lookup_adaptive(c.sp.pos, c.sp.normal).0.is_none()));
        }
        if pending.len() >= WAVE_GATHERS {
            run_wave(cache, &mut pending, gather, tally);
        }
        progress(done);
    }
    if !pending.is_empty() {
        run_wave(cache, &mut pending, gather, tally);
    }
    tally.fill.insert.n_inserted - before
}

/// Gather every pending point in parallel, then insert in visiting order, skipping points covered by
/// records inserted earlier in this wave (their gathers still count in the caller's statistics).
fn run_wave<P: Send + Sync, S: AddAssign + Send>(cache: &mut IrradianceCache, pending: &mut Vec<Candidate<P>>, gather: &GatherWithFn<P, S>, tally: &mut Tally<S>) {
    tally.fill.n_waves += 1;
    tally.fill.n_gathers += pending.len() as u64;
    let gathered: Vec<(NewRecord, S)> = pending.par_iter().with_max_len(1).map(|c| gather(c.x, c.y, c.i, &c.sp, &c.payload)).collect();
    for (c, (rec, s)) in pending.drain(..).zip(gathered) {
        tally.gathers += s;
        let hit = cache.lookup(c.sp.pos, c.sp.normal, Pass::A);
        tally.fill.lookups.record(hit.as_ref());
        if hit.is_some() {
            tally.fill.n_skipped_covered += 1;
            continue;
        }
        tally.fill.insert += cache.insert(NewRecord { pixel_world: c.sp.pixel_world, ..rec });
    }
}

/// Shading points with no usable pass-A record.
fn count_uncovered<P: Clone + Sync>(cache: &IrradianceCache, pixels: &[(u32, u32)], store: &PointStore<P>) -> u64 {
    pixels
        .par_iter()
        .map(|&(x, y)| store.get(x, y).iter().filter(|(sp, _)| cache.lookup(sp.pos, sp.normal, Pass::A).is_none()).count() as u64)
        .sum()
}
