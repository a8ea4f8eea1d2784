//! The light arriving at glossy surfaces, baked lazily per atlas texel in low-order spherical
//! harmonics: what a final-gather ray ending on a glossy surface reads for the lobe's reflection.
//!
//! A gather ray that ends on a glossy surface needs the light the lobe reflects back along the ray. A
//! k-NN estimate with the lobe as BRDF per ray (Jensen's) costs more than the rest of the gather
//! (docs/algorithms.md). Here the first ray to reach a texel projects the photons around the texel's
//! middle (`L·cos θ` of every global photon, and apart of those that are not direct) on [`ORDER`]
//! bands of spherical harmonics; every ray reads the texel and turns it into the lobe's radiance toward it with one dot product
//! (`sh::reflect`). Few bands blur the lobe — what a gather ray needs, since hundreds of them are
//! averaged — while keeping its total reflected power. A texel's value is a function of its position
//! alone: which thread estimates it first changes nothing.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use glam::Vec3;
use photon::{Estimate, PhotonMap};

use super::atlas::{IrradianceAtlas, Texel};
use super::coverage::SceneCoverage;
use crate::material::Bsdf;
use crate::scene::Scene;
use crate::sh::{self, PhongKernel};
use crate::warp::luminance;

/// Bands of the texels' harmonics.
pub const ORDER: usize = 4;
const LEN: usize = sh::len(ORDER);

/// The harmonics of the light of the photons that are not direct, then of the direct ones, then the
/// direct photons' power-weighted direction sums (x, y, z).
type Coefficients = [Vec3; 2 * LEN + 3];

/// The sums of a texel's estimate: its [`Coefficients`], then the irradiance of the photons that are
/// not direct and of the indirect ones (the atlas texel's).
const SUMS: usize = 2 * LEN + 5;

/// Direct light whose photons' mean direction is at least this long (nearly one direction: one small
/// light) is reflected as arriving from that direction rather than through the bands, which spread a
/// highlight over what it lights.
const COHERENT_DIRECT: f32 = 0.95;

/// A glossy texel once estimated, laid out for its reads (a gather ray's read is mostly a cache miss):
/// what a read needs first and together.
struct Baked {
    /// The direct light as arriving from one direction, when its photons nearly share one: that
    /// direction and the light's irradiance.
    coherent: Option<(Vec3, Vec3)>,
    /// Harmonics of the light of the photons that are not direct.
    not_direct: [Vec3; LEN],
    /// Harmonics of all the light (read when the direct light is not `coherent`).
    all: [Vec3; LEN],
}

impl Baked {
    fn new(g: &Coefficients) -> Baked {
        let mut not_direct = [Vec3::ZERO; LEN];
        not_direct.copy_from_slice(&g[..LEN]);
        let mut all = [Vec3::ZERO; LEN];
        for (a, (x, y)) in all.iter_mut().zip(g[..LEN].iter().zip(&g[LEN..2 * LEN])) {
            *a = *x + *y;
        }
        Baked {
            coherent: coherent_direct(g),
            not_direct,
            all,
        }
    }
}

/// Bytes a glossy texel takes once estimated.
pub const TEXEL_BYTES: u64 = std::mem::size_of::<Baked>() as u64;

pub struct GlossyTexels {
    /// Each triangle's first slot; `u32::MAX` for triangles that are not glossy.
    first: Vec<u32>,
    slots: Vec<OnceLock<Box<Baked>>>,
    /// Each material's lobe as a kernel, and its exponent (glossy materials only).
    kernels: Vec<Option<(PhongKernel, f32)>>,
    estimated: AtomicU64,
}

impl GlossyTexels {
    /// Slots for the texels of `atlas` on the scene's glossy triangles; `None` without glossy materials.
    pub fn new(scene: &Scene, atlas: &IrradianceAtlas) -> Option<GlossyTexels> {
        let kernels: Vec<Option<(PhongKernel, f32)>> = scene
            .materials
            .iter()
            .map(|m| match m.bsdf {
                Bsdf::Glossy {
                    specular, exponent, ..
                } if specular != Vec3::ZERO => Some((PhongKernel::new(exponent), exponent)),
                _ => None,
            })
            .collect();
        if kernels.iter().all(Option::is_none) {
            return None;
        }
        let mut next = 0u32;
        let first = scene
            .geometry
            .triangles
            .iter()
            .enumerate()
            .map(|(tri, t)| {
                if kernels[t.material as usize].is_none() {
                    return u32::MAX;
                }
                let at = next;
                next += atlas.texel_range(tri as u32).0;
                at
            })
            .collect();
        Some(GlossyTexels {
            first,
            slots: (0..next).map(|_| OnceLock::new()).collect(),
            kernels,
            estimated: AtomicU64::new(0),
        })
    }

    /// The light the glossy lobe of the surface at point `p` (the `front` or back side of triangle
    /// `tri`, shading normal `n`, material `material` with specular reflectance `ks`) reflects toward
    /// `wo`, from its texel's harmonics: of all the light, or with `not_direct` of all but the light
    /// that came straight from a light (for a point whose direct light is sampled).
    #[allow(clippy::too_many_arguments)]
    pub fn radiance(
        &self,
        atlas: &IrradianceAtlas,
        cov: &SceneCoverage,
        global: &PhotonMap,
        (tri, front, p): (u32, bool, Vec3),
        lobe: (u32, Vec3),
        toward: (Vec3, Vec3),
        not_direct: bool,
    ) -> Vec3 {
        let texel = atlas.texel(tri, front, p);
        self.radiance_at(atlas, cov, global, texel, lobe, toward, not_direct)
    }

    /// [`radiance`](Self::radiance) at the point's texel, found by the caller.
    #[allow(clippy::too_many_arguments)]
    pub fn radiance_at(
        &self,
        atlas: &IrradianceAtlas,
        cov: &SceneCoverage,
        global: &PhotonMap,
        texel: Texel,
        (material, ks): (u32, Vec3),
        (n, wo): (Vec3, Vec3),
        not_direct: bool,
    ) -> Vec3 {
        let (tri, front) = (texel.tri, texel.front);
        let (Some((kernel, exponent)), Some(&first)) = (
            self.kernels.get(material as usize).copied().flatten(),
            self.first.get(tri as usize),
        ) else {
            return Vec3::ZERO;
        };
        if first == u32::MAX {
            return Vec3::ZERO;
        }
        let slot = first + (texel.index - atlas.texel_range(tri).1);
        let g = self.slots[slot as usize].get_or_init(|| {
            self.estimated.fetch_add(1, Ordering::Relaxed);
            let ng = cov.0.geometry.triangles[tri as usize].ng;
            let side = if front { ng } else { -ng };
            let (k, max_radius) = atlas.search();
            // The atlas texel's irradiance is summed over the same photons: one search for both.
            let (est, sums) =
                global.projected(atlas.middle(&texel), side, k, max_radius, cov, |ph| {
                    let mut y = [0.0f32; SUMS];
                    let at = if ph.direct { LEN } else { 0 };
                    sh::eval(ORDER, ph.wi, &mut y[at..at + LEN]);
                    if ph.direct {
                        y[2 * LEN..2 * LEN + 3].copy_from_slice(&ph.wi.to_array());
                    }
                    y[SUMS - 2] = (!ph.direct) as u32 as f32;
                    y[SUMS - 1] = ph.indirect as u32 as f32;
                    y
                });
            let not_direct = Estimate {
                e: sums[SUMS - 2],
                ..est
            };
            atlas.read_given(cov, global, texel, Some((not_direct, sums[SUMS - 1])));
            let mut g = [Vec3::ZERO; 2 * LEN + 3];
            g.copy_from_slice(&sums[..2 * LEN + 3]);
            Box::new(Baked::new(&g))
        });
        let r = crate::warp::reflect(wo, n);
        // Truncated harmonics ring, below zero in some directions: the caller clamps the point's sum,
        // where the other terms offset the ringing (clamping here alone biases the lobe up).
        if not_direct {
            return ks * sh::reflect(&g.not_direct, ORDER, &kernel, r);
        }
        ks * match g.coherent {
            Some((d, e)) => {
                let cos = d.dot(r).max(0.0);
                sh::reflect(&g.not_direct, ORDER, &kernel, r)
                    + e * (exponent + 2.0) / (2.0 * std::f32::consts::PI) * cos.powf(exponent)
            }
            None => sh::reflect(&g.all, ORDER, &kernel, r),
        }
    }

    /// Texels estimated so far, and the bytes held.
    pub fn stats(&self) -> (u64, u64) {
        let estimated = self.estimated.load(Ordering::Relaxed);
        let bytes = self.slots.len() * std::mem::size_of::<OnceLock<Box<Baked>>>()
            + self.first.len() * 4
            + estimated as usize * std::mem::size_of::<Baked>();
        (estimated, bytes as u64)
    }
}

/// A texel's direct light as arriving from one direction, when its photons nearly share one (one small
/// light): that direction and the light's irradiance.
fn coherent_direct(g: &Coefficients) -> Option<(Vec3, Vec3)> {
    let sum = Vec3::new(
        luminance(g[2 * LEN]),
        luminance(g[2 * LEN + 1]),
        luminance(g[2 * LEN + 2]),
    );
    // The irradiance of the direct photons: band 0 times √(4π).
    let e = g[LEN] * (4.0 * std::f32::consts::PI).sqrt();
    let (len, e_lum) = (sum.length(), luminance(e));
    (e_lum > 0.0 && len >= COHERENT_DIRECT * e_lum).then(|| (sum / len, e))
}
