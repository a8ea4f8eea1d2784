//! The phases of the photon-map methods: `trace_photons` (maps and their kd-trees),
//! `fill_cache` (pass A, `pm` only) and `shade` (pass B), each timed and reported.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use glam::Vec3;
use gather::GatherParams;
use icache::{CacheStats, FillStats, IrradianceCache};
use photon::sampling::Rng;
use photon::PrecomputedIrradiance;

use super::tiles::render_tiles;
use super::files::{load_cache, load_photons, PhotonOutput};
use super::{Options, Plan, Progress, RenderOutput};
use crate::camera::Camera;
use crate::geometry::Hit;
use crate::error::{runtime, Error, Result};
use crate::integrator::cache_fill::{gather_record, shading_hits};
use crate::integrator::photons::{PhotonData, PhotonSettings};
use crate::integrator::pm::{IndirectSource, PmContext};
use crate::integrator::terms::{Terms, TERM_NAMES};
use crate::integrator::SampleCounters;
use crate::scene::{FillMode, Method, Scene};
use crate::stats::Report;

pub struct PmRun {
    pub output: RenderOutput,
    pub counters: SampleCounters,
    pub samples: super::tiles::SampleCount,
    pub report: Report,
}

pub fn render_pm(scene: &Scene, plan: &Plan, opts: &Options, camera: &Camera, progress: &dyn Progress, cancel: &AtomicBool) -> Result<PmRun> {
    let mut report = Report::default();
    let settings = PhotonSettings::resolve(scene);
    let icache = &scene.settings.icache;
    let (cache_params, rays, fill_mode) = (icache.for_image(plan.width, plan.height), icache.rays, icache.fill);

    let (maps, precomputed, info) = photon_maps(scene, plan, &settings, opts, progress, cancel, &mut report)?;
    let photons = PhotonData::new(maps, precomputed, settings, scene);

    let mut ctx = PmContext {
        scene,
        photons: &photons,
        source: IndirectSource::PhotonMap,
        gather: GatherParams { rays },
        max_depth: scene.settings.max_depth,
        seed: plan.seed,
        cancel,
    };
    let mut cache = None;
    let mut n_loaded = 0u64;
    let mut fill = FillStats::default();
    let mut one_pass: Option<icache::OnePassFill> = None;
    let mut fc = SampleCounters::default();
    if let (Method::Pm, Some(path)) = (plan.method, &opts.files.load_cache) {
        let c = load_cache(path, scene.fingerprint)?;
        n_loaded = c.len() as u64;
        cache = Some(c);
    } else if plan.method == Method::Pm {
        let t = Instant::now();
        let (lo, hi) = scene.bounds;
        let mut c = IrradianceCache::new(lo, hi, cache_params).map_err(runtime)?;
        progress.start("cache", plan.width as u64 * plan.height as u64);
        let points = |x, y| shading_hits(&ctx, camera, x, y);
        let gather = |x, y, i, sp: &icache::ShadingPoint, hit: &Hit| gather_record(&ctx, x, y, i, sp, hit);
        let report_progress = |done, _| progress.set(done);
        match fill_mode {
            FillMode::TwoPass => (fill, fc) = icache::fill_pass_a_cancellable(&mut c, plan.width, plan.height, &points, &gather, &report_progress, cancel),
            FillMode::OnePass => {
                let (f, counters, order) = icache::fill_one_pass_cancellable(&mut c, plan.width, plan.height, &points, &gather, &report_progress, cancel);
                (fill, fc) = (f, counters);
                one_pass = Some(order);
            }
        }
        progress.finish();
        let label = if fill_mode == FillMode::OnePass { "Fill cache (one pass)" } else { "Fill cache (pass A)" };
        report.seconds("Time", label, "time.fill_cache_s", t.elapsed().as_secs_f64());
        cache = Some(c);
    }
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::Interrupted);
    }
    ctx.source = match (&cache, plan.method) {
        (Some(c), _) => IndirectSource::Cache(c),
        (None, Method::PmFg) => IndirectSource::Gather,
        _ => IndirectSource::PhotonMap,
    };

    let t = Instant::now();
    let sample = |x: u32, y: u32, off: [f32; 2], memo: &mut crate::integrator::PixelMemo, rng: &mut Rng, c: &mut SampleCounters| -> Vec<Vec3> {
        let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
        let terms: Terms = match (&one_pass, &ctx.source) {
            (Some(order), IndirectSource::Cache(cache)) => {
                let seen = IndirectSource::CacheUpTo(cache, order.visible_records(x, y));
                PmContext { source: seen, ..ctx }.shade(camera.eye, d, Some(memo), rng, c)
            }
            _ => ctx.shade(camera.eye, d, Some(memo), rng, c),
        };
        terms.to_layers()
    };
    progress.start("shade", plan.window.n_pixels());
    let (layers, counters, samples) = render_tiles(plan.width, plan.height, plan.window, plan.sampling(), plan.seed, TERM_NAMES.len(), &sample, &|n| progress.set(n), cancel)?;
    progress.finish();
    report.seconds("Time", "Shade", "time.shade_s", t.elapsed().as_secs_f64());

    if let Some(atlas) = &photons.atlas {
        let s = atlas.stats();
        report.count("Photons", "Irradiance atlas texels", "photons.atlas_texels", s.slots);
        report.count("Photons", "Irradiance atlas texels estimated", "photons.atlas_estimates", s.estimates);
        report.bytes("Photons", "Memory, irradiance atlas", "photons.atlas_memory_bytes", s.memory_bytes);
    }
    if let Some(c) = &cache {
        let mut cs = CacheStats::collect(c, &fill, &counters.lookups);
        cs.records_pass_b -= n_loaded.min(cs.records_pass_b);
        if n_loaded > 0 {
            report.count("Irradiance cache", "Records loaded from file", "icache.records_loaded", n_loaded);
        }
        cache_rows(&mut report, &cs, &fill, fc.gather_rays + counters.gather_rays);
    }
    report.count("Final gather", "Gathers", "gather.gathers", fc.gathers + counters.gathers);
    report.count("Final gather", "Gather rays", "gather.rays", fc.gather_rays + counters.gather_rays);
    report.count("Final gather", "Gather rays in the cache fill", "gather.rays_fill", fc.gather_rays);
    report.count("Rays", "Rays while shading (camera, bounce, shadow, pass-B gathers)", "rays.shade", counters.rays + counters.shadow_rays);
    report.count("Photons", "k-NN estimates while rendering (caustic, indirect)", "photons.estimates", fc.photon_estimates + counters.photon_estimates);
    let mut counters = counters;
    counters += fc;
    let mut beauty = crate::io::output::Image::new(plan.width, plan.height);
    for l in &layers {
        for (b, v) in beauty.pixels.iter_mut().zip(&l.pixels) {
            *b += *v;
        }
    }
    let layers = TERM_NAMES.iter().copied().zip(layers).collect();
    let photons = info.map(|info| PhotonOutput { info, maps: photons.maps, precomputed: photons.precomputed });
    Ok(PmRun { output: RenderOutput { beauty, layers, cache, photons }, counters, samples, report })
}

type Maps = (photon::PhotonMaps, Option<PrecomputedIrradiance>, Option<photon::MapsInfo>);

/// `trace_photons` and `build_maps`, or a photon file loaded instead. The `MapsInfo` is there when the
/// maps were traced and `--save-photons` or `--dump-photons` asks for them (written with the outputs).
fn photon_maps(scene: &Scene, plan: &Plan, settings: &PhotonSettings, opts: &Options, progress: &dyn Progress, cancel: &AtomicBool, report: &mut Report) -> Result<Maps> {
    if let Some(path) = &opts.files.load_photons {
        let t = Instant::now();
        let loaded = load_photons(path, scene.fingerprint)?;
        // Precomputed points in files of earlier versions are kept for --save-photons; the render reads
        // the atlas.
        let pre = loaded.precomputed;
        report.seconds("Time", "Load photons", "time.load_photons_s", t.elapsed().as_secs_f64());
        let stats = photon::TraceStats {
            n_paths_emitted: loaded.info.n_paths_emitted,
            n_global_stored: loaded.maps.global.as_ref().map_or(0, |m| m.len() as u64),
            n_caustic_stored: loaded.maps.caustic.as_ref().map_or(0, |m| m.len() as u64),
            global_memory_bytes: loaded.maps.global.as_ref().map_or(0, |m| m.memory_bytes() as u64),
            caustic_memory_bytes: loaded.maps.caustic.as_ref().map_or(0, |m| m.memory_bytes() as u64),
            ..Default::default()
        };
        photon_rows(report, &stats, settings, pre.as_ref());
        return Ok((loaded.maps, pre, None));
    }
    let t = Instant::now();
    progress.start("photons", (settings.global + settings.caustic) as u64);
    let (maps, trace_stats) = PhotonData::trace(scene, settings, plan.seed, &|done, _| progress.set(done), cancel)?;
    progress.finish();
    report.seconds("Time", "Trace photons", "time.trace_photons_s", t.elapsed().as_secs_f64());
    // The maps' kd-trees are built by the photon pass; the irradiance atlas fills during the cache fill.
    let precomputed = None;
    photon_rows(report, &trace_stats, settings, None);
    let keep = opts.files.save_photons.is_some() || opts.files.dump_photons.is_some();
    let info = keep.then(|| photon::MapsInfo::new(scene.fingerprint, plan.seed, PhotonData::targets(settings), &trace_stats));
    Ok((maps, precomputed, info))
}

fn photon_rows(r: &mut Report, s: &photon::TraceStats, settings: &PhotonSettings, pre: Option<&PrecomputedIrradiance>) {
    r.count("Photons", "Paths emitted", "photons.paths_emitted", s.n_paths_emitted);
    r.count("Photons", "Global photons stored", "photons.global_stored", s.n_global_stored);
    r.count("Photons", "Caustic photons stored", "photons.caustic_stored", s.n_caustic_stored);
    r.seconds("Photons", "Trace time", "photons.trace_s", s.trace_s);
    r.seconds("Photons", "Build time (kd-trees)", "photons.build_s", s.global_build_s + s.caustic_build_s);
    r.bytes("Photons", "Memory, global map", "photons.global_memory_bytes", s.global_memory_bytes);
    r.bytes("Photons", "Memory, caustic map", "photons.caustic_memory_bytes", s.caustic_memory_bytes);
    r.bytes("Photons", "Memory", "photons.memory_bytes", s.global_memory_bytes + s.caustic_memory_bytes + pre.map(|p| p.memory_bytes() as u64).unwrap_or(0));
    r.count("Photons", "Paths dropped (non-finite)", "rare.photon_paths_dropped", s.n_paths_dropped);
    r.count("Photons", "Caustic map stopped by its path budget", "photons.caustic_cut", s.n_caustic_cut);
    r.count("Photons", "Lookup k", "photons.lookup", settings.lookup as u64);
    r.number("Photons", "Max radius (global)", "photons.max_radius_global", settings.max_radius_global as f64);
    r.number("Photons", "Max radius (caustic)", "photons.max_radius_caustic", settings.max_radius_caustic as f64);
    if let Some(p) = pre {
        r.count("Photons", "Precomputed irradiance points", "photons.precomputed", p.points().len() as u64);
    }
}

fn cache_rows(r: &mut Report, s: &CacheStats, fill: &FillStats, gather_rays: u64) {
    r.count("Irradiance cache", "Records created in pass A", "icache.records_pass_a", s.records_pass_a);
    r.count("Irradiance cache", "Records created in pass B", "icache.records_pass_b", s.records_pass_b);
    r.count("Irradiance cache", "Lookups", "icache.lookups", s.lookups);
    r.count("Irradiance cache", "Pass-B lookups", "icache.lookups_pass_b", s.lookups_pass_b);
    r.count("Irradiance cache", "Pass-B misses (no record interpolates)", "icache.misses_pass_b", s.misses_pass_b);
    r.count("Irradiance cache", "Pass-B misses extrapolated across normals", "icache.extrapolated_pass_b", s.extrapolated_pass_b);
    r.count("Irradiance cache", "Pass-B misses gathered (no record at all)", "icache.gathered_pass_b", s.gathered_pass_b);
    r.count("Irradiance cache", "Pass-B lookups from one record", "icache.single_record_pass_b", s.single_record_pass_b);
    r.count("Irradiance cache", "Pass-B lookups reused within a pixel", "icache.reused_pass_b", s.reused_pass_b);
    r.number("Irradiance cache", "Mean usable records per lookup", "icache.mean_records_per_lookup", s.mean_records_per_lookup());
    r.count("Irradiance cache", "Gather rays", "icache.gather_rays", gather_rays);
    let h = &s.radius_px;
    r.value(
        "Irradiance cache",
        "Record radius (px) avg [min–max]",
        "icache.radius_px",
        serde_json::json!({"min": h.min_px, "avg": h.mean_px(), "max": h.max_px, "counts": h.counts.to_vec(), "edges": (0..=icache::stats::RADIUS_BINS).map(|i| h.edge(i)).collect::<Vec<_>>()}),
        format!("{:.1} [{:.1}–{:.1}]", h.mean_px(), h.min_px, h.max_px),
    );
    r.count("Irradiance cache", "Shrunk by neighbor clamping", "icache.shrunk_by_clamping", s.shrunk_by_clamping);
    r.count("Irradiance cache", "Shrunk by the gradient limit", "icache.shrunk_by_gradient", s.shrunk_by_gradient);
    r.count("Irradiance cache", "Clamped to min spacing", "icache.clamped_min", s.clamped_min);
    r.count("Irradiance cache", "Clamped to max spacing", "icache.clamped_max", s.clamped_max);
    r.count("Irradiance cache", "Pass-A waves", "icache.waves", fill.n_waves);
    r.count("Irradiance cache", "Points left uncovered after pass A", "icache.uncovered_after_fill", fill.n_uncovered_after);
    r.bytes("Irradiance cache", "Memory", "icache.memory_bytes", s.memory_bytes);
}
