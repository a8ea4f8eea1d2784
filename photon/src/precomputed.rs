//! Precomputed irradiance (Christensen 1999): irradiance estimated once at every n-th global photon and
//! stored with the photon's position and normal, so that a final-gather ray needs a nearest-neighbour
//! lookup instead of a k-nearest density estimate. The estimates use the global map (FLANN); the points
//! are read through [`PointTree`] (see there why not FLANN).
#![forbid(unsafe_code)]

use std::cell::RefCell;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::map::{Coverage, PhotonMap};
use crate::pointtree::PointTree;
use crate::sampling::mix64;

/// Candidates examined per lookup for a compatible point.
pub(crate) const LOOKUP_CANDIDATES: usize = 8;
/// A point is usable where its normal is within ~45° of the query's.
pub(crate) const MIN_NORMAL_COS: f32 = 0.7;

/// One irradiance sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradiancePoint {
    pub pos: Vec3,
    pub normal: Vec3,
    /// Irradiance from every photon: what a final-gather ray reaching this surface sees.
    pub e: Vec3,
    /// Irradiance from the photons flagged `indirect` only: the soft indirect term of a point that has
    /// its own direct and caustic terms (one reached through a glossy lobe).
    pub e_indirect: Vec3,
    /// Half-thickness of the slab its estimate counted photons in: thinner than usual where another
    /// surface lies close above or below (stacked slats); a query farther off its plane is another layer.
    pub half_thickness: f32,
}

pmbase::summable! {
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct PrecomputeStats {
        pub n_points: u64,
        /// Points whose estimate hit the maximum radius (sparse regions).
        pub n_hit_max_radius: u64,
        pub build_s: f64,
        pub memory_bytes: u64,
    }
}

thread_local! {
    static CANDIDATES: RefCell<Vec<(u32, f32)>> = const { RefCell::new(Vec::new()) };
}

/// Irradiance points over their own kd-tree.
pub struct PrecomputedIrradiance {
    points: Vec<IrradiancePoint>,
    tree: PointTree,
    /// Lookups farther than this from every point find nothing (the estimate's own max radius).
    max_radius: f32,
}

impl PrecomputedIrradiance {
    /// Estimates irradiance (k nearest within `max_radius`, no filter) at one photon out of each block
    /// of `every` consecutive global photons, in parallel; the result does not depend on the thread count.
    pub fn build(
        global: &PhotonMap,
        every: usize,
        k: usize,
        max_radius: f32,
        cov: &dyn Coverage,
    ) -> Result<(Self, PrecomputeStats)> {
        if every == 0 || k == 0 || max_radius.is_nan() || max_radius <= 0.0 {
            return Err(Error::InvalidParameter(format!(
                "precomputed irradiance needs every ≥ 1, k ≥ 1, max_radius > 0 (got {every}, {k}, {max_radius})"
            )));
        }
        let start = Instant::now();
        let photons = global.photons();
        let estimates: Vec<(IrradiancePoint, bool)> = (0..photons.len().div_ceil(every))
            .into_par_iter()
            .map(|block| {
                let ph = &photons[pick_in_block(block, every, photons.len())];
                let (est, e_indirect) =
                    global.irradiance_and_indirect(ph.pos, ph.normal, k, max_radius, cov);
                let half_thickness = if est.half_thickness > 0.0 {
                    est.half_thickness
                } else {
                    crate::map::DISC_HALF_THICKNESS * max_radius
                };
                (
                    IrradiancePoint {
                        pos: ph.pos,
                        normal: ph.normal,
                        e: est.e,
                        e_indirect,
                        half_thickness,
                    },
                    est.hit_max_radius,
                )
            })
            .collect();
        let n_hit_max_radius = estimates.iter().filter(|(_, hit)| *hit).count() as u64;
        let points: Vec<IrradiancePoint> = estimates.into_iter().map(|(p, _)| p).collect();
        let this = Self::from_points(points, max_radius)?;
        let stats = PrecomputeStats {
            n_points: this.points.len() as u64,
            n_hit_max_radius,
            build_s: start.elapsed().as_secs_f64(),
            memory_bytes: this.memory_bytes() as u64,
        };
        Ok((this, stats))
    }

    /// Wraps already computed points (e.g. read from a file).
    pub(crate) fn from_points(points: Vec<IrradiancePoint>, max_radius: f32) -> Result<Self> {
        let positions: Vec<Vec3> = points.iter().map(|p| p.pos).collect();
        let tree = PointTree::build(&positions);
        Ok(PrecomputedIrradiance {
            points,
            tree,
            max_radius,
        })
    }

    pub fn points(&self) -> &[IrradiancePoint] {
        &self.points
    }

    pub fn max_radius(&self) -> f32 {
        self.max_radius
    }

    /// The nearest point that is compatible with the query among the
    /// `LOOKUP_CANDIDATES` nearest within the max radius; `None` if there is none. (Searching the whole
    /// radius for a compatible point reaches through thin closed objects: the stability suite's sealed box
    /// leaked more light that way.)
    pub fn lookup(&self, p: Vec3, n: Vec3) -> Option<&IrradiancePoint> {
        // Most queries are answered by the single nearest point.
        let (id, _) = self.tree.nearest_where(p, self.max_radius, |_| true)?;
        let pt = &self.points[id as usize];
        if self.compatible(pt, p, n) {
            return Some(pt);
        }
        CANDIDATES.with(|cell| {
            let mut found = cell.borrow_mut();
            self.tree
                .knn(p, LOOKUP_CANDIDATES, self.max_radius, &mut found);
            found
                .iter()
                .map(|&(id, _)| &self.points[id as usize])
                .find(|pt| self.compatible(pt, p, n))
        })
    }

    /// A point may stand for the query if it faces the same way and lies near the query's tangent
    /// plane (as in the photon estimate's disc): a surface parallel to the query's, a little above or
    /// below it — the inside of a box resting on or floating over a floor — has seen other light.
    fn compatible(&self, pt: &IrradiancePoint, p: Vec3, n: Vec3) -> bool {
        let slab = pt
            .half_thickness
            .min(crate::map::DISC_HALF_THICKNESS * self.max_radius);
        pt.normal.dot(n) > MIN_NORMAL_COS && (pt.pos - p).dot(n).abs() <= slab
    }

    pub fn memory_bytes(&self) -> usize {
        self.points.capacity() * std::mem::size_of::<IrradiancePoint>() + self.tree.memory_bytes()
    }
}

/// The photon chosen in block `block` of `every` photons: at a hashed offset, not at a fixed stride,
/// because photons are stored in path order and paths follow a Halton sequence: a fixed stride picks
/// paths of the same Halton stratum, i.e. photons from one band of emission directions.
fn pick_in_block(block: usize, every: usize, n_photons: usize) -> usize {
    let first = block * every;
    let len = every.min(n_photons - first);
    first + (mix64(block as u64 ^ 0x1F0E_D5C3) % len as u64) as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::map::{FullDisc, Photon};
    use crate::sampling::Rng;

    fn two_sided_plane(n: usize) -> PhotonMap {
        // Photons on z = 0: the top side lit with 1 W/m² (4 W over 4 m²), the bottom with 0.25 W/m².
        let mut rng = Rng::new(9);
        let photons = (0..n)
            .map(|i| {
                let pos = Vec3::new(rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0, 0.0);
                let (side, power) = if i % 2 == 0 {
                    (Vec3::Z, 8.0)
                } else {
                    (-Vec3::Z, 2.0)
                };
                Photon {
                    pos,
                    wi: side,
                    power: Vec3::splat(power / n as f32),
                    normal: side,
                    indirect: false,
                    direct: false,
                }
            })
            .collect();
        PhotonMap::new(photons).unwrap()
    }

    #[test]
    fn lookup_returns_the_nearest_compatible_estimate() {
        let map = two_sided_plane(100_000);
        // Photons alternate sides; a fixed stride of 4 would see only the top side.
        let (pre, stats) = PrecomputedIrradiance::build(&map, 4, 400, 0.5, &FullDisc).unwrap();
        assert_eq!(stats.n_points, 25_000);
        assert_eq!(stats.n_hit_max_radius, 0);
        // 400 neighbours, about 200 on the queried side: ±7 % (1σ); the bound is 4σ.
        let top = pre.lookup(Vec3::new(0.1, 0.2, 0.0), Vec3::Z).unwrap().e;
        assert!((top.x - 1.0).abs() < 0.3, "{top}");
        let bottom = pre.lookup(Vec3::new(0.1, 0.2, 0.0), -Vec3::Z).unwrap().e;
        assert!((bottom.x - 0.25).abs() < 0.075, "{bottom}");
        assert_eq!(pre.lookup(Vec3::new(0.1, 0.2, 0.0), Vec3::X), None);
        assert_eq!(pre.lookup(Vec3::new(5.0, 0.0, 0.0), Vec3::Z), None);
        // Every test photon is flagged direct.
        assert_eq!(
            pre.lookup(Vec3::new(0.1, 0.2, 0.0), Vec3::Z)
                .unwrap()
                .e_indirect,
            Vec3::ZERO
        );
    }

    #[test]
    fn build_is_independent_of_thread_count() {
        let map = two_sided_plane(20_000);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                PrecomputedIrradiance::build(&map, 3, 50, 0.5, &FullDisc)
                    .unwrap()
                    .0
                    .points()
                    .to_vec()
            })
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn picks_stay_in_their_block() {
        for (every, n) in [(1usize, 5usize), (4, 10), (7, 7), (4, 1)] {
            for block in 0..n.div_ceil(every) {
                let i = pick_in_block(block, every, n);
                assert!(i >= block * every && i < ((block + 1) * every).min(n));
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let map = two_sided_plane(10);
        assert!(PrecomputedIrradiance::build(&map, 0, 10, 1.0, &FullDisc).is_err());
        assert!(PrecomputedIrradiance::build(&map, 1, 10, f32::NAN, &FullDisc).is_err());
    }
}
