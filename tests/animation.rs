//! Animated scenes: bad keys and output patterns refused before anything is written, a
//! sequence where nothing moves is the still render frame after frame, a walk-through frame agrees
//! with a still render of its camera, a moving object's frame with a still render of its placement,
//! the same frames at 1 and 2 threads, Ctrl-C mid-sequence, per-frame and sequence statistics,
//! `export-mitsuba --frame`, and (slow) the ball scene's flicker against its Mitsuba reference sequence.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use pmrender::io::output::Image;

const CUBE_MTL: &str = "newmtl block
Kd 0.2 0.3 0.7
";

/// The keys and `[animation]` of a test scene: the room of `common`, a cube and a point light. Each
/// field is TOML text placed where its table needs it (`[[mesh.key]]` right after the cube's mesh).
#[derive(Default, Clone)]
struct Keys {
    animation: String,
    camera: String,
    cube: String,
    light: String,
    size: (u32, u32),
}

impl Keys {
    fn frames(n: u32) -> Keys {
        Keys {
            animation: format!("[animation]\nframes = {n}\n"),
            ..Keys::default()
        }
    }
}

/// The base values; a still scene is `scene_text(&Keys::default())`.
const EYE: [f32; 3] = [0.0, 1.0, 3.0];
const TARGET: [f32; 3] = [0.0, 1.0, 0.0];
const CUBE_AT: [f32; 3] = [-0.4, 0.25, 0.0];

fn v3(v: [f32; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

fn scene_text(k: &Keys) -> String {
    let (w, h) = if k.size == (0, 0) { (32, 24) } else { k.size };
    format!(
        "version = 1\n{anim}\n[camera]\neye = {eye}\ntarget = {target}\nfov = 45.0\nwidth = {w}\nheight = {h}\n{cam}\n\
         [[mesh]]\nobj = \"room.obj\"\n\n[[mesh]]\nobj = \"cube.obj\"\nscale = 0.25\ntranslate = {cube_at}\n{cube}\n\
         [[light]]\ntype = \"point\"\nposition = [0.5, 1.5, 0.5]\nintensity = [1.0, 1.0, 1.0]\n{light}\n\
         [render]\nspp = 2\nseed = 3\n",
        anim = k.animation,
        eye = v3(EYE),
        target = v3(TARGET),
        cam = k.camera,
        cube_at = v3(CUBE_AT),
        cube = k.cube,
        light = k.light,
    )
}

/// A folder with the room, the cube and `scene.toml` from `keys`, and an empty `out/` for the outputs.
fn scene(keys: &Keys) -> tempfile::TempDir {
    let cube = cube_obj("cube.mtl", "block");
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("cube.obj", &cube),
        ("cube.mtl", CUBE_MTL),
        ("scene.toml", &scene_text(keys)),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    d
}

fn out(d: &Path, name: &str) -> String {
    p(&d.join("out"), name)
}

/// Runs `render` and panics with its stderr unless it succeeds.
fn render_ok(args: &[&str]) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.push("--quiet");
    let r = run_bounded(&all, Duration::from_secs(300));
    assert!(
        r.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

fn rel_diff(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1e-6)
}

// ---------------------------------------------------------------------------------------------------
// Bad input: exit 2, one line naming the scene's file:line or the option, nothing written.

/// Runs `render` on the scene of `keys` with `args` (outputs under out/), expects exit 2 with one
/// line holding every one of `needles`, and no file anywhere but the scene's inputs.
fn refused(keys: &Keys, args: &[&str], needles: &[&str]) {
    let d = scene(keys);
    let before = listing(d.path());
    let scene = p(d.path(), "scene.toml");
    let mut all = vec!["render", scene.as_str()];
    let o = out(d.path(), "f-####.exr");
    if !args.contains(&"-o") {
        all.extend(["-o", o.as_str()]);
    }
    let resolved: Vec<String> = args
        .iter()
        .map(|a| a.replace("OUT/", &format!("{}/", d.path().join("out").display())))
        .collect();
    all.extend(resolved.iter().map(String::as_str));
    all.push("--quiet");
    let r = run_bounded(&all, Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{all:?}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{all:?}: '{n}' not in: {stderr}");
    }
    assert!(
        listing(&d.path().join("out")).is_empty(),
        "{all:?} wrote {:?}",
        listing(&d.path().join("out"))
    );
    assert_eq!(listing(d.path()), before, "{all:?}");
}

/// `scene.toml:N:` where N is the (1-based) line of the scene holding `text` (its `nth` occurrence).
fn at_line_of(keys: &Keys, text: &str, nth: usize) -> String {
    let line = scene_text(keys)
        .lines()
        .enumerate()
        .filter(|(_, l)| l.contains(text))
        .nth(nth)
        .unwrap_or_else(|| panic!("'{text}' not in the scene"))
        .0;
    format!("scene.toml:{}:", line + 1)
}

#[test]
fn bad_keys_are_refused_with_their_line() {
    // A key outside 0..frames−1 (one of a mesh, one of the camera).
    let mut k = Keys::frames(4);
    k.cube =
        "[[mesh.key]]\nframe = 0\n[[mesh.key]]\nframe = 4\ntranslate = [0.4, 0.25, 0.0]\n".into();
    refused(&k, &[], &[&at_line_of(&k, "frame = 4", 0), "frame"]);
    let mut k = Keys::frames(4);
    k.camera = "[[camera.key]]\nframe = -1\neye = [0.0, 1.0, 2.5]\n".into();
    refused(&k, &[], &[&at_line_of(&k, "frame = -1", 0)]);
    // Two keys of one object at one frame.
    let mut k = Keys::frames(4);
    k.light = "[[light.key]]\nframe = 2\nintensity = [2.0, 2.0, 2.0]\n[[light.key]]\nframe = 2\nintensity = [3.0, 3.0, 3.0]\n".into();
    refused(&k, &[], &[&at_line_of(&k, "frame = 2", 1), "frame 2"]);
    // A key field the object does not have: a spot's cone in a (point) light key, a direction on a
    // point light, a field of view on a mesh, a scale on the camera.
    for (field, table) in [
        ("cone_angle = 30.0", "light"),
        ("direction = [0.0, -1.0, 0.0]", "light"),
        ("fov = 30.0", "mesh"),
        ("scale = 2.0", "camera"),
    ] {
        let mut k = Keys::frames(4);
        let key = format!("[[{table}.key]]\nframe = 1\n{field}\n");
        match table {
            "light" => k.light = key,
            "mesh" => k.cube = key,
            _ => k.camera = key,
        }
        let name = field.split(' ').next().unwrap();
        refused(&k, &[], &[&at_line_of(&k, field, 0), name]);
    }
    // Keys without [animation].
    let k = Keys {
        cube: "[[mesh.key]]\nframe = 1\ntranslate = [0.4, 0.25, 0.0]\n".into(),
        ..Keys::default()
    };
    refused(
        &k,
        &["-o", "OUT/still.exr"],
        &[&at_line_of(&k, "[[mesh.key]]", 0), "[animation]"],
    );
    // No frames.
    let k = Keys::frames(0);
    refused(&k, &[], &[&at_line_of(&k, "frames = 0", 0), "frames"]);
}

#[test]
fn an_eye_interpolated_onto_its_target_is_refused() {
    // Frame 1 lies halfway between eyes on either side of the target: the eye is the target there.
    let mut k = Keys::frames(3);
    k.camera = format!(
        "[[camera.key]]\nframe = 0\neye = {}\n[[camera.key]]\nframe = 2\neye = {}\n",
        v3([0.0, 1.0, 1.0]),
        v3([0.0, 1.0, -1.0])
    );
    refused(&k, &[], &["scene.toml:", "frame 1"]);
}

/// A NaN or infinite key is refused at its own line (it was named at the key before it: every frame
/// interpolated toward it is NaN, and the first such frame's value is set by the key before).
#[test]
fn a_nan_or_infinite_key_is_refused_at_its_own_line() {
    for (table, before, bad) in [
        ("mesh", "scale = 0.25", "scale = nan"),
        (
            "mesh",
            "translate = [0.4, 0.25, 0.0]",
            "translate = [0.4, -inf, 0.0]",
        ),
        ("camera", "fov = 45.0", "fov = inf"),
        ("camera", "eye = [0.0, 1.0, 2.5]", "eye = [nan, 1.0, 2.5]"),
        (
            "light",
            "intensity = [1.0, 1.0, 1.0]",
            "intensity = [1.0, nan, 1.0]",
        ),
    ] {
        let mut k = Keys::frames(4);
        let keys =
            format!("[[{table}.key]]\nframe = 0\n{before}\n[[{table}.key]]\nframe = 3\n{bad}\n");
        match table {
            "light" => k.light = keys,
            "mesh" => k.cube = keys,
            _ => k.camera = keys,
        }
        let field = bad.split(' ').next().unwrap();
        refused(
            &k,
            &[],
            &[
                &format!("{} {table}.key.{field}: ", at_line_of(&k, bad, 0)),
                "is not a finite number",
            ],
        );
    }
}

/// Two finite keys whose values differ by more than f32's range: every frame between them would be
/// infinite. Refused at the first of those frames, on the line of the key before it, saying so (it
/// read "must be finite", of values the file never gave).
#[test]
fn keys_whose_interpolation_overflows_are_refused_with_their_lines() {
    let mut k = Keys::frames(4);
    k.cube = "[[mesh.key]]\nframe = 0\nrotate = [0.0, 3e38, 0.0]\n\
              [[mesh.key]]\nframe = 3\nrotate = [0.0, -3e38, 0.0]\n"
        .into();
    let next = at_line_of(&k, "rotate = [0.0, -3e38", 0);
    let next = next.trim_start_matches("scene.toml:").trim_end_matches(':');
    refused(
        &k,
        &[],
        &[
            &format!(
                "{} frame 1: mesh.rotate: this key's 3e38 and the next key's -3e38 (line {next}) \
                 differ by more than f32's range (3.4e38)",
                at_line_of(&k, "rotate = [0.0, 3e38", 0)
            ),
            "keep consecutive keys within 3.4e38",
        ],
    );
    // The camera's target (any finite point), keyed after a first key that leaves it unset.
    let mut k = Keys::frames(5);
    k.camera = "[[camera.key]]\nframe = 0\nfov = 40.0\n[[camera.key]]\nframe = 1\n\
                target = [-3e38, 1.0, 0.0]\n[[camera.key]]\nframe = 4\ntarget = [3e38, 1.0, 0.0]\n"
        .into();
    refused(
        &k,
        &[],
        &[
            &format!(
                "{} frame 2: camera.target: this key's -3e38",
                at_line_of(&k, "target = [-3e38", 0)
            ),
            "overflow",
        ],
    );
}

#[test]
fn bad_output_patterns_and_frame_ranges_are_refused() {
    let k = {
        let mut k = Keys::frames(4);
        k.cube = "[[mesh.key]]\nframe = 3\ntranslate = [0.4, 0.25, 0.0]\n".into();
        k
    };
    refused(&k, &["-o", "OUT/f.exr"], &["-o", "#"]);
    refused(&k, &["-o", "OUT/f-##-##.exr"], &["-o", "#"]);
    refused(&k, &["--png", "OUT/f.png"], &["--png"]);
    refused(&k, &["--stats", "OUT/s.json"], &["--stats"]);
    refused(&k, &["--frames", "3..1"], &["--frames"]);
    refused(&k, &["--frames", "2..4"], &["--frames"]);
    refused(&k, &["--frames", "4"], &["--frames"]);
    refused(&k, &["--save-cache", "OUT/c.bin"], &["--save-cache"]);
    // --load-photons names a file that exists (a missing one is refused for that reason first).
    let d = scene(&k);
    let photons = p(d.path(), "photons.bin");
    std::fs::write(&photons, b"not photons").unwrap();
    let before = listing(d.path());
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &out(d.path(), "f-####.exr"),
        "--load-photons",
        &photons,
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--load-photons"), "{stderr}");
    assert!(listing(&d.path().join("out")).is_empty());
    assert_eq!(listing(d.path()), before);
    // --frames on a still scene.
    refused(
        &Keys::default(),
        &["-o", "OUT/still.exr", "--frames", "0..1"],
        &["--frames"],
    );
}

// ---------------------------------------------------------------------------------------------------
// Nothing moves: the still render, frame after frame.

/// Renders the still scene (no `[animation]`, no keys) to `out/still.exr` and returns its path.
fn still_render(keys: &Keys, extra: &[&str]) -> (tempfile::TempDir, String) {
    let d = scene(keys);
    let o = out(d.path(), "still.exr");
    let mut args = vec![p(d.path(), "scene.toml"), "-o".into(), o.clone()];
    args.extend(extra.iter().map(|s| s.to_string()));
    render_ok(&args.iter().map(String::as_str).collect::<Vec<_>>());
    (d, o)
}

/// Renders the sequence of `keys` to out/f-####.exr and returns the frames' paths.
fn sequence(d: &Path, n: u32, extra: &[&str]) -> Vec<String> {
    let scene = p(d, "scene.toml");
    let pattern = out(d, "f-####.exr");
    let mut args = vec![scene.as_str(), "-o", pattern.as_str()];
    args.extend_from_slice(extra);
    render_ok(&args);
    (0..n).map(|f| out(d, &format!("f-{f:04}.exr"))).collect()
}

#[test]
fn nothing_moves_every_frame_is_the_still_render() {
    for method in ["pm", "path"] {
        nothing_moves_with(method);
    }
}

fn nothing_moves_with(method: &str) {
    let (_still_dir, still) = still_render(&Keys::default(), &["--method", method]);
    let still = bytes(&still);
    // Keys that set the base values again, at frames of their own.
    let mut same = Keys::frames(3);
    same.camera = format!(
        "[[camera.key]]\nframe = 0\neye = {}\ntarget = {}\n[[camera.key]]\nframe = 2\neye = {}\nfov = 45.0\n",
        v3(EYE),
        v3(TARGET),
        v3(EYE)
    );
    same.cube = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = 2\ntranslate = {}\nscale = 0.25\n",
        v3(CUBE_AT),
        v3(CUBE_AT)
    );
    same.light = "[[light.key]]\nframe = 1\nintensity = [1.0, 1.0, 1.0]\n".into();
    for (what, keys) in [
        ("keys of the base values", same),
        ("no keys", Keys::frames(3)),
    ] {
        let d = scene(&keys);
        let frames = sequence(d.path(), 3, &["--method", method]);
        for (f, path) in frames.iter().enumerate() {
            assert!(
                bytes(path) == still,
                "{method}, {what}: frame {f} differs from the still render"
            );
        }
    }
}

#[test]
fn a_still_scene_renders_as_it_did_before_animation() {
    // The still scene, and the same file with [animation] and keys that hold the base values at
    // frame 0 (the camera and cube move after it): frame 0 is the still render, byte for byte, and so
    // is a one-frame [animation] without keys. (The still render itself was checked once against the
    // binary of the commit before animation, 2f2bf05: cornell-caustics, spot-point, interior-diffuse
    // and fog-cornell at 64x48, pm and path, byte-identical EXRs.)
    let (_d, still) = still_render(&Keys::default(), &[]);
    let still = bytes(&still);
    let mut k = Keys::frames(2);
    k.camera = format!(
        "[[camera.key]]\nframe = 0\neye = {}\n[[camera.key]]\nframe = 1\neye = {}\n",
        v3(EYE),
        v3([0.3, 1.1, 2.8])
    );
    k.cube = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = 1\ntranslate = {}\n",
        v3(CUBE_AT),
        v3([0.4, 0.25, 0.0])
    );
    let d = scene(&k);
    let frames = sequence(d.path(), 2, &["--frames", "0..0"]);
    assert!(bytes(&frames[0]) == still, "frame 0 differs from the still");
    let d = scene(&Keys::frames(1));
    let frames = sequence(d.path(), 1, &[]);
    assert!(bytes(&frames[0]) == still, "one-frame sequence differs");
}

// ---------------------------------------------------------------------------------------------------
// Frames against still renders of the same camera and placements.

/// relMSE of `b`×`b` block means, and the relative difference of the image means (max over channels).
fn agreement(img: &Image, still: &Image, b: u32) -> (f64, f32) {
    let block = rel_mse(&block_means(img, b), &block_means(still, b));
    let (m, r) = (mean(img), mean(still));
    let dm = (0..3).map(|c| rel_diff(m[c], r[c])).fold(0.0, f32::max);
    (block, dm)
}

/// The shipped diffuse interior (its model by absolute path) at 64×48, with camera keys.
fn interior(keys: &str, eye: [f32; 3], target: [f32; 3], frames: u32, seed: u64) -> String {
    let obj = repo().join("scenes/models/interior-diffuse.obj");
    let anim = if keys.is_empty() {
        String::new()
    } else {
        format!("[animation]\nframes = {frames}\n")
    };
    format!(
        "version = 1\n{anim}[camera]\neye = {}\ntarget = {}\nfov = 55.0\nwidth = 64\nheight = 48\n{keys}\n\
         [[mesh]]\nobj = \"{}\"\n[render]\nseed = {seed}\n",
        v3(eye),
        v3(target),
        obj.display()
    )
}

#[test]
fn a_walk_through_frame_agrees_with_a_still_render_of_its_camera() {
    // Four frames walking toward the back of the room; frame 3 is shaded from a cache grown over
    // frames 0–3 (records of earlier views reused where valid) and from the photon maps of frame 0.
    let (e0, t0) = ([2.1, 1.5, 2.2], [-0.6, 0.8, -1.2]);
    let (e3, t3) = ([0.9, 1.3, 1.4], [-1.4, 0.7, -1.6]);
    let keys = format!(
        "[[camera.key]]\nframe = 0\neye = {}\ntarget = {}\n[[camera.key]]\nframe = 3\neye = {}\ntarget = {}\n",
        v3(e0),
        v3(t0),
        v3(e3),
        v3(t3)
    );
    let d = scene_dir(&[
        ("walk.toml", &interior(&keys, e0, t0, 4, 0)),
        ("still.toml", &interior("", e3, t3, 1, 0)),
        ("other-seed.toml", &interior("", e3, t3, 1, 1)),
    ]);
    let o = |n: &str| p(d.path(), n);
    render_ok(&[&o("walk.toml"), "-o", &o("w-#.exr")]);
    render_ok(&[&o("still.toml"), "-o", &o("still.exr")]);
    render_ok(&[&o("other-seed.toml"), "-o", &o("other.exr")]);
    let (frame, still, other) = (
        read(Path::new(&o("w-3.exr"))),
        read(Path::new(&o("still.exr"))),
        read(Path::new(&o("other.exr"))),
    );
    let (block, dmean) = agreement(&frame, &still, 8);
    let (noise_block, noise_dmean) = agreement(&other, &still, 8);
    eprintln!(
        "[walk] frame 3 vs still: 8x8-block relMSE {block:.3e}, mean {:.2} %; another seed's still: \
         {noise_block:.3e}, {:.2} %",
        dmean * 100.0,
        noise_dmean * 100.0
    );
    // Within its noise: no further from the still than 3x a still of another seed is. Seeds 0, 2, 4
    // (each with its next seed's still; SSE4.2's kernels gave seed 0's figures): block relMSE
    // 0.95, 1.10, 0.92 times the other seed's (the bound 2.7× the worst); means 0.06, 0.05, 0.09 %
    // apart, another seed's still 0.04, 0.03, 0.14 %: bound 0.5 % (it was 2 %, 22× the worst).
    assert!(
        dmean <= 0.005,
        "image mean differs by {:.2} %",
        dmean * 100.0
    );
    assert!(
        block <= 3.0 * noise_block,
        "block relMSE {block:.3e} (another seed: {noise_block:.3e})"
    );
}

#[test]
fn records_stay_while_the_camera_backs_away() {
    // Stepping back along its view, every record spans fewer pixels than in the view it was made
    // for: none is too coarse for the new view, none is dropped (a record spanning more than half
    // its pixel-spacing limit used to be dropped the next frame whatever the camera did, and made
    // again in the same place).
    let (e0, t0) = ([1.2, 1.3, 1.4], [-1.4, 0.7, -1.6]);
    let e2 = [1.5, 1.37, 1.75];
    let keys = format!(
        "[[camera.key]]\nframe = 0\neye = {}\n[[camera.key]]\nframe = 2\neye = {}\n",
        v3(e0),
        v3(e2)
    );
    let d = scene_dir(&[("walk.toml", &interior(&keys, e0, t0, 3, 0))]);
    let o = |n: &str| p(d.path(), n);
    render_ok(&[
        &o("walk.toml"),
        "-o",
        &o("w-#.exr"),
        "--stats",
        &o("w-#.json"),
    ]);
    for f in 1..3 {
        let frame = &json(&o(&format!("w-{f}.json")))["frame"];
        eprintln!("[back] frame {f}: {frame}");
        assert!(
            frame["records_reused"].as_u64().unwrap_or(0) > 0,
            "frame {f}: {frame}"
        );
        assert_eq!(
            frame["records_dropped"].as_u64(),
            Some(0),
            "frame {f}: {frame}"
        );
    }
}

#[test]
fn a_walk_through_frame_covers_its_points_before_shading() {
    // Pass B reads the records of earlier views only where a shadow ray reaches them. Pass A must
    // count a point covered by them only there too, or pass B misses the point, makes a record for it
    // between its rounds and shades the pixel again: misses stay as rare as in a still (none there).
    // The camera swings past the ball and the block of the ball's box, so that earlier views' records
    // lie behind them (without the test in pass A, 2–4 % of pass B's lookups missed).
    let models = repo().join("scenes/models");
    let scene = format!(
        "version = 1\n[animation]\nframes = 6\n[camera]\neye = [-0.8, 0.5, 1.8]\n\
         target = [0.3, 0.3, -0.5]\nfov = 50.0\nwidth = 160\nheight = 120\n\
         [[camera.key]]\nframe = 0\neye = [-0.8, 0.5, 1.8]\n\
         [[camera.key]]\nframe = 5\neye = [0.8, 0.5, 1.8]\ntarget = [-0.3, 0.3, -0.5]\n\
         [[mesh]]\nobj = \"{}\"\n[[mesh]]\nobj = \"{}\"\nscale = 0.25\n\
         translate = [-0.2, 0.25, 0.0]\n[render]\nseed = 0\n",
        models.join("anim-ball-box.obj").display(),
        models.join("ball.obj").display()
    );
    let d = scene_dir(&[("walk.toml", &scene)]);
    let o = |n: &str| p(d.path(), n);
    render_ok(&[
        &o("walk.toml"),
        "-o",
        &o("w-#.exr"),
        "--stats",
        &o("w-#.json"),
    ]);
    for f in 1..6 {
        let s = json(&o(&format!("w-{f}.json")));
        let misses = s["icache"]["misses_pass_b"].as_u64().unwrap();
        let lookups = s["icache"]["lookups_pass_b"].as_u64().unwrap();
        eprintln!("[walk] frame {f}: pass B misses {misses} of {lookups} lookups");
        assert!(
            misses * 10_000 <= lookups,
            "frame {f}: pass B missed {misses} of {lookups} lookups"
        );
    }
}

#[test]
fn a_moving_object_frame_agrees_with_a_still_render_of_its_placement() {
    // The cube slides across the room in 4 frames; frame 2 against the still scene with the cube where
    // frame 2 puts it (2/3 of the way: keys at 0 and 3).
    let (a, b) = ([-0.5, 0.25, 0.0], [0.4, 0.25, 0.3]);
    let at2: [f32; 3] = std::array::from_fn(|i| a[i] + (b[i] - a[i]) * (2.0 / 3.0));
    let mut k = Keys::frames(4);
    k.size = (64, 48);
    k.cube = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = 3\ntranslate = {}\n",
        v3(a),
        v3(b)
    );
    let d = scene(&k);
    let stats = out(d.path(), "f-####.json");
    let frames = sequence(d.path(), 4, &["--stats", &stats]);
    // Pixels only the cube's changed bounce light reaches are relit, not shaded again: the frame's
    // agreement below covers them.
    let relit = json(&out(d.path(), "f-0002.json"))["frame"]["pixels_relit"]
        .as_u64()
        .unwrap_or(0);
    let still_keys = Keys {
        size: (64, 48),
        ..Keys::default()
    };
    let still_text = scene_text(&still_keys).replace(
        &format!("translate = {}", v3(CUBE_AT)),
        &format!("translate = {}", v3(at2)),
    );
    std::fs::write(d.path().join("still.toml"), &still_text).unwrap();
    let still = out(d.path(), "still.exr");
    render_ok(&[&p(d.path(), "still.toml"), "-o", &still]);
    let other_text = still_text.replace("seed = 3", "seed = 4");
    std::fs::write(d.path().join("other.toml"), other_text).unwrap();
    let other = out(d.path(), "other.exr");
    render_ok(&[&p(d.path(), "other.toml"), "-o", &other]);
    let (frame, still, other) = (
        read(Path::new(&frames[2])),
        read(Path::new(&still)),
        read(Path::new(&other)),
    );
    let (block, dmean) = agreement(&frame, &still, 8);
    let (noise_block, _) = agreement(&other, &still, 8);
    eprintln!(
        "[moving] frame 2 vs still: 8x8-block relMSE {block:.3e}, mean {:.2} %; another seed: {noise_block:.3e}; {relit} pixels relit",
        dmean * 100.0
    );
    assert!(relit > 0, "no pixel relit");
    // Measured 0 when each frame where the cube moved is traced and filled as a still; with the
    // temporal cache carrying records over, at seeds 3, 5, 7 (each with its next seed's still) and
    // SSE4.2's kernels at seed 3: block relMSE 0.11, 0.14, 0.28, 0.15 times the other seed's
    // (3.1e-5 – 7.3e-5), means 0.12, 0.17, 0.15, 0.17 % apart. Bounds (they were 3× and 2 %, 11×
    // and 12× the worst): the block error within 1.5× another seed's (5.4× the worst), the means
    // within 1 % (5.9×) — the frame no further from its still than noise, where a frame with the
    // cube's old bounce light left in it would be.
    assert!(
        dmean <= 0.01,
        "image mean differs by {:.2} %",
        dmean * 100.0
    );
    assert!(
        block <= 1.5 * noise_block,
        "block relMSE {block:.3e} (another seed: {noise_block:.3e})"
    );
}

#[test]
fn a_sequence_is_the_same_at_1_and_2_threads() {
    // The camera moves over frames 0–2 (one cache carried over), the cube over frames 2–4 (each frame
    // traced again), the light's intensity at frame 4.
    let mut k = Keys::frames(5);
    k.camera = format!(
        "[[camera.key]]\nframe = 0\neye = {}\n[[camera.key]]\nframe = 2\neye = {}\ntarget = {}\n",
        v3(EYE),
        v3([0.5, 1.2, 2.6]),
        v3([-0.2, 0.8, 0.0])
    );
    k.cube = format!(
        "[[mesh.key]]\nframe = 2\ntranslate = {}\n[[mesh.key]]\nframe = 4\ntranslate = {}\n",
        v3(CUBE_AT),
        v3([0.3, 0.25, 0.2])
    );
    k.light = "[[light.key]]\nframe = 3\nintensity = [1.0, 1.0, 1.0]\n[[light.key]]\nframe = 4\nintensity = [2.0, 1.5, 1.0]\n".into();
    let d = scene(&k);
    let scene_path = p(d.path(), "scene.toml");
    let mut seen = Vec::new();
    for threads in ["1", "2"] {
        let pattern = out(d.path(), &format!("t{threads}-####.exr"));
        render_ok(&[&scene_path, "-o", &pattern, "--threads", threads]);
        seen.push(
            (0..5)
                .map(|f| bytes(&out(d.path(), &format!("t{threads}-{f:04}.exr"))))
                .collect::<Vec<_>>(),
        );
    }
    for f in 0..5 {
        assert!(seen[0][f] == seen[1][f], "frame {f} differs");
    }
    // The frames differ from each other where something moved (the test would pass on one image).
    assert!(seen[0][0] != seen[0][2] && seen[0][2] != seen[0][4]);
}

// ---------------------------------------------------------------------------------------------------
// Outputs: statistics, Ctrl-C.

fn json(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}")))
        .unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn stats_write_each_frame_and_a_sequence_summary() {
    // Frames 1–2: the camera moves (photons traced once, cache carried over); frame 3 holds still
    // (nothing changes); frame 4: the cube moves (photons traced again). --frames 1..4, which renders
    // frame 0 too, unwritten, to reach frame 1 as the whole run does.
    let mut k = Keys::frames(6);
    k.camera = format!(
        "[[camera.key]]\nframe = 1\neye = {}\n[[camera.key]]\nframe = 2\neye = {}\n",
        v3(EYE),
        v3([0.4, 1.1, 2.7])
    );
    k.cube = format!(
        "[[mesh.key]]\nframe = 3\ntranslate = {}\n[[mesh.key]]\nframe = 4\ntranslate = {}\n",
        v3(CUBE_AT),
        v3([0.3, 0.25, 0.2])
    );
    let d = scene(&k);
    render_ok(&[
        &p(d.path(), "scene.toml"),
        "-o",
        &out(d.path(), "f-##.exr"),
        "--png",
        &out(d.path(), "f-##.png"),
        "--stats",
        &out(d.path(), "s-##.json"),
        "--frames",
        "1..4",
    ]);
    let mut expected: Vec<String> = (1..=4)
        .flat_map(|f| {
            [
                format!("f-{f:02}.exr"),
                format!("f-{f:02}.png"),
                format!("s-{f:02}.json"),
            ]
        })
        .collect();
    expected.push("s-sequence.json".into());
    expected.sort();
    assert_eq!(listing(&d.path().join("out")), expected);
    for f in 1..=4u64 {
        let j = json(&out(d.path(), &format!("s-{f:02}.json")));
        assert_eq!(j["frame"]["index"], f, "{j}");
        for section in ["frame", "time", "image"] {
            assert!(j.get(section).is_some(), "frame {f}: no {section}");
        }
    }
    let s = json(&out(d.path(), "s-sequence.json"));
    assert_eq!(s["complete"], true);
    assert_eq!(s["frames_written"], 4);
    let rows = s["frames"].as_array().expect("frames");
    let frames: Vec<u64> = rows.iter().map(|r| r["frame"].as_u64().unwrap()).collect();
    assert_eq!(frames, [1, 2, 3, 4]);
    for r in rows {
        for key in ["time_s", "photons", "records_reused", "records_after"] {
            assert!(r.get(key).is_some_and(|v| !v.is_null()), "{key} in {r}");
        }
    }
    // Frame 0, rendered to reach the range (not written), traced the photon maps, and nothing moved
    // to frame 1: frame 1 reuses them with frame 0's image. Frame 2's camera moved over a static
    // scene: its photon maps are still frame 0's, its cache carries the records before. Frame 4's cube
    // moved: its photons are traced again.
    assert_eq!(rows[0]["photons"], "reused", "{}", rows[0]);
    assert_eq!(rows[0]["image_reused"], true, "{}", rows[0]);
    assert_ne!(rows[1]["photons"], "traced", "{}", rows[1]);
    assert!(
        rows[1]["records_reused"].as_u64().unwrap() > 0,
        "{}",
        rows[1]
    );
    assert_eq!(rows[3]["photons"], "traced", "{}", rows[3]);
    // Nothing changed from frame 2 to frame 3: the same image.
    assert!(
        bytes(&out(d.path(), "f-02.exr")) == bytes(&out(d.path(), "f-03.exr")),
        "frame 3 differs from frame 2"
    );
}

/// `frames` frames of the cube sliding across the box at 48×36: every frame traced and filled anew.
fn sliding_cube(frames: u32) -> Keys {
    let mut k = Keys::frames(frames);
    k.size = (48, 36);
    k.cube = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = {}\ntranslate = {}\n",
        v3([-0.6, 0.25, 0.0]),
        frames - 1,
        v3([0.6, 0.25, 0.0])
    );
    k
}

/// Sends `child` SIGINT and checks it ends as interrupted (exit 130); its stderr.
fn interrupt(child: std::process::Child) -> String {
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let result = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&result.stderr).into_owned();
    assert_eq!(result.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    stderr
}

/// Ctrl-C into a million-frame sequence while its outputs are checked (seconds of stat calls before
/// the movers' window is found and frame 0 rendered): the phase reads the flag (no watchdog), and
/// nothing is written. The signal is sent once the check has begun, seen as `out/`'s modification
/// time changing when its writability probe is made and removed, not after a fixed sleep: under
/// load the process could still be loading the keys (every frame's interpolation checked, which
/// reads no flag) a second in, and the watchdog ended it there.
#[test]
fn ctrl_c_before_the_first_frame_of_a_long_sequence() {
    let d = scene(&sliding_cube(1_000_000));
    let dir = d.path().join("out");
    let modified = || std::fs::metadata(&dir).and_then(|m| m.modified()).unwrap();
    let before = modified();
    let child = spawn_interruptible(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &out(d.path(), "f-#######.exr"),
        "--quiet",
    ]);
    let t = std::time::Instant::now();
    while modified() == before {
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "no output check began in 2 minutes"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let stderr = interrupt(child);
    assert!(!stderr.contains("watchdog"), "{stderr}");
    let files = listing(&dir);
    assert!(files.iter().all(|f| !f.starts_with("f-")), "{files:?}");
}

#[test]
fn ctrl_c_keeps_the_frames_written_and_nothing_of_the_current_one() {
    // 400 frames of a cube sliding: every frame traced and filled anew, a fraction of a second each.
    let d = scene(&sliding_cube(400));
    let dir = d.path().join("out");
    let mut child = spawn_interruptible(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &out(d.path(), "f-####.exr"),
        "--png",
        &out(d.path(), "f-####.png"),
        "--stats",
        &out(d.path(), "f-####.json"),
        "--quiet",
    ]);
    // Until frame 2 is on disk, then Ctrl-C during a later frame.
    let t = Instant::now();
    while !dir.join("f-0002.exr").exists() {
        assert!(child.try_wait().unwrap().is_none(), "ended before frame 2");
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "no frame 2 after 2 min"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(100));
    interrupt(child);
    // Frames 0..n, each with all three of its files, and the summary; nothing else.
    let files = listing(&dir);
    let n = files.iter().filter(|f| f.ends_with(".exr")).count();
    assert!((3..400).contains(&n), "{n} frames: {files:?}");
    eprintln!("[ctrl-c] {n} frames written before the signal");
    let mut expected: Vec<String> = (0..n)
        .flat_map(|f| ["exr", "png", "json"].map(|e| format!("f-{f:04}.{e}")))
        .collect();
    expected.push("f-sequence.json".into());
    expected.sort();
    let without_summary: Vec<&String> = expected
        .iter()
        .filter(|f| *f != "f-sequence.json")
        .collect();
    assert!(
        files == expected || files.iter().collect::<Vec<_>>() == without_summary,
        "left {files:?}"
    );
    for f in 0..n {
        let img = read(&dir.join(format!("f-{f:04}.exr")));
        assert_eq!((img.width, img.height), (48, 36));
        assert!(img.pixels.iter().all(|p| p.is_finite()));
        json(&p(&dir, &format!("f-{f:04}.json")));
    }
    if files.contains(&"f-sequence.json".to_string()) {
        let s = json(&p(&dir, "f-sequence.json"));
        assert_eq!(s["complete"], false, "{s}");
        assert_eq!(s["frames_written"], n as u64, "{s}");
    }
}

// ---------------------------------------------------------------------------------------------------
// export-mitsuba --frame

#[test]
fn export_mitsuba_writes_the_frame_asked_for() {
    let mut k = Keys::frames(4);
    k.cube = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = 3\ntranslate = {}\n",
        v3([-0.6, 0.25, 0.0]),
        v3([0.6, 0.25, 0.0])
    );
    let d = scene(&k);
    let scene_path = p(d.path(), "scene.toml");
    // The cube's OBJ group: its material's vertices' mean x is where the frame puts it.
    let cube_x = |dir: &Path| -> f64 {
        let xml = std::fs::read_to_string(dir.join("scene.xml")).unwrap();
        let mut xs = Vec::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if !name.ends_with(".obj") || !xml.contains(&name) {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let vs: Vec<[f64; 3]> = text
                .lines()
                .filter_map(|l| l.strip_prefix("v "))
                .map(|l| {
                    let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
                    [c[0], c[1], c[2]]
                })
                .collect();
            // The cube is the one group no wider than 0.5 below y = 0.5 (the light is as wide).
            let (lo, hi) = vs.iter().fold((f64::MAX, f64::MIN), |(lo, hi), v| {
                (lo.min(v[0]), hi.max(v[0]))
            });
            let top = vs.iter().map(|v| v[1]).fold(f64::MIN, f64::max);
            if hi - lo <= 0.51 && top <= 0.51 {
                xs.push((lo + hi) / 2.0);
            }
        }
        assert_eq!(xs.len(), 1, "one cube group");
        xs[0]
    };
    for (frame, x) in [
        (None, -0.6),
        (Some("0"), -0.6),
        (Some("2"), 0.2),
        (Some("3"), 0.6),
    ] {
        let dir = d.path().join(format!("x{}", frame.unwrap_or("default")));
        let mut args = vec!["export-mitsuba", &scene_path, dir.to_str().unwrap()];
        if let Some(f) = frame {
            args.extend(["--frame", f]);
        }
        let r = run(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let got = cube_x(&dir);
        assert!((got - x).abs() < 1e-4, "frame {frame:?}: cube at x = {got}");
    }
    // A frame outside the sequence, and --frame on a still scene: exit 2, one line, nothing written.
    let still = scene(&Keys::default());
    for (scene_path, frame, needle) in [
        (scene_path.clone(), "4", "0..=3"),
        (p(still.path(), "scene.toml"), "0", "[animation]"),
    ] {
        let dir = d.path().join("refused");
        let r = run(&[
            "export-mitsuba",
            &scene_path,
            dir.to_str().unwrap(),
            "--frame",
            frame,
        ]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains("--frame") && stderr.contains(needle),
            "{stderr}"
        );
        assert!(!dir.exists());
    }
}

/// The ball crossing the box, frames 0–9 at 96×72: far from the ball (the top of the right wall) the
/// image changes from frame to frame by what the ball's light does there, a tenth of a per cent
/// (the reference: at most 0.13 % a frame over the 48 frames). The second frame shaded again every
/// pixel a changed record reached (the first frame noted no light to compare with: 1728 of 6912
/// pixels kept, now 6421), and records made on the room's edges found no surface and vanished:
/// that corner jumped by 1.2 %; a record's gather from beside the edge then read twice its light
/// (frame 8, +1.2 %). Measured now: at most 0.03 % a frame. Bound 0.5 %.
#[test]
fn far_from_the_ball_the_image_does_not_pop() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/anim-ball.toml");
    render_ok(&[
        scene.to_str().unwrap(),
        "-o",
        &p(d.path(), "f-####.exr"),
        "--stats",
        &p(d.path(), "f-####.json"),
        "--width",
        "96",
        "--height",
        "72",
        "--frames",
        "0..9",
    ]);
    let kept = json(&p(d.path(), "f-0001.json"))["frame"]["pixels_kept"]
        .as_u64()
        .unwrap();
    assert!(kept >= 6000, "frame 1 kept {kept} of 6912 pixels");
    let corner = |f: u32| {
        let img = read(&d.path().join(format!("f-{f:04}.exr")));
        let mut sum = 0.0f64;
        for y in 0..15 {
            for x in 72..84 {
                sum += img.pixels[y * 96 + x].element_sum() as f64;
            }
        }
        sum
    };
    let means: Vec<f64> = (0..10).map(corner).collect();
    for f in 1..10 {
        let step = (means[f] / means[f - 1] - 1.0).abs();
        eprintln!("[corner] frame {f}: {:+.4} %", 100.0 * step);
        assert!(
            step <= 0.005,
            "the wall's corner changed by {step:.4} at frame {f}"
        );
    }
}

// ---------------------------------------------------------------------------------------------------
// Slow: the ball crossing the box against its Mitsuba reference sequence.

/// Flicker of one pair of frames, as tools/flicker.py defines it: the mean over pixels and channels of
/// ((I_t − I_s) − (R_t − R_s))² / (((R_t + R_s)/2)² + 0.01).
fn rel_mse_diff(i_t: &Image, i_s: &Image, r_t: &Image, r_s: &Image) -> f64 {
    let n = i_t.pixels.len();
    assert!([i_s, r_t, r_s].iter().all(|x| x.pixels.len() == n));
    let mut sum = 0.0f64;
    for k in 0..n {
        for c in 0..3 {
            let d = (i_t.pixels[k][c] - i_s.pixels[k][c]) as f64
                - (r_t.pixels[k][c] - r_s.pixels[k][c]) as f64;
            let r = (r_t.pixels[k][c] as f64 + r_s.pixels[k][c] as f64) / 2.0;
            sum += d * d / (r * r + 0.01);
        }
    }
    sum / (3 * n) as f64
}

/// Per-frame relMSE and the temporal relMSE (mean over consecutive pairs) of `frames` against `refs`.
fn flicker(frames: &[Image], refs: &[Image]) -> (Vec<f64>, f64) {
    let per_frame: Vec<f64> = frames
        .iter()
        .zip(refs)
        .map(|(i, r)| rel_mse(i, r))
        .collect();
    let pairs: Vec<f64> = (1..frames.len())
        .map(|t| rel_mse_diff(&frames[t], &frames[t - 1], &refs[t], &refs[t - 1]))
        .collect();
    let temporal = pairs.iter().sum::<f64>() / pairs.len() as f64;
    (per_frame, temporal)
}

fn reference_frames() -> (PathBuf, serde_json::Value) {
    let dir = repo().join("tests/reference/anim-ball");
    let info = json(&p(&dir, "sequence.json"));
    (dir, info)
}

#[test]
#[ignore]
fn anim_ball_flicker_against_the_mitsuba_sequence() {
    let (ref_dir, info) = reference_frames();
    let (w, h) = (
        info["width"].as_u64().unwrap(),
        info["height"].as_u64().unwrap(),
    );
    let n = info["frames"].as_array().unwrap().len();
    assert_eq!(n, 48, "the reference holds every frame");
    let refs: Vec<Image> = (0..n)
        .map(|f| read(&ref_dir.join(format!("frame-{f:04}.exr"))))
        .collect();
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/anim-ball.toml");
    let (ws, hs) = (w.to_string(), h.to_string());
    // The sequence, one command.
    let t = Instant::now();
    render_ok(&[
        scene.to_str().unwrap(),
        "-o",
        &p(d.path(), "seq-####.exr"),
        "--width",
        &ws,
        "--height",
        &hs,
    ]);
    let seq_s = t.elapsed().as_secs_f64();
    // Independent stills: each frame its own process, its own photon maps and cache.
    let t = Instant::now();
    for f in 0..n {
        let fs = f.to_string();
        render_ok(&[
            scene.to_str().unwrap(),
            "-o",
            &p(d.path(), "ind-####.exr"),
            "--width",
            &ws,
            "--height",
            &hs,
            "--frames",
            &fs,
            "--chunk",
            "1",
        ]);
    }
    let ind_s = t.elapsed().as_secs_f64();
    let load = |prefix: &str| -> Vec<Image> {
        (0..n)
            .map(|f| read(&d.path().join(format!("{prefix}-{f:04}.exr"))))
            .collect()
    };
    let (seq_err, seq_flicker) = flicker(&load("seq"), &refs);
    let (ind_err, ind_flicker) = flicker(&load("ind"), &refs);
    let max = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let noise = info["noise_relmse_mean"].as_f64().unwrap();
    eprintln!(
        "[anim-ball {w}x{h}, {n} frames] sequence: {seq_s:.1} s, relMSE mean {:.3e} max {:.3e}, \
         temporal relMSE {seq_flicker:.3e}; independent stills: {ind_s:.1} s, relMSE mean {:.3e} max \
         {:.3e}, temporal {ind_flicker:.3e}; flicker ratio {:.2}; reference noise relMSE {noise:.1e}",
        avg(&seq_err),
        max(&seq_err),
        avg(&ind_err),
        max(&ind_err),
        seq_flicker / ind_flicker,
    );
    // Measured against the 16384-spp reference (its own flicker about 0.26e-6): independent stills,
    // frames 3.0e-4 to 3.4e-4, temporal relMSE 2.34e-5; the sequence with the temporal cache, frames
    // up to 3.59e-4, temporal relMSE 5.69e-6: ratio 0.243. The images do not depend on the machine
    // or the threads (same scene, same seed), so the target itself is the bound: flicker at most 1/4
    // of the independent stills'. Frames: 2x the measured worst.
    assert!(
        max(&seq_err) <= 7.2e-4,
        "a frame's relMSE {:.3e} > 7.2e-4",
        max(&seq_err)
    );
    assert!(
        seq_flicker <= 0.25 * ind_flicker,
        "temporal relMSE {seq_flicker:.3e} > 1/4 of the independent stills' {ind_flicker:.3e}"
    );
}
