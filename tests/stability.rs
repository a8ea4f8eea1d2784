//! Failure-case stability suite: scenes where photon maps and irradiance caching are
//! known to break — cracks, small geometry, creases, scanline order, splotches, caustics, specular-only,
//! unlit and sealed scenes, broken meshes, extreme scales. Each is rendered small with `pm` and compared
//! with `path` (or an analytic answer).
//!
//! Every render is checked for NaN, Inf and negative pixels and a zero `rare.nan_or_negative` counter.
//! The error is relMSE of 2×2 block means (bias shows, per-pixel noise averages out) against the reference.
//! Bounds are set from seeds 0–3 (the renders' `--seed`, every render of a case at the same seed) and
//! SSE4.2's kernels at seed 0, whose figures are seed 0's but where stated: the range is written next
//! to each bound, which is at least 2× its worst (or, for a ratio, its worst plus about 2 sd).
//! Renders run under a hang guard: a render still running after `HANG_S` is killed and the test fails.

mod common;
mod stability_scenes;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{bin, block_means, read, rel_mse};
use pmrender::io::output::Image;
use stability_scenes::*;

/// A render that has not finished after this long is taken as hung (the slowest one here takes ~3 s).
const HANG_S: u64 = 120;

struct Render {
    img: Image,
    stats: serde_json::Value,
}

/// Renders `dir/scene.toml` with `method` at `spp` (plus `extra` options) under the hang guard.
fn render(dir: &Path, method: &str, spp: u32, extra: &[&str]) -> Render {
    let tag = format!("{method}-{spp}-{}", extra.join("_").replace(['/', ' '], ""));
    let (out, stats, log) = (
        dir.join(format!("{tag}.exr")),
        dir.join(format!("{tag}.json")),
        dir.join(format!("{tag}.log")),
    );
    let spp_s = spp.to_string();
    let mut args = vec![
        "render",
        "scene.toml",
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
    ];
    args.extend_from_slice(&["--method", method, "--spp", &spp_s, "--quiet"]);
    args.extend_from_slice(extra);
    let mut child = Command::new(bin())
        .args(&args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .expect("pmrender starts");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(HANG_S) {
            child.kill().ok();
            child.wait().ok();
            panic!(
                "{method} render of {} still running after {HANG_S} s: hung",
                dir.display()
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let stderr = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        status.success(),
        "{method} {extra:?} failed ({status}): {stderr}"
    );
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    keep(dir);
    let img = read(&out);
    sane(&img, &stats, &format!("{method} {extra:?}"));
    Render { img, stats }
}

/// Debugging aid: with `STABILITY_KEEP=DIR`, the scene and its renders are copied to DIR/<temp name>.
fn keep(dir: &Path) {
    if let Ok(k) = std::env::var("STABILITY_KEEP") {
        let to = Path::new(&k).join(dir.file_name().unwrap());
        std::fs::create_dir_all(&to).unwrap();
        for f in std::fs::read_dir(dir).unwrap().flatten() {
            std::fs::copy(f.path(), to.join(f.file_name())).unwrap();
        }
    }
}

/// No NaN, Inf or negative pixel; the NaN-or-negative counter is zero.
fn sane(img: &Image, stats: &serde_json::Value, what: &str) {
    for (i, p) in img.pixels.iter().enumerate() {
        assert!(
            p.is_finite() && p.min_element() >= 0.0,
            "{what}: pixel {i} = {p}"
        );
    }
    assert_eq!(
        stats["rare"]["nan_or_negative"].as_u64(),
        Some(0),
        "{what}: rare.nan_or_negative"
    );
}

/// relMSE of 2×2 block means.
fn err(img: &Image, reference: &Image) -> f64 {
    rel_mse(&block_means(img, 2), &block_means(reference, 2))
}

fn max_value(img: &Image) -> f32 {
    img.pixels
        .iter()
        .map(|p| p.max_element())
        .fold(0.0, f32::max)
}

fn report(case: &str, rows: &[(&str, f64)]) {
    let s: Vec<String> = rows.iter().map(|(k, e)| format!("{k} = {e:.3e}")).collect();
    eprintln!("[stability {case}] {}", s.join(", "));
}

fn check(case: &str, what: &str, e: f64, bound: f64) {
    assert!(e < bound, "{case}: {what} error {e:.5} ≥ bound {bound}");
}

const PHOTONS: &str = "[render.photons]\nglobal = 20000\n";
const NO_CLAMP: &str = "[render.icache]\nneighbor_clamping = false\n";

fn stat(r: &Render, group: &str, key: &str) -> f64 {
    r.stats[group][key]
        .as_f64()
        .unwrap_or_else(|| panic!("stats {group}.{key} missing"))
}

fn black(w: u32, h: u32) -> Image {
    Image {
        width: w,
        height: h,
        pixels: vec![glam::Vec3::ZERO; (w * h) as usize],
    }
}

/// a. A closed room whose walls stop 1 mm above the floor; the floor runs on outside, where a point light
/// 10× brighter than the one inside shines. Photons outside lie within a lookup radius of the inside floor,
/// so the gathered indirect light shows a bright band along the crack (nothing in the renderer stops it;
/// the final gather confines it to the band, where `photons` spreads it).
#[test]
fn a_light_leaking_through_a_crack() {
    let mut o = Obj::new();
    o.quad(
        "wall",
        [
            v(-3.0, 0.0, 3.0),
            v(3.0, 0.0, 3.0),
            v(3.0, 0.0, -3.0),
            v(-3.0, 0.0, -3.0),
        ],
    );
    o.cuboid(
        "wall",
        v(-1.0, 0.001, -1.0),
        v(1.0, 2.0, 1.0),
        true,
        &["-y"],
    );
    let lights = "[[light]]\ntype = \"point\"\nposition = [0.0, 1.0, -2.0]\nintensity = [100.0, 100.0, 100.0]\n\n\
                  [[light]]\ntype = \"point\"\nposition = [0.0, 1.8, 0.0]\nintensity = [10.0, 10.0, 10.0]\n\n";
    let scene = |extra: &str| {
        toml(
            v(0.0, 1.2, 0.95),
            v(0.0, 0.3, -1.0),
            70.0,
            (32, 32),
            &format!("{lights}{PHOTONS}{extra}"),
        )
    };
    let d = write(&o, MTL, &scene(""));
    let dn = write(&o, MTL, &scene(NO_CLAMP));
    let reference = render(d.path(), "path", 1024, &[]);
    let pm = render(d.path(), "pm", 64, &[]);
    let ph = render(d.path(), "photons", 64, &[]);
    let pm_nc = render(dn.path(), "pm", 64, &[]);
    let (e, e_ph, e_nc) = (
        err(&pm.img, &reference.img),
        err(&ph.img, &reference.img),
        err(&pm_nc.img, &reference.img),
    );
    report(
        "a",
        &[("pm", e), ("photons", e_ph), ("pm no clamping", e_nc)],
    );
    check("a", "pm", e, 0.014); // seeds 0–3: 0.0042–0.0053 (no clamping 0.0049–0.0062)
    check("a", "photons", e_ph, 0.064); // 0.027–0.031
    assert!(
        e < e_ph,
        "a: gathering must reduce the leak: pm {e} vs photons {e_ph}"
    );
}

/// b. A thin pillar (4 cm square) 3 cm in front of the back wall: gather rays from the wall behind it mostly
/// miss it, so records there are too large unless neighbor clamping shrinks them.
#[test]
fn b_thin_pillar_near_a_wall() {
    let mut o = Obj::new();
    open_room(&mut o);
    o.cuboid(
        "wall",
        v(-0.02, 0.0, -0.97),
        v(0.02, 1.98, -0.93),
        false,
        &[],
    );
    let d = write(&o, MTL, &room_toml(PHOTONS));
    let dn = write(&o, MTL, &room_toml(&format!("{PHOTONS}{NO_CLAMP}")));
    let reference = render(d.path(), "path", 1024, &[]);
    let pm = render(d.path(), "pm", 32, &[]);
    let pm_nc = render(dn.path(), "pm", 32, &[]);
    let (e, e_nc) = (
        err(&pm.img, &reference.img),
        err(&pm_nc.img, &reference.img),
    );
    report("b", &[("pm", e), ("pm no clamping", e_nc)]);
    check("b", "pm", e, 0.0016); // seeds 0–3: 0.00024–0.00046
    check("b", "pm without clamping", e_nc, 0.004); // 0.00035–0.00064; pm 0.55–0.73× of it
    assert!(
        e < e_nc,
        "b: neighbor clamping must help: {e} vs {e_nc} without"
    );
    assert!(stat(&pm, "icache", "shrunk_by_clamping") > 0.0);
}

/// c. Inside corners and creases: the room's 90° corners and an 11° crease between the floor and a ramp
/// leaning on the back wall, where tiny gather hit distances make translational gradients explode.
/// The remedy is the gradient limit (records whose gradient is too steep are shrunk).
#[test]
fn c_inside_corners_and_creases() {
    let mut o = Obj::new();
    open_room(&mut o);
    o.quad(
        "wall",
        [
            v(-1.0, 0.0, 0.5),
            v(1.0, 0.0, 0.5),
            v(1.0, 0.3, -1.0),
            v(-1.0, 0.3, -1.0),
        ],
    );
    let cam = |extra: &str| {
        toml(
            v(0.0, 1.3, 2.5),
            v(0.0, 0.3, -0.6),
            45.0,
            (32, 32),
            &format!("{PHOTONS}{extra}"),
        )
    };
    let d = write(&o, MTL, &cam(""));
    let dn = write(&o, MTL, &cam(NO_CLAMP));
    let dg = write(&o, MTL, &cam("[render.icache]\ngradients = false\n"));
    let reference = render(d.path(), "path", 1024, &[]);
    let pm = render(d.path(), "pm", 32, &[]);
    let pm_nc = render(dn.path(), "pm", 32, &[]);
    let pm_ng = render(dg.path(), "pm", 32, &[]);
    let (e, e_nc, e_ng) = (
        err(&pm.img, &reference.img),
        err(&pm_nc.img, &reference.img),
        err(&pm_ng.img, &reference.img),
    );
    report(
        "c",
        &[
            ("pm", e),
            ("pm no clamping", e_nc),
            ("pm no gradients", e_ng),
        ],
    );
    check("c", "pm", e, 0.0003); // seeds 0–3: 0.000054–0.000088
    check("c", "pm without clamping", e_nc, 0.0003); // 0.000097–0.000128 (without gradients
                                                     // 0.00011–0.00013: pm 0.49–0.66× of it)
    assert!(
        e < e_ng,
        "c: gradients (with their limit) must help in the crease: {e} vs {e_ng} without"
    );
    assert!(stat(&pm, "icache", "shrunk_by_gradient") > 0.0);
}

/// d. Scanline-order discontinuities. `fill = "one-pass"` is Ward's lazy fill in scanline order: each pixel
/// sees only the records made before it, so records made further down never reach back and the image
/// steps where they begin. The two-pass fill (pass A in hierarchical order, pass B only reads) must remove
/// that. Rendered at 64² (at 32² too few records exist for the order to matter). The cache's own error is
/// measured on the `indirect` layer against `pm-fg` (a gather at every sample: the same photon map with
/// no cache); steps are measured by [`step_error`]. The one-pass fill places ~10 % more records than the
/// two-pass fill at the same `accuracy`.
#[test]
fn d_scanline_order() {
    let mut o = Obj::new();
    open_room(&mut o);
    o.cuboid("wall", v(-0.5, 0.0, -0.5), v(-0.1, 0.8, -0.1), false, &[]);
    o.cuboid("wall", v(0.2, 0.0, -0.2), v(0.6, 0.4, 0.2), false, &[]);
    let scene = |extra: &str| {
        let t = toml(
            v(0.0, 1.0, 3.0),
            v(0.0, 1.0, 0.0),
            45.0,
            (64, 64),
            &format!("{PHOTONS}[render.icache]\n{extra}"),
        );
        write(&o, MTL, &t)
    };
    let (two, one) = (scene(""), scene("fill = \"one-pass\"\n"));
    let reference = render(two.path(), "path", 1024, &[]);
    render(two.path(), "pm-fg", 16, &[]); // read below as a layer: pm-fg-16-.exr
    let (pm, pm1) = (
        render(two.path(), "pm", 32, &[]),
        render(one.path(), "pm", 32, &[]),
    );
    let indirect = |d: &tempfile::TempDir, tag: &str| {
        pmrender::io::output::read_layer(&d.path().join(format!("{tag}.exr")), Some("indirect"))
            .expect("indirect layer")
    };
    let i_ref = indirect(&two, "pm-fg-16-");
    let (i2, i1) = (indirect(&two, "pm-32-"), indirect(&one, "pm-32-"));
    let records = |r: &Render| stat(r, "icache", "records_pass_a");
    let (steps2, steps1) = (step_error(&i2, &i_ref), step_error(&i1, &i_ref));
    let (cache_e2, cache_e1) = (rel_mse(&i2, &i_ref), rel_mse(&i1, &i_ref));
    let (e, e1) = (err(&pm.img, &reference.img), err(&pm1.img, &reference.img));
    let (misses, lookups) = (
        stat(&pm, "icache", "misses_pass_b"),
        stat(&pm, "icache", "lookups_pass_b"),
    );
    report(
        "d",
        &[
            ("records two-pass", records(&pm)),
            ("one-pass", records(&pm1)),
            ("indirect steps two-pass", steps2),
            ("one-pass", steps1),
            ("indirect relMSE two-pass", cache_e2),
            ("one-pass", cache_e1),
            ("beauty vs path two-pass", e),
            ("one-pass", e1),
            ("pass-B misses", misses),
            ("pass-B lookups", lookups),
        ],
    );
    // The two-pass fill removes the steps: seeds 0–3, steps 1.23–1.46e-4 vs 2.03–2.57e-4, 0.48–0.70×
    // (mean 0.61, sd 0.10); bound 0.9×, the worst plus 2 sd, below the 1× of a fill order that made
    // no difference. It places about as many records (pixel centres, and pixel corners that see another
    // surface): 337, 328, 334, 385 against 381, 380, 337, 366 (0.86–1.05×; "fewer", the bound until
    // now, failed at seed 3); bound 1.3×. The relMSEs are the records' gather noise and the photons'
    // (the same in both fills), not the fill order: indirect 0.37–0.78×, beauty 0.76–0.98× the
    // one-pass's, so they are only bounded here.
    assert!(
        records(&pm) < 1.3 * records(&pm1),
        "d: two-pass {} records vs one-pass {}",
        records(&pm),
        records(&pm1)
    );
    assert!(
        steps2 < 0.9 * steps1,
        "d: steps two-pass {steps2} vs one-pass {steps1}"
    );
    assert!(
        cache_e2 < 1.25 * cache_e1,
        "d: indirect relMSE two-pass {cache_e2} vs one-pass {cache_e1}"
    );
    assert!(
        e < 1.25 * e1,
        "d: error vs path two-pass {e} vs one-pass {e1}"
    );
    check("d", "two-pass", e, 0.0016); // seeds 0–3: 0.00031–0.00054
                                       // Seeds 0–3: no miss in 34 600–35 300 lookups.
    assert!(
        misses <= 0.005 * lookups,
        "d: {misses} pass-B misses in {lookups} lookups"
    );
    assert!(stat(&pm, "icache", "uncovered_after_fill") <= 10.0);
}

/// Error of the steps between neighbouring pixels: mean over horizontal and vertical neighbour pairs and
/// channels of (Δimg − Δref)² / (r̄² + 0.01), with r̄ the pair's reference mean. Discontinuities in the
/// interpolated irradiance show up here even where block errors average them out.
fn step_error(img: &Image, reference: &Image) -> f64 {
    let (w, h) = (img.width as usize, img.height as usize);
    let (mut sum, mut n) = (0.0f64, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then_some(i + 1), (y + 1 < h).then_some(i + w)]
                .into_iter()
                .flatten()
            {
                let d =
                    (img.pixels[j] - img.pixels[i]) - (reference.pixels[j] - reference.pixels[i]);
                let m = 0.5 * (reference.pixels[j] + reference.pixels[i]);
                for c in 0..3 {
                    sum += (d[c] as f64).powi(2) / ((m[c] as f64).powi(2) + 0.01);
                    n += 1;
                }
            }
        }
    }
    sum / n.max(1) as f64
}

/// e. The global map read directly (`photons`) is splotchy; gathering it (`pm`) must remove that.
#[test]
fn e_photons_versus_pm() {
    let mut o = Obj::new();
    open_room(&mut o);
    let d = write(&o, MTL, &room_toml(PHOTONS));
    let reference = render(d.path(), "path", 1024, &[]);
    // The estimators are compared, not the samplers: 32 samples in every pixel for both.
    let pm = render(d.path(), "pm", 32, &["--noise", "0"]);
    let ph = render(d.path(), "photons", 32, &["--noise", "0"]);
    let (e, e_ph) = (err(&pm.img, &reference.img), err(&ph.img, &reference.img));
    report("e", &[("pm", e), ("photons", e_ph)]);
    // pm / photons 0.22–0.39 at seeds 0–3 (0.34 at one seed before stratified samples took the
    // aliasing out of both errors).
    check("e", "pm", e, 0.0015); // seeds 0–3: 0.00021–0.00044
    check("e", "photons", e_ph, 0.0045); // 0.00075–0.00114 (0.0022 before samples were stratified)
    assert!(
        e < 0.65 * e_ph,
        "e: the splotches must go: pm {e} vs photons {e_ph}"
    );
}

/// f. A glass-sphere caustic with too few caustic photons (500) and with a huge lookup radius: the error
/// stays finite and bounded, and the defaults (100 000 caustic photons, automatic radius) do better.
#[test]
fn f_caustics_with_too_few_photons_or_too_large_a_radius() {
    let mut o = Obj::new();
    open_room(&mut o);
    o.sphere("glass", v(0.0, 0.45, -0.2), 0.4, 24, 12);
    let cam = |extra: &str| room_toml(&format!("{PHOTONS}{extra}"));
    let d = write(&o, MTL, &cam(""));
    let few = write(&o, MTL, &cam("caustic = 500\n"));
    let wide = write(&o, MTL, &cam("caustic = 500\nmax_radius = 100.0\n"));
    let reference = render(d.path(), "path", 1024, &[]);
    let pm = render(d.path(), "pm", 32, &[]);
    let pm_few = render(few.path(), "pm", 32, &[]);
    let pm_wide = render(wide.path(), "pm", 32, &[]);
    let (e, e_few, e_wide) = (
        err(&pm.img, &reference.img),
        err(&pm_few.img, &reference.img),
        err(&pm_wide.img, &reference.img),
    );
    report(
        "f",
        &[
            ("pm defaults", e),
            ("caustic 500", e_few),
            ("caustic 500, max_radius 100", e_wide),
        ],
    );
    check("f", "pm defaults", e, 0.006); // seeds 0–3: 0.0014–0.0018
    check("f", "caustic 500", e_few, 0.0066); // 0.0019–0.0026 (the defaults 0.68–0.70× of it)
    check("f", "caustic 500, max_radius 100", e_wide, 0.0104); // 0.0041–0.0050
    assert!(
        e < e_few && e < e_wide,
        "f: defaults must do better: {e} vs {e_few}, {e_wide}"
    );
    assert_eq!(stat(&pm_few, "photons", "caustic_stored"), 500.0);
}

/// g. Only specular surfaces: a closed mirror box. (1) With a point light nothing can be stored and nothing
/// is visible (analytic: black); the photon pass must give up, not emit forever. (2) With an emitter that is
/// itself a mirror (MTL `Ke` + `illum 3`), the image is the light seen through reflections: compared with
/// path (the difference is anti-aliasing noise of a kaleidoscope at 32 vs 256 spp).
#[test]
fn g_only_specular_surfaces() {
    let mut o = Obj::new();
    o.cuboid("mirror", v(-1.0, 0.0, -1.0), v(1.0, 2.0, 1.0), true, &[]);
    let point = "[[light]]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = [10.0, 10.0, 10.0]\n\n";
    let cam = |extra: &str| {
        toml(
            v(0.3, 0.8, 0.9),
            v(-0.2, 1.2, -1.0),
            60.0,
            (32, 32),
            &format!("{extra}{PHOTONS}"),
        )
    };
    let d = write(&o, MTL, &cam(point));
    let pm = render(d.path(), "pm", 8, &[]);
    let emitted = stat(&pm, "photons", "paths_emitted");
    report(
        "g point light",
        &[
            ("pm max", max_value(&pm.img) as f64),
            ("paths emitted", emitted),
        ],
    );
    assert_eq!(
        max_value(&pm.img),
        0.0,
        "g: a point light in a mirror box is invisible"
    );
    assert_eq!(stat(&pm, "photons", "global_stored"), 0.0);
    // Measured 212 992 paths: emission stops after 200k paths that stored nothing.
    assert!(
        emitted <= 500_000.0,
        "g: {emitted} photon paths for nothing"
    );

    let mut o2 = Obj::new();
    o2.cuboid("mirror", v(-1.0, 0.0, -1.0), v(1.0, 2.0, 1.0), true, &[]);
    ceiling_light(&mut o2, 0.25);
    let mtl = MTL.replace(
        "newmtl light\nKd 0 0 0\nKe 10 10 10\n",
        "newmtl light\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\nKe 10 10 10\n",
    );
    let d2 = write(&o2, &mtl, &cam(""));
    let reference = render(d2.path(), "path", 256, &[]);
    let pm2 = render(d2.path(), "pm", 32, &[]);
    let e = err(&pm2.img, &reference.img);
    report("g mirror emitter", &[("pm", e)]);
    check("g", "pm (mirror emitter)", e, 0.1); // seeds 0–3: 0.040–0.055
    assert_eq!(stat(&pm2, "photons", "global_stored"), 0.0);
}

/// h. No light reaches any diffuse surface: a spot over a floor points straight up into empty space.
/// Analytic answer: black; the photon pass gives up after storing nothing.
#[test]
fn h_no_light_reaches_a_diffuse_surface() {
    let mut o = Obj::new();
    o.quad(
        "wall",
        [
            v(-2.0, 0.0, 2.0),
            v(2.0, 0.0, 2.0),
            v(2.0, 0.0, -2.0),
            v(-2.0, 0.0, -2.0),
        ],
    );
    let spot = "[[light]]\ntype = \"spot\"\nposition = [0.0, 1.0, 0.0]\ntarget = [0.0, 5.0, 0.0]\n\
                intensity = [50.0, 50.0, 50.0]\ncone_angle = 30.0\n\n";
    let d = write(
        &o,
        MTL,
        &toml(
            v(0.0, 2.0, 3.0),
            v(0.0, 0.0, 0.0),
            45.0,
            (32, 32),
            &format!("{spot}{PHOTONS}"),
        ),
    );
    let pm = render(d.path(), "pm", 8, &[]);
    let path = render(d.path(), "path", 8, &[]);
    let emitted = stat(&pm, "photons", "paths_emitted");
    report(
        "h",
        &[
            ("pm max", max_value(&pm.img) as f64),
            ("path max", max_value(&path.img) as f64),
            ("paths emitted", emitted),
        ],
    );
    assert_eq!(max_value(&pm.img), 0.0);
    assert_eq!(max_value(&path.img), 0.0);
    assert!(
        emitted <= 500_000.0,
        "h: {emitted} photon paths for nothing"
    ); // measured 212 992
}

/// Renders [`sealed_box_scene`] with pm, photons and path at 8 spp.
fn sealed_box(y0: f32) -> (Render, Render, Render) {
    let d = sealed_box_scene(y0, PHOTONS);
    (
        render(d.path(), "pm", 8, &[]),
        render(d.path(), "photons", 8, &[]),
        render(d.path(), "path", 8, &[]),
    )
}

/// i. A point light sealed inside a closed diffuse box; the camera outside must see a black box (the walls
/// have no thickness: photons stored on their inside must not be seen from outside).
/// Box floating 0.3 above the floor: `pm`, `photons` and `path` must all be exactly black. This was a bug
/// the suite found (the precomputed irradiance's lookup, since replaced by the atlas, accepted the nearest point on its normal alone, so
/// final-gather rays hitting the floor under the box read the irradiance of the box's inside bottom face
/// 0.3 above it and the box glowed, up to 2.7 W/(m²·sr)); fixed with a tangent-plane distance test.
/// Box resting on the floor: its bottom is coplanar with the floor, so photons inside lie in the floor's
/// plane within a lookup radius of the floor outside — the crack leak of case a at zero distance, a
/// photon-map limitation (only a visibility test per photon would stop it). The bound is about twice the
/// measured leak, to catch it growing.
#[test]
fn i_light_sealed_in_a_box() {
    let zero = black(32, 32);
    let (pm, ph, path) = sealed_box(0.3);
    report(
        "i floating",
        &[
            ("pm max", max_value(&pm.img) as f64),
            ("photons max", max_value(&ph.img) as f64),
        ],
    );
    assert!(
        stat(&pm, "photons", "global_stored") > 0.0,
        "i: the photons are inside the box"
    );
    assert_eq!(max_value(&path.img), 0.0);
    assert_eq!(max_value(&ph.img), 0.0, "i: photons seen through a wall");
    assert_eq!(
        max_value(&pm.img),
        0.0,
        "i: light leaks out of a sealed floating box"
    );
    let (pm, ph, path) = sealed_box(0.0);
    let (e, e_ph) = (err(&pm.img, &zero), err(&ph.img, &zero));
    report(
        "i on the floor",
        &[
            ("pm", e),
            ("photons", e_ph),
            ("pm max", max_value(&pm.img) as f64),
        ],
    );
    assert_eq!(max_value(&path.img), 0.0);
    // Seeds 0–3: pm 1.38–1.68 (max pixel 1.5–2.0; it was 51 when the case was written), photons
    // 88–129.
    check("i on the floor", "pm", e, 3.5);
    check("i on the floor", "photons", e_ph, 250.0);
}

/// j. A broken copy of the open room: zero-area and degenerate triangles, duplicated vertices, a wall wound
/// the other way, a ceiling whose normals point out of the room, a wall whose per-vertex normals disagree
/// (pairs pointing in and out: they cancel on its diagonal), and walls without normals. Surfaces reflect on
/// both sides, so it must render like the clean room.
#[test]
fn j_broken_meshes() {
    let mut clean = Obj::new();
    open_room(&mut clean);
    let mut o = Obj::new();
    broken_room(&mut o);
    let dc = write(&clean, MTL, &room_toml(PHOTONS));
    let d = write(&o, MTL, &room_toml(PHOTONS));
    let reference = render(dc.path(), "path", 1024, &[]);
    let path = render(d.path(), "path", 1024, &[]);
    let pm = render(d.path(), "pm", 32, &[]);
    let pm_clean = render(dc.path(), "pm", 32, &[]);
    let (e, e_path, e_clean) = (
        err(&pm.img, &reference.img),
        err(&path.img, &reference.img),
        err(&pm_clean.img, &reference.img),
    );
    report(
        "j",
        &[
            ("pm broken vs path clean", e),
            ("path broken vs path clean", e_path),
            ("pm clean vs path clean", e_clean),
        ],
    );
    check("j", "pm broken", e, 0.003); // seeds 0–3: 0.00036–0.00060 (clean room's pm: 0.00023–0.00048)
    check("j", "path broken", e_path, 1e-4); // 1.9–2.3e-6
    assert_eq!(
        stat(&pm, "scene", "degenerate_triangles"),
        3.0,
        "j: the three zero-area floor triangles"
    );
}

/// k. The open room at scale 1e-3 and 1e4 (mesh `scale`, camera scaled with it): radiance does not depend
/// on scale, so the image must match the scale-1 render. Both do (1e-3 did not until the ray-offset
/// fix of `k_scale_1e_minus_3_matches_scale_1`: 0.043 against path).
#[test]
fn k_scale() {
    let d1 = scaled_room(1.0, PHOTONS);
    let reference = render(d1.path(), "path", 1024, &[]);
    let pm1 = render(d1.path(), "pm", 32, &[]);
    let e1 = err(&pm1.img, &reference.img);
    let big = render(scaled_room(1e4, PHOTONS).path(), "pm", 32, &[]);
    let small = render(scaled_room(1e-3, PHOTONS).path(), "pm", 32, &[]);
    let (e_big, e_big1) = (err(&big.img, &reference.img), err(&big.img, &pm1.img));
    let (e_small, e_small1) = (err(&small.img, &reference.img), err(&small.img, &pm1.img));
    report(
        "k",
        &[
            ("pm 1 vs path 1", e1),
            ("pm 1e4 vs path 1", e_big),
            ("pm 1e4 vs pm 1", e_big1),
            ("pm 1e-3 vs path 1", e_small),
            ("pm 1e-3 vs pm 1", e_small1),
        ],
    );
    // Seeds 0–3: pm at scale 1 0.00023–0.00048, at 1e4 0.00023–0.00049 and 1e-3 0.00023–0.00048
    // against path; against pm at scale 1, 1e4 7e-8 – 9.6e-5 and 1e-3 5e-6 – 9.9e-5.
    check("k", "pm scale 1", e1, 0.0015);
    check("k", "pm scale 1e4 vs path", e_big, 0.0016);
    check("k", "pm scale 1e4 vs pm scale 1", e_big1, 0.0002);
    check("k", "pm scale 1e-3 vs path", e_small, 0.0016);
    check("k", "pm scale 1e-3 vs pm scale 1", e_small1, 0.0002);
}

/// Was a bug (`offset_origin` moved origins near 0 by a fixed 1/65536: in the room at scale 1e-3 floor
/// shadow rays started above the light hanging 10 µm under the ceiling, and the image mean dropped from
/// 0.222 to 0.198); the fixed step now shrinks with the point's magnitude.
#[test]
fn k_scale_1e_minus_3_matches_scale_1() {
    let d1 = scaled_room(1.0, PHOTONS);
    let reference = render(d1.path(), "path", 1024, &[]);
    let small = render(scaled_room(1e-3, PHOTONS).path(), "path", 1024, &[]);
    let e = err(&small.img, &reference.img);
    check("k", "path scale 1e-3 vs path scale 1", e, 1e-4);
}
