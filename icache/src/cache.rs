//! The irradiance cache: records, their spatial index, and interpolation
//! E(p) = Σ wᵢ [Eᵢ + (nᵢ × n)·∇r Eᵢ + (p − pᵢ)·∇t Eᵢ] / Σ wᵢ over the usable records.
#![forbid(unsafe_code)]

use glam::Vec3;
use pmbase::luminance;

use crate::error::{Error, Result};
use crate::index::Octree;
use crate::params::{CacheParams, Pass};
use crate::record::{finite_rel_err, Lookup, NewRecord, Record};
use crate::stats::InsertStats;
use crate::weight::usable_weight;

/// Weighted sum over usable records.
#[derive(Default)]
struct Accum {
    sum: Vec3,
    weight_sum: f32,
    n_used: u32,
}

impl Accum {
    fn add(&mut self, w: f32, e: Vec3) {
        self.sum += w * e;
        self.weight_sum += w;
        self.n_used += 1;
    }
}

/// The share of a cosine lobe about `n_turned` that lies above the plane of normal `n`,
/// (1 + n·n_turned)/2: a bumped facet turned by α sees that much of a uniform sky, the rest of its
/// hemisphere being under the smooth surface, which blocks it. The rotational gradient, a first-order
/// term, cannot say so (the change is of second order in α). On a floor whose normal map tilts it
/// 25°, turned records read its soft indirect light 3.1 % brighter than records gathered on the
/// tilted normals without this factor, 1.1 % with it.
fn horizon_share(n: Vec3, n_turned: Vec3) -> f32 {
    (0.5 * (1.0 + n.dot(n_turned))).clamp(0.0, 1.0)
}

/// A cache without gradients turns a record's irradiance to a bumped normal only where its dominant
/// direction is at least this far above the smooth tangent plane (the cosine): nearer to grazing,
/// the first-order change divides by almost nothing.
const MIN_TURN_COS: f32 = 0.1;

thread_local! {
    static CANDIDATES: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Ward's irradiance cache with gradients, TL weighting and neighbor clamping.
#[derive(Clone, Debug)]
pub struct IrradianceCache {
    pub(crate) params: CacheParams,
    pub(crate) bounds: (Vec3, Vec3),
    pub(crate) records: Vec<Record>,
    pub(crate) index: Octree,
    pub(crate) totals: InsertStats,
    /// Reused buffer for neighbor queries during insertion.
    pub(crate) scratch: Vec<u32>,
    /// The radius each record's sphere was put into the index with (its cells), by record id.
    pub(crate) indexed: Vec<f32>,
    /// While `Some`: every shrink of an existing record (by neighbor clamping or adaptive caching), with
    /// the record's radii before it, for the fill's repair sweeps (only points that a record could
    /// interpolate before a shrink and cannot after it can have lost their cover).
    pub(crate) shrink_log: Option<Vec<Shrink>>,
    /// Records below this id keep their radii: insertions neither clamp nor shrink them (set by
    /// [`Self::freeze`]).
    pub(crate) frozen: usize,
    /// The record count at the end of each stage of the fill ([`Self::end_stage`]).
    pub(crate) stages: Vec<u32>,
    /// Pass A's checks of covered points ([`crate::validation`]); `None`: none.
    pub(crate) validation: Option<crate::Validation>,
}

/// A record's radii before one of its shrinks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Shrink {
    pub id: u32,
    pub r_harmonic: f32,
    pub r_clamped: f32,
}

impl Shrink {
    pub(crate) fn of(id: u32, rec: &Record) -> Shrink {
        Shrink {
            id,
            r_harmonic: rec.r_harmonic,
            r_clamped: rec.r_clamped,
        }
    }
}

impl IrradianceCache {
    /// An empty cache whose index covers [bounds_min, bounds_max] (records outside still work, more slowly).
    pub fn new(bounds_min: Vec3, bounds_max: Vec3, params: CacheParams) -> Result<Self> {
        params.validate()?;
        // The extent must be finite too: octree cells halve it, and an infinite cell never shrinks.
        let extent = (bounds_max - bounds_min).max_element() * 1.02;
        if !(bounds_min.is_finite()
            && bounds_max.is_finite()
            && bounds_min.cmple(bounds_max).all()
            && extent.is_finite())
        {
            return Err(Error::InvalidBounds(format!(
                "[{bounds_min}, {bounds_max}] (its extent must be finite)"
            )));
        }
        Ok(IrradianceCache {
            params,
            bounds: (bounds_min, bounds_max),
            records: Vec::new(),
            index: Octree::new(bounds_min, bounds_max),
            totals: InsertStats::default(),
            scratch: Vec::new(),
            indexed: Vec::new(),
            shrink_log: None,
            frozen: 0,
            stages: Vec::new(),
            validation: None,
        })
    }

    /// From now on the records there are keep their radii: later insertions clamp themselves against
    /// them but shrink none of them (neighbor clamping and adaptive caching act on the later records
    /// only), so a lookup over the first [`len`](Self::len) records gives what it gives now.
    pub(crate) fn freeze(&mut self) {
        self.frozen = self.records.len();
    }

    /// Ends a stage of the fill — pass A, or a round of pass B, whether or not it made records — noting
    /// the record count. With frozen records, [`Self::lookup_first`] over a stage's count is the cache as
    /// it stood then, also in a cache read from a file: a render with it takes the same samples.
    pub fn end_stage(&mut self) {
        self.stages.push(self.records.len() as u32);
    }

    /// The records so far as one stage, ended now: a first round of pass B reads them all (a cache
    /// whose pass A ran over several views, each ending a stage of its own).
    pub fn one_stage(&mut self) {
        self.stages.clear();
        self.end_stage();
    }

    /// The record count at the end of each stage so far.
    pub fn stages(&self) -> &[u32] {
        &self.stages
    }

    pub fn params(&self) -> &CacheParams {
        &self.params
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Records in insertion order.
    pub fn records(&self) -> &[Record] {
        &self.records
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Sum of the statistics of every insertion so far.
    pub(crate) fn insert_totals(&self) -> &InsertStats {
        &self.totals
    }

    /// Heap and inline bytes held by the records and the index.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
            + self.records.capacity() * std::mem::size_of::<Record>()
            + self.index.memory_bytes()
            + self.scratch.capacity() * 4
            + self.indexed.capacity() * 4
    }

    /// Interpolated irradiance at `p` with unit normal `n`, or `None` when no record is usable there.
    pub fn lookup(&self, p: Vec3, n: Vec3, pass: Pass) -> Option<Lookup> {
        self.lookup_first(p, n, pass, usize::MAX)
    }

    /// [`lookup_first`](Self::lookup_first) over the usable records that `visible(id, record)` also
    /// accepts (the caller's occlusion test between the point and the record), called only for those
    /// usable.
    pub fn lookup_first_visible(
        &self,
        p: Vec3,
        n: Vec3,
        pass: Pass,
        n_records: usize,
        visible: impl Fn(u32, &Record) -> bool,
    ) -> Option<Lookup> {
        let mut acc = Accum::default();
        self.each_used(p, n, pass, n_records, visible, |_, w, e| acc.add(w, e));
        self.finish(acc)
    }

    /// [`lookup_first_visible`](Self::lookup_first_visible), also writing to `ids` the ids of the
    /// records it interpolates (in record order) when their values at `p` differ by more than
    /// `agree` times the interpolation's luminance: only then does the interpolation change much
    /// near `p`. `ids` is cleared first, and left empty where the records agree or none is usable.
    #[allow(clippy::too_many_arguments)]
    pub fn lookup_noting(
        &self,
        p: Vec3,
        n: Vec3,
        pass: Pass,
        n_records: usize,
        visible: impl Fn(u32, &Record) -> bool,
        agree: f32,
        ids: &mut Vec<u32>,
    ) -> Option<Lookup> {
        self.lookup_noting_turned(p, n, n, pass, n_records, visible, agree, ids)
    }

    /// [`lookup_noting`](Self::lookup_noting) at a point whose shading normal a bump turned from `n`
    /// to `n_turned`: the records are chosen and weighted by `n`, so that bumps neither multiply nor
    /// thin them, and each one's irradiance is turned to `n_turned` (see [`Self::each_used_turned`]).
    #[allow(clippy::too_many_arguments)]
    pub fn lookup_noting_turned(
        &self,
        p: Vec3,
        n: Vec3,
        n_turned: Vec3,
        pass: Pass,
        n_records: usize,
        visible: impl Fn(u32, &Record) -> bool,
        agree: f32,
        ids: &mut Vec<u32>,
    ) -> Option<Lookup> {
        ids.clear();
        let mut acc = Accum::default();
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        self.each_used_turned(p, n, n_turned, pass, n_records, visible, |id, w, e| {
            acc.add(w, e);
            ids.push(id);
            let l = luminance(e);
            (lo, hi) = (lo.min(l), hi.max(l));
        });
        let found = self.finish(acc);
        if !found.is_some_and(|l| hi - lo > agree * luminance(l.e)) {
            ids.clear();
        }
        found
    }

    /// The interpolation at (p, n) over the records `ids` alone (in record order; those of them usable
    /// there, without the index or a visibility test): how the interpolation a lookup made
    /// ([`lookup_noting`](Self::lookup_noting)) goes on near its point. Ids past the cache's end are
    /// skipped.
    pub fn lookup_among(&self, p: Vec3, n: Vec3, pass: Pass, ids: &[u32]) -> Option<Lookup> {
        if !(p.is_finite() && n.is_finite()) {
            return None;
        }
        let mut acc = Accum::default();
        for rec in ids.iter().filter_map(|&id| self.records.get(id as usize)) {
            if let Some((w, e)) = self.weighted(rec, p, n, pass) {
                acc.add(w, e);
            }
        }
        self.finish(acc)
    }

    /// The records [`lookup_first_visible`](Self::lookup_first_visible) would interpolate at (p, n), each
    /// with its weight and its irradiance extrapolated to p by its gradients: `each(id, w, e)` in record
    /// order. For payloads the caller keeps beside the records (a radiance cache's coefficients).
    pub fn each_used(
        &self,
        p: Vec3,
        n: Vec3,
        pass: Pass,
        n_records: usize,
        visible: impl Fn(u32, &Record) -> bool,
        each: impl FnMut(u32, f32, Vec3),
    ) {
        self.each_used_turned(p, n, n, pass, n_records, visible, each)
    }

    /// [`each_used`](Self::each_used) with the records chosen and weighted by normal `n` and each
    /// one's irradiance turned to normal `n_turned` (a bumped normal): by its rotational gradient,
    /// (nᵢ × n_turned)·∇r E in place of (nᵢ × n)·∇r E (Ward & Heckbert's first-order term, as
    /// Radiance applies bump maps); in a cache without gradients, by the first-order change of a
    /// light from the record's dominant direction, E (1 + (n_turned − n)·d / (n·d)), held to [0, 2E];
    /// then times the share of the turned hemisphere above the smooth surface ([`horizon_share`]).
    #[allow(clippy::too_many_arguments)]
    pub fn each_used_turned(
        &self,
        p: Vec3,
        n: Vec3,
        n_turned: Vec3,
        pass: Pass,
        n_records: usize,
        visible: impl Fn(u32, &Record) -> bool,
        mut each: impl FnMut(u32, f32, Vec3),
    ) {
        if !(p.is_finite() && n.is_finite() && n_turned.is_finite()) {
            return;
        }
        self.with_candidates(p, pass, n_records, |ids| {
            for &id in ids {
                let rec = &self.records[id as usize];
                if let Some((w, e)) = self.weighted_turned(rec, p, n, n_turned, pass) {
                    if visible(id, rec) {
                        each(id, w, e);
                    }
                }
            }
        })
    }

    /// [`lookup`](Self::lookup) over the first `n_records` records only (in insertion order): what the
    /// cache held at that moment of a one-pass fill.
    pub fn lookup_first(&self, p: Vec3, n: Vec3, pass: Pass, n_records: usize) -> Option<Lookup> {
        self.lookup_first_visible(p, n, pass, n_records, |_, _| true)
    }

    /// [`lookup`](Self::lookup) over the records from id `since` on that `visible(id, record)` also
    /// accepts, scanned without the index: the lookup of a point that no record before `since` could
    /// interpolate (records only narrow), which gives the same answer as the full one.
    pub(crate) fn lookup_since_visible(
        &self,
        p: Vec3,
        n: Vec3,
        pass: Pass,
        since: usize,
        visible: impl Fn(u32, &Record) -> bool,
    ) -> Option<Lookup> {
        if !(p.is_finite() && n.is_finite()) {
            return None;
        }
        let mut acc = Accum::default();
        for (k, rec) in self.records.iter().enumerate().skip(since) {
            if let Some((w, e)) = self.weighted(rec, p, n, pass) {
                if visible(k as u32, rec) {
                    acc.add(w, e);
                }
            }
        }
        self.finish(acc)
    }

    /// Pass A's lookup under adaptive caching (Křivánek et al. 2006): the interpolation at (p, n), unless
    /// the usable records disagree there — one's extrapolated luminance differs from their weighted mean
    /// by more than the Weber fraction τ — and the most deviant of them can still shrink. Then no
    /// interpolation (the point is uncovered) and that record's id, to be shrunk by the caller.
    /// Without adaptive caching, [`lookup`](Self::lookup) with `Pass::A`.
    /// Only the records `visible(id, record)` accepts take part.
    pub(crate) fn lookup_adaptive(
        &self,
        p: Vec3,
        n: Vec3,
        visible: impl Fn(u32, &Record) -> bool,
    ) -> (Option<Lookup>, Option<u32>) {
        let Some(tau) = self.params.adaptive else {
            return (self.cover(p, n, visible), None);
        };
        if !(p.is_finite() && n.is_finite()) {
            return (None, None);
        }
        self.with_candidates(p, Pass::A, usize::MAX, |ids| {
            let mut acc = Accum::default();
            // (id, luminance of its extrapolation) of the usable records, in record order.
            let mut used: Vec<(u32, f32)> = Vec::with_capacity(ids.len());
            for &id in ids {
                let rec = &self.records[id as usize];
                if let Some((w, e)) = self.weighted(rec, p, n, Pass::A) {
                    if visible(id, rec) {
                        acc.add(w, e);
                        used.push((id, luminance(e.max(Vec3::ZERO))));
                    }
                }
            }
            let lookup = self.finish(acc);
            let Some(l) = lookup else { return (None, None) };
            let mean = luminance(l.e);
            let deviant = used
                .iter()
                .filter(|(_, li)| (li - mean).abs() > tau * mean)
                .filter(|(id, _)| self.can_shrink_adaptive(*id))
                .max_by(|a, b| {
                    (a.1 - mean)
                        .abs()
                        .total_cmp(&(b.1 - mean).abs())
                        .then(b.0.cmp(&a.0))
                });
            match deviant {
                Some(&(id, _)) if used.len() > 1 => (None, Some(id)),
                _ => (lookup, None),
            }
        })
    }

    /// Pass A's coverage test: whether a record usable at (p, n) that `visible(id, record)` accepts
    /// exists, as the interpolation of that one record alone (`n_used` 1, a lower bound on the records
    /// usable there). The interpolation itself is not made: pass A needs only whether it exists, and
    /// the visibility test of each record of an earlier frame is a ray. The newest records are tried
    /// first (those of the frame being filled need no ray).
    pub(crate) fn cover(
        &self,
        p: Vec3,
        n: Vec3,
        visible: impl Fn(u32, &Record) -> bool,
    ) -> Option<Lookup> {
        if !(p.is_finite() && n.is_finite()) {
            return None;
        }
        let scale = (self.params.a(Pass::A) / self.params.index_factor()).min(1.0);
        CANDIDATES.with(|cell| {
            let mut ids = cell.borrow_mut();
            ids.clear();
            self.index
                .for_each_candidate_within(p, scale, |id| ids.push(id));
            ids.sort_unstable_by(|a, b| b.cmp(a));
            ids.iter().find_map(|&id| {
                let rec = &self.records[id as usize];
                let (w, e) = self.weighted(rec, p, n, Pass::A)?;
                let mut acc = Accum::default();
                acc.add(w, e);
                visible(id, rec).then(|| self.finish(acc)).flatten()
            })
        })
    }

    /// `f` over the ids of the index's candidate records at `p` for `pass` below `n_records`, sorted and
    /// unique. Sums run in record order, not in index order: the index of a cache loaded from a file can
    /// hold the same records in other nodes, and the image must not change in the last bit.
    fn with_candidates<T>(
        &self,
        p: Vec3,
        pass: Pass,
        n_records: usize,
        f: impl FnOnce(&[u32]) -> T,
    ) -> T {
        // A record is usable only within a·R' (both weightings; see `params`), and the index holds it
        // with the loosest pass's reach.
        let scale = (self.params.a(pass) / self.params.index_factor()).min(1.0);
        CANDIDATES.with(|cell| {
            let mut ids = cell.borrow_mut();
            ids.clear();
            self.index.for_each_candidate_within(p, scale, |id| {
                if (id as usize) < n_records {
                    ids.push(id)
                }
            });
            ids.sort_unstable();
            ids.dedup();
            f(&ids)
        })
    }

    /// The same as [`lookup`](Self::lookup) by scanning every record: the oracle for the index.
    #[cfg(test)]
    pub(crate) fn lookup_brute(&self, p: Vec3, n: Vec3, pass: Pass) -> Option<Lookup> {
        self.lookup_since_visible(p, n, pass, 0, |_, _| true)
    }

    /// Indices of the records usable at (p, n), by brute force, sorted.
    #[cfg(test)]
    pub(crate) fn usable_records_brute(&self, p: Vec3, n: Vec3, pass: Pass) -> Vec<usize> {
        (0..self.records.len())
            .filter(|&i| usable_weight(&self.params, pass, &self.records[i], p, n).is_some())
            .collect()
    }

    /// A usable record's weight at (p, n) and its irradiance extrapolated there by its gradients.
    #[inline]
    fn weighted(&self, rec: &Record, p: Vec3, n: Vec3, pass: Pass) -> Option<(f32, Vec3)> {
        self.weighted_turned(rec, p, n, n, pass)
    }

    /// [`weighted`](Self::weighted) by normal `n`, the irradiance turned to `n_turned` (see
    /// [`each_used_turned`](Self::each_used_turned)).
    #[inline]
    fn weighted_turned(
        &self,
        rec: &Record,
        p: Vec3,
        n: Vec3,
        n_turned: Vec3,
        pass: Pass,
    ) -> Option<(f32, Vec3)> {
        let w = usable_weight(&self.params, pass, rec, p, n)?;
        let mut e = rec.e;
        if self.params.gradients {
            let axis = rec.normal.cross(n_turned);
            let dp = p - rec.pos;
            for c in 0..3 {
                e[c] += axis.dot(rec.grad_r[c]) + dp.dot(rec.grad_t[c]);
            }
        } else if n_turned != n {
            let d = rec.dir.normalize_or_zero();
            let cos = n.dot(d);
            if cos > MIN_TURN_COS {
                e *= (1.0 + (n_turned - n).dot(d) / cos).clamp(0.0, 2.0);
            }
        }
        if n_turned != n {
            e *= horizon_share(n, n_turned);
        }
        Some((w, e))
    }

    #[inline]
    fn finish(&self, acc: Accum) -> Option<Lookup> {
        if acc.n_used == 0 || acc.weight_sum <= 0.0 || acc.weight_sum.is_nan() {
            return None;
        }
        let e = acc.sum / acc.weight_sum;
        if !e.is_finite() {
            return None;
        }
        Some(Lookup {
            e: e.max(Vec3::ZERO),
            n_used: acc.n_used,
            weight_sum: acc.weight_sum,
        })
    }

    /// The interpolation at (p, n) as [`lookup`](Self::lookup) makes it, and the standard deviation of
    /// its luminance that the records' own gather noise gives it: √(Σ wᵢ² σᵢ²) / Σ wᵢ with σᵢ each
    /// record's [`Record::rel_err`] times its luminance (the records' gathers are independent).
    pub fn lookup_with_noise(&self, p: Vec3, n: Vec3, pass: Pass) -> Option<(Lookup, f32)> {
        if !(p.is_finite() && n.is_finite()) {
            return None;
        }
        self.with_candidates(p, pass, usize::MAX, |ids| {
            let (mut acc, mut var) = (Accum::default(), 0.0f64);
            for &id in ids {
                let rec = &self.records[id as usize];
                if let Some((w, e)) = self.weighted(rec, p, n, pass) {
                    acc.add(w, e);
                    var += ((w * rec.rel_err * luminance(rec.e)) as f64).powi(2);
                }
            }
            let sum = acc.weight_sum;
            self.finish(acc)
                .map(|l| (l, (var.sqrt() / sum as f64) as f32))
        })
    }

    /// Record `id` with a further gather at its point folded in: `more` (its irradiance, gradients and
    /// noise; position and radii are kept), weighted `share` of the sum (its share of the rays) against
    /// the record's `1 − share`. The translational gradient gets the scale the record's own carries
    /// (R/R' where R < R'). The noise becomes that of the weighted sum of independent gathers (an upper
    /// bound for rounds whose jitter stratifies together, `gather::gather_batch_round`).
    pub fn refine(&mut self, id: usize, more: &NewRecord, share: f32) {
        let Some(rec) = self.records.get_mut(id) else {
            return;
        };
        if !(share > 0.0 && share < 1.0) || !more.e.is_finite() {
            return;
        }
        let keep = 1.0 - share;
        let s = self.params.start_scale() * rec.r_harmonic;
        let scale = if s < rec.r_clamped {
            s / rec.r_clamped
        } else {
            1.0
        };
        let old_sd = rec.rel_err * luminance(rec.e);
        let new_sd = finite_rel_err(more.rel_err) * luminance(more.e);
        rec.e = (keep * rec.e + share * more.e.max(Vec3::ZERO)).max(Vec3::ZERO);
        for c in 0..3 {
            if more.grad_r[c].is_finite() && more.grad_t[c].is_finite() {
                rec.grad_r[c] = keep * rec.grad_r[c] + share * more.grad_r[c];
                rec.grad_t[c] = keep * rec.grad_t[c] + share * scale * more.grad_t[c];
            }
        }
        // The gradient limit of a new record (extrapolation within R' changes no channel by more than
        // 100 %) also holds after the fold: a further gather's ray may meet a surface almost at the
        // record's point, where its translational gradient grows without bound.
        let worst = (0..3)
            .map(|c| rec.grad_t[c].length() * rec.r_clamped / rec.e[c])
            .filter(|x| !x.is_nan())
            .fold(0.0f32, f32::max);
        if worst > 1.0 {
            rec.grad_t.iter_mut().for_each(|g| *g /= worst);
        }
        let l = luminance(rec.e);
        rec.rel_err = if l > 0.0 {
            ((keep * old_sd).powi(2) + (share * new_sd).powi(2)).sqrt() / l
        } else {
            0.0
        };
    }

    /// Lazy caching: the pass-A interpolation at (p, n) if one exists, else run `gather`, insert its record
    /// (with `pixel_world` overriding the one it returns) and interpolate again. Falls back to the gathered
    /// irradiance itself if the record was rejected (non-finite position or normal).
    pub fn get_or_insert_with(
        &mut self,
        p: Vec3,
        n: Vec3,
        pixel_world: f32,
        gather: impl FnOnce() -> NewRecord,
    ) -> Vec3 {
        if let Some(hit) = self.lookup(p, n, Pass::A) {
            return hit.e;
        }
        let rec = NewRecord {
            pixel_world,
            ..gather()
        };
        let fallback = rec.e;
        self.insert(rec);
        match self.lookup(p, n, Pass::A) {
            Some(hit) => hit.e,
            None if fallback.is_finite() => fallback.max(Vec3::ZERO),
            None => Vec3::ZERO,
        }
    }

    /// Start (or stop) logging the records that neighbor clamping shrinks; see [`Self::take_shrink_log`].
    pub(crate) fn log_shrinks(&mut self, on: bool) {
        self.shrink_log = on.then(Vec::new);
    }

    /// Put record `id` (the newest) into the index with its reach.
    pub(crate) fn index_new(&mut self, id: u32, pos: Vec3, r_clamped: f32) {
        let radius = r_clamped * self.params.index_factor();
        self.index.insert(id, pos, radius);
        self.indexed.push(radius);
    }

    /// Tell the index that record `id`'s R' has shrunk.
    pub(crate) fn reindex(&mut self, id: u32) {
        let rec = &self.records[id as usize];
        self.indexed[id as usize] = self.index.shrink(
            id,
            rec.pos,
            self.indexed[id as usize],
            rec.r_clamped * self.params.index_factor(),
        );
    }

    /// The shrinks logged since the last call.
    pub(crate) fn take_shrink_log(&mut self) -> Vec<Shrink> {
        self.shrink_log
            .as_mut()
            .map(std::mem::take)
            .unwrap_or_default()
    }

    /// Where the record of `shrink` reaches in pass A before the shrink: its position and radius.
    pub(crate) fn reach_before(&self, shrink: &Shrink) -> (Vec3, f32) {
        (
            self.records[shrink.id as usize].pos,
            shrink.r_clamped * self.params.a(Pass::A),
        )
    }

    /// True when the record of `shrink` could interpolate at (p, n) in pass A before the shrink and
    /// cannot now. Every test of usability only narrows as R and R' shrink, so a point this is false for
    /// at every logged shrink has lost no record.
    pub(crate) fn lost_cover(&self, shrink: &Shrink, p: Vec3, n: Vec3) -> bool {
        let now = &self.records[shrink.id as usize];
        let before = Record {
            r_harmonic: shrink.r_harmonic,
            r_clamped: shrink.r_clamped,
            ..*now
        };
        usable_weight(&self.params, Pass::A, &before, p, n).is_some()
            && usable_weight(&self.params, Pass::A, now, p, n).is_none()
    }

    /// The records `keep` returns (each given with its index; `None` drops it), in order, as a new cache
    /// over `bounds` (the next frame of a sequence: records reused where they are still valid, their
    /// irradiance possibly updated). They are frozen, as records read from a file are, and no stage is
    /// recorded yet. Returns the cache and how many records were dropped.
    pub fn rebuilt(
        self,
        bounds: (Vec3, Vec3),
        mut keep: impl FnMut(usize, Record) -> Option<Record>,
    ) -> Result<(Self, usize)> {
        let mut cache = IrradianceCache::new(bounds.0, bounds.1, self.params)?;
        let mut dropped = 0;
        for (i, rec) in self.records.into_iter().enumerate() {
            match keep(i, rec) {
                Some(r) => cache.push_raw(r),
                None => dropped += 1,
            }
        }
        cache.frozen = cache.len();
        Ok((cache, dropped))
    }

    /// Lets later insertions shrink every record again (neighbor clamping, adaptive caching): the
    /// next frame of a sequence fills its pass A over the records of earlier frames, whose repair
    /// sweeps restore the cover of this frame's points that a shrink takes away.
    pub fn thaw(&mut self) {
        self.frozen = 0;
    }

    /// Put a finished record back (file loading): no gradient limit, clamping or neighbor clamping.
    pub(crate) fn push_raw(&mut self, rec: Record) {
        let id = self.records.len() as u32;
        self.index_new(id, rec.pos, rec.r_clamped);
        self.records.push(rec);
    }
}
