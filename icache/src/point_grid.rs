//! The fill's shading points by position, for the repair sweeps: which points lie inside a sphere,
//! without visiting the others.
//!
//! A uniform grid of cubic cells; each point's index is kept sorted by its cell's key, so a cell's
//! points are one binary search away. A sweep after the first logs a few hundred shrinks at most,
//! so visiting the points near their spheres is cheap, where testing every point of a million-pixel
//! image against them (an octree walk each) took a large part of the fill.
#![forbid(unsafe_code)]

use glam::{IVec3, Vec3};

/// Cells per axis at most (keys pack three 21-bit coordinates).
const MAX_CELLS_PER_AXIS: i32 = (1 << 21) - 1;
/// A sphere spanning more cells than this is answered by scanning every point instead.
const MAX_CELLS_PER_QUERY: i64 = 4096;

pub(crate) struct PointGrid {
    origin: Vec3,
    cell: f32,
    /// The highest cell coordinates of any point: a query clamps its cells to them.
    top: IVec3,
    /// (cell key, point index), sorted.
    keys: Vec<(u64, u32)>,
    /// Every point's position, by index.
    positions: Vec<Vec3>,
}

impl PointGrid {
    /// A grid of cells of side `cell` over `positions` (non-finite positions are never found).
    pub(crate) fn new(positions: Vec<Vec3>, cell: f32) -> PointGrid {
        let finite = positions.iter().filter(|p| p.is_finite());
        let origin = finite
            .clone()
            .fold(Vec3::splat(f32::INFINITY), |a, &p| a.min(p));
        let hi = finite.fold(Vec3::splat(f32::NEG_INFINITY), |a, &p| a.max(p));
        let extent = (hi - origin).max_element();
        // Never more cells per axis than the keys hold.
        let cell = if extent.is_finite() && extent > 0.0 {
            cell.max(extent / MAX_CELLS_PER_AXIS as f32)
        } else {
            1.0
        };
        let cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            1.0
        };
        let origin = if origin.is_finite() {
            origin
        } else {
            Vec3::ZERO
        };
        let mut grid = PointGrid {
            origin,
            cell,
            top: IVec3::ZERO,
            keys: Vec::new(),
            positions,
        };
        if hi.is_finite() {
            grid.top = grid.coords(hi);
        }
        let mut keys: Vec<(u64, u32)> = grid
            .positions
            .iter()
            .enumerate()
            .filter(|(_, p)| p.is_finite())
            .map(|(i, &p)| (key(grid.coords(p)), i as u32))
            .collect();
        keys.sort_unstable();
        grid.keys = keys;
        grid
    }

    fn coords(&self, p: Vec3) -> IVec3 {
        let c = ((p - self.origin) / self.cell).floor();
        c.clamp(Vec3::ZERO, Vec3::splat(MAX_CELLS_PER_AXIS as f32))
            .as_ivec3()
    }

    /// Call `f` with the index of every point within `r` of `c` (with a relative slack of 1e-5, so
    /// that rounding never drops a point at the border: the caller's exact test decides), each
    /// once.
    pub(crate) fn for_each_within(&self, c: Vec3, r: f32, mut f: impl FnMut(u32)) {
        if !(c.is_finite() && r >= 0.0) {
            return;
        }
        let r2 = r * r * (1.0 + 1e-5);
        let mut test = |i: u32| {
            if (self.positions[i as usize] - c).length_squared() <= r2 {
                f(i)
            }
        };
        // Cells past the points' are empty: a sphere far larger than the scene (a record allowed
        // 1e8 pixels) spans no more cells than the grid has, and its product of spans cannot
        // overflow (2^21 cells per axis cubed is 2^63).
        let (lo, hi) = (
            self.coords(c - Vec3::splat(r)).min(self.top),
            self.coords(c + Vec3::splat(r)).min(self.top),
        );
        let span = (hi - lo + IVec3::ONE).max(IVec3::ZERO).as_i64vec3();
        if !r.is_finite() || span.x * span.y * span.z > MAX_CELLS_PER_QUERY {
            self.keys.iter().for_each(|&(_, i)| test(i));
            return;
        }
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                // A row of cells along x is one run of keys (x is the lowest field).
                let (a, b) = (key(IVec3::new(lo.x, y, z)), key(IVec3::new(hi.x, y, z)));
                let start = self.keys.partition_point(|&(k, _)| k < a);
                self.keys[start..]
                    .iter()
                    .take_while(|&&(k, _)| k <= b)
                    .for_each(|&(_, i)| test(i));
            }
        }
    }
}

/// x in the low 21 bits, then y, then z.
fn key(c: IVec3) -> u64 {
    c.x as u64 | (c.y as u64) << 21 | (c.z as u64) << 42
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    /// Against brute force: random points on a few planes (as shading points lie), spheres of many
    /// sizes, including ones larger than the whole set and ones centred outside it.
    #[test]
    fn finds_exactly_the_points_in_a_sphere() {
        let mut rng = Rng::new(3);
        let points: Vec<Vec3> = (0..20_000)
            .map(|i| match i % 3 {
                0 => Vec3::new(rng.uniform() * 10.0, 0.0, rng.uniform() * 10.0),
                1 => Vec3::new(0.0, rng.uniform() * 5.0, rng.uniform() * 10.0),
                _ => Vec3::new(rng.uniform() * 10.0, rng.uniform() * 5.0, 3.0),
            })
            .chain([Vec3::NAN, Vec3::INFINITY])
            .collect();
        let grid = PointGrid::new(points.clone(), 0.3);
        for q in 0..300 {
            let c = Vec3::new(
                rng.uniform() * 12.0 - 1.0,
                rng.uniform() * 6.0 - 0.5,
                rng.uniform() * 12.0 - 1.0,
            );
            let r = [0.05, 0.3, 1.0, 4.0, 100.0][q % 5] * rng.uniform();
            let mut found = Vec::new();
            grid.for_each_within(c, r, |i| found.push(i));
            found.sort_unstable();
            let n = found.len();
            found.dedup();
            assert_eq!(n, found.len(), "a point found twice");
            let truth: Vec<u32> = (0..points.len() as u32)
                .filter(|&i| (points[i as usize] - c).length() <= r)
                .collect();
            // The slack may add points on the border, never drop one.
            assert!(
                truth.iter().all(|i| found.contains(i)),
                "query {q}: missed a point"
            );
            assert!(
                found
                    .iter()
                    .all(|&i| (points[i as usize] - c).length() <= r * 1.0001),
                "query {q}: far point"
            );
        }
        // Degenerate queries find nothing and do not panic.
        let mut n = 0;
        grid.for_each_within(Vec3::NAN, 1.0, |_| n += 1);
        grid.for_each_within(Vec3::ZERO, f32::NAN, |_| n += 1);
        grid.for_each_within(Vec3::ZERO, -1.0, |_| n += 1);
        assert_eq!(n, 0);
        // An infinite radius finds every finite point.
        grid.for_each_within(Vec3::ZERO, f32::INFINITY, |_| n += 1);
        assert_eq!(n, 20_000);
    }

    /// A finite sphere spanning more cells than the keys hold on every axis (2^21 each: the product
    /// overflowed, and the query walked 2^42 rows) finds every point at once.
    #[test]
    fn a_sphere_far_larger_than_the_grid_is_answered_at_once() {
        let points: Vec<Vec3> = (0..1000).map(|i| Vec3::splat(i as f32 * 0.01)).collect();
        let grid = PointGrid::new(points, 0.3);
        let start = std::time::Instant::now();
        for r in [1e7, 1e12, 3e38] {
            let mut n = 0;
            grid.for_each_within(Vec3::splat(5.0), r, |_| n += 1);
            assert_eq!(n, 1000, "radius {r}");
        }
        assert!(start.elapsed().as_secs_f32() < 1.0);
    }
}
