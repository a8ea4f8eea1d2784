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

    pub fn prob(&self, i: usize) -> f32 {
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        ((self.cdf[i] - lo) / self.total) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
