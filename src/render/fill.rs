//! The `fill_cache` phase of `pm` (pass A): the irradiance cache filled so that every shading point of
//! the image is covered — in hierarchical order by default, or in Ward's scanline order
//! (`[render.icache] fill = "one-pass"`) — or a cache file loaded instead.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use icache::media::{MediaCache, MediaFillStats, MediaPoint};
use icache::{IrradianceCache, OnePassFill, ShadingPoint};

use super::stats::CacheFillStats;
use super::Plan;
use super::{files, gather_rays};
use crate::error::{runtime, Result};
use crate::geometry::Hit;
use crate::integrator::cache_fill::{gather_record, shading_hits};
use crate::integrator::pm::{IndirectSource, OtherViews, PmContext};
use crate::integrator::radiance_cache::RadianceCache;
use crate::photons::media_fill;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::{FillMode, Scene};

/// A filled (or loaded) cache.
pub struct CacheFill {
    pub cache: IrradianceCache,
    /// With the one-pass fill: the records each pixel may see.
    pub one_pass: Option<OnePassFill>,
    /// Rays per final gather of pass B when pass A chose them (see [`gather_rays`]).
    pub chosen_rays: Option<usize>,
}

/// What the fill's gathers read: the photon maps, the media cache, and the radiance cache they add to.
#[derive(Clone, Copy)]
pub struct FillLight<'a> {
    pub photons: &'a PhotonData<'a>,
    pub media_cache: Option<&'a MediaCache>,
    pub radiance: Option<&'a RadianceCache>,
}

/// Each pixel's shading points are traced once, with their hits, and a gather starts from the hit it is
/// given. `earlier`: the records of earlier frames of a sequence, frozen, and how many of them were
/// made for other views (read only where in sight, see [`PmContext::fill_may_use`]); `only`: the pixels pass A
/// visits (a sequence's frame where the camera stayed and a mesh moved there). `cancel` is read before every
/// chunk of pixels (two-pass) or row (one-pass), and by every gather ray.
pub fn fill_cache(
    scene: &Scene,
    plan: &Plan,
    light: FillLight,
    earlier: Option<(IrradianceCache, OtherViews<'_>)>,
    only: Option<super::tiles::Window>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(CacheFill, CacheFillStats)> {
    let t = Instant::now();
    let radiance = light.radiance;
    let foreign = earlier.as_ref().map_or(OtherViews::default(), |(_, v)| *v);
    let ctx = fill_context(scene, plan, light, foreign, cancel);
    let (lo, hi) = scene.bounds;
    // Records of earlier frames cover what they cover; pass A adds records only where they do not.
    let mut cache = match earlier {
        Some((c, _)) => c,
        None => IrradianceCache::new(lo, hi, plan.cache).map_err(runtime)?,
    };
    cache.set_validation(plan.cache_validation);
    // Outside `only` the earlier records already cover what the camera sees, which has not changed.
    let points = |x: u32, y: u32| match only {
        Some(w) if !(x >= w.x0 && x < w.x1 && y >= w.y0 && y < w.y1) => Vec::new(),
        _ => shading_hits(&ctx, &plan.camera, x, y),
    };
    let gather = |x, y, i, sp: &ShadingPoint, hit: &Hit| gather_record(&ctx, x, y, i, sp, hit);
    let visible =
        |sp: &ShadingPoint, hit: &Hit, id, rec: &_| ctx.fill_may_use(hit, sp.normal, id, rec);
    let report_progress = |done, _| progress.set(done);
    let (w, h) = (plan.width, plan.height);
    progress.start("cache", w as u64 * h as u64);
    let mut rays_choice = None;
    let (fill, counters, one_pass) = match scene.settings.icache.fill {
        FillMode::TwoPass => {
            let (fill, mut counters) = icache::fill_pass_a_cancellable(
                &mut cache,
                w,
                h,
                if plan.pass_a_gaps_only {
                    icache::PassAPixels::LatticeThenGaps
                } else {
                    icache::PassAPixels::Stride(plan.pass_a_stride)
                },
                &points,
                &gather,
                &visible,
                &report_progress,
                cancel,
            );
            cache.end_stage();
            if plan.choose_rays {
                let (choice, refined) = choose_rays(&ctx, plan, &mut cache, progress, cancel);
                if let Some(c) = refined {
                    counters += c;
                }
                rays_choice = Some(choice);
            }
            (fill, counters, None)
        }
        FillMode::OnePass => {
            let (fill, counters, order) = icache::fill_one_pass_cancellable(
                &mut cache,
                w,
                h,
                &points,
                &gather,
                &report_progress,
                cancel,
            );
            (fill, counters, Some(order))
        }
    };
    progress.finish();
    if let Some(r) = radiance {
        r.attach(&cache);
    }
    Ok(filled(cache, one_pass, (fill, counters), rays_choice, t))
}

/// The filled cache with its one-pass order and the rays chosen, and the fill's statistics (begun at
/// `start`).
fn filled(
    cache: IrradianceCache,
    one_pass: Option<OnePassFill>,
    (fill, counters): (icache::FillStats, crate::counters::SampleCounters),
    rays_choice: Option<(f64, u32)>,
    start: Instant,
) -> (CacheFill, CacheFillStats) {
    let stats = CacheFillStats {
        time_s: Some(start.elapsed().as_secs_f64()),
        one_pass: one_pass.is_some(),
        fill,
        counters,
        n_loaded: 0,
        rays_choice,
    };
    let chosen_rays = rays_choice.map(|(_, rounds)| gather_rays::rays_for_rounds(rounds));
    (
        CacheFill {
            cache,
            one_pass,
            chosen_rays,
        },
        stats,
    )
}

/// The integrator pass A's gathers run: reading the photon maps, the media cache and the glossy
/// radiance cache of `light`, the cache's `foreign` records made for other views.
pub(crate) fn fill_context<'a>(
    scene: &'a Scene,
    plan: &Plan,
    light: FillLight<'a>,
    foreign: OtherViews<'a>,
    cancel: &'a AtomicBool,
) -> PmContext<'a> {
    PmContext {
        radiance: light.radiance,
        foreign,
        ..plan.pm_context(
            scene,
            light.photons,
            light.media_cache,
            IndirectSource::PhotonMap,
            cancel,
        )
    }
}

/// The rays `pm`'s gathers take, chosen after pass A ([`gather_rays`]): the noise its records
/// predict at the base rays and the rounds that make it (the records gathering the further rounds
/// now), with those rounds' counters.
fn choose_rays(
    ctx: &PmContext,
    plan: &Plan,
    cache: &mut IrradianceCache,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> ((f64, u32), Option<crate::counters::SampleCounters>) {
    let noise = gather_rays::predicted_noise(ctx, &plan.camera, cache, plan.width, plan.height);
    let rounds = gather_rays::rounds_for(noise);
    let refined = (rounds > 1)
        .then(|| gather_rays::refine_records(ctx, &plan.camera, cache, rounds, progress, cancel));
    ((noise, rounds), refined)
}

/// A `--save-cache` file of the same scene, instead of `fill_cache` (pass B only).
pub fn load_cache(scene: &Scene, plan: &Plan, path: &Path) -> Result<(CacheFill, CacheFillStats)> {
    let cache = files::load_cache(path, files::cache_fingerprint(scene, plan.method))?;
    let stats = CacheFillStats {
        n_loaded: cache.len() as u64,
        ..Default::default()
    };
    Ok((
        CacheFill {
            cache,
            one_pass: None,
            chosen_rays: None,
        },
        stats,
    ))
}

/// `pm`'s pass A in participating media (scenes with a volume photon map): the media radiance cache
/// filled at the points where the camera rays of a pixel lattice cross a medium (none without media or
/// a volume map).
pub fn fill_media_cache(
    scene: &Scene,
    plan: &Plan,
    photons: &PhotonData,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> (Option<MediaCache>, MediaFillStats) {
    let (Some(media), Some(_)) = (&scene.media, &photons.maps().volume) else {
        return (None, MediaFillStats::default());
    };
    let (lo, hi) = media.bounds();
    let mut cache = MediaCache::new(lo, hi, scene.settings.icache.media_gradients());
    let stride = media_fill::lattice_stride(plan.width, plan.height);
    let points = media_fill::media_points(scene, &plan.camera, plan.width, plan.height, stride);
    progress.start("media cache", points.len() as u64);
    let estimate = |p: &MediaPoint| media_fill::media_record(scene, photons, p, stride);
    let stats = icache::media::fill_media(
        &mut cache,
        &points,
        &estimate,
        &|done, _| progress.set(done),
        cancel,
    );
    progress.finish();
    (Some(cache), MediaFillStats { stride, ..stats })
}
