//! Lights: emissive triangles (area lights), point, spot and directional lights; sampling them from a
//! shading point and emitting photons from them, both in proportion to emitted power.

use std::f32::consts::PI;

use glam::Vec3;

use crate::distribution::Distribution;
use crate::geometry::Geometry;
use crate::warp::{concentric_disk, cosine_hemisphere, onb, to_world, uniform_cone, uniform_sphere, uniform_triangle};

#[derive(Clone, Debug)]
pub enum Light {
    /// An emissive triangle; `le` is its radiance, emitted toward `n`.
    Area { tri: u32, le: Vec3, n: Vec3, area: f32 },
    Point { pos: Vec3, intensity: Vec3 },
    /// Full intensity within `cos_falloff`, zero beyond `cos_cone`, linear in angle between (as Mitsuba's spot).
    Spot { pos: Vec3, dir: Vec3, intensity: Vec3, cone: f32, falloff: f32 },
    /// `dir` is the way light travels; the scene's bounding sphere (`center`, `radius`) bounds its photons.
    Directional { dir: Vec3, irradiance: Vec3, center: Vec3, radius: f32 },
}

/// Light arriving at a shading point from one sampled light position.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: Vec3,
    /// Distance to the light point (infinite for directional lights).
    pub dist: f32,
    pub p_light: Vec3,
    /// Normal at the light point (for offsetting the shadow ray's far end); zero for non-area lights.
    pub n_light: Vec3,
    /// Incident radiance × geometry / pdf for delta lights; radiance for area lights (divide by `pdf`).
    pub li: Vec3,
    /// Solid-angle pdf including the light selection (1 × selection for delta lights).
    pub pdf: f32,
    pub delta: bool,
}

/// A photon leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    pub origin: Vec3,
    pub dir: Vec3,
    /// Power of the path divided by all sampling pdfs (W).
    pub power: Vec3,
    /// Surface normal at the origin for area lights (for the ray offset), zero otherwise.
    pub n: Vec3,
}

pub struct Lights {
    pub lights: Vec<Light>,
    select: Distribution,
    /// For each triangle, the index of its area light (u32::MAX if not emissive).
    light_of_tri: Vec<u32>,
}

fn mean(c: Vec3) -> f64 {
    ((c.x + c.y + c.z) / 3.0) as f64
}

impl Light {
    /// Spot attenuation for a direction at angle cos θ from the axis.
    fn spot_falloff(cos_t: f32, cone: f32, falloff: f32) -> f32 {
        let angle = cos_t.clamp(-1.0, 1.0).acos();
        if angle <= falloff {
            1.0
        } else if angle >= cone {
            0.0
        } else {
            (cone - angle) / (cone - falloff).max(1e-6)
        }
    }

    /// Emitted power (W), per channel.
    pub fn power(&self) -> Vec3 {
        match *self {
            Light::Area { le, area, .. } => le * PI * area,
            Light::Point { intensity, .. } => intensity * 4.0 * PI,
            Light::Spot { intensity, cone, falloff, .. } => {
                // ∫ falloff dω over the cone, by the midpoint rule in θ.
                let steps = 512;
                let dt = cone / steps as f32;
                let s: f32 = (0..steps)
                    .map(|i| {
                        let t = (i as f32 + 0.5) * dt;
                        Self::spot_falloff(t.cos(), cone, falloff) * t.sin() * dt
                    })
                    .sum();
                intensity * 2.0 * PI * s
            }
            Light::Directional { irradiance, radius, .. } => irradiance * PI * radius * radius,
        }
    }
}

impl Lights {
    /// Returns None when no light emits any power.
    pub fn new(lights: Vec<Light>, n_triangles: usize) -> Option<Lights> {
        let weights: Vec<f64> = lights.iter().map(|l| mean(l.power())).collect();
        let select = Distribution::new(&weights)?;
        let mut light_of_tri = vec![u32::MAX; n_triangles];
        for (i, l) in lights.iter().enumerate() {
            if let Light::Area { tri, .. } = l {
                light_of_tri[*tri as usize] = i as u32;
            }
        }
        Some(Lights { lights, select, light_of_tri })
    }

    pub fn total_power(&self) -> Vec3 {
        self.lights.iter().map(Light::power).sum()
    }

    /// Samples incident light at `p` (`u` = [select, u1, u2]).
    pub fn sample(&self, geo: &Geometry, p: Vec3, u: [f32; 3]) -> Option<LightSample> {
        let (i, p_sel) = self.select.sample(u[0]);
        match self.lights[i] {
            Light::Area { tri, le, n, area } => {
                let (b1, b2) = uniform_triangle([u[1], u[2]]);
                let q = geo.point_on(tri, b1, b2);
                let d = q - p;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = -wi.dot(n);
                if cos_l <= 0.0 {
                    return None;
                }
                let pdf = p_sel * dist2 / (cos_l * area);
                Some(LightSample { wi, dist, p_light: q, n_light: n, li: le, pdf, delta: false })
            }
            Light::Point { pos, intensity } => {
                let d = pos - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                Some(LightSample { wi: d / dist, dist, p_light: pos, n_light: Vec3::ZERO, li: intensity / dist2, pdf: p_sel, delta: true })
            }
            Light::Spot { pos, dir, intensity, cone, falloff } => {
                let d = pos - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let wi = d / dist;
                let f = Light::spot_falloff((-wi).dot(dir), cone, falloff);
                (f > 0.0).then_some(LightSample { wi, dist, p_light: pos, n_light: Vec3::ZERO, li: intensity * f / dist2, pdf: p_sel, delta: true })
            }
            Light::Directional { dir, irradiance, .. } => Some(LightSample {
                wi: -dir,
                dist: f32::INFINITY,
                p_light: p - dir * 1e30,
                n_light: Vec3::ZERO,
                li: irradiance,
                pdf: p_sel,
                delta: true,
            }),
        }
    }

    /// Solid-angle pdf with which `sample` would pick point `q` on emissive triangle `tri` from `p`.
    pub fn pdf_hit(&self, tri: u32, p: Vec3, q: Vec3) -> f32 {
        let Some(&li) = self.light_of_tri.get(tri as usize) else { return 0.0 };
        if li == u32::MAX {
            return 0.0;
        }
        let Light::Area { n, area, .. } = self.lights[li as usize] else { return 0.0 };
        let d = q - p;
        let dist2 = d.length_squared();
        let cos_l = (-d.normalize()).dot(n);
        if cos_l <= 0.0 {
            return 0.0;
        }
        self.select.prob(li as usize) * dist2 / (cos_l * area)
    }

    /// One photon path's start: `u` = [select, position u1, u2, direction u1, u2].
    pub fn emit(&self, geo: &Geometry, u: [f32; 5]) -> Option<Emission> {
        let (i, p_sel) = self.select.sample(u[0]);
        let light = &self.lights[i];
        match *light {
            Light::Area { tri, le, n, area } => {
                let (b1, b2) = uniform_triangle([u[1], u[2]]);
                let origin = geo.point_on(tri, b1, b2);
                let dir = to_world(n, cosine_hemisphere([u[3], u[4]]));
                // Le cos / (pdf_area · pdf_dir) = Le cos · A · π / cos = Le A π.
                Some(Emission { origin, dir, power: le * area * PI / p_sel, n })
            }
            Light::Point { pos, intensity } => {
                let dir = uniform_sphere([u[3], u[4]]);
                Some(Emission { origin: pos, dir, power: intensity * 4.0 * PI / p_sel, n: Vec3::ZERO })
            }
            Light::Spot { pos, dir: axis, intensity, cone, falloff } => {
                let cos_max = cone.cos();
                let dir = to_world(axis, uniform_cone([u[3], u[4]], cos_max));
                let f = Light::spot_falloff(dir.dot(axis), cone, falloff);
                let pdf = 1.0 / (2.0 * PI * (1.0 - cos_max)).max(1e-12);
                Some(Emission { origin: pos, dir, power: intensity * f / (pdf * p_sel), n: Vec3::ZERO })
            }
            Light::Directional { dir, irradiance, center, radius } => {
                let (t, b) = onb(dir);
                let d = concentric_disk([u[1], u[2]]) * radius;
                let origin = center - dir * (2.0 * radius) + t * d.x + b * d.y;
                Some(Emission { origin, dir, power: irradiance * PI * radius * radius / p_sel, n: Vec3::ZERO })
            }
        }
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
}
