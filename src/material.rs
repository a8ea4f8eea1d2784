//! Materials: Lambert, ideal mirror, smooth dielectric, energy-conserving modified Phong; emission.
//!
//! All functions work in world space with `n` the shading normal turned toward `wo` (surfaces are
//! two-sided); `front` says whether `wo` is on the side the unflipped normal points to, which matters
//! only for glass (entering or leaving).

use glam::Vec3;
use std::f32::consts::PI;

use crate::warp::{cosine_hemisphere, reflect, to_world};

#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse {
        albedo: Vec3,
        texture: Option<usize>,
    },
    Mirror {
        reflectance: Vec3,
    },
    Glass {
        ior: f32,
        transmittance: Vec3,
    },
    /// Modified Phong. With a texture, the diffuse colour is [`glossy_texel`] of the texel, and once the
    /// scene is loaded `albedo` is its mean over the texture (for readers that take no texel).
    Glossy {
        albedo: Vec3,
        specular: Vec3,
        exponent: f32,
        texture: Option<usize>,
        /// The factor that brought Kd + Ks down to at most 1 (1 when they were within it), applied to
        /// `albedo` and `specular` already and to the texels when they are read.
        texel_scale: f32,
    },
    /// The invisible boundary of a medium (index-matched): light crosses it unchanged.
    Null,
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Radiance emitted on the front side (W/(m²·sr)); zero for non-emitters.
    pub emission: Vec3,
}

/// The diffuse colour of a textured glossy surface: the texel scaled as Kd was, capped per channel at
/// 1 − ks so that kd + ks ≤ 1 holds for texels brighter than Kd too.
pub fn glossy_texel(texel: Vec3, texel_scale: f32, specular: Vec3) -> Vec3 {
    (texel * texel_scale).min(Vec3::ONE - specular)
}

/// Whether a radiance (camera) or importance (photon) path is being traced: refraction scales radiance by
/// 1/η² but not photon power.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Transport {
    Radiance,
    Importance,
}

#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f · |cos θi| / pdf.
    pub weight: Vec3,
    pub pdf: f32,
    /// A Dirac lobe (mirror or glass): no light sampling, no MIS.
    pub delta: bool,
}

/// The normalised lobe of modified Phong about the mirror direction `r` of `wo` (Lafortune & Willems
/// 1994): the BRDF ks·(n+2)/(2π)·cosⁿα, sampled exactly with density (n+1)/(2π)·cosⁿα, where α is the
/// angle between `r` and the incident direction. The material, the integrators and the photon-map
/// estimate at gather ends all read this one lobe.
#[derive(Clone, Copy, Debug)]
pub struct PhongLobe {
    /// The mirror direction.
    pub r: Vec3,
    pub exponent: f32,
}

impl PhongLobe {
    /// The lobe of a surface with shading normal `n` seen from `wo`.
    pub fn new(wo: Vec3, n: Vec3, exponent: f32) -> PhongLobe {
        PhongLobe {
            r: reflect(wo, n),
            exponent,
        }
    }

    fn cos(&self, wi: Vec3) -> f32 {
        self.r.dot(wi).max(0.0)
    }

    /// The BRDF over ks toward `wi`: (n+2)/(2π)·cosⁿα.
    pub fn brdf(&self, wi: Vec3) -> f32 {
        let (cos_a, exponent) = (self.cos(wi), self.exponent);
        (exponent + 2.0) / (2.0 * PI) * cos_a.powf(exponent)
    }

    /// The solid-angle density of [`sample`](Self::sample) choosing `wi`: (n+1)/(2π)·cosⁿα.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let (cos_a, exponent) = (self.cos(wi), self.exponent);
        (exponent + 1.0) / (2.0 * PI) * cos_a.powf(exponent)
    }

    /// [`pdf`](Self::pdf) times `p`, the probability of choosing the lobe (multiplied in first).
    pub fn chosen_pdf(&self, p: f32, wi: Vec3) -> f32 {
        let (cos_a, exponent) = (self.cos(wi), self.exponent);
        p * (exponent + 1.0) / (2.0 * PI) * cos_a.powf(exponent)
    }

    /// A direction drawn with density [`pdf`](Self::pdf) from two uniform numbers.
    pub fn sample(&self, u: [f32; 2]) -> Vec3 {
        let cos_a = u[0].powf(1.0 / (self.exponent + 1.0));
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let phi = 2.0 * PI * u[1];
        let local = Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a);
        to_world(self.r, local)
    }

    /// BRDF · cos θi / pdf over ks for a direction the lobe sampled: (n+2)/(n+1)·cos θi.
    pub fn sampled_weight(&self, cos_i: f32) -> f32 {
        (self.exponent + 2.0) / (self.exponent + 1.0) * cos_i
    }
}

impl Bsdf {
    /// Mirror and glass: a ray can only leave along a Dirac lobe.
    pub fn is_specular(&self) -> bool {
        matches!(self, Bsdf::Mirror { .. } | Bsdf::Glass { .. })
    }

    /// A medium's invisible boundary: rays cross it as if it were not there.
    pub fn is_null(&self) -> bool {
        matches!(self, Bsdf::Null)
    }

    /// Diffuse reflectance (the part the irradiance estimates multiply); `kd` is the texture-resolved albedo.
    pub fn diffuse_albedo(&self, kd: Vec3) -> Vec3 {
        match self {
            Bsdf::Diffuse { .. } => kd,
            Bsdf::Glossy { .. } => kd,
            _ => Vec3::ZERO,
        }
    }

    /// f(wo, wi) without the cosine; zero for Dirac lobes.
    pub fn eval(&self, kd: Vec3, n: Vec3, wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.dot(n) <= 0.0 || wo.dot(n) <= 0.0 {
            return Vec3::ZERO;
        }
        match *self {
            Bsdf::Diffuse { .. } => kd / PI,
            Bsdf::Glossy {
                specular, exponent, ..
            } => kd / PI + specular * PhongLobe::new(wo, n, exponent).brdf(wi),
            _ => Vec3::ZERO,
        }
    }

    /// Probability of choosing the diffuse lobe of a glossy material.
    fn glossy_diffuse_prob(kd: Vec3, ks: Vec3) -> f32 {
        let (d, s) = (kd.max_element(), ks.max_element());
        if d + s <= 0.0 {
            1.0
        } else {
            d / (d + s)
        }
    }

    /// Solid-angle density of `sample` choosing `wi`.
    pub fn pdf(&self, kd: Vec3, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
        let cos_i = wi.dot(n);
        if cos_i <= 0.0 || wo.dot(n) <= 0.0 {
            return 0.0;
        }
        match *self {
            Bsdf::Diffuse { .. } => cos_i / PI,
            Bsdf::Glossy {
                specular, exponent, ..
            } => {
                let pd = Self::glossy_diffuse_prob(kd, specular);
                pd * cos_i / PI + PhongLobe::new(wo, n, exponent).chosen_pdf(1.0 - pd, wi)
            }
            _ => 0.0,
        }
    }

    pub fn sample(
        &self,
        kd: Vec3,
        n: Vec3,
        wo: Vec3,
        front: bool,
        u: [f32; 3],
        mode: Transport,
    ) -> Option<BsdfSample> {
        match *self {
            Bsdf::Diffuse { .. } => {
                let wi = to_world(n, cosine_hemisphere([u[0], u[1]]));
                let pdf = wi.dot(n) / PI;
                (pdf > 0.0).then_some(BsdfSample {
                    wi,
                    weight: kd,
                    pdf,
                    delta: false,
                })
            }
            Bsdf::Glossy {
                specular, exponent, ..
            } => {
                let pd = Self::glossy_diffuse_prob(kd, specular);
                let wi = if u[2] < pd {
                    to_world(n, cosine_hemisphere([u[0], u[1]]))
                } else {
                    PhongLobe::new(wo, n, exponent).sample([u[0], u[1]])
                };
                let pdf = self.pdf(kd, n, wo, wi);
                if pdf <= 0.0 {
                    return None;
                }
                let weight = self.eval(kd, n, wo, wi) * wi.dot(n) / pdf;
                Some(BsdfSample {
                    wi,
                    weight,
                    pdf,
                    delta: false,
                })
            }
            Bsdf::Mirror { reflectance } => Some(BsdfSample {
                wi: reflect(wo, n),
                weight: reflectance,
                pdf: 1.0,
                delta: true,
            }),
            Bsdf::Glass { ior, transmittance } => {
                sample_glass(ior, transmittance, n, wo, front, u[2], mode)
            }
            Bsdf::Null => Some(BsdfSample {
                wi: -wo,
                weight: Vec3::ONE,
                pdf: 1.0,
                delta: true,
            }),
        }
    }
}

/// Unpolarised Fresnel reflectance of a smooth dielectric; `cos_i` > 0 on the incident side, `eta` =
/// η_transmitted / η_incident. Returns (F, cos_t); F = 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32) {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return (1.0, 0.0);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t)
}

/// Both lobes of smooth glass seen from `wo` for radiance: (mirror direction, F) and, unless light is
/// totally reflected, (refracted direction, (1 − F) × transmittance / η²); a zero weight where a lobe
/// does not exist. The weights are the expected contributions of `sample_glass`'s two outcomes.
pub fn glass_lobes(
    ior: f32,
    transmittance: Vec3,
    n: Vec3,
    wo: Vec3,
    front: bool,
) -> [(Vec3, Vec3); 2] {
    let (eta, f) = glass_fresnel(ior, n, wo, front);
    let reflected = (reflect(wo, n), Vec3::splat(f.0));
    if f.0 >= 1.0 {
        return [reflected, (Vec3::ZERO, Vec3::ZERO)];
    }
    [
        reflected,
        (
            refracted(wo, n, eta, f),
            transmittance * ((1.0 - f.0) / (eta * eta)),
        ),
    ]
}

/// η (transmitted over incident) for the side `wo` is on, and Fresnel's (F, cos θt) there.
fn glass_fresnel(ior: f32, n: Vec3, wo: Vec3, front: bool) -> (f32, (f32, f32)) {
    let eta = if front { ior } else { 1.0 / ior };
    (eta, fresnel_dielectric(wo.dot(n).clamp(0.0, 1.0), eta))
}

/// The refracted direction of `wo` through a surface of normal `n` (on `wo`'s side), given η and
/// [`glass_fresnel`]'s (F, cos θt).
fn refracted(wo: Vec3, n: Vec3, eta: f32, (_, cos_t): (f32, f32)) -> Vec3 {
    let cos_i = wo.dot(n).clamp(0.0, 1.0);
    (-wo / eta + (cos_i / eta - cos_t) * n).normalize()
}

fn sample_glass(
    ior: f32,
    transmittance: Vec3,
    n: Vec3,
    wo: Vec3,
    front: bool,
    u: f32,
    mode: Transport,
) -> Option<BsdfSample> {
    let (eta, fr) = glass_fresnel(ior, n, wo, front);
    let f = fr.0;
    if u < f {
        return Some(BsdfSample {
            wi: reflect(wo, n),
            weight: Vec3::ONE,
            pdf: f,
            delta: true,
        });
    }
    let wi = refracted(wo, n, eta, fr);
    let scale = match mode {
        Transport::Radiance => 1.0 / (eta * eta),
        Transport::Importance => 1.0,
    };
    Some(BsdfSample {
        wi,
        weight: transmittance * scale,
        pdf: 1.0 - f,
        delta: true,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glass_lobes_are_the_expected_outcomes_of_sampling() {
        let n = Vec3::Z;
        let t = Vec3::new(1.0, 0.9, 0.8);
        for (wo, front) in [
            (Vec3::new(0.3, 0.1, 0.95).normalize(), true),
            (Vec3::new(0.8, 0.0, 0.6), false),
            (Vec3::new(0.2, 0.0, 0.98).normalize(), false),
        ] {
            let lobes = glass_lobes(1.5, t, n, wo, front);
            // Sampling's two outcomes over a fine grid of u, weighted by how often each is drawn.
            let m = 10_000;
            let (mut refl, mut refr) = (Vec3::ZERO, Vec3::ZERO);
            for i in 0..m {
                let u = (i as f32 + 0.5) / m as f32;
                let s = sample_glass(1.5, t, n, wo, front, u, Transport::Radiance).unwrap();
                if s.wi.dot(n) > 0.0 {
                    assert!((s.wi - lobes[0].0).length() < 1e-5);
                    refl += s.weight / m as f32;
                } else {
                    assert!((s.wi - lobes[1].0).length() < 1e-5);
                    refr += s.weight / m as f32;
                }
            }
            assert!(
                (refl - lobes[0].1).abs().max_element() < 1e-3,
                "{refl} vs {:?}",
                lobes[0]
            );
            assert!(
                (refr - lobes[1].1).abs().max_element() < 1e-3,
                "{refr} vs {:?}",
                lobes[1]
            );
        }
        // Beyond the critical angle inside the glass: reflection only.
        let lobes = glass_lobes(1.5, t, n, Vec3::new(0.9, 0.0, 0.4359).normalize(), false);
        assert_eq!(lobes[0].1, Vec3::ONE);
        assert_eq!(lobes[1].1, Vec3::ZERO);
    }

    #[test]
    fn fresnel_normal_incidence_and_tir() {
        let (f, _) = fresnel_dielectric(1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-4);
        let (f, _) = fresnel_dielectric(0.1, 1.0 / 1.5);
        assert_eq!(f, 1.0);
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        // u = 0.999 picks refraction (F is small at this angle).
        let s = sample_glass(1.5, Vec3::ONE, n, wo, true, 0.999, Transport::Importance).unwrap();
        let sin_i = 0.6;
        let sin_t = (1.0 - s.wi.z * s.wi.z).sqrt();
        assert!(
            (sin_i - 1.5 * sin_t).abs() < 1e-5,
            "{sin_i} vs {}",
            1.5 * sin_t
        );
        assert!(s.wi.z < 0.0 && s.wi.x < 0.0);
    }

    #[test]
    fn glossy_texels_are_scaled_as_kd_and_capped_at_one_minus_ks() {
        let ks = Vec3::new(0.4, 0.2, 0.0);
        assert_eq!(glossy_texel(Vec3::splat(0.5), 0.8, ks), Vec3::splat(0.4));
        assert_eq!(
            glossy_texel(Vec3::ONE, 0.8, ks),
            Vec3::new(0.6, 0.8, 0.8),
            "kd + ks <= 1 for texels brighter than Kd"
        );
    }

    #[test]
    fn glossy_conserves_energy_at_grazing_and_normal() {
        let bsdf = Bsdf::Glossy {
            albedo: Vec3::splat(0.0),
            specular: Vec3::splat(1.0),
            exponent: 20.0,
            texture: None,
            texel_scale: 1.0,
        };
        let n = Vec3::Z;
        for wo in [Vec3::Z, Vec3::new(0.8, 0.0, 0.6).normalize()] {
            let mut rng = photon::sampling::Rng::new(3);
            let m = 200_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..m {
                let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                if let Some(s) = bsdf.sample(Vec3::ZERO, n, wo, true, u, Transport::Radiance) {
                    sum += s.weight;
                }
            }
            let albedo = sum.x / m as f32;
            assert!(albedo <= 1.01, "albedo {albedo}");
        }
    }

    fn chi2_bsdf(bsdf: Bsdf, kd: Vec3, wo: Vec3) {
        let n = Vec3::Z;
        let mut rng = photon::sampling::Rng::new(11);
        let mut sample = |_: usize| {
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            bsdf.sample(kd, n, wo, true, u, Transport::Radiance)
                .filter(|s| s.wi.z > 0.0)
                .map(|s| s.wi)
        };
        let pdf = |wi: Vec3| bsdf.pdf(kd, n, wo, wi) as f64;
        let (stat, limit) = crate::chi2::run(400_000, &mut sample, &pdf);
        assert!(stat < limit, "{bsdf:?} wo={wo}: χ² = {stat} ≥ {limit}");
    }

    #[test]
    fn chi2_diffuse_sampling() {
        chi2_bsdf(
            Bsdf::Diffuse {
                albedo: Vec3::splat(0.5),
                texture: None,
            },
            Vec3::splat(0.5),
            Vec3::new(0.3, 0.2, 0.9).normalize(),
        );
    }

    #[test]
    fn chi2_glossy_sampling() {
        for (exponent, wo) in [
            (10.0, Vec3::new(0.5, 0.1, 0.8)),
            (60.0, Vec3::new(-0.2, 0.4, 0.6)),
            (3.0, Vec3::Z),
        ] {
            let kd = Vec3::splat(0.3);
            chi2_bsdf(
                Bsdf::Glossy {
                    albedo: kd,
                    specular: Vec3::splat(0.5),
                    exponent,
                    texture: None,
                    texel_scale: 1.0,
                },
                kd,
                wo.normalize(),
            );
        }
    }

    #[test]
    fn chi2_detects_a_wrong_pdf() {
        // The test itself must be able to fail: a cosine sampler checked against a uniform pdf.
        let mut rng = photon::sampling::Rng::new(5);
        let mut sample = |_: usize| {
            Some(crate::warp::cosine_hemisphere([
                rng.uniform(),
                rng.uniform(),
            ]))
        };
        let pdf = |wi: Vec3| {
            if wi.z > 0.0 {
                1.0 / (2.0 * std::f64::consts::PI)
            } else {
                0.0
            }
        };
        let (stat, limit) = crate::chi2::run(100_000, &mut sample, &pdf);
        assert!(stat > limit);
    }
}
