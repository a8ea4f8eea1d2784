//! What a frame reuses from the frames before: their records, updated where something changed and
//! fit for this view, and (while the camera stays) the pixels whose light did not change.

use super::*;

impl Sequence {
    /// The frame's records of the frames before ([`Self::earlier_records`]) in their parts (none
    /// without photon maps: the cache is dropped).
    pub(super) fn earlier(
        &mut self,
        scene: &Scene,
        plan: &mut Plan,
        moving: Option<Window>,
        light: Option<&FillLight>,
        cancel: &AtomicBool,
        frame: &mut FrameStats,
    ) -> Result<EarlierParts> {
        let earlier = match (self.cache.take(), light) {
            (Some(c), Some(light)) => {
                Some(self.earlier_records(scene, plan, moving, light, cancel, c, frame)?)
            }
            _ => None,
        };
        Ok(Earlier::parts(earlier))
    }

    /// The records of the frames before, for this frame: updated where a mesh or a light changed
    /// (the temporal cache), then made fit for this view when the camera moved. Where the camera
    /// stayed and a mesh moved, pass A visits only the window it changed, held finer.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn earlier_records(
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
                let ctx = crate::render::fill::fill_context(
                    scene,
                    plan,
                    *light,
                    Default::default(),
                    cancel,
                );
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
    pub(super) fn kept_pixels(
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
pub(super) struct Earlier {
    pub(super) cache: icache::IrradianceCache,
    pub(super) foreign: usize,
    pub(super) only: Option<Window>,
    pub(super) still_view: Option<StillView>,
}

/// Where the camera stayed and a mesh moved: what changed, the spheres where the cached light
/// changed, and how many records the frame before left.
pub(super) type StillView = (SceneChange, Vec<(Vec3, f32)>, usize);

/// The pixels a frame takes from the frame before, those it shades again with the samples they
/// took, the factor relighting each kept pixel's indirect light, and the samples each took.
pub(super) struct Kept {
    pub(super) keep: Vec<bool>,
    pub(super) repeat: Vec<bool>,
    pub(super) relight: Vec<Option<Vec3>>,
    pub(super) samples: Option<Vec<u32>>,
}

/// [`Earlier::parts`]: the records for the fill (with their count made for other views), the window
/// pass A visits, that count for shading, and what a still view's mesh change did.
pub(super) type EarlierParts = (
    Option<(icache::IrradianceCache, usize)>,
    Option<Window>,
    usize,
    Option<StillView>,
);

impl Earlier {
    /// The records and how many were made for other views (for the fill), the window pass A
    /// visits, that count again (for shading) and what a still view's mesh change did; all empty
    /// without records from the frames before.
    pub(super) fn parts(e: Option<Earlier>) -> EarlierParts {
        match e {
            Some(e) => (Some((e.cache, e.foreign)), e.only, e.foreign, e.still_view),
            None => (None, None, 0, None),
        }
    }
}

impl Kept {
    /// The pixels shading leaves alone: those `kept` keeps (none without it).
    pub(super) fn view(kept: Option<&Kept>) -> KeptPixels<'_> {
        KeptPixels {
            kept: kept.map(|k| &k.keep[..]),
            kept_samples: kept.and_then(|k| k.samples.as_deref()),
            repeat: kept.map(|k| &k.repeat[..]),
        }
    }

    /// Pastes the kept pixels of `before` (the frame before's layers) into `layers`, relit, with
    /// their samples, and counts them in `frame`.
    pub(super) fn paste(
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
pub(super) fn reused_image_stats(before: &RenderStats, f: u32) -> RenderStats {
    let after = before.frame.map_or(0, |fr| fr.n_records_after);
    RenderStats {
        setup: before.setup.clone(),
        cache: before.cache,
        frame: Some(FrameStats {
            frame: f,
            photons_reused: true,
            no_photon_maps: before.frame.is_some_and(|fr| fr.no_photon_maps),
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
        progressive: None,
        total_s: 0.0,
        write_outputs_s: None,
        peak_rss_bytes: before.peak_rss_bytes,
        crossings_given_up: 0,
    }
}
