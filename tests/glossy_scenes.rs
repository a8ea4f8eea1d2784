//! The glossy scenes (`tests/scenes/`: McGuire's glossy Cornell boxes, Sibenik with a polished
//! floor, Sponza as a Blender export and with the conference room's materials) rendered by `pm` with its defaults and by `path`, against their
//! references (`tests/reference/<scene>-path.exr`, Mitsuba 3 with the `pm_phong` plugin of
//! `tools/mref_phong.py`, made by `tools/mitsuba_reference.py`; command, sample count, time and the
//! reference's own noise in the JSON beside each). Our `path` agreed with Mitsuba on CornellBox-Glossy to
//! +0.006 % in the image mean at 4096 spp (block relMSE 1.3e-4 per pixel): the two Phong models match.
//!
//! Asserted: the image mean within 1 % of the reference's and the 8×8-block relMSE below a bound set
//! from the measured value (written beside each). `path` on Sponza is slow (`make test-slow`).

mod common;

use std::time::Instant;

use common::{block_means, mean, read, rel_mse, repo, run};

/// Renders `scene` at its reference's size with `method` (its defaults, or `spp` samples; at `seed`,
/// else the scene's) and returns (relative error of the image mean, 8×8-block relMSE, seconds).
fn measure(
    scene: &str,
    name: &str,
    method: &str,
    spp: Option<u32>,
    seed: Option<u32>,
) -> (f64, f64, f64) {
    let reference = read(&repo().join(format!("tests/reference/{name}-path.exr")));
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.exr");
    let (w, h) = (reference.width.to_string(), reference.height.to_string());
    let spp = spp.map(|n| n.to_string());
    let scene_path = repo().join(scene);
    let mut args = vec![
        "render",
        scene_path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--method",
        method,
        "--width",
        &w,
        "--height",
        &h,
        "--quiet",
    ];
    if let Some(n) = &spp {
        args.extend(["--spp", n]);
    }
    let seed = seed.map(|s| s.to_string());
    if let Some(s) = &seed {
        args.extend(["--seed", s]);
    }
    let start = Instant::now();
    let r = run(&args);
    let secs = start.elapsed().as_secs_f64();
    assert!(
        r.status.success(),
        "{name} {method}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
    let img = read(&out);
    let (m, m_ref) = (
        mean(&img).element_sum() as f64,
        mean(&reference).element_sum() as f64,
    );
    let block = rel_mse(&block_means(&img, 8), &block_means(&reference, 8));
    let err = m / m_ref - 1.0;
    eprintln!(
        "[glossy {name} {method}] mean {:+.3} %, 8×8-block relMSE {block:.6}, {secs:.1} s",
        100.0 * err
    );
    (err, block, secs)
}

/// Renders `tests/scenes/<name>.toml` and checks it against its reference: the mean within 1 %, the
/// 8×8-block relMSE below `max_block`.
fn check(name: &str, method: &str, spp: Option<u32>, max_block: f64) {
    let scene = format!("tests/scenes/{name}.toml");
    let (err, block, _) = measure(&scene, name, method, spp, None);
    assert!(
        err.abs() <= 0.01,
        "{name} {method}: image mean off by {:+.2} %",
        100.0 * err
    );
    assert!(
        block < max_block,
        "{name} {method}: 8×8-block relMSE {block} ≥ {max_block}"
    );
}

#[test]
fn cornell_glossy_pm() {
    // Measured: mean -0.470 %, block relMSE 0.000051 (0.6 s).
    check("cornell-glossy", "pm", None, 1e-4);
}

#[test]
fn cornell_glossy_path() {
    // Measured: mean -0.106 %, block relMSE 0.000023 at 256 spp (3.5 s).
    check("cornell-glossy", "path", Some(256), 5e-5);
}

/// Seeds 0–2, each mean within 1 % and block relMSE below 6e-4, their median below 1.5e-4. Measured
/// over seeds 0–7 on AVX2's and SSE4.2's ray kernels (16 realisations): means −0.46 … +0.22 %, block
/// relMSE 0.000053–0.000122 but one, 0.000434 (SSE4.2, seed 0: a third of it in one corner block);
/// the median of three seeds at most 0.000115. The single-seed bound of 1e-4 failed on SSE4.2.
#[test]
fn cornell_glossy_floor_pm() {
    let scene = "tests/scenes/cornell-glossy-floor.toml";
    let mut blocks: Vec<f64> = (0..3)
        .map(|seed| {
            let (err, block, _) = measure(scene, "cornell-glossy-floor", "pm", None, Some(seed));
            assert!(
                err.abs() <= 0.01,
                "seed {seed}: mean off by {:+.2} %",
                100.0 * err
            );
            assert!(block < 6e-4, "seed {seed}: 8×8-block relMSE {block}");
            block
        })
        .collect();
    blocks.sort_by(f64::total_cmp);
    assert!(blocks[1] < 1.5e-4, "median 8×8-block relMSE {}", blocks[1]);
}

#[test]
fn cornell_glossy_floor_path() {
    // Measured: mean -0.102 %, block relMSE 0.000021 at 256 spp (3.7 s).
    check("cornell-glossy-floor", "path", Some(256), 5e-5);
}

#[test]
fn sibenik_polished_pm() {
    // Measured: mean -0.038 %, block relMSE 0.000101 (3.5 s). It was +7.9 % while a textured glossy
    // material's albedo, which the irradiance atlas reads, was its scaled Kd, not its texture's mean.
    check("sibenik-polished", "pm", None, 2e-4);
}

#[test]
fn sibenik_polished_path() {
    // Measured: mean -0.225 %, block relMSE 0.000204 at the default 64 spp (3.6 s).
    check("sibenik-polished", "path", None, 4e-4);
}

#[test]
fn sponza_blender_pm() {
    // Measured: mean -0.438 %, block relMSE 0.000706 (4.8 s).
    check("sponza-blender", "pm", None, 1e-3);
}

#[test]
#[ignore = "slow: make test-slow"]
fn sponza_blender_path() {
    // Measured: mean -0.28 %, block relMSE 0.020 at the default 64 spp (21 s; per-pixel relMSE 1.0:
    // fireflies of Ns 225 everywhere).
    check("sponza-blender", "path", None, 0.05);
}

#[test]
fn sponza_conference_pm() {
    // Measured: mean -0.778 %, block relMSE 0.000363 (5.7 s); seeds 1, 2: -0.96 %, -0.64 %. Sponza
    // with its diffuse MTL is -0.43 % against its own reference.
    check("sponza-conference", "pm", None, 1e-3);
}

#[test]
fn sponza_conference_path() {
    // Measured: mean -0.211 %, block relMSE 0.0032 at the default 64 spp (2.0 s).
    check("sponza-conference", "path", None, 0.008);
}
