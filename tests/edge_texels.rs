//! Edge texels: a final-gather ray that lands on an atlas texel crossed by a shadow's edge takes the direct
//! light of the point it landed on, not the texel middle's.
//!
//! A room whose roof has a 50 cm slit lets the sun draw a sharp strip on the floor; everything else in
//! the room is lit by that strip's bounce. With coarse texels (`precompute_every = 1000`, ~0.5 m) a
//! texel middle was either in the strip or not, so the whole texel was lit or dark and the light the
//! strip bounces was off by whatever the texels' alignment made it: `pm` 0.952 on the shaded pixels,
//! 0.977 on the image (seed 0; seed 0 now gives 1.012 / 1.003). The same fault left the shaded
//! arcades of Sponza up to 18 % dark at the default texel size; with edge texels 3 %. `pm` and
//! `pm-fg` against `path` at 1024 spp, on the pixels whose direct light is zero. (A 20 cm slit on
//! these texels is narrower than the 2 × 2 probes of a texel can see: −7.6 %.)
//!
//! One seed's shaded mean is as far from the truth as the fault: over seeds 0–9 (against seed 0's
//! `path`, whose own seed-to-seed spread there is 0.5 %) `pm` 0.953–1.012 (mean 0.986, sd 1.9 %) and
//! `pm-fg` 0.935–0.984 (mean 0.963, sd 1.8 %; its image 0.971–1.005, mean 0.990), so a single seed
//! held to 3 % failed at seed 1 (`pm` 0.958). The test holds the mean of seeds 0–3 of each method
//! (sd about 1 %): measured `pm` 0.993 shaded / 0.995 image (seeds 4–7: 0.983 shaded), `pm-fg`
//! 0.969 / 0.992 (seeds 4–7: 0.961; SSE4.2's kernels gave the same figures). Bounds: `pm`
//! 4 % on the shaded pixels and 2 % on the image, `pm-fg` 7 % and 3 %: at least 2.5 sd beyond the
//! measured means.

mod common;
mod stability_scenes;

use common::{mean, read};
use glam::Vec3;
use pmrender::io::output::{read_layer, Image};
use stability_scenes::{toml, v, write, Obj, MTL};

const SIZE: u32 = 64;

fn scene(extra: &str) -> tempfile::TempDir {
    let mut o = Obj::new();
    // Floor, back and side walls facing in; no front, no roof but two slabs with a slit between them.
    o.cuboid(
        "wall",
        v(-1.0, 0.0, -1.0),
        v(1.0, 2.0, 1.0),
        true,
        &["+z", "+y"],
    );
    o.cuboid("wall", v(-1.0, 2.0, -1.0), v(-0.25, 2.05, 1.0), false, &[]);
    o.cuboid("wall", v(0.25, 2.0, -1.0), v(1.0, 2.05, 1.0), false, &[]);
    let sun = "[[light]]\ntype = \"directional\"\ndirection = [0.35, -1.0, 0.2]\nirradiance = [8.0, 8.0, 8.0]\n";
    let settings =
        format!("{sun}[render.photons]\nglobal = 100000\nprecompute_every = 1000\n{extra}");
    write(
        &o,
        MTL,
        &toml(
            v(0.0, 1.0, 3.2),
            v(0.0, 0.9, 0.0),
            50.0,
            (SIZE, SIZE),
            &settings,
        ),
    )
}

/// The seeds whose `pm` and `pm-fg` renders are averaged (see the module's note).
const SEEDS: [&str; 4] = ["0", "1", "2", "3"];

/// Renders `dir/scene.toml` with `method` at `spp` and `seed`: (beauty, `direct` layer, statistics).
fn render(
    dir: &std::path::Path,
    method: &str,
    spp: u32,
    seed: &str,
) -> (Image, Option<Image>, serde_json::Value) {
    let out = dir.join(format!("{method}-{seed}.exr"));
    let stats = dir.join(format!("{method}-{seed}.json"));
    let spp = spp.to_string();
    let args = [
        "render",
        "scene.toml",
        "-o",
        out.to_str().unwrap(),
        "--method",
        method,
        "--spp",
        &spp,
        "--quiet",
        "--stats",
        stats.to_str().unwrap(),
        "--seed",
        seed,
    ];
    let r = std::process::Command::new(common::bin())
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        r.status.success(),
        "{method}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
    let json = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    (read(&out), read_layer(&out, Some("direct")).ok(), json)
}

/// Mean of `img` over the pixels where `direct` is zero (lit only by the strip's bounce).
fn shaded_mean(img: &Image, direct: &Image) -> Vec3 {
    let px: Vec<Vec3> = img
        .pixels
        .iter()
        .zip(&direct.pixels)
        .filter(|(_, d)| d.max_element() <= 0.0)
        .map(|(p, _)| *p)
        .collect();
    assert!(
        px.len() > (SIZE * SIZE / 2) as usize,
        "most of the room is out of the sun: {} pixels",
        px.len()
    );
    px.iter().copied().sum::<Vec3>() / px.len() as f32
}

#[test]
fn light_bounced_by_a_sharp_sun_strip_is_right_with_coarse_texels() {
    let dir = scene("");
    let (reference, _, _) = render(dir.path(), "path", 1024, "0");
    for (method, spp, shaded_bound, image_bound) in
        [("pm", 32, 0.04, 0.02), ("pm-fg", 4, 0.07, 0.03)]
    {
        let (mut shaded, mut whole) = (0.0, 0.0);
        for seed in SEEDS {
            let (img, direct, stats) = render(dir.path(), method, spp, seed);
            let direct = direct.expect("direct layer");
            let s = shaded_mean(&img, &direct).element_sum()
                / shaded_mean(&reference, &direct).element_sum();
            let w = mean(&img).element_sum() / mean(&reference).element_sum();
            let edges = stats["photons"]["atlas_edge_texels"].as_f64().unwrap();
            eprintln!(
                "[edge texels] {method} seed {seed}: shaded pixels {s:.4}, image {w:.4}, edge texels {edges}"
            );
            assert!(
                edges > 0.0,
                "{method}: no edge texel on a floor crossed by a sun strip"
            );
            shaded += s / SEEDS.len() as f32;
            whole += w / SEEDS.len() as f32;
        }
        assert!(
            (shaded - 1.0).abs() < shaded_bound,
            "{method}: shaded pixels off by {:+.1} % (mean of seeds {SEEDS:?})",
            (shaded - 1.0) * 100.0
        );
        assert!(
            (whole - 1.0).abs() < image_bound,
            "{method}: image off by {:+.1} % (mean of seeds {SEEDS:?})",
            (whole - 1.0) * 100.0
        );
    }
}
