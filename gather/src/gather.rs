//! One final gather: trace one jittered ray per hemisphere stratum and reduce the answers to the
//! irradiance, its two gradients, the hit-distance statistics and the dominant incoming direction —
//! everything an irradiance-cache record needs.
//!
//! The crate knows no scene: the caller's `trace` closure shoots a ray from the gather point (with
//! whatever offset and shading it likes) and reports its radiance and hit distance.
#![forbid(unsafe_code)]

use crate::gradient::{self, Grid};
use crate::strata::{Frame, Strata, DEFAULT_RAYS};
use glam::{DVec3, Vec3};
use photon::sampling::Rng;
use pmbase::luminance;

/// How to gather.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatherParams {
    /// Requested number of rays; the strata grid (`strata_for_rays`) traces about this many.
    pub rays: usize,
}

impl Default for GatherParams {
    fn default() -> Self {
        GatherParams { rays: DEFAULT_RAYS }
    }
}

/// What one gather ray saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherRay {
    /// Radiance arriving at the gather point along the ray.
    pub radiance: Vec3,
    /// Distance to the hit; `f32::INFINITY` on a miss.
    pub distance: f32,
}

impl GatherRay {
    /// A ray that escaped, seeing `radiance` from the environment.
    pub fn miss(radiance: Vec3) -> Self {
        GatherRay {
            radiance,
            distance: f32::INFINITY,
        }
    }
}

/// The irradiance at a point and what an irradiance-cache record needs besides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherResult {
    /// Irradiance, E = (π / MN) Σ L_jk.
    pub e: Vec3,
    /// Rotational gradient, one world vector per colour channel: E(n') ≈ E + (n × n') ·
    /// `grad_r[c]`.
    pub grad_r: [Vec3; 3],
    /// Translational gradient, one world vector (in the tangent plane) per colour channel:
    /// E(p') ≈ E + (p' − p) · `grad_t[c]`.
    pub grad_t: [Vec3; 3],
    /// Harmonic mean of the hit distances, misses counting as infinity; `INFINITY` if all missed.
    pub r_harmonic: f32,
    /// Smallest hit distance; `INFINITY` if all missed.
    pub r_min: f32,
    /// Dominant incoming direction: luminance-weighted mean of the ray directions, normalised;
    /// the normal when that mean is zero.
    pub dir: Vec3,
    /// Rays traced (M · N).
    pub n_rays: u32,
    /// Estimated relative standard error of E's luminance, from the gather's own rays: strata
    /// paired side by side in azimuth, Var(Σ L) ≈ Σ over pairs of (L_a − L_b)² (one sample per
    /// stratum; conservative where the radiance varies smoothly across a pair). 0 when E is 0.
    pub rel_err: f32,
}

/// [`GatherResult::rel_err`] of the luminances of a strata grid's rays (row-major, `n` per row).
fn paired_rel_err(lum: &[f64], n: usize) -> f32 {
    let total: f64 = lum.iter().sum();
    if !(total > 0.0) || n < 2 {
        return 0.0;
    }
    let (mut var, mut paired) = (0.0f64, 0usize);
    for row in lum.chunks(n) {
        for pair in row.chunks_exact(2) {
            var += (pair[0] - pair[1]).powi(2);
            paired += 2;
        }
    }
    // An odd row's last stratum is unpaired: scale the pairs' variance up to all strata.
    let var = var * lum.len() as f64 / paired.max(1) as f64;
    (var.sqrt() / total) as f32
}

/// Gathers at `p` with unit normal `n`. One jitter pair per stratum is drawn, row by row, from
/// `Rng::new(seed)`, so the same seed gives bitwise the same result. `trace` receives unit world
/// directions in the hemisphere around `n`, one at a time.
pub fn gather(
    p: Vec3,
    n: Vec3,
    params: &GatherParams,
    seed: u64,
    trace: &mut dyn FnMut(Vec3) -> GatherRay,
) -> GatherResult {
    gather_batch(p, n, params, seed, &mut |dirs, out| {
        out.extend(dirs.iter().map(|&d| trace(d)))
    })
}

/// [`gather`] with every direction handed to `trace` at once: it appends one answer per direction,
/// in order, to the (empty) vector it is given. A caller that reads memory at the end of each ray
/// can then trace all rays first and make the reads together, their cache misses overlapping (a
/// read after each ray waits for memory each time).
pub(crate) fn gather_batch(
    p: Vec3,
    n: Vec3,
    params: &GatherParams,
    seed: u64,
    trace: &mut dyn FnMut(&[Vec3], &mut Vec<GatherRay>),
) -> GatherResult {
    gather_batch_round(p, n, params, seed, 0, trace)
}

/// Point `k` of the two-dimensional Sobol sequence, as 32-bit fractions: its first 2^m points put
/// one point in each of the 2^m elementary intervals of every shape (a (0, 2)-sequence in base 2).
fn sobol2(k: u32) -> [u32; 2] {
    let (mut y, mut v, mut i) = (0u32, 1u32 << 31, k);
    while i != 0 {
        if i & 1 != 0 {
            y ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    [k.reverse_bits(), y]
}

/// The jitter of round `round` in a stratum whose round-0 jitter is `xi`: Sobol point `round`
/// scrambled by XOR with `xi`'s bits. Each round's point alone is uniform over the stratum (so each
/// round is an unbiased gather), and rounds 0..2^m together fill the stratum's 2^m elementary
/// intervals: 4 rounds of a grid are a 2 × 2 finer stratification, not 4 independent grids. Round 0
/// is `xi` itself.
fn round_jitter(xi: [f32; 2], round: u32) -> [f32; 2] {
    if round == 0 {
        return xi;
    }
    let s = sobol2(round);
    let scale = 4_294_967_296.0f64;
    std::array::from_fn(|d| {
        let bits = ((xi[d] as f64 * scale) as u64).min(u32::MAX as u64) as u32;
        (((bits ^ s[d]) as f64 / scale) as f32).min(1.0 - f32::EPSILON / 2.0)
    })
}

/// `gather_batch` as round `round` of gathers from the same `seed`: see `round_jitter`. Round 0 is
/// `gather_batch`'s gather.
pub fn gather_batch_round(
    p: Vec3,
    n: Vec3,
    params: &GatherParams,
    seed: u64,
    round: u32,
    trace: &mut dyn FnMut(&[Vec3], &mut Vec<GatherRay>),
) -> GatherResult {
    // `p` only identifies the gather to the caller, whose closure knows where to shoot from.
    let _ = p;
    debug_assert!(
        (n.length() - 1.0).abs() < 1e-3,
        "gather normal must be unit: {n}"
    );
    let strata = Strata::for_rays(params.rays);
    let frame = Frame::from_normal(n);
    let mut rng = Rng::new(seed);
    let mut dirs = Vec::with_capacity(strata.len());
    for j in 0..strata.m {
        for k in 0..strata.n {
            dirs.push(
                frame
                    .to_world(strata.direction(j, k, round_jitter(rng.uniform2(), round)))
                    .normalize(),
            );
        }
    }
    let mut rays = Vec::with_capacity(strata.len());
    trace(&dirs, &mut rays);
    assert_eq!(rays.len(), dirs.len(), "one answer per gather direction");
    // E and 1/R are sums of thousands of like terms: f64 keeps them exact to f32 precision.
    let (mut sum_l, mut sum_inv_r) = (DVec3::ZERO, 0.0f64);
    let (mut sum_dir, mut r_min) = (Vec3::ZERO, f32::INFINITY);
    let mut radiance = Vec::with_capacity(strata.len());
    let mut distance = Vec::with_capacity(strata.len());
    for (&wi, ray) in dirs.iter().zip(&rays) {
        sum_l += ray.radiance.as_dvec3();
        sum_dir += wi * luminance(ray.radiance);
        if ray.distance < f32::INFINITY {
            sum_inv_r += 1.0 / ray.distance as f64;
            r_min = r_min.min(ray.distance);
        }
        radiance.push(ray.radiance);
        distance.push(ray.distance);
    }
    let n_rays = strata.len() as f64;
    let lum: Vec<f64> = radiance.iter().map(|&l| luminance(l) as f64).collect();
    let rel_err = paired_rel_err(&lum, strata.n);
    let grid = Grid {
        strata,
        frame,
        radiance: &radiance,
        distance: &distance,
    };
    GatherResult {
        e: (sum_l * (std::f64::consts::PI / n_rays)).as_vec3(),
        grad_r: gradient::rotational(&grid),
        grad_t: gradient::translational(&grid),
        r_harmonic: if sum_inv_r > 0.0 {
            (n_rays / sum_inv_r) as f32
        } else {
            f32::INFINITY
        },
        r_min,
        dir: sum_dir.try_normalize().unwrap_or(n),
        n_rays: strata.len() as u32,
        rel_err,
    }
}
