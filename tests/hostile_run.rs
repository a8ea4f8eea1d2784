//! Hostile runs: resource requests that cannot fit, outputs that collide with each
//! other or with inputs, late write failures, exceptions in the image library, and SIGINT/SIGTERM in
//! every long phase. Each case: the exit status, one line naming the option, no file created, inputs
//! unchanged, bounded time.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs the binary with extra environment variables.
fn run_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(bin());
    cmd.args(args).env_remove("PMRENDER_MAX_MEMORY");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("pmrender runs")
}

/// A room with an empty `out/` directory for the outputs.
fn room_with_out(toml: &str) -> (tempfile::TempDir, PathBuf) {
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", toml),
    ]);
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    (d, out)
}

/// Contents of every file directly in `dir` (inputs, to check they are unchanged).
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    listing(dir)
        .into_iter()
        .filter(|n| dir.join(n).is_file())
        .map(|n| (n.clone(), std::fs::read(dir.join(&n)).unwrap()))
        .collect()
}

/// Status `code`, one line on stderr containing every `expect`.
fn assert_fails(r: &Output, code: i32, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(code), "stderr: {stderr}");
    assert_eq!(
        stderr.trim().lines().count(),
        1,
        "one line expected: {stderr}"
    );
    for e in expect {
        assert!(stderr.contains(e), "'{e}' not in: {stderr}");
    }
}

#[test]
fn requests_that_cannot_fit_are_refused_before_allocating() {
    let big_toml = ROOM_TOML
        .replace("width = 24", "width = 65536")
        .replace("height = 16", "height = 65536");
    let photons_toml =
        ROOM_TOML.replace("spp = 2", "spp = 2\n[render.photons]\nglobal = 100000000");
    for (toml, extra, expect) in [
        (
            ROOM_TOML.to_string(),
            vec![
                "--width", "65536", "--height", "65536", "--crop", "0", "0", "1", "1", "--method",
                "path",
            ],
            vec!["image 65536×65536", "budget of 16.0 GiB"],
        ),
        (
            big_toml,
            vec!["--method", "pm"],
            vec!["irradiance cache fill", "budget"],
        ),
        (
            photons_toml,
            vec![],
            vec!["photon maps: 22.4 GiB", "budget of 16.0 GiB"],
        ),
    ] {
        let (d, out) = room_with_out(&toml);
        let before = snapshot(d.path());
        let (scene, o) = (p(d.path(), "scene.toml"), p(&out, "o.exr"));
        let mut args = vec!["render", &scene, "-o", &o, "--quiet"];
        args.extend(extra);
        let t = Instant::now();
        let r = run_env(&args, &[("PMRENDER_MAX_MEMORY", "16G")]);
        assert!(
            t.elapsed() < Duration::from_secs(10),
            "refused at once, not after allocating"
        );
        assert_fails(&r, 2, &expect);
        assert!(listing(&out).is_empty());
        assert_eq!(snapshot(d.path()), before);
    }
}

#[test]
fn the_memory_budget_can_be_set_and_is_named() {
    let (d, out) = room_with_out(ROOM_TOML);
    let (scene, o) = (p(d.path(), "scene.toml"), p(&out, "o.exr"));
    let r = run_env(
        &["render", &scene, "-o", &o, "--quiet", "--max-memory", "1M"],
        &[],
    );
    assert_fails(&r, 2, &["memory", "budget of 1 MiB", "--max-memory"]);
    let r = run_env(
        &["render", &scene, "-o", &o, "--quiet"],
        &[("PMRENDER_MAX_MEMORY", "100k")],
    );
    assert_fails(&r, 2, &["budget of 100 KiB", "PMRENDER_MAX_MEMORY"]);
    for bad in ["lots", "-1G", "0", "5Q"] {
        let r = run_env(
            &["render", &scene, "-o", &o, "--quiet", "--max-memory", bad],
            &[],
        );
        assert_fails(&r, 2, &["--max-memory", bad]);
    }
    assert!(listing(&out).is_empty());
    let r = run_env(
        &[
            "render",
            &scene,
            "-o",
            &o,
            "--quiet",
            "--max-memory",
            "2G",
            "--method",
            "path",
        ],
        &[],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

#[test]
fn command_line_limits_match_the_scene_file_and_name_the_option() {
    let (d, out) = room_with_out(ROOM_TOML);
    let (scene, o) = (p(d.path(), "scene.toml"), p(&out, "o.exr"));
    for (opt, value, expect) in [
        ("--width", "65537", "1..=65536"),
        ("--width", "1048576", "1..=65536"),
        ("--height", "70000", "1..=65536"),
        ("--spp", "2000000", "1..=1048576"),
        ("--spp", "0", "1..=1048576"),
    ] {
        let r = run(&["render", &scene, "-o", &o, "--quiet", opt, value]);
        assert_fails(&r, 2, &[opt, value, expect]);
    }
    let r = run(&["render", &scene, "--quiet"]);
    assert_fails(&r, 2, &["--output"]);
    assert!(listing(&out).is_empty());
}

#[test]
fn outputs_colliding_with_each_other_or_with_inputs_are_refused() {
    let (d, out) = room_with_out(ROOM_TOML);
    let dir = d.path();
    let photon_file = p(dir, "maps.bin");
    assert!(run(&[
        "render",
        &p(dir, "scene.toml"),
        "-o",
        &p(dir, "first.exr"),
        "--save-photons",
        &photon_file,
        "--quiet"
    ])
    .status
    .success());
    std::fs::remove_file(dir.join("first.exr")).unwrap();
    let before = snapshot(dir);
    let scene = p(dir, "scene.toml");
    let o = p(&out, "o.exr");
    let same = format!("{}/../out/o.exr", out.display());
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec!["--stats".into(), o.clone()], "--stats"),
        (vec!["--save-cache".into(), same.clone()], "--save-cache"),
        (
            vec![
                "--png".into(),
                p(&out, "a.png"),
                "--cache-image".into(),
                p(&out, "a.png"),
            ],
            "--cache-image",
        ),
        (vec!["--save-photons".into(), scene.clone()], "scene file"),
        (
            vec!["--dump-photons".into(), p(dir, "room.obj")],
            "OBJ file",
        ),
        (vec!["--stats".into(), p(dir, "room.mtl")], "MTL file"),
        (
            vec![
                "--load-photons".into(),
                photon_file.clone(),
                "--save-photons".into(),
                photon_file.clone(),
            ],
            "photon file",
        ),
        (
            vec![
                "--load-photons".into(),
                photon_file.clone(),
                "--dump-photons".into(),
                format!("{}/./maps.bin", dir.display()),
            ],
            "photon file",
        ),
    ];
    for (extra, expect) in cases {
        let mut args: Vec<&str> = vec!["render", &scene, "-o", &o, "--quiet", "--method", "pm"];
        args.extend(extra.iter().map(String::as_str));
        let r = run(&args);
        assert_fails(&r, 2, &[expect]);
        assert!(listing(&out).is_empty(), "{extra:?}");
        assert_eq!(snapshot(dir), before, "inputs unchanged: {extra:?}");
    }
    // A hard link to the scene is the scene.
    std::fs::hard_link(dir.join("scene.toml"), out.join("link.json")).unwrap();
    let r = run(&[
        "render",
        &scene,
        "-o",
        &o,
        "--quiet",
        "--stats",
        &p(&out, "link.json"),
    ]);
    assert_fails(&r, 2, &["--stats", "scene file"]);
}

#[test]
fn output_paths_that_name_no_writable_file_are_refused() {
    let (d, out) = room_with_out(ROOM_TOML);
    let scene = p(d.path(), "scene.toml");
    let o = p(&out, "o.exr");
    std::fs::write(d.path().join("plain"), b"x").unwrap();
    let (dir_out, under_file, jpg) = (
        p(d.path(), "out"),
        p(d.path(), "plain/c.bin"),
        p(&out, "c.jpg"),
    );
    let cases = [
        (vec!["-o", "x.exr/"], "-o", "does not name a file"),
        (
            vec!["-o", &o, "--stats", "/tmp/"],
            "--stats",
            "does not name a file",
        ),
        (
            vec!["-o", &o, "--stats", &dir_out],
            "--stats",
            "is a directory",
        ),
        (
            vec!["-o", &o, "--png", "/nonexistent-dir/a.png"],
            "--png",
            "does not exist",
        ),
        (
            vec!["-o", &o, "--save-cache", &under_file],
            "--save-cache",
            "does not exist",
        ),
        (
            vec!["-o", &o, "--dump-photons", "/dev/null"],
            "--dump-photons",
            "not a regular file",
        ),
        (
            vec!["-o", &o, "--cache-image", &jpg],
            "--cache-image",
            ".png",
        ),
    ];
    for (args, opt, expect) in cases {
        let mut all = vec!["render", &scene, "--quiet"];
        all.extend(args);
        let r = run(&all);
        assert_fails(&r, 2, &[opt, expect]);
        assert!(listing(&out).is_empty());
    }
}

#[test]
fn a_long_legal_output_name_works() {
    let (d, out) = room_with_out(ROOM_TOML);
    let exr = out.join(format!("{}.exr", "e".repeat(240)));
    let png = out.join(format!("{}.png", "p".repeat(251)));
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        exr.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(listing(&out).len(), 2, "both outputs, no temporary file");
}

#[test]
fn a_late_write_failure_leaves_no_output() {
    // The photon file (MBs) goes over a 32 KiB file-size limit after the EXR, PNG and stats are written.
    let (d, out) = room_with_out(ROOM_TOML);
    let cmd = format!(
        "trap '' XFSZ; ulimit -f 64; exec '{}' render '{}' -o '{}' --png '{}' --stats '{}' --save-photons '{}' --width 32 --height 32 --quiet",
        bin().display(), p(d.path(), "scene.toml"), p(&out, "o.exr"), p(&out, "o.png"), p(&out, "s.json"), p(&out, "maps.bin")
    );
    let r = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert_fails(&r, 1, &["maps.bin"]);
    assert!(
        listing(&out).is_empty(),
        "no output and no temporary file: {:?}",
        listing(&out)
    );
    // The same render without the limit writes all four.
    let r = Command::new("sh")
        .args(["-c", &cmd.replace("ulimit -f 64;", "")])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(listing(&out).len(), 4);
}

#[test]
fn an_exception_in_the_image_library_is_an_error() {
    // A PNG whose header promises 23170×23170 RGBA (8.6 GB as floats) under a 4 GB address-space
    // limit: the shim's allocation throws bad_alloc, which must not cross into Rust (abort).
    let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd huge.png");
    let (d, out) = room_with_out(ROOM_TOML);
    std::fs::write(d.path().join("room.mtl"), mtl).unwrap();
    std::fs::write(d.path().join("huge.png"), huge_png_header(23170, 23170)).unwrap();
    let cmd = format!(
        "ulimit -v 4000000; exec '{}' render '{}' -o '{}' --quiet",
        bin().display(),
        p(d.path(), "scene.toml"),
        p(&out, "o.exr")
    );
    let r = Command::new("sh").args(["-c", &cmd]).output().unwrap();
    assert_fails(&r, 2, &["huge.png"]);
    assert!(listing(&out).is_empty());
}

fn huge_png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut v = (data.len() as u32).to_be_bytes().to_vec();
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        v.extend(&body);
        v.extend(crc(&body).to_be_bytes());
        v
    };
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(chunk(b"IEND", &[]));
    png
}

/// Starts a render, sends `signal` after `delay`, and returns (exit code, seconds from signal to exit,
/// stderr); the seconds are −1 when the process had already ended.
fn interrupt(args: &[&str], signal: &str, delay: Duration) -> (Option<i32>, f64, String) {
    let mut child = Command::new(bin())
        .args(args)
        .env("PMRENDER_MAX_MEMORY", "16G")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_handler(child.id());
    std::thread::sleep(delay);
    if child.try_wait().unwrap().is_some() {
        let out = child.wait_with_output().unwrap();
        return (
            out.status.code(),
            -1.0,
            String::from_utf8_lossy(&out.stderr).into_owned(),
        );
    }
    let t = Instant::now();
    let _ = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code(),
        t.elapsed().as_secs_f64(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Waits (at most 20 s: a loaded machine may take long to start a process) until the process catches
/// SIGINT (bit 1) and SIGTERM (bit 14) in /proc/PID/status, so the signal tests time the renderer, not
/// its start.
fn wait_for_handler(pid: u32) {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) {
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
        let caught = status
            .lines()
            .find_map(|l| l.strip_prefix("SigCgt:"))
            .and_then(|m| u64::from_str_radix(m.trim(), 16).ok());
        match caught {
            Some(mask) if mask & (1 << 1) != 0 && mask & (1 << 14) != 0 => return,
            None if !status.is_empty() => return, // no SigCgt line: nothing to wait for
            _ => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

#[test]
fn sigint_and_sigterm_stop_every_phase_and_leave_nothing() {
    let photons = ROOM_TOML.replace("spp = 2", "spp = 2\n[render.photons]\nglobal = 20000000");
    let fill = ROOM_TOML.replace(
        "spp = 2",
        "spp = 2\n[render.photons]\nglobal = 5000\n[render.icache]\nrays = 65536",
    );
    let phases: [(&str, &str, &[&str]); 4] = [
        ("photon pass", &photons, &["--method", "pm"]),
        (
            "cache fill",
            &fill,
            &["--method", "pm", "--width", "96", "--height", "64"],
        ),
        ("final gather per sample", &fill, &["--method", "pm-fg"]),
        (
            "shading, one tile at 100000 spp",
            ROOM_TOML,
            &[
                "--method", "path", "--spp", "100000", "--width", "16", "--height", "16",
            ],
        ),
    ];
    for (phase, toml, extra) in phases {
        for (signal, code) in [("INT", 130), ("TERM", 143)] {
            let (d, out) = room_with_out(toml);
            let before = snapshot(d.path());
            let o = |n: &str| p(&out, n);
            let (scene, exr, png, stats, maps, ply, cache) = (
                p(d.path(), "scene.toml"),
                o("o.exr"),
                o("o.png"),
                o("s.json"),
                o("m.bin"),
                o("m.ply"),
                o("c.bin"),
            );
            let mut args = vec![
                "render",
                &scene,
                "-o",
                &exr,
                "--png",
                &png,
                "--stats",
                &stats,
                "--save-cache",
                &cache,
                "--quiet",
            ];
            // `path` traces no photon maps: saving them is refused.
            if !extra.contains(&"path") {
                args.extend(["--save-photons", &maps, "--dump-photons", &ply]);
            }
            args.extend(extra);
            let (status, seconds, stderr) = interrupt(&args, signal, Duration::from_millis(700));
            assert_eq!(status, Some(code), "{phase}, SIG{signal}: {stderr}");
            assert!(seconds >= 0.0, "{phase}: ended before the signal");
            assert!(
                seconds < 3.0,
                "{phase}, SIG{signal}: stopped after {seconds:.2} s"
            );
            assert!(stderr.contains("interrupted"), "{stderr}");
            // The phase itself saw the flag: the watchdog, the backstop for waits that cannot poll, was not needed.
            assert!(
                !stderr.contains("watchdog"),
                "{phase}, SIG{signal}: {stderr}"
            );
            assert!(
                listing(&out).is_empty(),
                "{phase}, SIG{signal}: left {:?}",
                listing(&out)
            );
            assert_eq!(snapshot(d.path()), before);
        }
    }
}

#[test]
fn a_scene_read_blocked_on_a_fifo_is_interrupted() {
    let (d, out) = room_with_out(ROOM_TOML);
    let fifo = d.path().join("fifo.toml");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let args = [
            "render",
            fifo.to_str().unwrap(),
            "-o",
            &p(&out, "o.exr"),
            "--quiet",
        ];
        let (status, seconds, stderr) = interrupt(&args, signal, Duration::from_millis(500));
        if seconds < 0.0 {
            // Refused before waiting (only regular files are inputs): fine, as long as it is a clean refusal.
            assert_eq!(status, Some(2), "{stderr}");
            continue;
        }
        assert_eq!(status, Some(code), "{stderr}");
        assert!(seconds < 3.0, "stopped after {seconds:.2} s");
        assert!(listing(&out).is_empty());
    }
}

/// Photon-map files that would do nothing — saved or dumped maps that are loaded, not traced, or any of
/// them under `path`, which traces none — are refused instead of left unwritten without a word.
#[test]
fn photon_files_that_would_do_nothing_are_refused() {
    let (d, out) = room_with_out(ROOM_TOML);
    let (scene, o) = (p(d.path(), "scene.toml"), p(&out, "o.exr"));
    let maps = p(d.path(), "maps.phot");
    let r = run(&[
        "render",
        &scene,
        "-o",
        &o,
        "--quiet",
        "--save-photons",
        &maps,
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    std::fs::remove_file(&o).unwrap();
    let (saved, dumped) = (p(&out, "again.phot"), p(&out, "maps.ply"));
    for (extra, expect) in [
        (
            vec!["--method", "path", "--save-photons", &saved],
            "--save-photons",
        ),
        (
            vec!["--method", "path", "--dump-photons", &dumped],
            "--dump-photons",
        ),
        (
            vec!["--method", "path", "--load-photons", &maps],
            "--load-photons",
        ),
        (
            vec!["--load-photons", &maps, "--save-photons", &saved],
            "--save-photons",
        ),
        (
            vec!["--load-photons", &maps, "--dump-photons", &dumped],
            "--dump-photons",
        ),
    ] {
        let mut args = vec!["render", &scene, "-o", &o, "--quiet"];
        args.extend(&extra);
        assert_fails(&run(&args), 2, &[expect]);
        assert!(listing(&out).is_empty(), "{extra:?}");
    }
}

/// Options that fail late or vaguely: an unparsable PMRENDER_MAX_MEMORY (ignored before), a thread
/// count the system cannot start ("os error 11", exit 1), a directory where a file is expected
/// ("not found"), an output name longer than the file system holds (it rendered fully, then failed at
/// the rename): each one line naming the option or variable, exit 2, nothing written.
#[test]
fn bad_options_name_themselves_before_rendering() {
    let (d, out) = room_with_out(ROOM_TOML);
    let (scene, o) = (p(d.path(), "scene.toml"), p(&out, "o.exr"));
    for value in ["lots", "-1G", "5Q"] {
        let r = run_env(
            &["render", &scene, "-o", &o, "--quiet"],
            &[("PMRENDER_MAX_MEMORY", value)],
        );
        assert_fails(&r, 2, &["PMRENDER_MAX_MEMORY", value]);
    }
    let r = run(&["render", &scene, "-o", &o, "--quiet", "--threads", "1024"]);
    assert_fails(&r, 2, &["--threads", "1024", "per core"]);
    std::fs::create_dir(d.path().join("maps.phot")).unwrap();
    let r = run(&[
        "render",
        &scene,
        "-o",
        &o,
        "--quiet",
        "--load-photons",
        &p(d.path(), "maps.phot"),
    ]);
    assert_fails(&r, 2, &["--load-photons", "is a directory"]);
    let r = run(&["render", &p(d.path(), "maps.phot"), "-o", &o, "--quiet"]);
    assert_fails(&r, 2, &["maps.phot", "is a directory"]);
    let long = p(&out, &format!("{}.exr", "n".repeat(252)));
    let r = run(&["render", &scene, "-o", &long, "--quiet"]);
    assert_fails(&r, 2, &["-o", "256 bytes"]);
    assert!(listing(&out).is_empty());
}

/// `converge` and `export-mitsuba` coerced values (`--photons 1.5` ran 2 photons, `--spp 0` wrote 1)
/// and left an empty `-o` folder or partial outputs behind on failure or signal: now refused, and
/// the folders they made are removed again.
#[test]
fn converge_and_export_refuse_coercions_and_leave_nothing() {
    let (d, out) = room_with_out(ROOM_TOML);
    let scene = p(d.path(), "scene.toml");
    let reference = p(d.path(), "ref.exr");
    let r = run(&[
        "render", &scene, "-o", &reference, "--quiet", "--method", "path",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let dir = out.join("made/here");
    let dir_s = dir.to_str().unwrap();
    for counts in ["1.5", "1e3,2.5e3,1e4.5"] {
        let r = run(&[
            "converge",
            &scene,
            "--photons",
            counts,
            "--reference",
            &reference,
            "-o",
            dir_s,
            "--quiet",
        ]);
        assert_fails(&r, 2, &["--photons"]);
    }
    let r = run(&["export-mitsuba", &scene, dir_s, "--spp", "0"]);
    assert_fails(&r, 2, &["--spp", "0"]);
    // A reference that is no HDR image fails after the -o folder would have been made.
    let r = run(&[
        "converge",
        &scene,
        "--photons",
        "1e3",
        "--reference",
        &scene,
        "-o",
        dir_s,
        "--quiet",
    ]);
    assert_eq!(
        r.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    assert!(listing(&out).is_empty(), "{:?}", listing(&out));
    // Interrupted while rendering: nothing, not even the folder.
    let photons = ["1e6", "3e6", "1e7", "3e7"].join(",");
    let (code, _, stderr) = interrupt(
        &[
            "converge",
            &scene,
            "--photons",
            &photons,
            "--reference",
            &reference,
            "-o",
            dir_s,
            "--quiet",
        ],
        "TERM",
        Duration::from_millis(1500),
    );
    assert_eq!(code, Some(143), "{stderr}");
    assert!(listing(&out).is_empty(), "{:?}", listing(&out));
}
