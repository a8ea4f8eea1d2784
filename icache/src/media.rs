//! The radiance cache in participating media (Jarosz, Donner, Zwicker & Jensen 2008): records of the
//! light a medium scatters, placed where camera rays need them, each valid within its own radius R,
//! interpolated with its translational gradient, filled by a deterministic pass A over points along
//! camera rays; pass B only reads it.
//!
//! A record holds four moments of the in-scattered light (the power and its first moment in direction:
//! the phase function to first order, interpreted by the caller) and their gradients. The caller's
//! estimate chooses R (from the medium's mean free path, the distances to the surfaces around the
//! point, the gradient and the estimate's own resolution); insertion applies Křivánek's neighbour
//! clamping, R_i ≤ R_j + ‖x_i − x_j‖ both ways, so that a record never reaches far past a small
//! neighbour (where the light changes fast).
//!
//! A lookup at x blends the records whose sphere holds x with the smooth weight w = (1 − d²/R²)², which
//! vanishes at a sphere's border: the result is continuous wherever records overlap. Pass A covers a
//! point only with records reaching it within `PASS_A_REACH`·R, so that pass B's samples between the
//! pass-A points (jittered steps, pixels between the lattice) still find records.
#![forbid(unsafe_code)]

use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use crate::index::Octree;
use crate::stats::RadiusHistogram;

/// Pass A calls a point covered when a record reaches it within this fraction of its radius.
pub(crate) const PASS_A_REACH: f32 = 0.7;
/// A record's phase ratio applies to rays within this cosine of its own.
pub const RATIO_COS: f32 = 0.95;
/// Points whose coverage is looked up together, then gathered as waves.
const CHUNK_POINTS: usize = 64;
/// Uncovered points estimated together (in parallel), then inserted in order.
const WAVE_ESTIMATES: usize = 16;
/// Most records a fill makes (about 64 MiB with their index); points beyond are pass B's misses.
pub const MAX_RECORDS: usize = 1 << 18;
/// Repair sweeps after the fill, for points uncovered by neighbour clamping.
const MAX_REPAIR_SWEEPS: u32 = 16;

/// A record: position, validity radius, moments `value[m]` (0: power, 1–3: power × ωi) and their
/// gradients `grad[m][axis]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeRecord {
    pub pos: Vec3,
    pub radius: f32,
    pub value: [Vec3; 4],
    pub grad: [[Vec3; 3]; 4],
    /// The direction of the ray the record was made for, and per channel the light its photons
    /// scatter toward that ray, each by its own phase, over what the moments' phase gives there.
    pub dir: Vec3,
    pub ratio: Vec3,
}

/// A point along a camera ray where the medium's light will be needed, with the world size of one
/// pixel there (for the radius histogram) and the largest radius a record there may take (the
/// caller's: the medium's mean free path).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediaPoint {
    pub pos: Vec3,
    pub pixel_world: f32,
    pub max_radius: f32,
    /// The ray's direction there and the medium's asymmetry.
    pub dir: Vec3,
    pub g: f32,
}

/// Records and their index.
pub struct MediaCache {
    records: Vec<VolumeRecord>,
    index: Octree,
    /// Extrapolate each record by its gradient.
    gradients: bool,
    neighbours: Vec<u32>,
}

/// What the media fill did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MediaFillStats {
    /// Points along camera rays examined (pass A).
    pub n_points: u64,
    /// The pixel lattice the points' rays went through (every `stride`-th pixel in x and y; the
    /// caller's).
    pub stride: u32,
    /// Estimates made (records inserted plus those skipped because an earlier one of the wave covered
    /// their point).
    pub n_estimates: u64,
    pub n_skipped_covered: u64,
    /// Records whose radius neighbour clamping lowered (counted once per insertion).
    pub n_shrunk_by_neighbours: u64,
    pub n_repair_sweeps: u32,
    /// Points still uncovered after the last sweep (pass B's misses there).
    pub n_uncovered_after: u64,
    /// Final radii in pixels (the pixel size at the point the record was made for).
    pub radius_px: RadiusHistogram,
    pub time_s: f64,
}

impl Default for MediaFillStats {
    fn default() -> Self {
        MediaFillStats {
            n_points: 0,
            stride: 0,
            n_estimates: 0,
            n_skipped_covered: 0,
            n_shrunk_by_neighbours: 0,
            n_repair_sweeps: 0,
            n_uncovered_after: 0,
            radius_px: RadiusHistogram::new(1.0, 1024.0),
            time_s: 0.0,
        }
    }
}

impl MediaCache {
    /// An empty cache over the media's bounds (records outside still work, more slowly).
    pub fn new(lo: Vec3, hi: Vec3, gradients: bool) -> MediaCache {
        MediaCache {
            records: Vec::new(),
            index: Octree::new(lo, hi),
            gradients,
            neighbours: Vec::new(),
        }
    }

    pub fn records(&self) -> &[VolumeRecord] {
        &self.records
    }

    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Heap bytes of records and index.
    pub fn memory_bytes(&self) -> usize {
        self.records.capacity() * std::mem::size_of::<VolumeRecord>() + self.index.memory_bytes()
    }

    /// Whether a record reaches `p` within `reach`·R.
    pub(crate) fn covers(&self, p: Vec3, reach: f32) -> bool {
        let mut found = false;
        self.index.for_each_candidate_within(p, reach, |id| {
            let r = &self.records[id as usize];
            found |= (p - r.pos).length_squared() < r.radius * r.radius * reach * reach;
        });
        found
    }

    /// The moments at `p`: the records whose sphere holds it, weighted by (1 − d²/R²)², each extrapolated
    /// by its gradient (its power never below zero); and, for a ray along `d`, the records' blended
    /// phase ratios (a record made for a ray more than [`RATIO_COS`] away from `d` counts 1). `None`
    /// where no record reaches.
    pub fn lookup(&self, p: Vec3, d: Vec3) -> Option<([Vec3; 4], Vec3)> {
        let (mut sum, mut wsum) = ([Vec3::ZERO; 4], 0.0f32);
        let mut ratio = Vec3::ZERO;
        self.index.for_each_candidate(p, |id| {
            let r = &self.records[id as usize];
            let dx = p - r.pos;
            let u2 = dx.length_squared() / (r.radius * r.radius);
            if !(u2 < 1.0) {
                return;
            }
            let w = (1.0 - u2) * (1.0 - u2);
            for m in 0..4 {
                let mut v = r.value[m];
                if self.gradients {
                    v += r.grad[m][0] * dx.x + r.grad[m][1] * dx.y + r.grad[m][2] * dx.z;
                    if m == 0 {
                        v = v.max(Vec3::ZERO);
                    }
                }
                sum[m] += v * w;
            }
            ratio += if r.dir.dot(d) > RATIO_COS {
                r.ratio
            } else {
                Vec3::ONE
            } * w;
            wsum += w;
        });
        (wsum > 0.0).then(|| (sum.map(|s| s / wsum), ratio / wsum))
    }

    /// Inserts a record with neighbour clamping both ways; returns whether any radius was lowered.
    /// A record with a non-finite position or value, or no positive radius, is not inserted.
    pub fn insert(&mut self, mut rec: VolumeRecord) -> bool {
        let finite = rec.pos.is_finite()
            && rec.value.iter().all(|v| v.is_finite())
            && rec.grad.iter().flatten().all(|g| g.is_finite());
        if !(finite && rec.radius > 0.0 && rec.radius.is_finite()) {
            return false;
        }
        let mut shrunk = false;
        let mut nb = std::mem::take(&mut self.neighbours);
        self.index.query_sphere(rec.pos, rec.radius, &mut nb);
        for &j in &nb {
            let other = &self.records[j as usize];
            let d = (other.pos - rec.pos).length();
            if other.radius + d < rec.radius {
                rec.radius = other.radius + d;
                shrunk = true;
            }
        }
        for &j in &nb {
            let other = self.records[j as usize];
            let d = (other.pos - rec.pos).length();
            if rec.radius + d < other.radius {
                let new = rec.radius + d;
                self.index.shrink(j, other.pos, other.radius, new);
                self.records[j as usize].radius = new;
                shrunk = true;
            }
        }
        self.neighbours = nb;
        let id = self.records.len() as u32;
        self.index.insert(id, rec.pos, rec.radius);
        self.records.push(rec);
        shrunk
    }
}

/// Pass A: makes records until every point is covered (within `PASS_A_REACH`·R), deterministically
/// whatever the thread count. Points are taken in the given order, in chunks whose coverage is looked
/// up in parallel; uncovered points are estimated in parallel waves and inserted in order, each
/// re-checked against the records inserted before it. Repair sweeps then re-cover what neighbour
/// clamping uncovered. `progress(done, total)` after each chunk; returns early soon after `cancel`.
/// At [`MAX_RECORDS`] it inserts no more (the points left are counted uncovered).
pub fn fill_media(
    cache: &mut MediaCache,
    points: &[MediaPoint],
    estimate: &(dyn Fn(&MediaPoint) -> VolumeRecord + Sync),
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &AtomicBool,
) -> MediaFillStats {
    let t = std::time::Instant::now();
    let mut stats = MediaFillStats {
        n_points: points.len() as u64,
        ..Default::default()
    };
    let mut pixel_world = Vec::new();
    let mut sweep: Vec<usize> = (0..points.len()).collect();
    for round in 0..=MAX_REPAIR_SWEEPS {
        if round > 0 {
            stats.n_repair_sweeps = round;
        }
        let mut shrunk = false;
        let mut wave: Vec<usize> = Vec::new();
        for (c, chunk) in sweep.chunks(CHUNK_POINTS).enumerate() {
            if cancel.load(Ordering::Relaxed) {
                stats.time_s = t.elapsed().as_secs_f64();
                return stats;
            }
            let covered: Vec<bool> = chunk
                .par_iter()
                .map(|&i| cache.covers(points[i].pos, PASS_A_REACH))
                .collect();
            wave.extend(
                chunk
                    .iter()
                    .zip(covered)
                    .filter(|(_, c)| !c)
                    .map(|(&i, _)| i),
            );
            let last = (c + 1) * CHUNK_POINTS >= sweep.len();
            if wave.len() >= WAVE_ESTIMATES || last {
                let recs: Vec<VolumeRecord> =
                    wave.par_iter().map(|&i| estimate(&points[i])).collect();
                stats.n_estimates += recs.len() as u64;
                for (&i, rec) in wave.iter().zip(recs) {
                    if cache.len() >= MAX_RECORDS {
                        break;
                    }
                    if cache.covers(points[i].pos, PASS_A_REACH) {
                        stats.n_skipped_covered += 1;
                        continue;
                    }
                    let n = cache.len();
                    if cache.insert(rec) {
                        stats.n_shrunk_by_neighbours += 1;
                        shrunk = true;
                    }
                    if cache.len() > n {
                        pixel_world.push(points[i].pixel_world);
                    }
                }
                wave.clear();
            }
            if round == 0 {
                progress(
                    ((c + 1) * CHUNK_POINTS).min(sweep.len()) as u64,
                    points.len() as u64,
                );
            }
        }
        if !shrunk {
            break;
        }
        // A shrink can uncover any point its record covered, in this sweep or not.
        let still: Vec<bool> = points
            .par_iter()
            .map(|p| !cache.covers(p.pos, PASS_A_REACH))
            .collect();
        sweep = still
            .iter()
            .enumerate()
            .filter(|(_, s)| **s)
            .map(|(i, _)| i)
            .collect();
        if sweep.is_empty() {
            break;
        }
    }
    stats.n_uncovered_after = points
        .par_iter()
        .filter(|p| !cache.covers(p.pos, PASS_A_REACH))
        .count() as u64;
    for (r, px) in cache.records.iter().zip(&pixel_world) {
        stats.radius_px.add(r.radius / px.max(f32::MIN_POSITIVE));
    }
    stats.time_s = t.elapsed().as_secs_f64();
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    fn record(pos: Vec3, radius: f32, value: f32) -> VolumeRecord {
        VolumeRecord {
            pos,
            radius,
            value: [Vec3::splat(value), Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
            ..Default::default()
        }
    }

    /// Points along lines through a unit cube.
    fn points() -> Vec<MediaPoint> {
        let mut rng = Rng::new(3);
        let mut out = Vec::new();
        for _ in 0..200 {
            let (o, d) = (
                Vec3::new(rng.uniform(), rng.uniform(), 0.0),
                Vec3::new(0.2 * rng.uniform() - 0.1, 0.2 * rng.uniform() - 0.1, 1.0).normalize(),
            );
            for k in 0..40 {
                out.push(MediaPoint {
                    pos: o + d * (k as f32 / 40.0),
                    pixel_world: 0.005,
                    max_radius: 1.0,
                    dir: d,
                    g: 0.0,
                });
            }
        }
        out
    }

    /// Small records on one side, large on the other: neighbour clamping has work to do.
    fn estimate(p: &MediaPoint) -> VolumeRecord {
        let r = if p.pos.x < 0.5 { 0.05 } else { 0.2 };
        let mut rec = record(p.pos, r, 1.0 + p.pos.x);
        rec.grad[0][0] = Vec3::ONE;
        rec
    }

    fn fill() -> (MediaCache, MediaFillStats, Vec<MediaPoint>) {
        let pts = points();
        let mut cache = MediaCache::new(Vec3::ZERO, Vec3::ONE, true);
        let stats = fill_media(
            &mut cache,
            &pts,
            &estimate,
            &|_, _| {},
            &AtomicBool::new(false),
        );
        (cache, stats, pts)
    }

    #[test]
    fn every_point_is_covered_and_radii_are_clamped_by_their_neighbours() {
        let (cache, stats, pts) = fill();
        assert_eq!(
            stats.n_uncovered_after, 0,
            "after {} sweeps",
            stats.n_repair_sweeps
        );
        assert!(pts.iter().all(|p| cache.covers(p.pos, PASS_A_REACH)));
        assert!(
            cache.len() < pts.len() / 3,
            "{} records for {} points",
            cache.len(),
            pts.len()
        );
        let rs = cache.records();
        for (i, a) in rs.iter().enumerate() {
            for b in &rs[i + 1..] {
                let d = (a.pos - b.pos).length();
                assert!(a.radius <= b.radius + d + 1e-5 && b.radius <= a.radius + d + 1e-5);
            }
        }
        assert!(stats.n_shrunk_by_neighbours > 0);
    }

    #[test]
    fn the_fill_does_not_depend_on_the_thread_count() {
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(fill)
                .0
                .records()
                .to_vec()
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn lookups_interpolate_a_linear_field_exactly_with_gradients() {
        let mut cache = MediaCache::new(Vec3::ZERO, Vec3::ONE, true);
        for (i, p) in [
            Vec3::new(0.4, 0.5, 0.5),
            Vec3::new(0.6, 0.5, 0.5),
            Vec3::new(0.5, 0.6, 0.45),
        ]
        .into_iter()
        .enumerate()
        {
            let mut rec = record(p, 0.3 + 0.01 * i as f32, 2.0 + 3.0 * p.x);
            rec.grad[0][0] = Vec3::splat(3.0);
            cache.insert(rec);
        }
        let p = Vec3::new(0.52, 0.55, 0.5);
        let v = cache.lookup(p, Vec3::ZERO).unwrap().0[0];
        assert!(
            (v - Vec3::splat(2.0 + 3.0 * p.x)).abs().max_element() < 1e-5,
            "{v}"
        );
        assert!(cache
            .lookup(Vec3::new(0.5, 0.5, 0.95), Vec3::ZERO)
            .is_none());
        let mut flat = MediaCache::new(Vec3::ZERO, Vec3::ONE, false);
        flat.insert(record(Vec3::splat(0.5), 0.2, 1.0));
        assert_eq!(
            flat.lookup(Vec3::splat(0.55), Vec3::ZERO).unwrap().0[0],
            Vec3::ONE
        );
    }

    #[test]
    fn bad_records_are_not_inserted() {
        let mut cache = MediaCache::new(Vec3::ZERO, Vec3::ONE, true);
        assert!(!cache.insert(record(Vec3::splat(f32::NAN), 0.1, 1.0)));
        cache.insert(record(Vec3::splat(0.5), 0.0, 1.0));
        cache.insert(record(Vec3::splat(0.5), 0.1, f32::INFINITY));
        assert!(cache.is_empty());
    }

    /// A record's phase ratio applies to rays along its own direction, and fades to 1 for others.
    #[test]
    fn the_phase_ratio_holds_near_the_records_ray_only() {
        let mut cache = MediaCache::new(Vec3::ZERO, Vec3::ONE, false);
        let mut a = record(Vec3::splat(0.5), 0.3, 1.0);
        (a.dir, a.ratio) = (Vec3::Z, Vec3::new(0.5, 0.6, 0.7));
        let mut b = record(Vec3::new(0.6, 0.5, 0.5), 0.3, 1.0);
        (b.dir, b.ratio) = (Vec3::X, Vec3::splat(2.0));
        cache.insert(a);
        cache.insert(b);
        let p = Vec3::new(0.55, 0.5, 0.5);
        let (_, along_a) = cache.lookup(p, Vec3::Z).unwrap();
        let (_, along_b) = cache.lookup(p, Vec3::X).unwrap();
        let (_, elsewhere) = cache.lookup(p, Vec3::Y).unwrap();
        // Equal weights (both records at the same distance): each ratio blends with the other's 1.
        assert!((along_a - Vec3::new(0.75, 0.8, 0.85)).abs().max_element() < 1e-5);
        assert!((along_b - Vec3::splat(1.5)).abs().max_element() < 1e-5);
        assert_eq!(elsewhere, Vec3::ONE);
    }
}
