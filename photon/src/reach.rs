//! Which parts of space hold a photon within a lookup radius: a hash set of grid cells the size of
//! the radius, so that a query with no photon in reach skips the kd-tree search (its estimate is
//! zero). Caustic maps are small and concentrated (thousands of photons under one window), while
//! every shading sample asks for a caustic estimate: most of those searches found nothing.
#![forbid(unsafe_code)]

use std::collections::HashSet;
use std::hash::{BuildHasherDefault, Hasher};

use glam::Vec3;

pub struct ReachGrid {
    cell: f32,
    occupied: HashSet<[i64; 3], BuildHasherDefault<CellHasher>>,
}

/// A multiplicative hash of the three cell coordinates: cheaper than the default SipHash, which
/// showed in renders' profiles.
#[derive(Default)]
pub(crate) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.write_u64(*b as u64);
        }
    }

    fn write_i64(&mut self, x: i64) {
        self.write_u64(x as u64);
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(21) ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }

    fn finish(&self) -> u64 {
        self.0 ^ (self.0 >> 29)
    }
}

impl ReachGrid {
    /// Cells of size `radius` holding at least one of `points`. A non-positive or non-finite radius
    /// gives a grid that answers "maybe" everywhere.
    pub fn build(points: impl Iterator<Item = Vec3>, radius: f32) -> Self {
        let cell = if radius.is_finite() && radius > 0.0 {
            radius
        } else {
            0.0
        };
        let mut occupied = HashSet::default();
        if cell > 0.0 {
            // Each point's cell and its 26 neighbours, so that a query probes one cell (27 probes
            // per shading sample were a tenth of the shading).
            let own: HashSet<[i64; 3], BuildHasherDefault<CellHasher>> = points
                .filter(|p| p.is_finite())
                .map(|p| Self::key(p, cell))
                .collect();
            for [x, y, z] in own {
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            occupied.insert([x + dx, y + dy, z + dz]);
                        }
                    }
                }
            }
        }
        ReachGrid { cell, occupied }
    }

    fn key(p: Vec3, cell: f32) -> [i64; 3] {
        (p / cell).floor().to_array().map(|x| x as i64)
    }

    /// False only when no point lies within the radius of `p` (no point in the 27 cells around
    /// `p`'s).
    pub fn may_reach(&self, p: Vec3) -> bool {
        if self.cell == 0.0 || !p.is_finite() {
            return true;
        }
        self.occupied.contains(&Self::key(p, self.cell))
    }

    pub fn memory_bytes(&self) -> usize {
        self.occupied.capacity() * std::mem::size_of::<[i64; 3]>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn never_says_no_where_a_point_is_within_reach() {
        let mut rng = Rng::new(3);
        let pts: Vec<Vec3> = (0..500)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0)
            .collect();
        let r = 0.3;
        let grid = ReachGrid::build(pts.iter().copied(), r);
        let mut n_skipped = 0;
        for _ in 0..20_000 {
            let q = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 8.0 - 4.0;
            let within = pts.iter().any(|p| (*p - q).length() <= r);
            if within {
                assert!(grid.may_reach(q), "{q}");
            }
            n_skipped += !grid.may_reach(q) as u32;
        }
        // Most of the 8³ query box lies far from the 4³ cloud: the grid must rule much of it out.
        assert!(n_skipped > 10_000, "{n_skipped}");
        assert!(ReachGrid::build(pts.iter().copied(), 0.0).may_reach(Vec3::splat(100.0)));
    }
}
