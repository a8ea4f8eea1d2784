//! A sequence's photon maps: traced over the first frame's paths, copying those nothing that moved
//! touched, with the atlas texels carried from the scene before.

use super::*;

impl Sequence {
    /// A frame's photon maps: over the paths the sequence's first frame took (the temporal cache's
    /// frames; `pm-fg` and `photons` render each frame as a still), copying the paths nothing that
    /// moved touched, and with the atlas texels carried from the scene before.
    pub(super) fn frame_photons<'a>(
        &mut self,
        scene: &'a Scene,
        plan: &Plan,
        opts: &Options,
        stats: &mut RenderStats,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<PhotonData<'a>> {
        let temporal = plan.method == Method::Pm;
        let (mut traced, mut s) = match &opts.files.load_photons {
            Some(file) => load_photons(scene, plan, file)?,
            None => self.trace_over_paths(scene, plan, temporal, opts, progress, cancel)?,
        };
        // The first frame's paths may store far fewer (or more) photons in this frame's scene — a
        // fog box moving away from its light: a map at a fraction of a still's density, its noise
        // several times a still's. Such a frame is traced as a still is, and the frames after it
        // take its paths.
        if let Some(first) = self.photon_stored.filter(|_| temporal) {
            if !density_holds(first, stored(&s.trace)) {
                let over = photon::Over {
                    log: true,
                    ..Default::default()
                };
                (traced, s) = trace_photons(scene, plan, over, &opts.files, progress, cancel)?;
                self.photon_paths = None;
            }
        }
        self.photon_log = traced.log.map(|log| (log, scene.bounds));
        if temporal && self.photon_paths.is_none() {
            self.photon_paths = Some(photon::MapPaths::of(&s.trace));
            self.photon_stored = Some(stored(&s.trace));
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
    pub(super) fn trace_over_paths(
        &self,
        scene: &Scene,
        plan: &Plan,
        temporal: bool,
        opts: &Options,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<(crate::render::photons::Maps, PhotonStats)> {
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
}

/// Photons stored per map: global, caustic, volume, volume caustic.
fn stored(t: &photon::TraceStats) -> [u64; 4] {
    [
        t.n_global_stored,
        t.n_caustic_stored,
        t.n_volume_stored,
        t.n_volume_caustic_stored,
    ]
}

/// Whether each map a frame stored is within a factor of two of what the first frame's paths
/// stored (maps of fewer than [`DENSITY_FLOOR`] photons at the first frame are not judged).
fn density_holds(first: [u64; 4], now: [u64; 4]) -> bool {
    first
        .iter()
        .zip(now)
        .all(|(&a, b)| a < DENSITY_FLOOR || (b.saturating_mul(2) >= a && b <= a.saturating_mul(2)))
}

/// Below this many photons a map's count says too little to judge its density by.
const DENSITY_FLOOR: u64 = 1000;
