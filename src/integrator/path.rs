//! Method `path`: unidirectional path tracing with next-event estimation, multiple importance sampling
//! (power heuristic) and Russian roulette. The reference inside our own binary.

use glam::Vec3;
use photon::sampling::Rng;

use crate::counters::SampleCounters;
use crate::geometry::spawn;
use crate::geometry::Frame;
use crate::material::Transport;
use crate::medium::{phase, sample_phase, Flight, MediumId};
use crate::scene::{past, Scene, MAX_NULL_CROSSINGS};
use crate::warp::power_heuristic;

/// Radiance arriving at `origin` from direction `dir`, the ray starting in `medium`. In a scene with
/// media this is a volumetric path tracer: free flights between surfaces, next-event estimation with
/// transmittance at every scattering event, Henyey–Greenstein sampling, null boundaries crossed without
/// counting a bounce. Without media it draws exactly the numbers it always drew.
pub fn radiance(
    scene: &Scene,
    origin: Vec3,
    dir: Vec3,
    medium: MediumId,
    max_depth: u32,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> Vec3 {
    c.monte_carlo += 1;
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let (mut o, mut d) = (origin, dir);
    let mut medium = medium;
    let mut delta_bounce = true;
    let mut prev_pdf = 0.0f32;
    let mut prev_p = origin;
    let mut crossings = 0;
    let mut depth = 0;
    // Past invisible boundaries the ray goes on along the same line: `t0` is how far it has come.
    let mut t0 = 0.0f32;
    // Spectral MIS in media (see `Flight`): the channel that samples distances, drawn at the first
    // medium met, and each channel's path pdf over the hero's (scaled to mean 1); `beta` is already
    // divided by their mean.
    let mut hero = None;
    let mut ratio = Vec3::ONE;
    while depth < max_depth {
        c.rays += 1;
        let hit = scene.intersect_after(o, d, t0);
        if let Some(m) = scene.medium(medium) {
            let h = *hero.get_or_insert_with(|| ((rng.uniform() * 3.0) as usize).min(2));
            match m.sample_flight(hit.map_or(f32::INFINITY, |h| h.t - t0), h, rng.uniform()) {
                Flight::Scatter {
                    t,
                    weight,
                    ratio: r,
                } => {
                    (beta, ratio) = spectral_mis(beta, ratio, weight, r);
                    let p = o + d * (t0 + t);
                    l += beta * medium_direct(scene, m.g, p, d, medium, rng, c);
                    let (wi, pdf) = sample_phase(m.g, d, [rng.uniform(), rng.uniform()]);
                    (delta_bounce, prev_pdf, prev_p) = (false, pdf, p);
                    if !roulette(depth, &mut beta, rng) {
                        break;
                    }
                    (o, d, t0) = (p, wi, 0.0);
                    depth += 1;
                    continue;
                }
                Flight::Through { weight, ratio: r } => {
                    (beta, ratio) = spectral_mis(beta, ratio, weight, r)
                }
            }
        }
        let Some(hit) = hit else { break };
        let bsdf = &scene.material(&hit).bsdf;
        if bsdf.is_null() {
            crossings += 1;
            if crossings > MAX_NULL_CROSSINGS {
                break;
            }
            medium = scene.medium_after(&hit, d, medium);
            t0 = past(hit.t, o);
            continue;
        }
        let wo = -d;
        let le = scene.emitted(&hit, wo);
        if le != Vec3::ZERO {
            let w = if delta_bounce {
                1.0
            } else {
                power_heuristic(prev_pdf, scene.lights.pdf_hit(hit.tri, prev_p, hit.p))
            };
            l += beta * le * w;
        }
        let frame = Frame::new(&hit, wo);
        let kd = scene.albedo(&hit);
        if !bsdf.is_specular() {
            l += beta * direct_light(scene, &hit, &frame, wo, kd, medium, rng, c);
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
        if !roulette(depth, &mut beta, rng) {
            break;
        }
        medium = scene.medium_after(&hit, s.wi, medium);
        o = spawn(&hit, s.wi);
        d = s.wi;
        t0 = 0.0;
        depth += 1;
    }
    l
}

/// One free flight into the path's spectral MIS: `beta` is the throughput f/p̄ with p̄ the mean over
/// the channels of the path pdf, `ratio` the channels' pdfs over the hero's, scaled to mean 1.
fn spectral_mis(beta: Vec3, ratio: Vec3, weight: Vec3, r: Vec3) -> (Vec3, Vec3) {
    let next = ratio * r;
    let m = (next.x + next.y + next.z) / 3.0;
    if !(m > 0.0 && m.is_finite()) {
        return (Vec3::ZERO, Vec3::ONE);
    }
    (beta * weight / m, next / m)
}

/// Russian roulette from the fourth bounce on: false when the path ends, else `beta` is reweighted.
fn roulette(depth: u32, beta: &mut Vec3, rng: &mut Rng) -> bool {
    if depth >= 3 {
        let q = beta.max_element().min(0.95);
        if rng.uniform() >= q {
            return false;
        }
        *beta /= q;
    }
    true
}

/// Single scattering at a point `p` of a medium (asymmetry `g`) reached travelling along `d`: one light
/// sample, times the phase function and the transmittance to the light, MIS against phase sampling for
/// area lights. In-scattered radiance per unit σs (the caller's throughput holds σs).
pub fn medium_direct(
    scene: &Scene,
    g: f32,
    p: Vec3,
    d: Vec3,
    medium: MediumId,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> Vec3 {
    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
    let Some(ls) = scene.lights.sample(&scene.geometry, p, u) else {
        return Vec3::ZERO;
    };
    if ls.pdf <= 0.0 {
        return Vec3::ZERO;
    }
    let f = phase(g, d, ls.wi);
    let tr = scene.visibility_from(p, ls.wi, ls.dist, medium, &mut c.shadow_rays);
    if tr == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let w = if ls.delta {
        1.0
    } else {
        power_heuristic(ls.pdf, f)
    };
    tr * f * ls.li * w / ls.pdf
}

/// One light sample with MIS against BSDF sampling (area lights) — reflected radiance toward `wo`.
#[allow(clippy::too_many_arguments)]
pub fn direct_light(
    scene: &Scene,
    hit: &crate::geometry::Hit,
    frame: &Frame,
    wo: Vec3,
    kd: Vec3,
    medium: MediumId,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> Vec3 {
    let bsdf = &scene.material(hit).bsdf;
    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
    let Some(ls) = scene.lights.sample(&scene.geometry, hit.p, u) else {
        return Vec3::ZERO;
    };
    if ls.pdf <= 0.0 || !frame.same_side(ls.wi) {
        return Vec3::ZERO;
    }
    let f = bsdf.eval(kd, frame.n, wo, ls.wi) * ls.wi.dot(frame.n).abs();
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let tr = scene.visibility(hit, ls.wi, ls.dist, medium, &mut c.shadow_rays);
    if tr == Vec3::ZERO {
        return Vec3::ZERO;
    }
    if ls.delta {
        tr * f * ls.li / ls.pdf
    } else {
        let w = power_heuristic(ls.pdf, bsdf.pdf(kd, frame.n, wo, ls.wi));
        tr * f * ls.li * w / ls.pdf
    }
}
