//! The volume photon map's in-scattered radiance baked lazily into a grid over the media, for
//! final-gather rays (as the irradiance atlas serves their surface ends): a gather ray through fog sees
//! the light the fog scatters toward it, which lights the walls around it (Cornell box in fog: a third
//! of the walls' indirect light). Each cell holds, from a k-NN estimate at its centre over all volume
//! photons, Σ ΔΦ / V and Σ ΔΦ ⊗ ωi / V: the phase function to first order, p ≈ (1 + 3g cos θ)/(4π).
//! A gather averages hundreds of rays, so the cells' blur matters little; the camera's own view of the
//! fog uses full k-NN estimates (`PhotonData::volume_radiance`).

use std::sync::OnceLock;

use glam::{UVec3, Vec3};
use photon::PhotonMap;

/// Most cells in the grid (the cell grows to stay under it).
const MAX_CELLS: u64 = 1 << 18;

pub struct VolumeGrid {
    lo: Vec3,
    cell: f32,
    dims: UVec3,
    cells: Vec<OnceLock<[Vec3; 4]>>,
    k: usize,
    max_radius: f32,
}

impl VolumeGrid {
    /// A grid over `bounds` with cells about half the estimate's radius cap.
    pub fn new(bounds: (Vec3, Vec3), k: usize, max_radius: f32) -> VolumeGrid {
        let extent = (bounds.1 - bounds.0).max(Vec3::splat(1e-6));
        let mut cell = (0.5 * max_radius).max(extent.max_element() * 1e-3);
        let dims = loop {
            let d = (extent / cell).ceil().as_uvec3().max(UVec3::ONE);
            if (d.x as u64) * (d.y as u64) * (d.z as u64) <= MAX_CELLS {
                break d;
            }
            cell *= 1.25;
        };
        let n = (dims.x * dims.y * dims.z) as usize;
        VolumeGrid { lo: bounds.0, cell, dims, cells: (0..n).map(|_| OnceLock::new()).collect(), k, max_radius }
    }

    /// σs·Li at `x` toward a ray travelling along `d` in a medium of asymmetry `g`.
    pub fn radiance(&self, map: &PhotonMap, x: Vec3, d: Vec3, g: f32) -> Vec3 {
        let c = ((x - self.lo) / self.cell).floor().max(Vec3::ZERO).as_uvec3().min(self.dims - UVec3::ONE);
        let i = ((c.z * self.dims.y + c.y) * self.dims.x + c.x) as usize;
        let centre = self.lo + (c.as_vec3() + 0.5) * self.cell;
        let [s0, sx, sy, sz] = *self.cells[i].get_or_init(|| self.estimate(map, centre));
        let l = (s0 + (sx * d.x + sy * d.y + sz * d.z) * (3.0 * g)) / (4.0 * std::f32::consts::PI);
        l.max(Vec3::ZERO)
    }

    fn estimate(&self, map: &PhotonMap, p: Vec3) -> [Vec3; 4] {
        let mut nb = Vec::new();
        map.tree().knn(p, self.k, self.max_radius, &mut nb);
        let r2 = if nb.len() >= self.k { nb.last().map_or(0.0, |n| n.dist2) } else { self.max_radius * self.max_radius };
        if nb.is_empty() || !(r2 > 0.0) {
            return [Vec3::ZERO; 4];
        }
        let v = 4.0 / 3.0 * std::f32::consts::PI * r2 * r2.sqrt();
        let photons = map.photons();
        let mut s = [Vec3::ZERO; 4];
        for n in &nb {
            let ph = &photons[n.index as usize];
            s[0] += ph.power;
            s[1] += ph.power * ph.wi.x;
            s[2] += ph.power * ph.wi.y;
            s[3] += ph.power * ph.wi.z;
        }
        s.map(|v3| v3 / v)
    }

    /// Cells estimated so far, of all.
    pub fn filled(&self) -> (usize, usize) {
        (self.cells.iter().filter(|c| c.get().is_some()).count(), self.cells.len())
    }
}
