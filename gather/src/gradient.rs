//! Irradiance gradients from one stratified gather (Ward & Heckbert 1992), per colour channel.
//!
//! Both gradients treat the radiance as constant over each stratum, L_jk, and differentiate the
//! resulting piecewise-constant irradiance integral.
//!
//! *Rotational.* Tilting the normal by a small angle α about a unit axis a changes
//! E = ∫ L max(0, n·ω) dω at the rate ∫ L (a × n)·ω dω = a · ∫ L (n × ω) dω (the horizon term
//! vanishes because cos θ = 0 there). With n × ω = sin θ v(φ), where v(φ) = n × u(φ) is the tangent
//! perpendicular to the azimuth, ∇_r E = Σ_jk L_jk ∫_jk sin²θ dθ ∫_k v(φ) dφ. This is Ward &
//! Heckbert's (π/MN) Σ_k v_k Σ_j tan θ_j L_jk with the cell integral in place of tan θ at one point
//! (finite even for the strata at the horizon). Sign convention: ∇_r E · a = dE/dα for a right-handed
//! rotation about a, so a record at normal n_i extrapolates to n as E_i + (n_i × n) · ∇_r E_i.
//! (Ward & Heckbert write −tan θ with their v_k; Mitsuba's irrcache uses the same −tan θ with
//! v_k = u(φ_k − π/2) = −v(φ_k), which is this formula.)
//!
//! *Translational.* Ward & Heckbert's edge model: the boundary between two neighbouring strata
//! is an edge of whatever is closer, at distance r = min(r_a, r_b). Moving p by d (tangent) moves
//! that edge in direction space by −d⊥ / r: the polar boundary θ_j by −cos θ (d·u)/r, the azimuthal
//! boundary φ_k by −(d·v)/(r sin θ). The irradiance swept from one cell to the other gives
//!
//! ∇_t E = Σ_k Σ_{j≥1} U_k sin θ_j cos²θ_j (L_jk − L_{j−1,k}) / min(r_jk, r_{j−1,k})
//!       + Σ_k Σ_j v(φ_k) (sin θ_{j+1} − sin θ_j) (L_jk − L_{j,k−1}) / min(r_jk, r_{j,k−1})
//!
//! with θ_j, φ_k the stratum boundaries (sin²θ_j = j/M, φ_k = 2πk/N) and U_k = ∫_k u(φ) dφ =
//! 2 sin(π/N) u(φ_centre), the exact integral along the polar boundary in place of Ward & Heckbert's
//! (2π/N) u_k (a 0.1 % difference at N = 38).
//! This is Ward & Heckbert 1992. Křivánek et al. 2005 evaluate the azimuthal term with the cell-centre
//! cos θ (cos θ_j − cos θ_{j+1}) / sin θ instead of the exact ∫ cos θ dθ = sin θ_{j+1} − sin θ_j; their
//! real generalisation is to non-cosine sampling (radiance caching), which gathering does not need.
//! Pairs where both rays missed contribute nothing (1/∞ = 0): a distant environment has no
//! translational gradient. Pairs with a zero or NaN distance are skipped rather than divided by.
#![forbid(unsafe_code)]

use crate::strata::{Frame, Strata};
use glam::Vec3;
use std::f32::consts::PI;

/// The radiance and hit distance of every stratum of one gather, row-major by [`Strata::index`].
pub(crate) struct Grid<'a> {
    pub strata: Strata,
    pub frame: Frame,
    pub radiance: &'a [Vec3],
    pub distance: &'a [f32],
}

/// Adds `w · dl[c]` along `dir` to channel c of a per-channel gradient.
#[inline]
fn accumulate(grad: &mut [Vec3; 3], dir: Vec3, w: f32, dl: Vec3) {
    for (c, g) in grad.iter_mut().enumerate() {
        *g += dir * (w * dl[c]);
    }
}

/// ∫ sin²θ dθ over polar row j: [(θ − sin θ cos θ) / 2] between the row's boundaries.
fn row_sin2_integral(strata: &Strata, j: usize) -> f32 {
    let f = |(s, c): (f32, f32)| 0.5 * (s.clamp(0.0, 1.0).asin() - s * c);
    f(strata.theta_boundary(j + 1)) - f(strata.theta_boundary(j))
}

/// Ward & Heckbert's rotational gradient, one world-space vector per colour channel.
pub(crate) fn rotational(grid: &Grid) -> [Vec3; 3] {
    let Grid {
        strata,
        frame,
        radiance,
        ..
    } = grid;
    let arc = 2.0 * (PI / strata.n as f32).sin();
    let mut grad = [Vec3::ZERO; 3];
    for k in 0..strata.n {
        let mut row_sum = Vec3::ZERO;
        for j in 0..strata.m {
            row_sum += radiance[strata.index(j, k)] * row_sin2_integral(strata, j);
        }
        let v = frame.azimuth_perp(strata.phi_centre(k)) * arc;
        accumulate(&mut grad, v, 1.0, row_sum);
    }
    grad
}

/// 1 / min(a, b), or `None` for a pair whose gradient term must be skipped.
#[inline]
fn inv_min_distance(a: f32, b: f32) -> Option<f32> {
    let r = a.min(b);
    (r > 0.0).then(|| 1.0 / r)
}

/// Ward & Heckbert's translational gradient, one world-space vector (in the tangent plane) per
/// colour channel.
pub(crate) fn translational(grid: &Grid) -> [Vec3; 3] {
    let Grid {
        strata,
        frame,
        radiance,
        distance,
    } = grid;
    let (m, n) = (strata.m, strata.n);
    let arc = 2.0 * (PI / n as f32).sin();
    let mut grad = [Vec3::ZERO; 3];
    // Polar boundaries: between rows j − 1 and j of column k.
    for k in 0..n {
        let u = frame.azimuth(strata.phi_centre(k)) * arc;
        for j in 1..m {
            let (a, b) = (strata.index(j, k), strata.index(j - 1, k));
            let Some(inv_r) = inv_min_distance(distance[a], distance[b]) else {
                continue;
            };
            let (s, c) = strata.theta_boundary(j);
            accumulate(&mut grad, u, s * c * c * inv_r, radiance[a] - radiance[b]);
        }
    }
    // Azimuthal boundaries: between columns k − 1 and k of row j (wrapping around).
    if n > 1 {
        for k in 0..n {
            let v = frame.azimuth_perp(strata.phi_boundary(k));
            let k_prev = (k + n - 1) % n;
            for j in 0..m {
                let (a, b) = (strata.index(j, k), strata.index(j, k_prev));
                let Some(inv_r) = inv_min_distance(distance[a], distance[b]) else {
                    continue;
                };
                let length = strata.theta_boundary(j + 1).0 - strata.theta_boundary(j).0;
                accumulate(&mut grad, v, length * inv_r, radiance[a] - radiance[b]);
            }
        }
    }
    grad
}
