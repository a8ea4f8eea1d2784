//! An animated scene rendered frame by frame. Frames between which no mesh and no light changes share
//! one scene: its photon maps are traced once, and its irradiance cache grows over the frames — each
//! frame's pass A makes records only where no record of an earlier frame reaches (Radiance's shared
//! ambient file), after dropping those too coarse for the new view. A frame where nothing changed at
//! all shows the frame before's image. Where something moves, the scene is loaded again and traced
//! with the same seed, so that the photons of unchanged regions follow the same paths.

use std::ops::RangeInclusive;
use std::sync::atomic::AtomicBool;

use super::atlas_carry::{AtlasBefore, PhotonKeys};
use super::temporal::Moved;
use super::{render_frame, Carry, FrameStats, Options, RenderOutput, RenderStats};
use crate::error::Result;
use crate::progress::Progress;
use crate::scene::{self, Animation, Scene};

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
    let pm = super::plan::method(&first_scene, opts) == crate::scene::Method::Pm;
    let moving_window = if pm && first_scene.settings.icache.temporal {
        let size = (
            opts.width.unwrap_or(first_scene.camera.width),
            opts.height.unwrap_or(first_scene.camera.height),
        );
        super::frame_pixels::sequence_window(
            anim,
            &first_scene,
            frames.clone(),
            size,
            progress,
            cancel,
        )?
    } else {
        None
    };
    let track_atlas = first_scene.settings.icache.temporal
        && (first..last).any(|f| !anim.moved_meshes(f, f + 1).is_empty());
    let mut loaded = Some(first_scene);
    let mut f = first;
    let mut handoff: Option<Handoff> = None;
    while f <= last {
        let scene = match loaded.take() {
            Some(s) => s,
            None => scene::load_frame(anim, f)?,
        };
        let temporal = scene.settings.icache.temporal;
        let mut carry = match handoff.take() {
            Some(h) if temporal => h.into_carry(anim, &scene, f),
            _ => Carry {
                moving_window: moving_window.clone(),
                ..Carry::default()
            },
        };
        carry.track_atlas = track_atlas;
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
                        carry.cache = out.cache.take();
                    }
                    let camera = scene::frame_camera(anim, f)?;
                    // The scene was built for its first frame's eye: this frame's may be in
                    // another medium.
                    scene.place_eye(camera.eye);
                    let frame_opts = Options {
                        camera: Some(camera),
                        frame: Some(f),
                        ..opts.clone()
                    };
                    let (out, stats) =
                        render_frame(&scene, &frame_opts, &mut carry, progress, cancel)?;
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
            carry.cache = out.cache.take();
        }
        handoff = Some(Handoff::of(carry, &scene));
    }
    Ok(())
}

/// What the frames of one scene leave to the next scene of the sequence (after a mesh or a light
/// changed): the caches, and where each mesh was.
struct Handoff {
    cache: Option<icache::IrradianceCache>,
    radiance: Option<crate::integrator::radiance_cache::RadianceCache>,
    lifespans: super::temporal::Lifespans,
    chosen_rays: Option<usize>,
    camera: Option<crate::camera::Camera>,
    layers: Option<Vec<crate::io::output::Image>>,
    shaded_light: super::frame_pixels::ShadedLight,
    pixel_samples: Option<Vec<u32>>,
    mesh_spheres: Vec<Option<(glam::Vec3, f32)>>,
    photon_paths: Option<photon::MapPaths>,
    photon_log: Option<(photon::PathLog, (glam::Vec3, glam::Vec3))>,
    atlas: Option<AtlasBefore>,
    moving_window: Option<(crate::camera::Camera, super::tiles::Window)>,
}

impl Handoff {
    fn of(carry: Carry, scene: &Scene) -> Handoff {
        // The temporal cache's frames carry the atlas (see `render_frame`).
        let temporal = carry.photon_paths.is_some();
        let atlas = carry.photons.filter(|_| temporal).and_then(|p| {
            let (maps, atlas) = p.into_maps_and_atlas();
            let keys = carry
                .atlas_next
                .or_else(|| Some(PhotonKeys::of(maps.global.as_ref()?.photons())))?;
            Some(AtlasBefore {
                atlas: atlas?,
                keys,
            })
        });
        Handoff {
            photon_paths: carry.photon_paths,
            photon_log: carry.photon_log,
            atlas,
            cache: carry.cache,
            radiance: carry.radiance,
            lifespans: carry.lifespans,
            chosen_rays: carry.chosen_rays,
            camera: carry.camera,
            layers: carry.layers,
            shaded_light: carry.shaded_light,
            pixel_samples: carry.pixel_samples,
            mesh_spheres: (0..scene.mesh_ranges.len())
                .map(|m| scene.mesh_sphere(m))
                .collect(),
            moving_window: carry.moving_window,
        }
    }

    /// The carry of frame `f`, the first of `scene`, with what changed since frame `f − 1`.
    fn into_carry<'a>(self, anim: &Animation, scene: &Scene, f: u32) -> Carry<'a> {
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
        Carry {
            cache: self.cache,
            radiance: self.radiance,
            lifespans: self.lifespans,
            chosen_rays: self.chosen_rays,
            camera: self.camera,
            layers: self.layers,
            shaded_light: self.shaded_light,
            pixel_samples: self.pixel_samples,
            photon_paths: self.photon_paths,
            photon_log: self.photon_log,
            atlas_before: self.atlas,
            moving_window: self.moving_window,
            change: Some(super::temporal::SceneChange {
                moved,
                rigid,
                lights,
            }),
            ..Carry::default()
        }
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
