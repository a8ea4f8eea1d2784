//! `make bench`, fourth part: animated scenes. A walk through Sibenik (camera only: photon maps traced
//! once, one irradiance cache for the sequence) against still renders of its frames, and a ball
//! crossing a box (temporal caching) against an independent cache per frame: time, per-frame error
//! against stored references, and flicker (temporal relMSE, `tools/flicker.py`'s definition).
//! Printed as ratios measured in this run, never asserted.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use pmrender::converge::{rel_mse, temporal_rel_mse};
use pmrender::io::output::{read_layer, Image};
use pmrender::render::sequence::render_sequence;
use pmrender::render::{render_seen_by, NoProgress, Options};
use pmrender::scene::{self, Animation};

/// The sequence's beauty images over `frames` and its seconds (`temporal = false` in `opts` is not
/// settable here: the scene decides; see [`independent`]).
fn sequence(anim: &Animation, frames: &[u32], opts: &Options) -> (Vec<Image>, f64) {
    let range = frames[0]..=*frames.last().expect("frames");
    let mut images = Vec::new();
    let t = Instant::now();
    render_sequence(
        anim,
        range,
        opts,
        &NoProgress,
        &AtomicBool::new(false),
        &mut |f, _, out, _| {
            if frames.contains(&f) {
                images.push(out.beauty.clone());
            }
            Ok(())
        },
    )
    .expect("sequence");
    (images, t.elapsed().as_secs_f64())
}

/// Each frame rendered as a still of its own: its scene loaded (or, with `shared`, the scene of frame
/// 0, for a camera-only sequence), its photons traced, its cache filled. Time includes loading.
fn independent(
    anim: &Animation,
    frames: &[u32],
    opts: &Options,
    shared: bool,
) -> (Vec<Image>, f64) {
    let t = Instant::now();
    let first = shared.then(|| scene::load_frame(anim, frames[0]).expect("frame"));
    let images = frames
        .iter()
        .map(|&f| {
            let own;
            let scene = match &first {
                Some(s) => s,
                None => {
                    own = scene::load_frame(anim, f).expect("frame");
                    &own
                }
            };
            let camera = scene::frame_camera(anim, f).expect("camera");
            render_seen_by(
                scene,
                opts,
                Some(&camera),
                &NoProgress,
                &AtomicBool::new(false),
            )
            .expect("render")
            .0
            .beauty
        })
        .collect();
    (images, t.elapsed().as_secs_f64())
}

fn sized(w: u32, h: u32) -> Options {
    Options {
        width: Some(w),
        height: Some(h),
        ..Default::default()
    }
}

fn reference(dir: &Path, name: &str) -> Option<Image> {
    read_layer(&dir.join(name), None).ok()
}

/// The walk: the whole sequence against stills of its frames (time at the scene's size); the error
/// of frames 0, 24, 47 against path references at 160×120, of the timed frames averaged down to the
/// references' size (the target's frames), and of a sequence and stills rendered at that size.
fn walk(root: &Path) {
    let Ok(Some(anim)) = scene::load_animation(&root.join("tests/scenes/sibenik-walk.toml")) else {
        return println!("sibenik-walk: skipped (scene missing)");
    };
    let all: Vec<u32> = (0..anim.frames()).collect();
    let picks = [0u32, 24, 47];
    let (seq_big, t_seq) = sequence(&anim, &all, &Options::default());
    let (stills_big, t_still) = independent(&anim, &all, &Options::default(), true);
    println!(
        "sibenik-walk {} frames 640×480: sequence {t_seq:.1} s, stills {t_still:.1} s, sequence/stills {:.3}",
        all.len(),
        t_seq / t_still
    );
    let dir = root.join("tests/reference/sibenik-walk");
    let refs: Vec<Option<Image>> = picks
        .iter()
        .map(|f| reference(&dir, &format!("path-{f:04}.exr")))
        .collect();
    if refs.iter().any(Option::is_none) {
        return println!("sibenik-walk errors: skipped (references missing)");
    }
    let errors = |label: &str, seq: &[Image], stills: &[Image]| {
        for (i, f) in picks.iter().enumerate() {
            let r = refs[i].as_ref().expect("reference");
            let (Some(s), Some(t)) = (
                averaged_down(&seq[*f as usize], r),
                averaged_down(&stills[*f as usize], r),
            ) else {
                return println!("sibenik-walk {label}: sizes differ from the references'");
            };
            let (e_seq, e_still) = (rel_mse(&s, r), rel_mse(&t, r));
            println!(
                "sibenik-walk frame {f} {label}: relMSE sequence {e_seq:.5}, still {e_still:.5}, ratio {:.3}",
                e_seq / e_still
            );
        }
    };
    errors("640×480 averaged to 160×120", &seq_big, &stills_big);
    drop((seq_big, stills_big));
    let small = sized(160, 120);
    let (seq, _) = sequence(&anim, &all, &small);
    let (stills, _) = independent(&anim, &all, &small, true);
    errors("rendered at 160×120", &seq, &stills);
}

/// `img` averaged over blocks of pixels down to `like`'s size (a box filter, as a pixel of `like` is
/// the mean over its area); `None` unless `img`'s size is a whole multiple of it.
fn averaged_down(img: &Image, like: &Image) -> Option<Image> {
    let (w, h) = (like.width, like.height);
    if w == 0 || h == 0 || !img.width.is_multiple_of(w) || !img.height.is_multiple_of(h) {
        return None;
    }
    let (kx, ky) = (img.width / w, img.height / h);
    let mut out = like.clone();
    for y in 0..h {
        for x in 0..w {
            let mut sum = glam::Vec3::ZERO;
            for dy in 0..ky {
                for dx in 0..kx {
                    sum += img.pixels[((y * ky + dy) * img.width + x * kx + dx) as usize];
                }
            }
            out.pixels[(y * w + x) as usize] = sum / (kx * ky) as f32;
        }
    }
    Some(out)
}

/// The ball: temporal caching against an independent cache per frame — time over the whole sequence
/// at the scene's size, error and flicker at the reference's size over its frames.
fn ball(root: &Path) {
    let dir = root.join("tests/reference/anim-ball");
    let Ok(Some(anim)) = scene::load_animation(&root.join("scenes/anim-ball.toml")) else {
        return println!("anim-ball: skipped (scene missing)");
    };
    let all: Vec<u32> = (0..anim.frames()).collect();
    // The machine's speed drifts by 10 % and more over minutes: the two kinds of run alternate, twice
    // each, and the fastest of each kind is compared.
    let (mut t_seq, mut t_ind) = (Vec::new(), Vec::new());
    for _ in 0..2 {
        t_seq.push(sequence(&anim, &all, &Options::default()).1);
        t_ind.push(independent(&anim, &all, &Options::default(), false).1);
    }
    let fastest = |t: &[f64]| t.iter().copied().fold(f64::INFINITY, f64::min);
    let (seq_s, ind_s) = (fastest(&t_seq), fastest(&t_ind));
    println!(
        "anim-ball {} frames at the scene's size: temporal {seq_s:.2} s, independent {ind_s:.2} s, \
         speed-up {:.2} (fastest of two alternating runs each: {:.2} / {:.2} s and {:.2} / {:.2} s)",
        all.len(),
        ind_s / seq_s,
        t_seq[0],
        t_seq[1],
        t_ind[0],
        t_ind[1],
    );
    let refs: Vec<(u32, Image)> = all
        .iter()
        .filter_map(|&f| Some((f, reference(&dir, &format!("frame-{f:04}.exr"))?)))
        .collect();
    let Some(first) = refs.first() else {
        return println!("anim-ball errors: skipped (references missing)");
    };
    let (w, h) = (first.1.width, first.1.height);
    let opts = sized(w, h);
    let frames: Vec<u32> = refs.iter().map(|(f, _)| *f).collect();
    let span: Vec<u32> = (frames[0]..=*frames.last().expect("frames")).collect();
    let pick = |images: Vec<Image>| -> Vec<Image> {
        frames
            .iter()
            .map(|f| images[(*f - frames[0]) as usize].clone())
            .collect()
    };
    let seq = pick(sequence(&anim, &span, &opts).0);
    let ind = pick(independent(&anim, &span, &opts, false).0);
    let reference: Vec<Image> = refs.into_iter().map(|(_, r)| r).collect();
    let mean_err = |images: &[Image]| {
        images
            .iter()
            .zip(&reference)
            .map(|(i, r)| rel_mse(i, r))
            .sum::<f64>()
            / images.len() as f64
    };
    let (f_seq, f_ind) = (
        temporal_rel_mse(&seq, &reference),
        temporal_rel_mse(&ind, &reference),
    );
    println!(
        "anim-ball {} reference frames {}×{}: flicker {f_seq:.2e} temporal vs {f_ind:.2e} independent \
         (ratio {:.3}); mean relMSE {:.5} vs {:.5}",
        frames.len(),
        w,
        h,
        f_seq / f_ind,
        mean_err(&seq),
        mean_err(&ind)
    );
}

/// `cargo bench --bench animation [-- ball|walk]`: both by default, or the one named.
fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let names: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wanted = |name: &str| names.is_empty() || names.iter().any(|n| n == name);
    if wanted("ball") {
        ball(root);
    }
    if wanted("walk") {
        walk(root);
    }
}
