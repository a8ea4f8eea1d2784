//! Method `path`: unidirectional path tracing with next-event estimation, multiple importance sampling
//! (power heuristic) and Russian roulette. The reference inside our own binary.

use glam::Vec3;
use photon::sampling::Rng;

use super::{Frame, SampleCounters};
use crate::geometry::spawn;
use crate::material::Transport;
use crate::scene::Scene;
use crate::warp::power_heuristic;

/// Radiance arriving at `origin` from direction `dir`.
pub fn radiance(scene: &Scene, origin: Vec3, dir: Vec3, max_depth: u32, rng: &mut Rng, c: &mut SampleCounters) -> Vec3 {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let (mut o, mut d) = (origin, dir);
    let mut delta_bounce = true;
    let mut prev_pdf = 0.0f32;
    let mut prev_p = origin;
    for depth in 0..max_depth {
        c.rays += 1;
        let Some(hit) = scene.intersect(o, d) else { break };
        let wo = -d;
        let le = scene.emitted(&hit, wo);
        if le != Vec3::ZERO {
            let w = if delta_bounce { 1.0 } else { power_heuristic(prev_pdf, scene.lights.pdf_hit(hit.tri, prev_p, hit.p)) };
            l += beta * le * w;
        }
        let frame = Frame::new(&hit, wo);
        let bsdf = &scene.material(&hit).bsdf;
        let kd = scene.albedo(&hit);
        if !bsdf.is_specular() {
            l += beta * direct_light(scene, &hit, &frame, wo, kd, rng, c);
        }
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        let Some(s) = bsdf.sample(kd, frame.n, wo, frame.front, u, Transport::Radiance) else {
            c.zero_pdf += 1;
            break;
        };
        if !s.delta && !frame.same_side(s.wi) {
            break;
        }
        beta *= s.weight;
        if beta == Vec3::ZERO {
            break;
        }
        delta_bounce = s.delta;
        prev_pdf = s.pdf;
        prev_p = hit.p;
        if depth >= 3 {
            let q = beta.max_element().min(0.95);
            if rng.uniform() >= q {
                break;
            }
            beta /= q;
        }
        o = spawn(&hit, s.wi);
        d = s.wi;
    }
    l
}

/// One light sample with MIS against BSDF sampling (area lights) — reflected radiance toward `wo`.
pub fn direct_light(scene: &Scene, hit: &crate::geometry::Hit, frame: &Frame, wo: Vec3, kd: Vec3, rng: &mut Rng, c: &mut SampleCounters) -> Vec3 {
    let bsdf = &scene.material(hit).bsdf;
    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
    let Some(ls) = scene.lights.sample(&scene.geometry, hit.p, u) else { return Vec3::ZERO };
    if ls.pdf <= 0.0 || !frame.same_side(ls.wi) {
        return Vec3::ZERO;
    }
    let f = bsdf.eval(kd, frame.n, wo, ls.wi) * ls.wi.dot(frame.n).abs();
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    c.shadow_rays += 1;
    if scene.occluded(hit, ls.wi, ls.dist) {
        return Vec3::ZERO;
    }
    if ls.delta {
        f * ls.li / ls.pdf
    } else {
        let w = power_heuristic(ls.pdf, bsdf.pdf(kd, frame.n, wo, ls.wi));
        f * ls.li * w / ls.pdf
    }
}
