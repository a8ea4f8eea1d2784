//! Same scene + same seed → byte-identical EXR, whatever the thread count.

mod common;
use common::*;

fn render_bytes(method: &str, threads: &str, dir: &std::path::Path) -> Vec<u8> {
    let scene = repo().join("scenes/cornell-caustics.toml");
    let out = dir.join(format!("{method}-{threads}.exr"));
    let r = run(&[
        "render", &scene.to_string_lossy(), "-o", &out.to_string_lossy(), "--method", method, "--threads", threads,
        "--width", "48", "--height", "48", "--spp", "4", "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    std::fs::read(out).expect("output written")
}

#[test]
fn path_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(render_bytes("path", "1", d.path()), render_bytes("path", "2", d.path()));
}

#[test]
fn pm_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(render_bytes("pm", "1", d.path()), render_bytes("pm", "2", d.path()));
}

#[test]
fn photons_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(render_bytes("photons", "1", d.path()), render_bytes("photons", "2", d.path()));
}
