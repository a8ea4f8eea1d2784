//! A tiny pure-Rust scene for the photon tracer: an isotropic point light and bounded planes, each
//! either Lambertian (albedo ρ, cosine sampling) or an ideal mirror (reflectance R).
#![allow(dead_code)]

use glam::{Vec2, Vec3};
use photon::{EmittedRay, PhotonScene, Scatter, SurfaceHit};

pub struct Plane {
    pub point: Vec3,
    pub normal: Vec3,
    /// Which points of the infinite plane belong to the surface.
    pub contains: fn(Vec3) -> bool,
    pub mirror: bool,
    /// Albedo (diffuse) or reflectance (mirror).
    pub reflectance: f32,
}

pub struct PlaneScene {
    pub light: Vec3,
    /// Radiant intensity, W/sr, the same in every direction.
    pub intensity: f32,
    pub planes: Vec<Plane>,
}

const EPS: f32 = 1e-4;

impl PhotonScene for PlaneScene {
    fn emit(&self, u: [f32; 5]) -> Option<EmittedRay> {
        let z = 1.0 - 2.0 * u[0];
        let s = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u[1];
        let dir = Vec3::new(s * phi.cos(), s * phi.sin(), z);
        // pdf = 1/(4π) over the sphere: power/pdf = 4π I.
        Some(EmittedRay {
            origin: self.light,
            dir,
            power: Vec3::splat(4.0 * std::f32::consts::PI * self.intensity),
            medium: u16::MAX,
        })
    }

    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit> {
        let mut best: Option<(f32, usize)> = None;
        for (i, pl) in self.planes.iter().enumerate() {
            let denom = dir.dot(pl.normal);
            if denom.abs() < 1e-9 {
                continue;
            }
            let t = (pl.point - origin).dot(pl.normal) / denom;
            if t > EPS && !best.is_some_and(|(tb, _)| t >= tb) && (pl.contains)(origin + t * dir) {
                best = Some((t, i));
            }
        }
        let (t, i) = best?;
        let pl = &self.planes[i];
        let normal = if pl.normal.dot(dir) > 0.0 {
            -pl.normal
        } else {
            pl.normal
        };
        Some(SurfaceHit {
            pos: origin + t * dir,
            normal,
            specular: pl.mirror,
            material: i as u32,
            prim: i as u32,
            uv: Vec2::ZERO,
        })
    }

    fn scatter(&self, hit: &SurfaceHit, wo: Vec3, u: [f32; 3]) -> Scatter {
        let pl = &self.planes[hit.material as usize];
        if pl.reflectance <= 0.0 {
            return Scatter::Absorbed;
        }
        let n = hit.normal;
        let dir = if pl.mirror {
            2.0 * wo.dot(n) * n - wo
        } else {
            let (t, b) = n.any_orthonormal_pair();
            let r = u[0].sqrt();
            let phi = 2.0 * std::f32::consts::PI * u[1];
            (r * phi.cos() * t + r * phi.sin() * b + (1.0 - u[0]).max(0.0).sqrt() * n).normalize()
        };
        Scatter::Continue {
            origin: hit.pos + EPS * n,
            dir,
            weight: Vec3::splat(pl.reflectance),
        }
    }

    fn has_specular(&self) -> bool {
        self.planes.iter().any(|p| p.mirror)
    }
}

/// (a) An infinite diffuse floor z = 0 (albedo 0.5) under a point light of intensity 1 W/sr at height 1.
pub fn lit_floor() -> PlaneScene {
    PlaneScene {
        light: Vec3::new(0.0, 0.0, 1.0),
        intensity: 1.0,
        planes: vec![Plane {
            point: Vec3::ZERO,
            normal: Vec3::Z,
            contains: |_| true,
            mirror: false,
            reflectance: 0.5,
        }],
    }
}

/// Analytic irradiance on the floor of [`lit_floor`]: E = I cos θ / r² = I h / r³.
pub fn lit_floor_irradiance(p: Vec3) -> f32 {
    let d = Vec3::new(0.0, 0.0, 1.0) - p;
    d.z / d.length().powi(3)
}

/// Mirror reflectance of [`mirror_wall`].
pub const MIRROR_R: f32 = 0.8;

/// (b) A diffuse floor z = 0 for x < 1 (albedo 0.5), an ideal mirror wall x = 1 for z > 0
/// (reflectance 0.8), a point light of intensity 1 W/sr at (0, 0, 1).
pub fn mirror_wall() -> PlaneScene {
    PlaneScene {
        light: Vec3::new(0.0, 0.0, 1.0),
        intensity: 1.0,
        planes: vec![
            Plane {
                point: Vec3::ZERO,
                normal: Vec3::Z,
                contains: |p| p.x < 1.0,
                mirror: false,
                reflectance: 0.5,
            },
            Plane {
                point: Vec3::X,
                normal: -Vec3::X,
                contains: |p| p.z > 0.0,
                mirror: true,
                reflectance: MIRROR_R,
            },
        ],
    }
}

/// Caustic irradiance on the floor of [`mirror_wall`]: the mirror image of the light, at (2, 0, 1),
/// seen through the mirror: E = R I cos θ' / d'² with d' the distance to the image.
pub fn mirror_wall_caustic(p: Vec3) -> f32 {
    let d = Vec3::new(2.0, 0.0, 1.0) - p;
    MIRROR_R * d.z / d.length().powi(3)
}

/// [`mirror_wall`] with a diffuse ceiling z = 3 over the floor (albedo 0.5): light the ceiling sends
/// to the mirror and on to the floor is L D S D, which must stay out of the caustic map.
pub fn mirror_wall_with_ceiling() -> PlaneScene {
    let mut scene = mirror_wall();
    scene.planes.push(Plane {
        point: Vec3::new(0.0, 0.0, 3.0),
        normal: -Vec3::Z,
        contains: |p| p.x < 1.0,
        mirror: false,
        reflectance: 0.5,
    });
    scene
}
