//! Every kind of bad input gives one line naming the file and line (or the option), exit status 2, and
//! no output file.

mod common;
use common::*;

use std::os::unix::process::CommandExt;

/// Runs a render that must fail; checks status 2, a one-line message containing `expect`, no output.
fn fails(dir: &tempfile::TempDir, scene: &str, extra: &[&str], expect: &[&str]) {
    let out = p(dir.path(), "out.exr");
    let png = p(dir.path(), "out.png");
    let mut args = vec!["render", scene, "-o", &out, "--png", &png, "--quiet"];
    args.extend_from_slice(extra);
    let r = run(&args);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "stderr: {stderr}");
    assert_eq!(
        stderr.trim().lines().count(),
        1,
        "one line expected: {stderr}"
    );
    for e in expect {
        assert!(stderr.contains(e), "'{e}' not in: {stderr}");
    }
    assert!(!std::path::Path::new(&out).exists(), "no output on failure");
    assert!(!std::path::Path::new(&png).exists(), "no output on failure");
}

fn with_toml(toml: &str) -> tempfile::TempDir {
    scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", toml),
    ])
}

#[test]
fn the_good_room_renders() {
    let d = room();
    let out = p(d.path(), "out.exr");
    let r = run(&["render", &p(d.path(), "scene.toml"), "-o", &out, "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(std::path::Path::new(&out).exists());
}

#[test]
fn malformed_toml_names_the_line() {
    let d = with_toml(&ROOM_TOML.replace("fov = 45.0", "fov = = 45"));
    fails(&d, &p(d.path(), "scene.toml"), &[], &["scene.toml:5:"]);
}

#[test]
fn unknown_key_is_an_error() {
    let d = with_toml(&ROOM_TOML.replace("fov = 45.0", "fov = 45.0\nfocal = 3"));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:6:", "focal"],
    );
}

#[test]
fn mistyped_value_is_an_error() {
    let d = with_toml(&ROOM_TOML.replace("width = 24", "width = \"wide\""));
    fails(&d, &p(d.path(), "scene.toml"), &[], &["scene.toml:6:"]);
}

#[test]
fn missing_obj() {
    let d = with_toml(&ROOM_TOML.replace("room.obj", "nothere.obj"));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:10:", "nothere.obj"],
    );
}

#[test]
fn missing_mtl() {
    let d = scene_dir(&[("room.obj", ROOM_OBJ), ("scene.toml", ROOM_TOML)]);
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["room.obj:1:", "room.mtl"],
    );
}

#[test]
fn missing_texture() {
    let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd bricks.png");
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", &mtl),
        ("scene.toml", ROOM_TOML),
    ]);
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["bricks.png", "not found"],
    );
}

#[test]
fn face_index_out_of_range() {
    let obj = ROOM_OBJ.replace("f 9 10 11 12", "f 9 10 11 13");
    let d = scene_dir(&[
        ("room.obj", &obj),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", ROOM_TOML),
    ]);
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["room.obj:21:", "out of range"],
    );
}

#[test]
fn nan_and_inf_coordinates() {
    for bad in ["nan", "inf", "-inf"] {
        let obj = ROOM_OBJ.replace("v 1 0 1", &format!("v 1 {bad} 1"));
        let d = scene_dir(&[
            ("room.obj", &obj),
            ("room.mtl", ROOM_MTL),
            ("scene.toml", ROOM_TOML),
        ]);
        fails(&d, &p(d.path(), "scene.toml"), &[], &["room.obj:3:"]);
    }
}

#[test]
fn no_lights() {
    let mtl = ROOM_MTL.replace("Ke 10 10 10", "");
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", &mtl),
        ("scene.toml", ROOM_TOML),
    ]);
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:1:", "no lights"],
    );
}

#[test]
fn zero_area_emitters_only() {
    let obj = ROOM_OBJ
        .replace("v 0.25 1.99 -0.25", "v -0.25 1.99 -0.25")
        .replace("v 0.25 1.99 0.25", "v -0.25 1.99 0.25");
    let d = scene_dir(&[
        ("room.obj", &obj),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", ROOM_TOML),
    ]);
    fails(&d, &p(d.path(), "scene.toml"), &[], &["zero area"]);
}

#[test]
fn resolution_must_be_positive() {
    for (from, to, line) in [
        ("width = 24", "width = 0", "scene.toml:6:"),
        ("height = 16", "height = -3", "scene.toml:7:"),
    ] {
        let d = with_toml(&ROOM_TOML.replace(from, to));
        fails(&d, &p(d.path(), "scene.toml"), &[], &[line]);
    }
    let d = room();
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--width", "0"],
        &["--width"],
    );
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--height", "-1"],
        &["--height"],
    );
}

#[test]
fn fov_must_be_in_open_interval() {
    for fov in ["0.0", "180.0", "-5.0", "400.0"] {
        let d = with_toml(&ROOM_TOML.replace("fov = 45.0", &format!("fov = {fov}")));
        fails(
            &d,
            &p(d.path(), "scene.toml"),
            &[],
            &["scene.toml:5:", "fov"],
        );
    }
}

#[test]
fn noise_target_must_be_in_range() {
    let d = room();
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--noise", "2"],
        &["--noise", "0..=1"],
    );
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--noise", "-0.1"],
        &["--noise"],
    );
    let d = with_toml(&ROOM_TOML.replace("spp = 2", "spp = 2\nnoise = -1.0"));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:14:", "noise"],
    );
}

#[test]
fn aa_spp_must_be_in_range() {
    let d = room();
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--aa-spp", "0"],
        &["--aa-spp", "1..="],
    );
    let d = with_toml(&ROOM_TOML.replace("spp = 2", "spp = 2\naa_spp = -3"));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:14:", "aa_spp"],
    );
}

#[test]
fn unknown_method() {
    let d = room();
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--method", "magic"],
        &["--method", "magic"],
    );
    let d = with_toml(&ROOM_TOML.replace("spp = 2", "spp = 2\nmethod = \"magic\""));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:14:", "magic"],
    );
}

#[test]
fn unwritable_output_path() {
    let d = room();
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        "/nonexistent-dir/x.exr",
        "--quiet",
    ]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("-o") && stderr.contains("nonexistent-dir"),
        "{stderr}"
    );
}

#[test]
fn missing_scene_file() {
    let d = room();
    fails(&d, &p(d.path(), "nope.toml"), &[], &["nope.toml"]);
}

#[test]
fn failed_render_leaves_existing_output_untouched() {
    let d = room();
    let out = d.path().join("out.exr");
    std::fs::write(&out, b"previous").unwrap();
    let bad = p(d.path(), "bad.toml");
    std::fs::write(&bad, "not toml [").unwrap();
    let r = run(&["render", &bad, "-o", &out.to_string_lossy(), "--quiet"]);
    assert_eq!(r.status.code(), Some(2));
    assert_eq!(std::fs::read(&out).unwrap(), b"previous");
}

#[test]
fn interrupted_render_leaves_no_output() {
    let scene = repo().join("scenes/cornell-caustics.toml");
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("big.exr");
    let mut cmd = std::process::Command::new(bin());
    // The child starts with SIGINT's default disposition whatever this test inherited: a test run
    // started in the background by a script ignores SIGINT, the child would inherit that, and the
    // renderer keeps an inherited SIG_IGN (as shells expect of background jobs).
    // SAFETY: the closure runs in the forked child before `exec` and only calls `signal`, which is
    // async-signal-safe.
    unsafe {
        cmd.pre_exec(|| {
            if libc::signal(libc::SIGINT, libc::SIG_DFL) == libc::SIG_ERR {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = cmd
        .args([
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--method",
            "path",
            "--spp",
            "4096",
            "--quiet",
        ])
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    // SIGINT, as Ctrl-C sends.
    let _ = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert_eq!(status.code(), Some(130));
    assert!(!out.exists());
    let leftovers: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn empty_scene() {
    let d = with_toml("version = 1\n[camera]\neye = [0.0, 1.0, 3.0]\ntarget = [0.0, 1.0, 0.0]\nfov = 45.0\nwidth = 8\nheight = 8\n");
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:1:", "no triangles"],
    );
}

#[test]
fn unknown_cache_fill_or_weighting() {
    let d = with_toml(&format!(
        "{ROOM_TOML}\n[render.icache]\naccuracy = 0.5\nfill = \"three-pass\"\n"
    ));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--method", "pm"],
        &["scene.toml:17:", "render.icache.fill", "three-pass"],
    );
    let d = with_toml(&format!(
        "{ROOM_TOML}\n[render.icache]\nweight = \"gauss\"\n"
    ));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--method", "pm"],
        &["scene.toml:16:", "render.icache.weight", "gauss"],
    );
}

#[test]
fn pass_a_stride_must_be_in_range() {
    for bad in ["0", "65", "-2"] {
        let d = with_toml(&format!(
            "{ROOM_TOML}\n[render.icache]\npass_a_stride = {bad}\n"
        ));
        fails(
            &d,
            &p(d.path(), "scene.toml"),
            &["--method", "pm"],
            &["scene.toml:16:", "render.icache.pass_a_stride", "1..=64"],
        );
    }
}

#[test]
fn cache_settings_are_checked_whatever_the_method() {
    // `[render.icache]` is checked when the scene is loaded: a bad value is an error under `--method path`
    // too, not ignored because that method has no cache.
    for extra in ["fill = \"three-pass\"", "weight = \"gauss\"", "rays = 2"] {
        let toml = format!("{ROOM_TOML}\n[render.icache]\n{extra}\n");
        let d = with_toml(&toml);
        let key = extra.split(' ').next().unwrap();
        let line = toml.lines().position(|l| l.starts_with(key)).unwrap() + 1;
        for method in ["path", "pm", "photons"] {
            fails(
                &d,
                &p(d.path(), "scene.toml"),
                &["--method", method],
                &[
                    &format!("scene.toml:{line}:"),
                    &format!("render.icache.{key}"),
                ],
            );
        }
    }
}

#[test]
fn photon_settings_are_checked_whatever_the_method() {
    // A photon count out of range is an error under `--method path` too, at its line.
    let toml = format!("{ROOM_TOML}\n[render.photons]\nglobal = 0\n");
    let d = with_toml(&toml);
    let line = toml.lines().position(|l| l.starts_with("global")).unwrap() + 1;
    for method in ["path", "pm"] {
        fails(
            &d,
            &p(d.path(), "scene.toml"),
            &["--method", method],
            &[&format!("scene.toml:{line}:"), "render.photons.global"],
        );
    }
}

#[test]
fn adaptive_caching_keys_checked() {
    // The Weber threshold must be a positive number, whatever the method; `adaptive` a boolean.
    let d = with_toml(&format!(
        "{ROOM_TOML}\n[render.icache]\nadaptive_threshold = -0.1\n"
    ));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--method", "path"],
        &["scene.toml:16:", "render.icache.adaptive_threshold", "-0.1"],
    );
    let d = with_toml(&format!(
        "{ROOM_TOML}\n[render.icache]\nadaptive = \"yes\"\n"
    ));
    fails(
        &d,
        &p(d.path(), "scene.toml"),
        &["--method", "pm"],
        &["scene.toml:16:", "expected a boolean"],
    );
}

#[test]
fn adaptive_caching_with_the_one_pass_fill_is_refused() {
    // Adaptive caching lives in the two-pass fill: with `fill = "one-pass"` it did nothing silently.
    for key in ["adaptive = true", "adaptive_threshold = 0.05"] {
        let toml = format!("{ROOM_TOML}\n[render.icache]\nfill = \"one-pass\"\n{key}\n");
        let d = with_toml(&toml);
        let name = key.split(' ').next().unwrap();
        let line = toml.lines().position(|l| l == key).unwrap() + 1;
        fails(
            &d,
            &p(d.path(), "scene.toml"),
            &["--method", "pm"],
            &[
                &format!("scene.toml:{line}:"),
                &format!("render.icache.{name}"),
                "one-pass",
            ],
        );
    }
    let d = with_toml(&format!(
        "{ROOM_TOML}\n[render.icache]\nfill = \"one-pass\"\nadaptive = false\n"
    ));
    let out = p(d.path(), "out.exr");
    let r = run(&["render", &p(d.path(), "scene.toml"), "-o", &out, "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}
