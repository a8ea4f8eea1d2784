//! Participating media wherever the light, the camera and the glass are: the configuration matrix of
//! `tests/media_matrix/` (scenes written by `tools/make_media_matrix.py`) against Mitsuba 3 `volpath`
//! references (`tests/reference/media/`, made by `tools/media_matrix_refs.sh`: 4096 spp at 48², each
//! reference's own noise in the JSON beside it).
//!
//! Each case renders with `path` and `pm` and `photons` here (`pm-fg` in `make test-slow`) and holds
//! - the image mean, per channel, within 1 % of the reference's (the measured value of seed 0, worst
//!   channel, is written next to every bound);
//! - the relMSE of 8×8-pixel block means (bias shows there, pixel noise averages out) below its bound,
//!   the measured value beside it.
//!
//! The references are exported with the emitters made transparent and their surfaces drawn again just
//! behind them (`tools/mref_export.py`): Mitsuba's shadow rays, moved off each null boundary they
//! cross, otherwise end inside an emitter that lies just beyond a boundary parallel to it and are
//! blocked — with the fog's top 1 cm under the ceiling light that made Mitsuba's image 11 % dark.

mod common;
use common::*;

/// One method's render of a case and what it must hold.
struct Check {
    method: &'static str,
    extra: &'static [&'static str],
    /// Largest |mean / reference mean − 1|.
    mean: f32,
    /// Largest 8×8-block relMSE.
    block: f64,
}

const fn check(method: &'static str, mean: f32, block: f64) -> Check {
    with_args(method, &[], mean, block)
}

/// `method` rendered with `extra` arguments.
const fn with_args(
    method: &'static str,
    extra: &'static [&'static str],
    mean: f32,
    block: f64,
) -> Check {
    Check {
        method,
        extra,
        mean,
        block,
    }
}

/// `path` at 512 samples per pixel.
const fn path(mean: f32, block: f64) -> Check {
    with_args("path", &["--spp", "512"], mean, block)
}

fn run_case(case: &str, checks: &[Check]) {
    let scene = repo().join(format!("tests/media_matrix/{case}.toml"));
    let reference = read(&repo().join(format!("tests/reference/media/{case}.exr")));
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for c in checks {
        let out = dir.path().join(format!("{}.exr", c.method));
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--method",
            c.method,
            "--quiet",
        ];
        args.extend_from_slice(c.extra);
        let r = run(&args);
        assert!(
            r.status.success(),
            "{case} {}: {}",
            c.method,
            String::from_utf8_lossy(&r.stderr)
        );
        let img = read(&out);
        let ratio = mean(&img) / mean(&reference);
        let off = (ratio - glam::Vec3::ONE).abs().max_element();
        let block = rel_mse(&block_means(&img, 8), &block_means(&reference, 8));
        eprintln!(
            "[media matrix] {case:20} {:8} mean/ref {:.4} {:.4} {:.4}, block relMSE {block:.5}",
            c.method, ratio.x, ratio.y, ratio.z
        );
        if off > c.mean {
            failures.push(format!(
                "{}: mean {:.2} % off the reference (bound {:.2} %)",
                c.method,
                off * 100.0,
                c.mean * 100.0
            ));
        }
        if block > c.block {
            failures.push(format!(
                "{}: block relMSE {block:.5} (bound {:.5})",
                c.method, c.block
            ));
        }
    }
    assert!(failures.is_empty(), "{case}: {}", failures.join("; "));
}

/// An area light 1 cm above the fog's top face: all its light enters the fog through a null face.
#[test]
fn area_light_outside_the_fog() {
    run_case(
        "area-light-outside",
        &[
            path(0.01, 0.0003),             // +0.16 %, 0.00006
            check("pm", 0.01, 0.001),       // −0.33 %, 0.00003
            check("photons", 0.01, 0.0005), // −0.35 %, 0.00011
        ],
    );
}

/// The same light inside the fog.
#[test]
fn area_light_inside_the_fog() {
    run_case(
        "area-light-inside",
        &[
            path(0.01, 0.0003),             // +0.09 %, 0.00007
            check("pm", 0.01, 0.001),       // −0.47 %, 0.00003
            check("photons", 0.01, 0.0005), // −0.46 %, 0.00012
        ],
    );
}

/// A spot light above the fog, its beam entering through the fog's top face.
#[test]
fn spot_light_outside_the_fog() {
    run_case(
        "spot-outside",
        &[
            path(0.01, 0.0003),             // −0.14 %, 0.00002
            check("pm", 0.01, 0.001),       // +0.24 %, 0.00007
            check("photons", 0.01, 0.0005), // −0.31 %, 0.00007
        ],
    );
}

/// A point light inside the fog.
#[test]
fn point_light_inside_the_fog() {
    run_case(
        "point-inside",
        &[
            path(0.01, 0.002),             // −0.78 %, 0.00035 (the light's 1/r² in the fog)
            check("pm", 0.01, 0.002),      // −0.34 %, 0.00030
            check("photons", 0.01, 0.001), // −0.31 %, 0.00023
        ],
    );
}

/// The sun through a window into a hazy room: the light enters the scene from outside it and the
/// haze through its boundary. `pm` at seeds 0–5: −0.29, −0.44, −0.57, −0.34, −0.49, −0.42 %.
#[test]
fn sun_through_a_window_into_haze() {
    run_case(
        "sun-window",
        &[
            path(0.01, 0.0003),            // −0.29 %, 0.00005
            check("pm", 0.01, 0.002),      // −0.23 %, 0.00011
            check("photons", 0.01, 0.001), // −0.50 %, 0.00029
        ],
    );
}

/// The camera inside the fog (`[camera] medium`).
#[test]
fn camera_inside_the_fog() {
    run_case(
        "camera-in-fog",
        &[
            path(0.01, 0.0003),             // −0.25 %, 0.00006
            check("pm", 0.01, 0.001),       // +0.41 %, 0.00011
            check("photons", 0.01, 0.0005), // −0.37 %, 0.00021
        ],
    );
}

/// The camera outside a dense cube of fog standing in the room.
#[test]
fn camera_outside_looking_into_a_fog_cube() {
    run_case(
        "fog-cube",
        &[
            path(0.01, 0.0003),             // −0.17 %, 0.00001
            check("pm", 0.01, 0.001),       // −0.07 %, 0.00005
            check("photons", 0.01, 0.0005), // −0.18 %, 0.00007
        ],
    );
}

/// A glass sphere filled with a scattering liquid, standing in fog.
#[test]
fn liquid_in_a_glass_in_fog() {
    run_case(
        "liquid-glass-in-fog",
        &[
            path(0.01, 0.001),             // +0.38 %, 0.00017
            check("pm", 0.01, 0.002),      // +0.49 %, 0.00037
            check("photons", 0.01, 0.001), // −0.30 %, 0.00018
        ],
    );
}

/// An empty glass sphere (a clear medium inside) in fog.
#[test]
fn empty_glass_in_fog() {
    run_case(
        "empty-glass-in-fog",
        &[
            path(0.01, 0.001),              // −0.09 %, 0.00021
            check("pm", 0.01, 0.001),       // −0.47 %, 0.00007
            check("photons", 0.01, 0.0005), // −0.32 %, 0.00016
        ],
    );
}

/// A dense smoke box nested in the room's fog.
#[test]
fn medium_nested_in_a_medium() {
    run_case(
        "nested-media",
        &[
            path(0.01, 0.0003),             // +0.22 %, 0.00007
            check("pm", 0.01, 0.0015),      // −0.15 %, 0.00005
            check("photons", 0.01, 0.0007), // −0.26 %, 0.00013
        ],
    );
}

/// A diffuse block and a mirror box standing half in a low fog.
#[test]
fn mirror_and_block_half_in_the_fog() {
    run_case(
        "half-in-fog",
        &[
            path(0.01, 0.0003),             // +0.07 %, 0.00005
            check("pm", 0.01, 0.001),       // −0.35 %, 0.00009
            check("photons", 0.01, 0.0005), // −0.27 %, 0.00008
        ],
    );
}

/// Two media sharing a face: each boundary's outside is found face by face, so the shared face leads
/// from one medium into the other (not into vacuum, whichever of its two copies a ray meets). Before,
/// `path` was 1.8 % dark here.
#[test]
fn two_media_sharing_a_face() {
    run_case(
        "touching-media",
        &[
            path(0.01, 0.0005),            // +0.11 %, 0.00011
            check("pm", 0.01, 0.002),      // −0.44 %, 0.00033
            check("photons", 0.01, 0.001), // +0.40 %, 0.00030
        ],
    );
}

/// A point light inside dense, forward-scattering fog (g = 0.6): the moments' phase overstated its
/// light by 7 % of the image before `pm`'s records kept their ray's phase. The light's 1/r² in dense
/// fog gives samples of unbounded variance, so the reference has 65536 spp (its mean's own standard
/// error 0.09–0.14 %); `path`'s 8×8-block relMSE at 4096 spp is 0.0015, 0.0011, 0.0006 at seeds
/// 0–2. Seeds 0–7: `photons` −0.03 % on average (spread 0.30 %), `pm` −0.23, −0.51, −0.57, −0.69,
/// +0.14, −0.77, −0.54, −0.60 % (spread 0.27 %).
#[test]
fn point_light_in_dense_forward_fog() {
    run_case(
        "dense-point",
        &[
            with_args("path", &["--spp", "4096"], 0.01, 0.003), // +0.74 %, 0.00150
            // The mean 1.5 %: seeds 0–7's worst −0.77 % held the 1 % by 1.3×; now 1.9× (SSE4.2
            // at seed 0: −0.21 %, 0.00066).
            check("pm", 0.015, 0.002),      // −0.21 %, 0.00061
            check("photons", 0.01, 0.0015), // +0.31 %, 0.00056
        ],
    );
}

/// The sun into a haze that scatters strongly forward (g = 0.8).
#[test]
fn sun_into_forward_scattering_haze() {
    run_case(
        "haze-forward",
        &[
            path(0.01, 0.0005),             // −0.33 %, 0.00005
            check("pm", 0.01, 0.002),       // +0.61 %, 0.00044
            check("photons", 0.01, 0.0007), // −0.53 %, 0.00022
        ],
    );
}

/// The area light 1 cm above a dense, coloured fog. `pm` at seeds 0–7: −0.75, −0.54, −0.89, −0.65,
/// −0.67, +0.43, −0.70, −0.44 %, −0.15 % at seed 8, −0.70 % on SSE4.2's kernels at seed 0 (block
/// relMSE 0.00027 both): its mean is held to 1.5 % (the 1 % held the worst by 1.1×; now 1.7×).
#[test]
fn area_light_over_dense_fog() {
    run_case(
        "dense-area-outside",
        &[
            path(0.01, 0.0005),            // +0.23 %, 0.00016
            check("pm", 0.015, 0.001),     // −0.73 %, 0.00025
            check("photons", 0.01, 0.001), // −0.42 %, 0.00028
        ],
    );
}

/// `pm-fg` at 32 samples per pixel (its default of 4 leaves ±2 % of pixel noise in the image mean of
/// these 48² images where an emitter is in view), on every case (`make test-slow`).
const fn pm_fg(mean: f32, block: f64) -> Check {
    with_args("pm-fg", &["--spp", "32"], mean, block)
}

#[test]
#[ignore = "slow: make test-slow"]
fn pm_fg_on_every_case() {
    for (case, bound) in [
        ("area-light-outside", pm_fg(0.01, 0.0003)), // −0.29 %, 0.00004
        ("area-light-inside", pm_fg(0.01, 0.0003)),  // −0.27 %, 0.00005
        ("spot-outside", pm_fg(0.01, 0.0003)),       // −0.48 %, 0.00002
        ("point-inside", pm_fg(0.01, 0.001)),        // −0.45 %, 0.00025
        ("sun-window", pm_fg(0.01, 0.0005)),         // −0.17 %, 0.00004
        ("camera-in-fog", pm_fg(0.01, 0.0005)),      // −0.20 %, 0.00010
        ("fog-cube", pm_fg(0.01, 0.0003)),           // −0.21 %, 0.00001
        ("liquid-glass-in-fog", pm_fg(0.01, 0.0005)), // +0.15 %, 0.00013
        ("empty-glass-in-fog", pm_fg(0.01, 0.0003)), // −0.25 %, 0.00006
        ("nested-media", pm_fg(0.01, 0.0003)),       // −0.10 %, 0.00007
        ("half-in-fog", pm_fg(0.01, 0.0003)),        // −0.27 %, 0.00002
        ("touching-media", pm_fg(0.01, 0.001)),      // +0.60 %, 0.00032
        ("dense-area-outside", pm_fg(0.01, 0.001)),  // −0.19 %, 0.00022
        ("haze-forward", pm_fg(0.01, 0.001)),        // +0.45 %, 0.00030
        ("dense-point", pm_fg(0.01, 0.002)),         // −0.59 %, 0.00071
    ] {
        run_case(case, &[bound]);
    }
}
