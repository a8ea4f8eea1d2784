//! What each sample counts: rays traced, events that must stay rare, lookups and the final gathers'
//! noise; summed per tile, per phase and per render.

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
