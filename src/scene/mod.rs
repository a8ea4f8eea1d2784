//! A loaded scene: camera, triangles in an Embree BVH, materials, textures, lights and render settings.

pub mod file;
pub mod input;
pub mod limits;
mod mtl;
mod obj;
mod objcheck;
mod build;
mod lights;
mod settings;

use std::path::{Path, PathBuf};

use glam::Vec3;

pub use build::load;
pub use file::{IcacheDesc, PhotonsDesc};
pub use settings::{FillMode, IcacheSettings, PhotonConfig, MAX_PHOTONS, SPACING_REFERENCE_SIDE};

use crate::accel::embree::Bvh;
use crate::camera::Camera;
use crate::geometry::{spawn, Geometry, Hit};
use crate::light::Lights;
use crate::material::Material;
use crate::texture::Texture;

/// The rendering method: the closed set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Path,
    Pm,
    PmFg,
    Photons,
}

impl Method {
    pub fn parse(s: &str) -> Option<Method> {
        match s {
            "path" => Some(Method::Path),
            "pm" => Some(Method::Pm),
            "pm-fg" => Some(Method::PmFg),
            "photons" => Some(Method::Photons),
            _ => None,
        }
    }

    /// Whether the method traces photon maps (every method but `path`).
    pub fn uses_photon_maps(self) -> bool {
        self != Method::Path
    }

    pub fn name(self) -> &'static str {
        match self {
            Method::Path => "path",
            Method::Pm => "pm",
            Method::PmFg => "pm-fg",
            Method::Photons => "photons",
        }
    }
}

pub const METHODS: &str = "path | pm | pm-fg | photons";

/// `[render]` after validation; `None` means "derive from the scene/method".
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub method: Option<Method>,
    pub spp: Option<u32>,
    /// Adaptive sampling's noise target; `None`: the method's default.
    pub noise: Option<f32>,
    pub seed: u64,
    pub max_depth: u32,
    pub photons: PhotonConfig,
    pub icache: IcacheSettings,
}

pub struct Scene {
    pub path: PathBuf,
    pub camera: Camera,
    pub geometry: Geometry,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Lights,
    pub bvh: Bvh,
    pub settings: RenderSettings,
    pub bounds: (Vec3, Vec3),
    /// Hash of everything that affects light transport (not the camera), for photon and cache files.
    pub fingerprint: u64,
}

impl Scene {
    pub fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        self.bvh.intersect(origin, dir, f32::INFINITY).map(|raw| self.geometry.hit(origin, dir, raw))
    }

    /// The first hit of a final-gather ray: on a plain diffuse surface the light hit of
    /// [`Geometry::hit_flat`] (all a gather reads there), elsewhere the full one.
    pub fn intersect_gather(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let raw = self.bvh.intersect(origin, dir, f32::INFINITY)?;
        let tri = &self.geometry.triangles[raw.prim as usize];
        Some(match &self.materials[tri.material as usize].bsdf {
            crate::material::Bsdf::Diffuse { .. } => self.geometry.hit_flat(origin, dir, raw),
            _ => self.geometry.hit(origin, dir, raw),
        })
    }

    /// Whether the segment from `hit` toward a light point is blocked.
    pub fn occluded(&self, hit: &Hit, wi: Vec3, dist: f32) -> bool {
        let o = spawn(hit, wi);
        let tmax = if dist.is_finite() { (dist - (o - hit.p).length()) * (1.0 - 1e-4) } else { f32::INFINITY };
        tmax > 0.0 && self.bvh.occluded(o, wi, tmax)
    }

    /// Diffuse albedo at a hit (texture-resolved).
    pub fn albedo(&self, hit: &Hit) -> Vec3 {
        match &self.materials[hit.material as usize].bsdf {
            crate::material::Bsdf::Diffuse { albedo, texture } => match texture {
                Some(t) => self.textures[*t].lookup(hit.uv),
                None => *albedo,
            },
            crate::material::Bsdf::Glossy { albedo, .. } => *albedo,
            _ => Vec3::ZERO,
        }
    }

    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }

    /// Radiance emitted from `hit` toward `wo` (one-sided emitters).
    pub fn emitted(&self, hit: &Hit, wo: Vec3) -> Vec3 {
        let m = self.material(hit);
        if m.emission == Vec3::ZERO || wo.dot(self.geometry.emit_normal(hit.tri)) <= 0.0 {
            Vec3::ZERO
        } else {
            m.emission
        }
    }

    pub fn diagonal(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).length()
    }

    /// Whether any triangle is mirror or glass (unused MTL entries do not count).
    pub fn has_specular(&self) -> bool {
        self.geometry.triangles.iter().any(|t| self.materials[t.material as usize].bsdf.is_specular())
    }

    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }
}
