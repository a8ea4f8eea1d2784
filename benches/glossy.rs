//! `make bench`, third part: glossy scenes as authored. For each, `pm` with its defaults against the
//! same scene with its materials diffuse (its MTL as authored: time ratio), and against its independent reference:
//! image mean error, relMSE, and `path`'s relMSE at the same wall time (the ratio `pm` must keep at 5×
//! or more). Printed, never asserted.

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

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    time_ratio(
        root,
        "sponza-blender",
        "tests/scenes/sponza-blender.toml",
        "tests/scenes/sponza.toml",
        (640, 480),
    );
    time_ratio(
        root,
        "sibenik-polished",
        "tests/scenes/sibenik-polished.toml",
        "tests/scenes/sibenik.toml",
        (1000, 1000),
    );
    for name in [
        "sponza-blender",
        "sibenik-polished",
        "cornell-glossy",
        "cornell-glossy-floor",
    ] {
        against_reference(root, name, &format!("tests/scenes/{name}.toml"));
    }
}
