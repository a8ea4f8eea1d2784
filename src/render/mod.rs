//! The render driver: a sequence of named phases, each a function returning its output and its
//! statistics, readable top-down from [`render`] for every method — `plan`, then `trace_photons` (or
//! `load_photons`) and `build_maps` for the photon-map methods, `fill_cache` (or `load_cache`) for `pm`,
//! `shade`; [`write::write_outputs`] is the last phase, called by the binary once the render is done.

pub mod budget;
pub mod files;
pub mod fill;
pub mod gather_rays;
pub mod outputs;
pub mod photons;
pub mod plan;
pub mod shade;
pub mod stats;
pub mod tiles;
pub mod write;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use gather::GatherParams;
use icache::media::MediaCache;

use crate::error::{Error, Result};
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::output::Image;
pub use crate::progress::{NoProgress, Progress};
use crate::scene::{Method, Scene};
use fill::{fill_cache, load_cache, CacheFill};
use photons::{build_maps, load_photons, trace_photons};
pub use plan::{plan, Plan, DEFAULT_NOISE};
use shade::{beauty, sampler, shade, Lighting};
pub use stats::RenderStats;
use tiles::Window;

/// Command-line overrides of the scene's `[render]` and `[camera]` values.
#[derive(Clone, Debug, Default)]
pub struct Options {
    pub method: Option<Method>,
    pub spp: Option<u32>,
    /// Adaptive sampling's noise target (`--noise`); see [`tiles::Sampling`].
    pub noise: Option<f32>,
    /// `--aa-spp`; see [`tiles::Sampling`].
    pub aa_spp: Option<u32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub seed: Option<u64>,
    pub crop: Option<Window>,
    pub files: files::FileOptions,
    /// Memory budget in bytes (`--max-memory`); see [`budget`].
    pub max_memory: Option<u64>,
}

/// What a render produced: beauty and the per-term layers of Jensen's split (empty for `path`).
pub struct RenderOutput {
    pub beauty: Image,
    pub layers: Vec<(&'static str, Image)>,
    /// The irradiance cache `pm` filled (for `--save-cache` and `--cache-image`).
    pub cache: Option<icache::IrradianceCache>,
    /// Traced photon maps, kept when `--save-photons` or `--dump-photons` asks for them.
    pub photons: Option<files::PhotonOutput>,
    /// Where the media radiance cache made records (for `--cache-image`); empty without media.
    pub media_records: Vec<glam::Vec3>,
    /// Where the glossy radiance cache's records are (for `--cache-image`); empty without it.
    pub radiance_records: Vec<glam::Vec3>,
}

/// Renders `scene` without writing anything; `Interrupted` soon after `cancel` is set, in any phase.
pub fn render(
    scene: &Scene,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let start = Instant::now();
    let plan = plan(scene, opts)?;
    budget::check(scene, &plan, opts)?;
    let mut stats = RenderStats::new(scene, &plan);

    let (photons, photon_info, precomputed) = if plan.method.uses_photon_maps() {
        let (traced, s) = match &opts.files.load_photons {
            Some(file) => load_photons(scene, &plan, file)?,
            None => trace_photons(scene, &plan, &opts.files, progress, cancel)?,
        };
        stats.photons = Some(s);
        (
            Some(build_maps(scene, &plan, traced.maps)),
            traced.info,
            traced.precomputed,
        )
    } else {
        (None, None, None)
    };
    interrupted(cancel)?;

    let media_cache = match (plan.method, &photons) {
        (Method::Pm, Some(photons)) if photons.maps().volume.is_some() => {
            let (cache, s) = fill::fill_media_cache(scene, &plan, photons, progress, cancel);
            stats.media_fill = Some(s);
            interrupted(cancel)?;
            cache
        }
        _ => None,
    };

    // Records read from a cache file have no harmonics: their glossy lobes are sampled.
    let radiance = match (plan.method, &opts.files.load_cache) {
        (Method::Pm, None) => RadianceCache::new(scene),
        _ => None,
    };
    let mut cache = match (plan.method, &photons) {
        (Method::Pm, Some(photons)) => {
            let (cache, s) = match &opts.files.load_cache {
                Some(file) => load_cache(scene, file)?,
                None => fill_cache(
                    scene,
                    &plan,
                    photons,
                    media_cache.as_ref(),
                    radiance.as_ref(),
                    progress,
                    cancel,
                )?,
            };
            stats.fill = Some(s);
            Some(cache)
        }
        _ => None,
    };
    interrupted(cancel)?;

    let lighting = Lighting {
        photons: photons.as_ref(),
        media_cache: media_cache.as_ref(),
        // Pass B's gathers take as many rays as pass A's records chose.
        gather: cache
            .as_ref()
            .and_then(|c| c.chosen_rays)
            .map_or(plan.gather, |rays| GatherParams { rays }),
        cache: cache.as_mut(),
        radiance: radiance.as_ref(),
    };
    let (mut sample, n_layers) = sampler(scene, &plan, lighting, cancel);
    let (layers, s) = shade(&plan, n_layers, &mut *sample, progress, cancel)?;
    drop(sample);
    stats.shade = s;
    let images = beauty(&plan, crate::integrator::terms::Layout::of(scene), layers);
    stats.finish(
        start,
        photons.as_ref(),
        media_cache.as_ref(),
        cache.as_ref().map(|c| &c.cache),
        radiance.as_ref(),
    );
    let kept = photons
        .zip(photon_info)
        .map(|(p, info)| files::PhotonOutput {
            info,
            maps: p.into_maps(),
            precomputed,
        });
    let mut out = output(images, kept, media_cache, cache);
    out.radiance_records = radiance.map_or(Vec::new(), |r| r.positions());
    Ok((out, stats))
}

/// The images, with what the render made that the binary may save: the irradiance cache, the photon
/// maps it was asked to keep, and the media cache's record positions.
fn output(
    (beauty, layers): (Image, Vec<(&'static str, Image)>),
    photons: Option<files::PhotonOutput>,
    media_cache: Option<MediaCache>,
    cache: Option<CacheFill>,
) -> RenderOutput {
    let media_records = media_cache
        .as_ref()
        .map_or(Vec::new(), |c| c.records().iter().map(|r| r.pos).collect());
    RenderOutput {
        beauty,
        layers,
        cache: cache.map(|c| c.cache),
        photons,
        media_records,
        radiance_records: Vec::new(),
    }
}

fn interrupted(cancel: &AtomicBool) -> Result<()> {
    if cancel.load(Ordering::Relaxed) {
        Err(Error::Interrupted)
    } else {
        Ok(())
    }
}
