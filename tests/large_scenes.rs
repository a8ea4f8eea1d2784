//! `pm` with its defaults on the scenes people render, against independent Mitsuba 3 references
//! (`tests/reference/<scene>-path.exr`, 128×128, made by `tools/mitsuba_reference.py`; the command, sample
//! count and the reference's own noise are in the JSON beside each). On these scenes `pm` was once
//! 4–12 % too dark (density estimates divided by a disc the surface did not fill) while it was excellent
//! on boxes.
//!
//! Asserted for each scene: the image mean and the mean of each large region against the reference —
//! averaged over the renders of [`SEEDS`], since a region's mean in one render also holds that render's noise
//! (the records' gathers and the photons: ±0.5–1 % on the blinds room's walls from seed to seed) and
//! the target is the bias — and the 8×8-block relMSE of the first render against what `path` reaches in
//! the same wall time (the path tracer's sample count is set from timed calibration renders in the same
//! run). Every bound is the accuracy target: 1 % on every mean and 1.5× path's block error (Sponza's right
//! wall meets it by 0.1 %; its comment says what is left there). Slow (renders of 66–75 k-triangle scenes, several
//! per scene): `make test-slow`.

mod common;

use std::path::Path;
use std::time::Instant;

use common::{block_means, read, rel_mse, repo, run};
use glam::Vec3;
use pmrender::io::output::Image;

/// A named rectangle `[x0, x1) × [y0, y1)` of the 128×128 image, and the largest relative error of its
/// mean allowed.
struct Region(&'static str, u32, u32, u32, u32, f32);

const SIZE: u32 = 128;

/// Seeds whose renders' region means are averaged.
const SEEDS: [u32; 5] = [0, 1, 2, 3, 4];

fn render(scene: &Path, method: &str, spp: u32, out: &Path) -> f64 {
    render_with(scene, method, spp, out, &[])
}

fn render_with(scene: &Path, method: &str, spp: u32, out: &Path, extra: &[&str]) -> f64 {
    let spp = spp.to_string();
    let size = SIZE.to_string();
    let start = Instant::now();
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--method",
        method,
        "--spp",
        &spp,
        "--width",
        &size,
        "--height",
        &size,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(
        r.status.success(),
        "{method}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
    start.elapsed().as_secs_f64()
}

fn region_mean(img: &Image, r: &Region) -> f32 {
    let mut sum = Vec3::ZERO;
    for y in r.3..r.4 {
        for x in r.1..r.2 {
            sum += img.pixels[(y * img.width + x) as usize];
        }
    }
    sum.element_sum() / ((r.2 - r.1) * (r.4 - r.3)) as f32
}

/// The equal-time comparison times renders: one scene at a time, whatever the test harness's threads.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `max_block_ratio`: the largest ratio of pm's 8×8-block relMSE to path's at equal time.
fn check_scene(scene: &str, name: &str, regions: &[Region], max_block_ratio: f64) {
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let scene = repo().join(scene);
    let reference = read(&repo().join(format!("tests/reference/{name}-path.exr")));
    let d = tempfile::tempdir().unwrap();
    let (pm_out, pm_stats) = (d.path().join("pm.exr"), d.path().join("pm.json"));
    let t_pm = render_with(
        &scene,
        "pm",
        32,
        &pm_out,
        &["--stats", pm_stats.to_str().unwrap()],
    );
    let pm = read(&pm_out);
    // More seeds, for the region means (the first render is seed 0, the default).
    let mut renders = vec![pm.clone()];
    for seed in &SEEDS[1..] {
        let out = d.path().join(format!("pm{seed}.exr"));
        render_with(&scene, "pm", 32, &out, &["--seed", &seed.to_string()]);
        renders.push(read(&out));
    }
    // Pass-B misses: samples that shaded with no record of their own surface (target: ≤ 0.1 %).
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&pm_stats).unwrap()).unwrap();
    let (misses, lookups) = (
        stats["icache"]["misses_pass_b"].as_f64().unwrap(),
        stats["icache"]["lookups_pass_b"].as_f64().unwrap(),
    );

    // Path tracing at equal time: time 8 and 24 spp (a fixed cost — loading, writing — plus a cost per
    // sample), then render the count that fits in pm's time.
    let calib = d.path().join("calib.exr");
    let (t8, t24) = (
        render(&scene, "path", 8, &calib),
        render(&scene, "path", 24, &calib),
    );
    let per_spp = ((t24 - t8) / 16.0).max(1e-6);
    let spp_path = (((t_pm - (t8 - 8.0 * per_spp)) / per_spp).round() as u32).clamp(8, 65536);
    let path_out = d.path().join("path.exr");
    let t_path = render(&scene, "path", spp_path, &path_out);
    let path = read(&path_out);

    let block = |img: &Image| rel_mse(&block_means(img, 8), &block_means(&reference, 8));
    let (e_pm, e_path) = (block(&pm), block(&path));
    let whole = Region("image", 0, SIZE, 0, SIZE, 0.01);
    let mut report = format!("[large {name}] pm {t_pm:.1} s, path {spp_path} spp {t_path:.1} s; 8×8-block relMSE pm {e_pm:.5} path {e_path:.5}; pass-B misses {misses} of {lookups} lookups");
    let mut failures = Vec::new();
    if misses > 1e-3 * lookups {
        failures.push(format!("{misses} pass-B misses of {lookups} lookups"));
    }
    report += &format!("; region means / reference over seeds {SEEDS:?} (each seed)");
    for r in std::iter::once(&whole).chain(regions) {
        let each: Vec<f32> = renders
            .iter()
            .map(|img| region_mean(img, r) / region_mean(&reference, r))
            .collect();
        let ratio = each.iter().sum::<f32>() / each.len() as f32;
        let each: Vec<String> = each.iter().map(|x| format!("{x:.4}")).collect();
        report += &format!("; {} {ratio:.4} ({})", r.0, each.join(" "));
        if (ratio - 1.0).abs() > r.5 {
            failures.push(format!(
                "{} mean off by {:+.2} %",
                r.0,
                (ratio - 1.0) * 100.0
            ));
        }
    }
    eprintln!("{report}");
    if e_pm > max_block_ratio * e_path {
        failures.push(format!(
            "block relMSE {e_pm:.5} > {max_block_ratio} × path's {e_path:.5}"
        ));
    }
    assert!(failures.is_empty(), "{name}: {}", failures.join("; "));
}

#[test]
#[ignore = "slow: make test-slow"]
fn sibenik_pm_matches_mitsuba() {
    check_scene(
        "tests/scenes/sibenik.toml",
        "sibenik",
        &[
            Region("vault", 40, 88, 0, 24, 0.01),
            Region("left wall", 0, 24, 16, 96, 0.01),
            Region("right wall", 104, 128, 16, 96, 0.01),
            Region("floor", 16, 112, 100, 128, 0.01),
        ],
        // Measured over seeds 0–4: image 0.9988, vault 0.9987, walls 1.0025 / 1.0022, floor 0.9955
        // (780 k photons, the default for 75 k triangles; atlas texels with direct light from shadow
        // rays, edge texels; 500 gather rays chosen from pass A's noise). Block relMSE (seed 0) 0.00011
        // against path's 0.00010 at 132 spp in the same 3.9 s (1.1×; at 128² path is very efficient
        // here: two point lights). It was 0.00018 (2.2×) while pass B read records out to twice their
        // pass-A distance (κ = 0.5).
        1.5,
    );
}

#[test]
#[ignore = "slow: make test-slow"]
fn sponza_pm_matches_mitsuba() {
    check_scene(
        "tests/scenes/sponza.toml",
        "sponza",
        &[
            Region("gallery", 32, 96, 16, 48, 0.01),
            Region("left wall", 0, 32, 16, 88, 0.01),
            // Measured 0.9912 over seeds 0–4 (0.9891 0.9909 0.9932 0.9909 0.9918; 0.9905 before the
            // gathers took 1000 rays here): within the 1 % target by 0.1 %. It was 0.9880 (0.9856–0.9912)
            // before edge texels: its darkest part, the shaded arcade at the right edge, lit by sunlit
            // patches the arches' shadows bound, was 18 % dark (`pm-fg` too: the atlas, not the cache);
            // 3 % with edge texels. What is left is the texels' photon estimates (their disc's blur):
            // `pm-fg` on this wall is 0.9944 of our `path` with the default photons and 0.999 with 6 M
            // photons of k = 10 per texel (2026-11-24, seeds 0–1).
            Region("right wall", 96, 128, 16, 88, 0.01),
            Region("sunlit floor", 64, 128, 92, 128, 0.01),
            Region("shaded floor", 0, 56, 100, 128, 0.01),
        ],
        // Measured over seeds 0–4: image 0.9951, gallery 0.9925, walls 0.9976 / 0.9912, floors 0.9979 /
        // 0.9951 (1000 gather rays chosen); block relMSE (seed 0) 0.00010 vs path's 0.00042 at equal
        // time (0.24×; 0.00016 before edge texels).
        1.5,
    );
}

#[test]
#[ignore = "slow: make test-slow"]
fn blinds_room_pm_matches_mitsuba() {
    check_scene(
        "scenes/blinds-room.toml",
        "blinds-room",
        &[
            Region("ceiling", 0, 128, 0, 28, 0.01),
            // Measured 1.0073 over seeds 0–4 (1.0032 1.0051 0.9997 1.0171 1.0112; 1000 gather rays chosen)
            // since pass B makes records for the
            // samples that found none (between its rounds): sub-pixel slats without records of their own
            // borrowed their neighbours' or gathered per sample (12 % of the lookups at 128² missed) and
            // were 1.8 % bright.
            Region("slats", 44, 84, 40, 64, 0.01),
            // Measured 1.0039 over seeds 0–4 (1.0002 1.0067 1.0033 1.0011 1.0081; with 500 gather rays,
            // before `pm` chose 1000 here: 1.0059, 0.9979–1.0176). The plain wall near the back-left
            // corner (the radiator's fins are left of the 128² frame), with few records (~35, 0.3–0.8 m
            // apart): each seed's mean holds their gathers' noise (sd 0.6–1.2 % over six seeds with the
            // photons fixed). Until 2026-11-24 every seed gathered with the same jitter and this wall was
            // 1.011–1.017 at every seed: one draw of that noise, taken for a bias of the cache.
            Region("left wall", 0, 16, 32, 88, 0.01),
            // Measured 1.0050 (1.0024 1.0085 1.0077 1.0022 1.0042; 1.0078, 0.9999–1.0136 with 500 rays).
            Region("right wall", 112, 128, 32, 88, 0.01),
            Region("chairs and floor", 0, 128, 96, 128, 0.01),
        ],
        // Measured over seeds 0–4: image 1.0018, ceiling 0.9979, chairs and floor 1.0015; block relMSE
        // (seed 0) 0.00027 vs path's 0.0030 at equal time (1.4 s; 0.09×; 0.00039 with 500 rays); pass-B
        // misses 0 of 203 k lookups (12 % before pass B made records for them).
        1.5,
    );
}

/// Pass-B misses (samples no record interpolates) ≤ 0.1 % of the lookups on every shipped and
/// benchmark scene at 1000² too (`shipped_scenes` checks the default sizes, the tests above 128²).
/// Measured 2026-11-24 at 4 spp: 0 misses of 3.7–4.2 M lookups everywhere but fog-spot (11 of 4.0 M);
/// the fog scenes take 73 and 92 s, the others 4–12 s.
#[test]
#[ignore = "slow: make test-slow"]
fn pass_b_misses_at_1000() {
    let d = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for scene in [
        "scenes/blinds-room.toml",
        "scenes/cornell-caustics.toml",
        "scenes/fog-cornell.toml",
        "scenes/fog-spot.toml",
        "scenes/interior-diffuse.toml",
        "scenes/spot-point.toml",
        "scenes/water-caustics.toml",
        "tests/scenes/sibenik.toml",
        "tests/scenes/sponza.toml",
    ] {
        let (out, stats) = (d.path().join("m.exr"), d.path().join("m.json"));
        let path = repo().join(scene);
        let r = run(&[
            "render",
            path.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
            "--width",
            "1000",
            "--height",
            "1000",
            "--spp",
            "4",
            "--quiet",
        ]);
        assert!(
            r.status.success(),
            "{scene}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        let (misses, lookups) = (
            j["icache"]["misses_pass_b"].as_f64().unwrap(),
            j["icache"]["lookups_pass_b"].as_f64().unwrap(),
        );
        eprintln!("[misses 1000²] {scene}: {misses} of {lookups} pass-B lookups");
        if !(lookups > 0.0 && misses <= 1e-3 * lookups) {
            failures.push(format!("{scene}: {misses} misses of {lookups} lookups"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("; "));
}
