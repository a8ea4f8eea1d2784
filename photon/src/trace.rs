//! Photon emission and tracing: paths leave the lights, bounce with Russian roulette, and leave photons
//! in the global map (every non-specular hit) and the caustic map (first non-specular hit of an
//! L S+ D path).
//!
//! Determinism: path `i` draws its numbers from `halton(i, dim, seed)` for the first `HALTON_DIMS`
//! dimensions (emission 0..5, then 4 per bounce: 3 for `scatter`, 1 for roulette) and from
//! `Rng::new(hash_keys(&[seed, i]))` beyond. Paths run in parallel in fixed-size batches and are merged
//! in path order; each map takes whole paths until it holds its target, so the maps are a function of
//! `(scene, targets, seed)` only, whatever the thread count.
#![forbid(unsafe_code)]

use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::map::{Photon, PhotonMap};
use crate::pathlog::{LoggedPath, PathLog, Reuse, ESCAPE_LENGTH};
use crate::sampling::{halton, hash_keys, Rng};

/// Bounces after which a path is cut (its remaining power is lost; counted in the stats).
pub const MAX_DEPTH: u32 = 64;
/// Dimensions taken from the Halton sequence: emission (5) and the first two bounces (4 each).
pub(crate) const HALTON_DIMS: usize = 13;
/// Paths per batch: the granularity at which the driver checks the targets and reports progress.
const BATCH_PATHS: u64 = 16_384;
/// Paths per parallel work item.
const CHUNK_PATHS: u64 = 256;

/// What the photon pass needs from a scene; the root crate implements it.
pub trait PhotonScene: Sync {
    /// One photon path leaving the lights, chosen in proportion to emitted power. `u` are 5 numbers
    /// in [0,1). Returns origin, unit direction and the path's power (W) divided by its sampling pdf,
    /// so that the mean over N paths of `power` is the scene's total emitted power.
    fn emit(&self, u: [f32; 5]) -> Option<EmittedRay>;
    /// Closest surface hit along a ray.
    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit>;
    /// Samples the continuation at a hit; `wo` points away from the surface toward where the photon
    /// came from.
    fn scatter(&self, hit: &SurfaceHit, wo: Vec3, u: [f32; 3]) -> Scatter;
    /// Whether any surface is specular (mirror/glass); if false the caustic map is never built.
    fn has_specular(&self) -> bool;
    /// Whether the ray from `origin` along `dir` crosses a specular surface anywhere along it (a false
    /// `true` costs nothing but time; a false `false` would lose caustic photons). A path that only the
    /// caustic map still wants and whose first ray reaches no specular surface can store nothing, and
    /// is not traced.
    fn may_reach_specular(&self, _origin: Vec3, _dir: Vec3) -> bool {
        true
    }
    /// Whether photons fly through participating media ([`propagate`](Self::propagate)); without, a
    /// path draws exactly the numbers it always drew.
    fn has_media(&self) -> bool {
        false
    }
    /// The next event of a photon leaving `origin` along `dir` in `medium`: a scattering event in the
    /// medium, or the next surface (invisible medium boundaries crossed, the medium updated), with the
    /// free flight's throughput weight and ratios for distances sampled in channel `hero` (0..3; see
    /// [`Propagation`]). `u` are 2 numbers in [0,1). Called only when `has_media`.
    fn propagate(
        &self,
        origin: Vec3,
        dir: Vec3,
        medium: u16,
        _hero: usize,
        _u: [f32; 2],
    ) -> Propagation {
        match self.intersect(origin, dir) {
            Some(hit) => Propagation::Surface {
                hit,
                weight: Vec3::ONE,
                ratio: Vec3::ONE,
                medium,
            },
            None => Propagation::Escaped,
        }
    }
    /// The medium a photon leaving `hit` along `dir` travels in, when it arrived in `current`.
    fn medium_after(&self, _hit: &SurfaceHit, _dir: Vec3, current: u16) -> u16 {
        current
    }
    /// A new direction after scattering in `medium` (travelling along `dir` before), sampled exactly by
    /// the phase function.
    fn scatter_in_medium(&self, dir: Vec3, _medium: u16, _u: [f32; 2]) -> Vec3 {
        dir
    }
}

/// Where a photon's free flight ended (see [`PhotonScene::propagate`]). Distances are sampled in the
/// path's hero channel: `weight` is each channel's throughput over the hero's pdf, `ratio` each
/// channel's pdf of the same flight over the hero's (all ones in clear space or grey media). A photon
/// path's power is its throughput over the mean of its ratios' products (one-sample MIS over the hero
/// channels, pbrt-v4's spectral MIS).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Propagation {
    Escaped,
    /// At a surface, reached in `medium`.
    Surface {
        hit: SurfaceHit,
        weight: Vec3,
        ratio: Vec3,
        medium: u16,
    },
    /// At a scattering event at `pos` in `medium`; `weight` includes the scattering albedo.
    Medium {
        pos: Vec3,
        weight: Vec3,
        ratio: Vec3,
        medium: u16,
    },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmittedRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub power: Vec3,
    /// The medium the light sits in (`u16::MAX`: none).
    pub medium: u16,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    pub pos: Vec3,
    /// Shading normal, flipped toward the incoming ray.
    pub normal: Vec3,
    pub specular: bool,
    pub material: u32,
    pub prim: u32,
    pub uv: Vec2,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scatter {
    Absorbed,
    /// `origin` is already offset (safe to trace from); `weight` is f·cos/pdf.
    Continue {
        origin: Vec3,
        dir: Vec3,
        weight: Vec3,
    },
}

/// Photons to store per map, and the number of paths after which the pass gives up. A map takes whole
/// paths, so it may end up to `MAX_DEPTH − 1` photons over its target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PhotonTargets {
    pub global: usize,
    pub caustic: usize,
    /// Photons stored at scattering events in media (0: no volume map).
    pub volume: usize,
    /// Volume photons of L S+ V paths (the volume caustic map; 0: none, as without specular surfaces).
    pub volume_caustic: usize,
    pub max_paths: u64,
}

/// The two maps; `None` when not wanted (target 0, no specular surface) or, for caustics, when no
/// caustic photon was stored.
#[derive(Default)]
pub struct PhotonMaps {
    pub global: Option<PhotonMap>,
    pub caustic: Option<PhotonMap>,
    /// Photons at scattering events in participating media (Jensen & Christensen 1998); only for
    /// scenes with media. Surface normals are zero.
    pub volume: Option<PhotonMap>,
    /// Volume photons whose path met only specular surfaces before (L S+ V: the beam a glass sphere
    /// focuses into fog), traced to a target of their own like the caustic map.
    pub volume_caustic: Option<PhotonMap>,
}

pmbase::summable! {
    #[derive(Clone, Debug, Default, PartialEq)]
    pub struct TraceStats {
        pub n_paths_emitted: u64,
        /// Paths over which each map's power is normalised (emitted while the map was filling).
        pub n_global_paths: u64,
        pub n_caustic_paths: u64,
        pub n_global_stored: u64,
        pub n_caustic_stored: u64,
        pub n_volume_paths: u64,
        pub n_volume_stored: u64,
        pub n_volume_caustic_paths: u64,
        pub n_volume_caustic_stored: u64,
        /// Paths abandoned on a non-finite or negative power, direction or hit (should stay ~0).
        pub n_paths_dropped: u64,
        /// Paths copied from an earlier trace's log, not traced ([`retrace_photons`]).
        pub n_paths_copied: u64,
        /// Paths cut at [`MAX_DEPTH`].
        pub n_paths_depth_capped: u64,
        /// 1 when the caustic map stopped short of its target at `CAUSTIC_PATH_BUDGET`.
        pub n_caustic_cut: u64,
        /// 1 when the global or the volume map stopped short of its target at `MEDIA_PATH_BUDGET`.
        pub n_media_cut: u64,
        pub trace_s: f64,
        pub global_build_s: f64,
        pub caustic_build_s: f64,
        pub volume_build_s: f64,
        pub global_memory_bytes: u64,
        pub caustic_memory_bytes: u64,
        pub volume_memory_bytes: u64,
        pub volume_caustic_memory_bytes: u64,
    }
}

/// Traces photon paths until each wanted map holds its target (or `max_paths` is reached), then builds
/// the kd-trees. `progress(stored, target)` is called after every batch, summed over both maps. Stops
/// with [`Error::Cancelled`] soon after `cancel` is set: it is read before every chunk of `CHUNK_PATHS`
/// paths and before each kd-tree build.
pub fn trace_photons_cancellable<S: PhotonScene + ?Sized>(
    scene: &S,
    targets: &PhotonTargets,
    seed: u64,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(PhotonMaps, TraceStats)> {
    trace(scene, targets, None, seed, progress, cancel).map(|(maps, stats, _)| (maps, stats))
}

/// How a trace goes: to the targets, or over the paths of an earlier one ([`retrace_photons`]) —
/// copying, with `reuse`, the paths nothing that moved touched — and whether it keeps a [`PathLog`].
#[derive(Clone, Copy, Default)]
pub struct Over<'a> {
    pub paths: Option<MapPaths>,
    pub reuse: Option<Reuse<'a>>,
    pub log: bool,
}

/// The paths each map of a trace took ([`TraceStats`]'s `n_*_paths`): given to [`retrace_photons`],
/// a later trace takes exactly as many per map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapPaths {
    pub global: u64,
    pub caustic: u64,
    pub volume: u64,
    pub volume_caustic: u64,
}

impl MapPaths {
    pub fn of(stats: &TraceStats) -> MapPaths {
        MapPaths {
            global: stats.n_global_paths,
            caustic: stats.n_caustic_paths,
            volume: stats.n_volume_paths,
            volume_caustic: stats.n_volume_caustic_paths,
        }
    }
}

/// [`trace_photons_cancellable`] over the paths of an earlier trace: each wanted map takes exactly
/// `paths`' count of paths whatever it stores, and its power is normalised by that count. A path
/// that meets nothing that changed since then leaves bit for bit the photons it left then, so an
/// animation's frames differ only where something moved (with photon targets, every map's count —
/// and so every photon's power — would shift a little from frame to frame).
///
/// With `over.reuse`, a path the log holds whose segments nothing touched is copied, not traced: the
/// same photons, bit for bit, as tracing it would give. With `over.log` the trace returns its own
/// log for the next. Without `over.paths` the maps fill to their targets, as
/// [`trace_photons_cancellable`]'s.
pub fn retrace_photons<S: PhotonScene + ?Sized>(
    scene: &S,
    targets: &PhotonTargets,
    over: Over,
    seed: u64,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(PhotonMaps, TraceStats, Option<PathLog>)> {
    trace(scene, targets, Some(over), seed, progress, cancel)
}

fn trace<S: PhotonScene + ?Sized>(
    scene: &S,
    targets: &PhotonTargets,
    over: Option<Over>,
    seed: u64,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(PhotonMaps, TraceStats, Option<PathLog>)> {
    let start = Instant::now();
    let over = over.unwrap_or_default();
    let fixed = over.paths;
    let mut log = over.log.then(PathLog::default);
    let mut maps = Fillings::new(scene, targets, fixed);
    let mut stats = TraceStats::default();
    let mut next_path = 0u64;
    let max_paths = fixed.map_or(targets.max_paths, |p| {
        p.global.max(p.caustic).max(p.volume).max(p.volume_caustic)
    });
    while maps.any_active() && next_path < max_paths {
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Cancelled);
        }
        let n_batch = BATCH_PATHS.min(max_paths - next_path);
        let batch = next_path..next_path + n_batch;
        let chunks = trace_batch(scene, batch, seed, maps.want(), over.reuse, cancel);
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Cancelled);
        }
        for chunk in &chunks {
            maps.take_chunk(chunk, &mut next_path, &mut stats, log.as_mut());
            if !maps.any_active() {
                break;
            }
        }
        let stored = maps.n_stored();
        progress(stored, maps.n_target());
        if stored == 0 && next_path >= GIVE_UP_EMPTY_PATHS {
            break; // nothing reaches a non-specular surface: more paths will not change that
        }
    }
    stats.n_paths_emitted = next_path;
    stats.trace_s = start.elapsed().as_secs_f64();
    if maps.global.target > 0 && maps.global.photons.is_empty() {
        return Err(Error::NothingStored {
            n_paths_emitted: next_path,
        });
    }
    let (maps, stats) = maps.build(next_path, stats, cancel)?;
    Ok((maps, stats, log))
}

/// The paths `batch` traced in parallel chunks of `CHUNK_PATHS`, in path order; empty chunks once
/// `cancel` is set.
fn trace_batch<S: PhotonScene + ?Sized>(
    scene: &S,
    batch: Range<u64>,
    seed: u64,
    want: Want,
    reuse: Option<Reuse>,
    cancel: &AtomicBool,
) -> Vec<ChunkOut> {
    let n_batch = batch.end - batch.start;
    (0..n_batch.div_ceil(CHUNK_PATHS) as usize)
        .into_par_iter()
        .with_max_len(1)
        .map(|c| {
            if cancel.load(Ordering::Relaxed) {
                return ChunkOut::default();
            }
            let first = batch.start + c as u64 * CHUNK_PATHS;
            let end = (first + CHUNK_PATHS).min(batch.end);
            trace_chunk(scene, first..end, seed, want, reuse)
        })
        .collect()
}

/// The four maps while they fill.
struct Fillings {
    global: Filling,
    caustic: Filling,
    volume: Filling,
    volume_caustic: Filling,
}

impl Fillings {
    /// Maps for `targets`, those the scene cannot make (caustics without specular surfaces, volume
    /// maps without media) with a target of 0; with `fixed`, each takes that many paths instead.
    fn new<S: PhotonScene + ?Sized>(
        scene: &S,
        targets: &PhotonTargets,
        fixed: Option<MapPaths>,
    ) -> Fillings {
        let caustic_target = if scene.has_specular() {
            targets.caustic
        } else {
            0
        };
        let volume = |target| if scene.has_media() { target } else { 0 };
        let volume_caustic = if scene.has_media() && scene.has_specular() {
            targets.volume_caustic
        } else {
            0
        };
        let paths = |f: fn(&MapPaths) -> u64| fixed.as_ref().map(f);
        Fillings {
            global: Filling::new(targets.global, paths(|p| p.global)),
            caustic: Filling::new(caustic_target, paths(|p| p.caustic)),
            volume: Filling::new(volume(targets.volume), paths(|p| p.volume)),
            volume_caustic: Filling::new(volume_caustic, paths(|p| p.volume_caustic)),
        }
    }

    fn fixed(&self) -> bool {
        self.global.fixed.is_some()
    }

    fn any_active(&self) -> bool {
        self.global.active
            || self.caustic.active
            || self.volume.active
            || self.volume_caustic.active
    }

    fn want(&self) -> Want {
        Want {
            global: self.global.active,
            caustic: self.caustic.active,
            volume: self.volume.active,
            volume_caustic: self.volume_caustic.active,
        }
    }

    fn n_stored(&self) -> u64 {
        (self.global.photons.len()
            + self.caustic.photons.len()
            + self.volume.photons.len()
            + self.volume_caustic.photons.len()) as u64
    }

    fn n_target(&self) -> u64 {
        (self.global.target + self.caustic.target + self.volume.target + self.volume_caustic.target)
            as u64
    }

    /// Takes the chunk's paths, numbered from `next_path` on, one by one until every map is full,
    /// stopping the maps whose path budget runs out.
    fn take_chunk(
        &mut self,
        chunk: &ChunkOut,
        next_path: &mut u64,
        stats: &mut TraceStats,
        log: Option<&mut PathLog>,
    ) {
        let mut log = log;
        for j in 0..chunk.ends.len() {
            let path = *next_path;
            *next_path += 1;
            let (g0, c0, v0, w0) = if j == 0 {
                (0, 0, 0, 0)
            } else {
                chunk.ends[j - 1]
            };
            let (g1, c1, v1, w1) = chunk.ends[j];
            if let Some(log) = log.as_deref_mut() {
                let s0 = if j == 0 { 0 } else { chunk.segment_ends[j - 1] };
                log.push(LoggedPath {
                    segments: &chunk.segments[s0..chunk.segment_ends[j]],
                    photons: [
                        &chunk.global[g0..g1],
                        &chunk.caustic[c0..c1],
                        &chunk.volume[v0..v1],
                        &chunk.volume_caustic[w0..w1],
                    ],
                    want: chunk.want.bits(),
                    end: chunk.end_kinds[j] as u8,
                });
            }
            stats.n_paths_copied += chunk.copied[j] as u64;
            self.global.take(&chunk.global[g0..g1], path);
            self.caustic.take(&chunk.caustic[c0..c1], path);
            self.volume.take(&chunk.volume[v0..v1], path);
            self.volume_caustic
                .take(&chunk.volume_caustic[w0..w1], path);
            self.apply_budgets(path, stats);
            match chunk.end_kinds[j] {
                PathEnd::Dropped => stats.n_paths_dropped += 1,
                PathEnd::DepthCapped => stats.n_paths_depth_capped += 1,
                PathEnd::Done => {}
            }
            if !self.any_active() {
                break;
            }
        }
    }

    /// Stops the maps that have had their path budget by `path`.
    fn apply_budgets(&mut self, path: u64, stats: &mut TraceStats) {
        if self.fixed() {
            return;
        }
        // Where little light reaches specular surfaces, the caustic map would keep emission going
        // for a long time for a dim effect: it gets CAUSTIC_PATH_BUDGET × the paths the global
        // map needed (at least CAUSTIC_MIN_PATHS), normalised by the paths emitted while it filled.
        if let (false, true, Some(g)) =
            (self.global.active, self.caustic.active, self.global.n_paths)
        {
            if path + 1 >= g.saturating_mul(CAUSTIC_PATH_BUDGET).max(CAUSTIC_MIN_PATHS) {
                self.caustic.active = false;
                self.caustic.n_paths = Some(path + 1);
                stats.n_caustic_cut = 1;
            }
        }
        // The volume caustic map likewise, against the volume map.
        if let (false, true, Some(v)) = (
            self.volume.active,
            self.volume_caustic.active,
            self.volume.n_paths,
        ) {
            if path + 1 >= v.saturating_mul(CAUSTIC_PATH_BUDGET).max(CAUSTIC_MIN_PATHS) {
                self.volume_caustic.active = false;
                self.volume_caustic.n_paths = Some(path + 1);
            }
        }
        // With media, a map that fills slowly next to the other (a dense fog that photons seldom
        // cross to a surface, or a thin one they seldom scatter in) gets MEDIA_PATH_BUDGET × the
        // paths the other needed, at least MEDIA_MIN_PATHS.
        stats.n_media_cut += media_cut(&self.global, &mut self.volume, path)
            + media_cut(&self.volume, &mut self.global, path);
    }

    /// The maps, their powers normalised over the `n_paths_emitted` paths and their kd-trees built
    /// (unless `cancel` is set), with `stats` completed.
    fn build(
        self,
        n_paths_emitted: u64,
        mut stats: TraceStats,
        cancel: &AtomicBool,
    ) -> Result<(PhotonMaps, TraceStats)> {
        let (global, n_global_paths) = self.global.finish(n_paths_emitted);
        let (caustic, n_caustic_paths) = self.caustic.finish(n_paths_emitted);
        let (volume, n_volume_paths) = self.volume.finish(n_paths_emitted);
        let (volume_caustic, n_volume_caustic_paths) = self.volume_caustic.finish(n_paths_emitted);
        stats.n_volume_caustic_paths = n_volume_caustic_paths;
        stats.n_volume_caustic_stored = volume_caustic.as_ref().map_or(0, |p| p.len() as u64);
        stats.n_volume_paths = n_volume_paths;
        stats.n_volume_stored = volume.as_ref().map_or(0, |p| p.len() as u64);
        stats.n_global_paths = n_global_paths;
        stats.n_caustic_paths = n_caustic_paths;
        stats.n_global_stored = global.as_ref().map_or(0, |p| p.len() as u64);
        stats.n_caustic_stored = caustic.as_ref().map_or(0, |p| p.len() as u64);
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Cancelled);
        }
        let (global, caustic) = rayon::join(|| build_map(global), || build_map(caustic));
        let (global, global_build_s) = global?;
        let (caustic, caustic_build_s) = caustic?;
        stats.global_build_s = global_build_s;
        stats.caustic_build_s = caustic_build_s;
        stats.global_memory_bytes = global.as_ref().map_or(0, |m| m.memory_bytes() as u64);
        stats.caustic_memory_bytes = caustic.as_ref().map_or(0, |m| m.memory_bytes() as u64);
        let (volume, volume_build_s) = build_map(volume)?;
        let (volume_caustic, volume_caustic_build_s) = build_map(volume_caustic)?;
        stats.volume_build_s = volume_build_s + volume_caustic_build_s;
        stats.volume_memory_bytes = volume.as_ref().map_or(0, |m| m.memory_bytes() as u64);
        stats.volume_caustic_memory_bytes = volume_caustic
            .as_ref()
            .map_or(0, |m| m.memory_bytes() as u64);
        Ok((
            PhotonMaps {
                global,
                caustic,
                volume,
                volume_caustic,
            },
            stats,
        ))
    }
}

fn build_map(photons: Option<Vec<Photon>>) -> Result<(Option<PhotonMap>, f64)> {
    let start = Instant::now();
    let map = photons.map(PhotonMap::new).transpose()?;
    Ok((map, start.elapsed().as_secs_f64()))
}

/// Paths after which a pass that has stored nothing at all stops (`NothingStored`).
pub(crate) const GIVE_UP_EMPTY_PATHS: u64 = 200_000;

/// Stops `b` (returns 1) when `a` is full and `b` has had its media path budget by `path`.
fn media_cut(a: &Filling, b: &mut Filling, path: u64) -> u64 {
    match (a.active, b.active, a.n_paths) {
        (false, true, Some(n))
            if path + 1 >= n.saturating_mul(MEDIA_PATH_BUDGET).max(MEDIA_MIN_PATHS) =>
        {
            b.active = false;
            b.n_paths = Some(path + 1);
            1
        }
        _ => 0,
    }
}

/// In scenes with media: paths the global or the volume map may take once the other is full, as a
/// multiple of the paths that filled it …
pub(crate) const MEDIA_PATH_BUDGET: u64 = 10;
/// … but never fewer than this many.
pub(crate) const MEDIA_MIN_PATHS: u64 = 200_000;

/// Paths the caustic map may take, as a multiple of the paths that filled the global map …
pub(crate) const CAUSTIC_PATH_BUDGET: u64 = 10;
/// … but never fewer than this many.
pub(crate) const CAUSTIC_MIN_PATHS: u64 = 2_000_000;

/// A map while it fills: it takes whole paths until it holds `target` photons.
struct Filling {
    photons: Vec<Photon>,
    target: usize,
    active: bool,
    /// Paths emitted while filling; set when the target is reached.
    n_paths: Option<u64>,
    /// Paths to take whatever is stored ([`retrace_photons`]), instead of filling to `target`.
    fixed: Option<u64>,
}

impl Filling {
    fn new(target: usize, fixed: Option<u64>) -> Filling {
        Filling {
            photons: Vec::new(),
            target,
            active: target > 0 && fixed != Some(0),
            n_paths: None,
            fixed,
        }
    }

    fn take(&mut self, path_photons: &[Photon], path: u64) {
        if !self.active {
            return;
        }
        self.photons.extend_from_slice(path_photons);
        let full = match self.fixed {
            Some(n) => path + 1 >= n,
            None => self.photons.len() >= self.target,
        };
        if full {
            self.active = false;
            self.n_paths = Some(path + 1);
        }
    }

    /// The photons with power divided by the paths emitted while filling; `None` if none was stored.
    fn finish(self, n_paths_emitted: u64) -> (Option<Vec<Photon>>, u64) {
        let n_paths = self.n_paths.unwrap_or(n_paths_emitted);
        if self.photons.is_empty() {
            return (None, n_paths);
        }
        let scale = 1.0 / n_paths as f64;
        let mut photons = self.photons;
        for ph in &mut photons {
            ph.power = (ph.power.as_dvec3() * scale).as_vec3();
        }
        (Some(photons), n_paths)
    }
}

#[derive(Clone, Copy, Default)]
struct Want {
    global: bool,
    caustic: bool,
    volume: bool,
    volume_caustic: bool,
}

impl Want {
    fn bits(self) -> u8 {
        self.global as u8
            | (self.caustic as u8) << 1
            | (self.volume as u8) << 2
            | (self.volume_caustic as u8) << 3
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum PathEnd {
    Done,
    Dropped,
    DepthCapped,
}

impl PathEnd {
    fn of(code: u8) -> PathEnd {
        match code {
            1 => PathEnd::Dropped,
            2 => PathEnd::DepthCapped,
            _ => PathEnd::Done,
        }
    }
}

/// Photons of consecutive paths; `ends[j]` = (global, caustic, volume, volume caustic) lengths after
/// path j, `segment_ends[j]` its segments' end, `copied[j]` whether it came from a [`Reuse`]'s log.
#[derive(Default)]
struct ChunkOut {
    global: Vec<Photon>,
    caustic: Vec<Photon>,
    volume: Vec<Photon>,
    volume_caustic: Vec<Photon>,
    ends: Vec<(usize, usize, usize, usize)>,
    end_kinds: Vec<PathEnd>,
    segments: Vec<[Vec3; 2]>,
    segment_ends: Vec<usize>,
    copied: Vec<bool>,
    want: Want,
}

fn trace_chunk<S: PhotonScene + ?Sized>(
    scene: &S,
    paths: std::ops::Range<u64>,
    seed: u64,
    want: Want,
    reuse: Option<Reuse>,
) -> ChunkOut {
    let mut out = ChunkOut {
        want,
        ..ChunkOut::default()
    };
    for i in paths {
        let (g, c, v, w) = (
            out.global.len(),
            out.caustic.len(),
            out.volume.len(),
            out.volume_caustic.len(),
        );
        let logged = reuse.and_then(|r| {
            let path = r.log.path(i)?;
            let untouched =
                path.want == want.bits() && !path.segments.iter().any(|&[a, b]| (r.touched)(a, b));
            untouched.then_some(path)
        });
        let copied = logged.is_some();
        let end = match logged {
            Some(path) => {
                out.global.extend_from_slice(path.photons[0]);
                out.caustic.extend_from_slice(path.photons[1]);
                out.volume.extend_from_slice(path.photons[2]);
                out.volume_caustic.extend_from_slice(path.photons[3]);
                out.segments.extend_from_slice(path.segments);
                PathEnd::of(path.end)
            }
            None => {
                let mut sampler = PathSampler {
                    index: i,
                    seed,
                    dim: 0,
                    rng: None,
                };
                trace_path(scene, &mut sampler, want, &mut out)
            }
        };
        if end == PathEnd::Dropped {
            // A path that went bad leaves nothing behind.
            out.global.truncate(g);
            out.caustic.truncate(c);
            out.volume.truncate(v);
            out.volume_caustic.truncate(w);
        }
        out.ends.push((
            out.global.len(),
            out.caustic.len(),
            out.volume.len(),
            out.volume_caustic.len(),
        ));
        out.end_kinds.push(end);
        out.segment_ends.push(out.segments.len());
        out.copied.push(copied);
    }
    out
}

/// The numbers of one path, by dimension.
struct PathSampler {
    index: u64,
    seed: u64,
    dim: usize,
    rng: Option<Rng>,
}

impl PathSampler {
    fn next(&mut self) -> f32 {
        let dim = self.dim;
        self.dim += 1;
        if dim < HALTON_DIMS {
            halton(self.index, dim, self.seed)
        } else {
            let (seed, index) = (self.seed, self.index);
            self.rng
                .get_or_insert_with(|| Rng::new(hash_keys(&[seed, index])))
                .uniform()
        }
    }
}

fn valid_power(power: Vec3) -> bool {
    power.is_finite() && power.min_element() >= 0.0
}

/// Stores a photon met at a diffuse surface or in a medium (`in_medium`) in its map, and in that map's
/// caustic one when the path met only specular surfaces before (`caustic`). Whether the path still
/// has something to store: after this event no photon of it can be a caustic one.
fn store(out: &mut ChunkOut, want: Want, photon: Photon, caustic: bool, in_medium: bool) -> bool {
    let (map, wanted, caustic_map, caustic_wanted) = if in_medium {
        (
            &mut out.volume,
            want.volume,
            &mut out.volume_caustic,
            want.volume_caustic,
        )
    } else {
        (&mut out.global, want.global, &mut out.caustic, want.caustic)
    };
    if wanted {
        map.push(photon);
    }
    if caustic_wanted && caustic {
        caustic_map.push(photon);
    }
    want.global || want.volume
}

fn trace_path<S: PhotonScene + ?Sized>(
    scene: &S,
    s: &mut PathSampler,
    want: Want,
    out: &mut ChunkOut,
) -> PathEnd {
    let u = [s.next(), s.next(), s.next(), s.next(), s.next()];
    let Some(ray) = scene.emit(u) else {
        return PathEnd::Done;
    };
    if !valid_power(ray.power) || !ray.origin.is_finite() || !ray.dir.is_finite() {
        return PathEnd::Dropped;
    }
    let media = scene.has_media();
    // Only the caustic maps still filling (surface and volume): a path whose first event is not a
    // specular hit stores nothing (one that scatters in a medium before its first surface is no L S+
    // path either). In a scene whose light reaches little glass, most paths are such.
    let caustic_only = !want.global && !want.volume && (want.caustic || want.volume_caustic);
    if caustic_only && !scene.may_reach_specular(ray.origin, ray.dir) {
        out.segments
            .push([ray.origin, ray.origin + ray.dir * ESCAPE_LENGTH]);
        return PathEnd::Done;
    }
    let (mut origin, mut dir, mut power, mut medium) = (ray.origin, ray.dir, ray.power, ray.medium);
    // With media: the hero channel distances are sampled in, and the product of the flights' pdf
    // ratios; the photon's power is `power / mean(ratios)` (see [`Propagation`]).
    let hero = if media {
        ((s.next() * 3.0) as usize).min(2)
    } else {
        0
    };
    let mut ratios = Vec3::ONE;
    let mis = |power: Vec3, ratios: Vec3| {
        let m = (ratios.x + ratios.y + ratios.z) / 3.0;
        if m > 0.0 {
            power / m
        } else {
            Vec3::ZERO
        }
    };
    let mut any_specular = false;
    let mut any_diffuse = false;
    for _ in 0..MAX_DEPTH {
        let event = if media {
            scene.propagate(origin, dir, medium, hero, [s.next(), s.next()])
        } else {
            match scene.intersect(origin, dir) {
                Some(hit) => Propagation::Surface {
                    hit,
                    weight: Vec3::ONE,
                    ratio: Vec3::ONE,
                    medium,
                },
                None => Propagation::Escaped,
            }
        };
        out.segments.push([
            origin,
            match &event {
                Propagation::Escaped => origin + dir * ESCAPE_LENGTH,
                Propagation::Surface { hit, .. } => hit.pos,
                Propagation::Medium { pos, .. } => *pos,
            },
        ]);
        let hit = match event {
            Propagation::Escaped => return PathEnd::Done,
            Propagation::Surface {
                hit,
                weight,
                ratio,
                medium: m,
            } => {
                power *= weight;
                ratios *= ratio;
                medium = m;
                hit
            }
            Propagation::Medium {
                pos,
                weight,
                ratio,
                medium: m,
            } => {
                // Stored with the power it scatters (× albedo): the volume estimate is then σs·Li.
                let before = mis(power, ratios);
                let (scattered, r) = (power * weight, ratios * ratio);
                let stored = mis(scattered, r);
                if !valid_power(stored) || !pos.is_finite() {
                    return PathEnd::Dropped;
                }
                let photon = Photon {
                    pos,
                    wi: -dir,
                    power: stored,
                    normal: Vec3::ZERO,
                    indirect: any_diffuse,
                    direct: !any_diffuse && !any_specular,
                };
                let go_on = store(out, want, photon, any_specular && !any_diffuse, true);
                any_diffuse = true;
                if !go_on {
                    return PathEnd::Done;
                }
                let (u, u_roulette) = ([s.next(), s.next()], s.next());
                // Roulette on the MIS-weighted power's change (the same whichever the hero channel).
                let survive = (stored.max_element() / before.max_element()).min(1.0);
                if survive.is_nan() || survive <= 0.0 || u_roulette >= survive {
                    return PathEnd::Done;
                }
                (power, ratios) = (scattered / survive, r);
                dir = scene.scatter_in_medium(dir, m, u);
                origin = pos;
                medium = m;
                continue;
            }
        };
        let power_here = mis(power, ratios);
        if !hit.pos.is_finite() || !hit.normal.is_finite() {
            return PathEnd::Dropped;
        }
        let wo = -dir;
        if !hit.specular {
            if !valid_power(power_here) {
                return PathEnd::Dropped;
            }
            let photon = Photon {
                pos: hit.pos,
                wi: wo,
                power: power_here,
                normal: hit.normal,
                indirect: any_diffuse,
                direct: !any_diffuse && !any_specular,
            };
            let go_on = store(out, want, photon, any_specular && !any_diffuse, false);
            any_diffuse = true;
            if !go_on {
                return PathEnd::Done;
            }
        }
        let u = [s.next(), s.next(), s.next()];
        let u_roulette = s.next();
        let Scatter::Continue {
            origin: o,
            dir: d,
            weight,
        } = scene.scatter(&hit, wo, u)
        else {
            return PathEnd::Done;
        };
        // Specular bounces follow the scene's own (Fresnel) choice; roulette acts at diffuse ones.
        let survive = if hit.specular {
            1.0
        } else {
            weight.max_element().min(1.0)
        };
        if survive.is_nan() || survive <= 0.0 || u_roulette >= survive {
            return PathEnd::Done;
        }
        any_specular |= hit.specular;
        power *= weight / survive;
        if !valid_power(power) || !o.is_finite() || !d.is_finite() {
            return PathEnd::Dropped;
        }
        if media {
            medium = scene.medium_after(&hit, d, medium);
        }
        (origin, dir) = (o, d);
    }
    PathEnd::DepthCapped
}
