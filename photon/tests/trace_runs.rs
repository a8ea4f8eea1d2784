//! The tracer's contract: identical maps whatever the thread count, exact targets, errors instead of
//! hangs when light reaches no diffuse surface.

mod common;

use common::*;
use glam::Vec3;
use photon::trace::MAX_DEPTH;
use photon::{trace_photons_cancellable, Error, PhotonMaps, PhotonTargets, TraceStats};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

fn run(scene: &PlaneScene, targets: PhotonTargets, threads: usize) -> (PhotonMaps, TraceStats) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        trace_photons_cancellable(scene, &targets, 11, &|_, _| {}, &AtomicBool::new(false)).unwrap()
    })
}

#[test]
fn maps_are_identical_with_one_and_two_threads() {
    let scene = mirror_wall();
    let targets = PhotonTargets {
        global: 30_000,
        caustic: 5_000,
        volume: 0,
        volume_caustic: 0,
        max_paths: 10_000_000,
    };
    let (a, sa) = run(&scene, targets, 1);
    let (b, sb) = run(&scene, targets, 2);
    for (x, y) in [(&a.global, &b.global), (&a.caustic, &b.caustic)] {
        let (x, y) = (x.as_ref().unwrap(), y.as_ref().unwrap());
        assert_eq!(x.photons(), y.photons());
    }
    assert_eq!(
        (
            sa.n_paths_emitted,
            sa.n_global_paths,
            sa.n_caustic_paths,
            sa.n_global_stored,
            sa.n_caustic_stored
        ),
        (
            sb.n_paths_emitted,
            sb.n_global_paths,
            sb.n_caustic_paths,
            sb.n_global_stored,
            sb.n_caustic_stored
        )
    );
}

#[test]
fn maps_stop_at_the_path_that_reaches_the_target() {
    let scene = mirror_wall();
    let small = PhotonTargets {
        global: 12_345,
        caustic: 0,
        volume: 0,
        volume_caustic: 0,
        max_paths: 10_000_000,
    };
    let (maps, stats) = run(&scene, small, 2);
    assert!(maps.caustic.is_none());
    let n = stats.n_global_stored;
    assert!((12_345..12_345 + MAX_DEPTH as u64).contains(&n), "{n}");
    assert_eq!(stats.n_global_paths, stats.n_paths_emitted);
    // A larger target traces the same first paths: the smaller map is a prefix of the larger one,
    // with powers rescaled by the ratio of path counts.
    let (big, big_stats) = run(
        &scene,
        PhotonTargets {
            global: 40_000,
            ..small
        },
        2,
    );
    let big = big.global.unwrap();
    let scale = big_stats.n_global_paths as f32 / stats.n_global_paths as f32;
    for (p, q) in maps.global.unwrap().photons().iter().zip(big.photons()) {
        assert_eq!(p.pos, q.pos);
        assert!((p.power - q.power * scale).abs().max_element() <= 1e-5 * p.power.max_element());
    }
}

#[test]
fn no_diffuse_surface_is_an_error_not_a_hang() {
    let mut scene = mirror_wall();
    scene.planes.remove(0); // only the mirror is left
    let targets = PhotonTargets {
        global: 1_000,
        caustic: 1_000,
        volume: 0,
        volume_caustic: 0,
        max_paths: 50_000,
    };
    let calls = AtomicU64::new(0);
    let result = trace_photons_cancellable(
        &scene,
        &targets,
        0,
        &|stored, target| {
            assert_eq!((stored, target), (0, 2_000));
            calls.fetch_add(1, Ordering::Relaxed);
        },
        &AtomicBool::new(false),
    );
    assert!(
        matches!(
            result,
            Err(Error::NothingStored {
                n_paths_emitted: 50_000
            })
        ),
        "{:?}",
        result.err()
    );
    assert!(calls.load(Ordering::Relaxed) >= 1);
}

#[test]
fn a_mirror_the_light_cannot_reach_gives_no_caustic_map() {
    let mut scene = mirror_wall();
    // The mirror moves under the (black) floor, which shields it from the light.
    let under_floor = |p: Vec3| p.x < 0.9;
    scene.planes[1] = Plane {
        point: Vec3::new(0.0, 0.0, -5.0),
        normal: Vec3::Z,
        contains: under_floor,
        mirror: true,
        reflectance: 1.0,
    };
    scene.planes[0].reflectance = 0.0;
    let targets = PhotonTargets {
        global: 1_000,
        caustic: 1_000,
        volume: 0,
        volume_caustic: 0,
        max_paths: 100_000,
    };
    let (maps, stats) =
        trace_photons_cancellable(&scene, &targets, 0, &|_, _| {}, &AtomicBool::new(false))
            .unwrap();
    assert!(maps.global.is_some());
    assert!(maps.caustic.is_none());
    assert_eq!(stats.n_caustic_stored, 0);
    assert_eq!(stats.n_paths_emitted, 100_000);
}

/// The scene, with `may_reach_specular` answered exactly (whether the ray crosses a mirror anywhere),
/// counting the rays the tracer casts.
struct Culled<'a> {
    scene: &'a PlaneScene,
    rays: AtomicU64,
}

impl photon::PhotonScene for Culled<'_> {
    fn emit(&self, u: [f32; 5]) -> Option<photon::EmittedRay> {
        self.scene.emit(u)
    }
    fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<photon::SurfaceHit> {
        self.rays.fetch_add(1, Ordering::Relaxed);
        self.scene.intersect(origin, dir)
    }
    fn scatter(&self, hit: &photon::SurfaceHit, wo: Vec3, u: [f32; 3]) -> photon::Scatter {
        self.scene.scatter(hit, wo, u)
    }
    fn has_specular(&self) -> bool {
        self.scene.has_specular()
    }
    fn may_reach_specular(&self, origin: Vec3, dir: Vec3) -> bool {
        self.scene.planes.iter().filter(|pl| pl.mirror).any(|pl| {
            let t = (pl.point - origin).dot(pl.normal) / dir.dot(pl.normal);
            t > 0.0 && (pl.contains)(origin + t * dir)
        })
    }
}

#[test]
fn caustic_only_paths_that_miss_every_mirror_are_not_traced_and_change_nothing() {
    let scene = mirror_wall();
    // The global map fills first; the caustic map's remaining paths are caustic-only.
    let targets = PhotonTargets {
        global: 2_000,
        caustic: 20_000,
        volume: 0,
        volume_caustic: 0,
        max_paths: 10_000_000,
    };
    let (all, sa) =
        trace_photons_cancellable(&scene, &targets, 5, &|_, _| {}, &AtomicBool::new(false))
            .unwrap();
    let culled = Culled {
        scene: &scene,
        rays: AtomicU64::new(0),
    };
    let (some, sb) =
        trace_photons_cancellable(&culled, &targets, 5, &|_, _| {}, &AtomicBool::new(false))
            .unwrap();
    assert_eq!(
        all.caustic.as_ref().unwrap().photons(),
        some.caustic.as_ref().unwrap().photons()
    );
    assert_eq!(
        all.global.as_ref().unwrap().photons(),
        some.global.as_ref().unwrap().photons()
    );
    assert_eq!(
        (sa.n_paths_emitted, sa.n_caustic_paths, sa.n_caustic_stored),
        (sb.n_paths_emitted, sb.n_caustic_paths, sb.n_caustic_stored)
    );
    assert!(
        sa.n_paths_emitted > 4 * sa.n_global_paths,
        "caustic-only paths: {} of {}",
        sa.n_paths_emitted - sa.n_global_paths,
        sa.n_paths_emitted
    );
    // Fewer rays than paths: most caustic-only paths left the light away from the mirror.
    let rays = culled.rays.load(Ordering::Relaxed);
    assert!(
        rays < sb.n_paths_emitted,
        "{rays} rays for {} paths",
        sb.n_paths_emitted
    );
}

#[test]
fn a_retrace_over_the_same_paths_gives_the_same_photons_whatever_the_targets() {
    let scene = mirror_wall();
    let targets = retrace_targets();
    let (a, sa) = run(&scene, targets, 2);
    // Other targets, the same paths: each map takes exactly the paths it took, bit for bit.
    let other = PhotonTargets {
        global: 5,
        caustic: 50_000_000,
        ..targets
    };
    let (b, sb) = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| {
            let over = photon::Over {
                paths: Some(photon::MapPaths::of(&sa)),
                ..Default::default()
            };
            let (maps, stats, _) = photon::retrace_photons(
                &scene,
                &other,
                over,
                11,
                &|_, _| {},
                &AtomicBool::new(false),
            )
            .unwrap();
            (maps, stats)
        });
    assert_eq!(photon::MapPaths::of(&sb), photon::MapPaths::of(&sa));
    assert!(sa.n_global_paths != sa.n_caustic_paths, "{sa:?}");
    for (x, y) in [(&a.global, &b.global), (&a.caustic, &b.caustic)] {
        assert_eq!(x.as_ref().unwrap().photons(), y.as_ref().unwrap().photons());
    }
}

#[test]
fn paths_copied_from_a_log_are_the_paths_traced_again() {
    let scene = mirror_wall();
    let targets = retrace_targets();
    let cancel = AtomicBool::new(false);
    let first = photon::Over {
        log: true,
        ..Default::default()
    };
    let (a, sa, log) =
        photon::retrace_photons(&scene, &targets, first, 11, &|_, _| {}, &cancel).unwrap();
    let log = log.unwrap();
    assert_eq!(log.len() as u64, sa.n_paths_emitted);
    // Segments on one side of the scene "moved": those paths are traced, the others copied; the
    // scene did not change, so either way the photons are the same.
    for (touched, copied) in [
        (
            &(|_: Vec3, _: Vec3| false) as &(dyn Fn(Vec3, Vec3) -> bool + Sync),
            true,
        ),
        (&|a: Vec3, b: Vec3| a.x > 0.0 || b.x > 0.0, false),
        (&|_: Vec3, _: Vec3| true, false),
    ] {
        let over = photon::Over {
            paths: Some(photon::MapPaths::of(&sa)),
            reuse: Some(photon::Reuse { log: &log, touched }),
            log: true,
        };
        let (b, sb, next) =
            photon::retrace_photons(&scene, &targets, over, 11, &|_, _| {}, &cancel).unwrap();
        for (x, y) in [(&a.global, &b.global), (&a.caustic, &b.caustic)] {
            assert_eq!(x.as_ref().unwrap().photons(), y.as_ref().unwrap().photons());
        }
        assert_eq!(next.unwrap().len(), log.len());
        if copied {
            assert_eq!(sb.n_paths_copied, sb.n_paths_emitted);
        } else {
            assert!(sb.n_paths_copied < sb.n_paths_emitted, "{sb:?}");
        }
    }
}

/// The photon targets of the retrace tests: both maps, the caustic one filling over fewer paths.
fn retrace_targets() -> PhotonTargets {
    PhotonTargets {
        global: 20_000,
        caustic: 3_000,
        volume: 0,
        volume_caustic: 0,
        max_paths: 10_000_000,
    }
}
