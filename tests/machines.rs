//! What a render owes to the machine it runs on. Embree picks its ray kernels by the CPU's instruction
//! set, and its kernels find different triangles on edges; pmrender pins them (AVX2 where the CPU has
//! it, SSE4.2 before it) so that Intel and AMD machines with or without AVX-512 render the same image,
//! and `PMRENDER_EMBREE_ISA` forces them, to render as another machine would (`make test-isa` runs
//! the whole suite so). What is identical across machines and what is not: `docs/determinism.md`.

mod common;

use std::process::Command;

use common::{bin, mean, read, rel_mse, repo};
use pmrender::io::output::Image;

/// Renders cornell-caustics at 160×128 with `PMRENDER_EMBREE_ISA` set to `isa` (unset: `None`), the
/// environment's own value never inherited; returns the exit status, stderr, image and statistics.
fn render_with(
    isa: Option<&str>,
    dir: &std::path::Path,
    tag: &str,
) -> (Option<i32>, String, Option<(Image, serde_json::Value)>) {
    let scene = repo().join("scenes/cornell-caustics.toml");
    render_scene_with(
        &scene,
        &["--width", "160", "--height", "128"],
        isa,
        dir,
        tag,
    )
}

/// [`render_with`] for `scene` with `args`.
fn render_scene_with(
    scene: &std::path::Path,
    args: &[&str],
    isa: Option<&str>,
    dir: &std::path::Path,
    tag: &str,
) -> (Option<i32>, String, Option<(Image, serde_json::Value)>) {
    let out = dir.join(format!("{tag}.exr"));
    let stats = dir.join(format!("{tag}.json"));
    let mut cmd = Command::new(bin());
    cmd.env_remove("PMRENDER_EMBREE_ISA");
    if let Some(isa) = isa {
        cmd.env("PMRENDER_EMBREE_ISA", isa);
    }
    let r = cmd
        .args(["render", scene.to_str().unwrap()])
        .args(["-o", out.to_str().unwrap()])
        .args(["--stats", stats.to_str().unwrap()])
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    let made = r.status.success().then(|| {
        let json = std::fs::read_to_string(&stats).unwrap();
        (read(&out), serde_json::from_str(&json).unwrap())
    });
    (r.status.code(), stderr, made)
}

/// The kernels a render ran, from its statistics.
fn isa_of(stats: &serde_json::Value) -> &str {
    stats["scene"]["ray_isa"].as_str().unwrap()
}

/// Left to itself the renderer runs the pinned kernels, whatever newer ones the CPU has.
#[test]
fn the_ray_kernels_are_pinned_whatever_the_cpu_offers() {
    let d = tempfile::tempdir().unwrap();
    let (code, stderr, made) = render_with(None, d.path(), "pinned");
    assert_eq!(code, Some(0), "{stderr}");
    let (_, stats) = made.unwrap();
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
        assert_eq!(isa_of(&stats), if avx2 { "avx2" } else { "sse4.2" });
    }
    #[cfg(not(target_arch = "x86_64"))]
    assert_eq!(isa_of(&stats), "Embree's choice");
}

/// How far SSE4.2's image mean may lie from the pinned kernels' (worst channel): measured at seeds
/// 0–3, 0.012–0.040 %, where one seed's mean lies up to 0.15 % from another's.
const MEAN_BOUND: f32 = 0.005;
/// How far SSE4.2's relMSE against Mitsuba may lie from the pinned kernels' (relative): measured at
/// seeds 0–3, −1.2 … +2.9 %.
const ERROR_BOUND: f64 = 0.15;

/// SSE4.2's kernels (a machine without AVX2) render the same scene within its noise: the image mean
/// within [`MEAN_BOUND`] of the pinned kernels' and the error against Mitsuba within [`ERROR_BOUND`]
/// of theirs.
#[test]
fn forced_kernels_render_the_same_scene_within_its_noise() {
    let d = tempfile::tempdir().unwrap();
    let (code, stderr, made) = render_with(Some("sse4.2"), d.path(), "sse");
    assert_eq!(code, Some(0), "{stderr}");
    let (sse, stats) = made.unwrap();
    assert_eq!(isa_of(&stats), "sse4.2");
    let (_, _, made) = render_with(None, d.path(), "pinned");
    let (pinned, _) = made.unwrap();
    let reference = common::cornell_reference();
    let (m_sse, m_pinned) = (mean(&sse), mean(&pinned));
    let diff = ((m_sse - m_pinned) / m_pinned).abs().max_element();
    let (e_sse, e_pinned) = (rel_mse(&sse, &reference), rel_mse(&pinned, &reference));
    eprintln!("[kernels] mean differs by {diff:.5}; relMSE {e_sse:.5} (sse4.2), {e_pinned:.5}");
    assert!(diff < MEAN_BOUND, "means {m_sse} against {m_pinned}");
    assert!(
        (e_sse / e_pinned - 1.0).abs() < ERROR_BOUND,
        "relMSE {e_sse} against {e_pinned}"
    );
}

/// Two media sharing a face (two coincident boundary triangles, the tie Embree's kernels break each
/// their own way): `pm` on SSE4.2's kernels within 0.5 % of the pinned kernels' image mean. Measured
/// −0.010 % (SSE4.2) and −0.055 % (AVX2) against Mitsuba; it was −2.5 % on SSE4.2 while the media's
/// parity rays went through one BVH of every boundary and met only one of the two faces.
#[test]
fn forced_kernels_agree_where_two_media_share_a_face() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("tests/media_matrix/touching-media.toml");
    let mean_of = |isa, tag| {
        let (code, stderr, made) =
            render_scene_with(&scene, &["--method", "pm"], isa, d.path(), tag);
        assert_eq!(code, Some(0), "{stderr}");
        mean(&made.unwrap().0)
    };
    let (sse, pinned) = (mean_of(Some("sse4.2"), "sse"), mean_of(None, "pinned"));
    let diff = ((sse - pinned) / pinned).abs().max_element();
    eprintln!("[kernels] touching media: means differ by {diff:.5}");
    assert!(diff < 0.005, "means {sse} against {pinned}");
}

/// An instruction set Embree does not know is the user's mistake: exit 2, one line naming the
/// variable, nothing written.
#[test]
fn an_unknown_instruction_set_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let (code, stderr, _) = render_with(Some("avx3"), d.path(), "bad");
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("PMRENDER_EMBREE_ISA"), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
}
