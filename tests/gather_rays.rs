//! `pm` chooses its final gathers' rays from the noise of pass A's gathers (`render::gather_rays`)
//! when the scene gives no `[render.icache] rays`: more where that noise would show in the pixels (the
//! blinds room's walls under bright ceiling patches), the base 250 where it would not. These tests
//! check the choice on two shipped scenes, that the records' further rounds are worth what a gather of
//! as many rays is, and that the choice keeps the image independent of the thread count.

mod common;

use common::{block_means, mean, read, rel_mse, repo, run};

fn render(
    scene: &str,
    size: [u32; 2],
    seed: u32,
    extra: &[&str],
    dir: &std::path::Path,
    tag: &str,
) -> (std::path::PathBuf, serde_json::Value) {
    let out = dir.join(format!("{tag}.exr"));
    let stats = dir.join(format!("{tag}.json"));
    let (w, h, seed) = (size[0].to_string(), size[1].to_string(), seed.to_string());
    let scene = repo().join(scene);
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--width",
        &w,
        "--height",
        &h,
        "--seed",
        &seed,
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    (
        out,
        serde_json::from_str(&std::fs::read_to_string(stats).unwrap()).unwrap(),
    )
}

/// A copy of a shipped scene with `[render.icache] rays` given (the models' paths made absolute).
fn with_rays(scene: &str, rays: u32, dir: &std::path::Path) -> String {
    let text = std::fs::read_to_string(repo().join(scene)).unwrap();
    let models = repo().join("scenes/models");
    let text = text.replace("\"models/", &format!("\"{}/", models.display()));
    let path = dir.join(format!("rays{rays}.toml"));
    std::fs::write(&path, format!("{text}\n[render.icache]\nrays = {rays}\n")).unwrap();
    path.to_str().unwrap().to_string()
}

/// At the references' sizes: the blinds room's pass-A gathers predict a relative variance of 1.0e-3 in
/// its pixels at 250 rays (ten times the target), so its records gather 1000; interior-diffuse's
/// 6.9e-5 is within the target and stays at 250. A scene that gives `rays` gets what it gives.
#[test]
fn rays_follow_what_the_gathers_see() {
    let d = tempfile::tempdir().unwrap();
    let (_, blinds) = render(
        "scenes/blinds-room.toml",
        [128, 128],
        0,
        &[],
        d.path(),
        "blinds",
    );
    let g = &blinds["gather"];
    assert_eq!(g["rays_chosen"].as_u64(), Some(1000), "{g}");
    assert!(g["predicted_noise"].as_f64().unwrap() > 4e-4, "{g}");
    let (_, interior) = render(
        "scenes/interior-diffuse.toml",
        [160, 120],
        0,
        &[],
        d.path(),
        "interior",
    );
    let g = &interior["gather"];
    assert_eq!(g["rays_chosen"].as_u64(), Some(250), "{g}");
    assert!(g["predicted_noise"].as_f64().unwrap() < 1e-4, "{g}");
    let given = with_rays("scenes/blinds-room.toml", 300, d.path());
    let (_, fixed) = render(&given, [64, 64], 0, &[], d.path(), "given");
    assert!(
        fixed["gather"].get("rays_chosen").is_none(),
        "{}",
        fixed["gather"]
    );
}

/// A dark room lit through a small spot-lit patch (image mean 0.018): its gathers see the patch in a
/// few rays each (their own noise 10–30 %), which an absolute floor of the relMSE called calm (predicted
/// 7e-5, 250 rays). The floor scales with the image's brightness: 1000 rays at every seed, which is
/// what catches that defect. Against Mitsuba, luminance mean over the reference's, seeds 0–7: with
/// 1000 rays +0.34…+1.02 % (mean +0.51 %, one seed's standard deviation 0.24 %, worst channel
/// +1.24 %); with 250 rays (the defect) +0.68 % in the mean, standard deviation 0.61 %: the defect
/// shows in the spread more than in the mean. The bounds: each seed's worst channel within 2 %, the
/// mean of seeds 0–3 within 1 % (0.5 % above the measured mean, four of its standard deviations). The
/// choice does not depend on the lights' scale in a dark image: the spot at half its intensity
/// predicts the same noise.
#[test]
fn a_dark_scene_chooses_its_rays_as_a_bright_one_would() {
    let d = tempfile::tempdir().unwrap();
    let scene = "tests/scenes/dark-spot-room.toml";
    let reference = read(&repo().join("tests/reference/dark-spot-room-path.exr"));
    let r = mean(&reference);
    let lum = |v: glam::Vec3| 0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z;
    let seeds = [0, 1, 2, 3];
    let mut ratio_sum = 0.0;
    let mut predicted = 0.0;
    for seed in seeds {
        let (out, stats) = render(scene, [64, 64], seed, &[], d.path(), &format!("s{seed}"));
        let g = &stats["gather"];
        assert_eq!(g["rays_chosen"].as_u64(), Some(1000), "seed {seed}: {g}");
        if seed == 1 {
            predicted = g["predicted_noise"].as_f64().unwrap();
        }
        let m = mean(&read(&out));
        let worst = (m / r - glam::Vec3::ONE).abs().max_element();
        eprintln!(
            "[gather rays] dark room seed {seed}: mean / reference {}",
            m / r
        );
        assert!(worst < 0.02, "seed {seed}: mean {m} against {r}");
        ratio_sum += lum(m) / lum(r);
    }
    let ratio = ratio_sum / seeds.len() as f32;
    assert!((ratio - 1.0).abs() < 0.01, "mean ratio {ratio}");
    // The same room with the spot at half its intensity (seed 1, as `predicted` above).
    let text = std::fs::read_to_string(repo().join(scene))
        .unwrap()
        .replace(
            "\"../media_matrix/",
            &format!("\"{}/", repo().join("tests/media_matrix").display()),
        )
        .replace("intensity = [8, 8, 8]", "intensity = [4, 4, 4]");
    assert!(text.contains("[4, 4, 4]"));
    let half = d.path().join("half.toml");
    std::fs::write(&half, text).unwrap();
    let (_, stats) = render(half.to_str().unwrap(), [64, 64], 1, &[], d.path(), "half");
    let p = stats["gather"]["predicted_noise"].as_f64().unwrap();
    assert!(
        (p / predicted - 1.0).abs() < 1e-3,
        "{p} at half intensity against {predicted}"
    );
}

/// The blinds room at 128², seeds 0 and 1, 8×8-block relMSE against the Mitsuba reference: with the
/// rays chosen (250, then three more rounds) as good as gathers of 1000 rays from the start, and better
/// than gathers of 500 (measured over seeds 0–4: 0.000251, 0.000256, 0.000394). Before the rounds'
/// jitter was scrambled from one sequence (four independent 250-ray gathers) it was 0.000314.
#[test]
fn rounds_are_worth_a_gather_of_as_many_rays() {
    let d = tempfile::tempdir().unwrap();
    let reference = read(&repo().join("tests/reference/blinds-room-path.exr"));
    let block =
        |p: &std::path::Path| rel_mse(&block_means(&read(p), 8), &block_means(&reference, 8));
    let mut err = [0.0f64; 3];
    for seed in [0, 1] {
        let (auto, _) = render(
            "scenes/blinds-room.toml",
            [128, 128],
            seed,
            &[],
            d.path(),
            &format!("auto{seed}"),
        );
        err[0] += block(&auto);
        for (k, rays) in [(1, 1000), (2, 500)] {
            let scene = with_rays("scenes/blinds-room.toml", rays, d.path());
            let (out, _) = render(
                &scene,
                [128, 128],
                seed,
                &[],
                d.path(),
                &format!("r{rays}-{seed}"),
            );
            err[k] += block(&out);
        }
    }
    eprintln!("[gather rays] blinds room block relMSE (sum of 2 seeds): chosen {:.6}, 1000 rays {:.6}, 500 rays {:.6}", err[0], err[1], err[2]);
    assert!(
        err[0] < 1.15 * err[1],
        "chosen {} against 1000 rays {}",
        err[0],
        err[1]
    );
    assert!(
        err[0] < 0.85 * err[2],
        "chosen {} against 500 rays {}",
        err[0],
        err[2]
    );
}

/// The choice and the further rounds do not depend on the thread count: the blinds room at 48² (1000 rays
/// chosen) is the same to the last bit with one and two threads.
#[test]
fn chosen_rays_are_identical_with_one_and_two_threads() {
    let d = tempfile::tempdir().unwrap();
    let (one, s1) = render(
        "scenes/blinds-room.toml",
        [48, 48],
        3,
        &["--threads", "1", "--spp", "8"],
        d.path(),
        "t1",
    );
    let (two, s2) = render(
        "scenes/blinds-room.toml",
        [48, 48],
        3,
        &["--threads", "2", "--spp", "8"],
        d.path(),
        "t2",
    );
    assert!(s1["gather"]["rays_chosen"].as_u64().unwrap() > 250);
    assert_eq!(
        s1["gather"]["predicted_noise"],
        s2["gather"]["predicted_noise"]
    );
    assert_eq!(std::fs::read(one).unwrap(), std::fs::read(two).unwrap());
}
