//! The occlusion methods' phases: `ao`'s pass A (the irradiance cache filled with occlusion records,
//! in the hierarchical order of `pm`'s two-pass fill) and both methods' samplers — `ao` reading the
//! cache and growing it between rounds where samples find no record, as `pm` does, `ao-direct`
//! gathering at every sample.

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use icache::{IrradianceCache, ShadingPoint};
use photon::sampling::Rng;

use super::fill::CacheFill;
use super::shade::CacheRounds;
use super::stats::CacheFillStats;
use super::tiles::{GrowStats, MissedSample, SamplePoint, Sampler};
use super::Plan;
use crate::counters::SampleCounters;
use crate::error::{runtime, Result};
use crate::geometry::Hit;
use crate::integrator::occlusion::{Occlusion, OcclusionSource};
use crate::integrator::terms::LayerValues;
use crate::integrator::PixelMemo;
use crate::progress::Progress;
use crate::scene::Scene;

/// The occlusion integrator of the plan, reading from `source`.
pub fn occlusion<'a>(
    scene: &'a Scene,
    plan: &Plan,
    source: OcclusionSource<'a>,
    cancel: &'a AtomicBool,
) -> Occlusion<'a> {
    Occlusion {
        scene,
        distance: scene.ao_distance(),
        gather: plan.gather,
        seed: plan.seed,
        source,
        defer_misses: false,
        cancel,
    }
}

/// `ao`'s pass A: records gathered until every pixel's shading points are covered (the pixels of
/// the plan's pass-A stride; pass B covers the rest between its rounds).
pub fn fill_occlusion_cache(
    scene: &Scene,
    plan: &Plan,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(CacheFill, CacheFillStats)> {
    let t = Instant::now();
    let ao = occlusion(scene, plan, OcclusionSource::Gather, cancel);
    let (lo, hi) = scene.bounds;
    let mut cache = IrradianceCache::new(lo, hi, plan.cache).map_err(runtime)?;
    cache.set_validation(plan.cache_validation);
    let points = |x: u32, y: u32| ao.shading_hits(&plan.camera, x, y, plan.pass_a_shift);
    let gather = |x, y, i, sp: &ShadingPoint, hit: &Hit| ao.record((x, y, i), 0, sp, hit);
    let visible = |_: &ShadingPoint, _: &Hit, _, _: &icache::Record| true;
    progress.start("cache", plan.width as u64 * plan.height as u64);
    let (fill, counters) = icache::fill_pass_a_cancellable(
        &mut cache,
        plan.width,
        plan.height,
        icache::PassAPixels::Stride(plan.pass_a_stride),
        &points,
        &gather,
        &visible,
        &|done, _| progress.set(done),
        cancel,
    );
    cache.end_stage();
    progress.finish();
    let stats = CacheFillStats {
        time_s: Some(t.elapsed().as_secs_f64()),
        one_pass: false,
        fill,
        counters,
        n_loaded: 0,
        rays_choice: None,
    };
    let fill = CacheFill {
        cache,
        one_pass: None,
        chosen_rays: None,
    };
    Ok((fill, stats))
}

/// The sampler of `ao` (over its cache) or `ao-direct` (without one).
pub fn sampler<'a>(
    scene: &'a Scene,
    plan: &'a Plan,
    cache: Option<&'a mut CacheFill>,
    cancel: &'a AtomicBool,
) -> Box<dyn Sampler + 'a> {
    let ao = occlusion(scene, plan, OcclusionSource::Gather, cancel);
    match cache {
        Some(fill) => Box::new(CachedOcclusion {
            ao,
            rounds: CacheRounds::new(plan, fill),
        }),
        None => Box::new(
            move |x: u32,
                  y: u32,
                  at: SamplePoint,
                  _: &mut PixelMemo,
                  rng: &mut Rng,
                  c: &mut SampleCounters|
                  -> LayerValues { ao.sample(&plan.camera, (x, y), at.offset, rng, c) },
        ),
    }
}

/// `ao` reading its cache, which grows between rounds where samples found no record, as `pm`'s does
/// ([`CacheRounds`]).
struct CachedOcclusion<'a> {
    ao: Occlusion<'a>,
    rounds: CacheRounds<'a>,
}

impl Sampler for CachedOcclusion<'_> {
    fn sample(
        &self,
        x: u32,
        y: u32,
        at: SamplePoint,
        _: &mut PixelMemo,
        rng: &mut Rng,
        c: &mut SampleCounters,
        defer_misses: bool,
    ) -> LayerValues {
        let ao = Occlusion {
            source: OcclusionSource::CacheUpTo(&self.rounds.fill.cache, self.rounds.view),
            defer_misses,
            ..self.ao
        };
        ao.sample(&self.rounds.plan.camera, (x, y), at.offset, rng, c)
    }

    fn adds_records(&self) -> bool {
        true
    }

    fn end_round(&mut self, missed: &[MissedSample]) -> Result<()> {
        let (ao, camera) = (self.ao, &self.rounds.plan.camera);
        let points = |x, y, offsets: &[[f32; 2]]| ao.sample_hits(camera, x, y, offsets);
        let gather = |x, y, i, sp: &ShadingPoint, hit: &Hit| ao.record((x, y, i), 0, sp, hit);
        let visible = |_: &ShadingPoint, _: &Hit, _, _: &icache::Record| true;
        self.rounds
            .end_round(ao.cancel, missed, &points, &gather, &visible);
        Ok(())
    }

    fn grown(&self) -> GrowStats {
        self.rounds.grown
    }
}
