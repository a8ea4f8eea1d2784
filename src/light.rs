//! Lights: emissive triangles (area lights), point, spot and directional lights; sampling them from a
//! shading point and emitting photons from them, both in proportion to emitted power.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::Vec3;

use crate::accel::embree::Cutout;
use crate::distribution::Distribution;
use crate::geometry::Geometry;
use crate::warp::{
    concentric_disk, cosine_hemisphere, onb, to_world, uniform_cone, uniform_sphere,
    uniform_triangle,
};

#[derive(Clone, Debug)]
pub enum Light {
    /// An emissive triangle; `le` is its radiance, emitted toward `n`.
    Area {
        tri: u32,
        le: Vec3,
        n: Vec3,
        area: f32,
    },
    Point {
        pos: Vec3,
        intensity: Vec3,
    },
    /// Full intensity within `cos_falloff`, zero beyond `cos_cone`, linear in angle between (as Mitsuba's spot).
    Spot {
        pos: Vec3,
        dir: Vec3,
        intensity: Vec3,
        cone: f32,
        falloff: f32,
    },
    /// `dir` is the way light travels; the scene's bounding sphere (`center`, `radius`) bounds its photons.
    Directional {
        dir: Vec3,
        irradiance: Vec3,
        center: Vec3,
        radius: f32,
    },
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
    /// Index of the light in `Lights::lights`.
    pub light: usize,
}

pub struct Lights {
    pub lights: Vec<Light>,
    /// Selection by power; `None` in a scene without any light (rendered only by the occlusion methods).
    select: Option<Distribution>,
    /// Selection among area lights only (by power), for integrators that evaluate every delta light.
    select_area: Option<Distribution>,
    /// For each triangle, the index of its area light (u32::MAX if not emissive).
    light_of_tri: Vec<u32>,
    /// The cutouts (`map_d`) of a scene where they cut an emitter: a sample on a cut texel emits
    /// nothing, as the texel is not there. `None` otherwise (no test per sample).
    cut: Option<Arc<dyn Cutout>>,
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
            Light::Spot {
                intensity,
                cone,
                falloff,
                ..
            } => {
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
            Light::Directional {
                irradiance, radius, ..
            } => irradiance * PI * radius * radius,
        }
    }
}

impl Lights {
    /// Returns None when no light emits any power.
    pub fn new(lights: Vec<Light>, n_triangles: usize) -> Option<Lights> {
        let weights: Vec<f64> = lights.iter().map(|l| mean(l.power())).collect();
        let select = Distribution::new(&weights)?;
        let area_weights: Vec<f64> = lights
            .iter()
            .zip(&weights)
            .map(|(l, w)| {
                if matches!(l, Light::Area { .. }) {
                    *w
                } else {
                    0.0
                }
            })
            .collect();
        let select_area = Distribution::new(&area_weights);
        let mut light_of_tri = vec![u32::MAX; n_triangles];
        for (i, l) in lights.iter().enumerate() {
            if let Light::Area { tri, .. } = l {
                light_of_tri[*tri as usize] = i as u32;
            }
        }
        Some(Lights {
            lights,
            select: Some(select),
            select_area,
            light_of_tri,
            cut: None,
        })
    }

    /// Makes samples and photons that start on a texel `cut` removes emit nothing.
    pub fn cut_by(&mut self, cut: Arc<dyn Cutout>) {
        self.cut = Some(cut);
    }

    /// Whether the point at barycentrics (b1, b2) of emissive triangle `tri` is cut away.
    fn is_cut(&self, tri: u32, b1: f32, b2: f32) -> bool {
        self.cut.as_ref().is_some_and(|c| c.is_cut(tri, b1, b2))
    }

    /// A scene's lights when it has none at all: the occlusion methods render it, the others refuse it
    /// (see `render::plan`).
    pub fn none(n_triangles: usize) -> Lights {
        Lights {
            lights: Vec::new(),
            select: None,
            select_area: None,
            light_of_tri: vec![u32::MAX; n_triangles],
            cut: None,
        }
    }

    pub fn total_power(&self) -> Vec3 {
        self.lights.iter().map(Light::power).sum()
    }

    /// Samples incident light at `p` (`u` = [select, u1, u2]).
    pub fn sample(&self, geo: &Geometry, p: Vec3, u: [f32; 3]) -> Option<LightSample> {
        let (i, p_sel) = self.select.as_ref()?.sample(u[0]);
        self.sample_light(i, p_sel, geo, p, u)
    }

    /// Whether any light is an emissive triangle.
    pub fn has_area(&self) -> bool {
        self.select_area.is_some()
    }

    /// Samples one area light (chosen by power among area lights only); None without area lights.
    pub fn sample_area(&self, geo: &Geometry, p: Vec3, u: [f32; 3]) -> Option<LightSample> {
        let (i, p_sel) = self.select_area.as_ref()?.sample(u[0]);
        self.sample_light(i, p_sel, geo, p, u)
    }

    /// [`Self::sample_area`] at a point of the unit square: its first coordinate chooses the triangle
    /// and, rescaled within the triangle's share, places the point with the second, so that points
    /// stratified in the square stay stratified over the lights' area.
    pub fn sample_area_at(&self, geo: &Geometry, p: Vec3, u: [f32; 2]) -> Option<LightSample> {
        let (i, p_sel, rest) = self.select_area.as_ref()?.sample_remapped(u[0]);
        self.sample_light(i, p_sel, geo, p, [u[0], rest, u[1]])
    }

    /// The incident light from every point, spot and directional light at `p` (no randomness).
    pub fn delta_samples<'a>(
        &'a self,
        geo: &'a Geometry,
        p: Vec3,
    ) -> impl Iterator<Item = LightSample> + 'a {
        (0..self.lights.len())
            .filter(|&i| !matches!(self.lights[i], Light::Area { .. }))
            .filter_map(move |i| self.sample_light(i, 1.0, geo, p, [0.5; 3]))
    }

    /// The incident light at `p` from delta light `i` (point, spot, directional; `None` for an area
    /// light or outside a spot's cone).
    pub fn delta_sample(&self, i: usize, geo: &Geometry, p: Vec3) -> Option<LightSample> {
        if matches!(self.lights[i], Light::Area { .. }) {
            return None;
        }
        self.sample_light(i, 1.0, geo, p, [0.5; 3])
    }

    /// Solid-angle pdf with which `sample_area` would pick point `q` on emissive triangle `tri` from `p`.
    pub fn pdf_hit_area(&self, tri: u32, p: Vec3, q: Vec3) -> f32 {
        match &self.select_area {
            Some(d) => self.pdf_hit_with(d, tri, p, q),
            None => 0.0,
        }
    }

    fn sample_light(
        &self,
        i: usize,
        p_sel: f32,
        geo: &Geometry,
        p: Vec3,
        u: [f32; 3],
    ) -> Option<LightSample> {
        match self.lights[i] {
            Light::Area { tri, le, n, area } => {
                let (b1, b2) = uniform_triangle([u[1], u[2]]);
                if self.is_cut(tri, b1, b2) {
                    return None;
                }
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
                Some(LightSample {
                    wi,
                    dist,
                    p_light: q,
                    n_light: n,
                    li: le,
                    pdf,
                    delta: false,
                })
            }
            Light::Point { pos, intensity } => {
                let d = pos - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                Some(LightSample {
                    wi: d / dist,
                    dist,
                    p_light: pos,
                    n_light: Vec3::ZERO,
                    li: intensity / dist2,
                    pdf: p_sel,
                    delta: true,
                })
            }
            Light::Spot {
                pos,
                dir,
                intensity,
                cone,
                falloff,
            } => {
                let d = pos - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let wi = d / dist;
                let f = Light::spot_falloff((-wi).dot(dir), cone, falloff);
                (f > 0.0).then_some(LightSample {
                    wi,
                    dist,
                    p_light: pos,
                    n_light: Vec3::ZERO,
                    li: intensity * f / dist2,
                    pdf: p_sel,
                    delta: true,
                })
            }
            Light::Directional {
                dir, irradiance, ..
            } => Some(LightSample {
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
        match &self.select {
            Some(select) => self.pdf_hit_with(select, tri, p, q),
            None => 0.0,
        }
    }

    fn pdf_hit_with(&self, select: &Distribution, tri: u32, p: Vec3, q: Vec3) -> f32 {
        let Some(&li) = self.light_of_tri.get(tri as usize) else {
            return 0.0;
        };
        if li == u32::MAX {
            return 0.0;
        }
        let Light::Area { n, area, .. } = self.lights[li as usize] else {
            return 0.0;
        };
        let d = q - p;
        let dist2 = d.length_squared();
        let cos_l = (-d.normalize()).dot(n);
        if cos_l <= 0.0 {
            return 0.0;
        }
        select.prob(li as usize) * dist2 / (cos_l * area)
    }

    /// One photon path's start: `u` = [select, position u1, u2, direction u1, u2].
    pub fn emit(&self, geo: &Geometry, u: [f32; 5]) -> Option<Emission> {
        let (i, p_sel) = self.select.as_ref()?.sample(u[0]);
        let light = &self.lights[i];
        match *light {
            Light::Area { tri, le, n, area } => {
                let (b1, b2) = uniform_triangle([u[1], u[2]]);
                if self.is_cut(tri, b1, b2) {
                    return None;
                }
                let origin = geo.point_on(tri, b1, b2);
                let dir = to_world(n, cosine_hemisphere([u[3], u[4]]));
                // Le cos / (pdf_area · pdf_dir) = Le cos · A · π / cos = Le A π.
                Some(Emission {
                    origin,
                    dir,
                    power: le * area * PI / p_sel,
                    n,
                    light: i,
                })
            }
            Light::Point { pos, intensity } => {
                let dir = uniform_sphere([u[3], u[4]]);
                Some(Emission {
                    origin: pos,
                    dir,
                    power: intensity * 4.0 * PI / p_sel,
                    n: Vec3::ZERO,
                    light: i,
                })
            }
            Light::Spot {
                pos,
                dir: axis,
                intensity,
                cone,
                falloff,
            } => {
                let cos_max = cone.cos();
                let dir = to_world(axis, uniform_cone([u[3], u[4]], cos_max));
                let f = Light::spot_falloff(dir.dot(axis), cone, falloff);
                let pdf = 1.0 / (2.0 * PI * (1.0 - cos_max)).max(1e-12);
                Some(Emission {
                    origin: pos,
                    dir,
                    power: intensity * f / (pdf * p_sel),
                    n: Vec3::ZERO,
                    light: i,
                })
            }
            Light::Directional {
                dir,
                irradiance,
                center,
                radius,
            } => {
                let (t, b) = onb(dir);
                let d = concentric_disk([u[1], u[2]]) * radius;
                let origin = center - dir * (2.0 * radius) + t * d.x + b * d.y;
                Some(Emission {
                    origin,
                    dir,
                    power: irradiance * PI * radius * radius / p_sel,
                    n: Vec3::ZERO,
                    light: i,
                })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;

    /// Two emissive triangles of different area and radiance above the origin.
    fn two_emitters() -> (Geometry, Lights) {
        let positions = vec![
            Vec3::new(-1.0, -0.5, 1.0),
            Vec3::new(0.5, -0.5, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
            Vec3::new(0.5, 0.5, 2.0),
            Vec3::new(2.0, 0.5, 2.0),
            Vec3::new(0.5, 1.5, 1.5),
        ];
        let mut geo = Geometry {
            normals: vec![Vec3::ZERO; 6],
            uvs: vec![glam::Vec2::ZERO; 6],
            positions,
            ..Default::default()
        };
        let mut lights = Vec::new();
        for (k, le) in [(0u32, 2.0f32), (1, 5.0)] {
            let v = [3 * k, 3 * k + 1, 3 * k + 2];
            let [a, b, c] = v.map(|i| geo.positions[i as usize]);
            let cr = (b - a).cross(c - a);
            // Face the origin (downward).
            let (v, ng) = if cr.z > 0.0 {
                ([v[0], v[2], v[1]], -cr.normalize())
            } else {
                (v, cr.normalize())
            };
            geo.triangles.push(Triangle {
                v,
                material: 0,
                ng,
                area: 0.5 * cr.length(),
                has_normals: false,
                has_uv: false,
            });
            lights.push(Light::Area {
                tri: k,
                le: Vec3::splat(le),
                n: ng,
                area: 0.5 * cr.length(),
            });
        }
        let n = geo.triangles.len();
        (geo, Lights::new(lights, n).unwrap())
    }

    fn ray_triangle(geo: &Geometry, tri: u32, o: Vec3, d: Vec3) -> Option<Vec3> {
        let [a, b, c] = geo.triangles[tri as usize]
            .v
            .map(|i| geo.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-12 {
            return None;
        }
        let tv = o - a;
        let u = tv.dot(pv) / det;
        let qv = tv.cross(e1);
        let v = d.dot(qv) / det;
        let t = e2.dot(qv) / det;
        (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(o + d * t)
    }

    #[test]
    fn chi2_area_light_sampling() {
        let (geo, lights) = two_emitters();
        let p = Vec3::ZERO;
        let mut rng = photon::sampling::Rng::new(2);
        let mut sample = |_: usize| {
            lights
                .sample(&geo, p, [rng.uniform(), rng.uniform(), rng.uniform()])
                .map(|s| s.wi)
        };
        let pdf = |wi: Vec3| -> f64 {
            (0..2u32)
                .filter_map(|t| {
                    ray_triangle(&geo, t, p, wi).map(|q| lights.pdf_hit(t, p, q) as f64)
                })
                .sum()
        };
        let (stat, limit) = crate::chi2::run(300_000, &mut sample, &pdf);
        assert!(stat < limit, "χ² = {stat} ≥ {limit}");
    }

    #[test]
    fn lights_are_chosen_by_power() {
        let (_, lights) = two_emitters();
        let p: Vec<f32> = (0..2)
            .map(|i| lights.select.as_ref().unwrap().prob(i))
            .collect();
        let w: Vec<f32> = lights.lights.iter().map(|l| l.power().x).collect();
        assert!((p[0] / p[1] - w[0] / w[1]).abs() < 1e-4);
    }

    #[test]
    fn emitted_photon_power_sums_to_light_power() {
        let (geo, lights) = two_emitters();
        let n = 10_000;
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            let u = [0, 1, 2, 3, 4].map(|d| photon::sampling::halton(i, d, 1));
            sum += lights.emit(&geo, u).unwrap().power;
        }
        let mean = sum / n as f32;
        let total = lights.total_power();
        assert!(
            ((mean - total).length() / total.length()) < 1e-3,
            "{mean} vs {total}"
        );
    }

    #[test]
    fn spot_power_matches_falloff_integral() {
        // Linear-in-angle falloff between 20° and 30°: compare with a fine numerical integral.
        let l = Light::Spot {
            pos: Vec3::ZERO,
            dir: Vec3::Z,
            intensity: Vec3::ONE,
            cone: 30f32.to_radians(),
            falloff: 20f32.to_radians(),
        };
        let steps = 100_000;
        let mut s = 0.0f64;
        for i in 0..steps {
            let t = (i as f64 + 0.5) / steps as f64 * std::f64::consts::PI;
            let f =
                Light::spot_falloff(t.cos() as f32, 30f32.to_radians(), 20f32.to_radians()) as f64;
            s += f * t.sin() * std::f64::consts::PI / steps as f64;
        }
        let expected = 2.0 * std::f64::consts::PI * s;
        assert!((l.power().x as f64 - expected).abs() < 1e-3 * expected);
    }
}
