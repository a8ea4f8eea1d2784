//! Light that a participating medium scatters toward a ray, for the photon-map methods: single
//! scattering from point and spot lights by equiangular sampling about each, from directional and area
//! lights by jittered steps (one area-light sample per step); multiple scattering read at those steps
//! from the media radiance cache (`media_cache`).

use glam::Vec3;
use photon::sampling::Rng;

use icache::media::MediaCache;

use crate::counters::SampleCounters;
use crate::light::{Light, LightSample};
use crate::medium::{phase, Medium, MediumId};
use crate::photons::PhotonData;
use crate::scene::Scene;

/// What the light scattered toward a ray is estimated from: the scene's lights, the photon maps and,
/// for `pm`, the media radiance cache.
#[derive(Clone, Copy)]
pub struct Sources<'a> {
    pub scene: &'a Scene,
    pub photons: &'a PhotonData<'a>,
    pub media_cache: Option<&'a MediaCache>,
}

/// Steps per march: one per 1/32 of the scene's diagonal on the way (at least 2) …
const MIN_STEPS: u32 = 2;
/// … at most this many.
const MAX_STEPS: u32 = 32;
/// Steps per estimate of multiple scattering without a media cache.
const UNCACHED_STRIDE: u32 = 4;

/// (single, multiple) scattered radiance reaching the origin `o` of a ray travelling along `d` through
/// medium `m` (id `medium`) over `[0, t_end)`, attenuated on the way back to `o`.
#[allow(clippy::too_many_arguments)]
pub fn in_scattered(
    ctx: &Sources,
    o: Vec3,
    d: Vec3,
    t_end: f32,
    medium: MediumId,
    m: &Medium,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> (Vec3, Vec3) {
    c.monte_carlo += 1;
    let step_len = ctx.scene.diagonal() / 32.0;
    let n = if step_len > 0.0 {
        ((t_end / step_len).ceil() as u32).clamp(MIN_STEPS, MAX_STEPS)
    } else {
        MIN_STEPS
    };
    let dt = t_end / n as f32;
    let scene = ctx.scene;
    let mut single = Vec3::ZERO;
    // Lights with a position: equiangular sampling about each (Kulla & Fajardo 2012), stratified over
    // n samples: the 1/d² of a point light seen from a ray passing near it is what made uniform steps
    // heavy-tailed (and adaptive sampling's stopping rule then biased the mean, +1.4 % in a fogged room).
    for (i, light) in scene.lights.lights.iter().enumerate() {
        let pos = match *light {
            Light::Point { pos, .. } | Light::Spot { pos, .. } => pos,
            _ => continue,
        };
        let delta = (pos - o).dot(d);
        let h = (pos - (o + d * delta)).length();
        if !(h > 1e-6 * t_end) {
            continue; // the light sits on the ray: steps below
        }
        let (a, b) = ((-delta / h).atan(), ((t_end - delta) / h).atan());
        let mut sum = Vec3::ZERO;
        for k in 0..n {
            let theta = a + (k as f32 + rng.uniform()) / n as f32 * (b - a);
            let t = (delta + h * theta.tan()).clamp(0.0, t_end);
            let pdf = h / ((b - a) * (h * h + (t - delta) * (t - delta)));
            if let Some(ls) = scene.lights.delta_sample(i, &scene.geometry, o + d * t) {
                sum += m.transmittance(t) * arriving(ctx, o + d * t, d, m.g, medium, &ls, c) / pdf;
            }
        }
        single += sum / n as f32;
    }
    // Directional lights, lights on the ray's line and area lights: jittered steps.
    let mut stepped = Vec3::ZERO;
    for k in 0..n {
        let t = (k as f32 + rng.uniform()) * dt;
        let x = o + d * t;
        stepped += m.transmittance(t) * light_at(ctx, x, d, m.g, medium, o, t_end, rng, c);
    }
    single = (single + stepped * dt) * m.sigma_s;
    // Multiple scattering from the media radiance cache, at the same steps (it is smooth and cheap), and
    // the volume caustic from its own map at full resolution.
    let mut multiple = Vec3::ZERO;
    if ctx.photons.maps().volume.is_some() {
        for i in 0..n {
            let t = (i as f32 + rng.uniform()) * dt;
            let x = o + d * t;
            multiple += m.transmittance(t) * ctx.photons.volume_caustic_radiance(x, d, m.g, c);
        }
        // Without a media cache (`pm-fg`, `photons`) each step is a k-NN estimate of the volume map:
        // at every UNCACHED_STRIDE-th step only (jittered over the ray), four times fewer for little
        // more noise — the multiple scattering is smooth.
        let (m_steps, m_dt) = if ctx.media_cache.is_some() {
            (n, dt)
        } else {
            let k = n.div_ceil(UNCACHED_STRIDE);
            (k, t_end / k as f32)
        };
        for i in 0..m_steps {
            let t = (i as f32 + rng.uniform()) * m_dt;
            multiple += m.transmittance(t)
                * ctx
                    .photons
                    .cached_multiple(ctx.media_cache, o + d * t, d, m.g, c)
                * (m_dt / dt);
        }
        multiple *= dt;
    }
    (single, multiple)
}

/// Radiance arriving at `x` straight from the lights that [`in_scattered`] steps through (directional
/// lights, delta lights on the ray's line, one area-light sample), weighted by the phase function
/// toward a ray from `o` travelling along `d` for `t_end`.
#[allow(clippy::too_many_arguments)]
fn light_at(
    ctx: &Sources,
    x: Vec3,
    d: Vec3,
    g: f32,
    medium: MediumId,
    o: Vec3,
    t_end: f32,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> Vec3 {
    let scene = ctx.scene;
    let mut l = Vec3::ZERO;
    for (i, light) in scene.lights.lights.iter().enumerate() {
        let stepped = match *light {
            Light::Directional { .. } => true,
            Light::Point { pos, .. } | Light::Spot { pos, .. } => {
                let delta = (pos - o).dot(d);
                !((pos - (o + d * delta)).length() > 1e-6 * t_end)
            }
            Light::Area { .. } => false,
        };
        if let Some(ls) = stepped
            .then(|| scene.lights.delta_sample(i, &scene.geometry, x))
            .flatten()
        {
            l += arriving(ctx, x, d, g, medium, &ls, c);
        }
    }
    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
    if let Some(ls) = scene.lights.sample_area(&scene.geometry, x, u) {
        l += arriving(ctx, x, d, g, medium, &ls, c);
    }
    l
}

/// One light sample's radiance at `x` (transmittance to the light included) times the phase function.
fn arriving(
    ctx: &Sources,
    x: Vec3,
    d: Vec3,
    g: f32,
    medium: MediumId,
    ls: &LightSample,
    c: &mut SampleCounters,
) -> Vec3 {
    if !(ls.pdf > 0.0) {
        return Vec3::ZERO;
    }
    let tr = ctx
        .scene
        .visibility_from(x, ls.wi, ls.dist, medium, &mut c.shadow_rays);
    tr * phase(g, d, ls.wi) * ls.li / ls.pdf
}
