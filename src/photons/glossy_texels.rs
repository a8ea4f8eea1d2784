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
use photon::PhotonMap;

use super::atlas::IrradianceAtlas;
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

/// Bytes a glossy texel's harmonics take once estimated.
pub const TEXEL_BYTES: u64 = std::mem::size_of::<Coefficients>() as u64;

pub struct GlossyTexels {
    /// Each triangle's first slot; `u32::MAX` for triangles that are not glossy.
    first: Vec<u32>,
    slots: Vec<OnceLock<Box<Coefficients>>>,
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
        (material, ks): (u32, Vec3),
        (n, wo): (Vec3, Vec3),
        not_direct: bool,
    ) -> Vec3 {
        let (Some((kernel, exponent)), Some(&first)) = (
            self.kernels.get(material as usize).copied().flatten(),
            self.first.get(tri as usize),
        ) else {
            return Vec3::ZERO;
        };
        if first == u32::MAX {
            return Vec3::ZERO;
        }
        let texel = atlas.texel(tri, front, p);
        let slot = first + (texel.index - atlas.texel_range(tri).1);
        let g = self.slots[slot as usize].get_or_init(|| {
            self.estimated.fetch_add(1, Ordering::Relaxed);
            let ng = cov.0.geometry.triangles[tri as usize].ng;
            let side = if front { ng } else { -ng };
            let (k, max_radius) = atlas.search();
            // The atlas texel's irradiance is summed over the same photons: one search for both.
            let (_, sums) =
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
            atlas.read_given(cov, global, texel, Some((sums[SUMS - 2], sums[SUMS - 1])));
            let mut g = Box::new([Vec3::ZERO; 2 * LEN + 3]);
            g.copy_from_slice(&sums[..2 * LEN + 3]);
            g
        });
        let r = crate::warp::reflect(wo, n);
        // Truncated harmonics ring, below zero in some directions: the caller clamps the point's sum,
        // where the other terms offset the ringing (clamping here alone biases the lobe up).
        if not_direct {
            return ks * sh::reflect(&g[..LEN], ORDER, &kernel, r);
        }
        ks * match coherent_direct(g) {
            Some((d, e)) => {
                let cos = d.dot(r).max(0.0);
                sh::reflect(&g[..LEN], ORDER, &kernel, r)
                    + e * (exponent + 2.0) / (2.0 * std::f32::consts::PI) * cos.powf(exponent)
            }
            None => {
                let mut all = [Vec3::ZERO; LEN];
                for (a, (x, y)) in all.iter_mut().zip(g[..LEN].iter().zip(&g[LEN..2 * LEN])) {
                    *a = *x + *y;
                }
                sh::reflect(&all, ORDER, &kernel, r)
            }
        }
    }

    /// Texels estimated so far, and the bytes held.
    pub fn stats(&self) -> (u64, u64) {
        let estimated = self.estimated.load(Ordering::Relaxed);
        let bytes = self.slots.len() * std::mem::size_of::<OnceLock<Box<Coefficients>>>()
            + self.first.len() * 4
            + estimated as usize * std::mem::size_of::<Coefficients>();
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
