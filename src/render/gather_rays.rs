//! How many rays `pm`'s final gathers take, from what the gathers of the scene see.
//!
//! Pass A gathers with [`BASE_RAYS`]. Its records then say how noisy they are (each gather's own
//! estimate of its relative standard error, `gather::GatherResult::rel_err`), and the cache says how
//! they are blended: at a lattice of pixels, the interpolation's noise from the records' noise
//! ([`icache::IrradianceCache::lookup_with_noise`]) is turned into the pixel's radiance next to the
//! direct light there, and into the relative error the image metric and the adaptive sampling use,
//! Var / (L² + 0.01). Its mean over the image, [`predicted_noise`], falls as 1/N with the rays N. In an
//! image darker than [`DARK_MEAN`] the floor 0.01 shrinks with the image's brightness squared: an
//! absolute floor would call a dark scene's records calm whatever their relative noise, though the
//! image is as blotchy as a bright one's would be (a small spot-lit patch lighting a dark room: 10–30 %
//! per record, the image mean +1 % at 250 rays).
//! Where it exceeds [`NOISE_TARGET`], every pass-A record gathers again ([`refine_records`]) —
//! another [`BASE_RAYS`] at a time, each stratum's next point of a scrambled Sobol sequence (so that the
//! rounds together stratify like one finer grid), folded into the record — and pass B's records gather
//! with as many rays. The choice is made once for the whole image, from thousands of records: no record's
//! ray count depends on its own noise (which would bias it: a gather that missed a small bright source
//! looks calm).

use std::sync::atomic::{AtomicBool, Ordering};

use icache::record::NO_PIXEL;
use icache::{IrradianceCache, NewRecord, Pass, Record, ShadingPoint};
use photon::sampling::hash_keys;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::counters::SampleCounters;
use crate::geometry::Hit;
use crate::integrator::cache_fill::{gather_record_round, shading_hits};
use crate::integrator::pm::PmContext;
use crate::photons::atlas::direct_irradiance;
use crate::progress::Progress;
use crate::warp::luminance;

/// Rays of a pass-A gather, and of each further round of [`refine_records`].
pub const BASE_RAYS: usize = 250;
/// Most rounds of [`BASE_RAYS`] a gather takes (1000 rays).
pub const MAX_ROUNDS: u32 = 4;
/// Largest mean relative variance ([`predicted_noise`]) the records' gather noise may add to a pixel:
/// (0.04 / 4)², a sixteenth of what the default noise target leaves of the samples' own (the records'
/// noise lies in blotches over many pixels, which more samples do not average). Chosen from the shipped
/// and benchmark scenes: it separates those where more rays paid from those where [`BASE_RAYS`] were
/// as good.
pub const NOISE_TARGET: f64 = 1e-4;
/// Most pixels [`predicted_noise`] looks at.
const NOISE_PIXELS: u32 = 4096;
/// Floor of the squared radiance in [`predicted_noise`]'s relative variance, as in the relMSE.
const REL_FLOOR: f64 = pmbase::REL_MSE_FLOOR;
/// Mean radiance (luminance over the lattice) below which the floor scales with the image's brightness
/// squared, so that the choice no longer depends on the lights' scale. Of the shipped and test scenes,
/// only two spot-lit fog scenes (their light is mostly in the fog) fall a little below, and keep their
/// choice; a dark room lit through a spot's patch (mean 0.018) goes from 250 rays to 1000.
const DARK_MEAN: f64 = 0.05;

/// The mean over a lattice of pixels of Var / (L² + floor): the variance of a pixel's radiance L (as
/// luminance) that the records' gather noise gives the interpolation, next to the direct light there
/// (the floor: 0.01, less in a dark image, see [`DARK_MEAN`]). Pixels that see no surface, or no
/// record, add 0.
pub fn predicted_noise(
    ctx: &PmContext,
    camera: &Camera,
    cache: &IrradianceCache,
    width: u32,
    height: u32,
) -> f64 {
    let step = ((width as f64 * height as f64 / NOISE_PIXELS as f64)
        .sqrt()
        .ceil() as u32)
        .max(1);
    let pixels: Vec<(u32, u32)> = (0..height)
        .step_by(step as usize)
        .flat_map(|y| (0..width).step_by(step as usize).map(move |x| (x, y)))
        .collect();
    // Each pixel's (L, Var L); summed in pixel order: the same total whatever the thread count.
    let parts: Vec<(f64, f64)> = pixels
        .par_iter()
        .map(|&(x, y)| pixel_variance(ctx, camera, cache, x, y).unwrap_or((0.0, 0.0)))
        .collect();
    let n = pixels.len().max(1) as f64;
    let mean = parts.iter().map(|p| p.0).sum::<f64>() / n;
    let floor = REL_FLOOR * (mean / DARK_MEAN).min(1.0).powi(2);
    let terms = parts.iter().map(|&(l, var)| {
        let term = var / (l * l + floor);
        if term.is_finite() {
            term
        } else {
            0.0
        }
    });
    terms.sum::<f64>() / n
}

/// Pixel (x, y)'s radiance L (luminance: direct light and the cache's irradiance on its first diffuse
/// surface) and the variance the records' gather noise gives it; `None` where it sees no surface or no
/// record.
fn pixel_variance(
    ctx: &PmContext,
    camera: &Camera,
    cache: &IrradianceCache,
    x: u32,
    y: u32,
) -> Option<(f64, f64)> {
    let (sp, hit) = shading_hits(ctx, camera, x, y).into_iter().next()?;
    let (lookup, sd) = cache.lookup_with_noise(sp.pos, sp.normal, Pass::B)?;
    let albedo_pi = ctx.scene.albedo(&hit) / std::f32::consts::PI;
    let seed = hash_keys(&[ctx.seed, 0x6a75, x as u64, y as u64]);
    let direct = direct_irradiance(ctx.scene, hit.tri, hit.p, sp.normal, seed, true, true);
    let l = luminance(albedo_pi * (direct + lookup.e)) as f64;
    let e = luminance(lookup.e);
    let sd_l = if e > 0.0 {
        (sd * luminance(albedo_pi * lookup.e) / e) as f64
    } else {
        0.0
    };
    let var = sd_l * sd_l;
    (l.is_finite() && var.is_finite()).then_some((l, var))
}

/// Rounds of [`BASE_RAYS`] that bring `noise` (measured with one round) within [`NOISE_TARGET`], at most
/// [`MAX_ROUNDS`].
pub fn rounds_for(noise: f64) -> u32 {
    let wanted = (noise / NOISE_TARGET).ceil();
    if wanted.is_finite() {
        (wanted as u32).clamp(1, MAX_ROUNDS)
    } else {
        MAX_ROUNDS
    }
}

/// Records gathered again per batch: progress and Ctrl-C are looked at between batches.
const REFINE_BATCH: usize = 2048;

/// Rays per gather after `rounds` rounds of [`BASE_RAYS`].
pub fn rays_for_rounds(rounds: u32) -> usize {
    rounds as usize * BASE_RAYS
}

/// Rounds 2..=`rounds` for every record of `cache` that knows its pixel (pass A's): a gather of
/// [`BASE_RAYS`] there with that round's jitter, folded in with the share of the rays it brings.
/// Returns early, leaving records half refined, once `cancel` is set (the render is then interrupted).
pub fn refine_records(
    ctx: &PmContext,
    camera: &Camera,
    cache: &mut IrradianceCache,
    rounds: u32,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> SampleCounters {
    // Each record's shading point, traced again once for all its rounds.
    let points: Vec<Option<Point>> = cache
        .records()
        .par_iter()
        .map(|rec| shading_point(ctx, camera, rec))
        .collect();
    let mut total = SampleCounters::default();
    progress.start(
        "gathers again",
        points.len() as u64 * rounds.saturating_sub(1) as u64,
    );
    let mut done = 0u64;
    for round in 2..=rounds {
        for (batch, chunk) in points.chunks(REFINE_BATCH).enumerate() {
            if cancel.load(Ordering::Relaxed) {
                return total;
            }
            let more: Vec<Option<(NewRecord, SampleCounters)>> = chunk
                .par_iter()
                .map(|point| {
                    point.as_ref().map(|(at, sp, hit)| {
                        gather_record_round(ctx, at[0], at[1], at[2] as usize, round - 1, sp, hit)
                    })
                })
                .collect();
            for (k, (new, c)) in more
                .into_iter()
                .enumerate()
                .filter_map(|(k, m)| m.map(|m| (k, m)))
            {
                cache.refine(batch * REFINE_BATCH + k, &new, 1.0 / round as f32);
                total += c;
            }
            done += chunk.len() as u64;
            progress.set(done);
        }
    }
    total
}

/// A record's pixel and shading point, with the hit its gathers start from.
type Point = ([u32; 3], ShadingPoint, Hit);

/// The shading point that made `rec`, traced again: `None` for a record that does not know its pixel,
/// or whose point is not found there again.
fn shading_point(ctx: &PmContext, camera: &Camera, rec: &Record) -> Option<Point> {
    if rec.at == NO_PIXEL {
        return None;
    }
    let [x, y, i] = rec.at;
    let (sp, hit) = shading_hits(ctx, camera, x, y)
        .into_iter()
        .nth(i as usize)?;
    (sp.pos == rec.pos).then_some((rec.at, sp, hit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_grow_with_the_noise_and_stop_at_the_most() {
        assert_eq!(rounds_for(0.0), 1);
        assert_eq!(rounds_for(NOISE_TARGET), 1);
        assert_eq!(rounds_for(1.5 * NOISE_TARGET), 2);
        assert_eq!(rounds_for(100.0 * NOISE_TARGET), MAX_ROUNDS);
        assert_eq!(rounds_for(f64::NAN), MAX_ROUNDS);
    }
}
