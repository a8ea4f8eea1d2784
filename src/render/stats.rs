//! The render's statistics: one typed struct with a part per phase, each part the second half of its
//! phase's `(output, stats)` (threads' counts merged with rayon inside the phase, no shared counter),
//! turned into report rows in one place, [`RenderStats::report`].

use std::time::Instant;

use icache::media::MediaCache;
use icache::{CacheStats, IrradianceCache};

use super::tiles::{GrowStats, SampleCount};
use super::Plan;
use crate::counters::SampleCounters;
use crate::integrator::radiance_cache::{RadianceCache, RadianceCacheStats};
use crate::photons::atlas::AtlasStats;
use crate::photons::PhotonData;
use crate::scene::{Method, Scene};
use crate::stats::{peak_rss_bytes, Report};

/// What a render did, phase by phase.
#[derive(Clone)]
pub struct RenderStats {
    pub setup: Setup,
    /// `trace_photons` (or `load_photons`); `None` for `path`.
    pub photons: Option<PhotonStats>,
    /// `fill_cache` (or a loaded cache); `pm` only.
    pub fill: Option<CacheFillStats>,
    pub shade: ShadeStats,
    /// The irradiance atlas after shading (it fills lazily, in the cache fill and the shading).
    pub atlas: Option<AtlasStats>,
    /// The volume grid's (estimated, all) cells after shading, with media.
    pub volume_grid: Option<(usize, usize)>,
    /// `pm`'s media radiance-cache fill (scenes with media).
    pub media_fill: Option<icache::media::MediaFillStats>,
    /// The media cache's (records, memory bytes).
    pub media_cache: Option<(u64, u64)>,
    /// The cache after shading; records loaded from a file are not counted as made in pass B.
    pub cache: Option<CacheStats>,
    /// Glossy surfaces: the radiance cache and the gather rays' texel harmonics.
    pub glossy: Option<GlossyStats>,
    /// A frame of a sequence: what it reused from the frames before.
    pub frame: Option<FrameStats>,
    /// Seconds from the plan to the end of shading.
    pub total_s: f64,
    /// Set by `write_outputs`.
    pub write_outputs_s: Option<f64>,
    pub peak_rss_bytes: u64,
}

fn frame_rows(r: &mut Report, f: &FrameStats) {
    r.count("Sequence", "Frame", "frame.index", f.frame as u64);
    r.text(
        "Sequence",
        "Photon maps",
        "frame.photons",
        if f.photons_reused { "reused" } else { "traced" },
    );
    if f.image_reused {
        r.text(
            "Sequence",
            "Image",
            "frame.image",
            "the frame before's (nothing changed)",
        );
    }
    r.count(
        "Sequence",
        "Cache records reused from earlier frames",
        "frame.records_reused",
        f.n_records_reused,
    );
    r.count(
        "Sequence",
        "Cache records dropped (too coarse for the view, or long out of it)",
        "frame.records_dropped",
        f.n_records_dropped,
    );
    if f.n_pixels_kept > 0 {
        r.count(
            "Sequence",
            "Pixels kept from the frame before (nothing they show changed)",
            "frame.pixels_kept",
            f.n_pixels_kept,
        );
        r.count(
            "Sequence",
            "Of them relit (only the cached light changed: indirect light scaled)",
            "frame.pixels_relit",
            f.n_pixels_relit,
        );
    }
    if let Some(t) = &f.temporal {
        for (title, key, n) in [
            (
                "Records kept as they were (temporal gradient)",
                "frame.records_kept",
                t.n_kept,
            ),
            (
                "Records gathered again in place (expired or near a change)",
                "frame.records_regathered",
                t.n_regathered,
            ),
            (
                "Records replaced (changed beyond their noise)",
                "frame.records_replaced",
                t.n_replaced,
            ),
            (
                "Records moved with their mesh and replaced by a new gather",
                "frame.records_moved",
                t.n_moved,
            ),
            (
                "Records carried along with their mesh, irradiance kept",
                "frame.records_carried",
                t.n_carried,
            ),
            (
                "Records dropped (their surface moved)",
                "frame.records_gone",
                t.n_gone,
            ),
        ] {
            r.count("Sequence", title, key, n);
        }
        r.seconds(
            "Time",
            "Temporal update of the records",
            "time.temporal_update_s",
            t.update_s,
        );
    }
    r.count(
        "Sequence",
        "Cache records after the frame",
        "frame.records_after",
        f.n_records_after,
    );
}

/// What a frame of a sequence reused.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameStats {
    pub frame: u32,
    /// The photon maps were traced for an earlier frame (nothing that emits or reflects light moved).
    pub photons_reused: bool,
    /// Irradiance-cache records of earlier frames kept for this one.
    pub n_records_reused: u64,
    /// Records of earlier frames dropped as too coarse for this frame's view, or out of view for long.
    pub n_records_dropped: u64,
    /// Records after this frame (reused and made).
    pub n_records_after: u64,
    /// Nothing changed since the frame before: its image is this frame's.
    pub image_reused: bool,
    /// Pixels taken from the frame before, unsampled (nothing they show changed).
    pub n_pixels_kept: u64,
    /// Of the kept pixels, those whose indirect light was scaled to the cached light's change.
    pub n_pixels_relit: u64,
    /// After a mesh or light changed: what the temporal update did to the records.
    pub temporal: Option<TemporalStats>,
}

/// What the update did, for the frame's statistics.
#[derive(Clone, Copy, Debug, Default)]
pub struct TemporalStats {
    /// Records whose irradiance stayed (or followed its temporal gradient).
    pub n_kept: u64,
    /// Records gathered again in place.
    pub n_regathered: u64,
    /// Of those, the ones whose change was beyond their noise: replaced by the new gather.
    pub n_replaced: u64,
    /// Records whose surface moved away.
    pub n_gone: u64,
    /// Of the replaced, those that moved with their mesh.
    pub n_moved: u64,
    /// Records carried along with their mesh that kept their irradiance (not due, or gathered
    /// within their noise): it follows their temporal gradient.
    pub n_carried: u64,
    /// Seconds the update took (its gathers, mostly).
    pub update_s: f64,
}

/// The plan and the scene, as reported.
#[derive(Clone)]
pub struct Setup {
    pub method: Method,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub aa_spp: u32,
    pub noise: f32,
    pub n_triangles: u64,
    pub n_degenerate: u64,
    pub n_lights: u64,
    /// The instruction set Embree's kernels run: renders match across machines that run the same.
    pub ray_isa: &'static str,
}

/// The photon maps, traced or loaded, and the settings they are read with.
#[derive(Clone)]
pub struct PhotonStats {
    /// Seconds to trace the maps, or to load them (`loaded`).
    pub time_s: f64,
    pub loaded: bool,
    pub trace: photon::TraceStats,
    pub lookup: usize,
    pub max_radius_global: f32,
    pub max_radius_caustic: f32,
    /// Zero without media.
    pub max_radius_volume: f32,
}

/// The irradiance atlas's rows.
fn atlas_rows(r: &mut Report, s: &AtlasStats) {
    r.count(
        "Photons",
        "Irradiance atlas texels",
        "photons.atlas_texels",
        s.slots,
    );
    r.count(
        "Photons",
        "Irradiance atlas texels estimated",
        "photons.atlas_estimates",
        s.estimates,
    );
    if s.carried > 0 {
        r.count(
            "Photons",
            "Irradiance atlas texels carried from the frame before",
            "photons.atlas_carried",
            s.carried,
        );
        r.count(
            "Photons",
            "… of them moved by the photons that entered or left their disc",
            "photons.atlas_updated",
            s.updated,
        );
    }
    r.count(
        "Photons",
        "Edge texels (direct light shaded where each ray lands)",
        "photons.atlas_edge_texels",
        s.edges,
    );
    r.count(
        "Photons",
        "Caustic estimates at texel middles (smooth caustics)",
        "photons.caustic_texel_estimates",
        s.caustic_estimates,
    );
    r.bytes(
        "Photons",
        "Memory, irradiance atlas",
        "photons.atlas_memory_bytes",
        s.memory_bytes,
    );
}

/// Pass A, or the cache loaded instead.
#[derive(Clone, Default)]
pub struct CacheFillStats {
    /// Seconds to fill; `None` when the cache was loaded.
    pub time_s: Option<f64>,
    pub one_pass: bool,
    pub fill: icache::FillStats,
    /// The fill's final gathers (their rays).
    pub counters: SampleCounters,
    pub n_loaded: u64,
    /// With rays chosen by `pm` (`render::gather_rays`): the predicted relative variance the pass-A
    /// gathers' noise gives the pixels (at one round), and the rounds chosen.
    pub rays_choice: Option<(f64, u32)>,
}

/// Every pixel's samples.
#[derive(Clone, Default)]
pub struct ShadeStats {
    pub time_s: f64,
    pub counters: SampleCounters,
    pub samples: SampleCount,
    /// Records made between rounds for samples that found none.
    pub grown: GrowStats,
}

impl RenderStats {
    /// What a user should hear about a render that succeeded on legal input but is likely not what
    /// they meant; the binary prints each on stderr.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(p) = self.photons.as_ref().filter(|p| !p.loaded) {
            let t = &p.trace;
            let stored = t.n_global_stored
                + t.n_caustic_stored
                + t.n_volume_stored
                + t.n_volume_caustic_stored;
            if stored == 0 {
                out.push(format!(
                    "no photon was stored after {} paths (no light reaches a surface or medium \
                     where photons are kept: a fog too dense to cross?): what method {} reads from \
                     the photon maps — indirect light, caustics, light scattered in media — is black",
                    t.n_paths_emitted,
                    self.setup.method.name()
                ));
            }
        }
        out
    }

    pub fn new(scene: &Scene, plan: &Plan) -> RenderStats {
        let setup = Setup {
            method: plan.method,
            width: plan.width,
            height: plan.height,
            spp: plan.spp,
            aa_spp: plan.aa_spp,
            noise: plan.noise,
            n_triangles: scene.geometry.triangles.len() as u64,
            n_degenerate: scene.geometry.n_degenerate as u64,
            n_lights: scene.lights.len() as u64,
            ray_isa: scene.bvh.isa(),
        };
        RenderStats {
            setup,
            photons: None,
            fill: None,
            shade: ShadeStats::default(),
            atlas: None,
            volume_grid: None,
            media_fill: None,
            media_cache: None,
            cache: None,
            glossy: None,
            frame: None,
            total_s: 0.0,
            write_outputs_s: None,
            peak_rss_bytes: 0,
        }
    }

    /// What is read once the phases are done: the atlas and the cache as shading left them, the time
    /// since `start`, the peak memory.
    pub fn finish(
        &mut self,
        start: Instant,
        photons: Option<&PhotonData>,
        media_cache: Option<&MediaCache>,
        cache: Option<&IrradianceCache>,
        radiance: Option<&RadianceCache>,
    ) {
        self.atlas = photons.and_then(|p| p.atlas()).map(|a| a.stats());
        let texels = photons.and_then(|p| p.glossy_texel_stats());
        if texels.is_some() || radiance.is_some() {
            self.glossy = Some(GlossyStats {
                radiance: radiance.map(|r| r.stats()).unwrap_or_default(),
                texels: texels.unwrap_or_default(),
            });
        }
        self.volume_grid = photons.and_then(|p| p.volume_grid()).map(|g| g.filled());
        self.media_cache = media_cache.map(|c| (c.len() as u64, c.memory_bytes() as u64));
        let fill = self.fill.as_ref();
        self.cache = cache.map(|c| {
            let mut s = CacheStats::collect(
                c,
                &fill.map(|f| f.fill).unwrap_or_default(),
                &self.shade.counters.lookups,
            );
            let n_loaded = fill.map_or(0, |f| f.n_loaded);
            s.records_pass_b -= n_loaded.min(s.records_pass_b);
            s
        });
        self.total_s = start.elapsed().as_secs_f64();
        self.peak_rss_bytes = peak_rss_bytes();
    }

    /// Counters of every phase that traces rays from the camera's view: the cache fill and the shading.
    fn counters(&self) -> SampleCounters {
        let mut c = self.shade.counters;
        c += self.fill_counters();
        c
    }

    fn fill_counters(&self) -> SampleCounters {
        self.fill.as_ref().map(|f| f.counters).unwrap_or_default()
    }

    /// The report: pbrt-style rows, in the order of the printed table.
    pub fn report(&self) -> Report {
        let mut r = Report::default();
        r.text(
            "Render",
            "Method",
            "render.method",
            self.setup.method.name(),
        );
        if let Some(f) = &self.frame {
            frame_rows(&mut r, f);
        }
        if let Some(p) = &self.photons {
            photon_rows(&mut r, p);
        }
        if let Some(f) = &self.fill {
            if let Some(t) = f.time_s {
                let label = if f.one_pass {
                    "Fill cache (one pass)"
                } else {
                    "Fill cache (pass A)"
                };
                r.seconds("Time", label, "time.fill_cache_s", t);
            }
        }
        if let Some(m) = &self.media_fill {
            r.seconds(
                "Time",
                "Fill media cache (pass A)",
                "time.fill_media_s",
                m.time_s,
            );
        }
        r.seconds("Time", "Shade", "time.shade_s", self.shade.time_s);
        if self.setup.method.uses_photon_maps() {
            self.photon_method_rows(&mut r);
        }
        r.seconds("Time", "Total", "time.total_s", self.total_s);
        self.ray_rows(&mut r);
        self.image_rows(&mut r);
        let c = self.counters();
        r.count(
            "Rare events",
            "NaN or negative radiance",
            "rare.nan_or_negative",
            c.nan_or_negative,
        );
        r.count(
            "Rare events",
            "Zero-pdf samples",
            "rare.zero_pdf",
            c.zero_pdf,
        );
        for (title, key, n) in [
            ("Triangles", "scene.triangles", self.setup.n_triangles),
            (
                "Degenerate triangles dropped",
                "scene.degenerate_triangles",
                self.setup.n_degenerate,
            ),
            ("Lights", "scene.lights", self.setup.n_lights),
        ] {
            r.count("Scene", title, key, n);
        }
        r.text(
            "Scene",
            "Ray kernels (Embree's instruction set)",
            "scene.ray_isa",
            self.setup.ray_isa,
        );
        r.bytes(
            "Memory",
            "Peak resident set",
            "memory.peak_rss_bytes",
            self.peak_rss_bytes,
        );
        if let Some(t) = self.write_outputs_s {
            r.seconds("Time", "Write outputs", "time.write_outputs_s", t);
        }
        r
    }

    /// Atlas, cache, final-gather and k-NN rows of the photon-map methods.
    fn photon_method_rows(&self, r: &mut Report) {
        let (shade, fill) = (&self.shade.counters, self.fill_counters());
        if let Some(s) = &self.atlas {
            atlas_rows(r, s);
        }
        if let Some((estimated, cells)) = self.volume_grid {
            r.count(
                "Photons",
                "Volume grid cells (for final-gather rays)",
                "photons.volume_grid_cells",
                cells as u64,
            );
            r.count(
                "Photons",
                "Volume grid cells estimated",
                "photons.volume_grid_estimates",
                estimated as u64,
            );
        }
        if let (Some(f), Some((records, bytes))) = (&self.media_fill, self.media_cache) {
            media_cache_rows(r, f, records, bytes, shade);
        }
        if let Some(g) = &self.glossy {
            glossy_rows(r, g);
        }
        if let (Some(cs), Some(f)) = (&self.cache, &self.fill) {
            if f.n_loaded > 0 {
                r.count(
                    "Irradiance cache",
                    "Records loaded from file",
                    "icache.records_loaded",
                    f.n_loaded,
                );
            }
            cache_rows(
                r,
                cs,
                &f.fill,
                fill.gather_rays + shade.gather_rays,
                &self.shade,
            );
        }
        self.gather_rows(r, &fill, shade);
        r.count(
            "Rays",
            "Rays while shading (camera, bounce, shadow, pass-B gathers)",
            "rays.shade",
            shade.rays + shade.shadow_rays,
        );
        r.count(
            "Photons",
            "k-NN estimates while rendering (caustic, indirect)",
            "photons.estimates",
            fill.photon_estimates + shade.photon_estimates,
        );
    }

    /// The final gathers' rows: gathers and rays in the fill and the shading, the rays chosen, the
    /// gathers' own noise.
    fn gather_rows(&self, r: &mut Report, fill: &SampleCounters, shade: &SampleCounters) {
        r.count(
            "Final gather",
            "Gathers",
            "gather.gathers",
            fill.gathers + shade.gathers,
        );
        r.count(
            "Final gather",
            "Gather rays",
            "gather.rays",
            fill.gather_rays + shade.gather_rays,
        );
        r.count(
            "Final gather",
            "Gather rays in the cache fill",
            "gather.rays_fill",
            fill.gather_rays,
        );
        if let Some((noise, rounds)) = self.fill.as_ref().and_then(|f| f.rays_choice) {
            let base = crate::render::gather_rays::BASE_RAYS;
            let title = format!(
                "Predicted gather-noise variance at {base} rays (target {:.0e})",
                crate::render::gather_rays::NOISE_TARGET
            );
            r.value(
                "Final gather",
                &title,
                "gather.predicted_noise",
                serde_json::Value::from(noise),
                format!("{noise:.2e}"),
            );
            r.count(
                "Final gather",
                "Rays per gather (chosen from that prediction)",
                "gather.rays_chosen",
                crate::render::gather_rays::rays_for_rounds(rounds) as u64,
            );
        }
        let mut noise = fill.gather_noise;
        noise += shade.gather_noise;
        if let (Some(mean), Some(p50), Some(p90)) =
            (noise.mean(), noise.quantile(0.5), noise.quantile(0.9))
        {
            r.number(
                "Final gather",
                "Gather noise: mean relative std error of E (own rays)",
                "gather.rel_err_mean",
                mean,
            );
            r.number(
                "Final gather",
                "Gather noise: median, at most",
                "gather.rel_err_p50",
                p50 as f64,
            );
            r.number(
                "Final gather",
                "Gather noise: 90th percentile, at most",
                "gather.rel_err_p90",
                p90 as f64,
            );
        }
    }

    /// Rays of the cache fill and the shading; their rate over the time of those two phases (the photon
    /// pass traces its own paths and is reported in its own rows).
    fn ray_rows(&self, r: &mut Report) {
        let c = self.counters();
        let rays = c.rays + c.shadow_rays;
        let seconds = self.shade.time_s + self.fill.as_ref().and_then(|f| f.time_s).unwrap_or(0.0);
        r.count("Rays", "Total", "rays.total", rays);
        r.count("Rays", "Camera and bounce rays", "rays.closest_hit", c.rays);
        r.count("Rays", "Shadow rays", "rays.shadow", c.shadow_rays);
        r.number(
            "Rays",
            "Rays per second",
            "rays.per_s",
            rays as f64 / seconds.max(1e-9),
        );
    }

    fn image_rows(&self, r: &mut Report) {
        let (s, n) = (&self.setup, &self.shade.samples);
        r.count("Image", "Width", "image.width", s.width as u64);
        r.count("Image", "Height", "image.height", s.height as u64);
        r.count(
            "Image",
            "Samples per pixel (most)",
            "image.spp",
            s.spp as u64,
        );
        r.number(
            "Image",
            "Noise target (0: fixed spp)",
            "image.noise",
            s.noise as f64,
        );
        if s.noise > 0.0 {
            r.count(
                "Image",
                "Samples per pixel without Monte Carlo estimates (most)",
                "image.aa_spp",
                s.aa_spp as u64,
            );
            r.count(
                "Image",
                "Monte Carlo pixels (area lights, glass, glossy, media)",
                "image.pixels_monte_carlo",
                n.monte_carlo_pixels,
            );
        }
        r.number(
            "Image",
            "Samples per pixel (mean)",
            "image.spp_mean",
            n.samples as f64 / n.pixels.max(1) as f64,
        );
        r.count(
            "Image",
            "Pixels at the sample limit",
            "image.pixels_at_limit",
            n.at_limit,
        );
        r.count("Image", "Samples", "image.samples", n.samples);
    }
}

fn photon_rows(r: &mut Report, p: &PhotonStats) {
    if p.loaded {
        r.seconds("Time", "Load photons", "time.load_photons_s", p.time_s);
    } else {
        r.seconds("Time", "Trace photons", "time.trace_photons_s", p.time_s);
    }
    let s = &p.trace;
    r.count(
        "Photons",
        "Paths emitted",
        "photons.paths_emitted",
        s.n_paths_emitted,
    );
    if s.n_paths_copied > 0 {
        r.count(
            "Photons",
            "Paths copied from the frame before (nothing that moved met them)",
            "photons.paths_copied",
            s.n_paths_copied,
        );
    }
    r.count(
        "Photons",
        "Global photons stored",
        "photons.global_stored",
        s.n_global_stored,
    );
    r.count(
        "Photons",
        "Caustic photons stored",
        "photons.caustic_stored",
        s.n_caustic_stored,
    );
    r.seconds("Photons", "Trace time", "photons.trace_s", s.trace_s);
    r.seconds(
        "Photons",
        "Build time (kd-trees)",
        "photons.build_s",
        s.global_build_s + s.caustic_build_s + s.volume_build_s,
    );
    r.bytes(
        "Photons",
        "Memory, global map",
        "photons.global_memory_bytes",
        s.global_memory_bytes,
    );
    r.bytes(
        "Photons",
        "Memory, caustic map",
        "photons.caustic_memory_bytes",
        s.caustic_memory_bytes,
    );
    if p.max_radius_volume > 0.0 {
        volume_photon_rows(r, p);
    }
    r.bytes(
        "Photons",
        "Memory",
        "photons.memory_bytes",
        s.global_memory_bytes
            + s.caustic_memory_bytes
            + s.volume_memory_bytes
            + s.volume_caustic_memory_bytes,
    );
    for (title, key, n) in [
        (
            "Paths dropped (non-finite)",
            "rare.photon_paths_dropped",
            s.n_paths_dropped,
        ),
        (
            "Caustic map stopped by its path budget",
            "photons.caustic_cut",
            s.n_caustic_cut,
        ),
        ("Lookup k", "photons.lookup", p.lookup as u64),
    ] {
        r.count("Photons", title, key, n);
    }
    r.number(
        "Photons",
        "Max radius (global)",
        "photons.max_radius_global",
        p.max_radius_global as f64,
    );
    r.number(
        "Photons",
        "Max radius (caustic)",
        "photons.max_radius_caustic",
        p.max_radius_caustic as f64,
    );
}

/// The volume photon maps' rows (scenes with media).
fn volume_photon_rows(r: &mut Report, p: &PhotonStats) {
    let s = &p.trace;
    r.count(
        "Photons",
        "Volume photons stored",
        "photons.volume_stored",
        s.n_volume_stored,
    );
    r.count(
        "Photons",
        "Volume caustic photons stored (L S+ V)",
        "photons.volume_caustic_stored",
        s.n_volume_caustic_stored,
    );
    r.bytes(
        "Photons",
        "Memory, volume caustic map",
        "photons.volume_caustic_memory_bytes",
        s.volume_caustic_memory_bytes,
    );
    r.bytes(
        "Photons",
        "Memory, volume map",
        "photons.volume_memory_bytes",
        s.volume_memory_bytes,
    );
    r.number(
        "Photons",
        "Max radius (volume)",
        "photons.max_radius_volume",
        p.max_radius_volume as f64,
    );
    r.count(
        "Photons",
        "Global or volume map stopped by its path budget",
        "photons.media_cut",
        s.n_media_cut,
    );
}

fn cache_rows(
    r: &mut Report,
    s: &CacheStats,
    fill: &icache::FillStats,
    gather_rays: u64,
    shade: &ShadeStats,
) {
    for (title, key, n) in [
        (
            "Records created in pass A",
            "icache.records_pass_a",
            s.records_pass_a,
        ),
        (
            "Records created in pass B (for missed samples)",
            "icache.records_pass_b",
            s.records_pass_b,
        ),
        (
            "Pass-B rounds that made records",
            "icache.rounds_with_records",
            shade.grown.rounds,
        ),
        (
            "Pass-B samples taken again with the new records",
            "icache.samples_redone",
            shade.samples.redone,
        ),
        (
            "Pass-B pixel rounds taken again",
            "icache.pixel_rounds_redone",
            shade.samples.redone_pixels,
        ),
        ("Lookups", "icache.lookups", s.lookups),
        ("Pass-B lookups", "icache.lookups_pass_b", s.lookups_pass_b),
        (
            "Pass-B misses (no record interpolates)",
            "icache.misses_pass_b",
            s.misses_pass_b,
        ),
        (
            "Pass-B misses extrapolated across normals",
            "icache.extrapolated_pass_b",
            s.extrapolated_pass_b,
        ),
        (
            "Pass-B misses gathered (no record at all)",
            "icache.gathered_pass_b",
            s.gathered_pass_b,
        ),
        (
            "Pass-B lookups from one record",
            "icache.single_record_pass_b",
            s.single_record_pass_b,
        ),
        (
            "Pass-B lookups reused within a pixel",
            "icache.reused_pass_b",
            s.reused_pass_b,
        ),
    ] {
        r.count("Irradiance cache", title, key, n);
    }
    r.number(
        "Irradiance cache",
        "Mean usable records per pass-B lookup",
        "icache.mean_records_per_lookup",
        s.mean_records_per_lookup(),
    );
    r.count(
        "Irradiance cache",
        "Gather rays",
        "icache.gather_rays",
        gather_rays,
    );
    spacing_rows(r, s, fill);
}

/// The irradiance cache's rows on record spacing: radii, what shrank or clamped them, pass A's
/// lattice, and the cache's memory.
fn spacing_rows(r: &mut Report, s: &CacheStats, fill: &icache::FillStats) {
    radius_row(r, "Irradiance cache", "icache.radius_px", &s.radius_px);
    for (title, key, n) in [
        (
            "Shrunk by neighbor clamping",
            "icache.shrunk_by_clamping",
            s.shrunk_by_clamping,
        ),
        (
            "Shrunk by the gradient limit",
            "icache.shrunk_by_gradient",
            s.shrunk_by_gradient,
        ),
        (
            "Shrunk by adaptive caching (halvings)",
            "icache.shrunk_adaptive",
            s.shrunk_adaptive,
        ),
        (
            "Clamped to min spacing",
            "icache.clamped_min",
            s.clamped_min,
        ),
        (
            "Clamped to max spacing",
            "icache.clamped_max",
            s.clamped_max,
        ),
        (
            "Pass-A pixel lattice (every n-th pixel in x and y)",
            "icache.pass_a_stride",
            fill.pass_a_stride as u64,
        ),
        (
            "Pass-A pixels skipped between covered lattice pixels",
            "icache.pass_a_pixels_skipped",
            fill.n_pixels_skipped,
        ),
        ("Pass-A waves", "icache.waves", fill.n_waves),
        (
            "Points left uncovered after pass A",
            "icache.uncovered_after_fill",
            fill.n_uncovered_after,
        ),
    ] {
        r.count("Irradiance cache", title, key, n);
    }
    r.bytes(
        "Irradiance cache",
        "Memory",
        "icache.memory_bytes",
        s.memory_bytes,
    );
}

/// A radius histogram as one row: mean [min–max] shown, the bins in the JSON.
fn radius_row(r: &mut Report, category: &str, key: &str, h: &icache::RadiusHistogram) {
    r.value(
        category,
        "Record radius (px) avg [min–max]",
        key,
        serde_json::json!({"min": h.min_px, "avg": h.mean_px(), "max": h.max_px, "counts": h.counts.to_vec(), "edges": (0..=icache::stats::RADIUS_BINS).map(|i| h.edge(i)).collect::<Vec<_>>()}),
        format!("{:.1} [{:.1}–{:.1}]", h.mean_px(), h.min_px, h.max_px),
    );
}

/// The media radiance cache: pass A's work, pass B's lookups and misses, the radii.
fn media_cache_rows(
    r: &mut Report,
    f: &icache::media::MediaFillStats,
    records: u64,
    bytes: u64,
    shade: &SampleCounters,
) {
    let c = "Media cache";
    r.count(
        c,
        "Records (pass A; pass B makes none)",
        "media.records",
        records,
    );
    r.count(
        c,
        "Pass-A points along camera rays",
        "media.points",
        f.n_points,
    );
    r.count(
        c,
        "Pass-A pixel lattice (every n-th pixel in x and y)",
        "media.lattice_stride",
        f.stride as u64,
    );
    r.count(
        c,
        "Estimates made in pass A",
        "media.estimates",
        f.n_estimates,
    );
    r.count(
        c,
        "Estimates covered by an earlier one of their wave",
        "media.skipped_covered",
        f.n_skipped_covered,
    );
    r.count(
        c,
        "Shrunk by neighbour clamping",
        "media.shrunk_by_clamping",
        f.n_shrunk_by_neighbours,
    );
    r.count(
        c,
        "Repair sweeps",
        "media.repair_sweeps",
        f.n_repair_sweeps as u64,
    );
    r.count(
        c,
        "Points left uncovered after pass A",
        "media.uncovered_after_fill",
        f.n_uncovered_after,
    );
    r.count(c, "Pass-B lookups", "media.lookups", shade.media_lookups);
    r.count(
        c,
        "Pass-B misses (estimated from the volume map)",
        "media.misses",
        shade.media_misses,
    );
    r.percent(
        c,
        "Pass-B miss ratio",
        "media.miss_ratio",
        shade.media_misses as f64 / shade.media_lookups.max(1) as f64,
    );
    radius_row(r, c, "media.radius_px", &f.radius_px);
    r.bytes(c, "Memory", "media.memory_bytes", bytes);
}

/// Glossy surfaces' statistics: the radiance cache's, and the gather rays' texel harmonics
/// ((estimated, bytes)).
#[derive(Clone, Copy, Debug, Default)]
pub struct GlossyStats {
    pub radiance: RadianceCacheStats,
    pub texels: (u64, u64),
}

fn glossy_rows(r: &mut Report, g: &GlossyStats) {
    let c = "Glossy";
    let rc = &g.radiance;
    r.count(c, "Radiance-cache records", "glossy.records", rc.records);
    r.count(
        c,
        "Harmonic bands kept (most of any lobe)",
        "glossy.order",
        rc.max_order as u64,
    );
    r.count(c, "Radiance-cache lookups", "glossy.lookups", rc.lookups);
    r.count(
        c,
        "Lookups without records: lobe sampled",
        "glossy.fallbacks",
        rc.fallbacks,
    );
    r.bytes(
        c,
        "Radiance-cache memory",
        "glossy.memory_bytes",
        rc.memory_bytes,
    );
    r.count(
        c,
        "Glossy texels estimated (gather rays, lobe samples)",
        "glossy.texels",
        g.texels.0,
    );
    r.bytes(
        c,
        "Texel harmonics memory",
        "glossy.texel_memory_bytes",
        g.texels.1,
    );
}
