//! The render driver: a sequence of named phases, each a function returning its output and its
//! statistics, readable top-down from [`render`] for every method — `plan`, then `trace_photons` (or
//! `load_photons`) and `build_maps` for the photon-map methods, `fill_cache` (or `load_cache`) for `pm`,
//! `shade`; [`write::write_outputs`] is the last phase, called by the binary once the render is done.

mod atlas_carry;
pub mod budget;
mod deposits;
pub mod files;
pub mod fill;
mod frame_pixels;
pub mod gather_rays;
pub mod outputs;
pub mod photons;
pub mod plan;
pub mod sequence;
pub mod shade;
pub mod stats;
pub mod temporal;
pub mod tiles;
pub mod write;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use gather::GatherParams;
use icache::media::MediaCache;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::integrator::pm::{IndirectSource, PmContext};
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::output::Image;
use crate::photons::PhotonData;
pub use crate::progress::{NoProgress, Progress};
use crate::scene::{Method, Scene};
use fill::{fill_cache, load_cache, FillLight};
use photons::{build_maps, load_photons, trace_photons};
pub use plan::{plan, Plan, DEFAULT_NOISE};
use shade::{beauty, sampler, shade, Lighting};
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
    /// The camera of this frame of a sequence, instead of the scene's.
    pub camera: Option<Camera>,
    /// The frame number, in a sequence (for its statistics).
    pub frame: Option<u32>,
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

/// What a frame of a sequence leaves to the next frame of the same scene (geometry and lights
/// unchanged): its photon maps and its caches. Empty before the first frame.
#[derive(Default)]
pub struct Carry<'a> {
    photons: Option<PhotonData<'a>>,
    photon_info: Option<photon::MapsInfo>,
    cache: Option<icache::IrradianceCache>,
    chosen_rays: Option<usize>,
    radiance: Option<RadianceCache>,
    /// The sequence's record lives, and what changed since the frame before (a new scene).
    lifespans: temporal::Lifespans,
    change: Option<temporal::SceneChange>,
    /// The camera of the frame before, and its layers (before they are summed into the beauty).
    camera: Option<Camera>,
    layers: Option<Vec<Image>>,
    /// The cached light each pixel was last shaded with, and the samples it took, while the camera
    /// stays.
    shaded_light: frame_pixels::ShadedLight,
    pixel_samples: Option<Vec<u32>>,
    /// The paths each photon map of the sequence's first frame took: later frames trace as many;
    /// and the last trace's log of them, with the bounds of its scene (later frames copy the paths
    /// nothing moved touched).
    photon_paths: Option<photon::MapPaths>,
    photon_log: Option<(photon::PathLog, (glam::Vec3, glam::Vec3))>,
    /// Whether the sequence moves a mesh (with the temporal cache): its frames' atlases keep what
    /// their texels are made of, for the next scene's first frame to carry them. The atlas and
    /// photons of the frame before (a new scene's first frame), and this scene's photons (for the
    /// next).
    track_atlas: bool,
    atlas_before: Option<atlas_carry::AtlasBefore>,
    atlas_next: Option<atlas_carry::PhotonKeys>,
    /// The pixels the sequence's moving meshes may cover while its camera stays, with that camera
    /// ([`frame_pixels::sequence_window`]): held to the finer noise target from the first frame on.
    moving_window: Option<(Camera, tiles::Window)>,
}

/// Renders `scene` without writing anything; `Interrupted` soon after `cancel` is set, in any phase.
pub fn render(
    scene: &Scene,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let mut carry = Carry::default();
    let (mut out, stats) = render_frame(scene, opts, &mut carry, progress, cancel)?;
    out.photons = carry
        .photons
        .zip(carry.photon_info)
        .map(|(p, info)| files::PhotonOutput {
            info,
            maps: p.into_maps(),
        });
    Ok((out, stats))
}

/// Renders `scene` (with `opts.camera`, a frame of a sequence) reusing what `carry` holds from the
/// frame before — photon maps, the irradiance cache's records still fine enough for this view, the
/// glossy radiance cache — and leaves them there for the next. Records are made in pass A and between
/// pass B's rounds only, as in a still.
pub fn render_frame<'a>(
    scene: &'a Scene,
    opts: &Options,
    carry: &mut Carry<'a>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let start = Instant::now();
    let mut plan = plan(scene, opts)?;
    // Where the sequence's movers pass, every frame from the first holds its pixels to the noise
    // target of a frame where something moved: a pixel's noise then does not change (flicker) when
    // a mover reaches it and it is shaded again.
    let moving = carry
        .moving_window
        .as_ref()
        .filter(|(cam, _)| cam.same_view(&plan.camera))
        .map(|(_, w)| *w);
    if plan.method == Method::Pm && opts.frame.is_some() && carry.cache.is_none() {
        plan.finer = moving.map(|w| (w, plan.noise * temporal::MOVING_NOISE));
    }
    budget::check(scene, &plan, opts)?;
    let mut stats = RenderStats::new(scene, &plan);
    let reused = carry.photons.is_some();
    if let Some(rays) = carry.chosen_rays {
        plan.choose_rays = false;
        plan.gather = GatherParams { rays };
    }

    if plan.method.uses_photon_maps() && carry.photons.is_none() {
        // The temporal cache's frames trace the first frame's paths, copying those nothing that
        // moved touched, and carry its atlas's texels (`pm-fg` and `photons` render each frame as
        // a still).
        let temporal = opts.frame.is_some() && plan.method == Method::Pm;
        let (traced, s) = match &opts.files.load_photons {
            Some(file) => load_photons(scene, &plan, file)?,
            None => {
                trace_frame_photons(scene, &plan, carry, temporal, &opts.files, progress, cancel)?
            }
        };
        carry.photon_log = traced.log.map(|log| (log, scene.bounds));
        if temporal && carry.photon_paths.is_none() {
            carry.photon_paths = Some(photon::MapPaths::of(&s.trace));
        }
        stats.photons = Some(s);
        let mut data = build_maps(scene, &plan, traced.maps);
        if temporal && carry.track_atlas {
            data.track_atlas();
        }
        if let (true, Some(before), Some(change)) =
            (temporal, carry.atlas_before.take(), &carry.change)
        {
            carry.atlas_next = atlas_carry::carry_atlas(scene, &mut data, before, change);
        }
        carry.photons = Some(data);
        carry.photon_info = traced.info;
    }
    let photons = carry.photons.as_ref();
    interrupted(cancel)?;

    let media_cache = match (plan.method, photons) {
        (Method::Pm, Some(photons)) if photons.maps().volume.is_some() => {
            let (cache, s) = fill::fill_media_cache(scene, &plan, photons, progress, cancel);
            stats.media_fill = Some(s);
            interrupted(cancel)?;
            cache
        }
        _ => None,
    };

    // Records read from a cache file have no harmonics: their glossy lobes are sampled.
    let radiance = match (plan.method, &opts.files.load_cache, carry.radiance.take()) {
        (Method::Pm, None, Some(mut r)) => {
            r.next_frame();
            Some(r)
        }
        (Method::Pm, None, None) => RadianceCache::new(scene),
        _ => None,
    };
    let mut frame = opts.frame.map(|f| FrameStats {
        frame: f,
        photons_reused: reused,
        ..Default::default()
    });
    let mut foreign = 0;
    let mut only = None;
    // A still camera after a mesh moved: what changed, the records it changed, the records carried.
    let mut still_view = None;
    let earlier = match (carry.cache.take(), photons) {
        (Some(c), Some(photons)) => {
            let f = frame.get_or_insert_with(Default::default);
            let c = match carry.change.take() {
                Some(change) => {
                    if carry
                        .camera
                        .as_ref()
                        .is_some_and(|cam| cam.same_view(&plan.camera))
                    {
                        carry.shaded_light.note_all(scene, &plan.camera, &c);
                    }
                    let ctx = PmContext {
                        radiance: radiance.as_ref(),
                        ..plan.pm_context(
                            scene,
                            photons,
                            media_cache.as_ref(),
                            IndirectSource::PhotonMap,
                            cancel,
                        )
                    };
                    let temporal::Updated {
                        cache: c,
                        stats: t,
                        changed,
                    } = carry.lifespans.update(&ctx, c, &change, f.frame)?;
                    f.temporal = Some(t);
                    if carry
                        .camera
                        .as_ref()
                        .is_some_and(|cam| cam.same_view(&plan.camera))
                    {
                        only = frame_pixels::screen_window(&change, &plan.camera);
                        let finer = match (moving, only) {
                            (Some(m), Some(o)) => Some(m.union(o)),
                            (m, o) => m.or(o),
                        };
                        plan.finer = finer.map(|w| (w, plan.noise * temporal::MOVING_NOISE));
                        if carry.layers.is_some()
                            && plan.window == tiles::Window::full(plan.width, plan.height)
                        {
                            still_view = Some((change, changed, c.len()));
                        }
                    }
                    c
                }
                None => c,
            };
            // Records made for another view: those too coarse for this one are dropped, new ones may
            // shrink the rest (neighbour clamping), and pass B reads them only where they are in
            // sight. From the same view they stay as they are, so that where nothing moved the image
            // does not change.
            let moved = carry
                .camera
                .as_ref()
                .is_some_and(|cam| !cam.same_view(&plan.camera));
            let c = if moved {
                plan.pass_a_gaps_only = scene
                    .settings
                    .icache
                    .pass_a_gaps_only(plan.width, plan.height);
                let mut c = carry.lifespans.for_view(c, scene, &plan.camera, f)?;
                c.thaw();
                foreign = c.len();
                c
            } else {
                f.n_records_reused = c.len() as u64;
                c
            };
            Some((c, foreign))
        }
        _ => None,
    };
    let mut cache = match (plan.method, photons) {
        (Method::Pm, Some(photons)) => {
            let (cache, s) = match &opts.files.load_cache {
                Some(file) => load_cache(scene, file)?,
                None => fill_cache(
                    scene,
                    &plan,
                    FillLight {
                        photons,
                        media_cache: media_cache.as_ref(),
                        radiance: radiance.as_ref(),
                    },
                    earlier,
                    only,
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
    let mut relight = None;
    if let (Some((change, mut changed, n_carried)), Some(w), Some(c)) = (still_view, only, &cache) {
        // Pass A's new records reach past its window too.
        changed.extend(
            c.cache.records()[n_carried..]
                .iter()
                .map(|r| (r.pos, r.r_clamped)),
        );
        if let Some(u) = frame_pixels::unchanged_pixels(
            scene,
            &plan.camera,
            &change,
            &changed,
            w,
            &c.cache,
            &mut carry.shaded_light,
        ) {
            plan.kept = Some(u.keep);
            plan.repeat = Some(u.repeat);
            relight = Some(u.relight);
        }
    }
    if plan.kept.is_some() {
        plan.kept_samples = carry.pixel_samples.take();
    } else {
        // Every pixel is shaded anew (or the view changed): nothing to compare with.
        carry.shaded_light = Default::default();
    }

    let lighting = Lighting {
        photons,
        media_cache: media_cache.as_ref(),
        // Pass B's gathers take as many rays as pass A's records chose.
        gather: cache
            .as_ref()
            .and_then(|c| c.chosen_rays)
            .map_or(plan.gather, |rays| GatherParams { rays }),
        cache: cache.as_mut(),
        radiance: radiance.as_ref(),
        foreign,
    };
    let (mut sample, n_layers) = sampler(scene, &plan, lighting, cancel);
    let (mut layers, s, mut samples) = shade(&plan, n_layers, &mut *sample, progress, cancel)?;
    drop(sample);
    stats.shade = s;
    if let (Some(kept), Some(before)) = (&plan.kept, &carry.layers) {
        for (now, then) in layers.iter_mut().zip(before) {
            for (i, _) in kept.iter().enumerate().filter(|(_, k)| **k) {
                now.pixels[i] = then.pixels[i];
            }
        }
        if let Some(relight) = &relight {
            let indirect = &mut layers[crate::integrator::terms::INDIRECT_LAYER];
            for (v, r) in indirect.pixels.iter_mut().zip(relight) {
                *v *= r.unwrap_or(glam::Vec3::ONE);
            }
        }
        if let Some(then) = &plan.kept_samples {
            for (i, _) in kept.iter().enumerate().filter(|(_, k)| **k) {
                samples[i] = then[i];
            }
        }
        if let Some(f) = &mut frame {
            f.n_pixels_kept = kept.iter().filter(|k| **k).count() as u64;
            f.n_pixels_relit = relight.iter().flatten().flatten().count() as u64;
        }
    }
    if opts.frame.is_some() {
        carry.layers = Some(layers.clone());
        carry.pixel_samples = Some(samples);
    }
    let images = beauty(&plan, crate::integrator::terms::Layout::of(scene), layers);
    stats.finish(
        start,
        photons,
        media_cache.as_ref(),
        cache.as_ref().map(|c| &c.cache),
        radiance.as_ref(),
    );
    if let (Some(f), Some(c)) = (&mut frame, &cache) {
        f.n_records_after = c.cache.len() as u64;
        carry.lifespans.note_new(&c.cache, f.frame, &plan.camera);
        if let Some(p) = photons {
            carry.lifespans.note_photons(scene, p);
        }
    }
    stats.frame = frame;
    let mut out = output(images, media_cache, plan.camera.clone());
    out.radiance_records = radiance.as_ref().map_or(Vec::new(), |r| r.positions());
    // The rays chosen by the sequence's first frame stay chosen: a frame that took them does not
    // choose again, and its cache knows none (every second frame gathered with other rays, a record's
    // change between the two kinds of gather read as a change of its light: 3 % flicker).
    carry.chosen_rays = cache
        .as_ref()
        .and_then(|c| c.chosen_rays)
        .or(carry.chosen_rays);
    out.cache = cache.map(|c| c.cache);
    carry.radiance = radiance;
    carry.camera = Some(plan.camera);
    Ok((out, stats))
}

/// A frame's photon maps: a still's to their targets; a temporal sequence's over the paths its first
/// frame took, copying from the frame before's log the paths no moved mesh's bounding sphere (before
/// or after its step) comes near — not after a light changed, nor where the scene's bounds changed
/// (a directional light's photons leave a disc over them: every path starts elsewhere).
fn trace_frame_photons(
    scene: &Scene,
    plan: &Plan,
    carry: &Carry,
    temporal: bool,
    files: &files::FileOptions,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(photons::Maps, stats::PhotonStats)> {
    let movers: Vec<(glam::Vec3, f32)> = match &carry.change {
        Some(c) if !c.lights => c.moved.iter().flat_map(|m| m.spheres).collect(),
        _ => Vec::new(),
    };
    let margin = 1e-4 * scene.diagonal();
    let touched = |a: glam::Vec3, b: glam::Vec3| {
        movers
            .iter()
            .any(|&(c, r)| photon::pathlog::segment_meets_sphere(a, b, c, r + margin))
    };
    let reuse_ok = temporal && carry.change.as_ref().is_some_and(|c| !c.lights);
    let over = photon::Over {
        paths: carry.photon_paths.filter(|_| temporal),
        reuse: carry
            .photon_log
            .as_ref()
            .filter(|(_, bounds)| reuse_ok && *bounds == scene.bounds)
            .map(|(log, _)| photon::Reuse {
                log,
                touched: &touched,
            }),
        log: temporal,
    };
    trace_photons(scene, plan, over, files, progress, cancel)
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
