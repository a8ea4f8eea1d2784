//! An animated scene rendered frame by frame. Frames between which no mesh and no light changes share
//! one scene: its photon maps are traced once, and its irradiance cache grows over the frames — each
//! frame's pass A makes records only where no record of an earlier frame reaches (Radiance's shared
//! ambient file), after dropping those too coarse for the new view. A frame where nothing changed at
//! all shows the frame before's image. Where something moves, the scene is loaded again and traced
//! with the same seed, so that the photons of unchanged regions follow the same paths.
//!
//! A frame runs the still's phases (`super`'s `plan`, photon maps, `media_phase`, `radiance_phase`,
//! `cache_phase`, `shade_bake_foreign`) with what [`Sequence`] keeps between frames attached at four
//! points: before the photons (copy the paths nothing moved touched), after the maps (carry atlas
//! texels), before the fill (the temporal update of the records), after shading (paste the pixels
//! kept). The temporal cache's parts: `temporal` (record lives and the update), `light_change`
//! (where the photons say the light changed), `kept_pixels` (which pixels to keep, repeat or relight
//! while the camera stays), `atlas_carry` (atlas texels carried from the frame before).

mod atlas_carry;
mod cones;
mod frame_photons;
mod kept_pixels;
mod light_change;
mod pixel_ends;
mod record_life;
mod reuse;
mod scene_change;
mod screen;
mod temporal;

use std::ops::RangeInclusive;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use gather::GatherParams;
use glam::Vec3;

use super::fill::FillLight;
use super::photons::{build_maps, load_photons, trace_photons};
use super::shade::{beauty, KeptPixels};
use super::stats::PhotonStats;
use super::tiles::Window;
use super::{
    budget, cache_phase, interrupted, media_phase, occlusion_cache_phase, output, plan,
    radiance_phase, shade_bake_foreign, Bake, FrameStats, Options, Plan, RenderOutput, RenderStats,
};
use crate::camera::Camera;
use crate::error::Result;
use crate::integrator::pm::OtherViews;
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::output::Image;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::{self, Animation, Method, Scene};
use atlas_carry::{AtlasBefore, PhotonKeys};
use kept_pixels::ShadedLight;
use reuse::{reused_image_stats, Kept};
use temporal::{Lifespans, Moved, Rigid, SceneChange};

/// The chunk of a sequence of `n` frames that frame `f` belongs to, chunks being `len` frames long
/// (the last may be shorter): a chunk starts afresh, with nothing from the frames before it.
pub fn chunk_of(f: u32, len: u32, n: u32) -> RangeInclusive<u32> {
    let len = len.max(1);
    let start = f - f % len;
    start..=start.saturating_add(len - 1).min(n.saturating_sub(1))
}

/// Renders `frames` of `anim`, handing each frame to `on_frame` as soon as it is done (the caller
/// writes it). The sequence is split into chunks of `opts.chunk` frames (default: one chunk of all),
/// each rendered from its first frame on as if it were the whole sequence; a range that begins inside
/// a chunk renders that chunk's earlier frames too, without handing them over, so that every frame is
/// the one the whole sequence renders. Stops with `Interrupted` soon after `cancel` is set; frames
/// handed over stay handed over.
pub fn render_sequence(
    anim: &Animation,
    frames: RangeInclusive<u32>,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
    on_frame: &mut dyn FnMut(u32, &Scene, &RenderOutput, &RenderStats) -> Result<()>,
) -> Result<()> {
    let (first, last) = (*frames.start(), *frames.end());
    let (n, len) = (anim.frames(), opts.chunk.unwrap_or(anim.frames()));
    let replay_from = *chunk_of(first, len, n).start();
    // Whatever a frame's scene would refuse is refused before the first frame is written.
    let first_scene = scene::load_frame(anim, replay_from)?;
    super::progressive::refuse_in_sequence(&first_scene, opts)?;
    // Frames where a medium's boundary moved are built to be checked: that can take a while.
    progress.start("checking frames", (last - replay_from + 1) as u64);
    let largest = scene::check_sequence(anim, replay_from..=last, &first_scene, progress, cancel)?;
    progress.finish();
    // What the process holds before its first frame: each frame's memory is checked against it.
    let held = crate::memory::resident();
    let camera = scene::frame_camera(anim, replay_from)?;
    check_frame_memory(&first_scene, &camera, replay_from, opts, held)?;
    if let Some(f) = largest {
        let scene = scene::load_frame(anim, f)?;
        check_frame_memory(&scene, &scene::frame_camera(anim, f)?, f, opts, held)?;
    }
    let mut loaded = Some(first_scene);
    let mut start = replay_from;
    while start <= last {
        let chunk = chunk_of(start, len, n);
        let scene = match loaded.take() {
            Some(s) => s,
            None => scene::load_frame(anim, start)?,
        };
        let upto = last.min(*chunk.end());
        let mut handed = |f: u32, s: &Scene, out: &RenderOutput, stats: &RenderStats| {
            if f >= first {
                on_frame(f, s, out, stats)?;
            }
            Ok(())
        };
        let span = Chunk {
            frames: chunk.clone(),
            upto,
            held,
        };
        render_chunk(anim, span, scene, opts, progress, cancel, &mut handed)?;
        match chunk.end().checked_add(1) {
            Some(next) => start = next,
            None => break,
        }
    }
    Ok(())
}

/// Refuses (before any frame is written) a sequence whose frame `f`, of `scene` seen by `camera`,
/// needs more memory than the budget, with the `held` bytes the process held before its first frame.
fn check_frame_memory(
    scene: &Scene,
    camera: &Camera,
    f: u32,
    opts: &Options,
    held: u64,
) -> Result<()> {
    let plan = plan(scene, opts, Some(camera))?;
    budget::check_held(scene, &plan, opts, held).map_err(|e| scene::at_frame(e, f))
}

/// The frames of one chunk, the last of them to render, and the bytes the process held before the
/// sequence's first frame.
struct Chunk {
    frames: RangeInclusive<u32>,
    upto: u32,
    held: u64,
}

/// One chunk's frames up to `span.upto`, from its first, whose scene `first_scene` is.
fn render_chunk(
    anim: &Animation,
    span: Chunk,
    first_scene: Scene,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
    on_frame: &mut dyn FnMut(u32, &Scene, &RenderOutput, &RenderStats) -> Result<()>,
) -> Result<()> {
    let (first, last) = (*span.frames.start(), span.upto);
    // What holds for the sequence is what holds for the whole chunk, however far it is rendered.
    let (moving_window, track_atlas) =
        sequence_settings(anim, &first_scene, span.frames, opts, progress, cancel)?;
    let mut loaded = Some(first_scene);
    let mut f = first;
    let mut left: Option<Sequence> = None;
    while f <= last {
        let scene = match loaded.take() {
            Some(s) => s,
            None => scene::load_frame(anim, f)?,
        };
        let temporal = scene.settings.icache.temporal;
        let mut seq = match left.take() {
            Some(mut s) if temporal => {
                s.next_scene(anim, &scene, f);
                s
            }
            _ => Sequence::new(moving_window.clone(), track_atlas, span.held),
        };
        // The scene's photon maps, traced for its first frame rendered.
        let mut maps: Option<PhotonData> = None;
        let mut prev: Option<(RenderOutput, RenderStats)> = None;
        // What changed from frame f − 1 to f, within this scene.
        let mut change = None;
        loop {
            let unchanged = change.is_some_and(|c: scene::Change| !c.camera);
            match &mut prev {
                Some((out, stats)) if unchanged => {
                    *stats = reused_image_stats(stats, f);
                    on_frame(f, &scene, out, stats)?;
                }
                _ => {
                    if let Some((mut out, _)) = prev.take() {
                        seq.cache = out.cache.take();
                    }
                    let camera = scene::frame_camera(anim, f)?;
                    // The scene was built for its first frame's eye: this frame's may be in
                    // another medium.
                    scene.place_eye(camera.eye);
                    let (out, stats) =
                        seq.render_frame(&scene, &mut maps, opts, &camera, f, progress, cancel)?;
                    on_frame(f, &scene, &out, &stats)?;
                    prev = Some((out, stats));
                }
            }
            f += 1;
            if f > last || !temporal {
                break;
            }
            let next = anim.change(f - 1, f);
            if next.scene {
                break;
            }
            change = Some(next);
        }
        if f > last {
            break;
        }
        if let Some((mut out, _)) = prev.take() {
            seq.cache = out.cache.take();
        }
        seq.end_scene(maps, &scene);
        left = Some(seq);
    }
    Ok(())
}

/// What holds for the whole sequence: the window its moving meshes may cover while the camera stays
/// (`pm`'s temporal cache shades it finer from the first frame on), and whether it moves a mesh (its
/// frames' atlases then keep what their texels are made of).
fn sequence_settings(
    anim: &Animation,
    first_scene: &Scene,
    frames: RangeInclusive<u32>,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Option<(Camera, Window)>, bool)> {
    let (first, last) = (*frames.start(), *frames.end());
    // Only `pm`'s temporal cache shades the movers' pixels at a finer target.
    let pm = super::plan::method(first_scene, opts) == Method::Pm;
    let moving_window = if pm && first_scene.settings.icache.temporal {
        let size = (
            opts.width.unwrap_or(first_scene.camera.width),
            opts.height.unwrap_or(first_scene.camera.height),
        );
        kept_pixels::sequence_window(anim, first_scene, frames.clone(), size, progress, cancel)?
    } else {
        None
    };
    let track_atlas = first_scene.settings.icache.temporal
        && (first..last).any(|f| !anim.moved_meshes(f, f + 1).is_empty());
    Ok((moving_window, track_atlas))
}

/// What a sequence's frames leave to the next frame, in the same scene or the next one (after a
/// mesh or a light changed): the caches, the frame before's view, layers and samples, the photon
/// paths, and what changed. The photon maps belong to one scene: the loop over its frames holds them.
struct Sequence {
    /// The pixels the sequence's moving meshes may cover while its camera stays, with that camera
    /// ([`kept_pixels::sequence_window`]): held to the finer noise target from the first frame on.
    moving_window: Option<(Camera, Window)>,
    /// Whether the sequence moves a mesh (with the temporal cache): its frames' atlases keep what
    /// their texels are made of, for the next scene's first frame to carry them.
    track_atlas: bool,
    cache: Option<icache::IrradianceCache>,
    /// The rays the sequence's first frame chose for its gathers.
    chosen_rays: Option<usize>,
    radiance: Option<RadianceCache>,
    /// The records' lives, and what changed since the frame before (on a new scene's first frame).
    lifespans: Lifespans,
    change: Option<SceneChange>,
    /// The camera of the frame before, and its layers (before they are summed into the beauty).
    camera: Option<Camera>,
    layers: Option<Vec<Image>>,
    /// The cached light each pixel was last shaded with, and the samples it took, while the camera
    /// stays.
    shaded_light: ShadedLight,
    pixel_samples: Option<Vec<u32>>,
    /// The paths each photon map of the sequence's first frame (or of the last frame traced afresh)
    /// took: later frames trace as many; and the last trace's log of them, with the bounds of its
    /// scene (later frames copy the paths nothing moved touched).
    photon_paths: Option<photon::MapPaths>,
    /// What those paths stored in each map (global, caustic, volume, volume caustic): the density
    /// later frames are held to ([`frame_photons`]).
    photon_stored: Option<[u64; 4]>,
    photon_log: Option<(photon::PathLog, (Vec3, Vec3))>,
    /// The atlas and photons of the scene before (for a new scene's first frame), and this scene's
    /// photons (for the next).
    atlas_before: Option<AtlasBefore>,
    atlas_next: Option<PhotonKeys>,
    /// Where each mesh of the scene before was (its bounding sphere).
    mesh_spheres: Vec<Option<(Vec3, f32)>>,
    /// The bytes the process held before the sequence's first frame.
    held: u64,
}

impl Sequence {
    fn new(moving_window: Option<(Camera, Window)>, track_atlas: bool, held: u64) -> Sequence {
        Sequence {
            moving_window,
            track_atlas,
            cache: None,
            chosen_rays: None,
            radiance: None,
            lifespans: Lifespans::default(),
            change: None,
            camera: None,
            layers: None,
            shaded_light: ShadedLight::default(),
            pixel_samples: None,
            photon_paths: None,
            photon_stored: None,
            photon_log: None,
            atlas_before: None,
            atlas_next: None,
            mesh_spheres: Vec::new(),
            held,
        }
    }

    /// Frame `f`, seen by `camera`: the still's phases over `maps` (traced here on the scene's first
    /// frame) and the caches of the frames before, which it leaves for the next.
    #[allow(clippy::too_many_arguments)]
    fn render_frame<'a>(
        &mut self,
        scene: &'a Scene,
        maps: &mut Option<PhotonData<'a>>,
        opts: &Options,
        camera: &Camera,
        f: u32,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<(RenderOutput, RenderStats)> {
        let start = Instant::now();
        let (mut plan, moving) = self.frame_plan(scene, opts, camera)?;
        budget::check_held(scene, &plan, opts, self.held)?;
        let mut stats = RenderStats::new(scene, &plan);
        let mut frame = FrameStats {
            frame: f,
            photons_reused: maps.is_some(),
            no_photon_maps: !plan.method.uses_photon_maps(),
            ..Default::default()
        };
        // Attached before the photons and after the maps: the paths nothing moved touched copied,
        // the atlas texels carried.
        if plan.method.uses_photon_maps() && maps.is_none() {
            *maps = Some(self.frame_photons(scene, &plan, opts, &mut stats, progress, cancel)?);
        }
        let photons = maps.as_ref();
        interrupted(cancel)?;
        let media_cache = media_phase(scene, &plan, photons, &mut stats, progress, cancel)?;
        let radiance = radiance_phase(scene, &plan, &opts.files, self.radiance.take());
        // Attached before the fill: the records of the frames before, updated for what changed.
        let light = photons.map(|photons| FillLight {
            photons,
            media_cache: media_cache.as_ref(),
            radiance: radiance.as_ref(),
        });
        let (earlier, only, foreign, still_view) =
            self.earlier(scene, &mut plan, moving, light.as_ref(), cancel, &mut frame)?;
        let cache = match light {
            Some(l) => {
                let (files, work) = (&opts.files, (earlier, only));
                cache_phase(scene, &plan, files, l, work, &mut stats, progress, cancel)?
            }
            // Occlusion reads no light: each frame fills its cache as its still does.
            None if plan.method == Method::Ao => {
                occlusion_cache_phase(scene, &plan, &opts.files, &mut stats, progress, cancel)?
            }
            None => None,
        };
        interrupted(cancel)?;
        let mut bake = Bake {
            photons: maps.take(),
            photon_info: None,
            media_cache,
            radiance,
            cache,
        };
        let kept = self.kept_pixels(scene, &plan, still_view.zip(only), &bake);
        let pixels = Kept::view(kept.as_ref());
        // Which records of the views before pass B reads: those no pixel reads retire.
        let reads: Vec<AtomicBool> = (0..foreign).map(|_| AtomicBool::new(false)).collect();
        let views = OtherViews {
            reads: Some(&reads),
            ..OtherViews::first(foreign)
        };
        let shaded = shade_bake_foreign(
            scene, &plan, &mut bake, pixels, views, &mut stats, progress, cancel,
        );
        *maps = bake.photons.take();
        let (mut layers, mut samples) = shaded?;
        if let (Some(c), true) = (&bake.cache, foreign > 0) {
            self.lifespans.note_reads(c.cache.records(), &reads);
        }
        // Attached after shading: the pixels kept pasted from the frame before.
        if let (Some(kept), Some(before)) = (&kept, &self.layers) {
            kept.paste(&mut layers, before, &mut samples, &mut frame);
        }
        self.layers = Some(layers.clone());
        self.pixel_samples = Some(samples);
        let images = beauty(&plan, crate::integrator::terms::Layout::of(scene), layers);
        let out = self.finish_frame(
            scene,
            plan,
            images,
            bake,
            maps.as_ref(),
            frame,
            &mut stats,
            start,
        );
        Ok((out, stats))
    }

    /// The frame's plan: the still's seen by `camera`, the movers' window held finer from the first
    /// frame on, the rays the first frame chose; with that window, where the camera sees it.
    fn frame_plan(
        &self,
        scene: &Scene,
        opts: &Options,
        camera: &Camera,
    ) -> Result<(Plan, Option<Window>)> {
        let mut plan = plan(scene, opts, Some(camera))?;
        // Where the sequence's movers pass, every frame from the first holds its pixels to the
        // noise target of a frame where something moved: a pixel's noise then does not change
        // (flicker) when a mover reaches it and it is shaded again.
        let moving = self
            .moving_window
            .as_ref()
            .filter(|(cam, _)| cam.same_view(&plan.camera))
            .map(|(_, w)| *w);
        if plan.method == Method::Pm && self.cache.is_none() {
            plan.finer = moving.map(|w| (w, plan.noise * temporal::MOVING_NOISE));
        }
        if let Some(rays) = self.chosen_rays {
            plan.choose_rays = false;
            plan.gather = GatherParams { rays };
        }
        Ok((plan, moving))
    }

    /// The frame's output from its images and its bake, with its statistics' totals; and what it
    /// leaves for the next frame: the records' lives, the rays chosen, the radiance cache, the camera.
    #[allow(clippy::too_many_arguments)]
    fn finish_frame(
        &mut self,
        scene: &Scene,
        plan: Plan,
        images: (Image, Vec<(&'static str, Image)>),
        bake: Bake,
        maps: Option<&PhotonData>,
        mut frame: FrameStats,
        stats: &mut RenderStats,
        start: Instant,
    ) -> RenderOutput {
        stats.finish(
            scene,
            start,
            maps,
            bake.media_cache.as_ref(),
            bake.cache.as_ref().map(|c| &c.cache),
            bake.radiance.as_ref(),
        );
        if let Some(c) = &bake.cache {
            frame.n_records_after = c.cache.len() as u64;
            self.lifespans.note_new(&c.cache, frame.frame, &plan.camera);
            if let Some(p) = maps {
                self.lifespans.note_photons(scene, p);
            }
        }
        stats.frame = Some(frame);
        let mut out = output(images, bake.media_cache, plan.camera.clone());
        out.radiance_records = bake.radiance.as_ref().map_or(Vec::new(), |r| r.positions());
        // The rays chosen by the sequence's first frame stay chosen: a frame that took them does
        // not choose again, and its cache knows none (every second frame gathered with other rays,
        // a record's change between the two kinds of gather read as a change of its light: 3 %
        // flicker).
        self.chosen_rays = bake
            .cache
            .as_ref()
            .and_then(|c| c.chosen_rays)
            .or(self.chosen_rays);
        out.cache = bake.cache.map(|c| c.cache);
        self.radiance = bake.radiance;
        self.camera = Some(plan.camera);
        out
    }
}
