//! FFI to FLANN's C API: an exact single kd-tree over 3-D points, owned by [`KdTree`].
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

/// An exact kd-tree (FLANN `KDTREE_SINGLE`, unlimited checks, eps 0) over a fixed point set.
pub struct KdTree {
    /// `None` for an empty point set: FLANN is never called then.
    index: Option<NonNull<c_void>>,
    /// Row-major copy of the points. FLANN keeps pointers into the dataset, so it lives as long as the index.
    coords: Vec<f32>,
}

// SAFETY: the index is only read after construction (see the module header) and freed once, in Drop.
unsafe impl Send for KdTree {}
unsafe impl Sync for KdTree {}

thread_local! {
    static SCRATCH: RefCell<(Vec<c_int>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl KdTree {
    /// Builds the tree. Errors on non-finite points or more points than FLANN's `int` rows allow.
    pub fn build(points: &[Vec3]) -> Result<KdTree> {
        if let Some(index) = points.iter().position(|p| !p.is_finite()) {
            return Err(Error::NonFinitePoint { index });
        }
        let rows = c_int::try_from(points.len()).map_err(|_| Error::TooManyPoints {
            n_points: points.len(),
        })?;
        let mut coords: Vec<f32> = points.iter().flat_map(|p| p.to_array()).collect();
        if rows == 0 {
            return Ok(KdTree {
                index: None,
                coords,
            });
        }
        static QUIET: Once = Once::new();
        // SAFETY: sets a plain global int; every later FLANN call happens after this Once completes.
        QUIET.call_once(|| unsafe { flann_log_verbosity(FLANN_LOG_NONE) });
        let mut p = params(-1);
        let mut speedup = 0.0f32;
        // SAFETY: `coords` holds rows × 3 floats and outlives the index (both owned by the KdTree).
        let raw =
            unsafe { flann_build_index_float(coords.as_mut_ptr(), rows, 3, &mut speedup, &mut p) };
        let index = NonNull::new(raw).ok_or(Error::Flann("build a kd-tree"))?;
        Ok(KdTree {
            index: Some(index),
            coords,
        })
    }

    pub fn len(&self) -> usize {
        self.coords.len() / 3
    }

    pub fn is_empty(&self) -> bool {
        self.coords.is_empty()
    }

    /// The `k` nearest points with squared distance strictly below `max_radius²`, sorted by
    /// `(dist2, index)`, written to `out` (cleared first). Among points tied at the k-th distance, which
    /// ones are returned is FLANN's (deterministic) choice. A non-finite query or a radius that is not
    /// positive yields nothing; `max_radius = f32::INFINITY` means unlimited.
    pub fn knn(&self, q: Vec3, k: usize, max_radius: f32, out: &mut Vec<Neighbor>) {
        out.clear();
        let Some(index) = self.index else { return };
        let k = k.min(self.len());
        if k == 0 || !q.is_finite() || max_radius.is_nan() || max_radius <= 0.0 {
            return;
        }
        let k_c = k as c_int; // k ≤ len ≤ i32::MAX, checked at build
        let radius2 = max_radius * max_radius;
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
        out.sort_unstable_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
    }

    /// The nearest point to each query, in ONE FLANN call (FLANN's per-call cost, an OpenMP region and
    /// result-set set-up, is paid once per batch instead of once per query). `out[i]` is `None` for a
    /// non-finite query or an empty tree. No radius limit: callers compare `dist2` themselves.
    pub fn nearest_batch(&self, queries: &[Vec3], out: &mut Vec<Option<Neighbor>>) {
        out.clear();
        out.resize(queries.len(), None);
        let Some(index) = self.index else { return };
        let finite: Vec<usize> = (0..queries.len())
            .filter(|&i| queries[i].is_finite())
            .collect();
        if finite.is_empty() || finite.len() > c_int::MAX as usize {
            return;
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
            return;
        }
        for (k, &i) in finite.iter().enumerate() {
            if indices[k] >= 0 {
                out[i] = Some(Neighbor {
                    index: indices[k] as u32,
                    dist2: dists[k],
                });
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

    /// Bytes held by the index (FLANN's own count) plus the point copy.
    pub fn memory_bytes(&self) -> usize {
        // SAFETY: the index is alive; the call only reads sizes.
        let flann = self.index.map_or(0, |i| {
            unsafe { flann_used_memory_float(i.as_ptr()) }.max(0) as usize
        });
        flann + self.coords.capacity() * std::mem::size_of::<f32>()
    }
}

impl Drop for KdTree {
    fn drop(&mut self) {
        if let Some(index) = self.index.take() {
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
