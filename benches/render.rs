//! `make bench`: throughput figures measured in one run and printed (never asserted).
//! Embree primary and incoherent rays/s on the shipped caustic scene and on Sibenik, the path tracer's
//! samples/s, and the ratios between them.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use glam::Vec3;
use photon::sampling::{hash_keys, Rng};
use pmrender::render::{render, NoProgress, Options};
use pmrender::scene::{self, Method, Scene};
use pmrender::warp::uniform_sphere;
use rayon::prelude::*;

fn primary_rays_per_s(scene: &Scene, size: u32) -> f64 {
    let cam = scene.camera.with_resolution(size, size);
    let t = Instant::now();
    let hits: u64 = (0..size)
        .into_par_iter()
        .map(|y| {
            (0..size)
                .filter(|&x| {
                    scene
                        .intersect(cam.eye, cam.ray(x as f32 + 0.5, y as f32 + 0.5))
                        .is_some()
                })
                .count() as u64
        })
        .sum();
    std::hint::black_box(hits);
    (size as f64 * size as f64) / t.elapsed().as_secs_f64()
}

/// Rays from random points on visible surfaces in uniformly random directions.
fn incoherent_rays_per_s(scene: &Scene, n: usize) -> f64 {
    let cam = scene.camera.with_resolution(256, 256);
    let origins: Vec<(pmrender::geometry::Hit, Vec3)> = (0..4096u64)
        .filter_map(|i| {
            let mut rng = Rng::new(hash_keys(&[7, i]));
            let d = cam.ray(rng.uniform() * 256.0, rng.uniform() * 256.0);
            scene.intersect(cam.eye, d).map(|h| (h, d))
        })
        .collect();
    if origins.is_empty() {
        return 0.0;
    }
    let t = Instant::now();
    let hits: u64 = (0..n as u64)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::new(hash_keys(&[9, i]));
            let (h, _) = &origins[(i as usize) % origins.len()];
            let dir = uniform_sphere([rng.uniform(), rng.uniform()]);
            scene
                .intersect(pmrender::geometry::spawn(h, dir), dir)
                .is_some() as u64
        })
        .sum();
    std::hint::black_box(hits);
    n as f64 / t.elapsed().as_secs_f64()
}

fn path_samples_per_s(scene: &Scene, size: u32, spp: u32) -> (f64, f64) {
    let opts = Options {
        method: Some(Method::Path),
        spp: Some(spp),
        width: Some(size),
        height: Some(size),
        ..Default::default()
    };
    let t = Instant::now();
    let (_, stats) = render(scene, &opts, &NoProgress, &AtomicBool::new(false)).expect("render");
    let s = t.elapsed().as_secs_f64();
    let rays = stats.report().to_json()["rays"]["per_s"]
        .as_f64()
        .unwrap_or(0.0);
    ((size * size * spp) as f64 / s, rays)
}

/// Our `pm` time against our `path` time at equal error (relMSE vs the Mitsuba reference) on the caustic
/// scene: path's spp doubles until its error is at most pm's.
fn pm_vs_path_at_equal_error(root: &Path) {
    let scene = match scene::load(&root.join("scenes/cornell-caustics.toml")) {
        Ok(s) => s,
        Err(e) => return println!("pm vs path: skipped ({e})"),
    };
    let reference = match pmrender::io::output::read_layer(
        &root.join("tests/reference/cornell-caustics-path.exr"),
        None,
    ) {
        Ok(r) => r,
        Err(e) => return println!("pm vs path: skipped ({e})"),
    };
    let run = |method: Method, spp: Option<u32>| {
        let opts = Options {
            method: Some(method),
            spp,
            width: Some(reference.width),
            height: Some(reference.height),
            ..Default::default()
        };
        let t = Instant::now();
        let (out, _) = render(&scene, &opts, &NoProgress, &AtomicBool::new(false)).expect("render");
        (
            t.elapsed().as_secs_f64(),
            pmrender::converge::rel_mse(&out.beauty, &reference),
        )
    };
    let (t_pm, e_pm) = run(Method::Pm, None);
    let mut spp = 64;
    loop {
        let (t_path, e_path) = run(Method::Path, Some(spp));
        if e_path <= e_pm || spp >= 16384 {
            println!(
                "cornell-caustics {}×{}: pm (defaults) relMSE {e_pm:.5} in {t_pm:.2} s; path reaches {e_path:.5} at {spp} spp in {t_path:.2} s; time ratio pm/path {:.3}",
                reference.width,
                reference.height,
                t_pm / t_path
            );
            break;
        }
        spp *= 2;
    }
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes = [
        (
            "cornell-caustics",
            root.join("scenes/cornell-caustics.toml"),
        ),
        ("sibenik", root.join("tests/scenes/sibenik.toml")),
    ];
    println!("machine: {} threads", rayon::current_num_threads());
    println!(
        "{:<18} {:>10} {:>14} {:>14} {:>14} {:>14} {:>10}",
        "scene",
        "triangles",
        "primary Mray/s",
        "incoh. Mray/s",
        "path kspp/s",
        "path Mray/s",
        "path/raw"
    );
    for (name, path) in scenes {
        let t = Instant::now();
        let scene = match scene::load(&path) {
            Ok(s) => s,
            Err(e) => {
                println!("{name}: skipped ({e})");
                continue;
            }
        };
        let load_s = t.elapsed().as_secs_f64();
        let primary = primary_rays_per_s(&scene, 1000);
        let incoherent = incoherent_rays_per_s(&scene, 2_000_000);
        let (spp_s, path_rays) = path_samples_per_s(&scene, 256, 8);
        println!(
            "{:<18} {:>10} {:>14.2} {:>14.2} {:>14.1} {:>14.2} {:>10.2}   (load {:.2} s)",
            name,
            scene.geometry.triangles.len(),
            primary / 1e6,
            incoherent / 1e6,
            spp_s / 1e3,
            path_rays / 1e6,
            path_rays / incoherent,
            load_s
        );
    }
    pm_vs_path_at_equal_error(root);
}
