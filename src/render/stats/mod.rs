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

mod cache_rows;
mod photon_rows;
mod report;

use cache_rows::*;
use photon_rows::*;

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
    /// A progressive render's passes (`--passes`, `--time`).
    pub progressive: Option<ProgressiveStats>,
    /// Seconds from the plan to the end of shading.
    pub total_s: f64,
    /// Set by `write_outputs`.
    pub write_outputs_s: Option<f64>,
    pub peak_rss_bytes: u64,
    /// Rays given up after [`crate::scene::MAX_NULL_CROSSINGS`] medium-boundary crossings during
    /// the render (the scene's count at its start, until `finish`).
    pub crossings_given_up: u64,
}

/// What a frame of a sequence reused.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameStats {
    pub frame: u32,
    /// The photon maps were traced for an earlier frame (nothing that emits or reflects light moved).
    pub photons_reused: bool,
    /// The method reads no photon maps (`path`, `ao`, `ao-direct`): none were traced or reused.
    pub no_photon_maps: bool,
    /// Irradiance-cache records of earlier frames kept for this one.
    pub n_records_reused: u64,
    /// Records of earlier frames dropped as too coarse for this frame's view, or out of view for long.
    pub n_records_dropped: u64,
    /// Of those, the records in view that no pixel had read for as long as the out-of-view wait.
    pub n_records_unread: u64,
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

/// Why a progressive render stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StopReason {
    /// It made the passes `--passes` asked for.
    #[default]
    Passes,
    /// The next pass would not have fitted in the time budget (or the one under way did not).
    Time,
    /// A signal: the image is the mean of the passes made before it.
    Interrupted,
}

impl StopReason {
    pub fn name(self) -> &'static str {
        match self {
            StopReason::Passes => "passes",
            StopReason::Time => "time",
            StopReason::Interrupted => "interrupted",
        }
    }
}

/// A progressive render's passes, summed.
#[derive(Clone, Debug, Default)]
pub struct ProgressiveStats {
    /// Seconds of each pass made.
    pub pass_s: Vec<f64>,
    /// The time budget, if one was set.
    pub budget_s: Option<f64>,
    pub stopped: StopReason,
    /// The last pass's photon lookup radius as a fraction of the first's (√ of their k-NN counts);
    /// `None` for the methods without photon maps.
    pub radius_fraction: Option<f64>,
    /// Photon paths traced and photons stored, over all passes.
    pub photon_paths: u64,
    pub photons_stored: u64,
    /// Per layer (beauty first), the relMSE the mean's noise alone gives, estimated from the spread
    /// between passes (empty before two).
    pub noise_relmse: Vec<(&'static str, f64)>,
    pub warnings: Vec<String>,
}

impl ProgressiveStats {
    /// One more pass, planned as `plan` in a render whose first pass is `first`, taken in.
    pub fn add_pass(&mut self, stats: &RenderStats, plan: &Plan, first: &Plan) {
        self.pass_s.push(stats.total_s);
        if let Some(p) = stats.photons.as_ref() {
            let t = &p.trace;
            self.photon_paths += t.n_paths_emitted;
            self.photons_stored += t.n_global_stored
                + t.n_caustic_stored
                + t.n_volume_stored
                + t.n_volume_caustic_stored;
            self.radius_fraction =
                Some((plan.photons.lookup as f64 / first.photons.lookup.max(1) as f64).sqrt());
        }
    }
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
    /// The scene's warnings from loading (file and line of each).
    pub load_warnings: Vec<String>,
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

impl ShadeStats {
    /// `o`'s samples added to these (another tile's).
    pub fn add(&mut self, o: &ShadeStats) {
        self.time_s += o.time_s;
        self.counters += o.counters;
        let (s, t) = (&mut self.samples, &o.samples);
        s.samples += t.samples;
        s.pixels += t.pixels;
        s.at_limit += t.at_limit;
        s.monte_carlo_pixels += t.monte_carlo_pixels;
        s.redone += t.redone;
        s.redone_pixels += t.redone_pixels;
        self.grown.rounds += o.grown.rounds;
        self.grown.fill += o.grown.fill;
        self.grown.counters += o.grown.counters;
    }
}

impl RenderStats {
    /// What a user should hear about a render that succeeded on legal input but is likely not what
    /// they meant; the binary prints each on stderr.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = self.setup.load_warnings.clone();
        if let Some(p) = &self.progressive {
            out.extend(p.warnings.iter().cloned());
        }
        if self.crossings_given_up > 0 {
            out.push(format!(
                "{} rays crossed more than {} medium boundaries and were given up, their light \
                 lost (stats: rare.crossings_given_up): a stack of that many boundaries along one \
                 line, or a mesh whose boundary faces repeat",
                self.crossings_given_up,
                crate::scene::MAX_NULL_CROSSINGS
            ));
        }
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
            load_warnings: scene.warnings.clone(),
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
            progressive: None,
            total_s: 0.0,
            write_outputs_s: None,
            peak_rss_bytes: 0,
            crossings_given_up: scene.n_crossings_given_up(),
        }
    }

    /// What is read once the phases are done: the atlas and the cache as shading left them, the time
    /// since `start`, the peak memory.
    pub fn finish(
        &mut self,
        scene: &Scene,
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
        self.crossings_given_up = scene.n_crossings_given_up() - self.crossings_given_up;
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
}

/// Glossy surfaces' statistics: the radiance cache's, and the gather rays' texel harmonics
/// ((estimated, bytes)).
#[derive(Clone, Copy, Debug, Default)]
pub struct GlossyStats {
    pub radiance: RadianceCacheStats,
    pub texels: (u64, u64),
}
