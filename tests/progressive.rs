//! Progressive renders (`--passes`, `--time`): the error falls with passes where a single pass has
//! a floor, passes are reproducible, a time budget is kept, a signal leaves the passes made, and what
//! a progressive render cannot do is refused.

mod common;
use common::*;

use glam::Vec3;
use pmrender::io::output::{read_layer, Image};

/// A floor (albedo 0.5) under a point light, above which a square mirror facing down throws the
/// light's image onto the floor: a caustic whose irradiance is known in closed form.
const MIRROR_OBJ: &str = "mtllib mirror.mtl
v -6 0 -6
v 6 0 -6
v 6 0 6
v -6 0 6
v -0.5 2 -0.5
v 0.5 2 -0.5
v 0.5 2 0.5
v -0.5 2 0.5
usemtl floor
f 1 4 3
f 1 3 2
usemtl mirror
f 5 6 7
f 5 7 8
";
const MIRROR_MTL: &str =
    "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl mirror\nKd 0 0 0\nKs 1 1 1\nillum 3\n";
const EYE: [f32; 3] = [0.0, 1.5, 4.0];
const TARGET: [f32; 3] = [0.0, 0.0, 0.5];
const FOV: f32 = 60.0;
const LIGHT_Y: f32 = 1.0;
const INTENSITY: f32 = 10.0;
const MIRROR_Y: f32 = 2.0;
const MIRROR_HALF: f32 = 0.5;
const W: u32 = 64;
const H: u32 = 48;

fn mirror_scene(extra: &str) -> tempfile::TempDir {
    let toml = format!(
        "version = 1\n[camera]\neye = {EYE:?}\ntarget = {TARGET:?}\nfov = {FOV}\nwidth = {W}\n\
         height = {H}\n\n[[mesh]]\nobj = \"mirror.obj\"\n\n[[light]]\ntype = \"point\"\n\
         position = [0.0, {LIGHT_Y}, 0.0]\nintensity = [{INTENSITY}, {INTENSITY}, {INTENSITY}]\n\n\
         [render]\nseed = 3\n{extra}\n[render.photons]\nglobal = 20000\ncaustic = 20000\n"
    );
    scene_dir(&[
        ("mirror.obj", MIRROR_OBJ),
        ("mirror.mtl", MIRROR_MTL),
        ("scene.toml", &toml),
    ])
}

/// The caustic's radiance on the floor at (x, 0, z): the light's image in the mirror, at height
/// 2·MIRROR_Y − LIGHT_Y, lights the points whose line to it crosses the mirror.
fn caustic_radiance(x: f32, z: f32) -> f32 {
    let image_y = 2.0 * MIRROR_Y - LIGHT_Y;
    let t = (image_y - MIRROR_Y) / image_y;
    if (x * t).abs() > MIRROR_HALF || (z * t).abs() > MIRROR_HALF {
        return 0.0;
    }
    let d2 = x * x + z * z + image_y * image_y;
    let e = INTENSITY * (image_y / d2.sqrt()) / d2;
    0.5 / std::f32::consts::PI * e
}

/// The caustic layer's exact image: each pixel the mean over a 16×16 lattice of the points its
/// camera rays meet on the floor (the camera as the renderer's: pinhole, y down).
fn exact_caustic() -> Image {
    let (eye, target) = (Vec3::from(EYE), Vec3::from(TARGET));
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tan_half = (FOV.to_radians() * 0.5).tan();
    let aspect = W as f32 / H as f32;
    let n = 16;
    let mut pixels = Vec::new();
    for py in 0..H {
        for px in 0..W {
            let mut sum = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let x = px as f32 + (i as f32 + 0.5) / n as f32;
                    let y = py as f32 + (j as f32 + 0.5) / n as f32;
                    let sx = (2.0 * x / W as f32 - 1.0) * tan_half * aspect;
                    let sy = (1.0 - 2.0 * y / H as f32) * tan_half;
                    let d = (forward + sx * right + sy * up).normalize();
                    if d.y < 0.0 {
                        let p = eye + d * (-eye.y / d.y);
                        sum += caustic_radiance(p.x, p.z);
                    }
                }
            }
            pixels.push(Vec3::splat(sum / (n * n) as f32));
        }
    }
    Image {
        width: W,
        height: H,
        pixels,
    }
}

fn render_passes(dir: &std::path::Path, name: &str, args: &[&str]) -> Image {
    let out = p(dir, name);
    let mut all = vec!["render", "-o", &out, "--quiet"];
    let scene = p(dir, "scene.toml");
    all.insert(1, &scene);
    all.extend_from_slice(args);
    let r = run(&all);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    read_layer(std::path::Path::new(&out), Some("caustic")).expect("caustic layer")
}

#[test]
fn a_progressive_caustic_converges_to_the_exact_one_without_a_floor() {
    let d = mirror_scene("");
    let exact = exact_caustic();
    let err = |n: u32| {
        let img = render_passes(
            d.path(),
            &format!("p{n}.exr"),
            &["--passes", &n.to_string()],
        );
        rel_mse(&img, &exact)
    };
    let e: Vec<f64> = [1, 4, 16].into_iter().map(err).collect();
    // Measured at seeds 3, 4, 5: 1.78–1.81e-3, 1.37–1.38e-3, 0.886–0.893e-3 — each pass 20k
    // caustic photons, k from 100 down to 40. One pass's estimate is 4.1 % bright in the mean (the
    // k-NN disc's bias); the mean of 16 passes 2.5 %, falling with the radius. Bounds: 4 passes under
    // 0.85× one pass's error, 16 under 0.75× four's. The ratios at seeds 3, 1, 2 (and SSE4.2 at
    // seed 3, the same figures): 4 against 1 pass 0.773, 0.758, 0.745 (mean 0.759, sd 0.014: the
    // bound the worst plus 5 sd); 16 against 4 0.649, 0.664, 0.652 (the bound the worst plus 6 sd).
    // Without the shrinking radius the error would stop at the one-pass bias (ratios near 1).
    assert!(
        e[1] < 0.85 * e[0] && e[2] < 0.75 * e[1],
        "relMSE by passes 1, 4, 16: {e:?}"
    );
}

fn stats_of(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("stats")).expect("stats JSON")
}

#[test]
fn one_pass_is_the_default_render_and_passes_are_the_same_at_any_thread_count() {
    let d = mirror_scene("");
    let run_ok = |name: &str, args: &[&str]| {
        let out = p(d.path(), name);
        let scene = p(d.path(), "scene.toml");
        let mut all = vec!["render", &scene, "-o", &out, "--quiet"];
        all.extend_from_slice(args);
        let r = run(&all);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        bytes(&out)
    };
    assert!(run_ok("default.exr", &[]) == run_ok("one.exr", &["--passes", "1"]));
    let one = run_ok("t1.exr", &["--passes", "3", "--threads", "1"]);
    assert!(one == run_ok("t2.exr", &["--passes", "3", "--threads", "2"]));
    assert!(
        one != run_ok("default2.exr", &[]),
        "three passes gave one pass's image"
    );
}

#[test]
fn a_time_budget_is_kept_and_reported() {
    let d = mirror_scene("");
    for (method, budget) in [("pm", 3.0), ("path", 2.0)] {
        let out = p(d.path(), &format!("{method}.exr"));
        let stats = p(d.path(), &format!("{method}.json"));
        let b = budget.to_string();
        let r = run(&[
            "render",
            &p(d.path(), "scene.toml"),
            "-o",
            &out,
            "--quiet",
            "--method",
            method,
            "--time",
            &b,
            "--stats",
            &stats,
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let s = stats_of(&stats);
        let total = s["time"]["total_s"].as_f64().unwrap();
        let prog = &s["progressive"];
        let passes = prog["passes"].as_u64().unwrap();
        // Within a tenth of the budget, and most of it used (a pass here takes well under a tenth).
        assert!(
            total <= 1.1 * budget && total >= 0.5 * budget,
            "{method}: {total} s of a {budget} s budget, {passes} passes"
        );
        assert!(passes >= 2, "{method}: {passes} passes in {budget} s");
        assert_eq!(prog["stopped"], "time", "{method}: {prog}");
        assert!(
            prog["noise_relmse"]["beauty"].as_f64().unwrap() > 0.0,
            "{prog}"
        );
        let img = read(std::path::Path::new(&out));
        assert!(img.pixels.iter().all(|p| p.is_finite()));
    }
}

#[test]
fn a_signal_after_the_first_pass_leaves_the_mean_of_the_passes_made() {
    let d = mirror_scene("");
    let out = p(d.path(), "out.exr");
    let stats = p(d.path(), "s.json");
    let child = spawn_interruptible(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &out,
        "--quiet",
        "--passes",
        "100000",
        "--stats",
        &stats,
    ]);
    std::thread::sleep(std::time::Duration::from_secs(3));
    // SAFETY: kill(2) on the child's pid, which it has not reaped.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let t = std::time::Instant::now();
    let r = child.wait_with_output().unwrap();
    assert!(
        t.elapsed().as_secs_f64() < 2.0,
        "took {:?} to stop",
        t.elapsed()
    );
    assert_eq!(
        r.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let s = stats_of(&stats);
    assert_eq!(s["progressive"]["stopped"], "interrupted");
    assert!(s["progressive"]["passes"].as_u64().unwrap() >= 1);
    let img = read(std::path::Path::new(&out));
    assert!(img.pixels.iter().all(|p| p.is_finite()) && mean(&img).x > 0.0);
}

#[test]
fn what_a_progressive_render_cannot_do_is_refused() {
    let d = mirror_scene("");
    let scene = p(d.path(), "scene.toml");
    let out = p(d.path(), "out.exr");
    let cache = p(d.path(), "c.cache");
    for (args, says) in [
        (vec!["--passes", "0"], "--passes"),
        (vec!["--time", "0"], "--time"),
        (vec!["--time", "-3"], "--time"),
        (vec!["--time", "nan"], "--time"),
        (vec!["--passes", "2", "--save-cache", &cache], "--passes"),
        (vec!["--time", "2", "--tiles", "2"], "--tiles"),
    ] {
        let mut all = vec!["render", &scene, "-o", &out, "--quiet"];
        all.extend_from_slice(&args);
        let r = run(&all);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(listing(d.path())
            .iter()
            .all(|f| f != "out.exr" && f != "c.cache"));
    }
    let bad = mirror_scene("time = -1.0");
    let r = run(&["render", &p(bad.path(), "scene.toml"), "-o", &out]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{err}");
    let text = std::fs::read_to_string(p(bad.path(), "scene.toml")).unwrap();
    let line = 1 + text.lines().position(|l| l.starts_with("time")).unwrap();
    assert!(
        err.contains(&format!("scene.toml:{line}: render.time")),
        "{err}"
    );
}

#[test]
fn a_sequence_refuses_a_budget_before_any_frame() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/anim-ball.toml");
    let out = p(d.path(), "f-####.exr");
    for args in [["--passes", "2"], ["--time", "5"]] {
        let mut all = vec!["render", scene.to_str().unwrap(), "-o", &out, "--quiet"];
        all.extend_from_slice(&args);
        let r = run(&all);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(args[0]) && err.contains("stills"),
            "{args:?}: {err}"
        );
        assert!(
            listing(d.path()).is_empty(),
            "{args:?} wrote {:?}",
            listing(d.path())
        );
    }
}
