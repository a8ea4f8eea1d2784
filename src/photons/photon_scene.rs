//! The scene as the photon pass sees it: emission from the lights, Embree hits, BSDF sampling in
//! importance mode.

use glam::Vec3;
use photon::{EmittedRay, PhotonScene, Propagation, Scatter, SurfaceHit};

use crate::geometry::Frame;
use crate::geometry::{offset_origin, spawn, Hit};
use crate::material::Transport;
use crate::medium::{sample_phase, Flight, VACUUM};
use crate::scene::{Scene, MAX_NULL_CROSSINGS};

pub struct PhotonView<'a>(pub &'a Scene);

impl PhotonView<'_> {
    /// Rebuilds our hit from the photon crate's (only what `scatter` needs).
    fn hit(&self, h: &SurfaceHit) -> Hit {
        let tri = &self.0.geometry.triangles[h.prim as usize];
        let ns = if h.normal.dot(tri.ng) >= 0.0 {
            h.normal
        } else {
            -h.normal
        };
        Hit {
            p: h.pos,
            t: 0.0,
            ng: tri.ng,
            ns,
            uv: h.uv,
            tri: h.prim,
            material: h.material,
        }
    }
}

impl PhotonScene for PhotonView<'_> {
    fn emit(&self, u: [f32; 5]) -> Option<EmittedRay> {
        let e = self.0.lights.emit(&self.0.geometry, u)?;
        let origin = if e.n == Vec3::ZERO {
            e.origin
        } else {
            offset_origin(e.origin, e.n)
        };
        let medium = self.0.media.as_ref().map_or(VACUUM, |m| m.lights[e.light]);
        Some(EmittedRay {
            origin,
            dir: e.dir,
            power: e.power,
            medium,
        })
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
        let frame = self.0.frame(&hit, wo);
        let bsdf = &self.0.bsdf(&hit);
        let kd = self.0.albedo(&hit);
        match bsdf.sample(kd, frame.n, wo, frame.front, u, Transport::Importance) {
            Some(s) if s.weight.max_element() > 0.0 && (s.delta || frame.same_side(s.wi)) => {
                Scatter::Continue {
                    origin: spawn(&hit, s.wi),
                    dir: s.wi,
                    weight: s.weight,
                }
            }
            _ => Scatter::Absorbed,
        }
    }

    fn has_specular(&self) -> bool {
        self.0.has_specular()
    }

    fn may_reach_specular(&self, origin: Vec3, dir: Vec3) -> bool {
        self.0
            .specular_bvh
            .as_ref()
            .is_some_and(|b| b.occluded(origin, dir, f32::INFINITY))
    }

    fn has_media(&self) -> bool {
        self.0.media.is_some()
    }

    /// One optical depth per flight, used up across the media it crosses (`u[1]` is unused).
    fn propagate(
        &self,
        origin: Vec3,
        dir: Vec3,
        medium: u16,
        hero: usize,
        u: [f32; 2],
    ) -> Propagation {
        let scene = self.0;
        let (mut t0, mut medium, mut weight, mut ratio) = (0.0f32, medium, Vec3::ONE, Vec3::ONE);
        let mut tau = -(1.0 - u[0]).ln();
        for _ in 0..MAX_NULL_CROSSINGS {
            let raw = scene.bvh.intersect_range(origin, dir, t0, f32::INFINITY);
            if let Some(m) = scene.medium(medium) {
                match m.photon_segment(raw.map_or(f32::INFINITY, |r| r.t - t0), hero, &mut tau) {
                    Flight::Scatter {
                        t,
                        weight: w,
                        ratio: r,
                    } => {
                        return Propagation::Medium {
                            pos: origin + dir * (t0 + t),
                            weight: weight * w,
                            ratio: ratio * r,
                            medium,
                        };
                    }
                    Flight::Through {
                        weight: w,
                        ratio: r,
                    } => {
                        weight *= w;
                        ratio *= r;
                    }
                }
            }
            let Some(raw) = raw else {
                return Propagation::Escaped;
            };
            let hit = scene.geometry.hit(origin, dir, raw);
            if !scene.material(&hit).bsdf.is_null() {
                let frame = Frame::new(&hit, -dir);
                let bsdf = &scene.material(&hit).bsdf;
                let hit = SurfaceHit {
                    pos: hit.p,
                    normal: frame.n,
                    specular: bsdf.is_specular(),
                    material: hit.material,
                    prim: hit.tri,
                    uv: hit.uv,
                };
                return Propagation::Surface {
                    hit,
                    weight,
                    ratio,
                    medium,
                };
            }
            (medium, t0) = scene.cross(origin, dir, hit.tri, hit.t, medium);
        }
        scene.give_up_crossings();
        Propagation::Escaped
    }

    fn medium_after(&self, h: &SurfaceHit, dir: Vec3, current: u16) -> u16 {
        self.0.medium_after(&self.hit(h), dir, current)
    }

    fn scatter_in_medium(&self, dir: Vec3, medium: u16, u: [f32; 2]) -> Vec3 {
        let g = self.0.medium(medium).map_or(0.0, |m| m.g);
        sample_phase(g, dir, u).0
    }
}
