//! Ambient occlusion (`ao`, `ao-direct`) against the exact open fraction of analytic scenes: the
//! cosine-weighted fraction of directions whose ray meets no surface within `ao_distance` D.

mod common;
use common::*;

/// A scene of `obj` (materials of `mtl`) seen from `eye` toward `target`, with a point light at the
/// eye (a scene must have a light; it plays no part in occlusion), rendered by `method` with
/// `ao_distance` and `seed` at `spp`: the image and the statistics.
fn occlusion(
    (obj, mtl): (&str, &str),
    (eye, target, up): ([f32; 3], [f32; 3], [f32; 3]),
    method: &str,
    ao_distance: f32,
    (spp, seed): (u32, u64),
) -> (pmrender::io::output::Image, serde_json::Value) {
    let toml = format!(
        "version = 1\n[camera]\neye = {eye:?}\ntarget = {target:?}\nup = {up:?}\nfov = 40.0\n\
         width = 24\nheight = 24\n\n[[mesh]]\nobj = \"s.obj\"\n\n\
         [[light]]\ntype = \"point\"\nposition = {eye:?}\nintensity = [1.0, 1.0, 1.0]\n\n[render]\nao_distance = {ao_distance}\n"
    );
    let d = scene_dir(&[("s.obj", obj), ("s.mtl", mtl), ("scene.toml", &toml)]);
    let (out, stats) = (p(d.path(), "out.exr"), p(d.path(), "stats.json"));
    let (spp, seed) = (spp.to_string(), seed.to_string());
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &out,
        "--stats",
        &stats,
        "--method",
        method,
        "--spp",
        &spp,
        "--seed",
        &seed,
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let json = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    (read(std::path::Path::new(&out)), json)
}

const MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 5 5 5\n";

/// A square of half-side `half` at height `y`, facing down (`down`) or up, of material `material`.
fn square(y: f32, half: f32, down: bool, first_vertex: usize, material: &str) -> String {
    let v = first_vertex;
    let f = if down {
        format!("f {} {} {} {}\n", v, v + 1, v + 2, v + 3)
    } else {
        format!("f {} {} {} {}\n", v + 3, v + 2, v + 1, v)
    };
    format!(
        "usemtl {material}\nv {} {y} {}\nv {half} {y} {}\nv {half} {y} {half}\nv {} {y} {half}\n{f}",
        -half, -half, -half, -half
    )
}

/// The lowest and highest of the image's 4×4-pixel block means (the R channel: all three are one).
fn block_range(img: &pmrender::io::output::Image) -> (f32, f32) {
    block_means(img, 4)
        .pixels
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.x), hi.max(p.x))
        })
}

fn assert_grey(img: &pmrender::io::output::Image) {
    assert!(
        img.pixels.iter().all(|p| p.x == p.y && p.y == p.z),
        "occlusion is the same in R, G and B"
    );
}

/// A floor under a parallel ceiling at height h < D: a cosine-weighted ray at angle θ meets the
/// ceiling at h / cos θ, so it is blocked where cos θ > h / D, and the open fraction is (h / D)².
/// The ceiling is a lamp: emitters occlude as any surface. Measured over seeds 0–3 at 4 spp, 24²
/// (h = 0.5, D = 1: exact 0.25; h = 0.8: 0.64): `ao-direct`'s means within 0.0002 of the exact
/// value, its 4×4 blocks within 0.0026; `ao`'s means within 0.0032 (0.2480–0.2510, 0.6368–0.6409),
/// its blocks within 0.0108 (the records' interpolation). Bounds: `ao-direct` mean and blocks
/// ±0.005; `ao` mean ±0.008, blocks ±0.015.
#[test]
fn floor_under_ceiling() {
    for (h, seed) in [(0.5f32, 0u64), (0.8, 1)] {
        let expected = h * h;
        let obj = format!(
            "mtllib s.mtl\n{}{}",
            square(0.0, 40.0, false, 1, "grey"),
            square(h, 40.0, true, 5, "lamp")
        );
        for method in ["ao-direct", "ao"] {
            let (img, _) = occlusion(
                (&obj, MTL),
                ([0.0, h / 2.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
                method,
                1.0,
                (4, seed),
            );
            assert_grey(&img);
            let (m, (lo, hi)) = (mean(&img).x, block_range(&img));
            eprintln!("[ceiling] {method} h={h}: mean {m:.4} (exact {expected:.4}), blocks [{lo:.4}, {hi:.4}]");
            let (mean_bound, block_bound) = if method == "ao" {
                (0.008, 0.015)
            } else {
                (0.005, 0.005)
            };
            assert!(
                (m - expected).abs() < mean_bound,
                "{method} h={h}: mean {m}"
            );
            assert!(
                lo > expected - block_bound && hi < expected + block_bound,
                "{method} h={h}: blocks [{lo}, {hi}] vs {expected}"
            );
        }
    }
}

/// A lone plane occludes nothing of itself: 1 everywhere, by both methods, to f32 rounding (each
/// open ray's 1/π in f32 times π/N: measured 0.99999994 and [0.9999998, 1]; bound 1e-5).
#[test]
fn lone_plane_is_open() {
    let obj = format!("mtllib s.mtl\n{}", square(0.0, 40.0, false, 1, "grey"));
    for method in ["ao-direct", "ao"] {
        let (img, _) = occlusion(
            (&obj, MTL),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            method,
            5.0,
            (4, 0),
        );
        assert_grey(&img);
        let lo = img.pixels.iter().map(|p| p.x).fold(f32::INFINITY, f32::min);
        let hi = img.pixels.iter().map(|p| p.x).fold(0.0, f32::max);
        eprintln!("[plane] {method}: [{lo}, {hi}]");
        assert!(
            lo > 1.0 - 1e-5 && hi <= 1.0,
            "{method}: a lone plane's occlusion is 1 everywhere: [{lo}, {hi}]"
        );
    }
}

/// Inside a closed sphere of radius R, a ray from the surface at angle θ to the normal meets it again
/// at the chord 2R cos θ: open where 2R cos θ > D, a cosine-weighted fraction 1 − (D / 2R)² for D < 2R,
/// 0 beyond (so 0 once D exceeds the diameter, and → 1 as D / R → 0). The sphere is 64 × 32 facets,
/// whose concave creases occlude a little more than the sphere. Measured over seeds 0–3 at 4 spp, 24²:
/// D = 2.5R: 0 exactly, both methods; D = R (exact 0.75): `ao-direct` means 0.7488–0.7489, blocks
/// [0.7464, 0.7506]; `ao` means 0.7498–0.7506, blocks [0.7435, 0.7563]; D = 0.1R (exact 0.9975):
/// `ao-direct` means 0.9966–0.9967, blocks [0.9957, 0.9974]; `ao` means 0.9972–0.9974, blocks
/// [0.9925, 1] (at `pm`'s accuracy 0.5 they reached down to 0.9709: the creases' thin shadows blurred
/// over a record's reach). Bounds: means ±0.005; blocks ±0.005 (`ao-direct`), ±0.012 (`ao`).
#[test]
fn inside_a_sphere() {
    let obj = inward_sphere(64, 32)
        .replace("furnace.mtl", "s.mtl")
        .replace("inside", "grey");
    for (d, seed) in [(2.5f32, 0u64), (1.0, 1), (0.1, 2)] {
        let expected = (1.0 - (d / 2.0).powi(2)).max(0.0);
        for method in ["ao-direct", "ao"] {
            let (img, _) = occlusion(
                (&obj, MTL),
                ([0.1, 0.2, 0.05], [1.0, 0.3, 0.2], [0.0, 1.0, 0.0]),
                method,
                d,
                (4, seed),
            );
            assert_grey(&img);
            let (m, (lo, hi)) = (mean(&img).x, block_range(&img));
            eprintln!("[sphere] {method} D={d}: mean {m:.4} (exact {expected:.4}), blocks [{lo:.4}, {hi:.4}]");
            if expected == 0.0 {
                assert!(
                    img.pixels.iter().all(|p| p.x == 0.0),
                    "{method} D={d}: all closed"
                );
                continue;
            }
            let block_bound = if method == "ao" { 0.012 } else { 0.005 };
            assert!((m - expected).abs() < 0.005, "{method} D={d}: mean {m}");
            assert!(
                lo > expected - block_bound && hi < expected + block_bound,
                "{method} D={d}: blocks [{lo}, {hi}] vs {expected}"
            );
        }
    }
}

/// A shipped scene at 64 × 48 by `method` at `spp` (`noise` 0: every pixel takes them all), with
/// `extra` options: the image and the statistics.
fn shipped(
    scene: &str,
    method: &str,
    (spp, noise, seed): (u32, f32, u64),
    dir: &std::path::Path,
    extra: &[&str],
) -> (pmrender::io::output::Image, serde_json::Value) {
    let mut args = vec!["--width", "64", "--height", "48"];
    args.extend_from_slice(extra);
    render_scene(scene, method, (spp, noise, seed), dir, &args)
}

/// `scene` by `method` at `spp` (`noise` 0: every pixel takes them all), with `extra` options: the
/// image and the statistics.
fn render_scene(
    scene: &str,
    method: &str,
    (spp, noise, seed): (u32, f32, u64),
    dir: &std::path::Path,
    extra: &[&str],
) -> (pmrender::io::output::Image, serde_json::Value) {
    let name = format!("{method}-{seed}-{}", extra.len());
    let (out, stats) = (
        dir.join(format!("{name}.exr")),
        dir.join(format!("{name}.json")),
    );
    let (spp, noise, seed) = (spp.to_string(), noise.to_string(), seed.to_string());
    let mut args = vec![
        "render",
        scene,
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--method",
        method,
        "--spp",
        &spp,
        "--noise",
        &noise,
        "--seed",
        &seed,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let json = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    (read(&out), json)
}

/// `ao` through its cache against `ao-direct`'s gathers at every sample (16 spp, no noise target),
/// at the defaults (ao_distance a tenth of the diagonal, the noise target), on a room with blinds and
/// on the Cornell box. Measured over seeds 0–3 (`ao` against `ao-direct` of the same seed): mean
/// ratios 1.0026–1.0036 (blinds room) and 1.0060–1.0067 (Cornell box; at `pm`'s accuracy 0.5 they
/// were 1.009–1.010 and 1.014); relMSE of the 4×4-pixel block means 4.9e-4–8.1e-4 and
/// 9.3e-4–1.0e-3. Bounds: mean within 1 %, block relMSE 2e-3. The cache's statistics are in `--stats`.
#[test]
fn ao_matches_ao_direct_on_shipped_scenes() {
    let dir = tempfile::tempdir().unwrap();
    for scene in ["scenes/blinds-room.toml", "scenes/cornell-caustics.toml"] {
        let scene = repo().join(scene);
        let scene = scene.to_str().unwrap();
        let seed = 0;
        let (reference, _) = shipped(scene, "ao-direct", (16, 0.0, seed), dir.path(), &[]);
        let (img, stats) = shipped(scene, "ao", (128, 0.04, seed), dir.path(), &[]);
        assert_grey(&img);
        let ratio = mean(&img).x / mean(&reference).x;
        let blocks = rel_mse(&block_means(&img, 4), &block_means(&reference, 4));
        eprintln!("[shipped] {scene}: mean ratio {ratio:.4}, block relMSE {blocks:.2e}");
        assert!((ratio - 1.0).abs() < 0.01, "{scene}: mean ratio {ratio}");
        assert!(blocks < 2e-3, "{scene}: block relMSE {blocks}");
        for key in [
            "icache.records_pass_a",
            "gather.gathers",
            "icache.lookups_pass_b",
        ] {
            let n = stats.pointer(&format!("/{}", key.replace('.', "/")));
            assert!(
                n.and_then(|v| v.as_f64()).is_some_and(|n| n > 0.0),
                "{scene}: statistic {key} = {n:?}"
            );
        }
    }
}

/// Mean ratio, relMSE of the 4×4-pixel block means and the largest difference of a block mean, of
/// `img` against `reference`.
fn against(
    img: &pmrender::io::output::Image,
    reference: &pmrender::io::output::Image,
) -> (f32, f64, f32) {
    let (b, b_ref) = (block_means(img, 4), block_means(reference, 4));
    let worst = b
        .pixels
        .iter()
        .zip(&b_ref.pixels)
        .map(|(a, r)| (a.x - r.x).abs())
        .fold(0.0f32, f32::max);
    (mean(img).x / mean(reference).x, rel_mse(&b, &b_ref), worst)
}

/// Bounds on [`against`]'s mean ratio (its distance from 1), block relMSE and worst block.
struct Bounds(f32, f64, f32);

fn check(what: &str, (ratio, blocks, worst): (f32, f64, f32), Bounds(m, b, w): Bounds) {
    eprintln!(
        "[96²] {what}: mean ratio {ratio:.4}, block relMSE {blocks:.2e}, worst block {worst:.4}"
    );
    assert!((ratio - 1.0).abs() < m, "{what}: mean ratio {ratio}");
    assert!(blocks < b, "{what}: block relMSE {blocks}");
    assert!(worst < w, "{what}: a block mean differs by {worst}");
}

/// At 96², `ao` at its defaults against `ao-direct` at 8 spp (no noise target), and both against the
/// independent occlusion reference of Mitsuba 3's ray casting (tests/reference/NAME-ao.exr,
/// tools/mref_ao.py: 1024 camera samples of 64 rays a pixel, its own noise relMSE 2.8e-5 and 2.2e-5),
/// on Sibenik (the public asset: vaults, columns, a long nave), McGuire's Cornell box and the shipped
/// Cornell box with its glass and mirror spheres. Measured over seeds 0–3:
/// - `ao` against `ao-direct` (same seed): Sibenik mean ratios 1.0044–1.0063, block relMSE
///   1.65e-4–1.95e-4, worst block 0.038–0.051; McGuire's box 1.0053–1.0057, 4.2e-4–5.0e-4,
///   0.081–0.100 (the contact shadows of the boxes, where a record's reach spans the fall-off).
/// - against Mitsuba, `ao-direct`: Sibenik 0.9987–1.0005, 7.7e-5–1.03e-4, 0.029–0.050; the shipped box
///   0.9998–1.0004, 9.1e-5–1.25e-4, 0.034–0.044. `ao`: Sibenik 1.0043–1.0050, 1.10e-4–1.22e-4,
///   0.030–0.044; the shipped box 1.0067–1.0068, 8.1e-4–1.03e-3, 0.127–0.145 (the spheres' contact
///   shadows on the floor).
///
/// Bounds: `ao` means within 1 %, `ao-direct`'s within 0.5 % of Mitsuba; block relMSE and worst
/// block about twice the largest measured. About 20 s on 2 cores.
#[test]
fn ao_matches_ao_direct_and_mitsuba_on_sibenik_and_cornell_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "96", "--height", "96"];
    // ao-direct: every pixel takes its 8 samples; ao: its defaults (128 spp, noise target 0.04).
    let render = |scene: &str, method: &str, spp| {
        let path = repo().join(scene);
        let noise = if method == "ao" { 0.04 } else { 0.0 };
        render_scene(
            path.to_str().unwrap(),
            method,
            (spp, noise, 0),
            dir.path(),
            &size,
        )
        .0
    };
    let mitsuba = |name: &str| read(&repo().join(format!("tests/reference/{name}-ao.exr")));

    let (direct, ao) = (
        render("tests/scenes/sibenik.toml", "ao-direct", 8),
        render("tests/scenes/sibenik.toml", "ao", 128),
    );
    assert_grey(&ao);
    let reference = mitsuba("sibenik");
    check(
        "sibenik ao/ao-direct",
        against(&ao, &direct),
        Bounds(0.01, 4e-4, 0.08),
    );
    check(
        "sibenik ao-direct/mitsuba",
        against(&direct, &reference),
        Bounds(0.005, 2.5e-4, 0.08),
    );
    check(
        "sibenik ao/mitsuba",
        against(&ao, &reference),
        Bounds(0.01, 2.5e-4, 0.08),
    );

    let scene = "tests/scenes/cornell-glossy.toml";
    let (direct, ao) = (render(scene, "ao-direct", 8), render(scene, "ao", 128));
    check(
        "mcguire ao/ao-direct",
        against(&ao, &direct),
        Bounds(0.01, 1e-3, 0.15),
    );

    let scene = "scenes/cornell-caustics.toml";
    let (direct, ao) = (render(scene, "ao-direct", 8), render(scene, "ao", 128));
    let reference = mitsuba("cornell-caustics");
    check(
        "cornell-caustics ao-direct/mitsuba",
        against(&direct, &reference),
        Bounds(0.005, 2.5e-4, 0.08),
    );
    check(
        "cornell-caustics ao/mitsuba",
        against(&ao, &reference),
        Bounds(0.01, 2e-3, 0.2),
    );
}

/// `ao`'s cache saved and loaded gives the render that saved it (stages replayed), its picture is
/// written, and the file is refused by `pm` (occlusion records are no irradiance) and by `ao` at
/// another `ao_distance`.
#[test]
fn ao_cache_files() {
    let dir = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/blinds-room.toml");
    let scene = scene.to_str().unwrap();
    let (cache, picture) = (p(dir.path(), "ao.cache"), p(dir.path(), "cache.png"));
    let (saved, _) = shipped(
        scene,
        "ao",
        (128, 0.04, 0),
        dir.path(),
        &["--save-cache", &cache, "--cache-image", &picture],
    );
    assert!(std::path::Path::new(&picture).exists());
    let (loaded, stats) = shipped(
        scene,
        "ao",
        (128, 0.04, 0),
        dir.path(),
        &["--load-cache", &cache],
    );
    assert_eq!(
        saved.pixels, loaded.pixels,
        "a loaded cache renders what saved it"
    );
    assert!(stats.pointer("/icache/records_loaded").is_some());
    let out = p(dir.path(), "pm.exr");
    for method in ["pm", "ao"] {
        let mut args = vec![
            "render",
            scene,
            "-o",
            &out,
            "--method",
            method,
            "--width",
            "64",
            "--height",
            "48",
            "--load-cache",
            &cache,
            "--quiet",
        ];
        let copy = p(dir.path(), "other-distance.toml");
        if method == "ao" {
            let text = std::fs::read_to_string(scene)
                .unwrap()
                .replace("[render]\n", "[render]\nao_distance = 0.5\n");
            let text = text.replace("models/", &format!("{}/scenes/models/", repo().display()));
            std::fs::write(&copy, text).unwrap();
            args[1] = &copy;
        }
        let r = run(&args);
        assert!(!r.status.success(), "{method} refuses the other cache");
    }
}

#[test]
fn geometry_without_any_light_renders_as_occlusion_and_only_so() {
    // A look-development occlusion pass of bare geometry: no [[light]], no emitter. Every other
    // method refuses it, at the scene's first line, saying which render it.
    let d = tempfile::tempdir().unwrap();
    let quad = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 2 3\nf 1 3 4\n";
    std::fs::write(d.path().join("quad.obj"), quad).unwrap();
    let scene = "version = 1\n[camera]\neye = [0.0, 3.0, 3.0]\ntarget = [0.0, 0.0, 0.0]\n\
                 fov = 50.0\nwidth = 24\nheight = 18\n[[mesh]]\nobj = \"quad.obj\"\n";
    std::fs::write(d.path().join("s.toml"), scene).unwrap();
    let s = d.path().join("s.toml");
    let (s, out) = (s.to_str().unwrap(), d.path().join("o.exr"));
    let o = out.to_str().unwrap();
    for method in ["ao", "ao-direct"] {
        let r = run(&[
            "render", s, "-o", o, "--method", method, "--spp", "4", "--quiet",
        ]);
        assert!(
            r.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        // A lone plane is open everywhere it is seen.
        let img = read(&out);
        let max = img
            .pixels
            .iter()
            .map(|p| p.max_element())
            .fold(0.0f32, f32::max);
        assert!((max - 1.0).abs() < 1e-5, "{method}: {max}");
        std::fs::remove_file(&out).unwrap();
    }
    for method in ["pm", "path", "photons", "pm-fg"] {
        let r = run(&["render", s, "-o", o, "--method", method, "--quiet"]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{method}: {stderr}");
        assert!(
            stderr.contains("s.toml:1") && stderr.contains("no lights"),
            "{stderr}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn an_occlusion_sequence_fills_a_cache_per_frame_and_gives_its_stills() {
    // A sequence's frames read no photon maps under `ao`: each fills its cache as its still does,
    // rather than gathering at every sample at ao-direct's cost, and is that still's image.
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/anim-ball.toml");
    let s = scene.to_str().unwrap();
    let render = |name: &str, extra: &[&str]| {
        let (o, st) = (
            p(d.path(), &format!("{name}-##.exr")),
            p(d.path(), &format!("{name}-##.json")),
        );
        let mut args = vec![
            "render", s, "-o", &o, "--stats", &st, "--frames", "0..2", "--method", "ao", "--width",
            "48", "--height", "36", "--spp", "8", "--quiet",
        ];
        args.extend_from_slice(extra);
        let r = run(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    };
    render("seq", &[]);
    render("still", &["--chunk", "1"]);
    for f in 0..=2 {
        let name = |n: &str| d.path().join(format!("{n}-{f:02}.exr"));
        assert_eq!(
            std::fs::read(name("seq")).unwrap(),
            std::fs::read(name("still")).unwrap()
        );
        let j: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(d.path().join(format!("seq-{f:02}.json"))).unwrap(),
        )
        .unwrap();
        assert!(
            j["icache"]["records_pass_a"].as_u64().unwrap() > 100,
            "frame {f}: {}",
            j["icache"]
        );
        // ao reads no photon maps: its frames neither trace nor reuse any.
        assert_eq!(j["frame"]["photons"], "none", "frame {f}: {}", j["frame"]);
    }
}

#[test]
fn a_bake_for_ao_says_why_it_is_refused() {
    // A bake holds photon maps and an irradiance cache for the photon-map methods; ao's records are
    // occlusion, and the refusal says so and names how ao's cache is kept instead.
    let scene = pmrender::scene::load(&repo().join("scenes/cornell-caustics.toml")).unwrap();
    for method in [
        pmrender::scene::Method::Ao,
        pmrender::scene::Method::AoDirect,
    ] {
        let opts = pmrender::render::Options {
            method: Some(method),
            ..Default::default()
        };
        let cancel = std::sync::atomic::AtomicBool::new(false);
        let err = pmrender::render::baked::bake_apart(
            &scene,
            &opts,
            &pmrender::render::NoProgress,
            &cancel,
        )
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
        assert!(
            err.contains("occlusion reads no photons") && err.contains("--save-cache"),
            "{err}"
        );
    }
}
