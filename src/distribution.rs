//! A discrete distribution sampled by inverting its CDF.

#[derive(Clone, Debug, Default)]
pub struct Distribution {
    cdf: Vec<f64>,
    total: f64,
}

impl Distribution {
    /// Weights must be finite and ≥ 0; returns None when they sum to zero.
    pub fn new(weights: &[f64]) -> Option<Distribution> {
        let mut cdf = Vec::with_capacity(weights.len());
        let mut acc = 0.0;
        for &w in weights {
            acc += w.max(0.0);
            cdf.push(acc);
        }
        (acc > 0.0).then_some(Distribution { cdf, total: acc })
    }

    /// Index and its probability.
    pub fn sample(&self, u: f32) -> (usize, f32) {
        let target = u as f64 * self.total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        (i, self.prob(i))
    }

    /// [`Self::sample`], and where `u` fell within the chosen index's share, rescaled to [0, 1).
    pub fn sample_remapped(&self, u: f32) -> (usize, f32, f32) {
        let (i, p) = self.sample(u);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let width = self.cdf[i] - lo;
        let rest = if width > 0.0 {
            ((u as f64 * self.total - lo) / width).clamp(0.0, 1.0) as f32
        } else {
            0.5
        };
        (i, p, rest.min(1.0 - f32::EPSILON))
    }

    pub fn prob(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        ((self.cdf[i] - lo) / self.total) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remapped_point_spans_its_share() {
        // Shares 1/4 and 3/4: u = 0.125 lies halfway through the first, u = 0.625 halfway through
        // the second; each index's remapped values cover [0, 1) evenly.
        let d = Distribution::new(&[1.0, 3.0]).unwrap();
        let (i, p, r) = d.sample_remapped(0.125);
        assert_eq!(i, 0);
        assert!((p - 0.25).abs() < 1e-6 && (r - 0.5).abs() < 1e-6);
        let (i, _, r) = d.sample_remapped(0.625);
        assert_eq!(i, 1);
        assert!((r - 0.5).abs() < 1e-6);
        let mut sums = [0.0f64; 2];
        let mut counts = [0usize; 2];
        for k in 0..4000 {
            let (i, _, r) = d.sample_remapped((k as f32 + 0.5) / 4000.0);
            assert!((0.0..1.0).contains(&r));
            sums[i] += r as f64;
            counts[i] += 1;
        }
        for i in 0..2 {
            assert!((sums[i] / counts[i] as f64 - 0.5).abs() < 1e-3);
        }
    }

    #[test]
    fn samples_in_proportion_and_skips_zero_weights() {
        let d = Distribution::new(&[1.0, 0.0, 3.0]).unwrap();
        let mut counts = [0usize; 3];
        for i in 0..4000 {
            counts[d.sample((i as f32 + 0.5) / 4000.0).0] += 1;
        }
        assert_eq!(counts, [1000, 0, 3000]);
        assert!(Distribution::new(&[0.0, 0.0]).is_none());
    }
}
