//! `make bench`: occlusion through the cache against a gather at every sample, on Sibenik at 1000²,
//! measured in one run and printed (never asserted). The target: `ao` at its defaults reaches
//! `ao-direct`'s error at 64 spp in at most a fifth of its time.
//!
//! `ao` renders the whole image. `ao-direct` at 64 spp over the whole image would take most of an
//! hour on 2 cores, so it renders a band of columns through the middle of the image (vault, nave,
//! floor) twice at 32 spp with different seeds, no noise target: a pixel's `ao-direct` costs the
//! same whatever the others do, so its time over the image is the band's scaled by their pixel
//! counts; the two renders' mean is a 64-spp image, whose noise is a quarter of their difference's
//! relMSE (it is unbiased). `ao`'s error is its relMSE against that 64-spp image over the band, less
//! that noise. Where `ao`'s error is the larger, `ao-direct`'s time to reach it is extrapolated from
//! the 64-spp noise falling as 1/spp. Last, `ao` with every band pixel at 64 samples splits its error
//! into the records' interpolation and its adaptive sampling's noise.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use pmrender::io::output::Image;
use pmrender::render::tiles::Window;
use pmrender::render::{render, NoProgress, Options};
use pmrender::scene::{self, Method, Scene};

const SIZE: u32 = 1000;
/// The band `ao-direct` renders: columns [X0, X1) of every row.
const X0: u32 = 488;
const X1: u32 = 512;

fn run(
    scene: &Scene,
    method: Method,
    spp: Option<u32>,
    seed: u64,
    crop: Option<Window>,
) -> (Image, f64) {
    let opts = Options {
        method: Some(method),
        spp,
        noise: spp.map(|_| 0.0),
        width: Some(SIZE),
        height: Some(SIZE),
        seed: Some(seed),
        crop,
        ..Default::default()
    };
    let t = Instant::now();
    let (out, _) = render(scene, &opts, &NoProgress, &AtomicBool::new(false)).expect("render");
    (out.beauty, t.elapsed().as_secs_f64())
}

/// relMSE = mean (a − r)² / (r² + 0.01) over the band's pixels (R: occlusion is grey).
fn band_rel_mse(a: &Image, r: &Image) -> f64 {
    let mut sum = 0.0;
    for y in 0..SIZE {
        for x in X0..X1 {
            let i = (y * SIZE + x) as usize;
            let (a, r) = (a.pixels[i].x as f64, r.pixels[i].x as f64);
            sum += (a - r).powi(2) / (r * r + 0.01);
        }
    }
    sum / (SIZE * (X1 - X0)) as f64
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = match scene::load(&root.join("tests/scenes/sibenik.toml")) {
        Ok(s) => s,
        Err(e) => return println!("ao vs ao-direct: skipped ({e})"),
    };
    println!("machine: {} threads", rayon::current_num_threads());
    let (ao, t_ao) = run(&scene, Method::Ao, None, 0, None);
    let band = Window {
        x0: X0,
        y0: 0,
        x1: X1,
        y1: SIZE,
    };
    let (d1, t1) = run(&scene, Method::AoDirect, Some(32), 1, Some(band));
    let (d2, t2) = run(&scene, Method::AoDirect, Some(32), 2, Some(band));
    let mut d64 = d1.clone();
    for (p, q) in d64.pixels.iter_mut().zip(&d2.pixels) {
        *p = (*p + *q) * 0.5;
    }
    let noise_64 = band_rel_mse(&d1, &d2) / 4.0;
    let e_ao = band_rel_mse(&ao, &d64) - noise_64;
    let scale = (SIZE * SIZE) as f64 / (SIZE * (X1 - X0)) as f64;
    let t_direct_64 = (t1 + t2) * scale;
    println!(
        "sibenik {SIZE}²: ao (defaults) {t_ao:.1} s, relMSE {e_ao:.2e}; ao-direct 64 spp {t_direct_64:.0} s \
         (band {X0}..{X1} × {SIZE} in {:.1} s, ×{scale:.1}), relMSE {noise_64:.2e}",
        t1 + t2
    );
    println!(
        "  time ratio ao / ao-direct-64 {:.3} (target ≤ 0.2); error ratio ao / ao-direct-64 {:.2} (target ≤ 1)",
        t_ao / t_direct_64,
        e_ao / noise_64
    );
    // Where ao's error comes from: the same cache read with every pixel of the band taking 64 samples
    // (no noise target) leaves the interpolation's share.
    let (ao_64, _) = run(&scene, Method::Ao, Some(64), 0, Some(band));
    println!(
        "  ao at 64 spp, no noise target, over the band: relMSE {:.2e} (the records' interpolation; \
         the rest of ao's error is its adaptive sampling's)",
        band_rel_mse(&ao_64, &d64) - noise_64
    );
    if e_ao > noise_64 {
        let spp = 64.0 * noise_64 / e_ao;
        println!(
            "  ao-direct reaches ao's error at about {spp:.1} spp in {:.0} s: ao takes {:.3} of that time",
            t_direct_64 * spp / 64.0,
            t_ao / (t_direct_64 * spp / 64.0)
        );
    }
}
