//! How much of a photon estimate's disc is surface, measured from the geometry with short probe rays,
//! so that density estimates divide by the area their photons could have landed on (see `photon::map`).
//!
//! Probes sit at a fixed sunflower pattern of points of the disc, turned by an angle hashed from the
//! query (deterministic, and without the pattern's structure showing). Each probe looks straight down
//! through the disc's slab, from `half_thickness` above the plane to as far below it: a hit on a surface
//! facing like the query (the estimate's own normal test) is surface the photons could have reached.
//! Past an edge, off a column's curve or between slats there is none.
//!
//! A probe stands for the area `π r² / PROBES` of the disc's plane; the surface under it has that area
//! divided by the cosine between its facet and the plane. The photons landed on the surface, so that is
//! the area to count: on a column whose curve stays within the slab, projected area alone made the
//! estimate ~15 % too bright (Sibenik's lower nave). Every layer the probe crosses counts (blind slats
//! 3 cm apart lie within one slab, and photons on each are counted): first hits alone made the slats of
//! the blinds room 8 % too bright.

use glam::Vec3;
use photon::map::{Disc, MIN_NORMAL_COS};
use photon::sampling::hash_keys;

use crate::accel::embree::{PacketRay, RawHit};
use crate::scene::Scene;

/// Probes per disc: the fraction's resolution (its noise is averaged by the final gather).
const PROBES: u32 = 24;
const N_PROBES: usize = PROBES as usize;
const GOLDEN_ANGLE: f32 = 2.399_963_2;
/// Facets steeper than this to the disc count as this steep (a probe grazing a facet says little).
const MIN_FACET_COS: f32 = 0.25;

pub struct SceneCoverage<'a>(pub &'a Scene);

/// Surfaces counted along one probe: thin layers closer than the slab (slats, fins) are each surface
/// photons land on, so every one the probe crosses counts, not only the first.
const MAX_PROBE_SURFACES: u32 = 8;

impl SceneCoverage<'_> {
    /// Distance from `p` to the nearest other surface straight above or below it (along ±`n`), up to
    /// `2 max`: the slab stops halfway to it, so a surface stacked close over another (slats 3 cm apart)
    /// counts its own photons only.
    fn gap(&self, p: Vec3, n: Vec3, max: f32) -> f32 {
        // Start a thousandth of the slab away: the query's own facet is not another surface.
        let skip = 1e-3 * max;
        [n, -n]
            .into_iter()
            .filter_map(|d| {
                self.0
                    .intersect_solid(p + skip * d, d, 2.0 * max)
                    .map(|raw| raw.t + skip)
            })
            .fold(2.0 * max, f32::min)
    }

    /// Surface area (in probe units) that the probe from `o` along `d` crosses within `length`: one per
    /// facet facing like `n`, divided by the facet's cosine to the disc. Past the first, a facet counts
    /// only where the probe enters it from its front (winding): leaving a closed slat through its
    /// underside crosses a face no photon from above can land on.
    fn layers(&self, o: Vec3, d: Vec3, length: f32, n: Vec3) -> f32 {
        let (mut t0, mut area) = (0.0f32, 0.0f32);
        for layer in 0..MAX_PROBE_SURFACES {
            let from = o + t0 * d;
            let Some(raw) = self.0.intersect_solid(from, d, length - t0) else {
                break;
            };
            area += self.facet_area(from, d, raw, n, layer);
            // Step past this facet (a thousandth of the slab: far below any layer spacing that matters).
            t0 += raw.t + 1e-3 * length;
            if t0 >= length {
                break;
            }
        }
        area
    }

    /// What the facet a probe from `o` along `d` met as its `layer`-th counts (see [`layers`](Self::layers)).
    fn facet_area(&self, o: Vec3, d: Vec3, raw: RawHit, n: Vec3, layer: u32) -> f32 {
        let hit = self.0.geometry.hit(o, d, raw);
        if hit.ns.dot(n).abs() > MIN_NORMAL_COS && (layer == 0 || hit.ng.dot(d) < 0.0) {
            1.0 / hit.ng.dot(n).abs().max(MIN_FACET_COS)
        } else {
            0.0
        }
    }

    /// [`layers`](Self::layers) of every probe at once (all along `d`), traced in coherent packets of 8:
    /// the probes of a disc are parallel and close together, so a packet's rays share most of their way
    /// through the BVH. For scenes without media (whose invisible boundaries [`layers`](Self::layers)
    /// steps through one ray at a time). The same ray as there, its origin kept and `tnear` moved on.
    fn layers_packed(
        &self,
        origins: &[Vec3; N_PROBES],
        d: Vec3,
        length: f32,
        n: Vec3,
        area: &mut [f32; N_PROBES],
    ) {
        let mut t0 = [0.0f32; N_PROBES];
        // Probes still crossing the slab: the first `n_open` of `open`, compacted in place each layer.
        let mut open: [usize; N_PROBES] = std::array::from_fn(|i| i);
        let mut n_open = N_PROBES;
        let mut rays = [PacketRay {
            origin: Vec3::ZERO,
            dir: d,
            tnear: 0.0,
            tfar: length,
        }; 8];
        let mut hits = [None; 8];
        for layer in 0..MAX_PROBE_SURFACES {
            let mut kept = 0;
            for start in (0..n_open).step_by(8) {
                let len = (n_open - start).min(8);
                let mut lanes = [0usize; 8];
                lanes[..len].copy_from_slice(&open[start..start + len]);
                for (ray, &i) in rays.iter_mut().zip(&lanes[..len]) {
                    *ray = PacketRay {
                        origin: origins[i],
                        dir: d,
                        tnear: t0[i],
                        tfar: length,
                    };
                }
                self.0.bvh.intersect8(&rays[..len], &mut hits);
                for (hit, &i) in hits.iter().zip(&lanes[..len]) {
                    let Some(raw) = *hit else { continue };
                    area[i] += self.facet_area(origins[i], d, raw, n, layer);
                    t0[i] = raw.t + 1e-3 * length;
                    if t0[i] < length {
                        open[kept] = i;
                        kept += 1;
                    }
                }
            }
            n_open = kept;
            if n_open == 0 {
                break;
            }
        }
    }
}

impl photon::Coverage for SceneCoverage<'_> {
    fn measure(&self, p: Vec3, n: Vec3, r: f32, half_thickness: f32) -> Disc {
        if !(r > 0.0 && half_thickness > 0.0) || !p.is_finite() || !n.is_finite() {
            return Disc {
                half_thickness,
                fraction: 1.0,
            };
        }
        let half_thickness = half_thickness.min(0.5 * self.gap(p, n, half_thickness));
        let (t, b) = n.any_orthonormal_pair();
        let key = hash_keys(&[
            p.x.to_bits() as u64,
            p.y.to_bits() as u64,
            p.z.to_bits() as u64,
        ]);
        let turn = (key >> 40) as f32 / (1u64 << 24) as f32 * std::f32::consts::TAU;
        let origins: [Vec3; N_PROBES] = std::array::from_fn(|i| {
            let rho = r * ((i as f32 + 0.5) / PROBES as f32).sqrt();
            let phi = turn + i as f32 * GOLDEN_ANGLE;
            p + rho * (phi.cos() * t + phi.sin() * b) + half_thickness * n
        });
        let mut area = [0.0f32; N_PROBES];
        if self.0.media.is_none() {
            self.layers_packed(&origins, -n, 2.0 * half_thickness, n, &mut area);
        } else {
            for (a, &o) in area.iter_mut().zip(&origins) {
                *a = self.layers(o, -n, 2.0 * half_thickness, n);
            }
        }
        let surface: f32 = area.iter().sum();
        // The query point is on a surface: never less than one probe's worth.
        Disc {
            half_thickness,
            fraction: surface.max(1.0) / PROBES as f32,
        }
    }
}
