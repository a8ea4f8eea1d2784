//! The render driver: a still is its list of named phases, each a function returning its output and
//! its statistics, readable top-down in [`render`] — `plan`, `budget`, the bake ([`bake`]: the photon
//! maps, then the media, glossy radiance and irradiance caches), `shade`, the images and statistics;
//! [`write::write_outputs`] is the last phase, called by the binary once the render is done. A
//! sequence's frames ([`sequence`]) run the same phases, with what the frame before left attached
//! between them.

pub mod baked;
pub mod budget;
pub mod files;
pub mod fill;
pub mod gather_rays;
pub mod occlusion;
pub mod outputs;
pub mod photons;
pub mod plan;
pub mod progressive;
pub mod sequence;
pub mod shade;
pub mod shared_bake;
pub mod stats;
pub mod tiled;
pub mod tiles;
pub mod write;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use gather::GatherParams;
use icache::media::MediaCache;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::integrator::pm::OtherViews;
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::output::Image;
use crate::photons::PhotonData;
pub use crate::progress::{NoProgress, Progress};
use crate::scene::{Method, Scene};
use fill::{fill_cache, load_cache, CacheFill, FillLight};
use photons::{build_maps, load_photons, trace_photons};
pub use plan::{method, plan, Plan, DEFAULT_NOISE};
use shade::{beauty, sampler, shade, KeptPixels, Lighting};
pub use stats::{FrameStats, RenderStats};
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
    /// A sequence's chunk length (`--chunk`): each chunk of this many frames starts afresh (see
    /// [`sequence::render_sequence`]); `None`: the sequence is one chunk.
    pub chunk: Option<u32>,
    /// `--passes` and `--time`: a progressive still ([`progressive`]); unset: one pass.
    pub budget: progressive::Budget,
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
    /// The camera the image was rendered with (at its size).
    pub camera: Camera,
}

/// What a render shades from, made once: the photon maps and every cache. A still's comes from
/// [`bake`]; a sequence's frames grow theirs from the frame before's. `--save-photons` and
/// `--save-cache` save it, `--load-photons` and `--load-cache` load it (a render from a loaded bake
/// is the render that saved it).
pub struct Bake<'a> {
    /// The photon maps (none for `path`).
    pub photons: Option<PhotonData<'a>>,
    /// The trace's parameters, when the maps were traced (for `--save-photons`).
    pub photon_info: Option<photon::MapsInfo>,
    /// `pm`'s media radiance cache (scenes with media).
    pub media_cache: Option<MediaCache>,
    /// `pm`'s radiance cache on glossy surfaces.
    pub radiance: Option<RadianceCache>,
    /// `pm`'s irradiance cache, and the gather rays pass A chose.
    pub cache: Option<CacheFill>,
}

/// Renders `scene` without writing anything; `Interrupted` soon after `cancel` is set, in any phase.
pub fn render(
    scene: &Scene,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    render_seen_by(scene, opts, None, progress, cancel)
}

/// [`render`] seen by `camera` (a sequence's frame's, rendered as a still), else by the scene's.
pub fn render_seen_by(
    scene: &Scene,
    opts: &Options,
    camera: Option<&Camera>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let passes = progressive::Budget::of(scene, opts);
    if passes.is_set() {
        return progressive::render_progressive(scene, opts, passes, camera, progress, cancel);
    }
    let start = Instant::now();
    let plan = plan(scene, opts, camera)?;
    budget::check(scene, &plan, opts)?;
    let mut stats = RenderStats::new(scene, &plan);
    let bake = bake(scene, &plan, &opts.files, &mut stats, progress, cancel)?;
    shade_and_finish(scene, &plan, bake, stats, start, progress, cancel)
}

/// The still's phases after the bake: shading, the beauty and its layers, the statistics (begun at
/// `start`), the output.
fn shade_and_finish(
    scene: &Scene,
    plan: &Plan,
    mut bake: Bake,
    mut stats: RenderStats,
    start: Instant,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let (layers, _) = shade_bake_foreign(
        scene,
        plan,
        &mut bake,
        KeptPixels::NONE,
        OtherViews::default(),
        &mut stats,
        progress,
        cancel,
    )?;
    let images = beauty(plan, crate::integrator::terms::Layout::of(scene), layers);
    stats.finish(
        scene,
        start,
        bake.photons.as_ref(),
        bake.media_cache.as_ref(),
        bake.cache.as_ref().map(|c| &c.cache),
        bake.radiance.as_ref(),
    );
    Ok((bake.into_output(images, plan.camera.clone()), stats))
}

/// The bake of a still: the photon maps traced (every path anew) or loaded, then the media cache,
/// the glossy radiance cache and the irradiance cache filled (or loaded).
pub fn bake<'a>(
    scene: &'a Scene,
    plan: &Plan,
    files: &files::FileOptions,
    stats: &mut RenderStats,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Bake<'a>> {
    let (photons, photon_info) = if plan.method.uses_photon_maps() {
        let (traced, s) = match &files.load_photons {
            Some(file) => load_photons(scene, plan, file)?,
            None => trace_photons(
                scene,
                plan,
                photon::Over::default(),
                files,
                progress,
                cancel,
            )?,
        };
        stats.photons = Some(s);
        (Some(build_maps(scene, plan, traced.maps)), traced.info)
    } else {
        (None, None)
    };
    interrupted(cancel)?;
    let media_cache = media_phase(scene, plan, photons.as_ref(), stats, progress, cancel)?;
    let radiance = radiance_phase(scene, plan, files, None);
    let cache = match &photons {
        None if plan.method == Method::Ao => {
            occlusion_cache_phase(scene, plan, files, stats, progress, cancel)?
        }
        Some(p) => cache_phase(
            scene,
            plan,
            files,
            FillLight {
                photons: p,
                media_cache: media_cache.as_ref(),
                radiance: radiance.as_ref(),
            },
            (None, None),
            stats,
            progress,
            cancel,
        )?,
        None => None,
    };
    Ok(Bake {
        photons,
        photon_info,
        media_cache,
        radiance,
        cache,
    })
}

/// The media radiance cache of `pm` in a scene with a volume photon map (pass A in the media).
pub(crate) fn media_phase(
    scene: &Scene,
    plan: &Plan,
    photons: Option<&PhotonData>,
    stats: &mut RenderStats,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Option<MediaCache>> {
    match (plan.method, photons) {
        (Method::Pm, Some(photons)) if photons.maps().volume.is_some() => {
            let (cache, s) = fill::fill_media_cache(scene, plan, photons, progress, cancel);
            stats.media_fill = Some(s);
            interrupted(cancel)?;
            Ok(cache)
        }
        _ => Ok(None),
    }
}

/// `pm`'s radiance cache on glossy surfaces: `before`'s (a sequence's frame before) carried on, else
/// a new one; none from a loaded cache file (its records have no harmonics: glossy lobes are sampled).
pub(crate) fn radiance_phase(
    scene: &Scene,
    plan: &Plan,
    files: &files::FileOptions,
    before: Option<RadianceCache>,
) -> Option<RadianceCache> {
    match (plan.method, &files.load_cache, before) {
        (Method::Pm, None, Some(mut r)) => {
            r.next_frame();
            Some(r)
        }
        (Method::Pm, None, None) => RadianceCache::new(scene),
        _ => None,
    }
}

/// `pm`'s irradiance cache: loaded, or filled by pass A over `earlier` (a sequence's records from
/// earlier frames, and how many of them were made for other views) and only in `only` (a window of
/// the image, or all of it); none for the other methods.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cache_phase(
    scene: &Scene,
    plan: &Plan,
    files: &files::FileOptions,
    light: FillLight,
    (earlier, only): (Option<(icache::IrradianceCache, usize)>, Option<Window>),
    stats: &mut RenderStats,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Option<CacheFill>> {
    if plan.method != Method::Pm {
        return Ok(None);
    }
    let (cache, s) = match &files.load_cache {
        Some(file) => load_cache(scene, plan, file)?,
        None => {
            let earlier = earlier.map(|(c, n)| (c, OtherViews::first(n)));
            fill_cache(scene, plan, light, earlier, only, progress, cancel)?
        }
    };
    stats.fill = Some(s);
    interrupted(cancel)?;
    Ok(Some(cache))
}

/// `ao`'s irradiance cache of occlusion records: loaded, or filled by its pass A.
pub(crate) fn occlusion_cache_phase(
    scene: &Scene,
    plan: &Plan,
    files: &files::FileOptions,
    stats: &mut RenderStats,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Option<CacheFill>> {
    let (cache, s) = match &files.load_cache {
        Some(file) => load_cache(scene, plan, file)?,
        None => occlusion::fill_occlusion_cache(scene, plan, progress, cancel)?,
    };
    stats.fill = Some(s);
    interrupted(cancel)?;
    Ok(Some(cache))
}

/// Shading (pass B) from `bake`, but the pixels `kept` marks: each layer's image and the samples each
/// pixel took. The cache's `foreign` records were made for other views.
#[allow(clippy::too_many_arguments)]
pub(crate) fn shade_bake_foreign(
    scene: &Scene,
    plan: &Plan,
    bake: &mut Bake,
    kept: KeptPixels,
    foreign: OtherViews<'_>,
    stats: &mut RenderStats,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Vec<Image>, Vec<u32>)> {
    let lighting = Lighting {
        photons: bake.photons.as_ref(),
        media_cache: bake.media_cache.as_ref(),
        // Pass B's gathers take as many rays as pass A's records chose.
        gather: bake
            .cache
            .as_ref()
            .and_then(|c| c.chosen_rays)
            .map_or(plan.gather, |rays| GatherParams { rays }),
        cache: bake.cache.as_mut(),
        radiance: bake.radiance.as_ref(),
        foreign,
    };
    let (mut sample, n_layers) = sampler(scene, plan, lighting, cancel);
    let (layers, s, samples) = shade(plan, kept, n_layers, &mut *sample, progress, cancel)?;
    drop(sample);
    stats.shade = s;
    Ok((layers, samples))
}

impl Bake<'_> {
    /// The render's output: its images, and the bake's caches and traced maps (for the files that
    /// save them and `--cache-image`).
    fn into_output(
        self,
        images: (Image, Vec<(&'static str, Image)>),
        camera: Camera,
    ) -> RenderOutput {
        let mut out = output(images, self.media_cache, camera);
        out.radiance_records = self.radiance.as_ref().map_or(Vec::new(), |r| r.positions());
        out.cache = self.cache.map(|c| c.cache);
        out.photons = self
            .photons
            .zip(self.photon_info)
            .map(|(p, info)| files::PhotonOutput {
                info,
                maps: p.into_maps(),
            });
        out
    }
}

/// The images, with the media cache's record positions; the caller adds the caches and photons.
fn output(
    (beauty, layers): (Image, Vec<(&'static str, Image)>),
    media_cache: Option<MediaCache>,
    camera: Camera,
) -> RenderOutput {
    let media_records = media_cache
        .as_ref()
        .map_or(Vec::new(), |c| c.records().iter().map(|r| r.pos).collect());
    RenderOutput {
        beauty,
        layers,
        cache: None,
        photons: None,
        media_records,
        radiance_records: Vec::new(),
        camera,
    }
}

fn interrupted(cancel: &AtomicBool) -> Result<()> {
    if cancel.load(Ordering::Relaxed) {
        Err(Error::Interrupted)
    } else {
        Ok(())
    }
}
