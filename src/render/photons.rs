//! The photon phases of every method but `path`: `trace_photons` (both maps, their kd-trees built by
//! the photon pass) or `load_photons` from a file, then `build_maps` (what shading reads besides the
//! maps: the caustic map's reach grid, the irradiance atlas that fills lazily during the render).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use photon::{MapsInfo, PhotonMaps, PrecomputedIrradiance};

use super::files::{self, FileOptions};
use super::stats::PhotonStats;
use super::Plan;
use crate::error::Result;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::Scene;

/// Photon maps traced or loaded.
pub struct Maps {
    pub maps: PhotonMaps,
    /// Precomputed irradiance points from a file of an earlier version, kept for `--save-photons` (the
    /// render reads the atlas).
    pub precomputed: Option<PrecomputedIrradiance>,
    /// There when the maps were traced and `--save-photons` or `--dump-photons` asks for them.
    pub info: Option<MapsInfo>,
}

/// The maps to the plan's targets, or over the paths `paths` of a sequence's first frame took.
pub fn trace_photons(
    scene: &Scene,
    plan: &Plan,
    paths: Option<photon::MapPaths>,
    files: &FileOptions,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Maps, PhotonStats)> {
    let t = Instant::now();
    let settings = &plan.photons;
    progress.start(
        "photons",
        (settings.global + settings.caustic + settings.volume + settings.volume_caustic) as u64,
    );
    let (maps, trace) = PhotonData::trace(
        scene,
        settings,
        paths,
        plan.seed,
        &|done, _| progress.set(done),
        cancel,
    )?;
    progress.finish();
    let time_s = t.elapsed().as_secs_f64();
    let keep = files.save_photons.is_some() || files.dump_photons.is_some();
    let info = keep.then(|| {
        MapsInfo::new(
            scene.fingerprint,
            plan.seed,
            PhotonData::targets(settings),
            &trace,
        )
    });
    let stats = photon_stats(plan, time_s, false, trace, None);
    Ok((
        Maps {
            maps,
            precomputed: None,
            info,
        },
        stats,
    ))
}

/// The maps of a `--save-photons` file of the same scene, instead of `trace_photons`.
pub fn load_photons(scene: &Scene, plan: &Plan, path: &Path) -> Result<(Maps, PhotonStats)> {
    let t = Instant::now();
    let loaded = files::load_photons(path, scene)?;
    let time_s = t.elapsed().as_secs_f64();
    let m = &loaded.maps;
    let (global, caustic, volume, volume_caustic) = (
        m.global.as_ref(),
        m.caustic.as_ref(),
        m.volume.as_ref(),
        m.volume_caustic.as_ref(),
    );
    let len = |m: Option<&photon::PhotonMap>| m.map_or(0, |m| m.len() as u64);
    let bytes = |m: Option<&photon::PhotonMap>| m.map_or(0, |m| m.memory_bytes() as u64);
    let trace = photon::TraceStats {
        n_paths_emitted: loaded.info.n_paths_emitted,
        n_global_paths: loaded.info.n_global_paths,
        n_caustic_paths: loaded.info.n_caustic_paths,
        n_volume_paths: loaded.info.n_volume_paths,
        n_volume_caustic_paths: loaded.info.n_volume_caustic_paths,
        n_global_stored: len(global),
        n_caustic_stored: len(caustic),
        n_volume_stored: len(volume),
        n_volume_caustic_stored: len(volume_caustic),
        global_memory_bytes: bytes(global),
        caustic_memory_bytes: bytes(caustic),
        volume_memory_bytes: bytes(volume),
        volume_caustic_memory_bytes: bytes(volume_caustic),
        ..Default::default()
    };
    let precomputed = loaded
        .precomputed
        .as_ref()
        .map(|p| (p.points().len() as u64, p.memory_bytes() as u64));
    let stats = photon_stats(plan, time_s, true, trace, precomputed);
    Ok((
        Maps {
            maps: loaded.maps,
            precomputed: loaded.precomputed,
            info: None,
        },
        stats,
    ))
}

fn photon_stats(
    plan: &Plan,
    time_s: f64,
    loaded: bool,
    trace: photon::TraceStats,
    precomputed: Option<(u64, u64)>,
) -> PhotonStats {
    let s = &plan.photons;
    PhotonStats {
        time_s,
        loaded,
        trace,
        precomputed,
        lookup: s.lookup,
        max_radius_global: s.max_radius_global,
        max_radius_caustic: s.max_radius_caustic,
        max_radius_volume: s.max_radius_volume,
    }
}

/// The maps wrapped for the render (see [`PhotonData::new`]); nothing here is counted.
pub fn build_maps<'a>(scene: &'a Scene, plan: &Plan, maps: PhotonMaps) -> PhotonData<'a> {
    PhotonData::new(maps, plan.photons.clone(), scene)
}
