//! Every frame of a sequence checked as its still would be before the first is written: a keyed
//! scale that puts a vertex past the limits or leaves no triangle, an emitter scaled past the power
//! cap — refused at the key's file:line with the frame, exit 2, nothing written. And a sequence
//! reads its OBJ files and images once: one edited (or removed) while the sequence renders changes
//! no frame.

mod common;
use common::*;

use std::time::Duration;

const EMITTER_MTL: &str = "newmtl glow\nKd 0.5 0.5 0.5\nKe 1e6 1e6 1e6\n";

/// The room and a cube (emitting with `emits`) under a point light, 4 frames, the cube's `scale`
/// keyed from 0.25 at frame 0 to `scale` at frame 3, every mesh's with `all`.
fn scene(scale: &str, emits: bool, all: bool) -> tempfile::TempDir {
    let (cube, mtl) = if emits {
        (cube_obj("cube.mtl", "glow"), EMITTER_MTL.to_string())
    } else {
        (
            cube_obj("cube.mtl", "block"),
            "newmtl block\nKd 0.2 0.3 0.7\n".into(),
        )
    };
    let key = |s: &str| {
        format!("[[mesh.key]]\nframe = 0\nscale = 0.25\n[[mesh.key]]\nframe = 3\nscale = {s}\n")
    };
    let room_keys = if all {
        key(scale).replace("scale = 0.25", "scale = 1.0")
    } else {
        String::new()
    };
    let text = format!(
        "version = 1\n[animation]\nframes = 4\n[camera]\neye = [0.0, 1.0, 3.0]\ntarget = [0.0, 1.0, 0.0]\n\
         fov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\nobj = \"room.obj\"\n{room_keys}\n[[mesh]]\n\
         obj = \"cube.obj\"\nscale = 0.25\ntranslate = [0.0, 0.5, 0.0]\n{}\n[[light]]\ntype = \"point\"\n\
         position = [0.5, 1.5, 0.5]\nintensity = [1.0, 1.0, 1.0]\n[render]\nspp = 1\nseed = 1\n",
        key(scale)
    );
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("cube.obj", &cube),
        ("cube.mtl", &mtl),
        ("scene.toml", &text),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    d
}

/// Renders the scene of `d` to out/f-#.exr (with --stats and `extra`) and expects a refusal naming
/// `needles`, with no file written.
fn refused_with(d: &tempfile::TempDir, extra: &[&str], needles: &[&str]) {
    let scene = p(d.path(), "scene.toml");
    let (out, stats) = (
        p(&d.path().join("out"), "f-#.exr"),
        p(&d.path().join("out"), "f-#.json"),
    );
    let args = ["render", &scene, "-o", &out, "--stats", &stats, "--quiet"];
    let r = run_bounded(&[&args, extra].concat(), Duration::from_secs(120));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{n:?} not in {stderr}");
    }
    let written = listing(&d.path().join("out"));
    assert!(written.is_empty(), "{written:?}");
}

fn refused(d: &tempfile::TempDir, needles: &[&str]) {
    refused_with(d, &[], needles)
}

/// The room (its `scale` keyed by `room_keys`) under a sun whose `irradiance` is keyed by
/// `sun_keys`, 4 frames, and an out/ directory.
fn sun_scene(room_scale: &str, room_keys: &str, sun_keys: &str) -> tempfile::TempDir {
    let text = format!(
        "version = 1\n[animation]\nframes = 4\n[camera]\neye = [0.0, 1.0, 3.0]\n\
         target = [0.0, 1.0, 0.0]\nfov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\n\
         obj = \"room.obj\"\nscale = {room_scale}\n{room_keys}[[light]]\ntype = \"directional\"\n\
         direction = [0.3, -1.0, 0.2]\nirradiance = [1e20, 1e20, 1e20]\n{sun_keys}[render]\n\
         spp = 1\nseed = 1\n"
    );
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", &text),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    d
}

/// The last line (from 1) of `scene.toml` in `d` that starts with `start`.
fn last_line_starting(d: &tempfile::TempDir, start: &str) -> usize {
    let text = std::fs::read_to_string(d.path().join("scene.toml")).unwrap();
    let lines = text.lines().enumerate();
    1 + lines
        .filter(|(_, l)| l.starts_with(start))
        .last()
        .unwrap()
        .0
}

#[test]
fn a_sun_keyed_past_the_power_cap_is_refused_before_frame_0() {
    // A room 2e8 across: a sun of 1 W/m² over it is 1e17 W at frame 0, keyed to 1e20 W/m² at frame
    // 3 (3e36 W); frame 1, a third of the way, is past the cap. Named at the key it grows toward.
    let keys = "[[light.key]]\nframe = 0\nirradiance = [1.0, 1.0, 1.0]\n\
                [[light.key]]\nframe = 3\nirradiance = [1e20, 1e20, 1e20]\n";
    let d = sun_scene("1e8", "", keys);
    let line = last_line_starting(&d, "irradiance = [1e20");
    refused(
        &d,
        &[
            &format!("scene.toml:{line}: frame 1: light.irradiance: emitted power"),
            "exceeds the limit",
        ],
    );
}

#[test]
fn a_sun_over_bounds_scaled_past_the_power_cap_is_refused_before_frame_0() {
    // A sun of 1e20 W/m² over the room is 1e21 W; the room keyed to scale 1e8 at frame 3 grows
    // its disc: 1e36 W at frame 1.
    let keys = "[[mesh.key]]\nframe = 0\nscale = 1.0\n[[mesh.key]]\nframe = 3\nscale = 1e8\n";
    let d = sun_scene("1.0", keys, "");
    let line = last_line_starting(&d, "irradiance");
    refused(
        &d,
        &[
            &format!("scene.toml:{line}: frame 1: light.irradiance: emitted power"),
            "bounding sphere (radius",
        ],
    );
}

#[test]
fn a_later_frame_over_the_memory_budget_is_refused_before_frame_0() {
    // A mirror cube keyed from scale 1e-30 (its triangles of zero area: none) to 0.3 at frame 3:
    // from frame 1 on the scene has a mirror, so a caustic map and its atlas slots (about 100 MiB
    // more). A budget between frame 0's need and frame 1's refuses the sequence before frame 0.
    let d = scene("0.3", false, false);
    let mtl = "newmtl block\nKs 0.9 0.9 0.9\nillum 3\n";
    std::fs::write(d.path().join("cube.mtl"), mtl).unwrap();
    let text = std::fs::read_to_string(d.path().join("scene.toml")).unwrap();
    std::fs::write(
        d.path().join("scene.toml"),
        text.replace("scale = 0.25", "scale = 1e-30"),
    )
    .unwrap();
    // Frame 0's need and what the process holds, from its refusal under a budget of 1 KiB.
    let scene = p(d.path(), "scene.toml");
    let out = p(&d.path().join("out"), "f-#.exr");
    let r = run(&[
        "render",
        &scene,
        "-o",
        &out,
        "--quiet",
        "--frames",
        "0..0",
        "--max-memory",
        "1k",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    let mib = |after: &str| -> u64 {
        let rest =
            &stderr[stderr.find(after).unwrap_or_else(|| panic!("{stderr}")) + after.len()..];
        let n = rest.split(' ').next().unwrap();
        assert!(rest[n.len()..].starts_with(" MiB"), "{stderr}");
        n.parse().unwrap()
    };
    let frame_0 = mib("needs about ") + mib("with the ");
    let budget = format!("{}M", frame_0 + 50);
    refused_with(
        &d,
        &["--max-memory", &budget],
        &[
            "scene.toml: frame 1: memory:",
            "raise --max-memory",
            "--width",
        ],
    );
    // Frame 0 alone fits that budget.
    let r = run(&[
        "render",
        &scene,
        "-o",
        &out,
        "--quiet",
        "--frames",
        "0..0",
        "--max-memory",
        &budget,
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

#[test]
fn a_keyed_scale_past_the_vertex_limit_is_refused_before_frame_0() {
    let d = scene("1e16", false, false);
    refused(&d, &["scene.toml:", "frame 1", "after scale"]);
}

#[test]
fn a_keyed_scale_that_leaves_no_triangle_is_refused_before_frame_0() {
    let d = scene("1e-30", false, true);
    refused(&d, &["scene.toml:", "frame 3", "no triangles"]);
}

#[test]
fn an_emitter_scaled_past_the_power_cap_is_refused_before_frame_0() {
    let d = scene("1e14", true, false);
    refused(&d, &["cube.mtl:", "frame ", "emitted power"]);
}

#[test]
fn an_obj_edited_while_a_sequence_renders_changes_no_frame() {
    // The cube moves at every frame, so every frame builds its scene again; the OBJ is replaced by
    // an empty one after frame 0 is written. Read once, it changes nothing.
    let d = scene("0.4", false, false);
    let scene = p(d.path(), "scene.toml");
    let out = p(&d.path().join("out"), "f-#.exr");
    let child = std::process::Command::new(bin())
        .args([
            "render", &scene, "-o", &out, "--quiet", "--width", "64", "--height", "48",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let first = d.path().join("out/f-0.exr");
    let start = std::time::Instant::now();
    while !first.exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    std::fs::write(d.path().join("cube.obj"), "# emptied\n").unwrap();
    let r = child.wait_with_output().unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(d.path().join("out/f-3.exr").exists());
}

/// Renders `scene` to `out` (f-#.exr, 64×48) and calls `meanwhile` once frame 0 is written.
fn render_then(scene: &str, out: &str, meanwhile: impl FnOnce()) -> std::process::Output {
    let child = std::process::Command::new(bin())
        .args([
            "render", scene, "-o", out, "--quiet", "--width", "64", "--height", "48",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let first = std::path::Path::new(out).with_file_name("f-0.exr");
    let start = std::time::Instant::now();
    while !first.exists() && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(5));
    }
    meanwhile();
    child.wait_with_output().unwrap()
}

#[test]
fn images_edited_while_a_sequence_renders_change_no_frame() {
    // The cube, moving at every frame, is glossy with every kind of image a material names: a
    // texture, glossy maps, a cutout mask and a bump map. After frame 0 is written the first four
    // are rewritten (another colour, another gloss, a mask that cuts the cube away) and the bump
    // map is removed; every frame must equal the frame rendered with the files left alone.
    let d = scene("0.4", false, false);
    let grey = |v: u8| format!("P3\n1 1\n255\n{v} {v} {v}\n");
    let images = ["tex.ppm", "ks.ppm", "ns.ppm", "d.ppm", "bump.ppm"];
    for (name, v) in images.iter().zip([200, 180, 200, 255, 128]) {
        std::fs::write(d.path().join(name), grey(v)).unwrap();
    }
    let mtl = "newmtl block\nKd 0.5 0.5 0.5\nKs 0.3 0.3 0.3\nNs 40\nmap_Kd tex.ppm\n\
               map_Ks ks.ppm\nmap_Ns ns.ppm\nmap_d d.ppm\nbump bump.ppm\n";
    std::fs::write(d.path().join("cube.mtl"), mtl).unwrap();
    let mut text = std::fs::read_to_string(d.path().join("scene.toml")).unwrap();
    text.push_str("[render.photons]\nglobal = 20000\n");
    std::fs::write(d.path().join("scene.toml"), text).unwrap();
    let scene = p(d.path(), "scene.toml");
    let left_alone = render_then(&scene, &p(&d.path().join("out"), "f-#.exr"), || ());
    assert!(left_alone.status.success(), "{left_alone:?}");
    std::fs::create_dir(d.path().join("edited")).unwrap();
    let r = render_then(&scene, &p(&d.path().join("edited"), "f-#.exr"), || {
        for (name, v) in images[..4].iter().zip([20, 0, 1, 0]) {
            std::fs::write(d.path().join(name), grey(v)).unwrap();
        }
        std::fs::remove_file(d.path().join("bump.ppm")).unwrap();
    });
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    for f in 0..4 {
        let name = format!("f-{f}.exr");
        let (a, b) = (
            read(&d.path().join("out").join(&name)),
            read(&d.path().join("edited").join(&name)),
        );
        assert!(a.pixels == b.pixels, "frame {f} changed");
    }
    // The edited files do change a frame rendered from them.
    std::fs::write(d.path().join("bump.ppm"), grey(128)).unwrap();
    let again = d.path().join("again");
    std::fs::create_dir(&again).unwrap();
    let r = run(&[
        "render",
        &scene,
        "-o",
        &p(&again, "f-#.exr"),
        "--quiet",
        "--width",
        "64",
        "--height",
        "48",
        "--frames",
        "0..0",
    ]);
    assert!(r.status.success(), "{r:?}");
    let f0 = read(&d.path().join("out/f-0.exr"));
    assert!(read(&again.join("f-0.exr")).pixels != f0.pixels);
}
