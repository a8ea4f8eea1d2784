//! `pm` with its defaults on the scenes people render, against independent Mitsuba 3 references
//! (`tests/reference/<scene>-path.exr`, 128×128, made by `tools/mitsuba_reference.py`; the command, sample
//! count and the reference's own noise are in the JSON beside each). Issue 10: on these scenes `pm` was
//! 4–12 % too dark (density estimates divided by a disc the surface did not fill) while it was excellent
//! on boxes.
//!
//! Asserted for each scene: the image mean and the mean of each large region against the reference,
//! and the 8×8-block relMSE against what `path` reaches in the same wall time (the path tracer's sample
//! count is set from timed calibration renders in the same run). Issue 10's target is 1 % on every mean
//! and 1.5× path's block error; where a scene does not meet it yet, the bound is the measured value with
//! a margin and the comment says so (these tests then guard against regressions, and the issue stays
//! open). Slow (renders of 75–260 k-triangle scenes, several per scene): `make test-slow`.

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

fn render(scene: &Path, method: &str, spp: u32, out: &Path) -> f64 {
    render_with(scene, method, spp, out, &[])
}

fn render_with(scene: &Path, method: &str, spp: u32, out: &Path, extra: &[&str]) -> f64 {
    let spp = spp.to_string();
    let size = SIZE.to_string();
    let start = Instant::now();
    let mut args = vec![
        "render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--method", method, "--spp", &spp,
        "--width", &size, "--height", &size, "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{method}: {}", String::from_utf8_lossy(&r.stderr));
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
    let t_pm = render_with(&scene, "pm", 32, &pm_out, &["--stats", pm_stats.to_str().unwrap()]);
    let pm = read(&pm_out);
    // Pass-B misses: samples that shaded with no record of their own surface (issue 10: ≤ 0.1 %).
    let stats: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&pm_stats).unwrap()).unwrap();
    let (misses, lookups) = (stats["icache"]["misses_pass_b"].as_f64().unwrap(), stats["icache"]["lookups_pass_b"].as_f64().unwrap());

    // Path tracing at equal time: time 8 and 24 spp (a fixed cost — loading, writing — plus a cost per
    // sample), then render the count that fits in pm's time.
    let calib = d.path().join("calib.exr");
    let (t8, t24) = (render(&scene, "path", 8, &calib), render(&scene, "path", 24, &calib));
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
    for r in std::iter::once(&whole).chain(regions) {
        let ratio = region_mean(&pm, r) / region_mean(&reference, r);
        report += &format!("; {} {ratio:.4}", r.0);
        if (ratio - 1.0).abs() > r.5 {
            failures.push(format!("{} mean off by {:+.2} %", r.0, (ratio - 1.0) * 100.0));
        }
    }
    eprintln!("{report}");
    if e_pm > max_block_ratio * e_path {
        failures.push(format!("block relMSE {e_pm:.5} > {max_block_ratio} × path's {e_path:.5}"));
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
        // Measured: image 0.9994, vault 1.0001, walls 1.0045 / 1.0032, floor 0.9933 (780 k photons, the
        // default for 75 k triangles; atlas texels with direct light from shadow rays). Block relMSE
        // 0.00013 against path's 0.00010 at 124 spp in the same 3.4 s (1.3×; at 128² path is very
        // efficient here: two point lights). It was 0.00018 (2.2×, walls 1.0099 / 1.0058) while pass B
        // read records out to twice their pass-A distance (κ = 0.5).
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
            // Measured 0.9835 (`pm-fg` 0.9857: the atlas or the photons, not the cache): the one region
            // over the 1 % target.
            Region("right wall", 96, 128, 16, 88, 0.02),
            Region("sunlit floor", 64, 128, 92, 128, 0.01),
            Region("shaded floor", 0, 56, 100, 128, 0.01),
        ],
        // Measured: image 0.9935, gallery 0.9914, shaded floor 0.9945; block relMSE 0.00017 vs path's
        // 0.00046 at equal time (0.37×).
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
            // Measured 1.0026 since pass B makes records for the samples that found none (between its
            // rounds): sub-pixel slats without records of their own borrowed their neighbours' or
            // gathered per sample (12 % of the lookups at 128² missed) and were 1.8 % bright.
            Region("slats", 44, 84, 40, 64, 0.01),
            // Measured 1.0156 (1.0201 with κ = 0.5): the radiator's fins (3 mm, 2.5 cm apart) stand on
            // this wall.
            Region("left wall", 0, 16, 32, 88, 0.025),
            Region("right wall", 112, 128, 32, 88, 0.01),
            Region("chairs and floor", 0, 128, 96, 128, 0.01),
        ],
        // Measured: image 1.0016, block relMSE 0.00040 vs path's 0.0042–0.0051 at equal time (1.0 s; 0.1×);
        // pass-B misses 0 of 203 k lookups (12 % before pass B made records for them).
        1.5,
    );
}
