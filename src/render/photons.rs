//! The photon phases of every method but `path`: `trace_photons` (both maps, their kd-trees built by
//! the photon pass) or `load_photons` from a file, then `build_maps` (what shading reads besides the
//! maps: the caustic map's reach grid, the irradiance atlas that fills lazily during the render).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use photon::{MapsInfo, PhotonMaps};

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
    /// There when the maps were traced and `--save-photons` or `--dump-photons` asks for them.
    pub info: Option<MapsInfo>,
    /// The trace's paths, when asked for (an animation's next frame copies those nothing touched).
    pub log: Option<photon::PathLog>,
}

/// The maps to the plan's targets, or as `over` says (a sequence's frame: see [`PhotonData::trace`]).
pub fn trace_photons(
    scene: &Scene,
    plan: &Plan,
    over: photon::Over,
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
    let (maps, trace, log) = PhotonData::trace(
        scene,
        settings,
        over,
        plan.seed,
        &|done, _| progress.set(done),
        cancel,
    )?;
    progress.finish();
    let time_s = t.elapsed().as_secs_f64();
    let keep = files.keeps_maps();
    let info = keep.then(|| {
        MapsInfo::new(
            scene.fingerprint,
            plan.seed,
            PhotonData::targets(settings),
            &trace,
        )
    });
    let stats = photon_stats(plan, time_s, false, trace);
    Ok((Maps { maps, info, log }, stats))
}

/// The maps of a `--save-photons` file of the same scene, instead of `trace_photons`.
pub fn load_photons(scene: &Scene, plan: &Plan, path: &Path) -> Result<(Maps, PhotonStats)> {
    let t = Instant::now();
    let loaded = files::load_photons(path, scene)?;
    Ok(loaded_photons(plan, loaded, t))
}

/// Maps read from a file or a bake (since `start`), with their statistics.
pub(crate) fn loaded_photons(
    plan: &Plan,
    loaded: photon::LoadedMaps,
    start: Instant,
) -> (Maps, PhotonStats) {
    let time_s = start.elapsed().as_secs_f64();
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
    let stats = photon_stats(plan, time_s, true, trace);
    (
        Maps {
            maps: loaded.maps,
            info: None,
            log: None,
        },
        stats,
    )
}

fn photon_stats(plan: &Plan, time_s: f64, loaded: bool, trace: photon::TraceStats) -> PhotonStats {
    let s = &plan.photons;
    PhotonStats {
        time_s,
        loaded,
        trace,
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

/// anim-ball's animation and the scenes of its frames `a` and `b` (tests of what a frame takes from
/// the one before).
#[cfg(test)]
pub(super) fn anim_ball_frames(a: u32, b: u32) -> (crate::scene::Animation, Scene, Scene) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let anim = crate::scene::load_animation(&root.join("scenes/anim-ball.toml"))
        .unwrap()
        .unwrap();
    let (before, after) = (
        crate::scene::load_frame(&anim, a).unwrap(),
        crate::scene::load_frame(&anim, b).unwrap(),
    );
    (anim, before, after)
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicBool;

    use crate::photons::{PhotonData, PhotonSettings};

    /// anim-ball's frames 10 and 11: the ball moved a step. Frame 11 traced over frame 10's paths,
    /// copying those whose segments pass the ball's spheres (before and after) by, equals frame 11
    /// traced in full over the same paths, photon for photon; and most paths are copied.
    #[test]
    fn copied_paths_give_the_photons_a_full_retrace_gives() {
        let (anim, before, after) = super::anim_ball_frames(10, 11);
        let settings = PhotonSettings::resolve(&before);
        let cancel = AtomicBool::new(false);
        let first = photon::Over {
            log: true,
            ..Default::default()
        };
        let (_, s0, log) =
            PhotonData::trace(&before, &settings, first, 0, &|_, _| {}, &cancel).unwrap();
        let paths = photon::MapPaths::of(&s0);
        let spheres: Vec<(glam::Vec3, f32)> = anim
            .moved_meshes(10, 11)
            .into_iter()
            .flat_map(|m| [before.mesh_sphere(m), after.mesh_sphere(m)])
            .flatten()
            .collect();
        assert_eq!(spheres.len(), 2);
        let touched = |a: glam::Vec3, b: glam::Vec3| {
            spheres
                .iter()
                .any(|&(c, r)| photon::pathlog::segment_meets_sphere(a, b, c, r * 1.001))
        };
        let log = log.unwrap();
        let reuse = photon::Over {
            paths: Some(paths),
            reuse: Some(photon::Reuse {
                log: &log,
                touched: &touched,
            }),
            log: false,
        };
        let full = photon::Over {
            paths: Some(paths),
            ..Default::default()
        };
        let (copied, sc, _) =
            PhotonData::trace(&after, &settings, reuse, 0, &|_, _| {}, &cancel).unwrap();
        let (traced, st, _) =
            PhotonData::trace(&after, &settings, full, 0, &|_, _| {}, &cancel).unwrap();
        assert_eq!(
            copied.global.as_ref().unwrap().photons(),
            traced.global.as_ref().unwrap().photons()
        );
        assert_eq!(
            (sc.n_paths_emitted, st.n_paths_copied),
            (st.n_paths_emitted, 0)
        );
        assert!(
            sc.n_paths_copied > sc.n_paths_emitted * 3 / 4,
            "{} of {} paths copied",
            sc.n_paths_copied,
            sc.n_paths_emitted
        );
    }
}
