//! A camera walk baked once (`--shared-bake`). When every frame of a sequence shares one scene (no
//! mesh moves and no light changes: only the camera), its photon maps are traced once and one
//! irradiance cache is filled by pass A over every frame's view in turn, each view adding records
//! only where those of the views before it do not reach — Radiance's shared ambient file, but made
//! in frame order, so that it is the same wherever it is made. Every frame is then shaded from that
//! bake alone (pass B, each record read only where it is in sight), so a frame is the same whichever
//! other frames are rendered, in whatever order, by whichever process: the command line's frames
//! and tiles and a farm's frame and tile tasks give the same pixels by construction.

use std::ops::RangeInclusive;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use gather::GatherParams;

use super::baked::{check_bakeable, render_baked_seen_by, shade_ready, Baked};
use super::files::FileOptions;
use super::fill::{fill_cache, CacheFill, FillLight};
use super::photons::{build_maps, trace_photons};
use super::stats::CacheFillStats;
use super::tiled::shade_tiles;
use super::{
    budget, interrupted, media_phase, plan, radiance_phase, Bake, FrameStats, Options,
    RenderOutput, RenderStats,
};
use crate::camera::Camera;
use crate::error::{option, Result};
use crate::integrator::pm::OtherViews;
use crate::photons::PhotonData;
use crate::progress::{NoProgress, Progress};
use crate::scene::{self, Animation, Method, Scene};

/// The option that asks for a shared bake, named in its refusals.
const OPTION: &str = "--shared-bake";

/// Bakes the walk `anim` once for every frame: its photon maps, and (for `pm`) one irradiance cache
/// filled over each frame's view in frame order. Refused where a frame moves a mesh or changes a
/// light, and for methods with nothing to bake.
pub fn bake_walk(
    anim: &Animation,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Baked, RenderStats)> {
    let start = Instant::now();
    if opts.chunk.is_some() {
        return Err(option(
            OPTION,
            "shades every frame apart from one bake: leave out --chunk",
        ));
    }
    let n = anim.frames();
    if let Some(f) = (1..n).find(|&f| anim.change(f - 1, f).scene) {
        return Err(option(
            OPTION,
            format!(
                "bakes a camera walk, whose frames share one scene, but frame {f} moves a mesh or \
                 changes a light: render this sequence without it"
            ),
        ));
    }
    let scene = scene::load_frame(anim, 0)?;
    super::progressive::refuse_in_bake(&scene, opts, OPTION)?;
    let cameras = (0..n)
        .map(|f| scene::frame_camera(anim, f))
        .collect::<Result<Vec<Camera>>>()?;
    let first = plan(&scene, opts, Some(&cameras[0]))?;
    check_bakeable(&first, opts)?;
    budget::check(&scene, &first, opts)?;
    let mut stats = RenderStats::new(&scene, &first);
    let files = FileOptions {
        keep_maps: true,
        ..opts.files.clone()
    };
    scene.place_eye(cameras[0].eye);
    let (traced, s) = trace_photons(
        &scene,
        &first,
        photon::Over::default(),
        &files,
        progress,
        cancel,
    )?;
    stats.photons = Some(s);
    let photons = build_maps(&scene, &first, traced.maps);
    interrupted(cancel)?;
    let media_cache = media_phase(&scene, &first, Some(&photons), &mut stats, progress, cancel)?;
    let mut radiance = radiance_phase(&scene, &first, &files, None);
    let cache = match first.method {
        Method::Pm => {
            let light = (&photons, media_cache.as_ref());
            let views = Views {
                scene: &scene,
                opts,
                cameras: &cameras,
            };
            let (fill, s, made) = views.fill(light, radiance.as_mut(), progress, cancel)?;
            stats.fill = Some(s);
            Some((fill, made))
        }
        _ => None,
    };
    let (cache, made) = cache.unzip();
    let bake = Bake {
        photons: Some(photons),
        photon_info: traced.info,
        media_cache,
        radiance,
        cache,
    };
    stats.finish(
        &scene,
        start,
        bake.photons.as_ref(),
        bake.media_cache.as_ref(),
        bake.cache.as_ref().map(|c| &c.cache),
        bake.radiance.as_ref(),
    );
    // Without a cache (pm-fg, photons) every frame's view made no record.
    let made = made.unwrap_or_else(|| vec![(0, 0); n as usize]);
    Ok((Baked::keep(&scene, first.method, bake, made)?, stats))
}

/// The records each frame's view made in a walk's cache: the first, and one past the last.
type ViewRecords = Vec<(u64, u64)>;

/// The frames' views of one scene, whose pass A fills one cache.
struct Views<'a> {
    scene: &'a Scene,
    opts: &'a Options,
    cameras: &'a [Camera],
}

impl Views<'_> {
    /// Pass A over each view in turn (a view like the one before it adds nothing), over the records
    /// of the views before, with the rays the first view chose; the fills' statistics summed, and the
    /// records each frame's view made (a frame whose view is the one before's, that view's).
    fn fill(
        &self,
        (photons, media_cache): (&PhotonData, Option<&icache::media::MediaCache>),
        mut radiance: Option<&mut crate::integrator::radiance_cache::RadianceCache>,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<(CacheFill, CacheFillStats, ViewRecords)> {
        let (scene, n) = (self.scene, self.cameras.len() as u64);
        progress.start("filling the cache over the frames' views", n);
        let mut fill: Option<CacheFill> = None;
        let mut total = CacheFillStats::default();
        let mut before: Option<&Camera> = None;
        let mut made: ViewRecords = Vec::with_capacity(self.cameras.len());
        for (f, cam) in self.cameras.iter().enumerate() {
            if let (Some(b), Some(&last)) = (before, made.last()) {
                if b.same_view(cam) {
                    made.push(last);
                    progress.set(f as u64 + 1);
                    continue;
                }
            }
            scene.place_eye(cam.eye);
            let mut plan = plan(scene, self.opts, Some(cam))?;
            let earlier = fill.take().map(|c| {
                // The views before chose the rays; their records may shrink for this view, as a
                // sequence's do (a view whose cover a shrink opened gets records in pass B).
                plan.choose_rays = false;
                if let Some(rays) = c.chosen_rays {
                    plan.gather = GatherParams { rays };
                }
                plan.pass_a_gaps_only = scene
                    .settings
                    .icache
                    .pass_a_gaps_only(plan.width, plan.height);
                let mut cache = c.cache;
                cache.thaw();
                let others = OtherViews {
                    fine: Some(fine_in(&plan)),
                    ..OtherViews::first(cache.len())
                };
                ((cache, others), c.chosen_rays)
            });
            if let (Some(r), Some(_)) = (radiance.as_deref_mut(), &earlier) {
                r.next_frame();
            }
            let light = FillLight {
                photons,
                media_cache,
                radiance: radiance.as_deref(),
            };
            let (records, chosen) = earlier.unzip();
            let had = records.as_ref().map_or(0, |(_, v)| v.below as u64);
            let (mut c, s) = fill_cache(scene, &plan, light, records, None, &NoProgress, cancel)?;
            made.push((had, c.cache.len() as u64));
            c.chosen_rays = chosen.flatten().or(c.chosen_rays);
            add_fill(&mut total, s);
            fill = Some(c);
            before = Some(cam);
            progress.set(f as u64 + 1);
        }
        progress.finish();
        // Each view's pass A ended a stage; pass B's first round reads every view's records.
        if let Some(c) = &mut fill {
            c.cache.one_stage();
        }
        // A walk has one frame or more.
        fill.map(|c| (c, total, made))
            .ok_or_else(|| option(OPTION, "the walk has no frame"))
    }
}

/// The view of `plan`, and the most of its pixels another view's record may span in it: the cache's
/// largest spacing (twice it with adaptive caching, which grows records up to that).
pub(super) fn fine_in(plan: &super::Plan) -> (crate::camera::PixelSpan, f32) {
    let p = &plan.cache;
    let most = p.max_spacing_px * if p.adaptive.is_some() { 2.0 } else { 1.0 };
    (plan.camera.pixel_span(), most)
}

/// `s` (one view's fill) added to `total`.
fn add_fill(total: &mut CacheFillStats, s: CacheFillStats) {
    total.time_s = Some(total.time_s.unwrap_or(0.0) + s.time_s.unwrap_or(0.0));
    total.one_pass |= s.one_pass;
    total.fill += s.fill;
    total.counters += s.counters;
    total.rays_choice = total.rays_choice.or(s.rays_choice);
}

/// Frame `f` of the walk `anim` (`scene` is its scene: any frame's) shaded from `baked`, the walk's
/// bake, as one image or as `tiles` bands of rows shaded apart.
#[allow(clippy::too_many_arguments)]
pub fn render_walk_frame(
    anim: &Animation,
    scene: &Scene,
    baked: &Baked,
    f: u32,
    tiles: Option<u32>,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    if baked.views() != anim.frames() {
        return Err(option(
            OPTION,
            format!(
                "the bake covers {} view(s), not this walk's {} frames: bake the walk itself",
                baked.views(),
                anim.frames()
            ),
        ));
    }
    let camera = scene::frame_camera(anim, f)?;
    scene.place_eye(camera.eye);
    let (out, mut stats) = match tiles {
        Some(n) => {
            let tiles = (n, None);
            let view = Some((&camera, f));
            shade_tiles(scene, opts, Some(baked), view, tiles, progress, cancel)?
        }
        None => render_baked_seen_by(scene, opts, baked, Some((&camera, f)), progress, cancel)?,
    };
    stats.frame = Some(frame_stats(f));
    Ok((out, stats))
}

/// The walk's frames `frames`, each shaded from one bake of the walk and handed to `on_frame` (the
/// caller writes it); `tiles` shades each frame as that many bands of rows. The bake is read back
/// once for every frame (its maps built, its cache loaded), as each frame of a farm reads it.
pub fn render_walk(
    anim: &Animation,
    frames: RangeInclusive<u32>,
    opts: &Options,
    tiles: Option<u32>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
    on_frame: &mut dyn FnMut(u32, &Scene, &RenderOutput, &RenderStats) -> Result<()>,
) -> Result<()> {
    let (baked, _) = bake_walk(anim, opts, progress, cancel)?;
    let scene = scene::load_frame(anim, *frames.start())?;
    let first = scene::frame_camera(anim, *frames.start())?;
    let plan_first = plan(&scene, opts, Some(&first))?;
    budget::check(&scene, &plan_first, opts)?;
    // Tiles read the bake once a tile, as a farm's tile tasks do.
    let mut ready = match tiles {
        None => Some(baked.ready(&scene, &plan_first, cancel)?),
        Some(_) => None,
    };
    for f in frames {
        let (out, stats) = match &mut ready {
            None => render_walk_frame(anim, &scene, &baked, f, tiles, opts, progress, cancel)?,
            Some(r) => {
                let start = Instant::now();
                let camera = scene::frame_camera(anim, f)?;
                scene.place_eye(camera.eye);
                let plan = plan(&scene, opts, Some(&camera))?;
                let (out, mut stats) =
                    shade_ready(&scene, &plan, &baked, r, Some(f), start, progress, cancel)?;
                stats.frame = Some(frame_stats(f));
                (out, stats)
            }
        };
        on_frame(f, &scene, &out, &stats)?;
    }
    Ok(())
}

/// A walk's frame's line of the statistics: its number, its photons read from the bake.
fn frame_stats(f: u32) -> FrameStats {
    FrameStats {
        frame: f,
        photons_reused: true,
        ..Default::default()
    }
}
