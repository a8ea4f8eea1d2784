//! Renders an image in parallel tiles. Each pixel sample draws its random numbers from a stream seeded by
//! (seed, pixel, sample index), and each pixel's samples are summed in order, so the image does not
//! depend on the number of threads.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::Vec3;
use photon::sampling::{hash_keys, Rng};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::integrator::{sanitize, SampleCounters};
use crate::io::output::Image;

const TILE: u32 = 16;

/// A rectangle of pixels [x0, x1) × [y0, y1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Window {
    pub fn full(width: u32, height: u32) -> Window {
        Window { x0: 0, y0: 0, x1: width, y1: height }
    }

    pub fn n_pixels(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}

/// What a method computes for one pixel sample: beauty is the sum of `layers` (or `layers[0]` when the
/// method has a single layer).
pub type SampleFn<'a> = dyn Fn(u32, u32, &mut Rng, &mut SampleCounters) -> Vec<Vec3> + Sync + 'a;

/// Renders `n_layers` images of the window at `spp` samples per pixel (box filter: the mean).
/// `progress` is called with the number of pixels finished; `cancel` (read before every sample) stops
/// early with `Interrupted`.
pub fn render_tiles(
    width: u32,
    height: u32,
    window: Window,
    spp: u32,
    seed: u64,
    n_layers: usize,
    sample: &SampleFn,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(Vec<Image>, SampleCounters)> {
    let mut tiles = Vec::new();
    for ty in (window.y0..window.y1).step_by(TILE as usize) {
        for tx in (window.x0..window.x1).step_by(TILE as usize) {
            tiles.push(Window { x0: tx, y0: ty, x1: (tx + TILE).min(window.x1), y1: (ty + TILE).min(window.y1) });
        }
    }
    let done = AtomicU64::new(0);
    let results: Vec<(Window, Vec<Vec<Vec3>>, SampleCounters)> = tiles
        .par_iter()
        .map(|t| {
            let mut counters = SampleCounters::default();
            let mut px = vec![vec![Vec3::ZERO; t.n_pixels() as usize]; n_layers];
            if cancel.load(Ordering::Relaxed) {
                return (*t, px, counters);
            }
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let k = ((y - t.y0) * (t.x1 - t.x0) + (x - t.x0)) as usize;
                    let pixel = y as u64 * width as u64 + x as u64;
                    let mut sum = vec![Vec3::ZERO; n_layers];
                    for s in 0..spp {
                        // Read every sample: one relaxed load next to a whole camera path costs nothing,
                        // and a single pixel at 100 000 spp must stop at once.
                        if cancel.load(Ordering::Relaxed) {
                            break;
                        }
                        let mut rng = Rng::new(hash_keys(&[seed, pixel, s as u64]));
                        let v = sample(x, y, &mut rng, &mut counters);
                        for (acc, l) in sum.iter_mut().zip(v) {
                            *acc += sanitize(l, &mut counters);
                        }
                    }
                    for (layer, acc) in px.iter_mut().zip(sum) {
                        layer[k] = acc / spp as f32;
                    }
                }
            }
            let n = done.fetch_add(t.n_pixels(), Ordering::Relaxed) + t.n_pixels();
            progress(n);
            (*t, px, counters)
        })
        .collect();
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::Interrupted);
    }
    let mut images = vec![Image::new(width, height); n_layers];
    let mut total = SampleCounters::default();
    for (t, px, c) in results {
        total += c;
        for (img, layer) in images.iter_mut().zip(px) {
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let k = ((y - t.y0) * (t.x1 - t.x0) + (x - t.x0)) as usize;
                    img.pixels[(y * width + x) as usize] = layer[k];
                }
            }
        }
    }
    Ok((images, total))
}
