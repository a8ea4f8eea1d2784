//! Stratified cosine-weighted hemisphere sampling for final gathering (Ward & Heckbert 1992).
//!
//! The hemisphere is cut into M polar × N azimuthal strata of equal *projected* solid angle
//! π / (MN): stratum (j, k) spans sin²θ ∈ [j/M, (j+1)/M) and φ ∈ [2πk/N, 2π(k+1)/N). One jittered
//! direction per stratum, θ_j = asin(sqrt((j + ξ)/M)), φ_k = 2π(k + ξ')/N, is a cosine-distributed
//! sample, so E = (π / MN) Σ L_jk. Because the strata are a regular grid, neighbouring cells are
//! known, which is what the gradient formulas in `gradient.rs` need.
#![forbid(unsafe_code)]

use glam::Vec3;
use std::f32::consts::PI;

/// Default number of gather rays per record when a caller has no opinion.
pub const DEFAULT_RAYS: usize = 500;

/// Chooses the strata grid (M polar, N azimuthal) for about `rays` rays.
///
/// N ≈ πM makes the strata roughly square in solid angle near the horizon, where most of the
/// projected solid angle is (Ward & Heckbert). M = round(sqrt(rays / π)); N = round(rays / M), so
/// M·N is the grid closest to the request for that M (it is within M/2 of `rays`) and N/M ≈ π.
/// The default 500 rays gives M = 13, N = 38 (494 rays). At least one stratum is always returned.
pub(crate) fn strata_for_rays(rays: usize) -> (usize, usize) {
    let rays = rays.max(1) as f64;
    let m = (rays / std::f64::consts::PI).sqrt().round().max(1.0);
    let n = (rays / m).round().max(1.0);
    (m as usize, n as usize)
}

/// An orthonormal frame around a unit normal: `t`, `b`, `n` are right-handed (t × b = n).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds the frame without branches on the normal's direction (Duff et al. 2017,
    /// "Building an Orthonormal Basis, Revisited"). `n` must be unit length.
    pub(crate) fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bt, n }
    }

    /// Local (x, y, z = normal) to world.
    #[inline]
    pub(crate) fn to_world(self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// World to local (x, y, z = normal).
    #[cfg(test)]
    pub(crate) fn to_local(self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Unit tangent vector in the azimuth `phi` direction: u(φ) = cos φ t + sin φ b.
    #[inline]
    pub(crate) fn azimuth(&self, phi: f32) -> Vec3 {
        self.t * phi.cos() + self.b * phi.sin()
    }

    /// Unit tangent vector perpendicular to azimuth `phi`: v(φ) = u(φ + π/2) = n × u(φ).
    #[inline]
    pub(crate) fn azimuth_perp(&self, phi: f32) -> Vec3 {
        self.b * phi.cos() - self.t * phi.sin()
    }
}

/// The strata grid and its cell boundaries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Strata {
    /// Number of polar strata.
    pub m: usize,
    /// Number of azimuthal strata.
    pub n: usize,
}

impl Strata {
    pub(crate) fn for_rays(rays: usize) -> Self {
        let (m, n) = strata_for_rays(rays);
        Strata { m, n }
    }

    pub(crate) fn len(&self) -> usize {
        self.m * self.n
    }

    /// Row-major index of stratum (j, k): polar row j, azimuthal column k.
    #[inline]
    pub(crate) fn index(&self, j: usize, k: usize) -> usize {
        j * self.n + k
    }

    /// sin θ and cos θ of the polar boundary between rows j − 1 and j (j = 0 is the zenith,
    /// j = M the horizon).
    #[inline]
    pub(crate) fn theta_boundary(&self, j: usize) -> (f32, f32) {
        let s2 = (j as f32 / self.m as f32).min(1.0);
        (s2.sqrt(), (1.0 - s2).max(0.0).sqrt())
    }

    /// Azimuth of the boundary between columns k − 1 and k.
    #[inline]
    pub(crate) fn phi_boundary(&self, k: usize) -> f32 {
        2.0 * PI * k as f32 / self.n as f32
    }

    /// Azimuth of the centre of column k.
    #[inline]
    pub(crate) fn phi_centre(&self, k: usize) -> f32 {
        2.0 * PI * (k as f32 + 0.5) / self.n as f32
    }

    /// Jittered local direction (z = normal) in stratum (j, k) for `xi` ∈ [0, 1)².
    #[inline]
    pub(crate) fn direction(&self, j: usize, k: usize, xi: [f32; 2]) -> Vec3 {
        let s2 = ((j as f32 + xi[0]) / self.m as f32).min(1.0);
        let sin_theta = s2.sqrt();
        let cos_theta = (1.0 - s2).max(0.0).sqrt();
        let phi = 2.0 * PI * (k as f32 + xi[1]) / self.n as f32;
        Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    #[test]
    fn default_grid_is_near_500_rays_and_pi_aspect() {
        let (m, n) = strata_for_rays(DEFAULT_RAYS);
        assert_eq!((m, n), (13, 38));
        for rays in [1usize, 2, 10, 100, 500, 4000, 100_000] {
            let (m, n) = strata_for_rays(rays);
            assert!(m >= 1 && n >= 1);
            assert!((m * n).abs_diff(rays) <= m / 2 + 1, "{rays}: {m}x{n}");
            // N/M ≈ rays/M² = π (1 + δ/M)⁻²: rounding M by δ ≤ ½ moves the aspect by up to ≈ π/M,
            // and rounding N by ½ moves it by 1/(2M) more.
            let aspect = n as f32 / m as f32;
            assert!(
                rays < 10 || (aspect - PI).abs() <= (PI + 0.5) / m as f32,
                "{rays}: {m}x{n}"
            );
        }
        assert_eq!(strata_for_rays(0), (1, 1));
    }

    #[test]
    fn frame_is_orthonormal_and_right_handed() {
        let mut rng = Rng::new(11);
        let mut normals = vec![Vec3::Z, -Vec3::Z, Vec3::X, Vec3::Y, -Vec3::Y];
        for _ in 0..1000 {
            let [a, b] = rng.uniform2();
            let z = 1.0 - 2.0 * a;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * b;
            normals.push(Vec3::new(r * phi.cos(), r * phi.sin(), z).normalize());
        }
        for n in normals {
            let f = Frame::from_normal(n);
            // f32 rounding in the Duff construction: a few ulps.
            let tol = 1e-5;
            assert!(
                (f.t.length() - 1.0).abs() < tol && (f.b.length() - 1.0).abs() < tol,
                "{n}"
            );
            assert!(f.t.dot(f.b).abs() < tol && f.t.dot(n).abs() < tol && f.b.dot(n).abs() < tol);
            assert!((f.t.cross(f.b) - n).length() < 1e-4, "{n}");
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
            assert!((f.azimuth_perp(0.7) - n.cross(f.azimuth(0.7))).length() < 1e-5);
        }
    }

    /// Upper quantile of χ²(k) by the Wilson–Hilferty approximation (accurate to ~1 % for k > 30).
    fn chi2_quantile(k: f64, z: f64) -> f64 {
        let h = 2.0 / (9.0 * k);
        k * (1.0 - h + z * h.sqrt()).powi(3)
    }

    const N_THETA: usize = 12;
    const N_PHI: usize = 16;

    /// χ² statistic of local directions against the cosine density p(ω) = cos θ / π, and its
    /// degrees of freedom. Bins are uniform in θ and φ, so they do not line up with the strata;
    /// expected counts come from each bin's cosine measure, P = (sin²θ_b − sin²θ_a) Δφ / 2π.
    fn chi2_cosine(dirs: impl Iterator<Item = Vec3>) -> (f64, f64) {
        let mut counts = vec![0u64; N_THETA * N_PHI];
        let mut total = 0u64;
        for d in dirs {
            let theta = d.z.clamp(0.0, 1.0).acos();
            let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
            let bt = ((theta / (0.5 * PI)) * N_THETA as f32) as usize;
            let bp = ((phi / (2.0 * PI)) * N_PHI as f32) as usize;
            counts[bt.min(N_THETA - 1) * N_PHI + bp.min(N_PHI - 1)] += 1;
            total += 1;
        }
        let mut chi2 = 0.0f64;
        for bt in 0..N_THETA {
            let edge = |i: usize| {
                (i as f64 / N_THETA as f64 * std::f64::consts::FRAC_PI_2)
                    .sin()
                    .powi(2)
            };
            let expected = total as f64 * (edge(bt + 1) - edge(bt)) / N_PHI as f64;
            assert!(expected > 5.0, "bins too small for χ²");
            for bp in 0..N_PHI {
                chi2 += (counts[bt * N_PHI + bp] as f64 - expected).powi(2) / expected;
            }
        }
        (chi2, (N_THETA * N_PHI - 1) as f64)
    }

    /// The strata's directions follow the cosine density. Rejected at p = 0.001 (z = 3.09): an
    /// honest i.i.d. sampler fails about once in a thousand seeds; stratification only lowers χ².
    #[test]
    fn strata_directions_are_cosine_distributed() {
        let mut dirs = Vec::new();
        for g in 0..120u64 {
            let strata = Strata::for_rays([37, 500, 1200][g as usize % 3]);
            let mut rng = Rng::new(photon::sampling::hash_keys(&[g]));
            for j in 0..strata.m {
                for k in 0..strata.n {
                    let d = strata.direction(j, k, rng.uniform2());
                    assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                    dirs.push(d);
                }
            }
        }
        let (chi2, dof) = chi2_cosine(dirs.into_iter());
        let limit = chi2_quantile(dof, 3.09);
        assert!(chi2 < limit, "χ² = {chi2:.1} ≥ {limit:.1} ({dof} dof)");
    }

    /// The same χ² machinery rejects a wrong density (uniform in θ), so the test above can fail.
    #[test]
    fn chi2_rejects_a_non_cosine_sampler() {
        let mut rng = Rng::new(5);
        let dirs = (0..100_000).map(|_| {
            let [a, b] = rng.uniform2();
            let (theta, phi) = (a * 0.5 * PI, b * 2.0 * PI);
            Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            )
        });
        let (chi2, dof) = chi2_cosine(dirs);
        assert!(chi2 > chi2_quantile(dof, 3.09), "χ² = {chi2:.1}");
    }
}
