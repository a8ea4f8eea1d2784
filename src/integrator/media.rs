//! Light that a participating medium scatters toward a ray, for the photon-map methods: single
//! scattering ray-marched with light samples (jittered steps, every delta light, one area-light sample
//! per step), multiple scattering read at the same steps from the media radiance cache (`volume_grid`).

use glam::Vec3;
use photon::sampling::Rng;

use super::pm::PmContext;
use super::SampleCounters;
use crate::medium::{phase, Medium, MediumId};

/// Steps per march: one per 1/32 of the scene's diagonal on the way (at least 2) …
const MIN_STEPS: u32 = 2;
/// … at most this many.
const MAX_STEPS: u32 = 32;

/// (single, multiple) scattered radiance reaching the origin `o` of a ray travelling along `d` through
/// medium `m` (id `medium`) over `[0, t_end)`, attenuated on the way back to `o`.
#[allow(clippy::too_many_arguments)]
pub fn in_scattered(ctx: &PmContext, o: Vec3, d: Vec3, t_end: f32, medium: MediumId, m: &Medium, rng: &mut Rng, c: &mut SampleCounters) -> (Vec3, Vec3) {
    let step_len = ctx.scene.diagonal() / 32.0;
    let n = if step_len > 0.0 { ((t_end / step_len).ceil() as u32).clamp(MIN_STEPS, MAX_STEPS) } else { MIN_STEPS };
    let dt = t_end / n as f32;
    let mut single = Vec3::ZERO;
    for i in 0..n {
        let t = (i as f32 + rng.uniform()) * dt;
        let x = o + d * t;
        single += m.transmittance(t) * light_at(ctx, x, d, m.g, medium, rng, c);
    }
    single *= m.sigma_s * dt;
    // Multiple scattering from the media radiance cache, at the same steps (it is smooth and cheap).
    let mut multiple = Vec3::ZERO;
    if ctx.photons.maps.volume.is_some() {
        for i in 0..n {
            let t = (i as f32 + rng.uniform()) * dt;
            multiple += m.transmittance(t) * ctx.photons.cached_multiple(o + d * t, d, m.g);
        }
        multiple *= dt;
    }
    (single, multiple)
}

/// Radiance arriving at `x` straight from the lights, weighted by the phase function toward a ray
/// travelling along `d`: every delta light, and one sample of the area lights.
fn light_at(ctx: &PmContext, x: Vec3, d: Vec3, g: f32, medium: MediumId, rng: &mut Rng, c: &mut SampleCounters) -> Vec3 {
    let scene = ctx.scene;
    let mut l = Vec3::ZERO;
    let mut add = |ls: crate::light::LightSample, c: &mut SampleCounters| {
        if !(ls.pdf > 0.0) {
            return;
        }
        let f = phase(g, d, ls.wi);
        let tr = scene.visibility_from(x, ls.wi, ls.dist, medium, &mut c.shadow_rays);
        l += tr * f * ls.li / ls.pdf;
    };
    for ls in scene.lights.delta_samples(&scene.geometry, x) {
        add(ls, c);
    }
    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
    if let Some(ls) = scene.lights.sample_area(&scene.geometry, x, u) {
        add(ls, c);
    }
    l
}
