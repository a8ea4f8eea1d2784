//! A camera following a moving object, the common shot: the ball of scenes/anim-ball.toml rolls
//! across the box by small steps and the camera moves with it. Its cache keeps a bounded number of
//! records (a record on the ball moves with it, one on the floor stays, and neither is made again
//! beside itself), and a late frame agrees with a still render of its camera and placement. The
//! 1,000-frame run, with its time per frame against `temporal = false`, is `make test-slow`'s.

mod common;
use common::*;

use std::path::Path;
use std::time::Duration;

use pmrender::io::output::Image;

/// Where frame `f` of an `n`-frame follow shot puts the ball's centre and the camera (x only: both
/// go from x = −0.6 to 0.6 between the first frame and the last, as the keys interpolate).
fn x_at(f: u32, n: u32) -> f32 {
    -0.6 + (0.6 - -0.6) * (f as f32 / (n - 1) as f32)
}

/// The scene of frame `f`'s camera and ball: keyed from `x_at(0)` to `x_at(n − 1)` (`animated`), or
/// a still at `x_at(f)`; 64×48, `seed`, `extra` appended to `[render]`.
fn follow_text(n: u32, f: u32, animated: bool, seed: u64, extra: &str) -> String {
    let models = repo().join("scenes/models");
    let (a, b) = (x_at(0, n), x_at(n - 1, n));
    let x = if animated { a } else { x_at(f, n) };
    let mut text = String::from("version = 1\n");
    if animated {
        text += &format!("[animation]\nframes = {n}\n");
    }
    text += &format!(
        "[camera]\neye = [{x:?}, 1.0, 3.9]\ntarget = [{x:?}, 0.6, 0.0]\nfov = 39.0\nwidth = 64\nheight = 48\n"
    );
    if animated {
        for (k, x) in [(0, a), (n - 1, b)] {
            text += &format!(
                "[[camera.key]]\nframe = {k}\neye = [{x:?}, 1.0, 3.9]\ntarget = [{x:?}, 0.6, 0.0]\n"
            );
        }
    }
    text += &format!(
        "[[mesh]]\nobj = \"{m}/anim-ball-box.obj\"\n[[mesh]]\nobj = \"{m}/ball.obj\"\nscale = 0.25\n\
         translate = [{x:?}, 0.25, 0.3]\n",
        m = models.display()
    );
    if animated {
        for (k, x) in [(0, a), (n - 1, b)] {
            text += &format!("[[mesh.key]]\nframe = {k}\ntranslate = [{x:?}, 0.25, 0.3]\n");
        }
    }
    text + &format!("[render]\nseed = {seed}\n{extra}")
}

/// Renders `scene` (text, written to `dir/name.toml`) with `args` and its outputs under `dir`.
fn render(dir: &Path, name: &str, scene: &str, args: &[&str], limit: Duration) {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, scene).unwrap();
    let path = path.to_string_lossy().into_owned();
    let mut all = vec!["render", path.as_str()];
    all.extend_from_slice(args);
    all.push("--quiet");
    let r = run_bounded(&all, limit);
    assert!(
        r.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

/// The sequence summary's rows: (records after the frame, its time in seconds).
fn frame_rows(summary: &Path) -> Vec<(u64, f64)> {
    let text = std::fs::read_to_string(summary).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["records_after"].as_u64().unwrap(),
                f["time_s"].as_f64().unwrap(),
            )
        })
        .collect()
}

/// relMSE of 8×8 block means of `img` against `still`, and the largest relative difference of the
/// channel means.
fn agreement(img: &Image, still: &Image) -> (f64, f32) {
    let block = rel_mse(&block_means(img, 8), &block_means(still, 8));
    let (m, s) = (mean(img), mean(still));
    let dm = (0..3)
        .map(|c| (m[c] - s[c]).abs() / s[c].abs().max(1e-6))
        .fold(0.0, f32::max);
    (block, dm)
}

/// Frame `f`'s image (`dir/f-####.exr`) against stills of its camera and placement with the
/// sequence's seed and another: (block relMSE to the still, the other seed's, mean difference).
fn against_still(dir: &Path, n: u32, f: u32) -> (f64, f64, f32) {
    let limit = Duration::from_secs(120);
    for (name, seed) in [("still", 0), ("other", 1)] {
        let out = p(dir, &format!("{name}.exr"));
        render(
            dir,
            name,
            &follow_text(n, f, false, seed, ""),
            &["-o", &out],
            limit,
        );
    }
    let frame = read(&dir.join(format!("f-{f:04}.exr")));
    let (still, other) = (read(&dir.join("still.exr")), read(&dir.join("other.exr")));
    let (block, dmean) = agreement(&frame, &still);
    (block, agreement(&other, &still).0, dmean)
}

#[test]
fn a_follow_shot_keeps_its_records_bounded() {
    // 240 frames, steps of 5 mm; frames 0–200 rendered. Measured (64×48): 301 records at frame 0,
    // 336 at frame 20, 397 at frame 100, 414 at frame 200 — new ones where the moving view shows
    // surface no record covers, fewer and fewer. Before, every record on the ball fell behind it (a
    // step too small to take the surface from under it left it in place) and an earlier view's
    // records on the curved ball were hidden by the ball itself: with steps of 3 mm, 784 records at
    // frame 10, 1,649 at frame 50, 2,712 at frame 99, 21 more every frame. The bound only tells the
    // two apart.
    let (n, last) = (240, 200);
    let d = tempfile::tempdir().unwrap();
    let (out, stats) = (p(d.path(), "f-####.exr"), p(d.path(), "f-####.json"));
    let frames = format!("0..{last}");
    let args = ["-o", &out, "--stats", &stats, "--frames", &frames];
    let scene = follow_text(n, 0, true, 0, "");
    render(d.path(), "follow", &scene, &args, Duration::from_secs(600));
    let rows = frame_rows(&d.path().join("f-sequence.json"));
    let records = |f: usize| rows[f].0;
    eprintln!(
        "[follow] records at frames 0 / 20 / 100 / {last}: {} / {} / {} / {}",
        records(0),
        records(20),
        records(100),
        records(last as usize)
    );
    assert!(
        records(last as usize) * 2 <= records(20) * 3,
        "{} records at frame {last} against {} at frame 20",
        records(last as usize),
        records(20)
    );
    // Measured: block relMSE 5.8e-6 against the still, another seed's 1.6e-5; means 0.11 % apart;
    // the same figures on SSE4.2's kernels (the bounds 8.5× and 18× them). One seed only: the 200
    // frames take five minutes a seed, so the bounds stay as they were, not tightened from it.
    let (block, noise, dmean) = against_still(d.path(), n, last);
    eprintln!(
        "[follow] frame {last} vs still: 8x8-block relMSE {block:.3e}, another seed {noise:.3e}, mean {:.2} %",
        dmean * 100.0
    );
    assert!(dmean <= 0.02, "means {:.2} % apart", dmean * 100.0);
    assert!(
        block <= 3.0 * noise,
        "block relMSE {block:.3e} (another seed: {noise:.3e})"
    );
}

#[test]
#[ignore = "slow: 1,000 frames, then 100 with temporal = false (about 8 minutes on 2 cores)"]
fn a_thousand_frame_follow_shot_takes_flat_time_per_frame() {
    // Steps of 1.2 mm. Measured (64×48, 2 shared cores): 301 records at frame 0, at most 344 over
    // frames 20–119, 422 over frames 900–999 (the rate falling: +43, +8, +4, +2 per 100 frames from
    // frame 100 on); 0.25 s a frame over frames 20–119, 0.28 s over 900–999, 0.23 s over frames
    // 1–99 against 0.87 s with temporal = false; peak memory 293 MB from frame 100 to the last.
    let n = 1000;
    let d = tempfile::tempdir().unwrap();
    let (out, stats) = (p(d.path(), "f-####.exr"), p(d.path(), "f-####.json"));
    let scene = follow_text(n, 0, true, 0, "");
    render(
        d.path(),
        "follow",
        &scene,
        &["-o", &out, "--stats", &stats],
        Duration::from_secs(1800),
    );
    let rows = frame_rows(&d.path().join("f-sequence.json"));
    let window = |from: usize| {
        let r = &rows[from..from + 100];
        (
            r.iter().map(|r| r.0).max().unwrap(),
            r.iter().map(|r| r.1).sum::<f64>() / 100.0,
        )
    };
    let (early, late) = (window(50), window(n as usize - 100));
    eprintln!(
        "[follow 1000] frames 50-149: at most {} records, {:.3} s a frame; frames 900-999: {} records, {:.3} s",
        early.0, early.1, late.0, late.1
    );
    assert!(
        late.0 * 4 <= early.0 * 5,
        "records grew: {early:?} to {late:?}"
    );
    assert!(
        late.1 <= 1.5 * early.1,
        "time per frame grew: {early:?} to {late:?}"
    );
    // The same frames rendered one by one: no faster than the sequence.
    let (alone, alone_stats) = (p(d.path(), "a-####.exr"), p(d.path(), "a-####.json"));
    let scene = follow_text(n, 0, true, 0, "[render.icache]\ntemporal = false\n");
    let args = ["-o", &alone, "--stats", &alone_stats, "--frames", "0..99"];
    render(d.path(), "alone", &scene, &args, Duration::from_secs(600));
    let alone_rows = frame_rows(&d.path().join("a-sequence.json"));
    let alone_s = alone_rows[1..].iter().map(|r| r.1).sum::<f64>() / 99.0;
    let seq_s = rows[1..100].iter().map(|r| r.1).sum::<f64>() / 99.0;
    eprintln!(
        "[follow 1000] frames 1-99: {seq_s:.3} s a frame, {alone_s:.3} s with temporal = false"
    );
    assert!(
        seq_s <= alone_s,
        "{seq_s:.3} s a frame against {alone_s:.3} s one by one"
    );
    let (block, noise, dmean) = against_still(d.path(), n, n - 1);
    eprintln!(
        "[follow 1000] frame {} vs still: block relMSE {block:.3e}, another seed {noise:.3e}, mean {:.2} %",
        n - 1,
        dmean * 100.0
    );
    assert!(dmean <= 0.02 && block <= 3.0 * noise);
}

/// A camera going half round a thin panel in a box room, from in front of it (z = 0.9) to behind
/// it (z = −0.9) over `n` frames; a still at frame `f`'s pose without `[animation]`.
fn round_panel_text(n: u32, f: Option<u32>, seed: u64) -> String {
    let keys = [
        (0, [0.0, 1.0, 0.9]),
        (n / 2, [0.9, 1.0, 0.0]),
        (n - 1, [0.0, 1.0, -0.9]),
    ];
    let mut text = String::from("version = 1\n");
    let eye = match f {
        None => {
            text += &format!("[animation]\nframes = {n}\n");
            keys[0].1
        }
        Some(f) => {
            // Linear between the keys, as the camera's keys interpolate.
            let (a, b) = if f <= n / 2 {
                (keys[0], keys[1])
            } else {
                (keys[1], keys[2])
            };
            let t = (f - a.0) as f32 / (b.0 - a.0) as f32;
            [0, 1, 2].map(|i| a.1[i] + t * (b.1[i] - a.1[i]))
        }
    };
    text += &format!(
        "[camera]\neye = {eye:?}\ntarget = [0.0, 0.9, 0.0]\nfov = 60.0\nwidth = 64\nheight = 48\n"
    );
    if f.is_none() {
        for (k, e) in keys {
            text +=
                &format!("[[camera.key]]\nframe = {k}\neye = {e:?}\ntarget = [0.0, 0.9, 0.0]\n");
        }
    }
    text + &format!(
        "[[mesh]]\nobj = \"room.obj\"\n[[mesh]]\nobj = \"panel.obj\"\nscale = [0.3, 0.7, 0.02]\n\
         translate = [0.0, 0.7, 0.0]\n[render]\nseed = {seed}\n"
    )
}

#[test]
fn records_no_pixel_reads_retire_as_the_camera_goes_round() {
    // The records on the panel's front stay in view once the camera is behind it, and no pixel can
    // read them (the panel hides its own front). Measured (48 frames, 64×48): 17 records retired
    // unread, all at frame 40 (16 frames after the camera passed the panel's edge); 254 records at
    // the end against 271 without retiring. Frame 47 against its still: block relMSE 1.0e-5
    // (another seed 2.9e-5), means 0.28 % apart.
    let n = 48;
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        ("panel.obj", &cube_obj("room.mtl", "wall")),
    ]);
    let (out, stats) = (p(d.path(), "f-####.exr"), p(d.path(), "f-####.json"));
    let limit = Duration::from_secs(300);
    let scene = round_panel_text(n, None, 0);
    render(
        d.path(),
        "round",
        &scene,
        &["-o", &out, "--stats", &stats],
        limit,
    );
    let text = std::fs::read_to_string(d.path().join("f-sequence.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let unread: u64 = json["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["records_unread"].as_u64().unwrap())
        .sum();
    eprintln!("[round] records retired unread: {unread}");
    assert!(unread >= 8, "{unread} records retired unread");
    for (name, seed) in [("still", 0), ("other", 1)] {
        let out = p(d.path(), &format!("{name}.exr"));
        render(
            d.path(),
            name,
            &round_panel_text(n, Some(n - 1), seed),
            &["-o", &out],
            limit,
        );
    }
    let frame = read(&d.path().join(format!("f-{:04}.exr", n - 1)));
    let (still, other) = (
        read(&d.path().join("still.exr")),
        read(&d.path().join("other.exr")),
    );
    let (block, dmean) = agreement(&frame, &still);
    let noise = agreement(&other, &still).0;
    eprintln!(
        "[round] last frame vs still: block relMSE {block:.3e}, another seed {noise:.3e}, mean {:.2} %",
        dmean * 100.0
    );
    assert!(dmean <= 0.02 && block <= 3.0 * noise);
}
