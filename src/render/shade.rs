//! The `shade` phase (pass B of `pm`): every pixel's samples in parallel tiles ([`render_tiles`]),
//! each sample by the method's closure — `path`'s radiance, or the photon-map methods' terms of Jensen's
//! split with soft indirect light from the cache, a final gather or the global map.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use glam::Vec3;
use photon::sampling::Rng;

use super::fill::CacheFill;
use super::stats::ShadeStats;
use super::tiles::{render_tiles, SampleFn};
use super::{Plan, Progress};
use crate::camera::Camera;
use crate::error::Result;
use crate::integrator::photons::PhotonData;
use crate::integrator::pm::{IndirectSource, PmContext};
use crate::integrator::terms::term_names;
use crate::integrator::{path, PixelMemo, SampleCounters};
use crate::io::output::Image;
use crate::scene::{Method, Scene};

/// `n_layers` images of the plan's window, by `sample`. `cancel` is read before every sample.
pub fn shade(plan: &Plan, n_layers: usize, sample: &SampleFn, progress: &dyn Progress, cancel: &AtomicBool) -> Result<(Vec<Image>, ShadeStats)> {
    let t = Instant::now();
    progress.start("shade", plan.window.n_pixels());
    let (layers, counters, samples) = render_tiles(plan.width, plan.height, plan.window, plan.sampling(), plan.seed, n_layers, sample, &|n| progress.set(n), cancel)?;
    progress.finish();
    Ok((layers, ShadeStats { time_s: t.elapsed().as_secs_f64(), counters, samples }))
}

/// The method's per-sample closure and its number of layers: `path`'s radiance without photon maps;
/// with them, the terms of the split, soft indirect light read from `cache` when there is one.
pub fn sampler<'a>(scene: &'a Scene, plan: &'a Plan, photons: Option<&'a PhotonData<'a>>, cache: Option<&'a CacheFill>, cancel: &'a AtomicBool) -> (Box<SampleFn<'a>>, usize) {
    let Some(photons) = photons else { return (path_sample(scene, &plan.camera), 1) };
    let source = match (cache, plan.method) {
        (Some(c), _) => IndirectSource::Cache(&c.cache),
        (None, Method::PmFg) => IndirectSource::Gather,
        _ => IndirectSource::PhotonMap,
    };
    let ctx = plan.pm_context(scene, photons, source, cancel);
    (pm_sample(ctx, &plan.camera, cache.and_then(|c| c.one_pass.as_ref())), term_names(scene.media.is_some()).len())
}

fn path_sample<'a>(scene: &'a Scene, camera: &'a Camera) -> Box<SampleFn<'a>> {
    let max_depth = scene.settings.max_depth;
    Box::new(move |x: u32, y: u32, off: [f32; 2], _: &mut PixelMemo, rng: &mut Rng, c: &mut SampleCounters| -> Vec<Vec3> {
        let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
        vec![path::radiance(scene, camera.eye, d, scene.camera_medium(), max_depth, rng, c)]
    })
}

/// With a one-pass cache, each pixel sees only the records made before the fill reached it.
fn pm_sample<'a>(ctx: PmContext<'a>, camera: &'a Camera, one_pass: Option<&'a icache::OnePassFill>) -> Box<SampleFn<'a>> {
    let media = ctx.scene.media.is_some();
    Box::new(move |x: u32, y: u32, off: [f32; 2], memo: &mut PixelMemo, rng: &mut Rng, c: &mut SampleCounters| -> Vec<Vec3> {
        let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
        let terms = match (one_pass, &ctx.source) {
            (Some(order), IndirectSource::Cache(cache)) => {
                let seen = IndirectSource::CacheUpTo(cache, order.visible_records(x, y));
                PmContext { source: seen, ..ctx }.shade(camera.eye, d, Some(memo), rng, c)
            }
            _ => ctx.shade(camera.eye, d, Some(memo), rng, c),
        };
        terms.to_layers(media)
    })
}

/// The beauty and the named layers: `path`'s one image is the beauty; the photon-map methods' beauty
/// is the sum of their terms.
pub fn beauty(plan: &Plan, media: bool, mut layers: Vec<Image>) -> (Image, Vec<(&'static str, Image)>) {
    if !plan.method.uses_photon_maps() {
        return (layers.remove(0), Vec::new());
    }
    let mut beauty = Image::new(plan.width, plan.height);
    for l in &layers {
        for (b, v) in beauty.pixels.iter_mut().zip(&l.pixels) {
            *b += *v;
        }
    }
    (beauty, term_names(media).iter().copied().zip(layers).collect())
}
