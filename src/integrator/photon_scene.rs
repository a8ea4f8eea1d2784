//! The scene as the photon pass sees it: emission from the lights, Embree hits, BSDF sampling in
//! importance mode.

use glam::Vec3;
use photon::{EmittedRay, PhotonScene, Scatter, SurfaceHit};

use super::Frame;
use crate::geometry::{offset_origin, spawn, Hit};
use crate::material::Transport;
use crate::scene::Scene;

pub struct PhotonView<'a>(pub &'a Scene);

impl PhotonView<'_> {
    /// Rebuilds our hit from the photon crate's (only what `scatter` needs).
    fn hit(&self, h: &SurfaceHit) -> Hit {
        let tri = &self.0.geometry.triangles[h.prim as usize];
        let ns = if h.normal.dot(tri.ng) >= 0.0 { h.normal } else { -h.normal };
        Hit { p: h.pos, t: 0.0, ng: tri.ng, ns, uv: h.uv, tri: h.prim, material: h.material }
    }
}

impl PhotonScene for PhotonView<'_> {
    fn emit(&self, u: [f32; 5]) -> Option<EmittedRay> {
        let e = self.0.lights.emit(&self.0.geometry, u)?;
        let origin = if e.n == Vec3::ZERO { e.origin } else { offset_origin(e.origin, e.n) };
        Some(EmittedRay { origin, dir: e.dir, power: e.power })
    }

    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit> {
        let hit = self.0.intersect(origin, dir)?;
        let frame = Frame::new(&hit, -dir);
        let bsdf = &self.0.material(&hit).bsdf;
        Some(SurfaceHit {
            pos: hit.p,
            normal: frame.n,
            specular: bsdf.is_specular(),
            material: hit.material,
            prim: hit.tri,
            uv: hit.uv,
        })
    }

    fn scatter(&self, h: &SurfaceHit, wo: Vec3, u: [f32; 3]) -> Scatter {
        let hit = self.hit(h);
        let frame = Frame::new(&hit, wo);
        let bsdf = &self.0.material(&hit).bsdf;
        let kd = self.0.albedo(&hit);
        match bsdf.sample(kd, frame.n, wo, frame.front, u, Transport::Importance) {
            Some(s) if s.weight.max_element() > 0.0 && (s.delta || frame.same_side(s.wi)) => {
                Scatter::Continue { origin: spawn(&hit, s.wi), dir: s.wi, weight: s.weight }
            }
            _ => Scatter::Absorbed,
        }
    }

    fn has_specular(&self) -> bool {
        self.0.has_specular()
    }
}
