//! Animated scenes whose changes the temporal path must not miss, each frame checked against a
//! still render of that frame's values (or the sequence refused before anything is written):
//!
//! - a point light keyed to another colour at the same luminance, and one dimmed by 15 %: the `pm`
//!   frames carry no irradiance of the light's old value;
//! - a moving emissive mesh (the only light): `pm`'s cached indirect light follows it;
//! - the camera walking into a fog box: `path` frames start their rays in the eye's medium of that
//!   frame; a camera keyed out of its declared `[camera] medium` is refused before the first frame;
//! - the only light keyed to zero intensity: refused before the first frame, naming the key's line;
//!   a field of view or `up` keyed into a bad value: refused naming that key;
//! - an output pattern whose `#` run is in a directory name: each frame's directory is checked (and
//!   written into), not the pattern's literal name.

mod common;
use common::*;

use std::path::Path;
use std::time::Duration;

use glam::Vec3;
use pmrender::io::output::Image;

/// A one-sided square (−1…1 in x and z at y = 0) facing +y, of material `glow`.
const PANEL_OBJ: &str = "mtllib panel.mtl
usemtl glow
v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
f 4 3 2 1
";

/// Black unless the scene gives it an `emission` (as `[materials.glow]`).
const PANEL_MTL: &str = "newmtl glow
Kd 0 0 0
";

const FOG_BOX_MTL: &str = "newmtl boundary
Kd 0 0 0
";

/// The room of `common` with its left wall (x = −1) red, so that light it bounces shows its colour.
fn red_room_obj() -> String {
    let obj = ROOM_OBJ
        .replace("mtllib room.mtl", "mtllib red-room.mtl")
        .replace("f 1 4 8 5\n", "usemtl red\nf 1 4 8 5\nusemtl wall\n");
    assert!(obj.contains("usemtl red"), "the room's left wall moved");
    obj
}

fn red_room_mtl() -> String {
    format!("{ROOM_MTL}newmtl red\nKd 0.7 0.1 0.1\n")
}

fn v3(v: [f32; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

/// `[animation]` for `frames` frames, or nothing for a still scene (`frames` 0).
fn animation(frames: u32) -> String {
    if frames == 0 {
        String::new()
    } else {
        format!("[animation]\nframes = {frames}\n")
    }
}

/// The room of `common`, its ceiling panel off, lit by one point light of `intensity` with `keys`
/// (`[[light.key]]` tables) under it.
fn point_light_room(frames: u32, intensity: [f32; 3], keys: &str) -> String {
    format!(
        "version = 1\n{anim}[camera]\neye = [0.0, 1.0, 3.0]\ntarget = [0.0, 1.0, 0.0]\nfov = 45.0\n\
         width = 48\nheight = 32\n[[mesh]]\nobj = \"room.obj\"\n[materials.light]\n\
         emission = [0.0, 0.0, 0.0]\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.5, 0.0]\n\
         intensity = {intensity}\n{keys}[render]\nseed = 3\n",
        anim = animation(frames),
        intensity = v3(intensity),
    )
}

/// The red-walled room at twice its size, its ceiling panel off, lit only by a small emissive panel
/// facing up (its light reaches the image by bouncing off the ceiling) at `at`, with `keys`.
fn panel_room(frames: u32, at: [f32; 3], keys: &str) -> String {
    format!(
        "version = 1\n{anim}[camera]\neye = [0.0, 2.0, 6.0]\ntarget = [0.0, 2.0, 0.0]\nfov = 45.0\n\
         width = 48\nheight = 32\n[[mesh]]\nobj = \"red-room.obj\"\nscale = 2.0\n[[mesh]]\n\
         obj = \"panel.obj\"\nscale = 0.12\ntranslate = {at}\n{keys}[materials.glow]\n\
         emission = [20.0, 20.0, 20.0]\n[materials.light]\nemission = [0.0, 0.0, 0.0]\n[render]\n\
         seed = 3\n",
        anim = animation(frames),
        at = v3(at),
    )
}

/// The room of `common` (its ceiling panel lit) holding a fog box, x and z in −0.9…0.9, y in
/// 0.1…1.9; the camera at `eye` looks toward the back wall, `camera` is more of its table (keys).
fn fog_room(frames: u32, eye: [f32; 3], camera: &str) -> String {
    format!(
        "version = 1\n{anim}[camera]\neye = {eye}\ntarget = [0.0, 1.0, -1.0]\nfov = 50.0\n\
         width = 48\nheight = 32\n{camera}[[medium]]\nname = \"fog\"\n\
         sigma_a = [0.02, 0.02, 0.02]\nsigma_s = [0.25, 0.25, 0.25]\ng = 0.3\n[[mesh]]\n\
         obj = \"room.obj\"\n[[mesh]]\nobj = \"fogbox.obj\"\nscale = 0.9\n\
         translate = [0.0, 1.0, 0.0]\ninterior = \"fog\"\n[materials.boundary]\ntype = \"null\"\n\
         [render]\nseed = 3\n",
        anim = animation(frames),
        eye = v3(eye),
    )
}

/// A folder with every model of this file, the scenes `scenes` (name, text) and an empty `out/`.
fn folder(scenes: &[(&str, &str)]) -> tempfile::TempDir {
    let (red_obj, red_mtl) = (red_room_obj(), red_room_mtl());
    let fog_box = cube_obj("fogbox.mtl", "boundary");
    let mut files: Vec<(&str, &str)> = vec![
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("red-room.obj", &red_obj),
        ("red-room.mtl", &red_mtl),
        ("panel.obj", PANEL_OBJ),
        ("panel.mtl", PANEL_MTL),
        ("fogbox.obj", &fog_box),
        ("fogbox.mtl", FOG_BOX_MTL),
    ];
    files.extend_from_slice(scenes);
    let d = scene_dir(&files);
    std::fs::create_dir(d.path().join("out")).unwrap();
    d
}

fn out(d: &Path, name: &str) -> String {
    p(&d.join("out"), name)
}

/// Runs `render` with `args` (and `--quiet`), bounded in time.
fn render(args: &[&str]) -> std::process::Output {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.push("--quiet");
    run_bounded(&all, Duration::from_secs(120))
}

/// Runs `render` and panics with its stderr unless it succeeds.
fn render_ok(args: &[&str]) {
    let r = render(args);
    assert!(
        r.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

/// Per channel, how far the mean of `img` lies from that of `still`, relative to the still's.
fn mean_diff(img: &Image, still: &Image) -> Vec3 {
    let (m, r) = (mean(img), mean(still));
    (m - r) / r.abs().max(Vec3::splat(1e-9))
}

/// Per-channel differences as "R +x.xx %, G …, B …".
fn percents(d: Vec3) -> String {
    format!(
        "R {:+.2} %, G {:+.2} %, B {:+.2} %",
        d.x * 100.0,
        d.y * 100.0,
        d.z * 100.0
    )
}

/// Renders the sequence `scene` into out/f-####.exr, then each still scene of `stills` into
/// out/still-F.exr, all with `extra`; returns, for each frame F of `frames`, (frame F, its still,
/// their paths).
fn frame_and_still(
    d: &Path,
    scene: &str,
    frames: &[u32],
    stills: &[&str],
    extra: &[&str],
) -> Vec<(Image, Image, String, String)> {
    let pattern = out(d, "f-####.exr");
    let scene = p(d, scene);
    let mut args = vec![scene.as_str(), "-o", pattern.as_str()];
    args.extend_from_slice(extra);
    render_ok(&args);
    frames
        .iter()
        .zip(stills)
        .map(|(&f, still)| {
            let still_out = out(d, &format!("still-{f}.exr"));
            let still_scene = p(d, still);
            let mut args = vec![still_scene.as_str(), "-o", still_out.as_str()];
            args.extend_from_slice(extra);
            render_ok(&args);
            let frame_out = out(d, &format!("f-{f:04}.exr"));
            (
                read(Path::new(&frame_out)),
                read(Path::new(&still_out)),
                frame_out,
                still_out,
            )
        })
        .collect()
}

/// The (1-based) lines of `text` from its `nth` line holding `start` to the line before the next
/// table header after it (the whole table it starts).
fn table_lines(text: &str, start: &str, nth: usize) -> std::ops::RangeInclusive<usize> {
    let lines: Vec<&str> = text.lines().collect();
    let first = (0..lines.len())
        .filter(|&i| lines[i].contains(start))
        .nth(nth)
        .unwrap_or_else(|| panic!("'{start}' not in the scene"));
    let last = (first + 1..lines.len())
        .find(|&i| lines[i].starts_with('['))
        .unwrap_or(lines.len());
    first + 1..=last
}

/// The line N of the first `scene.toml:N:` in `stderr`.
fn line_named(stderr: &str) -> Option<usize> {
    let rest = &stderr[stderr.find("scene.toml:")? + "scene.toml:".len()..];
    rest.split(':').next()?.parse().ok()
}

/// Runs `render` on `scene.toml` of `d` with `args`, expects exit 2 before anything is written
/// (`out/` stays empty) with one line on stderr, and returns that.
fn refused(d: &Path, args: &[&str]) -> String {
    let scene = p(d, "scene.toml");
    let mut all = vec![scene.as_str()];
    all.extend_from_slice(args);
    let r = render(&all);
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    assert_eq!(r.status.code(), Some(2), "{all:?}: {stderr}");
    assert!(
        listing(&d.join("out")).is_empty(),
        "{all:?} wrote {:?} ({stderr})",
        listing(&d.join("out"))
    );
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    stderr
}

// ---------------------------------------------------------------------------------------------------
// Lights that change: every frame is the still of its light.

/// A point light keyed from white to orange at about the same luminance (frames 0–2): `pm`'s
/// frame 2 has each channel's image mean within 0.1 % of the still render of frame 2's colour.
#[test]
fn a_light_changing_colour_at_constant_luminance_matches_its_still() {
    let orange = [1.5, 0.9018, 0.5];
    let keys = format!(
        "[[light.key]]\nframe = 0\nintensity = {}\n[[light.key]]\nframe = 2\nintensity = {}\n",
        v3([1.0, 1.0, 1.0]),
        v3(orange)
    );
    let d = folder(&[
        ("scene.toml", &point_light_room(3, [1.0, 1.0, 1.0], &keys)),
        ("still.toml", &point_light_room(0, orange, "")),
    ]);
    let pairs = frame_and_still(
        d.path(),
        "scene.toml",
        &[2],
        &["still.toml"],
        &["--method", "pm"],
    );
    let (frame, still, ..) = &pairs[0];
    let diff = mean_diff(frame, still);
    eprintln!("[colour] pm frame 2 vs still: {}", percents(diff));
    // With a frame's irradiance gathered anew wherever the light changed, the frame is the still
    // (the photons and the records' places are the same): 0.00 % at seeds 0–9, and on SSE4.2's and
    // AVX-512's ray kernels. The stale records left red 15 % low and blue 46 % high; hits measured by
    // Embree's AVX2 kernels (before they were measured from the triangle's corners) +1.30 %.
    assert!(
        diff.abs().max_element() <= 0.001,
        "frame 2's means differ from its still's by {}",
        percents(diff)
    );
}

/// A point light dimmed by 15 % from frame 0 to frame 4: each of `pm`'s frames 1–4 has each
/// channel's image mean within 0.1 % of the still render of its intensity.
#[test]
fn a_dimming_light_matches_its_still_at_every_frame() {
    let at = |f: u32| -> [f32; 3] { [1.0 - 0.15 * f as f32 / 4.0; 3] };
    let keys = format!(
        "[[light.key]]\nframe = 0\nintensity = {}\n[[light.key]]\nframe = 4\nintensity = {}\n",
        v3(at(0)),
        v3(at(4))
    );
    let anim = point_light_room(5, at(0), &keys);
    let stills: Vec<(String, String)> = (1..=4)
        .map(|f| (format!("still-{f}.toml"), point_light_room(0, at(f), "")))
        .collect();
    let mut files: Vec<(&str, &str)> = vec![("scene.toml", &anim)];
    files.extend(stills.iter().map(|(n, t)| (n.as_str(), t.as_str())));
    let d = folder(&files);
    let names: Vec<&str> = stills.iter().map(|(n, _)| n.as_str()).collect();
    let pairs = frame_and_still(
        d.path(),
        "scene.toml",
        &[1, 2, 3, 4],
        &names,
        &["--method", "pm"],
    );
    let mut worst = (0, 0.0f32);
    for (f, (frame, still, ..)) in (1..=4).zip(&pairs) {
        let diff = mean_diff(frame, still);
        eprintln!("[dim] pm frame {f} vs still: {}", percents(diff));
        if diff.abs().max_element() > worst.1 {
            worst = (f, diff.abs().max_element());
        }
    }
    // Every frame is its still: 0.00 % at seeds 0–9, and on SSE4.2's and AVX-512's ray kernels.
    // Records that kept their value where the change looked like the gathers' noise left frames 1
    // and 3 1.6 % bright here (frame 4 of the probe's scene 1.9 %; here frames 2 and 4 gathered
    // anew, the change since the kept value having grown past the noise); hits measured by Embree's
    // AVX2 kernels (before they were measured from the triangle's corners) +1.30 %.
    assert!(
        worst.1 <= 0.001,
        "frame {}'s mean differs from its still's by {:.2} %",
        worst.0,
        worst.1 * 100.0
    );
}

/// A small emissive panel, the only light, moving across the red-walled room (frames 0–3): `pm`'s
/// frame 3 has each channel's image mean within 1.5 % of the still render of the panel's last
/// place.
#[test]
fn a_moving_emissive_mesh_matches_its_still() {
    // From near the red wall, high, to the other side: the light the red wall bounced goes with it.
    let (from, to) = ([-1.4, 3.0, 0.0], [1.2, 2.4, -0.6]);
    let keys = format!(
        "[[mesh.key]]\nframe = 0\ntranslate = {}\n[[mesh.key]]\nframe = 3\ntranslate = {}\n",
        v3(from),
        v3(to)
    );
    let d = folder(&[
        ("scene.toml", &panel_room(4, from, &keys)),
        ("still.toml", &panel_room(0, to, "")),
    ]);
    let pairs = frame_and_still(
        d.path(),
        "scene.toml",
        &[3],
        &["still.toml"],
        &["--method", "pm"],
    );
    let (frame, still, frame_path, still_path) = &pairs[0];
    let diff = mean_diff(frame, still);
    let indirect = |path: &str| {
        mean(&pmrender::io::output::read_layer(Path::new(path), Some("indirect")).unwrap())
    };
    let di = (indirect(frame_path) - indirect(still_path)) / indirect(still_path);
    eprintln!(
        "[area light] pm frame 3 vs still: {} (indirect: {})",
        percents(diff),
        percents(di)
    );
    // Stills of other seeds lie within 0.4 %; records the moving light was not counted as reaching
    // kept its earlier light (green and blue 15 % low, their indirect 34 % low). Frame 3 against
    // its still at seeds 3, 1, 2 (SSE4.2's kernels: seed 3's figures): worst channel −0.42, −0.04,
    // −0.37 %; the bound 3.6× the worst and 10× under the defect.
    assert!(
        diff.abs().max_element() <= 0.015,
        "frame 3's means differ from its still's by {}",
        percents(diff)
    );
}

// ---------------------------------------------------------------------------------------------------
// The camera's medium.

/// The eye walking from outside a fog box (z = 3.9) into it (z = 0.5) over frames 0–2: `path`'s
/// frame 2 is the still render of that camera, byte for byte or with channel means within 0.5 %.
#[test]
fn a_camera_walking_into_fog_matches_its_still() {
    let (outside, inside) = ([0.0, 1.0, 3.9], [0.0, 1.0, 0.5]);
    let keys = format!(
        "[[camera.key]]\nframe = 0\neye = {}\n[[camera.key]]\nframe = 2\neye = {}\n",
        v3(outside),
        v3(inside)
    );
    let d = folder(&[
        ("scene.toml", &fog_room(3, outside, &keys)),
        ("still.toml", &fog_room(0, inside, "")),
    ]);
    let extra = ["--method", "path", "--spp", "16"];
    let pairs = frame_and_still(d.path(), "scene.toml", &[2], &["still.toml"], &extra);
    let (frame, still, frame_path, still_path) = &pairs[0];
    let same = bytes(frame_path) == bytes(still_path);
    let diff = mean_diff(frame, still);
    eprintln!(
        "[fog camera] path frame 2 vs still: {}{}",
        if same { "byte-identical, " } else { "" },
        percents(diff)
    );
    // Rendered alone (--frames 2) the frame is the still byte for byte; with the medium of frame
    // 0's eye (none) the fog between the eye and the walls was missing: 17 % dark. In the sequence
    // too it is byte-identical at seeds 3, 1, 2 and on SSE4.2's kernels; the 0.5 % is for a machine
    // whose frame differs in a last bit.
    assert!(
        same || diff.abs().max_element() <= 0.005,
        "frame 2's means differ from its still's by {}",
        percents(diff)
    );
}

/// A camera that declares `medium = "fog"` with its eye keyed out of the fog box (inside at frame
/// 0, outside from frame 1): refused before the first frame, exit 2, one line naming `scene.toml`
/// and a line of the camera's table or its keys, nothing written.
#[test]
fn a_camera_keyed_out_of_its_declared_medium_is_refused() {
    let (inside, outside) = ([0.0, 1.0, 0.5], [0.0, 1.0, 3.9]);
    let camera = format!(
        "medium = \"fog\"\n[[camera.key]]\nframe = 0\neye = {}\n\
         [[camera.key]]\nframe = 2\neye = {}\n",
        v3(inside),
        v3(outside)
    );
    let text = fog_room(3, inside, &camera);
    let d = folder(&[("scene.toml", &text)]);
    let stderr = refused(
        d.path(),
        &[
            "-o",
            &out(d.path(), "f-####.exr"),
            "--method",
            "path",
            "--spp",
            "16",
        ],
    );
    // The camera's lines: from `[camera]` to the last line of its last key.
    let first = table_lines(&text, "[camera]", 0);
    let last = table_lines(&text, "[[camera.key]]", 1);
    eprintln!("[camera medium] {}", stderr.trim());
    let line = line_named(&stderr);
    assert!(
        line.is_some_and(|l| (*first.start()..=*last.end()).contains(&l)),
        "no line of the camera (lines {}–{}) named: {stderr}",
        first.start(),
        last.end()
    );
}

// ---------------------------------------------------------------------------------------------------
// Checks every frame needs, made before the first one.

/// The only light keyed to intensity [0, 0, 0] at frame 2 (of 0–3): refused before the first
/// frame, exit 2, one line naming `scene.toml` at a line of that key, nothing written (no frame, no
/// statistics, no sequence summary).
#[test]
fn a_light_keyed_to_zero_is_refused_before_any_frame() {
    let keys = format!(
        "[[light.key]]\nframe = 0\nintensity = {}\n[[light.key]]\nframe = 2\nintensity = {}\n",
        v3([2.0, 2.0, 2.0]),
        v3([0.0, 0.0, 0.0])
    );
    let text = point_light_room(4, [2.0, 2.0, 2.0], &keys);
    let d = folder(&[("scene.toml", &text)]);
    let stderr = refused(
        d.path(),
        &[
            "-o",
            &out(d.path(), "f-####.exr"),
            "--stats",
            &out(d.path(), "f-####.json"),
        ],
    );
    // The key's table: `[[light.key]]`, `frame = 2`, `intensity = [0.0, 0.0, 0.0]`.
    let key = table_lines(&text, "[[light.key]]", 1);
    eprintln!("[zero light] {}", stderr.trim());
    let line = line_named(&stderr);
    assert!(
        line.is_some_and(|l| key.contains(&l)),
        "the zero key (lines {}–{}) not named: {stderr}",
        key.start(),
        key.end()
    );
}

/// A value the keys interpolate into a bad one (here a camera field of view keyed to 180° at frame 2,
/// and `up` keyed parallel to the view at frame 1) is refused naming the key that set it, not the
/// base value or the `[camera]` table.
#[test]
fn a_bad_interpolated_value_is_refused_at_its_key() {
    for (keys, what) in [
        ("[[camera.key]]\nframe = 0\nfov = 45.0\n[[camera.key]]\nframe = 2\nfov = 180.0\n", "fov"),
        (
            "[[camera.key]]\nframe = 0\nup = [0.0, 1.0, 0.0]\n[[camera.key]]\nframe = 1\nup = [0.0, 0.0, -1.0]\n",
            "up",
        ),
    ] {
        let text = point_light_room(3, [2.0, 2.0, 2.0], "").replacen(
            "[[mesh]]",
            &format!("{keys}[[mesh]]"),
            1,
        );
        let d = folder(&[("scene.toml", &text)]);
        let stderr = refused(d.path(), &["-o", &out(d.path(), "f-####.exr")]);
        let key = table_lines(&text, "[[camera.key]]", 1);
        let line = line_named(&stderr);
        assert!(
            line.is_some_and(|l| key.contains(&l)) && stderr.contains(&format!("camera.{what}")),
            "the {what} key (lines {}–{}) not named: {stderr}",
            key.start(),
            key.end()
        );
    }
}

// ---------------------------------------------------------------------------------------------------
// Output patterns whose frame number is in a directory.

/// A two-frame scene: the camera steps sideways from frame 0 to frame 1.
fn two_frames() -> String {
    let keys = "[[camera.key]]\nframe = 0\neye = [0.0, 1.0, 3.0]\n\
                [[camera.key]]\nframe = 1\neye = [0.3, 1.0, 3.0]\n";
    format!(
        "version = 1\n[animation]\nframes = 2\n[camera]\neye = [0.0, 1.0, 3.0]\n\
         target = [0.0, 1.0, 0.0]\nfov = 45.0\nwidth = 32\nheight = 24\n{keys}[[mesh]]\n\
         obj = \"room.obj\"\n[render]\nspp = 4\nseed = 3\n"
    )
}

/// `-o out/d-####/x.exr` and `--png out/d-####/x.png` with out/d-0000 and out/d-0001 made
/// beforehand: frames 0 and 1 written into them (the images `-o f-####.exr` gives), nothing else.
#[test]
fn a_frame_number_in_a_directory_name_renders_into_existing_directories() {
    let d = folder(&[("scene.toml", &two_frames())]);
    for f in ["d-0000", "d-0001"] {
        std::fs::create_dir(d.path().join("out").join(f)).unwrap();
    }
    let scene = p(d.path(), "scene.toml");
    let extra = ["--method", "path"];
    let (exr, png) = (out(d.path(), "d-####/x.exr"), out(d.path(), "d-####/x.png"));
    let mut args = vec![scene.as_str(), "-o", exr.as_str(), "--png", png.as_str()];
    args.extend_from_slice(&extra);
    render_ok(&args);
    assert_eq!(listing(&d.path().join("out")), ["d-0000", "d-0001"]);
    for f in ["d-0000", "d-0001"] {
        assert_eq!(
            listing(&d.path().join("out").join(f)),
            ["x.exr", "x.png"],
            "{f}"
        );
    }
    // Frame f in d-000f: the images of a flat pattern (which differ, the camera having moved).
    let flat = p(d.path(), "f-####.exr");
    let mut args = vec![scene.as_str(), "-o", flat.as_str()];
    args.extend_from_slice(&extra);
    render_ok(&args);
    for f in 0..2 {
        assert!(
            bytes(&out(d.path(), &format!("d-{f:04}/x.exr")))
                == bytes(&p(d.path(), &format!("f-{f:04}.exr"))),
            "d-{f:04}/x.exr is not frame {f}"
        );
    }
    assert!(bytes(&p(d.path(), "f-0000.exr")) != bytes(&p(d.path(), "f-0001.exr")));
}

/// `-o out/d-####/x.exr` with out/d-0000 made and out/d-0001 missing: refused before the first
/// frame, exit 2, one line naming the option `-o` and the missing directory `d-0001`, nothing
/// written.
#[test]
fn a_missing_frame_directory_is_refused_before_any_frame() {
    let d = folder(&[("scene.toml", &two_frames())]);
    let kept = d.path().join("out").join("d-0000");
    std::fs::create_dir(&kept).unwrap();
    let scene = p(d.path(), "scene.toml");
    let r = render(&[
        &scene,
        "-o",
        &out(d.path(), "d-####/x.exr"),
        "--method",
        "path",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    eprintln!("[missing directory] {}", stderr.trim());
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert_eq!(listing(&d.path().join("out")), ["d-0000"]);
    assert!(listing(&kept).is_empty(), "wrote {:?}", listing(&kept));
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    // The frame whose directory is missing, not the pattern's literal `d-####`.
    assert!(
        stderr.contains("-o") && stderr.contains("d-0001"),
        "'-o' and 'd-0001' not in: {stderr}"
    );
}
