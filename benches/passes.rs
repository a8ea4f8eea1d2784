//! `make bench`, second part: the photon pass and the cached final gather, with the raw rates they
//! should be compared with — photons traced/s, FLANN k-NN queries/s (single and batched), memory per
//! million photons; `pm` on Sibenik and Sponza at 1000² (wall time, records, rays/s vs raw Embree rays/s)
//! and on the caustic scene at 512². Printed, never asserted.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use glam::Vec3;
use photon::sampling::Rng;
use photon::KdTree;
use pmrender::integrator::photons::{PhotonData, PhotonSettings};
use pmrender::render::{render, NoProgress, Options};
use pmrender::scene::{self, Method};
use rayon::prelude::*;

fn flann_rates() {
    let n = 1_000_000;
    let mut rng = Rng::new(1);
    let pts: Vec<Vec3> = (0..n).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())).collect();
    let t = Instant::now();
    let tree = KdTree::build(&pts).expect("tree");
    let build_s = t.elapsed().as_secs_f64();
    let queries: Vec<Vec3> = (0..200_000).map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())).collect();
    println!("FLANN single kd-tree, 1 M uniform points: build {:.2} s", build_s);
    let t = Instant::now();
    let found: usize = queries
        .par_chunks(500)
        .map(|chunk| {
            let mut out = Vec::new();
            tree.nearest_batch(chunk, &mut out);
            out.iter().flatten().count()
        })
        .sum();
    std::hint::black_box(found);
    println!("  1-NN in FLANN batches of 500 (one C call each, as the final gather does): {:>8.2} M/s", queries.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
    for k in [1usize, 8, 100] {
        let q = if k == 100 { &queries[..40_000] } else { &queries[..] };
        let t = Instant::now();
        let found: usize = q
            .par_iter()
            .map_init(Vec::new, |out, &p| {
                tree.knn(p, k, 0.2, out);
                out.len()
            })
            .sum();
        let single = q.len() as f64 / t.elapsed().as_secs_f64();
        let t = Instant::now();
        let batched: usize = tree.knn_batch(q, k, 0.2).iter().map(Vec::len).sum();
        let batch = q.len() as f64 / t.elapsed().as_secs_f64();
        assert_eq!(found, batched);
        println!("  k = {k:>3}: single queries {:>8.2} M/s, batched {:>8.2} M/s", single / 1e6, batch / 1e6);
    }
}

fn photon_rates(root: &Path) {
    let scene = scene::load(&root.join("scenes/cornell-caustics.toml")).expect("scene");
    let mut settings = PhotonSettings::resolve(&scene).expect("settings");
    settings.global = 1_000_000;
    settings.caustic = 200_000;
    let t = Instant::now();
    let (maps, stats) = PhotonData::trace(&scene, &settings, 0, &|_, _| {}, &AtomicBool::new(false)).expect("photons");
    let s = t.elapsed().as_secs_f64();
    let stored = stats.n_global_stored + stats.n_caustic_stored;
    let mem = stats.global_memory_bytes + stats.caustic_memory_bytes;
    println!(
        "photon pass (cornell-caustics, 1 M global + 200 k caustic): {:.2} s, {:.2} M paths/s, {:.2} M photons stored/s, kd-tree build {:.2} s, {:.1} MiB per million photons",
        s,
        stats.n_paths_emitted as f64 / stats.trace_s / 1e6,
        stored as f64 / stats.trace_s / 1e6,
        stats.global_build_s + stats.caustic_build_s,
        mem as f64 / (stored as f64 / 1e6) / (1 << 20) as f64
    );
    drop(maps);
}

fn pm_scene(name: &str, path: &Path, size: u32) {
    let scene = match scene::load(path) {
        Ok(s) => s,
        Err(e) => return println!("{name}: skipped ({e})"),
    };
    let opts = Options { method: Some(Method::Pm), spp: Some(1), width: Some(size), height: Some(size), ..Default::default() };
    let t = Instant::now();
    let (_, report) = render(&scene, &opts, &NoProgress, &AtomicBool::new(false)).expect("render");
    let wall = t.elapsed().as_secs_f64();
    let j = report.to_json();
    let f = |a: &str, b: &str| j[a][b].as_f64().unwrap_or(f64::NAN);
    // Raw Embree rate: incoherent rays from camera hits, as in the `render` bench.
    let cam = scene.camera.with_resolution(256, 256);
    let n = 1_000_000u64;
    let t = Instant::now();
    let hits: u64 = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut rng = Rng::new(i);
            let d = cam.ray(rng.uniform() * 256.0, rng.uniform() * 256.0);
            match scene.intersect(cam.eye, d) {
                Some(h) => {
                    let dir = pmrender::warp::uniform_sphere([rng.uniform(), rng.uniform()]);
                    scene.intersect(pmrender::geometry::spawn(&h, dir), dir).is_some() as u64
                }
                None => 0,
            }
        })
        .sum();
    std::hint::black_box(hits);
    let raw = 2.0 * n as f64 / t.elapsed().as_secs_f64();
    let rays = f("rays", "total");
    println!(
        "{name:<18} {size}²  wall {wall:>7.2} s (photons {:.2} s, cache fill {:.2} s, shade {:.2} s)  records {:>7}  pass-B misses {:>5}  gather rays {:>6.2} M  rays/s {:>6.2} M  raw Embree {:>6.2} M/s  ratio {:.2}",
        f("time", "trace_photons_s") + f("time", "build_maps_s"),
        f("time", "fill_cache_s"),
        f("time", "shade_s"),
        f("icache", "records_pass_a"),
        f("icache", "misses_pass_b"),
        f("gather", "rays") / 1e6,
        rays / wall / 1e6,
        raw / 1e6,
        (rays / wall) / raw
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    println!("machine: {} threads", rayon::current_num_threads());
    flann_rates();
    photon_rates(root);
    pm_scene("cornell-caustics", &root.join("scenes/cornell-caustics.toml"), 512);
    pm_scene("sibenik", &root.join("tests/scenes/sibenik.toml"), 1000);
    pm_scene("sponza", &root.join("tests/scenes/sponza.toml"), 1000);
}
