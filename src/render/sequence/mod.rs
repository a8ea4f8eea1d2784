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
mod kept_pixels;
mod light_change;
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
    budget, cache_phase, interrupted, media_phase, output, plan, radiance_phase,
    shade_bake_foreign, Bake, FrameStats, Options, Plan, RenderOutput, RenderStats,
};
use crate::camera::Camera;
use crate::error::Result;
use crate::integrator::pm::{IndirectSource, PmContext};
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::output::Image;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::{self, Animation, Method, Scene};
use atlas_carry::{AtlasBefore, PhotonKeys};
use kept_pixels::ShadedLight;
use temporal::{Lifespans, Moved, SceneChange};

/// Renders `frames` of `anim`, handing each frame to `on_frame` as soon as it is done (the caller
/// writes it). Stops with `Interrupted` soon after `cancel` is set; frames handed over stay handed over.
pub fn render_sequence(
    anim: &Animation,
    frames: RangeInclusive<u32>,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
    on_frame: &mut dyn FnMut(u32, &Scene, &RenderOutput, &RenderStats) -> Result<()>,
) -> Result<()> {
    let (first, last) = (*frames.start(), *frames.end());
    // Whatever a frame's scene would refuse is refused before the first frame is written.
    let first_scene = scene::load_frame(anim, first)?;
    // Frames where a medium's boundary moved are built to be checked: that can take a while.
    progress.start("checking frames", (last - first + 1) as u64);
    scene::check_sequence(anim, frames.clone(), &first_scene, progress, cancel)?;
    progress.finish();
    // Only `pm`'s temporal cache shades the movers' pixels at a finer target.
    let pm = super::plan::method(&first_scene, opts) == Method::Pm;
    let moving_window = if pm && first_scene.settings.icache.temporal {
        let size = (
            opts.width.unwrap_or(first_scene.camera.width),
            opts.height.unwrap_or(first_scene.camera.height),
        );
        kept_pixels::sequence_window(anim, &first_scene, frames.clone(), size, progress, cancel)?
    } else {
        None
    };
    let track_atlas = first_scene.settings.icache.temporal
        && (first..last).any(|f| !anim.moved_meshes(f, f + 1).is_empty());
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
            _ => Sequence::new(moving_window.clone(), track_atlas),
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
    /// The paths each photon map of the sequence's first frame took: later frames trace as many;
    /// and the last trace's log of them, with the bounds of its scene (later frames copy the paths
    /// nothing moved touched).
    photon_paths: Option<photon::MapPaths>,
    photon_log: Option<(photon::PathLog, (Vec3, Vec3))>,
    /// The atlas and photons of the scene before (for a new scene's first frame), and this scene's
    /// photons (for the next).
    atlas_before: Option<AtlasBefore>,
    atlas_next: Option<PhotonKeys>,
    /// Where each mesh of the scene before was (its bounding sphere).
    mesh_spheres: Vec<Option<(Vec3, f32)>>,
}

impl Sequence {
    fn new(moving_window: Option<(Camera, Window)>, track_atlas: bool) -> Sequence {
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
            photon_log: None,
            atlas_before: None,
            atlas_next: None,
            mesh_spheres: Vec::new(),
        }
    }

    /// Frame `f` of `anim` begins `scene` (a mesh or a light changed since frame `f − 1`): what
    /// changed, from where each mesh was.
    fn next_scene(&mut self, anim: &Animation, scene: &Scene, f: u32) {
        let mut moved = Vec::new();
        let mut rigid = Vec::new();
        // A mesh that emits and moved is a light that changed.
        let mut lights = anim.lights_changed(f - 1, f);
        for m in anim.moved_meshes(f - 1, f) {
            lights |= scene.mesh_emits(m);
            if let (Some(before), Some(after)) = (
                self.mesh_spheres.get(m).copied().flatten(),
                scene.mesh_sphere(m),
            ) {
                let step = match (
                    scene::mesh_transform(anim, f - 1, m),
                    scene::mesh_transform(anim, f, m),
                ) {
                    (Some(t0), Some(t1)) => Some(t1 * t0.inverse()),
                    _ => None,
                };
                moved.push(Moved::new(before, after, step));
                if let Some(step) = step {
                    rigid.push((before, step));
                }
            }
        }
        self.change = Some(SceneChange {
            moved,
            rigid,
            lights,
        });
        self.atlas_next = None;
    }

    /// `scene`'s last frame is done: its atlas (with the temporal cache) and where its meshes were
    /// are kept for the next scene's first frame.
    fn end_scene(&mut self, maps: Option<PhotonData>, scene: &Scene) {
        let temporal = self.photon_paths.is_some();
        let next = self.atlas_next.take();
        self.atlas_before = maps.filter(|_| temporal).and_then(|p| {
            let (maps, atlas) = p.into_maps_and_atlas();
            let keys = next.or_else(|| Some(PhotonKeys::of(maps.global.as_ref()?.photons())))?;
            Some(AtlasBefore {
                atlas: atlas?,
                keys,
            })
        });
        self.mesh_spheres = (0..scene.mesh_ranges.len())
            .map(|m| scene.mesh_sphere(m))
            .collect();
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
        budget::check(scene, &plan, opts)?;
        let mut stats = RenderStats::new(scene, &plan);
        let mut frame = FrameStats {
            frame: f,
            photons_reused: maps.is_some(),
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
        let earlier = match (self.cache.take(), &light) {
            (Some(c), Some(light)) => {
                Some(self.earlier_records(scene, &mut plan, moving, light, cancel, c, &mut frame)?)
            }
            _ => None,
        };
        let (earlier, only, foreign, still_view) = match earlier {
            Some(e) => (Some((e.cache, e.foreign)), e.only, e.foreign, e.still_view),
            None => (None, None, 0, None),
        };
        let cache = match light {
            Some(light) => {
                let (files, work) = (&opts.files, (earlier, only));
                cache_phase(
                    scene, &plan, files, light, work, &mut stats, progress, cancel,
                )?
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
        let pixels = KeptPixels {
            kept: kept.as_ref().map(|k| &k.keep[..]),
            kept_samples: kept.as_ref().and_then(|k| k.samples.as_deref()),
            repeat: kept.as_ref().map(|k| &k.repeat[..]),
        };
        let shaded = shade_bake_foreign(
            scene, &plan, &mut bake, pixels, foreign, &mut stats, progress, cancel,
        );
        *maps = bake.photons.take();
        let (mut layers, mut samples) = shaded?;
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

    /// A frame's photon maps: over the paths the sequence's first frame took (the temporal cache's
    /// frames; `pm-fg` and `photons` render each frame as a still), copying the paths nothing that
    /// moved touched, and with the atlas texels carried from the scene before.
    fn frame_photons<'a>(
        &mut self,
        scene: &'a Scene,
        plan: &Plan,
        opts: &Options,
        stats: &mut RenderStats,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<PhotonData<'a>> {
        let temporal = plan.method == Method::Pm;
        let (traced, s) = match &opts.files.load_photons {
            Some(file) => load_photons(scene, plan, file)?,
            None => self.trace_over_paths(scene, plan, temporal, opts, progress, cancel)?,
        };
        self.photon_log = traced.log.map(|log| (log, scene.bounds));
        if temporal && self.photon_paths.is_none() {
            self.photon_paths = Some(photon::MapPaths::of(&s.trace));
        }
        stats.photons = Some(s);
        let mut data = build_maps(scene, plan, traced.maps);
        if temporal && self.track_atlas {
            data.track_atlas();
        }
        let before = self.atlas_before.take();
        if let (true, Some(before), Some(change)) = (temporal, before, &self.change) {
            self.atlas_next = atlas_carry::carry_atlas(scene, &mut data, before, change);
        }
        Ok(data)
    }

    /// The trace of a frame: a temporal sequence's over the paths its first frame took, copying
    /// from the frame before's log the paths no moved mesh's bounding sphere (before or after its
    /// step) comes near — not after a light changed, nor where the scene's bounds changed (a
    /// directional light's photons leave a disc over them: every path starts elsewhere).
    fn trace_over_paths(
        &self,
        scene: &Scene,
        plan: &Plan,
        temporal: bool,
        opts: &Options,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<(super::photons::Maps, PhotonStats)> {
        let movers: Vec<(Vec3, f32)> = match &self.change {
            Some(c) if !c.lights => c.moved.iter().flat_map(|m| m.spheres).collect(),
            _ => Vec::new(),
        };
        let margin = 1e-4 * scene.diagonal();
        let touched = |a: Vec3, b: Vec3| {
            movers
                .iter()
                .any(|&(c, r)| photon::pathlog::segment_meets_sphere(a, b, c, r + margin))
        };
        let reuse_ok = temporal && self.change.as_ref().is_some_and(|c| !c.lights);
        let over = photon::Over {
            paths: self.photon_paths.filter(|_| temporal),
            reuse: self
                .photon_log
                .as_ref()
                .filter(|(_, bounds)| reuse_ok && *bounds == scene.bounds)
                .map(|(log, _)| photon::Reuse {
                    log,
                    touched: &touched,
                }),
            log: temporal,
        };
        trace_photons(scene, plan, over, &opts.files, progress, cancel)
    }

    /// The records of the frames before, for this frame: updated where a mesh or a light changed
    /// (the temporal cache), then made fit for this view when the camera moved. Where the camera
    /// stayed and a mesh moved, pass A visits only the window it changed, held finer.
    #[allow(clippy::too_many_arguments)]
    fn earlier_records(
        &mut self,
        scene: &Scene,
        plan: &mut Plan,
        moving: Option<Window>,
        light: &FillLight,
        cancel: &AtomicBool,
        cache: icache::IrradianceCache,
        frame: &mut FrameStats,
    ) -> Result<Earlier> {
        let same_view = self
            .camera
            .as_ref()
            .is_some_and(|cam| cam.same_view(&plan.camera));
        let (mut only, mut still_view) = (None, None);
        let cache = match self.change.take() {
            Some(change) => {
                if same_view {
                    self.shaded_light.note_all(scene, &plan.camera, &cache);
                }
                let ctx = PmContext {
                    radiance: light.radiance,
                    ..plan.pm_context(
                        scene,
                        light.photons,
                        light.media_cache,
                        IndirectSource::PhotonMap,
                        cancel,
                    )
                };
                let temporal::Updated {
                    cache,
                    stats,
                    changed,
                } = self.lifespans.update(&ctx, cache, &change, frame.frame)?;
                frame.temporal = Some(stats);
                if same_view {
                    only = kept_pixels::screen_window(&change, &plan.camera);
                    let finer = match (moving, only) {
                        (Some(m), Some(o)) => Some(m.union(o)),
                        (m, o) => m.or(o),
                    };
                    plan.finer = finer.map(|w| (w, plan.noise * temporal::MOVING_NOISE));
                    if self.layers.is_some() && plan.window == Window::full(plan.width, plan.height)
                    {
                        still_view = Some((change, changed, cache.len()));
                    }
                }
                cache
            }
            None => cache,
        };
        // Records made for another view: those too coarse for this one are dropped, new ones may
        // shrink the rest (neighbour clamping), and pass B reads them only where they are in
        // sight. From the same view they stay as they are, so that where nothing moved the image
        // does not change.
        let moved = self
            .camera
            .as_ref()
            .is_some_and(|cam| !cam.same_view(&plan.camera));
        let (cache, foreign) = if moved {
            plan.pass_a_gaps_only = scene
                .settings
                .icache
                .pass_a_gaps_only(plan.width, plan.height);
            let mut c = self.lifespans.for_view(cache, scene, &plan.camera, frame)?;
            c.thaw();
            let n = c.len();
            (c, n)
        } else {
            frame.n_records_reused = cache.len() as u64;
            (cache, 0)
        };
        Ok(Earlier {
            cache,
            foreign,
            only,
            still_view,
        })
    }

    /// Where the camera stayed and a mesh moved: the pixels whose light did not change, kept from
    /// the frame before (and those to repeat or relight); `None` where every pixel is shaded anew.
    fn kept_pixels(
        &mut self,
        scene: &Scene,
        plan: &Plan,
        still_view: Option<(StillView, Window)>,
        bake: &Bake,
    ) -> Option<Kept> {
        let kept = match (still_view, &bake.cache) {
            (Some(((change, mut changed, n_carried), w)), Some(c)) => {
                // Pass A's new records reach past its window too.
                changed.extend(
                    c.cache.records()[n_carried..]
                        .iter()
                        .map(|r| (r.pos, r.r_clamped)),
                );
                kept_pixels::unchanged_pixels(
                    scene,
                    &plan.camera,
                    &change,
                    &changed,
                    w,
                    &c.cache,
                    &mut self.shaded_light,
                )
                .map(|u| Kept {
                    keep: u.keep,
                    repeat: u.repeat,
                    relight: u.relight,
                    samples: None,
                })
            }
            _ => None,
        };
        match kept {
            Some(k) => Some(Kept {
                samples: self.pixel_samples.take(),
                ..k
            }),
            None => {
                // Every pixel is shaded anew (or the view changed): nothing to compare with.
                self.shaded_light = ShadedLight::default();
                None
            }
        }
    }
}

/// A frame's records of the frames before ([`Sequence::earlier_records`]): how many of the first
/// were made for other views, the window pass A visits, and what a still view's mesh change did.
struct Earlier {
    cache: icache::IrradianceCache,
    foreign: usize,
    only: Option<Window>,
    still_view: Option<StillView>,
}

/// Where the camera stayed and a mesh moved: what changed, the spheres where the cached light
/// changed, and how many records the frame before left.
type StillView = (SceneChange, Vec<(Vec3, f32)>, usize);

/// The pixels a frame takes from the frame before, those it shades again with the samples they
/// took, the factor relighting each kept pixel's indirect light, and the samples each took.
struct Kept {
    keep: Vec<bool>,
    repeat: Vec<bool>,
    relight: Vec<Option<Vec3>>,
    samples: Option<Vec<u32>>,
}

impl Kept {
    /// Pastes the kept pixels of `before` (the frame before's layers) into `layers`, relit, with
    /// their samples, and counts them in `frame`.
    fn paste(
        &self,
        layers: &mut [Image],
        before: &[Image],
        samples: &mut [u32],
        frame: &mut FrameStats,
    ) {
        let kept = || self.keep.iter().enumerate().filter(|(_, k)| **k);
        for (now, then) in layers.iter_mut().zip(before) {
            for (i, _) in kept() {
                now.pixels[i] = then.pixels[i];
            }
        }
        let indirect = &mut layers[crate::integrator::terms::INDIRECT_LAYER];
        for (v, r) in indirect.pixels.iter_mut().zip(&self.relight) {
            *v *= r.unwrap_or(Vec3::ONE);
        }
        if let Some(then) = &self.samples {
            for (i, _) in kept() {
                samples[i] = then[i];
            }
        }
        frame.n_pixels_kept = kept().count() as u64;
        frame.n_pixels_relit = self.relight.iter().flatten().count() as u64;
    }
}

/// The statistics of frame `f`, which shows the frame before's image (nothing changed): the frame
/// before's setup and cache, and no work of its own (no photons traced, no record gathered, no pixel
/// sampled), so that the sequence's sums count each phase once.
fn reused_image_stats(before: &RenderStats, f: u32) -> RenderStats {
    let after = before.frame.map_or(0, |fr| fr.n_records_after);
    RenderStats {
        setup: before.setup.clone(),
        cache: before.cache,
        frame: Some(FrameStats {
            frame: f,
            photons_reused: true,
            n_records_reused: after,
            n_records_after: after,
            image_reused: true,
            ..Default::default()
        }),
        photons: None,
        fill: None,
        shade: Default::default(),
        atlas: None,
        volume_grid: None,
        media_fill: None,
        media_cache: before.media_cache,
        glossy: None,
        total_s: 0.0,
        write_outputs_s: None,
        peak_rss_bytes: before.peak_rss_bytes,
    }
}
