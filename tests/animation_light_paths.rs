//! Animated scenes where what moves changes light far from itself, each `pm` frame checked against
//! the still render of that frame (`--frames F..F --chunk 1`, a fresh cache):
//!
//! - a mirror panel turning about its own centre under a spot (its bounding sphere stays put): the
//!   cached indirect light follows the reflected beam from the green wall to the red one;
//! - a small ball sliding into a spot's beam, then holding: the red wall's bleed from the blocked
//!   beam leaves the indirect light, and the held frames keep the right image;
//! - a ball moving above a glossy floor: its reflection (the glossy layer) moves with it;
//! - a ball's long shadow from a low directional light: pixels kept from the frame before show the
//!   shadow where it is now, not where it was;
//! - a light keyed to another hue at the same luminance, then held while a small ball still moves:
//!   the records do not go on drifting in hue after the light stopped;
//! - a ball sliding slowly into a spot's beam in a scene where `pm` chooses more gather rays: every
//!   frame gathers with the rays the first one chose (the choice was lost every second frame, and
//!   the two kinds of gather alternated the indirect light by 3 %);
//! - frames that show the frame before's image (nothing changed) report no work of their own, and
//!   the sequence summary counts each rendered frame's records once, with `records_dropped` (view
//!   drops) and `records_gone` apart.

mod common;
use common::*;

use std::path::Path;
use std::time::Duration;

use glam::Vec3;
use pmrender::io::output::{read_layer, Image};

/// A 20 × 20 grey quad at y = 0, facing +y, of material `grey`.
const FLOOR_OBJ: &str = "mtllib floor.mtl
usemtl grey
v -10 0 10
v 10 0 10
v 10 0 -10
v -10 0 -10
f 1 2 3 4
";

const FLOOR_MTL: &str = "newmtl grey
Kd 0.6 0.6 0.6
";

const CUBE_MTL: &str = "newmtl cube
Kd 0.8 0.8 0.8
";

/// A model of the repository's scenes/models, as a quoted TOML string of its absolute path.
fn model(name: &str) -> String {
    format!("{:?}", p(&repo().join("scenes/models"), name))
}

/// The anim-ball box (red left wall, green right wall) with its ceiling light off, seen from the
/// front, 48 × 36, frames 0…`frames`−1: `meshes` and `lights` are more of its tables.
fn dark_box(frames: u32, meshes: &str, lights: &str, render: &str) -> String {
    format!(
        "version = 1\n[animation]\nframes = {frames}\n[camera]\neye = [0.0, 1.0, 3.9]\n\
         target = [0.0, 1.0, 0.0]\nfov = 39.0\nwidth = 48\nheight = 36\n[[mesh]]\nobj = {}\n\
         {meshes}[materials.light]\nemission = [0.0, 0.0, 0.0]\n{lights}[render]\nseed = 0\n{render}",
        model("anim-ball-box.obj")
    )
}

/// The ball of scenes/models (radius 1 before `scale`), keyed from `from` at frame 0 to `to` at
/// frame `at`.
fn moving_ball(scale: f32, from: [f32; 3], to: [f32; 3], at: u32) -> String {
    format!(
        "[[mesh]]\nobj = {}\nscale = {scale:?}\ntranslate = {}\n[[mesh.key]]\nframe = 0\n\
         translate = {}\n[[mesh.key]]\nframe = {at}\ntranslate = {}\n",
        model("ball.obj"),
        v3(from),
        v3(from),
        v3(to)
    )
}

fn v3(v: [f32; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

/// A folder with the floor and cube models, `scene.toml` and an empty `out/`.
fn folder(scene: &str) -> tempfile::TempDir {
    let cube = cube_obj("cube.mtl", "cube");
    let d = scene_dir(&[
        ("floor.obj", FLOOR_OBJ),
        ("floor.mtl", FLOOR_MTL),
        ("cube.obj", &cube),
        ("cube.mtl", CUBE_MTL),
        ("scene.toml", scene),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    d
}

fn out(d: &Path, name: &str) -> String {
    p(&d.join("out"), name)
}

/// Runs `render` on `scene.toml` of `d` with `args` (and `--quiet`), bounded in time, and panics
/// with its stderr unless it succeeds.
fn render_ok(d: &Path, args: &[&str]) {
    let scene = p(d, "scene.toml");
    let mut all = vec!["render", scene.as_str()];
    all.extend_from_slice(args);
    all.push("--quiet");
    let r = run_bounded(&all, Duration::from_secs(120));
    assert!(
        r.status.success(),
        "{all:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
}

/// Renders the whole sequence into out/f-####.exr (with `extra`) and frame `f` alone into
/// out/still-####.exr; returns the paths of frame `f` of each.
fn frame_and_still(d: &Path, f: u32, extra: &[&str]) -> (String, String) {
    let pattern = out(d, "f-####.exr");
    let mut args = vec!["-o", pattern.as_str()];
    args.extend_from_slice(extra);
    render_ok(d, &args);
    let still = out(d, "still-####.exr");
    let frames = format!("{f}..{f}");
    // A chunk of one frame: the frame rendered as a still of its own.
    render_ok(d, &["-o", &still, "--frames", &frames, "--chunk", "1"]);
    (
        out(d, &format!("f-{f:04}.exr")),
        out(d, &format!("still-{f:04}.exr")),
    )
}

/// A layer of an EXR (`None`: the beauty).
fn layer(path: &str, name: Option<&str>) -> Image {
    read_layer(Path::new(path), name).unwrap_or_else(|e| panic!("{path} {name:?}: {e}"))
}

/// Per channel, the mean of `img` over that of `still`.
fn ratio(img: &Image, still: &Image) -> Vec3 {
    mean(img) / mean(still).abs().max(Vec3::splat(1e-12))
}

/// The x-centroid (pixels) of an image's channel sum.
fn x_centroid(img: &Image) -> f32 {
    let (mut sum, mut moment) = (0.0f64, 0.0f64);
    for (i, px) in img.pixels.iter().enumerate() {
        let v = px.element_sum() as f64;
        sum += v;
        moment += v * (i as u32 % img.width) as f64;
    }
    (moment / sum.max(1e-30)) as f32
}

fn json(path: &str) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}")))
        .unwrap_or_else(|e| panic!("{path}: {e}"))
}

// ---------------------------------------------------------------------------------------------------
// Light moved across the room by what moves.

/// A thin mirror panel (the cube scaled [0.3, 0.02, 0.3]) at height 0.6 under a spot pointing
/// straight down, turned about its own centre from −30° to +30° about z over frames 0–3: the beam it
/// reflects sweeps from the green wall to the red one. `pm`'s frame 3 has each channel of its
/// `indirect` mean within 5 % of the still's (measured: 0.989, 0.988, 0.985 of it; a still of seed
/// 1: 0.990, 0.991, 0.990; sequence and still at seed 1 1.009, 1.006, 1.007, at seed 2 1.013, 1.009,
/// 1.014, on SSE4.2's kernels 0.992, 0.989, 0.989: the bound 3.3× the worst). A turning mesh counted
/// as not moving (its bounding sphere stays put) kept frame 0's green bleed: red 0.27×, green 6.1×,
/// blue 1.95×.
#[test]
fn a_mirror_turning_in_place_moves_the_indirect_light() {
    let panel =
        "[[mesh]]\nobj = \"cube.obj\"\nscale = [0.3, 0.02, 0.3]\ntranslate = [0.0, 0.6, 0.0]\n\
                 [[mesh.key]]\nframe = 0\nrotate = [0.0, 0.0, -30.0]\n\
                 [[mesh.key]]\nframe = 3\nrotate = [0.0, 0.0, 30.0]\n\
                 [materials.cube]\ntype = \"mirror\"\nreflectance = [0.95, 0.95, 0.95]\n";
    let spot = "[[light]]\ntype = \"spot\"\nposition = [0.0, 1.9, 0.0]\ntarget = [0.0, 0.6, 0.0]\n\
                intensity = [20.0, 20.0, 20.0]\ncone_angle = 10.0\nfalloff_start = 8.0\n";
    let d = folder(&dark_box(4, panel, spot, ""));
    let (frame, still) = frame_and_still(d.path(), 3, &[]);
    let r = ratio(
        &layer(&frame, Some("indirect")),
        &layer(&still, Some("indirect")),
    );
    eprintln!("[turning mirror] frame 3 indirect / still: {r:.4}");
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.05,
        "frame 3's indirect means are {r:.4} of its still's"
    );
}

/// A ball (scale 0.1) sliding 0.52 units over frames 0–2 into a narrow spot's beam just in front
/// of the spot, which lit a patch of the red wall, then holding (frames 3–4 show frame 2's image);
/// a point light under the ceiling gives a base level. `pm`'s frame 4 has each channel of its
/// `indirect` mean within 3 % of the still's (measured: 0.998, 1.004, 1.000; a still of seed 1:
/// 1.003, 1.000, 1.007). Records far from the ball kept the red wall's bleed from the beam it
/// blocks: red 1.143×.
#[test]
fn a_ball_blocking_a_spot_removes_its_bounce_from_the_indirect_light() {
    let ball = moving_ball(0.1, [0.682, 1.708, -0.1], [0.682, 1.708, 0.42], 2);
    let lights = "[[light]]\ntype = \"spot\"\nposition = [0.9, 1.8, 0.5]\n\
                  target = [-1.0, 1.0, -0.2]\nintensity = [30.0, 30.0, 30.0]\ncone_angle = 12.0\n\
                  falloff_start = 10.0\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.9, 0.0]\n\
                  intensity = [2.0, 2.0, 2.0]\n";
    // More gather rays than the default only to lower the noise (seed to seed 0.3 % in red).
    let d = folder(&dark_box(
        5,
        &ball,
        lights,
        "[render.icache]\nrays = 4000\n",
    ));
    let (frame, still) = frame_and_still(d.path(), 4, &[]);
    let r = ratio(
        &layer(&frame, Some("indirect")),
        &layer(&still, Some("indirect")),
    );
    eprintln!("[blocked spot] frame 4 indirect / still: {r:.4}");
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.03,
        "frame 4's indirect means are {r:.4} of its still's"
    );
}

/// A ball (scale 0.15) sinking slowly, over 30 frames, into a narrow spot beam aimed at the back
/// wall, a metre from the ball: the wall's bright patch and its bounce light in the whole room dim,
/// a few photons per texel at a time. `pm`'s frame 29 has each channel of its `indirect` mean
/// within 2.5 % of the still's (measured: 1.005, 0.998, 0.992; before the atlas's texels were carried
/// 1.006, 0.999, 0.993; a still of seed 1: 0.986, 0.975, 0.972, but a sequence and a still share
/// their seed's photons; sequence and still at seed 1 1.012, 1.014, 0.999, at seed 2 0.998, 0.993,
/// 0.986, on SSE4.2's kernels 0.998, 0.999, 0.991). Texels carried while no single cell's photons
/// changed significantly kept the brighter bounce: 1.028, 0.982, 0.964. The bound, 1.8× the worst
/// seed's 1.4 %, stays below that defect's 3.6 % (2 % held the seeds by 1.4× only; 30 frames are too
/// slow to average seeds).
#[test]
fn a_slow_dimming_of_bounce_light_reaches_the_carried_texels() {
    let ball = moving_ball(0.15, [0.2, 1.55, -0.1], [0.2, 1.2, -0.1], 29);
    let lights = "[[light]]\ntype = \"spot\"\nposition = [0.9, 1.8, 0.8]\n\
                  target = [-0.5, 0.6, -1.0]\nintensity = [40.0, 40.0, 40.0]\ncone_angle = 6.0\n\
                  falloff_start = 5.0\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.9, 0.0]\n\
                  intensity = [0.3, 0.3, 0.3]\n";
    let d = folder(&dark_box(30, &ball, lights, ""));
    let (frame, still) = frame_and_still(d.path(), 29, &[]);
    let r = ratio(
        &layer(&frame, Some("indirect")),
        &layer(&still, Some("indirect")),
    );
    eprintln!("[dimming bounce] frame 29 indirect / still: {r:.4}");
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.025,
        "frame 29's indirect means are {r:.4} of its still's"
    );
}

/// A ball (scale 0.5) rolling in from outside the scene's bounds (x = 14, the floor ends at 10)
/// beside a block, under a low sun: while it is outside, each frame's scene bounds differ, so does
/// the disc the sun's photons leave from, and every photon path starts elsewhere. `pm`'s frame 30 has
/// each channel of its `indirect` mean within 4 % of the still's (measured: 0.986, 0.981, 0.974; the
/// binary before photon paths were copied between frames 0.984, 0.980, 0.973). Copying the paths
/// whose segments passed the ball by, from the frame before's log, kept the old starts: 1.000,
/// 0.978, 0.937.
#[test]
fn a_mover_from_outside_the_bounds_under_the_sun_retraces_every_path() {
    let ball = moving_ball(0.5, [14.0, 0.8, 7.5], [6.5, 0.8, 7.5], 30);
    let scene = format!(
        "version = 1\n[animation]\nframes = 31\n[camera]\neye = [6.0, 5.0, 13.0]\n\
         target = [6.0, 0.0, 7.5]\nfov = 39.0\nwidth = 64\nheight = 48\n[[mesh]]\n\
         obj = \"floor.obj\"\n[[mesh]]\nobj = \"cube.obj\"\nscale = 0.8\n\
         translate = [4.5, 0.8, 7.0]\n{ball}[[light]]\ntype = \"directional\"\n\
         direction = [-4.0, -1.0, 0.3]\nirradiance = [3.0, 3.0, 3.0]\n[render]\nseed = 0\n"
    );
    let d = folder(&scene);
    let (frame, still) = frame_and_still(d.path(), 30, &[]);
    let r = ratio(
        &layer(&frame, Some("indirect")),
        &layer(&still, Some("indirect")),
    );
    eprintln!("[sun, mover from outside] frame 30 indirect / still: {r:.4}");
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.04,
        "frame 30's indirect means are {r:.4} of its still's"
    );
}

/// A white ball (scale 0.2) at height 1.1, lit by a spot, moving from x = −0.6 to +0.6 over frames
/// 0–4 above a 4 × 4 glossy floor (exponent 25), just out of view: its blurred reflection is seen
/// in the floor. `pm`'s frame 4 has the x-centroid of its `glossy` layer within 2 px of the
/// still's (measured, 48 px wide: 30.03 against 30.28; a still of seed 1: 30.23; frame 0: 17.38)
/// and its mean within 10 % of the still's (measured +1.7 %; seed 1 +3.3 %; at 64 px wide the
/// glossy layer reads 3–6 % low against the still, a known bias of the glossy records, so the
/// bound is loose). The glossy records not near the ball kept frame 0's reflection: centroid 17.38.
#[test]
fn a_glossy_reflection_follows_a_moving_ball() {
    let ball = moving_ball(0.2, [-0.6, 1.1, 0.0], [0.6, 1.1, 0.0], 4);
    let scene = format!(
        "version = 1\n[animation]\nframes = 5\n[camera]\neye = [0.0, 1.2, 3.5]\n\
         target = [0.0, 0.0, 0.5]\nfov = 39.0\nwidth = 48\nheight = 36\n[[mesh]]\n\
         obj = \"floor.obj\"\nscale = 0.2\n{ball}[materials.grey]\ntype = \"glossy\"\n\
         albedo = [0.2, 0.2, 0.2]\nspecular = [0.5, 0.5, 0.5]\nexponent = 25.0\n\
         [materials.ball]\nalbedo = [0.9, 0.9, 0.9]\n[[light]]\ntype = \"spot\"\n\
         position = [0.0, 1.1, 1.6]\ntarget = [0.0, 1.1, 0.0]\nintensity = [40.0, 40.0, 40.0]\n\
         cone_angle = 24.0\nfalloff_start = 22.0\n[render]\nseed = 0\n[render.icache]\n\
         rays = 4000\n"
    );
    let d = folder(&scene);
    let (frame, still) = frame_and_still(d.path(), 4, &[]);
    let (g, gs) = (layer(&frame, Some("glossy")), layer(&still, Some("glossy")));
    let first = x_centroid(&layer(&out(d.path(), "f-0000.exr"), Some("glossy")));
    let (c, cs) = (x_centroid(&g), x_centroid(&gs));
    let r = ratio(&g, &gs);
    eprintln!(
        "[glossy] frame 4 glossy x-centroid {c:.2} px, still {cs:.2} px (frame 0: {first:.2}); \
         mean / still {r:.4}"
    );
    assert!(
        (c - cs).abs() <= 2.0,
        "frame 4's reflection is at x = {c:.2} px, the still's at {cs:.2} px (frame 0's at {first:.2})"
    );
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.10,
        "frame 4's glossy means are {r:.4} of its still's"
    );
}

/// A ball (scale 0.15) at height 2 near a corner of a 20 × 20 floor, moving 1 unit in z over frames
/// 0–2, under a low directional light (direction [−4, −1, 0]); a narrow camera (fov 14°, 96 × 72)
/// sees its long shadow but not the ball, so frames keep pixels of the frame before. `pm`'s frame 2
/// has no pixel differing from the still's by more than 0.05 (the most two stills of other seeds
/// differ by: 0.048), while it keeps some pixels (`pixels_kept` 1728 of 6912). Measured: no pixel
/// differs by more than 1e-4. Kept pixels whose shadow rays were modelled as ending at one far
/// point, not parallel, showed the shadows of frames 0 and 1 and missed part of frame 2's: 50
/// pixels off by more than 0.05 (up to 0.139), 6864 pixels kept.
#[test]
fn kept_pixels_show_a_moving_shadow_from_a_directional_light() {
    let ball = moving_ball(0.15, [8.0, 2.0, 7.0], [8.0, 2.0, 8.0], 2);
    let scene = format!(
        "version = 1\n[animation]\nframes = 3\n[camera]\neye = [1.0, 20.0, 29.5]\n\
         target = [1.0, 0.0, 7.5]\nfov = 14.0\nwidth = 96\nheight = 72\n[[mesh]]\n\
         obj = \"floor.obj\"\n{ball}[[light]]\ntype = \"directional\"\n\
         direction = [-4.0, -1.0, 0.0]\nirradiance = [3.0, 3.0, 3.0]\n[render]\nseed = 0\n"
    );
    let d = folder(&scene);
    let stats = out(d.path(), "f-####.json");
    let (frame, still) = frame_and_still(d.path(), 2, &["--stats", &stats]);
    let kept = json(&out(d.path(), "f-0002.json"))["frame"]["pixels_kept"]
        .as_u64()
        .unwrap_or(0);
    let (a, b) = (layer(&frame, None), layer(&still, None));
    let diffs: Vec<f32> = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| ((*x - *y).element_sum() / 3.0).abs())
        .collect();
    let wrong = diffs.iter().filter(|&&v| v > 0.05).count();
    let worst = diffs.iter().copied().fold(0.0f32, f32::max);
    eprintln!(
        "[sun shadow] frame 2: {kept} pixels kept, {wrong} pixels off by more than 0.05, \
         most {worst:.4}"
    );
    assert!(kept > 0, "frame 2 kept no pixel: the test checks nothing");
    assert_eq!(
        wrong, 0,
        "{wrong} pixels of frame 2 differ from the still's by more than 0.05 (most {worst:.4})"
    );
}

// ---------------------------------------------------------------------------------------------------
// Statistics of frames that show the frame before's image.

/// The blocked-spot scene with its keys ending at frame 2, rendered with `--stats out/f-####.json`:
/// frames 3 and 4 show frame 2's image, and their statistics report no temporal counts and no
/// phase times (fill, photons, temporal update); the summary out/f-sequence.json has
/// `records_regathered`, `records_replaced` and `records_carried` equal to the sums over the frames
/// rendered (0–2), `records_dropped` the sum of the frames' (view drops) and `records_gone` that of
/// theirs. Measured: frames 0–2 regathered 180 records, replaced 179, carried 2; 0 dropped, 7 gone;
/// the summary says the same. Reused frames repeated frame 2's counts and times (frame 3:
/// `records_regathered` 43), so the summary counted frame 2 three times (`records_regathered` 163
/// against 77 over frames 0–2, `records_replaced` 140 against 68, `records_carried` 19 against 7),
/// and its `records_dropped` (11, against 0 view drops) held the gone records, with no
/// `records_gone`.
#[test]
fn frames_that_reuse_the_image_report_no_work_of_their_own() {
    let ball = moving_ball(0.1, [0.682, 1.708, -0.1], [0.682, 1.708, 0.42], 2);
    let lights = "[[light]]\ntype = \"spot\"\nposition = [0.9, 1.8, 0.5]\n\
                  target = [-1.0, 1.0, -0.2]\nintensity = [30.0, 30.0, 30.0]\ncone_angle = 12.0\n\
                  falloff_start = 10.0\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.9, 0.0]\n\
                  intensity = [2.0, 2.0, 2.0]\n";
    let scene = dark_box(5, &ball, lights, "")
        .replace("width = 48", "width = 32")
        .replace("height = 36", "height = 24");
    let d = folder(&scene);
    let (images, stats) = (out(d.path(), "f-####.exr"), out(d.path(), "f-####.json"));
    render_ok(d.path(), &["-o", &images, "--stats", &stats]);
    let frames: Vec<serde_json::Value> = (0..5)
        .map(|f| json(&out(d.path(), &format!("f-{f:04}.json"))))
        .collect();
    let reused = |fr: &serde_json::Value| {
        fr["frame"]["image"]
            .as_str()
            .is_some_and(|s| s.contains("nothing changed"))
    };
    let shown: Vec<bool> = frames.iter().map(reused).collect();
    assert_eq!(
        shown,
        [false, false, false, true, true],
        "frames 3 and 4 (after the last key) should show frame 2's image"
    );
    let summary = json(&out(d.path(), "f-sequence.json"));
    let sum = |k: &str| -> u64 {
        frames
            .iter()
            .filter(|fr| !reused(fr))
            .map(|fr| fr["frame"][k].as_u64().unwrap_or(0))
            .sum()
    };
    eprintln!(
        "[reused frames] summary: regathered {}, replaced {}, carried {}, dropped {}, gone {}; \
         rendered frames: {}, {}, {}, {}, {}",
        summary["records_regathered"],
        summary["records_replaced"],
        summary["records_carried"],
        summary["records_dropped"],
        summary["records_gone"],
        sum("records_regathered"),
        sum("records_replaced"),
        sum("records_carried"),
        sum("records_dropped"),
        sum("records_gone"),
    );
    let counts = [
        "records_regathered",
        "records_replaced",
        "records_carried",
        "records_kept",
        "records_moved",
        "records_gone",
    ];
    let times = ["fill_cache_s", "trace_photons_s", "temporal_update_s"];
    for (f, fr) in frames.iter().enumerate().skip(3) {
        for k in counts {
            let v = fr["frame"][k].as_u64().unwrap_or(0);
            assert_eq!(v, 0, "frame {f} (image reused) reports {k} = {v}");
        }
        for k in times {
            let v = fr["time"][k].as_f64().unwrap_or(0.0);
            assert!(v == 0.0, "frame {f} (image reused) reports {k} = {v}");
        }
    }
    assert!(
        sum("records_regathered") > 0,
        "no record gathered again: the test checks nothing"
    );
    for k in [
        "records_regathered",
        "records_replaced",
        "records_carried",
        "records_dropped",
        "records_gone",
    ] {
        assert_eq!(
            summary[k].as_u64(),
            Some(sum(k)),
            "the summary's {k} is not the sum over the frames rendered"
        );
    }
}

/// A closed grey room (the cube, seen from inside) lit by a point light keyed from [2, 2, 2] to
/// [2.6, 1.8, 2.213] (the same luminance) over frames 0–2, then held, while a tiny ball creeps along
/// the floor until frame 8 (so that the later frames are rendered, not copied). A record's lifespan
/// after the light's change came from its luminance's rate of change, about zero: it went on
/// following its per-channel temporal gradient for 8 frames, frame 5's indirect 1.047, 0.974, 1.018
/// of the still's (pink disks, one per record, red up to 1.37). Now each channel of frame 5's
/// `indirect` mean is within 1.5 % of the still's (measured 0.9978, 0.9979, 0.9981; a still of seed
/// 1 is within 0.3 %; sequence and still at seeds 1, 2 and on SSE4.2 0.9975–0.9984, the bound 6×
/// the worst and a third of the defect's 4.7 %).
#[test]
fn records_stop_changing_hue_when_the_light_stops() {
    let scene = format!(
        "version = 1\n[animation]\nframes = 9\n[camera]\neye = [0.0, 1.0, 0.95]\n\
         target = [0.0, 0.8, 0.0]\nfov = 60.0\nwidth = 64\nheight = 48\n[[mesh]]\n\
         obj = \"cube.obj\"\ntranslate = [0.0, 1.0, 0.0]\n{}[[light]]\ntype = \"point\"\n\
         position = [0.0, 1.8, 0.0]\nintensity = [2.0, 2.0, 2.0]\n[[light.key]]\nframe = 0\n\
         intensity = [2.0, 2.0, 2.0]\n[[light.key]]\nframe = 2\nintensity = [2.6, 1.8, 2.213]\n\
         [render]\nseed = 0\n",
        moving_ball(0.03, [-0.8, 0.03, -0.8], [-0.7, 0.03, -0.8], 8)
    );
    let d = folder(&scene);
    let (frame, still) = frame_and_still(d.path(), 5, &[]);
    let r = ratio(
        &layer(&frame, Some("indirect")),
        &layer(&still, Some("indirect")),
    );
    eprintln!("[hue held] frame 5 indirect / still: {r:.4}");
    assert!(
        (r - Vec3::ONE).abs().max_element() <= 0.015,
        "frame 5's indirect means are {r:.4} of its still's"
    );
}

/// The anim-ball box lit by a narrow spot at the red wall and a dim point light (`pm` chooses 1000
/// gather rays here), a ball (scale 0.1) sliding 0.0088 a frame into the spot's beam: frames 54–59
/// rendered as a sequence of their own (a chunk from frame 54). The rays chosen on the first frame
/// were forgotten on the second, chosen again on the third (pass A's records refined again in
/// rounds), forgotten again…:
/// over a long run the red of the `indirect` layer alternated by about 3 % from frame to frame where
/// the stills change by 0.3 %. Now the first frame alone chooses, and every later frame's gathers
/// (pass A's and the records' updates) take as many rays as it chose.
#[test]
fn every_frame_gathers_with_the_rays_the_first_chose() {
    let ball = moving_ball(0.1, [0.682, 1.708, -0.1], [0.682, 1.708, 0.42], 59);
    let lights = "[[light]]\ntype = \"spot\"\nposition = [0.9, 1.8, 0.5]\n\
                  target = [-1.0, 1.0, -0.2]\nintensity = [30.0, 30.0, 30.0]\ncone_angle = 12.0\n\
                  falloff_start = 10.0\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.9, 0.0]\n\
                  intensity = [2.0, 2.0, 2.0]\n";
    let d = folder(&dark_box(100, &ball, lights, ""));
    let (pattern, stats) = (out(d.path(), "f-####.exr"), out(d.path(), "f-####.json"));
    render_ok(
        d.path(),
        &[
            "-o", &pattern, "--stats", &stats, "--frames", "54..59", "--chunk", "54",
        ],
    );
    let gather = |f: u32| json(&out(d.path(), &format!("f-{f:04}.json")))["gather"].clone();
    let chosen = gather(54)["rays_chosen"]
        .as_u64()
        .expect("the first frame chooses its rays");
    assert!(chosen > 250, "{}", gather(54));
    for f in 55..=59 {
        let g = gather(f);
        assert!(g.get("rays_chosen").is_none(), "frame {f} chose again: {g}");
        let (gathers, rays) = (g["gathers"].as_u64().unwrap(), g["rays"].as_u64().unwrap());
        // Each gather takes the chosen count, to within the strata's rounding (M × N ≈ rays).
        assert!(
            gathers == 0 || (rays as f64 / gathers as f64) >= 0.9 * chosen as f64,
            "frame {f}: {rays} rays in {gathers} gathers, {chosen} chosen: {g}"
        );
    }
}
