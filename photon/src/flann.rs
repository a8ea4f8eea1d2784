//! FFI to FLANN's C API: an exact kd-tree over 3-D points (one FLANN index, or two over the halves of a
//! large point set), owned by [`KdTree`].
//!
//! This is the crate's only `unsafe` module. Thread safety: a query (`flann_radius_search_float`) only
//! reads the index (`KDTreeSingleIndex::findNeighbors` is `const` and keeps its state on the stack); the C
//! entry point's only global side effects are `flann::log_verbosity(level)` when `level >= 0` and
//! `srand` when `random_seed > 0`. Queries pass `log_level = -1` and `random_seed = 0`, so they write no
//! global state and concurrent queries on one tree are safe. The log level is set once, under a
//! `Once`, before the first index exists. `cores = 1` keeps FLANN's OpenMP region to the calling thread.
//!
//! Queries use `flann_radius_search_float` with `max_neighbors = k`: FLANN's `KNNRadiusResultSet` then
//! returns the k nearest strictly inside the radius, sorted, in one call (`flann_find_nearest_neighbors_index_float`
//! has no radius and pads missing neighbours).
#![allow(unsafe_code)]

use std::cell::RefCell;
use std::ffi::{c_int, c_long, c_uint, c_void};
use std::ptr::NonNull;
use std::sync::Once;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// `struct FLANNParameters` of flann.h 1.9 (enums are C `int`).
#[repr(C)]
#[derive(Clone, Copy)]
struct FlannParameters {
    algorithm: c_int,
    checks: c_int,
    eps: f32,
    sorted: c_int,
    max_neighbors: c_int,
    cores: c_int,
    trees: c_int,
    leaf_max_size: c_int,
    branching: c_int,
    iterations: c_int,
    centers_init: c_int,
    cb_index: f32,
    target_precision: f32,
    build_weight: f32,
    memory_weight: f32,
    sample_fraction: f32,
    table_number: c_uint,
    key_size: c_uint,
    multi_probe_level: c_uint,
    log_level: c_int,
    random_seed: c_long,
}

const FLANN_INDEX_KDTREE_SINGLE: c_int = 4;
const FLANN_CHECKS_UNLIMITED: c_int = -1;
const FLANN_LOG_NONE: c_int = 0;
/// A negative level makes FLANN leave its global logger alone.
const LOG_LEVEL_UNCHANGED: c_int = -1;

extern "C" {
    fn flann_log_verbosity(level: c_int);
    fn flann_build_index_float(
        dataset: *mut f32,
        rows: c_int,
        cols: c_int,
        speedup: *mut f32,
        params: *mut FlannParameters,
    ) -> *mut c_void;
    fn flann_radius_search_float(
        index: *mut c_void,
        query: *mut f32,
        indices: *mut c_int,
        dists: *mut f32,
        max_nn: c_int,
        radius: f32,
        params: *mut FlannParameters,
    ) -> c_int;
    fn flann_find_nearest_neighbors_index_float(
        index: *mut c_void,
        testset: *mut f32,
        trows: c_int,
        indices: *mut c_int,
        dists: *mut f32,
        nn: c_int,
        params: *mut FlannParameters,
    ) -> c_int;
    fn flann_used_memory_float(index: *mut c_void) -> c_int;
    fn flann_free_index_float(index: *mut c_void, params: *mut FlannParameters) -> c_int;
}

fn params(max_neighbors: c_int) -> FlannParameters {
    FlannParameters {
        algorithm: FLANN_INDEX_KDTREE_SINGLE,
        checks: FLANN_CHECKS_UNLIMITED,
        eps: 0.0,
        sorted: 1,
        max_neighbors,
        cores: 1,
        trees: 1,
        leaf_max_size: 10,
        branching: 32,
        iterations: 5,
        centers_init: 0,
        cb_index: 0.2,
        target_precision: -1.0,
        build_weight: 0.01,
        memory_weight: 0.0,
        sample_fraction: 0.1,
        table_number: 12,
        key_size: 20,
        multi_probe_level: 2,
        log_level: LOG_LEVEL_UNCHANGED,
        random_seed: 0,
    }
}

/// One neighbour of a query: the point's index in the slice the tree was built from and its squared
/// distance, computed as FLANN does, `(dx² + dy²) + dz²` in f32.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub index: u32,
    pub dist2: f32,
}

/// An exact kd-tree over a fixed point set: one FLANN `KDTREE_SINGLE` index (unlimited checks, eps 0),
/// or for [`SPLIT_AT`] points and more two, one on each side of the median of the widest axis, built
/// at once on two threads. FLANN builds single-threaded, and a sequence's frames build their photon
/// maps anew while the other core waits; a query asks the half on its side first and the other only
/// within the k-th distance found, which passes the splitting plane by for most queries.
pub struct KdTree {
    parts: Vec<Part>,
    /// With two parts: the axis and the value that part 0 lies at or below and part 1 at or above.
    split: Option<(usize, f32)>,
    n: usize,
}

/// Point sets from this size on are built as two trees (see [`KdTree`]); below it a build takes a
/// few milliseconds.
const SPLIT_AT: usize = 1 << 16;

/// One FLANN index and the indices of its points in the tree's point set (`None`: the same).
struct Part {
    index: Index,
    ids: Option<Vec<u32>>,
}

/// One FLANN index over a copy of its points.
struct Index {
    /// `None` for an empty point set: FLANN is never called then.
    raw: Option<NonNull<c_void>>,
    /// Row-major copy of the points. FLANN keeps pointers into the dataset, so it lives as long as the index.
    coords: Vec<f32>,
}

// SAFETY: the index is only read after construction (see the module header) and freed once, in Drop.
unsafe impl Send for Index {}
unsafe impl Sync for Index {}

thread_local! {
    static SCRATCH: RefCell<(Vec<c_int>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl KdTree {
    /// Builds the tree. Errors on non-finite points or more points than FLANN's `int` rows allow.
    pub fn build(points: &[Vec3]) -> Result<KdTree> {
        if let Some(index) = points.iter().position(|p| !p.is_finite()) {
            return Err(Error::NonFinitePoint { index });
        }
        c_int::try_from(points.len()).map_err(|_| Error::TooManyPoints {
            n_points: points.len(),
        })?;
        static QUIET: Once = Once::new();
        // SAFETY: sets a plain global int; every later FLANN call happens after this Once completes.
        QUIET.call_once(|| unsafe { flann_log_verbosity(FLANN_LOG_NONE) });
        let n = points.len();
        if n < SPLIT_AT {
            let index = Index::build(points.iter().copied())?;
            return Ok(KdTree {
                parts: vec![Part { index, ids: None }],
                split: None,
                n,
            });
        }
        let (lo, hi) = points
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let extent = hi - lo;
        let axis = (0..3)
            .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
            .unwrap_or(0);
        let mut ids: Vec<u32> = (0..n as u32).collect();
        let mid = n / 2;
        ids.select_nth_unstable_by(mid, |&a, &b| {
            points[a as usize][axis].total_cmp(&points[b as usize][axis])
        });
        let value = points[ids[mid] as usize][axis];
        let upper = ids.split_off(mid);
        let part = |ids: Vec<u32>| -> Result<Part> {
            let index = Index::build(ids.iter().map(|&i| points[i as usize]))?;
            Ok(Part {
                index,
                ids: Some(ids),
            })
        };
        let (a, b) = rayon::join(|| part(ids), || part(upper));
        Ok(KdTree {
            parts: vec![a?, b?],
            split: Some((axis, value)),
            n,
        })
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The `k` nearest points with squared distance strictly below `max_radius²`, sorted by
    /// `(dist2, index)`, written to `out` (cleared first). Among points tied at the k-th distance, which
    /// ones are returned is FLANN's (deterministic) choice. A non-finite query or a radius that is not
    /// positive yields nothing; `max_radius = f32::INFINITY` means unlimited.
    pub fn knn(&self, q: Vec3, k: usize, max_radius: f32, out: &mut Vec<Neighbor>) {
        out.clear();
        let k = k.min(self.len());
        if k == 0 || !q.is_finite() || max_radius.is_nan() || max_radius <= 0.0 {
            return;
        }
        let radius2 = max_radius * max_radius;
        let Some((axis, value)) = self.split else {
            self.parts[0].index.knn(q, k, radius2, out);
            out.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
            return;
        };
        let near = usize::from(q[axis] >= value);
        let parts = [&self.parts[near], &self.parts[1 - near]];
        parts[0].index.knn(q, k, radius2, out);
        parts[0].to_global(out);
        // The other side only within the k-th distance found (just past it: a point tied with it may
        // be the one a single tree returns), and only when the splitting plane is that near.
        let reach2 = if out.len() == k {
            out.iter()
                .map(|n| n.dist2)
                .fold(0.0f32, f32::max)
                .next_up()
                .min(radius2)
        } else {
            radius2
        };
        let plane2 = (q[axis] - value) * (q[axis] - value);
        if plane2 <= reach2 * (1.0 + 1e-5) {
            let mut other = Vec::new();
            parts[1].index.knn(q, k, reach2, &mut other);
            parts[1].to_global(&mut other);
            out.append(&mut other);
        }
        out.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
        out.truncate(k);
    }

    /// The nearest point to each query, in one FLANN call per part (FLANN's per-call cost, an OpenMP
    /// region and result-set set-up, is paid once per batch instead of once per query). `out[i]` is
    /// `None` for a non-finite query or an empty tree. No radius limit: callers compare `dist2`
    /// themselves.
    pub fn nearest_batch(&self, queries: &[Vec3], out: &mut Vec<Option<Neighbor>>) {
        out.clear();
        out.resize(queries.len(), None);
        for part in &self.parts {
            for (best, found) in out.iter_mut().zip(part.index.nearest_batch(queries)) {
                let Some(mut found) = found else { continue };
                if let Some(ids) = &part.ids {
                    found.index = ids[found.index as usize];
                }
                let closer = best.is_none_or(|b| {
                    found.dist2 < b.dist2 || (found.dist2 == b.dist2 && found.index < b.index)
                });
                if closer {
                    *best = Some(found);
                }
            }
        }
    }

    /// [`knn`](Self::knn) for many queries, in parallel; result `i` belongs to `queries[i]`.
    pub fn knn_batch(&self, queries: &[Vec3], k: usize, max_radius: f32) -> Vec<Vec<Neighbor>> {
        queries
            .par_iter()
            .map(|&q| {
                let mut out = Vec::with_capacity(k.min(self.len()));
                self.knn(q, k, max_radius, &mut out);
                out
            })
            .collect()
    }

    /// Bytes held by the indices (FLANN's own count), their point copies and index maps.
    pub fn memory_bytes(&self) -> usize {
        self.parts
            .iter()
            .map(|p| {
                p.index.memory_bytes()
                    + p.ids
                        .as_ref()
                        .map_or(0, |ids| ids.capacity() * std::mem::size_of::<u32>())
            })
            .sum()
    }
}

impl Part {
    /// Rewrites `found`'s indices from this part's to the tree's point set.
    fn to_global(&self, found: &mut [Neighbor]) {
        if let Some(ids) = &self.ids {
            for n in found {
                n.index = ids[n.index as usize];
            }
        }
    }
}

impl Index {
    /// A FLANN index over `points` (finite, at most `c_int::MAX` of them: checked by the caller).
    fn build(points: impl Iterator<Item = Vec3>) -> Result<Index> {
        let mut coords: Vec<f32> = points.flat_map(|p| p.to_array()).collect();
        let rows = (coords.len() / 3) as c_int;
        if rows == 0 {
            return Ok(Index { raw: None, coords });
        }
        let mut p = params(-1);
        let mut speedup = 0.0f32;
        // SAFETY: `coords` holds rows × 3 floats and outlives the index (both owned by the Index).
        let raw =
            unsafe { flann_build_index_float(coords.as_mut_ptr(), rows, 3, &mut speedup, &mut p) };
        let raw = NonNull::new(raw).ok_or(Error::Flann("build a kd-tree"))?;
        Ok(Index {
            raw: Some(raw),
            coords,
        })
    }

    fn len(&self) -> usize {
        self.coords.len() / 3
    }

    /// The `k` nearest points with squared distance strictly below `radius2` (`k` ≥ 1, `q` finite),
    /// in FLANN's order, appended to `out`.
    fn knn(&self, q: Vec3, k: usize, radius2: f32, out: &mut Vec<Neighbor>) {
        let Some(index) = self.raw else { return };
        let k = k.min(self.len());
        if k == 0 {
            return;
        }
        let k_c = k as c_int; // k ≤ len ≤ i32::MAX, checked at build
        SCRATCH.with(|cell| {
            let mut scratch = cell.borrow_mut();
            let (indices, dists) = &mut *scratch;
            indices.resize(k, -1);
            dists.resize(k, f32::INFINITY);
            let mut query = q.to_array();
            let mut p = params(k_c);
            // SAFETY: the buffers hold k entries, max_nn = k; the index is alive and only read.
            let n = unsafe {
                flann_radius_search_float(
                    index.as_ptr(),
                    query.as_mut_ptr(),
                    indices.as_mut_ptr(),
                    dists.as_mut_ptr(),
                    k_c,
                    radius2,
                    &mut p,
                )
            };
            debug_assert!(n >= 0, "FLANN radius search failed");
            let n = (n.max(0) as usize).min(k);
            out.extend(
                indices[..n]
                    .iter()
                    .zip(&dists[..n])
                    .filter(|(&i, _)| i >= 0)
                    .map(|(&i, &d)| Neighbor {
                        index: i as u32,
                        dist2: d,
                    }),
            );
        });
    }

    /// The nearest point to each query (`None` for a non-finite query or an empty index), in this
    /// index's numbering.
    fn nearest_batch(&self, queries: &[Vec3]) -> Vec<Option<Neighbor>> {
        let mut out = vec![None; queries.len()];
        let Some(index) = self.raw else { return out };
        let finite: Vec<usize> = (0..queries.len())
            .filter(|&i| queries[i].is_finite())
            .collect();
        if finite.is_empty() || finite.len() > c_int::MAX as usize {
            return out;
        }
        let mut flat: Vec<f32> = finite.iter().flat_map(|&i| queries[i].to_array()).collect();
        let mut indices = vec![-1 as c_int; finite.len()];
        let mut dists = vec![f32::INFINITY; finite.len()];
        let mut p = params(1);
        // SAFETY: `flat` holds rows × 3 floats, `indices` and `dists` hold rows × nn (= 1) entries; the
        // index is alive and only read.
        let rc = unsafe {
            flann_find_nearest_neighbors_index_float(
                index.as_ptr(),
                flat.as_mut_ptr(),
                finite.len() as c_int,
                indices.as_mut_ptr(),
                dists.as_mut_ptr(),
                1,
                &mut p,
            )
        };
        if rc < 0 {
            return out;
        }
        for (k, &i) in finite.iter().enumerate() {
            if indices[k] >= 0 {
                out[i] = Some(Neighbor {
                    index: indices[k] as u32,
                    dist2: dists[k],
                });
            }
        }
        out
    }

    /// Bytes held by the index (FLANN's own count) plus the point copy.
    fn memory_bytes(&self) -> usize {
        // SAFETY: the index is alive; the call only reads sizes.
        let flann = self.raw.map_or(0, |i| {
            unsafe { flann_used_memory_float(i.as_ptr()) }.max(0) as usize
        });
        flann + self.coords.capacity() * std::mem::size_of::<f32>()
    }
}

impl Drop for Index {
    fn drop(&mut self) {
        if let Some(index) = self.raw.take() {
            let mut p = params(-1);
            // SAFETY: the index was returned by flann_build_index_float and is freed exactly once.
            unsafe { flann_free_index_float(index.as_ptr(), &mut p) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn dist2_like_flann(a: Vec3, b: Vec3) -> f32 {
        let d = a - b;
        d.x * d.x + d.y * d.y + d.z * d.z
    }

    fn brute_force(points: &[Vec3], q: Vec3, k: usize, max_radius: f32) -> Vec<Neighbor> {
        let r2 = max_radius * max_radius;
        let mut all: Vec<Neighbor> = (0..points.len())
            .map(|i| Neighbor {
                index: i as u32,
                dist2: dist2_like_flann(q, points[i]),
            })
            .filter(|n| n.dist2 < r2)
            .collect();
        all.sort_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
        all.truncate(k);
        all
    }

    /// Distances must match exactly; indices must match exactly except among points tied at the last
    /// returned distance, where any tied point is a correct answer.
    fn check(got: &[Neighbor], want: &[Neighbor]) {
        assert_eq!(got.len(), want.len());
        let Some(last) = want.last().map(|n| n.dist2) else {
            return;
        };
        for (g, w) in got.iter().zip(want) {
            assert_eq!(g.dist2, w.dist2);
            if w.dist2 < last {
                assert_eq!(g.index, w.index);
            }
        }
        let mut tied: Vec<u32> = got
            .iter()
            .filter(|n| n.dist2 == last)
            .map(|n| n.index)
            .collect();
        tied.dedup();
        assert_eq!(
            tied.len(),
            got.iter().filter(|n| n.dist2 == last).count(),
            "duplicate index"
        );
    }

    fn random_points(rng: &mut Rng, n: usize, n_dup: usize) -> Vec<Vec3> {
        let mut pts: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect();
        for _ in 0..n_dup {
            let i = (rng.next_u32() as usize) % n;
            pts.push(pts[i]);
        }
        pts
    }

    #[test]
    fn knn_matches_brute_force_with_duplicates_and_radius() {
        let mut rng = Rng::new(42);
        for &(n, n_dup) in &[(1usize, 0usize), (7, 3), (500, 200), (3000, 1000)] {
            let pts = random_points(&mut rng, n, n_dup);
            let tree = KdTree::build(&pts).unwrap();
            let mut out = Vec::new();
            for qi in 0..200 {
                let q = if qi % 4 == 0 {
                    pts[qi % pts.len()]
                } else {
                    Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2 - 0.1
                };
                for &k in &[1usize, 5, 32, 100_000] {
                    for &r in &[f32::INFINITY, 0.05, 0.2] {
                        tree.knn(q, k, r, &mut out);
                        check(&out, &brute_force(&pts, q, k, r));
                    }
                }
            }
        }
    }

    #[test]
    fn a_split_tree_answers_as_brute_force_across_its_plane() {
        let mut rng = Rng::new(11);
        // Stretched in x so the split falls at x ≈ 1, with duplicates straddling it.
        let mut pts: Vec<Vec3> = random_points(&mut rng, SPLIT_AT + 500, 0)
            .into_iter()
            .map(|p| p * Vec3::new(2.0, 1.0, 1.0))
            .collect();
        for i in 0..300 {
            pts.push(Vec3::new(1.0, i as f32 / 300.0, 0.5));
        }
        let tree = KdTree::build(&pts).unwrap();
        assert!(tree.split.is_some());
        assert_eq!(tree.len(), pts.len());
        let mut out = Vec::new();
        let queries: Vec<Vec3> = (0..120)
            .map(|i| {
                let x = if i % 2 == 0 {
                    1.0 + (rng.uniform() - 0.5) * 0.02
                } else {
                    2.0 * rng.uniform()
                };
                Vec3::new(x, rng.uniform(), rng.uniform())
            })
            .collect();
        for &q in &queries {
            for &k in &[1usize, 16, 100] {
                for &r in &[f32::INFINITY, 0.03] {
                    tree.knn(q, k, r, &mut out);
                    check(&out, &brute_force(&pts, q, k, r));
                }
            }
        }
        let mut nearest = Vec::new();
        tree.nearest_batch(&queries, &mut nearest);
        for (q, n) in queries.iter().zip(&nearest) {
            assert_eq!(
                n.map(|n| n.dist2),
                brute_force(&pts, *q, 1, f32::INFINITY)
                    .first()
                    .map(|n| n.dist2)
            );
        }
    }

    #[test]
    fn batch_equals_single_queries() {
        let mut rng = Rng::new(5);
        let pts = random_points(&mut rng, 2000, 100);
        let tree = KdTree::build(&pts).unwrap();
        let queries: Vec<Vec3> = (0..300)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect();
        let batch = tree.knn_batch(&queries, 16, 0.1);
        let mut out = Vec::new();
        for (q, b) in queries.iter().zip(&batch) {
            tree.knn(*q, 16, 0.1, &mut out);
            assert_eq!(&out, b);
        }
    }

    #[test]
    fn all_identical_points_and_degenerate_queries() {
        let pts = vec![Vec3::splat(0.5); 1000];
        let tree = KdTree::build(&pts).unwrap();
        let mut out = Vec::new();
        tree.knn(Vec3::ZERO, 10, f32::INFINITY, &mut out);
        assert_eq!(out.len(), 10);
        assert!(out.iter().all(|n| n.dist2 == 0.75));
        tree.knn(Vec3::NAN, 10, 1.0, &mut out);
        assert!(out.is_empty());
        tree.knn(Vec3::ZERO, 10, 0.0, &mut out);
        assert!(out.is_empty());
        tree.knn(Vec3::ZERO, 0, 1.0, &mut out);
        assert!(out.is_empty());
        assert!(tree.memory_bytes() >= 1000 * 12);
    }

    #[test]
    fn empty_tree_answers_nothing() {
        let tree = KdTree::build(&[]).unwrap();
        assert!(tree.is_empty());
        let mut out = vec![Neighbor {
            index: 0,
            dist2: 0.0,
        }];
        tree.knn(Vec3::ZERO, 5, f32::INFINITY, &mut out);
        assert!(out.is_empty());
        assert!(tree.knn_batch(&[Vec3::ONE], 3, 1.0)[0].is_empty());
    }

    #[test]
    fn non_finite_points_are_rejected() {
        let err = KdTree::build(&[Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 0.0)])
            .err()
            .unwrap();
        assert!(matches!(err, Error::NonFinitePoint { index: 1 }));
    }
}
