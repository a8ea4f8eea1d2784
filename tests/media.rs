//! Participating media: closed forms that a volumetric renderer must reproduce, the scene
//! keys' validation, and determinism across thread counts.
//!
//! - Beer–Lambert: an emitter seen through purely absorbing slabs, one nested in the other (exact).
//! - Single scattering in a slab lit by a directional light (closed form; `max_depth = 1` keeps only
//!   the light scattered once).
//! - A furnace: a black sphere whose inside emits Le, filled with a medium of albedo 1, is Le
//!   everywhere.
//! - Volume photons lie inside the medium's boundary.
//! - A ray crosses many nearly clear media without losing light: 130 slabs between the light and
//!   the floor render as the room without them.

mod common;
use common::*;

use glam::Vec3;

/// An axis-aligned box as OBJ text with material `mtl`, vertices numbered from `base + 1`, faces wound
/// outward (`inward` turns them).
fn box_obj(lo: [f32; 3], hi: [f32; 3], mtl: &str, base: usize, inward: bool) -> String {
    let mut s = format!("usemtl {mtl}\n");
    for k in 0..8 {
        let c = |axis: usize| {
            if k >> axis & 1 == 1 {
                hi[axis]
            } else {
                lo[axis]
            }
        };
        s += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    // Corner k has x = bit 0, y = bit 1, z = bit 2; each face listed counter-clockwise seen from outside.
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    for f in faces {
        let [a, b, c, d] = f.map(|i| i + base + 1);
        s += &if inward {
            format!("f {a} {c} {b}\nf {a} {d} {c}\n")
        } else {
            format!("f {a} {b} {c}\nf {a} {c} {d}\n")
        };
    }
    s
}

/// A quad in the plane z = `z` spanning ±`half` in x and y, facing +z.
fn quad_facing_z(z: f32, half: f32, mtl: &str, base: usize) -> String {
    let mut s = format!("usemtl {mtl}\n");
    for (x, y) in [(-half, -half), (half, -half), (half, half), (-half, half)] {
        s += &format!("v {x} {y} {z}\n");
    }
    let b = base + 1;
    s + &format!("f {} {} {}\nf {} {} {}\n", b, b + 1, b + 2, b, b + 2, b + 3)
}

fn render(dir: &std::path::Path, extra: &[&str]) -> pmrender::io::output::Image {
    let out = dir.join("out.exr");
    let scene = p(dir, "scene.toml");
    let mut args = vec![
        "render",
        scene.as_str(),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let img = read(&out);
    std::fs::remove_file(&out).unwrap();
    img
}

fn center(img: &pmrender::io::output::Image) -> Vec3 {
    let (w, h) = (img.width, img.height);
    let mut s = Vec3::ZERO;
    for y in h / 2 - 1..h / 2 + 1 {
        for x in w / 2 - 1..w / 2 + 1 {
            s += img.pixels[(y * img.width + x) as usize];
        }
    }
    s / 4.0
}

const SLAB_MTL: &str =
    "newmtl boundary\nKd 0 0 0\nnewmtl inner\nKd 0 0 0\nnewmtl lamp\nKd 0 0 0\nKe 1 1 1\n";

/// An emitter of radiance 1 at z = −2 seen along −z through an absorbing slab (z ∈ [0, 1]) holding a
/// second, more absorbing one (z ∈ [0.25, 0.5]); both boundaries are null.
fn absorbing_slabs() -> tempfile::TempDir {
    let toml = r#"version = 1
[camera]
eye = [0.0, 0.0, 10.0]
target = [0.0, 0.0, 0.0]
fov = 5.0
width = 16
height = 16

[[medium]]
name = "ink"
sigma_a = [0.5, 1.0, 2.0]
sigma_s = [0.0, 0.0, 0.0]

[[medium]]
name = "dye"
sigma_a = [3.0, 0.0, 1.0]
sigma_s = [0.0, 0.0, 0.0]

[[mesh]]
obj = "outer.obj"
interior = "ink"

[[mesh]]
obj = "inner.obj"
interior = "dye"

[[mesh]]
obj = "lamp.obj"

[materials.boundary]
type = "null"

[materials.inner]
type = "null"

[render]
method = "path"
spp = 4
"#;
    let obj = |body: String| format!("mtllib scene.mtl\n{body}");
    scene_dir(&[
        ("scene.mtl", SLAB_MTL),
        (
            "outer.obj",
            &obj(box_obj(
                [-5.0, -5.0, 0.0],
                [5.0, 5.0, 1.0],
                "boundary",
                0,
                false,
            )),
        ),
        // Wound inward: the inside is found from the mesh's volume, whatever its winding.
        (
            "inner.obj",
            &obj(box_obj(
                [-4.0, -4.0, 0.25],
                [4.0, 4.0, 0.5],
                "inner",
                0,
                true,
            )),
        ),
        ("lamp.obj", &obj(quad_facing_z(-2.0, 8.0, "lamp", 0))),
        ("scene.toml", toml),
    ])
}

#[test]
fn beer_lambert_through_nested_absorbing_slabs_is_exact() {
    let d = absorbing_slabs();
    let img = render(d.path(), &[]);
    // Through 0.75 of ink and 0.25 of dye (the rays are within 0.1° of the axis: cos = 1 − 2e-6).
    let expect = (-(Vec3::new(0.5, 1.0, 2.0) * 0.75 + Vec3::new(3.0, 0.0, 1.0) * 0.25)).exp();
    let got = center(&img);
    assert!(
        (got - expect).abs().max_element() < 1e-4 * expect.max_element(),
        "got {got}, expected {expect}"
    );
    // The slab's edge is outside the view: every pixel sees the same (to the cosine of its ray).
    for y in 0..img.height {
        for x in 0..img.width {
            let v = img.pixels[(y * img.width + x) as usize];
            assert!(
                (v - expect).abs().max_element() < 2e-3 * expect.max_element(),
                "pixel {x},{y}: {v} vs {expect}"
            );
        }
    }
}

/// Single scattering of a directional light (irradiance E, direction making angle θ with the slab's
/// normal) seen straight down through a slab of thickness d: L = σs p E (1 − e^{−σt d (1 + 1/μ)}) /
/// (σt (1 + 1/μ)), μ = cos θ, p the phase function at the angle between the view ray and the light.
#[test]
fn single_scattering_in_a_slab_matches_its_closed_form() {
    let (sa, ss, g, d, e) = (
        Vec3::new(0.1, 0.2, 0.4),
        Vec3::new(0.6, 0.3, 0.1),
        0.4f32,
        1.0f32,
        2.0f32,
    );
    let theta = 40f32.to_radians();
    let obj = String::from("mtllib scene.mtl\n")
        + &box_obj(
            [-60.0, -60.0, -1.0],
            [60.0, 60.0, 0.0],
            "boundary",
            0,
            false,
        );
    let light_dir = Vec3::new(theta.sin(), 0.0, -theta.cos()); // travels down into the slab
    let toml = format!(
        r#"version = 1
[camera]
eye = [0.0, 0.0, 10.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 8.0
width = 16
height = 16

[[medium]]
name = "fog"
sigma_a = [{}, {}, {}]
sigma_s = [{}, {}, {}]
g = {g}

[[mesh]]
obj = "slab.obj"
interior = "fog"

[materials.boundary]
type = "null"

[[light]]
type = "directional"
direction = [{}, {}, {}]
irradiance = [{e}, {e}, {e}]

[render]
method = "path"
spp = 1024
max_depth = 1
"#,
        sa.x, sa.y, sa.z, ss.x, ss.y, ss.z, light_dir.x, light_dir.y, light_dir.z
    );
    let dir = scene_dir(&[
        ("scene.mtl", "newmtl boundary\nKd 0 0 0\n"),
        ("slab.obj", &obj),
        ("scene.toml", &toml),
    ]);
    let img = render(dir.path(), &[]);
    let st = sa + ss;
    let mu = theta.cos();
    let view = Vec3::new(0.0, 0.0, -1.0);
    let p = pmrender::medium::hg(g, view.dot(-light_dir));
    let k = 1.0 + 1.0 / mu;
    let expect = ss * p * e * (Vec3::ONE - (-st * d * k).exp()) / (st * k);
    let got = mean(&img);
    let rel = ((got - expect) / expect).abs().max_element();
    // Seeds 0–11, worst channel: −0.12 … +0.61 % (SSE4.2 at seed 0 as seed 0: +0.23 %); bound 1.5 %,
    // 2.5× the worst. A wrong phase or transmittance factor moves it by tens of per cent.
    assert!(
        rel < 0.015,
        "mean {got}, closed form {expect} ({:.2} % off)",
        rel * 100.0
    );
}

/// A black sphere whose inside emits 1, filled with a medium that scatters all it meets (albedo 1,
/// forward-scattering): every path ends on the emitter, so L = 1 in every pixel.
#[test]
fn furnace_filled_with_a_scattering_medium_conserves_energy() {
    let sphere = inward_sphere(24, 12);
    let toml = r#"version = 1
[camera]
eye = [0.1, 0.2, 0.05]
target = [1.0, 0.3, 0.2]
fov = 120.0
width = 16
height = 16

[[medium]]
name = "milk"
sigma_a = [0.0, 0.0, 0.0]
sigma_s = [2.0, 1.0, 4.0]
g = 0.5

[[mesh]]
obj = "sphere.obj"
interior = "milk"

[render]
method = "path"
spp = 64
max_depth = 1000
"#;
    let dir = scene_dir(&[
        ("furnace.mtl", "newmtl inside\nKd 0 0 0\nKe 1 1 1\n"),
        ("sphere.obj", &sphere),
        ("scene.toml", toml),
    ]);
    let img = render(dir.path(), &[]);
    let m = mean(&img);
    // Each channel's mean is noise around 1 (one distance-sampling channel serves all three): seeds
    // 0–11, worst channel 0.34–1.90 % off (−1.48 … +1.90 %; the bound of 1 % failed at seeds 2 and
    // 11). Bound 3 %, 1.6× the worst.
    assert!(
        (m - Vec3::ONE).abs().max_element() < 0.03,
        "mean {m}, expected 1"
    );
}

#[test]
fn media_images_do_not_depend_on_the_thread_count() {
    let sphere = inward_sphere(16, 8);
    let toml = "version = 1\n[camera]\neye = [0.1, 0.2, 0.05]\ntarget = [1.0, 0.3, 0.2]\nfov = 100.0\nwidth = 12\nheight = 10\n\n[[medium]]\nname = \"fog\"\nsigma_a = [0.3, 0.2, 0.1]\nsigma_s = [1.0, 1.5, 2.0]\ng = -0.3\n\n[[mesh]]\nobj = \"sphere.obj\"\ninterior = \"fog\"\n\n[[light]]\ntype = \"point\"\nposition = [0.0, 0.5, 0.0]\nintensity = [1.0, 1.0, 1.0]\n\n[render]\nmethod = \"path\"\nspp = 8\n";
    let dir = scene_dir(&[
        ("furnace.mtl", "newmtl inside\nKd 0.5 0.5 0.5\n"),
        ("sphere.obj", &sphere),
        ("scene.toml", toml),
    ]);
    let a = render(dir.path(), &["--threads", "1"]);
    let b = render(dir.path(), &["--threads", "2"]);
    assert_eq!(a.pixels, b.pixels);
    assert!(mean(&a).min_element() > 0.0);
}

/// Bad media input: exit status 2, one line naming the file and line of the key at fault, no output.
#[test]
fn bad_media_keys_are_refused_with_their_line() {
    let base_obj = String::from("mtllib scene.mtl\n")
        + &box_obj([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], "boundary", 0, false);
    let lamp_obj = String::from("mtllib scene.mtl\n") + &quad_facing_z(-3.0, 4.0, "lamp", 0);
    let base = r#"version = 1
[camera]
eye = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
width = 8
height = 8

[[medium]]
name = "fog"
sigma_a = [0.1, 0.1, 0.1]
sigma_s = [0.5, 0.5, 0.5]
g = 0.0

[[mesh]]
obj = "scene.obj"
interior = "fog"

[materials.boundary]
type = "null"

[render]
method = "path"

[[mesh]]
obj = "lamp.obj"
"#;
    // Sanity: the base scene renders.
    let ok = scene_dir(&[
        ("scene.mtl", SLAB_MTL),
        ("scene.obj", &base_obj),
        ("lamp.obj", &lamp_obj),
        ("scene.toml", base),
    ]);
    render(ok.path(), &["--spp", "1"]);
    let open_obj = base_obj.replacen("f 1 3 4\nf 1 4 2\n", "", 1);
    let flipped_obj = base_obj.replacen("f 1 3 4\n", "f 1 4 3\n", 1);
    let cases: Vec<(String, String, &[&str])> = vec![
        (base.replace("sigma_a = [0.1, 0.1, 0.1]", "sigma_a = [0.1, -1.0, 0.1]"), base_obj.clone(), &["scene.toml:11:", "medium.sigma_a", "-1"]),
        (base.replace("sigma_s = [0.5, 0.5, 0.5]", "sigma_s = [0.5, 1e30, 0.5]"), base_obj.clone(), &["scene.toml:12:", "medium.sigma_s"]),
        (base.replace("g = 0.0", "g = 1.0"), base_obj.clone(), &["scene.toml:13:", "medium.g", "(-1, 1)"]),
        // Below 1, but 1 in single precision: named as given, not as "1 is outside".
        (base.replace("g = 0.0", "g = 0.99999999"), base_obj.clone(), &["scene.toml:13:", "medium.g", "0.99999999 rounds to 1 in single precision"]),
        (base.replace("interior = \"fog\"", "interior = \"smoke\""), base_obj.clone(), &["scene.toml:17:", "mesh.interior", "'smoke'"]),
        (base.replace("fov = 40.0", "fov = 40.0\nmedium = \"fog\""), base_obj.clone(), &["scene.toml:6:", "camera.medium", "not 'fog'"]),
        (base.replace("fov = 40.0", "fov = 40.0\nmedium = \"haze\""), base_obj.clone(), &["scene.toml:6:", "camera.medium", "'haze'"]),
        (base.to_string(), open_obj.clone(), &["scene.toml:17:", "not closed"]),
        (base.to_string(), flipped_obj, &["scene.toml:17:", "not consistently oriented"]),
        (base.replace("interior = \"fog\"\n", ""), base_obj.clone(), &["scene.toml:19:", "materials.boundary", "only for the boundary of a medium"]),
        (base.replace("name = \"fog\"", "name = \"fog\"\ncolour = 3"), base_obj.clone(), &["scene.toml:11:", "colour"]),
        (base.replace("[materials.boundary]\ntype = \"null\"", "[materials.boundary]\ntype = \"null\"\nemission = [1.0, 1.0, 1.0]"), base_obj.clone(), &["scene.toml:20:", "cannot emit"]),
        (base.replace("[[mesh]]", "[[medium]]\nname = \"fog\"\nsigma_a = [0.0, 0.0, 0.0]\nsigma_s = [0.0, 0.0, 0.0]\n\n[[mesh]]"), base_obj.clone(), &["scene.toml:16:", "medium.name", "'fog'"]),
    ];
    for (toml, obj, expect) in cases {
        let d = scene_dir(&[
            ("scene.mtl", SLAB_MTL),
            ("scene.obj", &obj),
            ("lamp.obj", &lamp_obj),
            ("scene.toml", &toml),
        ]);
        let out = d.path().join("out.exr");
        let scene = p(d.path(), "scene.toml");
        let r = run(&["render", &scene, "-o", out.to_str().unwrap(), "--quiet"]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{toml}\n{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        for e in expect {
            assert!(stderr.contains(e), "'{e}' not in: {stderr}");
        }
        assert!(!out.exists());
    }
}

/// Renders a shipped scene with `method` at `w`×`h` into `dir`; returns the beauty and, for the photon
/// methods, the two media layers.
fn render_shipped(
    scene: &str,
    method: &str,
    w: u32,
    h: u32,
    dir: &std::path::Path,
    extra: &[&str],
) -> (pmrender::io::output::Image, Option<(Vec3, Vec3)>) {
    let scene = repo().join("scenes").join(scene);
    let out = dir.join(format!("{method}.exr"));
    let (w, h) = (w.to_string(), h.to_string());
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
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
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let beauty = read(&out);
    let layers = (method != "path").then(|| {
        let single = pmrender::io::output::read_layer(&out, Some("media_single"))
            .expect("media_single layer");
        let multiple = pmrender::io::output::read_layer(&out, Some("media_multiple"))
            .expect("media_multiple layer");
        (mean(&single), mean(&multiple))
    });
    (beauty, layers)
}

/// The Cornell box in fog (glass sphere, block, area light) against its Mitsuba 3 reference
/// (`volpath`, 4096 spp, tests/reference/fog-cornell-path.json): our `path` and every photon-map
/// method on the image mean. Measured at 64², seed 0 (worst channel): path +0.29 % (512 spp), pm
/// −0.20 %, pm-fg +0.63 %, photons −0.36 % (with k-NN estimates at 4 steps instead of the media
/// radiance cache: pm −0.8 %, twice the time); other seeds not measured yet (their renders are the
/// suite's slowest), so the bounds stay 2.5–5× that. Before final-gather rays saw the fog's own glow
/// pm was 10 % dark; with the invisible boundaries counted as surfaces by the photon-disc probes, 14 %.
#[test]
fn every_method_agrees_with_mitsuba_in_the_fogged_cornell_box() {
    let dir = tempfile::tempdir().unwrap();
    let reference = read(&repo().join("tests/reference/fog-cornell-path.exr"));
    let r = mean(&reference);
    for (method, extra, bound) in [
        ("path", &["--spp", "512"][..], 0.015),
        ("pm", &[][..], 0.025),
        ("pm-fg", &[][..], 0.03),
        ("photons", &[][..], 0.025),
    ] {
        let (img, layers) = render_shipped("fog-cornell.toml", method, 64, 64, dir.path(), extra);
        let m = mean(&img);
        let off = ((m - r) / r).abs().max_element();
        assert!(
            off < bound,
            "{method}: mean {m} vs Mitsuba {r} ({:.1} % off, bound {:.1} %)",
            off * 100.0,
            bound * 100.0
        );
        if let Some((single, multiple)) = layers {
            // The fog glows: both media terms carry light (several % of the image each).
            assert!(
                single.x > 0.03 * m.x && multiple.x > 0.03 * m.x,
                "{method}: media layers {single} {multiple} of {m}"
            );
        }
    }
}

/// The snooted lamp through a glass sphere in fog (the beam and the volume caustic) against its
/// Mitsuba 3 reference (`volpath`, 65536 spp; a noisy one, relMSE 0.014 per pixel: the caustic light
/// reaches it only when a path hits the small lamp through the glass). At 64 fixed samples (the light
/// seen through the sphere is heavy-tailed; adaptive sampling's stopping rule biases it): measured pm
/// −0.11 % (seed 0), pm-fg −0.26 % (seeds 1–4 move pm's mean between −0.14 and +1.13 %: the photon maps'
/// noise; the reference's image mean has a standard error of 0.55 % of its own). Our `path` is too noisy here for a test (1024 spp: −6 %, 2048:
/// −1.7 %).
#[test]
fn photon_methods_agree_with_mitsuba_on_the_volume_caustic() {
    let dir = tempfile::tempdir().unwrap();
    let r = mean(&read(&repo().join("tests/reference/fog-spot-path.exr")));
    for method in ["pm", "pm-fg"] {
        let (img, layers) = render_shipped(
            "fog-spot.toml",
            method,
            64,
            48,
            dir.path(),
            &["--spp", "64", "--noise", "0"],
        );
        let m = mean(&img);
        let off = ((m - r) / r).abs().max_element();
        assert!(
            off < 0.05,
            "{method}: mean {m} vs Mitsuba {r} ({:.1} % off)",
            off * 100.0
        );
        // The beam and the volume caustic are multiple scattering here (through glass): most of the fog's light.
        let (single, multiple) = layers.unwrap();
        assert!(
            multiple.x > 3.0 * single.x && multiple.x > 0.15 * m.x,
            "{method}: media layers {single} {multiple} of {m}"
        );
    }
}

#[test]
fn pm_in_media_does_not_depend_on_the_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let (a, _) = render_shipped(
        "fog-spot.toml",
        "pm",
        24,
        18,
        dir.path(),
        &["--threads", "1"],
    );
    let (b, _) = render_shipped(
        "fog-spot.toml",
        "pm",
        24,
        18,
        dir.path(),
        &["--threads", "2"],
    );
    assert_eq!(a.pixels, b.pixels);
}

/// `pm`'s media radiance cache (Jarosz et al. 2008): pass A places records along the camera rays of a
/// pixel lattice, adaptively (radii from the surfaces around, the gradient, the mean free path: they
/// differ several-fold), clamped by their neighbours, covering every pass-A point; pass B makes none and
/// misses ≤ 0.1 % of its lookups — at the reference size (every pixel) and at 4× the pixels (every
/// second pixel of the lattice). Measured: fog-spot 64×48 2.3 k records for 72 k points, 0.005 % misses;
/// fog-cornell 256² 0.015 %.
#[test]
fn the_media_cache_covers_what_camera_rays_need() {
    let dir = tempfile::tempdir().unwrap();
    for (w, h, stride) in [(64u32, 48u32, 1u64), (128, 96, 1), (160, 144, 2)] {
        let json = dir.path().join(format!("{w}.json"));
        render_shipped(
            "fog-spot.toml",
            "pm",
            w,
            h,
            dir.path(),
            &[
                "--stats",
                json.to_str().unwrap(),
                "--spp",
                "4",
                "--noise",
                "0",
            ],
        );
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let m = &stats["media"];
        let n = |k: &str| m[k].as_f64().unwrap_or_else(|| panic!("media.{k} missing"));
        assert_eq!(n("lattice_stride") as u64, stride, "{w}×{h}");
        assert!(
            n("records") > 100.0 && n("records") < 0.25 * n("points"),
            "{w}×{h}: {} records for {} points",
            n("records"),
            n("points")
        );
        assert_eq!(n("uncovered_after_fill"), 0.0, "{w}×{h}");
        assert!(
            n("misses") <= 0.001 * n("lookups") && n("lookups") > 0.0,
            "{w}×{h}: {} misses of {} lookups",
            n("misses"),
            n("lookups")
        );
        let r = &m["radius_px"];
        assert!(
            r["max"].as_f64().unwrap() > 3.0 * r["min"].as_f64().unwrap(),
            "{w}×{h}: radii {r}"
        );
    }
}

/// Photon files hold the volume and volume caustic maps: a render that loads them is the render that
/// traced and saved them, bit for bit (fog-spot has all four maps).
#[test]
fn photon_files_hold_the_volume_maps() {
    let dir = tempfile::tempdir().unwrap();
    let ph = dir.path().join("p.bin");
    let ph_arg = ph.to_str().unwrap();
    let (saved, _) = render_shipped(
        "fog-spot.toml",
        "pm",
        24,
        18,
        dir.path(),
        &["--save-photons", ph_arg, "--seed", "5"],
    );
    assert!(ph.exists());
    let (loaded, _) = render_shipped(
        "fog-spot.toml",
        "pm",
        24,
        18,
        dir.path(),
        &["--load-photons", ph_arg, "--seed", "5"],
    );
    assert!(
        saved.pixels == loaded.pixels,
        "the render from the file differs from the one that saved it"
    );
    let bytes = std::fs::read(&ph).unwrap();
    let volume = u64::from_le_bytes(bytes[144..152].try_into().unwrap());
    let volume_caustic = u64::from_le_bytes(bytes[152..160].try_into().unwrap());
    assert!(
        volume > 0 && volume_caustic > 0,
        "volume photons {volume}, volume caustic {volume_caustic}"
    );
}

/// Single scattering of a point light in a fogged black room, against a numerical integral of
/// σs·Tr·p·I/d²·Tr along every ray (16 sub-pixel rays per pixel, 4000 steps each): `pm`'s
/// `media_single` layer (default, adaptive sampling) and `path` with `max_depth = 1` (light scattered
/// once, nothing else). Measured over seeds 0–11: pm −0.11 … +0.18 %, path −0.39 … +0.48 %; bound
/// 1.5 %, 3× the worst. (With the light in view, pm's adaptive
/// sampling runs +3 % at 16²: the glow's singularity gives its pixel infinite variance.)
#[test]
fn single_scattering_of_a_point_light_matches_a_numerical_integral() {
    let (ss, sa, g) = (0.6f32, 0.05f32, 0.3f32);
    let (lo, hi) = (Vec3::new(-0.99, 0.01, -0.99), Vec3::new(0.99, 1.99, 0.99));
    // The light is out of view: a point light seen in fog is a singularity of the image (the glow ∝ 1/h
    // at distance h from it: infinite variance in its pixel, for every sampler).
    let (eye, light) = (Vec3::new(0.0, 1.0, 0.95), Vec3::new(0.7, 1.8, 0.8));
    let room = String::from("mtllib s.mtl\n")
        + &box_obj([-1.0, 0.0, -1.0], [1.0, 2.0, 1.0], "wall", 0, true);
    let fog = String::from("mtllib s.mtl\n")
        + &box_obj(lo.to_array(), hi.to_array(), "boundary", 0, false);
    let toml = |depth: &str| {
        format!(
            "version = 1\n[camera]\neye = [0.0, 1.0, 0.95]\ntarget = [0.0, 1.0, -1.0]\nfov = 80.0\nwidth = 16\nheight = 16\n\n[[medium]]\nname = \"fog\"\nsigma_a = [{sa}, {sa}, {sa}]\nsigma_s = [{ss}, {ss}, {ss}]\ng = {g}\n\n[[mesh]]\nobj = \"room.obj\"\n\n[[mesh]]\nobj = \"fog.obj\"\ninterior = \"fog\"\n\n[materials.boundary]\ntype = \"null\"\n\n[[light]]\ntype = \"point\"\nposition = [0.7, 1.8, 0.8]\nintensity = [1.0, 1.0, 1.0]\n{depth}"
        )
    };
    let mtl = "newmtl wall\nKd 0 0 0\nnewmtl boundary\nKd 0 0 0\n";
    let dir = scene_dir(&[
        ("s.mtl", mtl),
        ("room.obj", &room),
        ("fog.obj", &fog),
        ("scene.toml", &toml("")),
    ]);
    let once = scene_dir(&[
        ("s.mtl", mtl),
        ("room.obj", &room),
        ("fog.obj", &fog),
        ("scene.toml", &toml("\n[render]\nmax_depth = 1\n")),
    ]);
    // The integral, with the renderer's camera (vertical fov, square image).
    let st = ss + sa;
    let tan_half = 40f32.to_radians().tan();
    let (n_px, sub, steps) = (16, 4, 4000);
    let mut total = 0.0f64;
    for py in 0..n_px {
        for px in 0..n_px {
            for s in 0..sub * sub {
                let x = px as f32 + ((s % sub) as f32 + 0.5) / sub as f32;
                let y = py as f32 + ((s / sub) as f32 + 0.5) / sub as f32;
                let d = Vec3::new(
                    (2.0 * x / n_px as f32 - 1.0) * tan_half,
                    (1.0 - 2.0 * y / n_px as f32) * tan_half,
                    -1.0,
                )
                .normalize();
                let exit = (0..3)
                    .map(|a| {
                        if d[a] > 0.0 {
                            (hi[a] - eye[a]) / d[a]
                        } else if d[a] < 0.0 {
                            (lo[a] - eye[a]) / d[a]
                        } else {
                            f32::INFINITY
                        }
                    })
                    .fold(f32::INFINITY, f32::min);
                let dt = exit / steps as f32;
                for k in 0..steps {
                    let t = (k as f32 + 0.5) * dt;
                    let p = eye + d * t;
                    let to = light - p;
                    let dist = to.length();
                    let f = ss * (-st * t).exp() * pmrender::medium::phase(g, d, to / dist)
                        / (dist * dist)
                        * (-st * dist).exp();
                    total += (f * dt) as f64;
                }
            }
        }
    }
    let exact = total / (n_px * n_px * sub * sub) as f64;
    let (pm, layers) = {
        let out = dir.path().join("pm.exr");
        let scene = p(dir.path(), "scene.toml");
        let r = run(&[
            "render",
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--method",
            "pm",
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        (
            read(&out),
            pmrender::io::output::read_layer(&out, Some("media_single")).unwrap(),
        )
    };
    let single = mean(&layers).x as f64;
    assert!(
        (single / exact - 1.0).abs() < 0.015,
        "pm media_single {single} vs integral {exact}"
    );
    assert!(
        mean(&pm).x as f64 > single,
        "the multiply scattered light adds to it"
    );
    let path = render(once.path(), &["--method", "path", "--spp", "1024"]);
    let m = mean(&path).x as f64;
    assert!(
        (m / exact - 1.0).abs() < 0.015,
        "path (max_depth 1) {m} vs integral {exact}"
    );
}

/// A fog so dense (σs = 1e9 per unit, albedo ≈ 1, g near 1) that photons never leave it and nothing
/// reaches a surface: every method still finishes (the photon pass gave the global map up to 20 M
/// paths of 64 scatterings each before the media path budget) and writes finite pixels. A render still
/// running after two minutes is killed and fails the test: a hang guard, not a speed target.
#[test]
fn a_dense_fog_does_not_hang_any_method() {
    let scene = std::fs::read_to_string(repo().join("scenes/fog-cornell.toml")).unwrap();
    let scene = scene
        .replace("sigma_s = [0.25, 0.25, 0.25]", "sigma_s = [1e9, 1e9, 1e9]")
        .replace("g = 0.3", "g = 0.99999")
        .replace("models/", &format!("{}/scenes/models/", repo().display()));
    let dir = scene_dir(&[("scene.toml", &scene)]);
    let (scene, out) = (p(dir.path(), "scene.toml"), dir.path().join("out.exr"));
    for method in ["path", "pm", "pm-fg", "photons"] {
        let args = [
            "render",
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--method",
            method,
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "4",
            "--quiet",
        ];
        let r = run_bounded(&args, std::time::Duration::from_secs(120));
        assert!(
            r.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        let img = read(&out);
        assert!(
            img.pixels.iter().all(|p| p.is_finite()),
            "{method}: non-finite pixels"
        );
    }
}

/// Renders `scene` (shipped) at its reference's size with `method` and `extra`; returns the image and
/// the wall time of the run.
fn timed_render(
    scene: &str,
    method: &str,
    w: u32,
    h: u32,
    dir: &std::path::Path,
    extra: &[&str],
) -> (pmrender::io::output::Image, f64) {
    let start = std::time::Instant::now();
    let (img, _) = render_shipped(scene, method, w, h, dir, extra);
    (img, start.elapsed().as_secs_f64())
}

/// `pm` with its defaults is more accurate than `path` in the same wall time
/// on both shipped fog scenes. `path` is timed at 8 and 24 spp (a fixed cost plus a cost per sample)
/// and rendered at the count that fits `pm`'s time; both against the Mitsuba references by pixel relMSE.
/// Measured (chart of 2026-11-27): fog-cornell pm 0.00129 in 4.1 s against path's 0.0090; fog-spot pm
/// 0.0147 (the reference's own noise is 0.0144) against path's ~1.5 at any budget under 10 s (the lamp
/// seen through the sphere). Slow: `make test-slow`.
#[test]
#[ignore = "slow: make test-slow"]
fn pm_beats_path_at_equal_time_in_both_fog_scenes() {
    let dir = tempfile::tempdir().unwrap();
    for (scene, name, w, h) in [
        ("fog-cornell.toml", "fog-cornell", 64, 64),
        ("fog-spot.toml", "fog-spot", 64, 48),
    ] {
        let reference = read(&repo().join(format!("tests/reference/{name}-path.exr")));
        let (pm, t_pm) = timed_render(scene, "pm", w, h, dir.path(), &[]);
        let (_, t8) = timed_render(scene, "path", w, h, dir.path(), &["--spp", "8"]);
        let (_, t24) = timed_render(scene, "path", w, h, dir.path(), &["--spp", "24"]);
        let per_spp = ((t24 - t8) / 16.0).max(1e-6);
        let spp = (((t_pm - (t8 - 8.0 * per_spp)) / per_spp).round() as u32)
            .clamp(8, 65536)
            .to_string();
        let (path, t_path) = timed_render(scene, "path", w, h, dir.path(), &["--spp", &spp]);
        let (e_pm, e_path) = (rel_mse(&pm, &reference), rel_mse(&path, &reference));
        eprintln!("[{name}] pm {t_pm:.1} s relMSE {e_pm:.5}; path {spp} spp {t_path:.1} s relMSE {e_path:.5}");
        assert!(e_pm < 0.5 * e_path, "{name}: pm relMSE {e_pm:.5} in {t_pm:.1} s is not half of path's {e_path:.5} at {spp} spp ({t_path:.1} s)");
    }
}

/// Boundaries nested deeper than the limit are refused on the innermost's line, before any ray: every
/// ray crosses each of them, so the time grew with the depth (80 nested boxes took 75 s at 32²). The
/// limit itself renders.
#[test]
fn boundaries_nested_too_deep_are_refused() {
    let scene = |n: usize| {
        let mut toml = String::from(
            "version = 1\n[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n\n[[medium]]\nname = \"fog\"\nsigma_a = [0.01, 0.01, 0.01]\nsigma_s = [0.05, 0.05, 0.05]\n\n[materials.boundary]\ntype = \"null\"\n\n[render]\nmethod = \"path\"\nspp = 1\n\n[[mesh]]\nobj = \"lamp.obj\"\n",
        );
        let mut files = vec![
            ("scene.mtl".to_string(), SLAB_MTL.to_string()),
            (
                "lamp.obj".into(),
                String::from("mtllib scene.mtl\n") + &quad_facing_z(-3.0, 4.0, "lamp", 0),
            ),
        ];
        for i in 0..n {
            let e = 2.0 - 1.9 * i as f32 / n as f32;
            files.push((
                format!("b{i}.obj"),
                String::from("mtllib scene.mtl\n")
                    + &box_obj([-e, -e, -e], [e, e, e], "boundary", 0, false),
            ));
            toml += &format!("\n[[mesh]]\nobj = \"b{i}.obj\"\ninterior = \"fog\"\n");
        }
        files.push(("scene.toml".into(), toml));
        let refs: Vec<(&str, &str)> = files
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        scene_dir(&refs)
    };
    render(scene(16).path(), &[]);
    let d = scene(40);
    let out = d.path().join("out.exr");
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    for e in ["scene.toml:90:", "mesh.interior", "'b16.obj'", "at most 16"] {
        assert!(stderr.contains(e), "'{e}' not in: {stderr}");
    }
    assert!(!out.exists());
}

/// A clear medium changes nothing, however many of its boundaries a path crosses: `path` counted the
/// crossings over the whole path and ended it after 256, so behind 127 thin boxes of clear medium (254
/// crossings on the camera ray) the room lost its indirect light (0.88×). The count is per ray now, as
/// everywhere else.
#[test]
fn many_clear_boundaries_change_nothing() {
    let room = |n: usize| {
        let mut obj = ROOM_OBJ.replace("mtllib room.mtl", "mtllib room.mtl\nmtllib slab.mtl");
        let mut toml = ROOM_TOML.replace("spp = 2", "spp = 32\nmethod = \"path\"");
        if n > 0 {
            toml += "\n[[medium]]\nname = \"clear\"\nsigma_a = [0.0, 0.0, 0.0]\nsigma_s = [0.0, 0.0, 0.0]\n\n[materials.boundary]\ntype = \"null\"\n";
        }
        let mut files = vec![
            ("room.mtl".to_string(), ROOM_MTL.to_string()),
            ("slab.mtl".into(), "newmtl boundary\nKd 0 0 0\n".into()),
        ];
        for i in 0..n {
            let z = -0.95 + 1.9 * i as f32 / n as f32;
            files.push((
                format!("s{i}.obj"),
                String::from("mtllib slab.mtl\n")
                    + &box_obj(
                        [-0.99, 0.01, z],
                        [0.99, 1.98, z + 0.005],
                        "boundary",
                        0,
                        false,
                    ),
            ));
            toml += &format!("\n[[mesh]]\nobj = \"s{i}.obj\"\ninterior = \"clear\"\n");
        }
        obj = obj.replace("mtllib slab.mtl\n", "");
        files.push(("room.obj".into(), obj));
        files.push(("scene.toml".into(), toml));
        let refs: Vec<(&str, &str)> = files
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        scene_dir(&refs)
    };
    let plain = mean(&render(room(0).path(), &[]));
    let slabs = mean(&render(room(127).path(), &[]));
    let ratio = slabs / plain;
    // 1.0000 in every channel at seeds 0–3 and on SSE4.2 (the clear media change none of the same
    // seed's paths); bound 2 %, a sixth of the defect's 0.88×.
    assert!(
        ratio.min_element() > 0.98 && ratio.max_element() < 1.02,
        "127 clear boxes: {ratio} × the plain room"
    );
}

/// Two boundaries enclosing the same space — the same box listed twice, or bounding two media — leave
/// which medium fills it to the order of the meshes (`pm` 0.141, `path` 0.065, neither medium alone):
/// refused on the second's line. Nested boxes sharing a face stay legal.
#[test]
fn boundaries_enclosing_the_same_space_are_refused() {
    let unit = |base: usize| box_obj([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], "boundary", base, false);
    let half = box_obj([-1.0, -1.0, -1.0], [0.0, 1.0, 1.0], "boundary", 0, false);
    let lamp_obj = String::from("mtllib scene.mtl\n") + &quad_facing_z(-3.0, 4.0, "lamp", 0);
    let toml = |second: &str| {
        format!(
            "version = 1\n[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n\n[[medium]]\nname = \"fog\"\nsigma_a = [0.1, 0.1, 0.1]\nsigma_s = [0.5, 0.5, 0.5]\n\n[[medium]]\nname = \"ink\"\nsigma_a = [1.0, 1.0, 1.0]\nsigma_s = [0.0, 0.0, 0.0]\n\n[materials.boundary]\ntype = \"null\"\n\n[render]\nmethod = \"path\"\nspp = 1\n\n[[mesh]]\nobj = \"lamp.obj\"\n\n[[mesh]]\nobj = \"a.obj\"\ninterior = \"fog\"\n\n[[mesh]]\nobj = \"b.obj\"\ninterior = \"{second}\"\n"
        )
    };
    let dir = |b_obj: &str, second: &str| {
        scene_dir(&[
            ("scene.mtl", SLAB_MTL),
            ("lamp.obj", &lamp_obj),
            ("a.obj", &(String::from("mtllib scene.mtl\n") + &unit(0))),
            ("b.obj", &(String::from("mtllib scene.mtl\n") + b_obj)),
            ("scene.toml", &toml(second)),
        ])
    };
    for second in ["fog", "ink"] {
        let d = dir(&unit(0), second);
        let out = d.path().join("out.exr");
        let r = run(&[
            "render",
            &p(d.path(), "scene.toml"),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{second}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        for e in [
            "scene.toml:35:",
            "mesh.interior",
            "'b.obj'",
            "same space as",
            "'a.obj'",
        ] {
            assert!(stderr.contains(e), "'{e}' not in: {stderr}");
        }
        assert!(!out.exists());
    }
    // Half the box, inside it and sharing three of its faces: nested, legal.
    render(dir(&half, "ink").path(), &[]);
}

/// Boundaries of two media that overlap in part leave the space inside both to whichever face a ray
/// entered it through: refused on the second's line, whether the faces cross or lie flush with each
/// other. Touching, nesting (also with shared faces), disjoint boxes and overlapping boundaries of
/// one medium (their union is that medium) stay legal.
#[test]
fn boundaries_overlapping_in_part_are_refused() {
    let lamp_obj = String::from("mtllib scene.mtl\n") + &quad_facing_z(-3.0, 4.0, "lamp", 0);
    let load = |b: ([f32; 3], [f32; 3]), second: &str| {
        let toml = format!(
            "version = 1\n[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\nwidth = 8\nheight = 8\n\n[[medium]]\nname = \"fog\"\nsigma_a = [0.1, 0.1, 0.1]\nsigma_s = [0.5, 0.5, 0.5]\n\n[[medium]]\nname = \"ink\"\nsigma_a = [1.0, 1.0, 1.0]\nsigma_s = [0.0, 0.0, 0.0]\n\n[materials.boundary]\ntype = \"null\"\n\n[render]\nmethod = \"path\"\nspp = 1\n\n[[mesh]]\nobj = \"lamp.obj\"\n\n[[mesh]]\nobj = \"a.obj\"\ninterior = \"fog\"\n\n[[mesh]]\nobj = \"b.obj\"\ninterior = \"{second}\"\n"
        );
        let a = box_obj([-1.0; 3], [1.0; 3], "boundary", 0, false);
        let d = scene_dir(&[
            ("scene.mtl", SLAB_MTL),
            ("lamp.obj", &lamp_obj),
            ("a.obj", &(String::from("mtllib scene.mtl\n") + &a)),
            (
                "b.obj",
                &(String::from("mtllib scene.mtl\n") + &box_obj(b.0, b.1, "boundary", 0, true)),
            ),
            ("scene.toml", &toml),
        ]);
        let r = pmrender::scene::load(&d.path().join("scene.toml"));
        (d, r.err().map(|e| e.to_string()))
    };
    let overlapping = [
        ([0.0, -1.0, -1.0], [2.0, 1.0, 1.0]), // half of each, faces flush
        ([-0.5, -2.0, -0.5], [0.5, 2.0, 0.5]), // a bar through the box
        ([0.5, 0.5, 0.5], [1.5, 1.5, 1.5]),   // an eighth at a corner
        ([0.8, -0.3, -0.3], [1.8, 0.3, 0.3]), // a fifth of the second box
        ([-1.0, -1.0, -0.5], [1.0, 1.0, 1.5]), // the box moved along z, four faces flush
    ];
    for b in overlapping {
        let (_, err) = load(b, "ink");
        let err = err.unwrap_or_else(|| panic!("{b:?} accepted"));
        for e in [
            "scene.toml:35:",
            "mesh.interior",
            "'b.obj'",
            "overlap in part",
            "'a.obj'",
        ] {
            assert!(err.contains(e), "'{e}' not in: {err}");
        }
    }
    let legal = [
        ([1.0, -1.0, -1.0], [3.0, 1.0, 1.0]), // touching: one face shared
        ([1.0, -0.5, -0.5], [2.0, 0.5, 0.5]), // touching part of a face
        ([-1.0, -1.0, -1.0], [0.0, 0.0, 0.0]), // an eighth of it, three faces shared
        ([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), // strictly inside
        ([-3.0, -3.0, -3.0], [3.0, 3.0, 3.0]), // around it
        ([-1.0, -1.0, -1.0], [1.0, 1.0, 1.5]), // around it, four faces shared
        ([2.0, 2.0, 2.0], [3.0, 3.0, 3.0]),   // apart
    ];
    for b in legal {
        let (_, err) = load(b, "ink");
        assert_eq!(err, None, "{b:?}");
    }
    assert_eq!(load(overlapping[0], "fog").1, None);
    // The command line: one line, exit status 2, no output.
    let (d, _) = load(overlapping[1], "ink");
    let out = d.path().join("out.exr");
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(!out.exists());
}

/// A fog so dense that no photon is stored is legal input: it renders, but says so on stderr (it
/// rendered black without a word).
#[test]
fn a_fog_that_stores_no_photon_is_reported() {
    let scene = std::fs::read_to_string(repo().join("scenes/fog-cornell.toml")).unwrap();
    let scene = scene
        .replace("sigma_s = [0.25, 0.25, 0.25]", "sigma_s = [1e9, 1e9, 1e9]")
        .replace("g = 0.3", "g = 0.99999")
        .replace("models/", &format!("{}/scenes/models/", repo().display()));
    let dir = scene_dir(&[("scene.toml", &scene)]);
    let out = dir.path().join("out.exr");
    let r = run_bounded(
        &[
            "render",
            &p(dir.path(), "scene.toml"),
            "-o",
            out.to_str().unwrap(),
            "--method",
            "photons",
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "2",
            "--quiet",
        ],
        std::time::Duration::from_secs(120),
    );
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(stderr.contains("warning: no photon was stored"), "{stderr}");
    assert!(out.exists());
}

/// Volume photons are stored only inside a medium's boundary. A photon entering the fog cube of the
/// media matrix within a micrometre of an edge leaves it at once through the next face; the step past
/// the first crossing passed over that face, and the photon carried the fog on outside the cube: 29,
/// 2 and 9 volume photons (seeds 0, 1, 2) across the room and beyond its open side; none since.
#[test]
fn volume_photons_stay_inside_the_fog_cube() {
    use pmrender::photons::{PhotonData, PhotonSettings};
    let scene = pmrender::scene::load(&repo().join("tests/media_matrix/fog-cube.toml")).unwrap();
    // The cube is the second [[mesh]].
    let g = &scene.geometry;
    let (lo, hi) = g.triangles[scene.mesh_ranges[1].clone()]
        .iter()
        .flat_map(|t| t.v)
        .map(|k| g.positions[k as usize])
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    let tolerance = 1e-4 * (scene.bounds.1 - scene.bounds.0).length();
    let settings = PhotonSettings::resolve(&scene);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    for seed in 0..3 {
        let (maps, _, _) = PhotonData::trace(
            &scene,
            &settings,
            Default::default(),
            seed,
            &|_, _| {},
            &cancel,
        )
        .unwrap();
        let photons = maps.volume.as_ref().expect("a volume map").photons();
        let outside: Vec<Vec3> = photons
            .iter()
            .map(|ph| ph.pos)
            .filter(|p| (p.cmplt(lo - tolerance) | p.cmpgt(hi + tolerance)).any())
            .collect();
        assert!(
            outside.is_empty(),
            "seed {seed}: {} of {} volume photons outside the fog cube {lo} – {hi}, e.g. {}",
            outside.len(),
            photons.len(),
            outside[0]
        );
    }
}

/// The room with `n` thin slabs of an almost clear medium (σa = 1e-6) stacked between its floor and
/// its ceiling light, each a closed box of its own: a shadow ray from the floor crosses 2n
/// boundaries. Rendered with `path` at 16×12, 32 spp; its mean.
fn slabs_mean(d: &std::path::Path, n: usize) -> (Vec3, String) {
    let mut text = String::from(
        "version = 1\n[camera]\neye = [0.0, 1.0, 3.0]\ntarget = [0.0, 1.0, 0.0]\nfov = 45.0\n\
         width = 16\nheight = 12\n[[mesh]]\nobj = \"room.obj\"\n",
    );
    if n > 0 {
        text += "[[medium]]\nname = \"thin\"\nsigma_a = [1e-6, 1e-6, 1e-6]\n\
                 sigma_s = [0.0, 0.0, 0.0]\n[materials.boundary]\ntype = \"null\"\n";
    }
    for i in 0..n {
        let y = 0.2 + i as f32 * 1.7 / n as f32;
        text += &format!(
            "[[mesh]]\nobj = \"slab.obj\"\ninterior = \"thin\"\ntranslate = [0.0, {y}, 0.0]\n"
        );
    }
    text += "[render]\nmethod = \"path\"\nspp = 32\nseed = 1\n";
    let name = format!("slabs-{n}");
    std::fs::write(d.join(format!("{name}.toml")), text).unwrap();
    let (out, stats) = (p(d, &format!("{name}.exr")), p(d, &format!("{name}.json")));
    let r = run(&[
        "render",
        &p(d, &format!("{name}.toml")),
        "-o",
        &out,
        "--stats",
        &stats,
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let img = read(std::path::Path::new(&out));
    (mean(&img), std::fs::read_to_string(&stats).unwrap())
}

#[test]
fn path_through_130_clear_slabs_renders_as_without_them() {
    // Crossing a boundary is no bounce; a ray gave up after 256 crossings, and a floor lit through
    // 260 lost its direct light: 14 % dark at 32×24, 64 spp.
    let slab = "mtllib slab.mtl\nusemtl boundary\n\
                v -0.9 0 -0.9\nv 0.9 0 -0.9\nv 0.9 0 0.9\nv -0.9 0 0.9\n\
                v -0.9 0.005 -0.9\nv 0.9 0.005 -0.9\nv 0.9 0.005 0.9\nv -0.9 0.005 0.9\n\
                f 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 2 6 7 3\nf 3 7 8 4\nf 4 8 5 1\n";
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("slab.obj", slab),
        ("slab.mtl", "newmtl boundary\nKd 0.5 0.5 0.5\n"),
    ]);
    let (clear, _) = slabs_mean(d.path(), 0);
    let (through, stats) = slabs_mean(d.path(), 130);
    // Each mean is of 6144 samples: about 0.5 % noise apart.
    let rel = ((through - clear) / clear).abs().max_element();
    assert!(rel < 0.03, "{through} against {clear} without the slabs");
    let json: serde_json::Value = serde_json::from_str(&stats).unwrap();
    assert_eq!(json["rare"]["crossings_given_up"], 0, "{stats}");
}
