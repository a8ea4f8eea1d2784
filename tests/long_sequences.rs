//! Long and split sequences as a user (or an attacker) writes them: a key per frame over tens of
//! thousands of frames loads in time linear in the keys, and no two frames' outputs may be one file.

mod common;
use common::*;
use std::time::Duration;

/// anim-ball with `n` frames and a camera key at every one of them.
fn keyed_path(dir: &std::path::Path, n: u32) -> String {
    let base = std::fs::read_to_string(repo().join("scenes/anim-ball.toml"))
        .unwrap()
        .replace("frames = 48", &format!("frames = {n}"))
        .replace("obj = \"", &format!("obj = \"{}/scenes/", repo().display()));
    let keys: String = (0..n)
        .map(|f| {
            let x = 0.5 * (f as f32 / 50.0).sin();
            format!("[[camera.key]]\nframe = {f}\neye = [{x:.4}, 1.0, 3.9]\n")
        })
        .collect();
    let path = dir.join("path.toml");
    std::fs::write(&path, base + "\n" + &keys).unwrap();
    path.to_string_lossy().into_owned()
}

#[test]
fn a_key_per_frame_loads_in_time_linear_in_the_keys() {
    // A key per frame over 40,000 frames: with a load linear in the keys, two frames render in
    // about 1.6 s here; a load quadratic in them (every frame built from every key) takes hours. The
    // bound only tells one from the other.
    let d = tempfile::tempdir().unwrap();
    let scene = keyed_path(d.path(), 40_000);
    let out = p(d.path(), "f-#####.exr");
    let r = run_bounded(
        &[
            "render", &scene, "-o", &out, "--frames", "0..1", "--width", "32", "--height", "24",
            "--spp", "1", "--quiet",
        ],
        Duration::from_secs(60),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(d.path().join("f-00001.exr").exists());
}

#[test]
fn outputs_of_different_frames_that_are_one_file_are_refused_before_any_is_written() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/anim-ball.toml");
    let s = scene.to_str().unwrap();
    let o = |name: &str| p(d.path(), name);
    for i in 0..2 {
        std::fs::create_dir(d.path().join(format!("d{i}"))).unwrap();
    }
    // Two frame folders that are one folder.
    std::fs::create_dir(d.path().join("real")).unwrap();
    for i in 0..2 {
        std::os::unix::fs::symlink(d.path().join("real"), d.path().join(format!("l{i}"))).unwrap();
    }
    let small = ["--width", "16", "--height", "12", "--spp", "1", "--quiet"];
    for (outputs, names) in [
        // Frame 0's statistics are o-10.exr, frame 10's image.
        (
            vec![
                "-o".to_string(),
                o("o-#.exr"),
                "--stats".into(),
                o("o-1#.exr"),
            ],
            "frame 10",
        ),
        (vec!["-o".to_string(), o("d#/../f.exr")], "frame 0"),
        (vec!["-o".to_string(), o("l#/f.exr")], "frame 0"),
        (
            vec![
                "-o".to_string(),
                o("p-#.exr"),
                "--png".into(),
                o("p-#.png"),
                "--cache-image".into(),
                o("p-1#.png"),
            ],
            "--png",
        ),
    ] {
        let mut args = vec!["render", s, "--frames", "0..11"];
        args.extend(outputs.iter().map(String::as_str));
        args.extend_from_slice(&small);
        let r = run(&args);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{outputs:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(
            stderr.contains(names) && stderr.contains("replace"),
            "{stderr}"
        );
    }
    let written: Vec<String> = listing(d.path())
        .into_iter()
        .filter(|n| n.ends_with(".exr") || n.ends_with(".png") || n.ends_with(".json"))
        .collect();
    assert!(written.is_empty(), "{written:?}");
    // Distinct outputs pass.
    let mut args = vec!["render", s, "--frames", "0..2"];
    let (a, b) = (o("ok-#.exr"), o("ok-#.json"));
    args.extend(["-o", &a, "--stats", &b]);
    args.extend_from_slice(&small);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

#[test]
fn a_frame_whose_maps_would_thin_out_is_traced_as_a_still() {
    // A floor under a spot slides out of its beam: over the first frame's 365 k paths it stored
    // 200 k, 194 k, 170 k, 130 k photons at frames 0–3, and would have gone on thinning (a still of
    // frame 5 stores 200 k, over 1.29 M paths). Frame 4's would have fallen under half the first
    // frame's: it is traced as a still (798 k paths, 200 k photons), and frame 5 takes its paths
    // (123 k). Every frame stays within a factor of two of a still's density.
    let d = tempfile::tempdir().unwrap();
    let quad = "mtllib quad.mtl\nv -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nusemtl white\n\
                f 1 2 3\nf 1 3 4\n";
    std::fs::write(d.path().join("quad.obj"), quad).unwrap();
    std::fs::write(d.path().join("quad.mtl"), "newmtl white\nKd 0.7 0.7 0.7\n").unwrap();
    let scene = "version = 1\n[animation]\nframes = 6\n[camera]\neye = [0.0, 4.0, 4.0]\n\
                 target = [0.0, 0.0, 0.0]\nfov = 50.0\nwidth = 32\nheight = 24\n[[mesh]]\n\
                 obj = \"quad.obj\"\n[[mesh.key]]\nframe = 0\ntranslate = [0.0, 0.0, 0.0]\n\
                 [[mesh.key]]\nframe = 5\ntranslate = [1.8, 0.0, 0.0]\n[[light]]\n\
                 type = \"spot\"\nposition = [0.0, 2.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n\
                 intensity = [20.0, 20.0, 20.0]\ncone_angle = 40.0\n[render]\nseed = 0\n";
    std::fs::write(d.path().join("s.toml"), scene).unwrap();
    let (s, out, stats) = (
        p(d.path(), "s.toml"),
        p(d.path(), "f-#.exr"),
        p(d.path(), "f-#.json"),
    );
    let r = run(&["render", &s, "-o", &out, "--stats", &stats, "--quiet"]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let photons = |f: u32| {
        let j: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(d.path().join(format!("f-{f}.json"))).unwrap(),
        )
        .unwrap();
        let p = &j["photons"];
        (
            p["global_stored"].as_u64().unwrap(),
            p["paths_emitted"].as_u64().unwrap(),
        )
    };
    let (target, first_paths) = photons(0);
    for f in 0..6 {
        let (stored, _) = photons(f);
        assert!(
            stored * 2 >= target && stored <= 2 * target,
            "frame {f}: {stored} photons against a still's {target}"
        );
    }
    assert!(photons(5).1 > first_paths, "no frame was traced afresh");
}

#[test]
fn a_summary_of_frames_in_numbered_folders_goes_beside_them() {
    // With `--stats out/d#/s.json` the run is in a folder's name: replacing it by "sequence" would
    // name out/dsequence/, a folder no frame has.
    let d = tempfile::tempdir().unwrap();
    for f in 0..2 {
        std::fs::create_dir(d.path().join(format!("d{f}"))).unwrap();
    }
    let scene = repo().join("scenes/anim-ball.toml");
    let (o, s) = (p(d.path(), "d#/f.exr"), p(d.path(), "d#/s.json"));
    let r = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        &o,
        "--stats",
        &s,
        "--frames",
        "0..1",
        "--width",
        "16",
        "--height",
        "12",
        "--spp",
        "1",
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    for f in 0..2 {
        assert!(d.path().join(format!("d{f}/s.json")).exists(), "frame {f}");
    }
    let summary = std::fs::read_to_string(d.path().join("s-sequence.json")).unwrap();
    assert!(summary.contains("\"frames_written\": 2"), "{summary}");
}
