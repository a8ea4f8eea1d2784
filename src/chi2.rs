//! Pearson χ² goodness-of-fit tests for direction samplers (test support, in the style of Mitsuba's
//! `chi2` module and pbrt's sampling tests): directions are binned in (cos θ, φ) over the sphere, the
//! expected count of each bin is the sampler's pdf integrated over it numerically, bins with small
//! expectation are pooled, and the statistic is compared with the χ² quantile.
#![cfg(test)]

use glam::Vec3;
use std::f64::consts::PI;

pub const THETA_BINS: usize = 20;
pub const PHI_BINS: usize = 40;

fn bin_of(d: Vec3) -> usize {
    let z = (d.z as f64).clamp(-1.0, 1.0);
    let t = (((1.0 - z) * 0.5) * THETA_BINS as f64) as usize;
    let phi = (d.y as f64).atan2(d.x as f64).rem_euclid(2.0 * PI);
    let p = (phi / (2.0 * PI) * PHI_BINS as f64) as usize;
    t.min(THETA_BINS - 1) * PHI_BINS + p.min(PHI_BINS - 1)
}

fn dir(z: f64, phi: f64) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
}

/// Expected counts: n × ∫ pdf over each bin (z-uniform bins make dω = dz dφ).
fn expected(pdf: &dyn Fn(Vec3) -> f64, n: usize) -> Vec<f64> {
    let sub = 32;
    let (dz, dphi) = (2.0 / THETA_BINS as f64, 2.0 * PI / PHI_BINS as f64);
    let mut out = vec![0.0; THETA_BINS * PHI_BINS];
    for t in 0..THETA_BINS {
        for p in 0..PHI_BINS {
            let mut s = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let z = 1.0 - (t as f64 + (a as f64 + 0.5) / sub as f64) * dz;
                    let phi = (p as f64 + (b as f64 + 0.5) / sub as f64) * dphi;
                    s += pdf(dir(z, phi));
                }
            }
            out[t * PHI_BINS + p] = s * dz * dphi / (sub * sub) as f64 * n as f64;
        }
    }
    out
}

/// Upper quantile of χ²(dof) at significance `alpha` (Wilson–Hilferty approximation).
fn chi2_quantile(dof: f64, z_alpha: f64) -> f64 {
    let h = 2.0 / (9.0 * dof);
    dof * (1.0 - h + z_alpha * h.sqrt()).powi(3)
}

/// Draws `n` samples (None = a failed sample, which counts as lost probability mass) and returns
/// (statistic, threshold) at a 1e-4 significance level (z = 3.72).
pub fn run(
    n: usize,
    sample: &mut dyn FnMut(usize) -> Option<Vec3>,
    pdf: &dyn Fn(Vec3) -> f64,
) -> (f64, f64) {
    let mut observed = vec![0.0f64; THETA_BINS * PHI_BINS];
    for i in 0..n {
        if let Some(d) = sample(i) {
            observed[bin_of(d.normalize())] += 1.0;
        }
    }
    let exp = expected(pdf, n);
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&exp) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
            continue;
        }
        stat += (o - e).powi(2) / e;
        dof += 1;
    }
    if pool_e > 5.0 {
        stat += (pool_o - pool_e).powi(2) / pool_e;
        dof += 1;
    } else if pool_o > 10.0 {
        // Samples where the pdf says there should be (almost) none.
        return (f64::INFINITY, 0.0);
    }
    (stat, chi2_quantile((dof.max(2) - 1) as f64, 3.72))
}
