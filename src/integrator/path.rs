//! Method `path`: unidirectional path tracing with next-event estimation, multiple importance sampling
//! (power heuristic) and Russian roulette. The reference inside our own binary.

use glam::Vec3;
use photon::sampling::Rng;

use crate::counters::SampleCounters;
use crate::geometry::{spawn, Frame, Hit};
use crate::material::Transport;
use crate::medium::{phase, sample_phase, Flight, Medium, MediumId};
use crate::scene::{Scene, MAX_NULL_CROSSINGS};
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
    let mut path = Path {
        l: Vec3::ZERO,
        beta: Vec3::ONE,
        o: origin,
        d: dir,
        medium,
        delta_bounce: true,
        prev_pdf: 0.0,
        prev_p: origin,
        crossings: 0,
        depth: 0,
        t0: 0.0,
        hero: None,
        ratio: Vec3::ONE,
    };
    while path.depth < max_depth {
        c.rays += 1;
        let hit = scene.intersect_after(path.o, path.d, path.t0);
        if let Some(m) = scene.medium(path.medium) {
            if let Some(goes_on) = path.in_medium(scene, m, hit.as_ref(), rng, c) {
                if goes_on {
                    continue;
                }
                break;
            }
        }
        let Some(hit) = hit else { break };
        if !path.at_surface(scene, &hit, rng, c) {
            break;
        }
    }
    path.l
}

/// A path's state between its events.
struct Path {
    /// Radiance gathered so far.
    l: Vec3,
    /// Throughput.
    beta: Vec3,
    /// The ray being followed: origin and direction.
    o: Vec3,
    d: Vec3,
    medium: MediumId,
    /// The last bounce was through a Dirac lobe (or there was none): emission counts fully.
    delta_bounce: bool,
    /// The last bounce's pdf and point, for MIS of the emission the ray hits.
    prev_pdf: f32,
    prev_p: Vec3,
    /// Null boundaries crossed along the current ray (since the last scattering or bounce): a ray
    /// trapped by a pathological mesh ends, a path through many thin boundaries does not.
    crossings: u32,
    depth: u32,
    /// Past invisible boundaries the ray goes on along the same line: `t0` is how far it has come.
    t0: f32,
    /// Spectral MIS in media (see `Flight`): the channel that samples distances, drawn at the first
    /// medium met, and each channel's path pdf over the hero's (scaled to mean 1); `beta` is already
    /// divided by their mean.
    hero: Option<usize>,
    ratio: Vec3,
}

impl Path {
    /// The flight through medium `m` toward `hit`: `Some(goes on)` when the path scattered in the
    /// medium, `None` when it passed through to the surface.
    fn in_medium(
        &mut self,
        scene: &Scene,
        m: &Medium,
        hit: Option<&Hit>,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Option<bool> {
        let h = *self
            .hero
            .get_or_insert_with(|| ((rng.uniform() * 3.0) as usize).min(2));
        let (o, d, t0) = (self.o, self.d, self.t0);
        match m.sample_flight(hit.map_or(f32::INFINITY, |h| h.t - t0), h, rng.uniform()) {
            Flight::Scatter {
                t,
                weight,
                ratio: r,
            } => {
                (self.beta, self.ratio) = spectral_mis(self.beta, self.ratio, weight, r);
                let p = o + d * (t0 + t);
                self.l += self.beta * medium_direct(scene, m.g, p, d, self.medium, rng, c);
                let (wi, pdf) = sample_phase(m.g, d, [rng.uniform(), rng.uniform()]);
                (self.delta_bounce, self.prev_pdf, self.prev_p) = (false, pdf, p);
                if !roulette(self.depth, &mut self.beta, rng) {
                    return Some(false);
                }
                (self.o, self.d, self.t0, self.crossings) = (p, wi, 0.0, 0);
                self.depth += 1;
                Some(true)
            }
            Flight::Through { weight, ratio: r } => {
                (self.beta, self.ratio) = spectral_mis(self.beta, self.ratio, weight, r);
                None
            }
        }
    }

    /// The events at a surface `hit`: a null boundary crossed, or emission, direct light and the next
    /// bounce. False when the path ends.
    fn at_surface(
        &mut self,
        scene: &Scene,
        hit: &Hit,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> bool {
        let d = self.d;
        let bsdf = &scene.bsdf(hit);
        if bsdf.is_null() {
            self.crossings += 1;
            if self.crossings > MAX_NULL_CROSSINGS {
                scene.give_up_crossings();
                return false;
            }
            (self.medium, self.t0) = scene.cross(self.o, d, hit.tri, hit.t, self.medium);
            return true;
        }
        let wo = -d;
        let le = scene.emitted(hit, wo);
        if le != Vec3::ZERO {
            let w = if self.delta_bounce {
                1.0
            } else {
                power_heuristic(
                    self.prev_pdf,
                    scene.lights.pdf_hit(hit.tri, self.prev_p, hit.p),
                )
            };
            self.l += self.beta * le * w;
        }
        let frame = scene.frame(hit, wo);
        let kd = scene.albedo(hit);
        if !bsdf.is_specular() {
            self.l += self.beta * direct_light(scene, hit, &frame, wo, kd, self.medium, rng, c);
        }
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        let Some(s) = bsdf.sample(kd, frame.n, wo, frame.front, u, Transport::Radiance) else {
            c.zero_pdf += 1;
            return false;
        };
        if !s.delta && !frame.same_side(s.wi) {
            return false;
        }
        self.beta *= s.weight;
        if self.beta == Vec3::ZERO {
            return false;
        }
        self.delta_bounce = s.delta;
        self.prev_pdf = s.pdf;
        self.prev_p = hit.p;
        if !roulette(self.depth, &mut self.beta, rng) {
            return false;
        }
        self.medium = scene.medium_after(hit, s.wi, self.medium);
        self.o = spawn(hit, s.wi);
        self.d = s.wi;
        self.t0 = 0.0;
        self.crossings = 0;
        self.depth += 1;
        true
    }
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
    let bsdf = &scene.bsdf(hit);
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
