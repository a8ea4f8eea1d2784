//! Adding a record, in an order that matters (each step works on the radius the one before left):
//! gradient limit on R, clamp R' to the pixel-based spacing bounds, scale ∇t by R/R' where R < R',
//! Křivánek's neighbor clamping on the unclamped R (with R' recomputed), then insertion into the
//! index.
//!
//! Neighbor clamping is propagated (Dijkstra order over overlapping records) rather than applied
//! one level deep: after every insertion R_j ≤ R_k + |p_j − p_k| holds both ways for every pair
//! whose R' spheres overlap. Radii only decrease and edge weights are positive, so the propagation
//! terminates.
#![forbid(unsafe_code)]

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::Vec3;

use crate::cache::{IrradianceCache, Shrink};
use crate::params::CacheParams;
use crate::record::{finite_rel_err, NewRecord, Record};
use crate::stats::InsertStats;

/// [R_min, R_max] in world units at a record with the given pixel footprint.
fn spacing_bounds(params: &CacheParams, pixel_world: f32) -> (f32, f32) {
    (
        params.min_spacing_px * pixel_world,
        params.max_spacing_px * pixel_world,
    )
}

/// The factor step 3 applies to ∇t: R/R' where R < R', else 1.
fn grad_scale(r: f32, r_clamped: f32) -> f32 {
    if r < r_clamped {
        r / r_clamped
    } else {
        1.0
    }
}

/// A record's R' for its unclamped R: s·R clamped to s times the pixel spacing bounds, where s is
/// the reach multiple of a new record (2 under adaptive caching, else 1).
fn clamped_reach(params: &CacheParams, r: f32, pixel_world: f32) -> (f32, f32) {
    let s = params.start_scale();
    let (lo, hi) = spacing_bounds(params, pixel_world);
    (s * r, (s * r).clamp(s * lo, s * hi))
}

/// Set a record's unclamped R, recompute R' (never growing it: adaptive caching may have shrunk it
/// further) and keep ∇t scaled by min(1, sR/R') for the new values.
fn set_radius(params: &CacheParams, rec: &mut Record, r: f32) {
    let s = params.start_scale();
    let old_scale = grad_scale(s * rec.r_harmonic, rec.r_clamped);
    rec.r_harmonic = r;
    rec.r_clamped = rec
        .r_clamped
        .min(clamped_reach(params, r, rec.pixel_world).1);
    let new_scale = grad_scale(s * rec.r_harmonic, rec.r_clamped);
    if old_scale > 0.0 && new_scale != old_scale {
        let f = new_scale / old_scale;
        rec.grad_t.iter_mut().for_each(|g| *g *= f);
    }
}

fn finite_or_zero(v: Vec3) -> (Vec3, bool) {
    if v.is_finite() {
        (v, false)
    } else {
        (Vec3::ZERO, true)
    }
}

/// Steps 1–3 on a gather result; `None` when the record cannot be placed at all.
fn prepare(params: &CacheParams, new: &NewRecord, stats: &mut InsertStats) -> Option<Record> {
    let normal = new.normal.try_normalize()?;
    if !(new.pos.is_finite() && new.pixel_world.is_finite() && new.pixel_world > 0.0) {
        return None;
    }
    let mut repaired = false;
    // Per channel: a NaN in one channel should not erase the others.
    let e =
        Vec3::from_array(
            new.e
                .to_array()
                .map(|x| if x.is_finite() { x.max(0.0) } else { f32::NAN }),
        );
    repaired |= e != new.e;
    let e = Vec3::from_array(e.to_array().map(|x| if x.is_nan() { 0.0 } else { x }));
    let mut grad_r = new.grad_r;
    let mut grad_t = new.grad_t;
    for g in grad_r.iter_mut().chain(grad_t.iter_mut()) {
        let (v, bad) = finite_or_zero(*g);
        *g = v;
        repaired |= bad;
    }
    let mut r = new.r_harmonic;
    if r.is_nan() || r < 0.0 {
        r = 0.0;
        repaired = true;
    }
    stats.n_sanitized += repaired as u64;
    // 1. Gradient limit: first-order extrapolation may not change any channel by more than 100 %.
    let limit = (0..3)
        .filter(|&c| grad_t[c].length() > 0.0)
        .map(|c| e[c] / grad_t[c].length())
        .fold(f32::INFINITY, f32::min);
    if limit < r {
        r = limit;
        stats.n_shrunk_by_gradient += 1;
    }
    // 2. Clamp to the pixel-based spacing bounds.
    let (lo, hi) = spacing_bounds(params, new.pixel_world);
    stats.n_clamped_min += (r < lo) as u64;
    stats.n_clamped_max += (r > hi) as u64;
    let (reach, r_clamped) = clamped_reach(params, r, new.pixel_world);
    // 3. A record spread wider than its R must not extrapolate to negative values.
    let s = grad_scale(reach, r_clamped);
    grad_t.iter_mut().for_each(|g| *g *= s);
    let (dir, _) = finite_or_zero(new.dir);
    Some(Record {
        pos: new.pos,
        normal,
        e,
        grad_r,
        grad_t,
        r_harmonic: r,
        r_clamped,
        dir,
        pixel_world: new.pixel_world,
        rel_err: finite_rel_err(new.rel_err),
        at: new.at,
    })
}

impl IrradianceCache {
    /// Adaptive caching: halve record `id`'s R' (never below its plain pixel spacing bound),
    /// logging its old reach for the repair sweeps. False when it is already there.
    pub(crate) fn shrink_adaptive(&mut self, id: u32) -> bool {
        if (id as usize) < self.frozen {
            return false;
        }
        let params = self.params;
        let rec = &mut self.records[id as usize];
        let floor = spacing_bounds(&params, rec.pixel_world).0;
        let r = (0.5 * rec.r_clamped).max(floor);
        if !(r < rec.r_clamped) {
            return false;
        }
        if let Some(log) = &mut self.shrink_log {
            log.push(Shrink::of(id, rec));
        }
        rec.r_clamped = r;
        self.totals.n_shrunk_adaptive += 1;
        self.reindex(id);
        true
    }

    /// Whether record `id` can still be shrunk by adaptive caching.
    pub(crate) fn can_shrink_adaptive(&self, id: u32) -> bool {
        let rec = &self.records[id as usize];
        id as usize >= self.frozen
            && rec.r_clamped > 1.001 * spacing_bounds(&self.params, rec.pixel_world).0
    }

    /// Add a gather result as a new record (see the module header for the steps).
    pub fn insert(&mut self, new: NewRecord) -> InsertStats {
        self.insert_near(new, None)
    }

    /// The records whose spheres may overlap the sphere `new` will get (a superset: radii only
    /// shrink), from the index as it stands; `None` when `new` cannot be placed. Read-only, so a
    /// wave's gathers can make these queries in parallel and its serial insertions skip them
    /// ([`Self::insert_near`]).
    pub(crate) fn neighbor_candidates(&self, new: &NewRecord) -> Option<Vec<u32>> {
        let rec = prepare(&self.params, new, &mut InsertStats::default())?;
        let mut ids = Vec::new();
        self.index.query_sphere(rec.pos, rec.r_clamped, &mut ids);
        Some(ids)
    }

    /// [`insert`](Self::insert), given `near = (ids, since)`: the [`neighbor_candidates`] of `new`
    /// when the cache held `since` records (those inserted after are checked too). The same record
    /// and the same clampings as `insert`, without searching the index for the new record's
    /// neighbours.
    pub(crate) fn insert_near(
        &mut self,
        new: NewRecord,
        near: Option<(&[u32], usize)>,
    ) -> InsertStats {
        let mut stats = InsertStats::default();
        let Some(rec) = prepare(&self.params, &new, &mut stats) else {
            stats.n_rejected += 1;
            self.totals += stats;
            return stats;
        };
        let j = self.records.len();
        self.records.push(rec);
        let mut shrunk = Vec::new();
        if self.params.neighbor_clamping && self.clamp_new_record(j, near) {
            shrunk.push(j as u32);
        }
        // 5. Insert into the index (before propagation, which must see the new record).
        let rec = self.records[j];
        self.index_new(j as u32, rec.pos, rec.r_clamped);
        if self.params.neighbor_clamping {
            self.propagate_clamping(j, &mut shrunk);
        }
        shrunk.sort_unstable();
        shrunk.dedup();
        stats.n_shrunk_by_neighbors += shrunk.len() as u64;
        stats.n_inserted += 1;
        self.totals += stats;
        stats
    }

    /// 4a. R_j ← min(R_j, R_k + |p_j − p_k|) over existing records k overlapping j (from the index,
    /// or `near`'s candidates and the records after them). True if R_j shrank.
    fn clamp_new_record(&mut self, j: usize, near: Option<(&[u32], usize)>) -> bool {
        let rec_j = self.records[j];
        let mut ids = std::mem::take(&mut self.scratch);
        match near {
            Some((candidates, since)) => {
                ids.clear();
                ids.extend_from_slice(candidates);
                ids.extend(since as u32..j as u32);
            }
            None => self
                .index
                .query_sphere(rec_j.pos, rec_j.r_clamped, &mut ids),
        }
        let mut r_j = rec_j.r_harmonic;
        for &k in &ids {
            let rec_k = &self.records[k as usize];
            let d = (rec_j.pos - rec_k.pos).length();
            if d < rec_j.r_clamped + rec_k.r_clamped {
                r_j = r_j.min(rec_k.r_harmonic + d);
            }
        }
        self.scratch = ids;
        if r_j < rec_j.r_harmonic {
            set_radius(&self.params, &mut self.records[j], r_j);
            return true;
        }
        false
    }

    /// 4b. R_k ← min(R_k, R_j + |p_j − p_k|) for overlapping k, propagated to their neighbours in
    /// increasing order of R. Ids whose R shrank are appended to `shrunk`.
    fn propagate_clamping(&mut self, j: usize, shrunk: &mut Vec<u32>) {
        // Key: R's bits (order-preserving for R ≥ 0, including +∞), then id for a deterministic
        // order.
        let mut heap = BinaryHeap::new();
        heap.push(Reverse((self.records[j].r_harmonic.to_bits(), j as u32)));
        let mut ids = std::mem::take(&mut self.scratch);
        while let Some(Reverse((bits, k))) = heap.pop() {
            let rec_k = self.records[k as usize];
            if rec_k.r_harmonic.to_bits() != bits {
                continue; // stale entry: k shrank again after being pushed
            }
            self.index
                .query_sphere(rec_k.pos, rec_k.r_clamped, &mut ids);
            for &m in &ids {
                if m == k || (m as usize) < self.frozen {
                    continue;
                }
                let rec_m = &mut self.records[m as usize];
                let d = (rec_m.pos - rec_k.pos).length();
                let bound = rec_k.r_harmonic + d;
                if d < rec_k.r_clamped + rec_m.r_clamped && rec_m.r_harmonic > bound {
                    if let Some(log) = &mut self.shrink_log {
                        log.push(Shrink::of(m, rec_m));
                    }
                    set_radius(&self.params, rec_m, bound);
                    self.reindex(m);
                    shrunk.push(m);
                    heap.push(Reverse((bound.to_bits(), m)));
                }
            }
        }
        self.scratch = ids;
    }
}
