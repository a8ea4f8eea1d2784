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

use crate::cache::{IrradianceCache, Shrink};
use crate::order::HierarchicalOrder;
use crate::params::Pass;
use crate::point_grid::PointGrid;
use crate::record::{Lookup, NewRecord, Record};
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

pub(crate) type ProgressFn<'a> = dyn Fn(u64, u64) + Sync + 'a;
/// Whether a record (id, record) may serve a shading point with its payload: the caller's occlusion
/// test, for records the weights alone do not settle (a sequence's records made for other views).
pub type VisibleFn<'a, P> = dyn Fn(&ShadingPoint, &P, u32, &Record) -> bool + Sync + 'a;
/// The shading points of pixel (x, y), each with the caller's payload for its gather.
pub(crate) type PointsWithFn<'a, P> = dyn Fn(u32, u32) -> Vec<(ShadingPoint, P)> + Sync + 'a;
/// The gather at point `i` of pixel (x, y), given its payload: the record and the caller's statistics.
pub(crate) type GatherWithFn<'a, P, S> =
    dyn Fn(u32, u32, usize, &ShadingPoint, &P) -> (NewRecord, S) + Sync + 'a;

/// An uncovered shading point waiting for its gather, or a covered one chosen to check the records
/// that cover it (`validate`, see [`crate::Validation`]).
struct Candidate<P> {
    x: u32,
    y: u32,
    i: usize,
    sp: ShadingPoint,
    payload: P,
    validate: bool,
    /// Its index in the [`PointStore`] (`u32::MAX` before the first sweep stores it).
    k: u32,
}

/// What a pixel's lookups found.
struct PixelFound<P> {
    lookups: LookupStats,
    /// Its uncovered points.
    misses: Vec<Candidate<P>>,
    /// All its points (kept for the repair sweeps), and how many records each could interpolate.
    points: Vec<(ShadingPoint, P)>,
    used: Vec<u32>,
    /// The records adaptive caching found deviant there.
    shrink: Vec<u32>,
}

/// What a fill counts: its own statistics and the sum of the caller's; and the records validation
/// shrank, whose other points the repair sweeps check too.
struct Tally<S> {
    fill: FillStats,
    gathers: S,
    suspects: Vec<u32>,
}

/// Which pixels pass A visits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PassAPixels {
    /// Every n-th pixel in x and y (1: every pixel).
    Stride(u32),
    /// The lattice of every other pixel in x and y, then a pixel between lattice pixels only where a
    /// lattice pixel next to it had a point no record covered: for a cache that already covers most of
    /// the image (a sequence's frame after its camera moved), whose gaps the lattice finds.
    LatticeThenGaps,
}

/// Fill the cache for a `width` × `height` image, with a payload per shading point and statistics per
/// gather (see the module header). `progress(done_pixels, total_pixels)` is called from the calling
/// thread after each chunk of the hierarchical pass. Returns early, with the cache partly filled, soon after `cancel` is set: it is read before every
/// chunk of pixels. (The caller makes its long gathers return early too.) Returns the fill's statistics
/// and the sum of the gathers'.
///
/// Pass A visits the pixels `pixels` names: with [`PassAPixels::Stride`] the pixels (x, y) with x and
/// y multiples of the stride (1: every pixel), the first 1/stride² of the hierarchical order. A point
/// between them that no record reaches is pass B's to cover (`pm` makes records for the samples that
/// miss, between its rounds).
///
/// A point counts as covered only by records that `visible` accepts there, as the shading pass will
/// read them.
#[allow(clippy::too_many_arguments)]
pub fn fill_pass_a_cancellable<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    pixels: PassAPixels,
    shading_points: &PointsWithFn<P>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    progress: &ProgressFn,
    cancel: &AtomicBool,
) -> (FillStats, S) {
    let (stride, gaps_only) = match pixels {
        PassAPixels::Stride(n) => (n.max(1), false),
        PassAPixels::LatticeThenGaps => (1, true),
    };
    let total = width.div_ceil(stride) as u64 * height.div_ceil(stride) as u64;
    let order = HierarchicalOrder::new(width, height)
        .filter(move |&(x, y)| x % stride == 0 && y % stride == 0);
    let (mut fill, s) = fill_in_order(
        cache,
        width,
        height,
        (order, gaps_only),
        total,
        shading_points,
        gather,
        visible,
        progress,
        cancel,
    );
    fill.pass_a_stride = stride;
    (fill, s)
}

/// More records where shading found none: the shading points of `pixels` (in any order; visited in the
/// hierarchical order, so their gathers spread over the image) filled as pass A fills the image's —
/// looked up, gathered where uncovered, in waves, then repaired — against the cache as it is, whose
/// records are frozen first (the new ones shrink none of them, so no point
/// they covered loses its cover). Between rounds of shading (`pm`'s pass B), with the points its samples
/// missed; deterministic as pass A is. `visible` as for [`fill_pass_a_cancellable`].
#[allow(clippy::too_many_arguments)]
pub fn fill_pixels_cancellable<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    pixels: &[(u32, u32)],
    shading_points: &PointsWithFn<P>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    cancel: &AtomicBool,
) -> (FillStats, S) {
    let mut wanted = vec![false; width as usize * height as usize];
    for &(x, y) in pixels {
        if x < width && y < height {
            wanted[(y * width + x) as usize] = true;
        }
    }
    let order = HierarchicalOrder::new(width, height)
        .filter(move |&(x, y)| wanted[(y * width + x) as usize]);
    cache.freeze();
    fill_in_order(
        cache,
        width,
        height,
        (order, false),
        pixels.len() as u64,
        shading_points,
        gather,
        visible,
        &|_, _| {},
        cancel,
    )
}

/// Pass A over the pixels of `order` (`total` of them; with `gaps_only`, see
/// [`PassAPixels::LatticeThenGaps`]), then its repair sweeps.
#[allow(clippy::too_many_arguments)]
fn fill_in_order<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    (order, gaps_only): (impl Iterator<Item = (u32, u32)>, bool),
    total: u64,
    shading_points: &PointsWithFn<P>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    progress: &ProgressFn,
    cancel: &AtomicBool,
) -> (FillStats, S) {
    let mut tally = Tally {
        fill: FillStats::default(),
        gathers: S::default(),
        suspects: Vec::new(),
    };
    let mut store = PointStore::new(width, height);
    cache.log_shrinks(true);
    let first = sweep(
        cache,
        (order, gaps_only),
        shading_points,
        &mut store,
        gather,
        visible,
        &mut tally,
        &|done| progress(done, total),
        cancel,
    );
    tally.fill.n_pixels = total;
    if first > 0 {
        repair(cache, &mut store, gather, visible, &mut tally, cancel);
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
    /// Each point's pixel.
    pixel: Vec<(u32, u32)>,
    /// How many records each point could interpolate at its last lookup (0 when it could not: its
    /// gather's record covers it, or one inserted before it).
    used: Vec<u32>,
    /// Whether a repair sweep has checked the point's records ([`suspect_points`]).
    validated: Vec<bool>,
}

impl<P: Clone> PointStore<P> {
    fn new(width: u32, height: u32) -> Self {
        PointStore {
            width,
            ranges: vec![(0, 0); width as usize * height as usize],
            points: Vec::new(),
            pixel: Vec::new(),
            used: Vec::new(),
            validated: Vec::new(),
        }
    }

    fn push(&mut self, x: u32, y: u32, points: Vec<(ShadingPoint, P)>, used: Vec<u32>) {
        let start = self.points.len() as u32;
        self.validated
            .extend(std::iter::repeat_n(false, used.len()));
        self.used.extend(used);
        self.pixel.extend(std::iter::repeat_n((x, y), points.len()));
        self.points.extend(points);
        self.ranges[(y * self.width + x) as usize] = (start, self.points.len() as u32);
    }

    /// Whether (x, y), off the lattice of every other pixel, has lattice pixels on both sides (or at
    /// its four corners) all stored, every point of theirs covered at its lookup: the gaps of a cache
    /// that covers most of the image show on the lattice, and are refined where they do.
    fn lattice_covers(&self, x: u32, y: u32) -> bool {
        if x.is_multiple_of(2) && y.is_multiple_of(2) {
            return false;
        }
        let height = self.ranges.len() as u32 / self.width.max(1);
        let xs = if x % 2 == 1 {
            [x.wrapping_sub(1), x + 1]
        } else {
            [x, x]
        };
        let ys = if y % 2 == 1 {
            [y.wrapping_sub(1), y + 1]
        } else {
            [y, y]
        };
        ys.iter().all(|&ly| {
            xs.iter().all(|&lx| {
                if lx >= self.width || ly >= height {
                    return false;
                }
                let (a, b) = self.ranges[(ly * self.width + lx) as usize];
                a < b && self.used[a as usize..b as usize].iter().all(|&u| u > 0)
            })
        })
    }

    /// Point `k` as a candidate for a gather.
    fn candidate(&self, k: u32, payload: P) -> Candidate<P> {
        let (x, y) = self.pixel[k as usize];
        let i = (k - self.ranges[(y * self.width + x) as usize].0) as usize;
        Candidate {
            x,
            y,
            i,
            sp: self.points[k as usize].0,
            payload,
            validate: false,
            k,
        }
    }
}

/// Neighbor clamping can shrink a record after it covered a point. Only the points that a shrunk record
/// could interpolate before its shrink and cannot after it can have lost their cover, so each repair
/// sweep looks up just those (in parallel, against the cache as the sweep finds it) and gathers the
/// uncovered ones in visiting order, in waves, each point checked again before its gather; until a sweep
/// shrinks nothing (at most `MAX_REPAIR_SWEEPS`). The points of a shrunk record's old sphere come from a
/// grid of the points ([`PointGrid`]), not from testing every point of the image against every sphere.
fn repair<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    store: &mut PointStore<P>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    tally: &mut Tally<S>,
    cancel: &AtomicBool,
) {
    let mut grid: Option<PointGrid> = None;
    loop {
        if cancel.load(Ordering::Relaxed) {
            return;
        }
        let log = first_shrinks(cache.take_shrink_log());
        if log.is_empty() {
            return;
        }
        if tally.fill.n_repair_sweeps == MAX_REPAIR_SWEEPS {
            tally.fill.n_uncovered_after = count_uncovered(cache, store, visible);
            return;
        }
        tally.fill.n_repair_sweeps += 1;
        let grid = grid.get_or_insert_with(|| point_grid(cache, store, &log));
        let lost = lost_records(cache, store, grid, &log);
        let suspect = suspect_points(store, &lost, &mut tally.suspects);
        let check = points_to_check(store, &lost);
        let mut waiting = look_up_again(cache, store, &check, visible, tally);
        waiting.extend(suspect);
        waiting.sort_by_key(|c| (c.k, c.validate));
        waiting.dedup_by_key(|c| c.k);
        if !gather_in_waves(cache, waiting, gather, visible, tally, cancel) {
            return;
        }
    }
}

/// A grid of the store's points with cells about as large as the typical old sphere of `log`'s shrinks
/// (the first sweep's: the most).
fn point_grid<P>(cache: &IrradianceCache, store: &PointStore<P>, log: &[Shrink]) -> PointGrid {
    let mut reach: Vec<f32> = log
        .iter()
        .map(|s| cache.reach_before(s).1)
        .filter(|r| r.is_finite() && *r > 0.0)
        .collect();
    let middle = reach.len() / 2;
    let cell = if reach.is_empty() {
        1.0
    } else {
        *reach.select_nth_unstable_by(middle, f32::total_cmp).1
    };
    PointGrid::new(store.points.iter().map(|(sp, _)| sp.pos).collect(), cell)
}

/// (point, record) for every point a shrink of `log` took a record from, sorted. Each record has one
/// shrink in the log and each point is found once per sphere: the pairs are distinct, and a point's
/// pairs are together, in visiting order (the store's).
fn lost_records<P: Sync>(
    cache: &IrradianceCache,
    store: &PointStore<P>,
    grid: &PointGrid,
    log: &[Shrink],
) -> Vec<(u32, u32)> {
    let mut lost: Vec<(u32, u32)> = log
        .par_iter()
        .with_max_len(64)
        .flat_map_iter(|shrink| {
            let (pos, reach) = cache.reach_before(shrink);
            let mut found = Vec::new();
            grid.for_each_within(pos, reach, |k| {
                let sp = &store.points[k as usize].0;
                if cache.lost_cover(shrink, sp.pos, sp.normal) {
                    found.push((k, shrink.id));
                }
            });
            found
        })
        .collect();
    lost.sort_unstable();
    lost
}

/// The points of `lost` that lost a record a validation gather found wrong (one of `suspects`) and
/// have not been checked yet, as candidates to check: the records still covering them may be as
/// wrong (a light panel's gap is read from several records outside it, one check finds one).
fn suspect_points<P: Clone>(
    store: &mut PointStore<P>,
    lost: &[(u32, u32)],
    suspects: &mut Vec<u32>,
) -> Vec<Candidate<P>> {
    if suspects.is_empty() {
        return Vec::new();
    }
    suspects.sort_unstable();
    suspects.dedup();
    let mut out = Vec::new();
    for &(k, id) in lost {
        if !store.validated[k as usize] && suspects.binary_search(&id).is_ok() {
            store.validated[k as usize] = true;
            let mut c = store.candidate(k, store.points[k as usize].1.clone());
            c.validate = true;
            out.push(c);
        }
    }
    out
}

/// The points of `lost` that may have lost their cover, each point's count of records it can still
/// interpolate lowered. A point still has a record if it lost fewer than it could interpolate at its
/// last lookup, less those lost in earlier sweeps: records only narrow, and each that stopped reaching
/// it is in one log (once it stops it never reaches again). Most points that lose a record keep their
/// cover; only the rest are looked up again.
fn points_to_check<P>(store: &mut PointStore<P>, lost: &[(u32, u32)]) -> Vec<u32> {
    let mut check = Vec::new();
    for ids in lost.chunk_by(|a, b| a.0 == b.0) {
        let (k, n) = (ids[0].0 as usize, ids.len() as u32);
        if n < store.used[k] {
            store.used[k] -= n;
        } else {
            check.push(k as u32);
        }
    }
    check
}

/// Looks up the points `check` (in parallel), noting how many records each can interpolate; the
/// uncovered ones, in order.
fn look_up_again<P: Clone + Send + Sync, S>(
    cache: &IrradianceCache,
    store: &mut PointStore<P>,
    check: &[u32],
    visible: &VisibleFn<P>,
    tally: &mut Tally<S>,
) -> Vec<Candidate<P>> {
    let found: Vec<(LookupStats, u32, Option<Candidate<P>>)> = check
        .par_iter()
        .with_max_len(256)
        .map(|&k| {
            let mut lookups = LookupStats::default();
            let (sp, payload) = &store.points[k as usize];
            let hit = covered(cache, sp, payload, visible);
            lookups.record(hit.as_ref());
            (
                lookups,
                hit.map_or(0, |h| h.n_used),
                hit.is_none().then(|| store.candidate(k, payload.clone())),
            )
        })
        .collect();
    for (&k, (_, used, _)) in check.iter().zip(&found) {
        store.used[k as usize] = *used;
    }
    let mut waiting = Vec::new();
    for (lookups, _, uncovered) in found {
        tally.fill.lookups += lookups;
        waiting.extend(uncovered);
    }
    waiting
}

/// Gathers for the `waiting` points in waves of up to `WAVE_GATHERS`, each point looked up again just
/// before (an earlier wave may have covered it). False when `cancel` stopped it.
fn gather_in_waves<P: Send + Sync, S: AddAssign + Send>(
    cache: &mut IrradianceCache,
    waiting: Vec<Candidate<P>>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    tally: &mut Tally<S>,
    cancel: &AtomicBool,
) -> bool {
    let mut waiting = waiting.into_iter().peekable();
    while waiting.peek().is_some() {
        if cancel.load(Ordering::Relaxed) {
            return false;
        }
        let cache_ref: &IrradianceCache = cache;
        let mut wave: Vec<Candidate<P>> = Vec::with_capacity(WAVE_GATHERS);
        for mut c in waiting.by_ref() {
            let hit = covered(cache_ref, &c.sp, &c.payload, visible);
            tally.fill.lookups.record(hit.as_ref());
            c.validate &= hit.is_some();
            if hit.is_none() || c.validate {
                wave.push(c);
                if wave.len() == WAVE_GATHERS {
                    break;
                }
            }
        }
        if !wave.is_empty() {
            run_wave(cache, &mut wave, gather, visible, tally);
        }
    }
    true
}

/// The first logged shrink of each record, by id: radii only decrease, so a point its first shrink took
/// from the record (usable with the radii before it, not with today's) is every point any of its later
/// shrinks took (a record is often shrunk several times in a sweep).
fn first_shrinks(mut log: Vec<Shrink>) -> Vec<Shrink> {
    // A stable sort keeps each record's shrinks in the order they happened.
    log.sort_by_key(|s| s.id);
    log.dedup_by_key(|s| s.id);
    log
}

/// One pass over `order`'s pixels, keeping every pixel's shading points in `store`; returns the number
/// of records inserted.
#[allow(clippy::too_many_arguments)]
fn sweep<P: Clone + Send + Sync, S: Default + AddAssign + Send>(
    cache: &mut IrradianceCache,
    (mut order, gaps_only): (impl Iterator<Item = (u32, u32)>, bool),
    shading_points: &PointsWithFn<P>,
    store: &mut PointStore<P>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
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
        let before = chunk.len();
        let chunk: Vec<(u32, u32)> = if gaps_only {
            chunk
                .into_iter()
                .filter(|&(x, y)| !store.lattice_covers(x, y))
                .collect()
        } else {
            chunk
        };
        tally.fill.n_pixels_skipped += (before - chunk.len()) as u64;
        let cache_ref: &IrradianceCache = cache;
        let validation = cache_ref.validation();
        let found: Vec<PixelFound<P>> = chunk
            .par_iter()
            .with_max_len(4)
            .map(|&(x, y)| {
                let mut f = PixelFound {
                    lookups: LookupStats::default(),
                    misses: Vec::new(),
                    points: shading_points(x, y),
                    used: Vec::new(),
                    shrink: Vec::new(),
                };
                for (i, (sp, payload)) in f.points.iter().enumerate() {
                    let (hit, deviant) = cache_ref
                        .lookup_adaptive(sp.pos, sp.normal, |id, r| visible(sp, payload, id, r));
                    f.lookups.record(hit.as_ref());
                    f.used.push(hit.map_or(0, |h| h.n_used));
                    f.shrink.extend(deviant);
                    let validate = hit.is_some() && validation.is_some_and(|v| v.selects(x, y, i));
                    if hit.is_none() || validate {
                        f.misses.push(Candidate {
                            x,
                            y,
                            i,
                            sp: *sp,
                            payload: payload.clone(),
                            validate,
                            k: u32::MAX,
                        });
                    }
                }
                f
            })
            .collect();
        // Adaptive caching: the records that disagreed somewhere in the chunk shrink once each, in id
        // order, before the chunk's uncovered points are gathered (each re-checked then).
        let mut shrink: Vec<u32> = found
            .iter()
            .flat_map(|f| f.shrink.iter().copied())
            .collect();
        shrink.sort_unstable();
        shrink.dedup();
        let n_shrunk = shrink
            .into_iter()
            .filter(|&id| cache.shrink_adaptive(id))
            .count() as u64;
        tally.fill.insert.n_shrunk_adaptive += n_shrunk;
        let shrunk = n_shrunk > 0;
        for (&(x, y), f) in chunk.iter().zip(found) {
            store.push(x, y, f.points, f.used);
            tally.fill.n_points += f.lookups.n_lookups;
            tally.fill.lookups += f.lookups;
            // A point that only the deviant records made uncovered may be covered by the rest now.
            let cache_ref: &IrradianceCache = cache;
            pending.extend(f.misses.into_iter().filter(|c| {
                !shrunk
                    || c.validate
                    || cache_ref
                        .lookup_adaptive(c.sp.pos, c.sp.normal, |id, r| {
                            visible(&c.sp, &c.payload, id, r)
                        })
                        .0
                        .is_none()
            }));
        }
        if pending.len() >= WAVE_GATHERS {
            run_wave(cache, &mut pending, gather, visible, tally);
        }
        progress(done);
    }
    if !pending.is_empty() {
        run_wave(cache, &mut pending, gather, visible, tally);
    }
    tally.fill.insert.n_inserted - before
}

/// Gather every pending point in parallel, then insert in visiting order, skipping points covered by
/// records inserted earlier in this wave (their gathers still count in the caller's statistics).
fn run_wave<P: Send + Sync, S: AddAssign + Send>(
    cache: &mut IrradianceCache,
    pending: &mut Vec<Candidate<P>>,
    gather: &GatherWithFn<P, S>,
    visible: &VisibleFn<P>,
    tally: &mut Tally<S>,
) {
    tally.fill.n_waves += 1;
    tally.fill.n_gathers += pending.len() as u64;
    // Every pending point was uncovered when the wave began (looked up since the last wave, or just
    // before this one in the repair), and records only narrow: only this wave's records can cover it,
    // and those are all a re-check reads. Each new record's neighbours in the index are searched in
    // parallel with the gathers; the serial insertion adds the wave's own: made serially,
    // these searches and re-checks were most of the insertion's time, the other cores idle. Under
    // adaptive caching a pending point may have been uncovered only by a deviant record, so the
    // re-check and the search are the full ones there.
    let since = cache.len();
    let within_wave = cache.params().adaptive.is_none();
    let cache_ref: &IrradianceCache = cache;
    let gathered: Vec<(NewRecord, S, Option<Vec<u32>>)> = pending
        .par_iter()
        .with_max_len(1)
        .map(|c| {
            let (rec, s) = gather(c.x, c.y, c.i, &c.sp, &c.payload);
            let rec = NewRecord {
                pixel_world: c.sp.pixel_world,
                ..rec
            };
            let near = if within_wave && cache_ref.params().neighbor_clamping {
                cache_ref.neighbor_candidates(&rec)
            } else {
                None
            };
            (rec, s, near)
        })
        .collect();
    for (c, (rec, s, near)) in pending.drain(..).zip(gathered) {
        tally.gathers += s;
        let seen = |id, r: &Record| visible(&c.sp, &c.payload, id, r);
        if c.validate {
            // A covered point: where its records were right the check's record adds nothing that
            // is worth the lookups it would cost; where they were wrong it takes their place.
            let (checked, shrunk) = cache.validate_with(&rec, seen);
            tally.fill.insert += checked;
            tally.suspects.extend(shrunk);
            if checked.n_validation_failed > 0 {
                tally.fill.insert +=
                    cache.insert_near(rec, near.as_deref().map(|ids| (ids, since)));
            }
            continue;
        }
        let hit = if within_wave {
            cache.lookup_since_visible(c.sp.pos, c.sp.normal, Pass::A, since, seen)
        } else {
            cache.lookup_first_visible(c.sp.pos, c.sp.normal, Pass::A, usize::MAX, seen)
        };
        tally.fill.lookups.record(hit.as_ref());
        if hit.is_some() {
            tally.fill.n_skipped_covered += 1;
            continue;
        }
        tally.fill.insert += cache.insert_near(rec, near.as_deref().map(|ids| (ids, since)));
    }
}

/// Shading points with no usable pass-A record.
fn count_uncovered<P: Clone + Sync>(
    cache: &IrradianceCache,
    store: &PointStore<P>,
    visible: &VisibleFn<P>,
) -> u64 {
    store
        .points
        .par_iter()
        .with_min_len(1024)
        .filter(|(sp, payload)| covered(cache, sp, payload, visible).is_none())
        .count() as u64
}

/// Pass A's lookup at a shading point, over the records `visible` accepts there.
fn covered<P>(
    cache: &IrradianceCache,
    sp: &ShadingPoint,
    payload: &P,
    visible: &VisibleFn<P>,
) -> Option<Lookup> {
    cache.cover(sp.pos, sp.normal, |id, r| visible(sp, payload, id, r))
}
