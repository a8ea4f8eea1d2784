//! Irradiance baked lazily onto the triangles: what a final-gather ray reads where it ends.
//!
//! Each side of each triangle is cut into a grid of texels over its barycentric coordinates, about as
//! fine as one texel per `every` global photons over the scene's surface. The first ray that reaches a
//! texel estimates the global map's irradiance at the texel's centre (the same k-NN estimate, with the
//! same coverage of its disc, as everywhere else) and stores it; every later ray reads it with a hash
//! probe. A texel's value is a function of its key alone, so which thread computes it first does not
//! change a bit of the image.
//!
//! This replaced Christensen's precomputed irradiance at every fourth photon, read through a
//! nearest-neighbour search with a compatibility test: on Sibenik the search was a quarter of the cache
//! fill, and the 4.6 % of gather rays whose nearest points faced another way (corners, mouldings, the
//! undersides of things) fell back to a full k-NN estimate each — another 40 %. Here a ray reads the
//! surface it hit, whatever its neighbours face, and pays nothing for a miss; texels nobody reaches are
//! never estimated (the precomputation estimated 195 k points on Sibenik before the first ray).

use std::collections::HashMap;
use std::hash::BuildHasherDefault;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::RwLock;

use glam::Vec3;
use photon::reach::CellHasher;
use photon::PhotonMap;

use super::coverage::SceneCoverage;
use crate::geometry::Geometry;

/// Texels per triangle side at most, per barycentric axis.
pub const MAX_TEXELS_PER_AXIS: u32 = 255;
/// Texels stored at most (each 32 bytes with its key); past that, a texel's estimate is made for the ray
/// and not kept (slower, never more memory).
pub const MAX_STORED_TEXELS: u64 = 16 << 20;
const SHARDS: usize = 64;

/// Irradiance at a texel: from every photon, and from the indirect ones only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelIrradiance {
    pub e: Vec3,
    pub e_indirect: Vec3,
}

type Shard = RwLock<HashMap<u64, TexelIrradiance, BuildHasherDefault<CellHasher>>>;

/// Entries of each thread's direct-mapped copy of the texels it read last: the rays of one gather and of
/// its neighbours reach the same texels again and again, and the shared map's lock and probe cost 11 %
/// of Sibenik's cache fill.
const RECENT: usize = 4096;

/// Tells atlases apart in the threads' copies (tests render several scenes in one process).
static NEXT_ID: AtomicU64 = AtomicU64::new(1);

thread_local! {
    static RECENT_TEXELS: std::cell::RefCell<Vec<(u64, u64, TexelIrradiance)>> = const { std::cell::RefCell::new(Vec::new()) };
}

pub struct IrradianceAtlas {
    id: u64,
    /// Texel edge length (world units).
    spacing: f32,
    k: usize,
    max_radius: f32,
    shards: Vec<Shard>,
    stored: AtomicU64,
    estimated: AtomicU64,
}

/// Counts for the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AtlasStats {
    pub texels: u64,
    pub estimates: u64,
    pub memory_bytes: u64,
}

impl IrradianceAtlas {
    /// An empty atlas whose texels hold `every` global photons of `n_photons` spread over `area`.
    pub fn new(area: f32, n_photons: usize, every: usize, k: usize, max_radius: f32) -> Self {
        let per_texel = (area.max(0.0) as f64 * every.max(1) as f64 / n_photons.max(1) as f64).sqrt() as f32;
        let spacing = if per_texel.is_finite() && per_texel > 0.0 { per_texel } else { f32::INFINITY };
        IrradianceAtlas {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            spacing,
            k,
            max_radius,
            shards: (0..SHARDS).map(|_| RwLock::new(HashMap::default())).collect(),
            stored: AtomicU64::new(0),
            estimated: AtomicU64::new(0),
        }
    }

    /// Irradiance of the global map on the `front` (winding) or back side of triangle `tri`, at the texel
    /// holding `p`.
    pub fn lookup(&self, geometry: &Geometry, cov: &SceneCoverage, global: &PhotonMap, tri: u32, front: bool, p: Vec3) -> TexelIrradiance {
        let (key, centre, n) = self.texel(geometry, tri, front, p);
        let hash = CellHasher::hash_u64(key);
        let slot = (hash >> 20) as usize % RECENT;
        let recent = RECENT_TEXELS.with(|r| {
            let r = r.borrow();
            r.get(slot).filter(|e| e.0 == self.id && e.1 == key).map(|e| e.2)
        });
        if let Some(v) = recent {
            return v;
        }
        let v = self.shared(key, hash, centre, n, cov, global);
        RECENT_TEXELS.with(|r| {
            let mut r = r.borrow_mut();
            if r.len() < RECENT {
                r.resize(RECENT, (0, 0, TexelIrradiance { e: Vec3::ZERO, e_indirect: Vec3::ZERO }));
            }
            r[slot] = (self.id, key, v);
        });
        v
    }

    /// The texel from the shared map, estimated and stored there if it is new.
    fn shared(&self, key: u64, hash: u64, centre: Vec3, n: Vec3, cov: &SceneCoverage, global: &PhotonMap) -> TexelIrradiance {
        // The map buckets by the low bits of the same hash: the shard takes high ones.
        let shard = &self.shards[(hash >> 40) as usize % SHARDS];
        if let Some(v) = shard.read().ok().and_then(|m| m.get(&key).copied()) {
            return v;
        }
        let (est, e_indirect) = global.irradiance_and_indirect(centre, n, self.k, self.max_radius, cov);
        let v = TexelIrradiance { e: est.e, e_indirect };
        self.estimated.fetch_add(1, Ordering::Relaxed);
        if self.stored.load(Ordering::Relaxed) < MAX_STORED_TEXELS {
            if let Ok(mut m) = shard.write() {
                if m.insert(key, v).is_none() {
                    self.stored.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
        v
    }

    /// The key, centre and normal of the texel of triangle `tri`'s `front` (or back) side holding `p`.
    fn texel(&self, geometry: &Geometry, tri: u32, front: bool, p: Vec3) -> (u64, Vec3, Vec3) {
        let t = &geometry.triangles[tri as usize];
        let [a, b, c] = t.v.map(|i| geometry.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let longest = e1.length().max(e2.length()).max((c - b).length());
        // Along the longest edge: a sliver 10 m long (Sponza's floor seams) needs more than one value.
        let n_axis = ((longest / self.spacing).ceil() as u32).clamp(1, MAX_TEXELS_PER_AXIS);
        let (b1, b2) = barycentric(e1, e2, p - a);
        let nf = n_axis as f32;
        let i = ((b1 * nf) as u32).min(n_axis - 1);
        let j = ((b2 * nf) as u32).min(n_axis - 1 - i);
        // A texel cut by the hypotenuse is a triangle: its centroid, else the square's centre.
        let off = if i + j == n_axis - 1 { 1.0 / 3.0 } else { 0.5 };
        let centre = geometry.point_on(tri, (i as f32 + off) / nf, (j as f32 + off) / nf);
        let n = if front { t.ng } else { -t.ng };
        let key = (tri as u64) << 17 | (front as u64) << 16 | (i as u64) << 8 | j as u64;
        (key, centre, n)
    }

    pub fn stats(&self) -> AtlasStats {
        let texels = self.stored.load(Ordering::Relaxed);
        AtlasStats { texels, estimates: self.estimated.load(Ordering::Relaxed), memory_bytes: texels * 40 }
    }
}

/// Barycentric coordinates (b1, b2) of the point `a + d` in the triangle spanned by `e1`, `e2` from `a`,
/// clamped into the triangle.
fn barycentric(e1: Vec3, e2: Vec3, d: Vec3) -> (f32, f32) {
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (d.dot(e1), d.dot(e2));
    let denom = d00 * d11 - d01 * d01;
    if !(denom > 0.0) || !denom.is_finite() {
        return (0.0, 0.0);
    }
    let b1 = ((d11 * d20 - d01 * d21) / denom).clamp(0.0, 1.0);
    let b2 = ((d00 * d21 - d01 * d20) / denom).clamp(0.0, 1.0 - b1);
    if b1.is_finite() && b2.is_finite() {
        (b1, b2)
    } else {
        (0.0, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn barycentrics_of_known_points() {
        let (e1, e2) = (Vec3::X * 2.0, Vec3::Y * 4.0);
        assert_eq!(barycentric(e1, e2, Vec3::ZERO), (0.0, 0.0));
        let (b1, b2) = barycentric(e1, e2, Vec3::new(1.0, 1.0, 0.3));
        assert!((b1 - 0.5).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        // Outside: clamped into the triangle.
        let (b1, b2) = barycentric(e1, e2, Vec3::new(3.0, 3.0, 0.0));
        assert!(b1 <= 1.0 && b1 + b2 <= 1.0 + 1e-6);
        // Degenerate triangle: no NaN.
        assert_eq!(barycentric(Vec3::X, Vec3::X, Vec3::Y), (0.0, 0.0));
    }
}
