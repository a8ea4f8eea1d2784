//! `make bench`, third part: glossy scenes as authored (Sponza as a Blender export, whose lobes are
//! sampled, and as the conference room authors its materials, whose lobes the radiance cache serves). For each, `pm` with its defaults against the
//! same scene with its materials diffuse (its MTL as authored: time ratio), and against its independent reference:
//! image mean error, relMSE, and `path`'s relMSE at the same wall time (the ratio `pm` must keep at 5×
//! or more), and Sibenik's polished floor against its diffuse floor (each against its own reference, over
//! the floor's pixels only). Printed, never asserted. `cargo bench --bench glossy -- NAME` runs the
//! parts whose name holds NAME.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use pmrender::io::output::Image;
use pmrender::render::{render, NoProgress, Options};
use pmrender::scene::{self, Method, Scene};

/// Renders `scene` with `method` at `size`, `spp` (None: the defaults): the beauty and the seconds.
fn run(scene: &Scene, method: Method, size: (u32, u32), spp: Option<u32>) -> (Image, f64) {
    let opts = Options {
        method: Some(method),
        spp,
        width: Some(size.0),
        height: Some(size.1),
        ..Default::default()
    };
    let t = Instant::now();
    let (out, _) = render(scene, &opts, &NoProgress, &AtomicBool::new(false)).expect("render");
    (out.beauty, t.elapsed().as_secs_f64())
}

fn mean(img: &Image) -> f64 {
    img.pixels
        .iter()
        .map(|p| (p.x + p.y + p.z) as f64)
        .sum::<f64>()
        / img.pixels.len() as f64
}

/// `pm`'s time on the glossy scene over its time on the diffuse twin, at `size`.
fn time_ratio(root: &Path, name: &str, glossy: &str, diffuse: &str, size: (u32, u32)) {
    let (Ok(g), Ok(d)) = (
        scene::load(&root.join(glossy)),
        scene::load(&root.join(diffuse)),
    ) else {
        return println!("{name}: skipped (scene missing)");
    };
    let (_, t_d) = run(&d, Method::Pm, size, None);
    let (_, t_g) = run(&g, Method::Pm, size, None);
    println!(
        "{name} {}×{}: pm glossy {t_g:.2} s, diffuse {t_d:.2} s, ratio {:.2}",
        size.0,
        size.1,
        t_g / t_d
    );
}

/// `pm` against the scene's reference, and `path` at the same wall time.
fn against_reference(root: &Path, name: &str, toml: &str) {
    let reference = match pmrender::io::output::read_layer(
        &root.join(format!("tests/reference/{name}-path.exr")),
        None,
    ) {
        Ok(r) => r,
        Err(e) => return println!("{name}: skipped ({e})"),
    };
    let Ok(scene) = scene::load(&root.join(toml)) else {
        return println!("{name}: skipped (scene missing)");
    };
    let size = (reference.width, reference.height);
    let (pm, t_pm) = run(&scene, Method::Pm, size, None);
    let e_pm = pmrender::converge::rel_mse(&pm, &reference);
    // path's time per sample from a short run, then the spp that takes pm's time.
    let (_, t4) = run(&scene, Method::Path, size, Some(4));
    let spp = ((t_pm / t4 * 4.0) as u32).clamp(1, 65536);
    let (path, t_path) = run(&scene, Method::Path, size, Some(spp));
    let e_path = pmrender::converge::rel_mse(&path, &reference);
    println!(
        "{name} {}×{}: pm mean {:+.2} %, relMSE {e_pm:.5} in {t_pm:.2} s; path {spp} spp relMSE {e_path:.5} in {t_path:.2} s; path/pm relMSE {:.1}",
        size.0,
        size.1,
        (mean(&pm) / mean(&reference) - 1.0) * 100.0,
        e_path / e_pm
    );
}

/// Relative MSE of the 8×8-pixel block means of `img` against `reference`, over the pixels of `mask`
/// (blocks at least half in the mask; bias shows there, pixel noise averages out).
fn masked_block_rel_mse(img: &Image, reference: &Image, mask: &[bool]) -> f64 {
    const B: u32 = 8;
    let (mut sum, mut blocks) = (0.0f64, 0u32);
    for by in 0..img.height / B {
        for bx in 0..img.width / B {
            let (mut a, mut r, mut n) = (glam::DVec3::ZERO, glam::DVec3::ZERO, 0u32);
            for y in by * B..(by + 1) * B {
                for x in bx * B..(bx + 1) * B {
                    let i = (y * img.width + x) as usize;
                    if mask[i] {
                        a += img.pixels[i].as_dvec3();
                        r += reference.pixels[i].as_dvec3();
                        n += 1;
                    }
                }
            }
            if n * 2 < B * B {
                continue;
            }
            let (a, r) = (a / n as f64, r / n as f64);
            sum += (0..3)
                .map(|c| (a[c] - r[c]).powi(2) / (r[c] * r[c] + 0.01))
                .sum::<f64>()
                / 3.0;
            blocks += 1;
        }
    }
    sum / blocks.max(1) as f64
}

/// The pixels (at `size`) whose camera ray through the pixel's middle first meets material `name`.
fn material_mask(scene: &Scene, name: &str, size: (u32, u32)) -> Vec<bool> {
    let opts = Options {
        width: Some(size.0),
        height: Some(size.1),
        ..Default::default()
    };
    let camera = pmrender::render::plan(scene, &opts, None)
        .expect("plan")
        .camera;
    (0..size.1)
        .flat_map(|y| (0..size.0).map(move |x| (x, y)))
        .map(|(x, y)| {
            let d = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            scene
                .intersect(camera.eye, d)
                .is_some_and(|h| scene.materials[h.material as usize].name == name)
        })
        .collect()
}

/// Sibenik's floor, polished and diffuse, each with `pm`'s defaults against its own reference: block
/// relMSE over the floor's pixels, and the ratio (the polished floor's may be at most 1.5× the
/// diffuse floor's).
fn sibenik_floor(root: &Path) {
    let read = |name: &str| {
        pmrender::io::output::read_layer(
            &root.join(format!("tests/reference/{name}-path.exr")),
            None,
        )
    };
    let (Ok(ref_g), Ok(ref_d), Ok(g), Ok(d)) = (
        read("sibenik-polished"),
        read("sibenik"),
        scene::load(&root.join("tests/scenes/sibenik-polished.toml")),
        scene::load(&root.join("tests/scenes/sibenik.toml")),
    ) else {
        return println!("sibenik floor: skipped (scene or references missing)");
    };
    let size = (ref_g.width, ref_g.height);
    let mask = material_mask(&g, "pod", size);
    let floor = mask.iter().filter(|&&m| m).count();
    let (img_g, _) = run(&g, Method::Pm, size, None);
    let (img_d, _) = run(&d, Method::Pm, size, None);
    let (e_g, e_d) = (
        masked_block_rel_mse(&img_g, &ref_g, &mask),
        masked_block_rel_mse(&img_d, &ref_d, &mask),
    );
    println!(
        "sibenik floor {}×{} ({floor} floor pixels): block relMSE polished {e_g:.2e}, diffuse {e_d:.2e}, ratio {:.2}",
        size.0,
        size.1,
        e_g / e_d
    );
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let only = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let wanted = |name: &str| only.as_deref().is_none_or(|o| name.contains(o));
    if wanted("sponza-blender") {
        time_ratio(
            root,
            "sponza-blender",
            "tests/scenes/sponza-blender.toml",
            "tests/scenes/sponza.toml",
            (640, 480),
        );
    }
    if wanted("sponza-conference") {
        time_ratio(
            root,
            "sponza-conference",
            "tests/scenes/sponza-conference.toml",
            "tests/scenes/sponza.toml",
            (640, 480),
        );
    }
    if wanted("sibenik-polished") {
        time_ratio(
            root,
            "sibenik-polished",
            "tests/scenes/sibenik-polished.toml",
            "tests/scenes/sibenik.toml",
            (1000, 1000),
        );
    }
    if wanted("sibenik-floor") {
        sibenik_floor(root);
    }
    for name in [
        "sponza-blender",
        "sponza-conference",
        "sibenik-polished",
        "cornell-glossy",
        "cornell-glossy-floor",
    ] {
        if wanted(name) {
            against_reference(root, name, &format!("tests/scenes/{name}.toml"));
        }
    }
}
