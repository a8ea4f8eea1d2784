//! Helpers shared by the whole-render tests: temporary scenes, running the binary, reading EXRs.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use glam::Vec3;
use pmrender::io::output::{read_layer, Image};

pub fn bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_pmrender"))
}

pub fn run(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .output()
        .expect("pmrender runs")
}

/// Runs the binary, killing it after `limit` (a hang is a failure, not a stuck test run).
pub fn run_bounded(args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(bin())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("pmrender runs");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("pmrender {args:?} still running after {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A box-room OBJ/MTL pair: walls of albedo `kd` facing inward, a ceiling light quad of radiance `ke`.
pub const ROOM_OBJ: &str = "mtllib room.mtl
v -1 0 1
v 1 0 1
v 1 0 -1
v -1 0 -1
v -1 2 1
v 1 2 1
v 1 2 -1
v -1 2 -1
v -0.25 1.99 -0.25
v 0.25 1.99 -0.25
v 0.25 1.99 0.25
v -0.25 1.99 0.25
usemtl wall
f 1 2 3 4
f 8 7 6 5
f 4 3 7 8
f 1 4 8 5
f 3 2 6 7
usemtl light
f 9 10 11 12
";

pub const ROOM_MTL: &str = "newmtl wall
Kd 0.6 0.6 0.6
newmtl light
Kd 0 0 0
Ke 10 10 10
";

/// A closed cube −1…1 with its faces outward, of material `material` from `mtllib`: placed by a scene's
/// scale, rotate and translate.
pub fn cube_obj(mtllib: &str, material: &str) -> String {
    format!(
        "mtllib {mtllib}\nusemtl {material}\n\
         v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
         f 1 4 3 2\nf 5 6 7 8\nf 1 5 8 4\nf 2 3 7 6\nf 1 2 6 5\nf 4 8 7 3\n"
    )
}

pub const ROOM_TOML: &str = r#"version = 1
[camera]
eye = [0.0, 1.0, 3.0]
target = [0.0, 1.0, 0.0]
fov = 45.0
width = 24
height = 16

[[mesh]]
obj = "room.obj"

[render]
spp = 2
"#;

/// Writes `files` (name, contents) into a fresh temporary directory.
pub fn scene_dir(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).expect("write scene file");
    }
    dir
}

pub fn room() -> tempfile::TempDir {
    scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", ROOM_TOML),
    ])
}

pub fn p(dir: &Path, name: &str) -> String {
    dir.join(name).to_string_lossy().into_owned()
}

pub fn read(path: &Path) -> Image {
    read_layer(path, None).expect("readable EXR")
}

pub fn mean(img: &Image) -> Vec3 {
    img.pixels.iter().copied().sum::<Vec3>() / img.pixels.len() as f32
}

/// relMSE = mean over pixels and channels of (x − r)² / (r² + 0.01) (the renderer's own definition).
pub fn rel_mse(img: &Image, reference: &Image) -> f64 {
    assert_eq!((img.width, img.height), (reference.width, reference.height));
    pmrender::converge::rel_mse(img, reference)
}

/// Means over `b`×`b` blocks: bias shows through, per-pixel noise averages out.
pub fn block_means(img: &Image, b: u32) -> Image {
    let (w, h) = (img.width / b, img.height / b);
    let mut out = Image {
        width: w,
        height: h,
        pixels: vec![Vec3::ZERO; (w * h) as usize],
    };
    for y in 0..h * b {
        for x in 0..w * b {
            out.pixels[((y / b) * w + x / b) as usize] +=
                img.pixels[(y * img.width + x) as usize] / (b * b) as f32;
        }
    }
    out
}

/// Renders the shipped caustic scene at the reference's 160×128 and returns (image, stats JSON).
pub fn render_cornell(
    method: &str,
    spp: u32,
    dir: &Path,
    extra: &[&str],
) -> (Image, serde_json::Value) {
    let scene = repo().join("scenes/cornell-caustics.toml");
    let out = dir.join(format!("{method}-{spp}.exr"));
    let stats = dir.join(format!("{method}-{spp}.json"));
    let spp_s = spp.to_string();
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--method",
        method,
        "--spp",
        &spp_s,
        "--width",
        "160",
        "--height",
        "128",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let json = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    (read(&out), json)
}

pub fn cornell_reference() -> Image {
    read(&repo().join("tests/reference/cornell-caustics-path.exr"))
}

/// A closed latitude–longitude sphere of radius 1 with faces wound to face inward.
pub fn inward_sphere(nu: usize, nv: usize) -> String {
    let mut s = String::from("mtllib furnace.mtl\nusemtl inside\n");
    for j in 0..=nv {
        let th = std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let ph = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
            s += &format!(
                "v {} {} {}\n",
                th.sin() * ph.cos(),
                th.cos(),
                th.sin() * ph.sin()
            );
        }
    }
    let idx = |i: usize, j: usize| j * nu + (i % nu) + 1;
    for j in 0..nv {
        for i in 0..nu {
            // (a, b, d) winds outward here; (a, d, b) faces the inside.
            let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
            s += &format!("f {a} {d} {b}\nf {b} {d} {c}\n");
        }
    }
    s
}

/// The file names in a folder, sorted.
pub fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A file's bytes (panics naming it when it cannot be read).
pub fn bytes(path: &str) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Waits (at most 20 s) until the process catches SIGINT (bit 1 of SigCgt in /proc/PID/status).
pub fn wait_for_handler(pid: u32) {
    let t = Instant::now();
    while t.elapsed() < Duration::from_secs(20) {
        let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
        let caught = status
            .lines()
            .find_map(|l| l.strip_prefix("SigCgt:"))
            .and_then(|m| u64::from_str_radix(m.trim(), 16).ok());
        match caught {
            Some(mask) if mask & (1 << 1) != 0 => return,
            None if !status.is_empty() => return,
            _ => std::thread::sleep(Duration::from_millis(10)),
        }
    }
}

/// The binary run with `args`, stderr piped, once it catches SIGINT.
pub fn spawn_interruptible(args: &[&str]) -> std::process::Child {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(bin());
    // SAFETY: the closure runs in the forked child before `exec` and only calls `signal`, which is
    // async-signal-safe. (The child starts with SIGINT's default disposition even when this test run
    // ignores SIGINT, as a background job does; see bad_input.rs.)
    unsafe {
        cmd.pre_exec(|| {
            if libc::signal(libc::SIGINT, libc::SIG_DFL) == libc::SIG_ERR {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let child = cmd
        .args(args)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    wait_for_handler(child.id());
    child
}
