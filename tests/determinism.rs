//! Same scene + same seed → byte-identical EXR, whatever the thread count.

mod common;
use common::*;

fn render_bytes(method: &str, threads: &str, dir: &std::path::Path) -> Vec<u8> {
    let scene = repo().join("scenes/cornell-caustics.toml");
    let out = dir.join(format!("{method}-{threads}.exr"));
    let r = run(&[
        "render",
        &scene.to_string_lossy(),
        "-o",
        &out.to_string_lossy(),
        "--method",
        method,
        "--threads",
        threads,
        "--width",
        "48",
        "--height",
        "48",
        "--spp",
        "4",
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    std::fs::read(out).expect("output written")
}

#[test]
fn path_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(
        render_bytes("path", "1", d.path()),
        render_bytes("path", "2", d.path())
    );
}

#[test]
fn pm_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(
        render_bytes("pm", "1", d.path()),
        render_bytes("pm", "2", d.path())
    );
}

#[test]
fn photons_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(
        render_bytes("photons", "1", d.path()),
        render_bytes("photons", "2", d.path())
    );
}

#[test]
fn one_pass_pm_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(repo().join("scenes/cornell-caustics.toml")).unwrap();
    let models = repo().join("scenes/models");
    let text = text.replace("\"models/", &format!("\"{}/", models.display()));
    let scene = d.path().join("one-pass.toml");
    std::fs::write(
        &scene,
        format!("{text}\n[render.icache]\nfill = \"one-pass\"\n"),
    )
    .unwrap();
    let render = |threads: &str| {
        let out = d.path().join(format!("one-{threads}.exr"));
        let r = run(&[
            "render",
            &scene.to_string_lossy(),
            "-o",
            &out.to_string_lossy(),
            "--method",
            "pm",
            "--threads",
            threads,
            "--width",
            "48",
            "--height",
            "48",
            "--spp",
            "4",
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        std::fs::read(out).expect("output written")
    };
    let one = render("1");
    assert_eq!(one, render("2"));
    assert_ne!(
        one,
        render_bytes("pm", "2", d.path()),
        "the one-pass fill must differ from the two-pass fill"
    );
}

/// Records made between the rounds of adaptive sampling for the samples that found none (the blinds
/// room's sub-pixel slats at 64×48) and those pixels' rounds taken again: still byte-identical.
#[test]
fn pm_growing_its_cache_in_pass_b_is_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/blinds-room.toml");
    let render = |threads: &str| {
        let (out, stats) = (
            d.path().join(format!("blinds-{threads}.exr")),
            d.path().join(format!("blinds-{threads}.json")),
        );
        let r = run(&[
            "render",
            &scene.to_string_lossy(),
            "-o",
            &out.to_string_lossy(),
            "--stats",
            &stats.to_string_lossy(),
            "--threads",
            threads,
            "--width",
            "64",
            "--height",
            "48",
            "--spp",
            "16",
            "--quiet",
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        (
            std::fs::read(out).expect("output written"),
            j["icache"]["records_pass_b"].as_u64().unwrap(),
            j["icache"]["samples_redone"].as_u64().unwrap(),
        )
    };
    let (one, records, redone) = render("1");
    assert!(
        records > 0 && redone > 0,
        "the test needs pass-B records: {records} records, {redone} samples redone"
    );
    assert!(one == render("2").0, "1 and 2 threads differ");
}
