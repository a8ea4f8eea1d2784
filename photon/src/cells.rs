//! An exact k-nearest search within a fixed radius over points binned in a dense lattice of cells the
//! radius's size: a query reads the 27 cells around its own. Made for the volume caustic map, which
//! every march step of every camera ray in a medium reads (over half of a fogged Cornell box's render
//! went into its kd-tree searches): a few thousand photons, a small radius, most queries finding few
//! or none, where a kd-tree's per-query cost (FLANN's call, its result set) outweighs the search.
#![forbid(unsafe_code)]

use glam::Vec3;

use crate::flann::Neighbor;

/// Cells of the lattice, at most, per point and in all (the cells grow past the radius to stay under
/// it): the index costs at most 16 bytes a point beyond the points themselves.
const CELLS_PER_POINT: usize = 4;
const MAX_CELLS: usize = 1 << 20;
/// Points around a query, at most, that a search measures one by one (where the photons crowd, in a
/// focused caustic, a kd-tree's search reads fewer).
pub const MAX_SCAN: usize = 4096;

pub struct CellIndex {
    lo: Vec3,
    cell: f32,
    dims: [i64; 3],
    /// Per cell, its points' slice of `points` (`start[c]..start[c + 1]`).
    start: Vec<u32>,
    /// The points by cell: position and index into the caller's array.
    points: Vec<(Vec3, u32)>,
    radius: f32,
}

impl CellIndex {
    /// `points` binned for searches within `radius` (non-finite points are left out; a radius that is
    /// not positive and finite gives an index that finds nothing).
    pub fn build(points: &[Vec3], radius: f32) -> CellIndex {
        let finite: Vec<(Vec3, u32)> = points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_finite())
            .map(|(i, &p)| (p, i as u32))
            .collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &(p, _) in &finite {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if finite.is_empty() || !(radius.is_finite() && radius > 0.0) {
            return CellIndex {
                lo: Vec3::ZERO,
                cell: 1.0,
                dims: [0; 3],
                start: vec![0],
                points: Vec::new(),
                radius: 0.0,
            };
        }
        let extent = (hi - lo).max(Vec3::splat(radius));
        let max_cells = (CELLS_PER_POINT * finite.len() + 64).min(MAX_CELLS) as f32;
        let cell = radius.max((extent.x * extent.y * extent.z / max_cells).cbrt() * 1.01);
        let d = (extent / cell).floor() + 1.0;
        let dims = [d.x as i64, d.y as i64, d.z as i64];
        let index = |p: Vec3| {
            let c = ((p - lo) / cell).floor();
            let c = [c.x as i64, c.y as i64, c.z as i64];
            ((c[2].min(dims[2] - 1) * dims[1] + c[1].min(dims[1] - 1)) * dims[0]
                + c[0].min(dims[0] - 1)) as usize
        };
        let n_cells = (dims[0] * dims[1] * dims[2]) as usize;
        let mut count = vec![0u32; n_cells + 1];
        for &(p, _) in &finite {
            count[index(p) + 1] += 1;
        }
        for c in 1..count.len() {
            count[c] += count[c - 1];
        }
        let start = count.clone();
        let mut next = count;
        let mut binned = vec![(Vec3::ZERO, 0u32); finite.len()];
        for &(p, i) in &finite {
            let c = index(p);
            binned[next[c] as usize] = (p, i);
            next[c] += 1;
        }
        CellIndex {
            lo,
            cell,
            dims,
            start,
            points: binned,
            radius,
        }
    }

    /// The `k` nearest points with squared distance strictly below `max_radius²`, sorted by
    /// `(dist2, index)`, into `out` (cleared first); among points tied at the k-th distance, those of
    /// lower index. `false` (and nothing in `out`) for a radius past the built one, and where the
    /// cells around `q` hold more than [`MAX_SCAN`] points: a kd-tree is faster there.
    pub fn knn(&self, q: Vec3, k: usize, max_radius: f32, out: &mut Vec<Neighbor>) -> bool {
        out.clear();
        let r = max_radius;
        if k == 0 || self.points.is_empty() || !q.is_finite() || !(r > 0.0) {
            return true;
        }
        if r > self.radius {
            return false;
        }
        let r2 = r * r;
        let f = (q - self.lo) / self.cell;
        let c = [f.x.floor(), f.y.floor(), f.z.floor()];
        if c.iter().any(|&x| !(x.abs() < 1e15)) {
            return true;
        }
        let c = c.map(|x| x as i64);
        let range = |a: usize| (c[a] - 1).max(0)..=(c[a] + 1).min(self.dims[a] - 1);
        // The (up to) nine runs of three cells along x around q's cell.
        let mut runs = [(0usize, 0usize); 9];
        let mut n_runs = 0;
        let xs = range(0);
        if !xs.is_empty() {
            for z in range(2) {
                for y in range(1) {
                    let row = (z * self.dims[1] + y) * self.dims[0];
                    runs[n_runs] = (
                        self.start[(row + xs.start()) as usize] as usize,
                        self.start[(row + xs.end() + 1) as usize] as usize,
                    );
                    n_runs += 1;
                }
            }
        }
        let runs = &runs[..n_runs];
        if runs.iter().map(|(a, b)| b - a).sum::<usize>() > MAX_SCAN {
            return false;
        }
        for &(p, index) in runs.iter().flat_map(|&(a, b)| &self.points[a..b]) {
            // As FLANN computes it, so that both give the same radius.
            let d = p - q;
            let dist2 = (d.x * d.x + d.y * d.y) + d.z * d.z;
            if dist2 < r2 {
                out.push(Neighbor { index, dist2 });
            }
        }
        let order =
            |a: &Neighbor, b: &Neighbor| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index));
        if out.len() > k {
            out.select_nth_unstable_by(k - 1, order);
            out.truncate(k);
        }
        out.sort_unstable_by(order);
        true
    }

    pub fn memory_bytes(&self) -> usize {
        self.start.capacity() * 4 + self.points.capacity() * std::mem::size_of::<(Vec3, u32)>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// The same neighbours as a search of every point, for clustered and spread points, queries inside
    /// and far outside the cloud, and radii below the built one.
    #[test]
    fn finds_what_a_search_of_every_point_finds() {
        let mut rng = Rng::new(5);
        let mut v = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let mut pts: Vec<Vec3> = (0..3000).map(|_| v() * 2.0).collect();
        pts.extend((0..6000).map(|_| Vec3::splat(0.7) + v() * 0.1));
        pts.push(Vec3::NAN);
        let radius = 0.08;
        let index = CellIndex::build(&pts, radius);
        let (mut out, mut n_declined) = (Vec::new(), 0);
        for i in 0..4000 {
            let q = v() * 2.4 - 0.2;
            let (k, r) = if i % 3 == 0 {
                (50, radius)
            } else {
                (100, 0.05)
            };
            if !index.knn(q, k, r, &mut out) {
                n_declined += 1;
                continue;
            }
            let mut want: Vec<Neighbor> = pts
                .iter()
                .enumerate()
                .filter(|(_, p)| p.is_finite())
                .map(|(i, p)| {
                    let d = *p - q;
                    Neighbor {
                        index: i as u32,
                        dist2: (d.x * d.x + d.y * d.y) + d.z * d.z,
                    }
                })
                .filter(|n| n.dist2 < r * r)
                .collect();
            want.sort_by(|a, b| a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index)));
            want.truncate(k);
            assert_eq!(out, want, "query {q}");
        }
        // The cluster (6000 points in a 0.1 cube) is past MAX_SCAN; the rest of the cloud is not.
        assert!(n_declined > 0 && n_declined < 400, "{n_declined}");
        assert!(!index.knn(Vec3::splat(0.75), 10, radius, &mut out) && out.is_empty());
        assert!(index.knn(Vec3::splat(50.0), 10, radius, &mut out) && out.is_empty());
        assert!(!index.knn(Vec3::splat(1.5), 10, 2.0 * radius, &mut out));
        assert!(CellIndex::build(&[], radius).memory_bytes() < 64);
    }
}
