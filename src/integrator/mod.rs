//! Integrators: the path-tracing reference and the photon-map methods built on Jensen's split.
pub mod atlas;
pub mod cache_fill;
pub mod coverage;
pub mod gather_rays;
pub mod media;
pub mod media_cache;
pub mod path;
pub mod photon_scene;
pub mod photons;
pub mod pm;
pub mod terms;
pub mod volume_grid;

use glam::Vec3;

use crate::geometry::Hit;

/// Soft indirect (and faint caustic) irradiance already computed in one pixel (kept across the rounds of
/// adaptive sampling while the pixel takes samples), per surface the camera sees there (triangle and side), for the pixel's later samples on that
/// surface: the cache interpolates over records several pixels apart, and each lookup, like each
/// caustic k-NN estimate with its coverage probes, costs more than the rest of a sample (on Sibenik,
/// faint caustic estimates under the red pane were half of the shading). A bright caustic is estimated
/// again at every sample: its edges are sharp within a pixel (cornell-caustics: relMSE 0.0017 → 0.0024
/// when it was reused). Each sample still traces its own camera ray, shadow rays and texture lookups.
#[derive(Clone, Debug, Default)]
pub struct PixelMemo {
    entries: Vec<MemoEntry>,
}

#[derive(Clone, Debug)]
struct MemoEntry {
    tri: u32,
    front: bool,
    /// `None` when too bright to reuse.
    caustic: Option<Vec3>,
    indirect: Vec3,
    /// The cache lookups the first sample made, counted again for each reuse.
    lookups: Replay,
}

/// A [`icache::LookupStats`] of one sample's lookups, in 8 bytes (a memo lives as long as its pixel
/// takes samples: up to every pixel of the image at once). Counts above the field's range saturate.
#[derive(Clone, Copy, Debug)]
struct Replay {
    lookups: u8,
    misses: u8,
    single_record: u8,
    extrapolated: u8,
    gathered: u8,
    records_used: u16,
}

impl Replay {
    fn of(s: &icache::LookupStats) -> Replay {
        let n = |v: u64| v.min(u8::MAX as u64) as u8;
        Replay {
            lookups: n(s.n_lookups),
            misses: n(s.n_misses),
            single_record: n(s.n_single_record),
            extrapolated: n(s.n_extrapolated),
            gathered: n(s.n_gathered),
            records_used: s.n_records_used.min(u16::MAX as u64) as u16,
        }
    }

    fn stats(&self) -> icache::LookupStats {
        icache::LookupStats {
            n_lookups: self.lookups as u64,
            n_misses: self.misses as u64,
            n_single_record: self.single_record as u64,
            n_extrapolated: self.extrapolated as u64,
            n_gathered: self.gathered as u64,
            n_records_used: self.records_used as u64,
            n_reused: 0,
        }
    }
}

/// Surfaces remembered per pixel (later ones are estimated at every sample).
const MEMO_SURFACES: usize = 4;

/// The most a pixel's memo holds while its pixel takes samples: the vector, its entries (grown one at a
/// time) and the allocator's overhead. Below pass A's per-pixel bytes, which are freed before shading.
pub const MEMO_BYTES_PER_PIXEL: u64 =
    (std::mem::size_of::<PixelMemo>() + 16 + MEMO_SURFACES * std::mem::size_of::<MemoEntry>())
        as u64;

impl PixelMemo {
    /// Surfaces remembered.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Forget the surfaces remembered after the first `n`.
    pub fn truncate(&mut self, n: usize) {
        self.entries.truncate(n);
    }

    /// Forget every surface and free the memory.
    pub fn clear(&mut self) {
        self.entries = Vec::new();
    }

    /// (caustic if reusable, indirect) irradiance on side `front` of triangle `tri`, if computed; its
    /// cache lookups are counted again in `c`.
    pub fn get(
        &self,
        tri: u32,
        front: bool,
        c: &mut SampleCounters,
    ) -> Option<(Option<Vec3>, Vec3)> {
        let e = self
            .entries
            .iter()
            .find(|e| e.tri == tri && e.front == front)?;
        c.lookups.replay(&e.lookups.stats());
        Some((e.caustic, e.indirect))
    }

    pub fn put(
        &mut self,
        tri: u32,
        front: bool,
        caustic: Option<Vec3>,
        indirect: Vec3,
        lookups: icache::LookupStats,
    ) {
        if self.entries.len() < MEMO_SURFACES {
            // One surface is the common case: no room for four.
            self.entries.reserve_exact(1);
            self.entries.push(MemoEntry {
                tri,
                front,
                caustic,
                indirect,
                lookups: Replay::of(&lookups),
            });
        }
    }
}

/// Events counted per sample that must stay rare, and rays traced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleCounters {
    pub rays: u64,
    pub shadow_rays: u64,
    pub nan_or_negative: u64,
    pub zero_pdf: u64,
    /// Irradiance-cache lookups made while shading (pass B).
    pub lookups: icache::LookupStats,
    pub gathers: u64,
    pub gather_rays: u64,
    /// k-NN photon-map estimates made for caustics and for `photons`' indirect term (glossy-lobe estimates
    /// at gather ends are not counted; the atlas counts its own).
    pub photon_estimates: u64,
    /// Monte Carlo estimates made in samples: area-light samples, a glass's choice between reflection
    /// and refraction, glossy lobes, media marching, per-sample gathers. A pixel whose samples made none
    /// differs from sample to sample only by where they fall in it (adaptive sampling caps it at
    /// `aa_spp`).
    pub monte_carlo: u64,
    /// Media radiance-cache lookups along rays in a medium (`pm`), and those no record reached (each
    /// then made the estimate itself).
    pub media_lookups: u64,
    pub media_misses: u64,
    /// The final gathers' own noise estimates ([`gather::GatherResult::rel_err`]).
    pub gather_noise: GatherNoise,
}

/// Upper edges of [`GatherNoise`]'s bins (relative standard error of a gather's E); the last bin is open.
pub const GATHER_NOISE_EDGES: [f32; 12] = [
    0.005, 0.01, 0.015, 0.02, 0.03, 0.04, 0.05, 0.07, 0.1, 0.15, 0.2, 0.3,
];

/// How noisy the final gathers were: a histogram of their estimated relative standard errors, their sum
/// and their largest. Tells whether more gather rays (`[render.icache] rays`) would pay: the cache's records carry this
/// noise into the image as blotches a few records wide.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherNoise {
    pub bins: [u32; GATHER_NOISE_EDGES.len() + 1],
    pub sum: f64,
    pub n: u64,
    pub max: f32,
}

impl GatherNoise {
    pub fn record(&mut self, rel_err: f32) {
        if !rel_err.is_finite() {
            return;
        }
        let bin = GATHER_NOISE_EDGES
            .iter()
            .position(|&e| rel_err <= e)
            .unwrap_or(GATHER_NOISE_EDGES.len());
        self.bins[bin] += 1;
        self.sum += rel_err as f64;
        self.n += 1;
        self.max = self.max.max(rel_err);
    }

    /// The upper edge of the bin holding the `q` quantile (the largest value for the open last bin); `None`
    /// without gathers.
    pub fn quantile(&self, q: f64) -> Option<f32> {
        let total: u64 = self.bins.iter().map(|&b| b as u64).sum();
        if total == 0 {
            return None;
        }
        let mut seen = 0u64;
        for (i, &b) in self.bins.iter().enumerate() {
            seen += b as u64;
            if seen as f64 >= q * total as f64 {
                return Some(GATHER_NOISE_EDGES.get(i).copied().unwrap_or(self.max));
            }
        }
        Some(self.max)
    }

    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum / self.n as f64)
    }
}

impl std::ops::AddAssign for GatherNoise {
    fn add_assign(&mut self, o: Self) {
        for (a, b) in self.bins.iter_mut().zip(o.bins) {
            *a += b;
        }
        self.sum += o.sum;
        self.n += o.n;
        self.max = self.max.max(o.max);
    }
}

impl SampleCounters {
    /// The rays and gathers alone (work done, whatever became of its result).
    pub fn work(&self) -> SampleCounters {
        SampleCounters {
            rays: self.rays,
            shadow_rays: self.shadow_rays,
            gathers: self.gathers,
            gather_rays: self.gather_rays,
            gather_noise: self.gather_noise,
            ..SampleCounters::default()
        }
    }
}

impl std::ops::AddAssign for SampleCounters {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.nan_or_negative += o.nan_or_negative;
        self.zero_pdf += o.zero_pdf;
        self.lookups += o.lookups;
        self.gathers += o.gathers;
        self.gather_rays += o.gather_rays;
        self.photon_estimates += o.photon_estimates;
        self.monte_carlo += o.monte_carlo;
        self.media_lookups += o.media_lookups;
        self.media_misses += o.media_misses;
        self.gather_noise += o.gather_noise;
    }
}

/// Shading frame at a hit seen from direction `wo`: the shading normal turned toward `wo`, and
/// whether `wo` is on the side the geometric normal points to.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub n: Vec3,
    /// Geometric normal turned toward `wo`.
    pub ng: Vec3,
    pub front: bool,
}

impl Frame {
    pub fn new(hit: &Hit, wo: Vec3) -> Frame {
        let front = wo.dot(hit.ng) >= 0.0;
        let s = if front { 1.0 } else { -1.0 };
        Frame {
            n: hit.ns * s,
            ng: hit.ng * s,
            front,
        }
    }

    /// Reflection must stay on `wo`'s geometric side, or light leaks through shading normals.
    pub fn same_side(&self, wi: Vec3) -> bool {
        wi.dot(self.ng) > 0.0
    }
}

/// Replaces a non-finite or negative radiance by zero, counting it.
pub fn sanitize(l: Vec3, counters: &mut SampleCounters) -> Vec3 {
    if l.is_finite() && l.min_element() >= 0.0 {
        l
    } else {
        counters.nan_or_negative += 1;
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_noise_quantiles_are_bin_edges_and_the_open_bin_its_largest_value() {
        let mut a = GatherNoise::default();
        assert_eq!(a.quantile(0.5), None);
        for x in [0.012, 0.018, 0.025, 0.035] {
            a.record(x);
        }
        a.record(f32::NAN); // not counted
        let mut b = GatherNoise::default();
        b.record(0.9);
        a += b;
        assert_eq!(a.n, 5);
        assert_eq!(a.quantile(0.5), Some(0.03)); // 0.025 is the third of five
        assert_eq!(a.quantile(0.2), Some(0.015));
        assert_eq!(a.quantile(1.0), Some(0.9)); // the open bin: the largest recorded
        assert!((a.mean().unwrap() - (0.012 + 0.018 + 0.025 + 0.035 + 0.9) / 5.0).abs() < 1e-6);
    }
}
