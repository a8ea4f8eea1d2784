//! The `shade` phase (pass B of `pm`): every pixel's samples in parallel tiles ([`render_tiles`]),
//! each sample by the method's closure — `path`'s radiance, or the photon-map methods' terms of Jensen's
//! split with soft indirect light from the cache, a final gather or the global map.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use photon::sampling::Rng;

use super::fill::CacheFill;
use super::stats::ShadeStats;
use super::tiles::{render_tiles, Canvas, GrowStats, MissedSample, SamplePoint, Sampler};
use super::Plan;
use crate::camera::Camera;
use crate::counters::SampleCounters;
use crate::error::Result;
use crate::geometry::Hit;
use crate::integrator::cache_fill::{gather_record, sample_hits};
use crate::integrator::pm::{IndirectSource, OtherViews, PmContext};
use crate::integrator::radiance_cache::RadianceCache;
use crate::integrator::terms::{LayerValues, Layout};
use crate::integrator::{path, PixelMemo};
use crate::io::output::Image;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::{Method, Scene};
use gather::GatherParams;
use icache::media::MediaCache;
use icache::{IrradianceCache, ShadingPoint};

/// Pixels a sequence's frame takes from the frame before rather than shading them anew (none in a
/// still): see [`Canvas`]'s fields of the same names.
#[derive(Clone, Copy)]
pub struct KeptPixels<'a> {
    pub kept: Option<&'a [bool]>,
    pub kept_samples: Option<&'a [u32]>,
    pub repeat: Option<&'a [bool]>,
}

impl KeptPixels<'_> {
    /// Every pixel shaded anew.
    pub const NONE: KeptPixels<'static> = KeptPixels {
        kept: None,
        kept_samples: None,
        repeat: None,
    };
}

/// `n_layers` images of the plan's window but the pixels `kept` marks, by `sampler`, and the samples
/// each pixel took (row-major, 0 where it took none). `cancel` is read before every sample.
pub fn shade(
    plan: &Plan,
    kept: KeptPixels,
    n_layers: usize,
    sampler: &mut dyn Sampler,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Vec<Image>, ShadeStats, Vec<u32>)> {
    let t = Instant::now();
    progress.start("shade", plan.window.n_pixels());
    let canvas = Canvas {
        width: plan.width,
        height: plan.height,
        window: plan.window,
        sampling: plan.sampling(),
        seed: plan.seed,
        n_layers,
        kept: kept.kept,
        kept_samples: kept.kept_samples,
        repeat: kept.repeat,
    };
    let (layers, mut counters, samples, per_pixel) =
        render_tiles(&canvas, sampler, &|n| progress.set(n), cancel)?;
    progress.finish();
    // The gathers of records made between rounds are rays of the shading.
    let grown = sampler.grown();
    counters += grown.counters.work();
    Ok((
        layers,
        ShadeStats {
            time_s: t.elapsed().as_secs_f64(),
            counters,
            samples,
            grown,
        },
        per_pixel,
    ))
}

/// What shading reads from the phases before it.
pub struct Lighting<'a> {
    /// The photon maps (none for `path`).
    pub photons: Option<&'a PhotonData<'a>>,
    /// `pm`'s media radiance cache.
    pub media_cache: Option<&'a MediaCache>,
    /// `pm`'s irradiance cache.
    pub cache: Option<&'a mut CacheFill>,
    /// Rays per final gather: pass A's choice when it made one, else the plan's.
    pub gather: GatherParams,
    /// `pm`'s radiance cache on glossy surfaces.
    pub radiance: Option<&'a RadianceCache>,
    /// The cache's records made for other views (see [`PmContext::foreign`]).
    pub foreign: OtherViews<'a>,
}

/// The method's sampler and its number of layers: `path`'s radiance without photon maps; with them,
/// the terms of the split, soft indirect light read from the irradiance cache when there is one (which
/// grows between rounds where samples find no record, except a one-pass cache).
pub fn sampler<'a>(
    scene: &'a Scene,
    plan: &'a Plan,
    lighting: Lighting<'a>,
    cancel: &'a AtomicBool,
) -> (Box<dyn Sampler + 'a>, usize) {
    if plan.method.is_occlusion() {
        return (
            super::occlusion::sampler(scene, plan, lighting.cache, cancel),
            1,
        );
    }
    let Some(photons) = lighting.photons else {
        return (path_sample(scene, &plan.camera), 1);
    };
    let n_layers = Layout::of(scene).count();
    let ctx = PmContext {
        gather: lighting.gather,
        radiance: lighting.radiance,
        foreign: lighting.foreign,
        ..plan.pm_context(
            scene,
            photons,
            lighting.media_cache,
            IndirectSource::PhotonMap,
            cancel,
        )
    };
    match lighting.cache {
        Some(fill) if fill.one_pass.is_none() => {
            (Box::new(GrowingCache::new(ctx, plan, fill)), n_layers)
        }
        Some(fill) => {
            let fill: &'a CacheFill = fill;
            (
                pm_sample(
                    ctx,
                    &plan.camera,
                    fill.one_pass.as_ref().map(|order| (&fill.cache, order)),
                ),
                n_layers,
            )
        }
        None => {
            let source = if plan.method == Method::PmFg {
                IndirectSource::Gather
            } else {
                IndirectSource::PhotonMap
            };
            (
                pm_sample(PmContext { source, ..ctx }, &plan.camera, None),
                n_layers,
            )
        }
    }
}

/// `pm` reading its (two-pass) cache: each sample looks records up; between rounds, the samples that
/// found none get records of their own, made as pass A makes them (see [`render_tiles`] and
/// [`CacheRounds`]).
struct GrowingCache<'a> {
    /// Everything but the cache, which `sample` lends it.
    ctx: PmContext<'a>,
    rounds: CacheRounds<'a>,
}

impl<'a> GrowingCache<'a> {
    fn new(ctx: PmContext<'a>, plan: &'a Plan, fill: &'a mut CacheFill) -> Self {
        GrowingCache {
            ctx,
            rounds: CacheRounds::new(plan, fill),
        }
    }
}

impl Sampler for GrowingCache<'_> {
    fn sample(
        &self,
        x: u32,
        y: u32,
        at: SamplePoint,
        memo: &mut PixelMemo,
        rng: &mut Rng,
        c: &mut SampleCounters,
        defer_misses: bool,
    ) -> LayerValues {
        let r = &self.rounds;
        let ctx = PmContext {
            source: IndirectSource::CacheUpTo(&r.fill.cache, r.view),
            defer_misses,
            ..self.ctx
        };
        camera_sample(&ctx, &r.plan.camera, x, y, at, memo, rng, c)
    }

    fn adds_records(&self) -> bool {
        true
    }

    fn end_round(&mut self, missed: &[MissedSample]) -> Result<()> {
        let (ctx, camera) = (self.ctx, &self.rounds.plan.camera);
        let points = |x, y, offsets: &[[f32; 2]]| sample_hits(&ctx, camera, x, y, offsets);
        let gather = |x, y, i, sp: &ShadingPoint, hit: &Hit| gather_record(&ctx, x, y, i, sp, hit);
        let visible = |sp: &ShadingPoint, hit: &Hit, id, rec: &icache::Record| {
            ctx.fill_may_use(hit, sp.normal, id, rec)
        };
        self.rounds
            .end_round(ctx.cancel, missed, &points, &gather, &visible);
        Ok(())
    }

    fn grown(&self) -> GrowStats {
        self.rounds.grown
    }
}

/// The camera rays of a pixel's samples at some offsets within it, and their shading points.
pub(crate) type SampleHitsFn<'a> =
    dyn Fn(u32, u32, &[[f32; 2]]) -> Vec<(ShadingPoint, Hit)> + Sync + 'a;
/// The gather at shading point `i` of pixel (x, y), as a record.
pub(crate) type RecordFn<'a> =
    dyn Fn(u32, u32, usize, &ShadingPoint, &Hit) -> (icache::NewRecord, SampleCounters) + Sync + 'a;

/// A cache read by pass B's rounds (`pm`'s or `ao`'s): each round reads the records of the stages
/// before it ([`icache::IrradianceCache::stages`]). With a cache read from a file, the stages it holds
/// are replayed (the rounds read what they read when it was made, so a crop equals the same pixels of
/// the full render); past them, the samples that found no record get records of their own between
/// rounds, made as pass A makes them.
pub(crate) struct CacheRounds<'a> {
    pub plan: &'a Plan,
    pub fill: &'a mut CacheFill,
    pub grown: GrowStats,
    /// Records the current round reads, and the index of the round just ended (from 1).
    pub view: usize,
    round: usize,
}

impl<'a> CacheRounds<'a> {
    pub(crate) fn new(plan: &'a Plan, fill: &'a mut CacheFill) -> CacheRounds<'a> {
        if fill.cache.stages().is_empty() {
            fill.cache.end_stage();
        }
        let view = fill.cache.stages()[0] as usize;
        CacheRounds {
            plan,
            fill,
            grown: GrowStats::default(),
            view,
            round: 0,
        }
    }

    /// After a round: the file's next stage, or records for `missed` (see [`Self::grow`]); the next
    /// round reads them.
    pub(crate) fn end_round(
        &mut self,
        cancel: &AtomicBool,
        missed: &[MissedSample],
        points: &SampleHitsFn,
        gather: &RecordFn,
        visible: &icache::VisibleFn<Hit>,
    ) {
        self.round += 1;
        if let Some(&n) = self.fill.cache.stages().get(self.round) {
            // A stage of the file's render: its records, made from that render's misses.
            self.view = n as usize;
            return;
        }
        let grown = self.grow(cancel, missed, points, gather, visible);
        self.grown.rounds += grown.rounds;
        self.grown.fill += grown.fill;
        self.grown.counters += grown.counters;
        self.view = self.fill.cache.len();
    }

    fn grow(
        &mut self,
        cancel: &AtomicBool,
        missed: &[MissedSample],
        points: &SampleHitsFn,
        gather: &RecordFn,
        visible: &icache::VisibleFn<Hit>,
    ) -> GrowStats {
        let mut grown = GrowStats::default();
        if !missed.is_empty() {
            let pixels: Vec<(u32, u32)> = missed
                .chunk_by(|a, b| (a.x, a.y) == (b.x, b.y))
                .map(|m| (m[0].x, m[0].y))
                .collect();
            let pixel_points = |x: u32, y: u32| {
                let from = missed.partition_point(|m| (m.y, m.x) < (y, x));
                let offsets: Vec<[f32; 2]> = missed[from..]
                    .iter()
                    .take_while(|m| (m.x, m.y) == (x, y))
                    .map(|m| m.offset)
                    .collect();
                points(x, y, &offsets)
            };
            // Seeds apart from pass A's gathers at the same pixel, and from other rounds'.
            let first = self.round << 16;
            let round_gather =
                |x, y, i, sp: &ShadingPoint, hit: &Hit| gather(x, y, first + i, sp, hit);
            let (fill, counters) = icache::fill_pixels_cancellable(
                &mut self.fill.cache,
                self.plan.width,
                self.plan.height,
                &pixels,
                &pixel_points,
                &round_gather,
                visible,
                cancel,
            );
            grown.rounds += (fill.insert.n_inserted > 0) as u64;
            grown.fill += fill;
            grown.counters += counters;
        }
        self.fill.cache.end_stage();
        grown
    }
}

fn path_sample<'a>(scene: &'a Scene, camera: &'a Camera) -> Box<dyn Sampler + 'a> {
    let max_depth = scene.settings.max_depth;
    Box::new(
        move |x: u32,
              y: u32,
              at: SamplePoint,
              _: &mut PixelMemo,
              rng: &mut Rng,
              c: &mut SampleCounters|
              -> LayerValues {
            let d = camera.ray(x as f32 + at.offset[0], y as f32 + at.offset[1]);
            LayerValues::one(path::radiance(
                scene,
                camera.eye,
                d,
                scene.camera_medium(),
                max_depth,
                rng,
                c,
            ))
        },
    )
}

/// With a one-pass cache, each pixel sees only the records made before the fill reached it.
fn pm_sample<'a>(
    ctx: PmContext<'a>,
    camera: &'a Camera,
    one_pass: Option<(&'a IrradianceCache, &'a icache::OnePassFill)>,
) -> Box<dyn Sampler + 'a> {
    Box::new(
        move |x: u32,
              y: u32,
              at: SamplePoint,
              memo: &mut PixelMemo,
              rng: &mut Rng,
              c: &mut SampleCounters|
              -> LayerValues {
            let ctx = match one_pass {
                Some((cache, order)) => PmContext {
                    source: IndirectSource::CacheUpTo(cache, order.visible_records(x, y)),
                    ..ctx
                },
                None => ctx,
            };
            camera_sample(&ctx, camera, x, y, at, memo, rng, c)
        },
    )
}

/// One camera sample of the photon-map methods: the terms of the split along the ray through (x, y) +
/// `at.offset`, its first glossy lobe and area-light samples at `at.points`.
#[allow(clippy::too_many_arguments)]
fn camera_sample(
    ctx: &PmContext,
    camera: &Camera,
    x: u32,
    y: u32,
    at: SamplePoint,
    memo: &mut PixelMemo,
    rng: &mut Rng,
    c: &mut SampleCounters,
) -> LayerValues {
    let d = camera.ray(x as f32 + at.offset[0], y as f32 + at.offset[1]);
    ctx.shade(camera.eye, d, at.points, Some(memo), rng, c)
        .to_layers(Layout::of(ctx.scene))
}

/// The beauty and the named layers: `path`'s one image is the beauty; the photon-map methods' beauty
/// is the sum of their terms.
pub fn beauty(
    plan: &Plan,
    layout: Layout,
    mut layers: Vec<Image>,
) -> (Image, Vec<(&'static str, Image)>) {
    if !plan.method.uses_photon_maps() {
        return (layers.remove(0), Vec::new());
    }
    let mut beauty = Image::new(plan.width, plan.height);
    for l in &layers {
        for (b, v) in beauty.pixels.iter_mut().zip(&l.pixels) {
            *b += *v;
        }
    }
    (beauty, layout.names().into_iter().zip(layers).collect())
}
