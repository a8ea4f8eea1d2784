//! Renders an image in parallel tiles: the canvas and the tile loop here; the pixel [`Window`]
//! (`window`), the [`Sampler`] a method gives (`sampler`), where samples fall (`sample_points`),
//! adaptive sampling's rounds and stopping rule (`convergence`), one pixel's round and the round taken
//! again after missed lookups (`round`).
//!
//! Each pixel sample draws its random numbers from a stream seeded by
//! (seed, pixel, sample index), and each pixel's samples are summed in order, so the image does not
//! depend on the number of threads.
//!
//! Samples come in groups of four, one in each quarter of the pixel (2×2 jittered strata). With a
//! `noise` target, a pixel stops once its own samples say its mean is good enough (adaptive sampling):
//! at 4, 8, 16, … samples, the estimated relative variance of the mean, per channel
//! Var[x̄] / (x̄² + 0.01) — what the pixel adds to the relMSE every accuracy figure here is measured in —
//! is compared with `noise²`. A pixel's decision depends on its own samples only, so the image still does
//! not depend on the thread count.
//!
//! The variance of a stratified mean is that of the samples *within* each quarter, not across the
//! pixel: a pixel whose quarters differ smoothly (a texture's gradient, the edge of a stone) has a
//! nearly exact mean after a few groups, though its samples differ a lot. From the second group on, the
//! estimate is made within the quarters — from the differences between the samples of the same quarter
//! in successive groups, 4 degrees of freedom per pair of groups. After the first group alone there is
//! no such difference and the estimate is the samples' plain variance, which can only be larger: over
//! textures and edges it kept many pixels sampling to their limit.
//!
//! Pixels differ in what more samples buy. Where a pixel's samples make no Monte Carlo estimate — delta
//! lights, cached and photon-map irradiance, mirrors — its samples differ only by where they fall in it
//! (a texture's mortar lines, an edge), and it stops at `aa_spp` (32). Where they do (area-light samples,
//! a glass's reflect-or-refract choice, glossy lobes, media, per-sample gathers), the pixel's noise is
//! what more samples remove, and it may go on to `spp` (128): scenes lit by area lights gain much
//! accuracy at little cost, while textured surfaces under point and spot lights stay at `aa_spp`.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use glam::Vec3;
use photon::sampling::{hash_keys, sobol_2d, Rng};
use rayon::prelude::*;

use crate::counters::SampleCounters;
use crate::error::{Error, Result};
use crate::integrator::pm::AREA_LIGHT_SAMPLES;
use crate::integrator::terms::{LayerValues, MAX_LAYERS};
use crate::integrator::{sanitize, LightPoints, PixelMemo, Stratified};
use crate::io::output::Image;

mod convergence;
mod round;
mod sample_points;
mod sampler;
mod window;

use convergence::*;
pub use convergence::{SampleCount, Sampling, MIN_ADAPTIVE_SPP, SUMS_BYTES_PER_PIXEL};
use round::*;
pub use sample_points::SamplePoint;
use sample_points::*;
pub use sampler::{GrowStats, MissedSample, SampleFn, Sampler};
pub use window::Window;

const TILE: u32 = 16;

/// A tile's pixels: their sums and, per layer, the sum of their samples.
struct TileState {
    window: Window,
    pixels: Vec<PixelSums>,
    layers: Vec<Vec<Vec3>>,
    /// Each pixel's memo, kept from round to round while the pixel takes samples: its later rounds
    /// reuse the soft indirect light its first round computed, so that sampling in rounds costs no
    /// more per sample than sampling all at once.
    memos: Vec<PixelMemo>,
    /// This round's pixels that missed, as they stood before it (when the sampler adds records).
    redo: Vec<Redo>,
}

/// What [`render_tiles`] renders: `n_layers` images of `width` × `height`, of which the samples fill
/// `window`, with `sampling` and the pixels' random numbers drawn from `seed`; the pixels `kept` marks
/// (row-major over the image) take no sample and stay 0 (a sequence's frame fills them from the frame
/// before).
#[derive(Clone, Copy, Debug)]
pub struct Canvas<'a> {
    pub width: u32,
    pub height: u32,
    pub window: Window,
    pub sampling: Sampling,
    pub seed: u64,
    pub n_layers: usize,
    pub kept: Option<&'a [bool]>,
    /// With `kept`, the samples each pixel took when it was last shaded (row-major over the image): a
    /// kept pixel counts as not converged after each round that took fewer, so that its neighbours go
    /// on sampling as they would have beside it (see [`render_tiles`]): a pixel shaded again among
    /// kept ones would otherwise have no neighbour to go on for it, and a few lucky samples (a
    /// penumbra they all missed) would stop it.
    pub kept_samples: Option<&'a [u32]>,
    /// With `kept_samples`, the pixels that take exactly the samples they took when last shaded (a
    /// sequence's frame where only their cached light changed): the same samples then read the new
    /// light, and the pixel changes by what the light did, not by new noise.
    pub repeat: Option<&'a [bool]>,
}

/// Renders the canvas's images (box filter: the mean of each pixel's samples).
///
/// With a noise target the samples are taken in rounds (4, 8, 16, … per pixel); after each round a pixel
/// goes on if it, or any of its 8 neighbours, has not [`converged`]. Looking at the neighbours catches
/// what one pixel's few samples can miss — a sub-pixel slat, the edge of a shadow — when the next pixel
/// has seen it; each round's decisions read only the previous rounds' sums, so the image does not depend
/// on the thread count. After each round, a sampler that [`Sampler::adds_records`] gets the samples whose
/// lookups missed (answered cheaply: see [`Sampler::sample`]); their pixels then take that round's
/// samples again (from their state before it), reading the records the sampler made for them.
/// `progress` is called with a number of pixels (rounds count as fractions of the window); `cancel`
/// (read before every sample) stops early with `Interrupted`.
pub fn render_tiles(
    canvas: &Canvas,
    sampler: &mut dyn Sampler,
    progress: &(dyn Fn(u64) + Sync),
    cancel: &AtomicBool,
) -> Result<(Vec<Image>, SampleCounters, SampleCount, Vec<u32>)> {
    let Canvas {
        width,
        window,
        sampling,
        seed,
        n_layers,
        kept,
        kept_samples,
        repeat,
        ..
    } = *canvas;
    let spp = sampling.spp.max(1);
    let adaptive = sampling.noise > 0.0 && spp > MIN_ADAPTIVE_SPP;
    let aa_spp = sampling.aa_spp.clamp(1, spp);
    let keep_redo = sampler.adds_records() && n_layers <= MAX_LAYERS;
    let mut tiles = tile_states(window, n_layers, sampling.past_aa_layers.is_some());
    // Pixels that take the next round's samples.
    let mut active = Active::all(window, kept, width);
    let rounds = rounds(spp, aa_spp, adaptive);
    let done = AtomicU64::new(0);
    let mut total = SampleCounters::default();
    let mut count = SampleCount::default();
    let round_of = RoundSpec {
        width,
        spp,
        seed,
        adaptive,
        past_aa_layers: sampling.past_aa_layers,
        lobe_points: sampling.lobe_points,
    };
    for (round, &target) in rounds.iter().enumerate() {
        let pass = TilePass {
            round_of: &round_of,
            target,
            keep_redo,
            done: &done,
            n_rounds: rounds.len() as u64,
        };
        let counters = pass.run(&mut tiles, &active, sampler, progress, cancel);
        total += counters;
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        if keep_redo {
            redo_missed(
                &mut tiles, &round_of, target, sampler, &mut total, &mut count, cancel,
            )?;
        }
        if round + 1 == rounds.len() {
            break;
        }
        // Past `aa_spp`, only pixels whose samples made Monte Carlo estimates go on.
        let past_aa = rounds[round + 1] > aa_spp;
        active = next_round(
            &tiles,
            window,
            past_aa,
            &sampling,
            Masks {
                width,
                kept,
                kept_samples,
                repeat,
                done: target,
            },
        );
        // A pixel that stops sampling needs its memo no more.
        clear_stopped_memos(&mut tiles, &active);
    }
    let mut samples = vec![0u32; (width * canvas.height) as usize];
    let images = images(canvas, &tiles, |i, n, monte_carlo| {
        samples[i] = n;
        count.samples += n as u64;
        count.pixels += 1;
        count.at_limit += (adaptive && n == if monte_carlo { spp } else { aa_spp }) as u64;
        count.monte_carlo_pixels += monte_carlo as u64;
    });
    Ok((images, total, count, samples))
}

/// One round of samples over the tiles: each active pixel's samples up to `target`.
struct TilePass<'a> {
    round_of: &'a RoundSpec,
    target: u32,
    /// Whether pixels whose samples missed keep their state to take the round again.
    keep_redo: bool,
    /// Pixels done over all rounds (for progress), and the rounds.
    done: &'a AtomicU64,
    n_rounds: u64,
}

impl TilePass<'_> {
    /// Takes the round in parallel, one tile per task; the sample counters summed.
    fn run(
        &self,
        tiles: &mut [TileState],
        active: &Active,
        sampler: &dyn Sampler,
        progress: &(dyn Fn(u64) + Sync),
        cancel: &AtomicBool,
    ) -> SampleCounters {
        tiles
            .par_iter_mut()
            // One tile per task: rayon's default splitting leaves ranges of hundreds of tiles that no
            // thread can steal from, and the rounds of adaptive sampling, whose active pixels cluster
            // in a few tiles, ended with one thread idle for up to a second (Sibenik 1000²).
            .with_max_len(1)
            .map(|t| {
                let w = t.window;
                let mut counters = SampleCounters::default();
                for y in w.y0..w.y1 {
                    for x in w.x0..w.x1 {
                        if !active.is(x, y) {
                            continue;
                        }
                        if !self.round_of.take(
                            t,
                            x,
                            y,
                            self.target,
                            sampler,
                            self.keep_redo,
                            &mut counters,
                            cancel,
                        ) {
                            return counters;
                        }
                    }
                }
                let n = self.done.fetch_add(w.n_pixels(), Ordering::Relaxed) + w.n_pixels();
                progress(n / self.n_rounds);
                counters
            })
            .reduce(SampleCounters::default, |mut a, b| {
                a += b;
                a
            })
    }
}

/// Clears the memo of every pixel of `tiles` that `active` no longer marks.
fn clear_stopped_memos(tiles: &mut [TileState], active: &Active) {
    for t in tiles.iter_mut() {
        let w = t.window;
        for (k, memo) in t.memos.iter_mut().enumerate() {
            let (x, y) = (
                w.x0 + k as u32 % (w.x1 - w.x0),
                w.y0 + k as u32 / (w.x1 - w.x0),
            );
            if !active.is(x, y) {
                memo.clear();
            }
        }
    }
}

/// The window cut into tiles of [`TILE`]² pixels, none sampled yet.
/// The tiles of `window`, their pixels' sums with a second spread when `monte_carlo_spread`.
fn tile_states(window: Window, n_layers: usize, monte_carlo_spread: bool) -> Vec<TileState> {
    let sums = PixelSums {
        monte_carlo_spread: monte_carlo_spread.then(Box::default),
        ..Default::default()
    };
    let mut tiles = Vec::new();
    for ty in (window.y0..window.y1).step_by(TILE as usize) {
        for tx in (window.x0..window.x1).step_by(TILE as usize) {
            let w = Window {
                x0: tx,
                y0: ty,
                x1: (tx + TILE).min(window.x1),
                y1: (ty + TILE).min(window.y1),
            };
            let n = w.n_pixels() as usize;
            tiles.push(TileState {
                window: w,
                pixels: vec![sums.clone(); n],
                layers: vec![vec![Vec3::ZERO; n]; n_layers],
                memos: vec![PixelMemo::default(); n],
                redo: Vec::new(),
            });
        }
    }
    tiles
}

/// The canvas's images from the tiles' sums, each pixel's mean of its samples; `each_pixel` sees every
/// pixel's sample count and whether its samples made Monte Carlo estimates.
fn images(
    canvas: &Canvas,
    tiles: &[TileState],
    mut each_pixel: impl FnMut(usize, u32, bool),
) -> Vec<Image> {
    let width = canvas.width;
    let mut images = vec![Image::new(width, canvas.height); canvas.n_layers];
    for t in tiles {
        let w = t.window;
        for y in w.y0..w.y1 {
            for x in w.x0..w.x1 {
                let k = ((y - w.y0) * (w.x1 - w.x0) + (x - w.x0)) as usize;
                let (n, monte_carlo) = (t.pixels[k].n, t.pixels[k].monte_carlo);
                each_pixel((y * width + x) as usize, n, monte_carlo);
                for (img, layer) in images.iter_mut().zip(&t.layers) {
                    img.pixels[(y * width + x) as usize] = layer[k] / n.max(1) as f32;
                }
            }
        }
    }
    images
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_groups_are_stratified_and_the_rest_is_not() {
        // spp 8: two whole groups, each sample in its own quarter.
        for s in 0..8 {
            let [x, y] = offset(7, 3, s, 8, 0.999, 0.0);
            let cell = s % 4;
            assert!(
                (x * 2.0).floor() as u32 == cell % 2 && (y * 2.0).floor() as u32 == cell / 2,
                "sample {s} at {x}, {y}"
            );
        }
        // spp 1 and the tail of spp 6: anywhere in the pixel, at the given point.
        assert_eq!(offset(7, 3, 0, 1, 0.7, 0.8), [0.7, 0.8]);
        assert_eq!(offset(7, 3, 5, 6, 0.7, 0.8), [0.7, 0.8]);
    }

    #[test]
    fn a_quarters_points_in_even_groups_stratify_it() {
        // 128 samples: 16 even groups, whose points in quarter 0 fill a 4×4 grid of it once each.
        let mut seen = [false; 16];
        for g in (0..32u32).step_by(2) {
            let [x, y] = offset(7, 3, g * GROUP, 128, 0.0, 0.0);
            let cell = (x * 8.0) as usize + 4 * (y * 8.0) as usize;
            assert!(!seen[cell], "group {g}");
            seen[cell] = true;
        }
    }

    #[test]
    fn a_pixel_beside_a_much_brighter_one_goes_on() {
        // A row of five converged pixels: an emitter's 17 beside the ceiling's 0.1, 0.3 and 0.5.
        let means = [17.0, 0.1, 0.3, 0.5, 0.5];
        let sampled: Vec<Option<Vec3>> = means.iter().map(|&m| Some(Vec3::splat(m))).collect();
        let mut open = vec![false; 5];
        open_beside_brighter(&mut open, &[true; 5], &sampled, 5, 1);
        // 0.1 opens beside 17; 0.3 beside 0.1 and 0.5 does not (0.5 < 4 · 0.4); nor does the emitter.
        assert_eq!(open, [false, true, false, false, false]);
        // A pixel not allowed to go on (past aa_spp without Monte Carlo estimates) stays shut, and a
        // pixel without samples of its own (kept from a frame before) neither opens nor opens others.
        let mut open = vec![false; 5];
        open_beside_brighter(&mut open, &[true, false, true, true, true], &sampled, 5, 1);
        assert_eq!(open, [false; 5]);
        let mut kept = sampled.clone();
        kept[0] = None;
        let mut open = vec![false; 5];
        open_beside_brighter(&mut open, &[true; 5], &kept, 5, 1);
        assert_eq!(open, [false; 5]);
    }

    #[test]
    fn pixels_without_monte_carlo_estimates_stop_at_aa_spp() {
        // 8 × 1 pixels, every sample a coin flip between 0 and 1 (never converges at noise 0.01); pixels
        // 0–3 count a Monte Carlo estimate in each sample, pixels 4–7 none.
        let sampler = |x: u32,
                       _y: u32,
                       _at: SamplePoint,
                       _m: &mut PixelMemo,
                       rng: &mut Rng,
                       c: &mut SampleCounters| {
            c.monte_carlo += (x < 4) as u64;
            LayerValues::one(Vec3::splat((rng.uniform() < 0.5) as u32 as f32))
        };
        let canvas = |sampling| Canvas {
            kept: None,
            kept_samples: None,
            repeat: None,
            width: 8,
            height: 1,
            window: Window::full(8, 1),
            sampling,
            seed: 1,
            n_layers: 1,
        };
        let run = |spp, aa_spp| {
            let mut s = sampler;
            let sampling = Sampling {
                finer: None,
                spp,
                noise: 0.01,
                aa_spp,
                past_aa_layers: None,
                lobe_points: false,
            };
            render_tiles(&canvas(sampling), &mut s, &|_| {}, &AtomicBool::new(false))
                .unwrap()
                .2
        };
        let count = run(128, 32);
        // 4 pixels × 128 + 4 × 32, every one at its limit.
        assert_eq!(count.samples, 4 * 128 + 4 * 32);
        assert_eq!((count.at_limit, count.monte_carlo_pixels), (8, 4));
        // aa_spp = spp: every pixel to spp.
        assert_eq!(run(64, 64).samples, 8 * 64);
        // Fixed sampling (no noise target) ignores aa_spp.
        let mut s = sampler;
        let fixed = render_tiles(
            &canvas(Sampling {
                finer: None,
                spp: 16,
                noise: 0.0,
                aa_spp: 4,
                past_aa_layers: None,
                lobe_points: false,
            }),
            &mut s,
            &|_| {},
            &AtomicBool::new(false),
        )
        .unwrap()
        .2;
        assert_eq!(fixed.samples, 8 * 16);
    }

    #[test]
    fn past_aa_spp_only_the_named_layers_noise_keeps_a_pixel_sampling() {
        // The direct layer (1) a coin flip (noise more samples would not remove, like a texture's
        // coverage of the pixel), the indirect one (4) constant; every sample counts a Monte Carlo
        // estimate.
        let sampler = |_x: u32,
                       _y: u32,
                       _at: SamplePoint,
                       _m: &mut PixelMemo,
                       rng: &mut Rng,
                       c: &mut SampleCounters| {
            c.monte_carlo += 1;
            let terms = crate::integrator::terms::Terms {
                direct: Vec3::splat((rng.uniform() < 0.5) as u32 as f32),
                indirect: Vec3::ONE,
                ..Default::default()
            };
            terms.to_layers(crate::integrator::terms::Layout {
                glossy: false,
                media: false,
            })
        };
        let run = |past_aa_layers| {
            let mut s = sampler;
            let canvas = Canvas {
                kept: None,
                kept_samples: None,
                repeat: None,
                width: 4,
                height: 1,
                window: Window::full(4, 1),
                sampling: Sampling {
                    finer: None,
                    spp: 128,
                    noise: 0.01,
                    aa_spp: 32,
                    past_aa_layers,
                    lobe_points: false,
                },
                seed: 1,
                n_layers: 5,
            };
            render_tiles(&canvas, &mut s, &|_| {}, &AtomicBool::new(false))
                .unwrap()
                .2
                .samples
        };
        assert_eq!(run(None), 4 * 128);
        assert_eq!(run(Some(1 << 4)), 4 * 32);
        assert_eq!(run(Some(1 << 1)), 4 * 128);
    }

    #[test]
    fn kept_neighbours_sample_on_as_they_did_and_repeated_pixels_take_their_count() {
        // 5 × 1 pixels, every sample the same value (each converges at its first group); the
        // image's four other pixels are kept, having taken 64 samples when last shaded.
        let sampler = |_x: u32,
                       _y: u32,
                       _at: SamplePoint,
                       _m: &mut PixelMemo,
                       _rng: &mut Rng,
                       c: &mut SampleCounters| {
            c.monte_carlo += 1;
            LayerValues::one(Vec3::splat(0.5))
        };
        let run = |kept: &[bool], before: &[u32], repeat: &[bool]| {
            let mut s = sampler;
            let canvas = Canvas {
                kept: Some(kept),
                kept_samples: Some(before),
                repeat: Some(repeat),
                width: 5,
                height: 1,
                window: Window::full(5, 1),
                sampling: Sampling {
                    finer: None,
                    spp: 128,
                    noise: 0.04,
                    aa_spp: 32,
                    past_aa_layers: None,
                    lobe_points: false,
                },
                seed: 1,
                n_layers: 1,
            };
            render_tiles(&canvas, &mut s, &|_| {}, &AtomicBool::new(false))
                .unwrap()
                .3
        };
        let kept = [true, true, false, true, true];
        let no_repeat = [false; 5];
        // Its kept neighbours went on to 64: so does the pixel shaded again beside them.
        assert_eq!(run(&kept, &[64, 64, 0, 64, 64], &no_repeat)[2], 64);
        // Beside neighbours that stopped at their first group, it stops at its own.
        assert_eq!(run(&kept, &[4, 4, 0, 4, 4], &no_repeat)[2], 4);
        // A pixel that repeats its samples takes the count it took, no more and no fewer.
        let repeat = [false, false, true, false, false];
        assert_eq!(run(&kept, &[64, 64, 16, 64, 64], &repeat)[2], 16);
        assert_eq!(run(&kept, &[4, 4, 32, 4, 4], &repeat)[2], 32);
    }

    #[test]
    fn lobe_points_take_every_quarter_once_per_group() {
        let quarter = |p: [f32; 2]| (p[0] >= 0.5) as u32 + 2 * (p[1] >= 0.5) as u32;
        for pixel in 0..50u64 {
            let q: Vec<u32> = (0..32)
                .map(|s| quarter(lobe_point(7, pixel, s, 32)))
                .collect();
            for g in q.chunks(4) {
                let mut seen = g.to_vec();
                seen.sort();
                assert_eq!(seen, [0, 1, 2, 3], "pixel {pixel}: {q:?}");
            }
            // The two groups of a pair put each sample's quarter of the pixel in the same quarter of
            // the lobe.
            for pair in q.chunks(8) {
                assert_eq!(pair[..4], pair[4..], "pixel {pixel}: {q:?}");
            }
        }
        // Over pixels, the pixel's quarter and the lobe's are independent.
        let mut counts = [[0u32; 4]; 4];
        for pixel in 0..4000u64 {
            for s in 0..4 {
                counts[s as usize][quarter(lobe_point(7, pixel, s, 32)) as usize] += 1;
            }
        }
        for row in counts {
            for n in row {
                assert!((850..1150).contains(&n), "{counts:?}");
            }
        }
    }

    fn pixel(samples: &[f32], spp: u32) -> PixelSums {
        let mut px = PixelSums::default();
        for (s, &x) in samples.iter().enumerate() {
            px.spread.add(s as u32, spp, Vec3::splat(x));
            px.n += 1;
        }
        px
    }

    fn converged(samples: &[f32], noise: f32) -> bool {
        let mean = samples.iter().sum::<f32>() / samples.len() as f32;
        let px = pixel(samples, 32);
        super::converged(&px.spread, px.n, Vec3::splat(mean), noise)
    }

    #[test]
    fn a_constant_pixel_converges_and_a_noisy_one_does_not() {
        assert!(converged(&[0.5; 4], 0.01));
        // Samples 0, 1, 0, 1: mean 0.5, variance 1/3, Var[mean] 1/12; relative 1/12 / 0.26 ≈ 0.32.
        assert!(!converged(&[0.0, 1.0, 0.0, 1.0], 0.5));
        assert!(converged(&[0.0, 1.0, 0.0, 1.0], 0.6));
        // The same quarters in two groups: the stratified mean is exact, however different they are.
        assert!(converged(&[0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0], 0.01));
        // Differences within the quarters: 0.1 between the groups in each quarter. Σ d² = 4 · 0.01 per
        // channel, Var[x̄] = 0.04 / (8 · 1 · 8) = 6.25e-4, relative 6.25e-4 / (0.5² + 0.01) = 0.0024
        // = noise² at noise 0.049.
        let varied = [0.0, 1.0, 0.0, 1.0, 0.1, 0.9, 0.1, 0.9];
        assert!(!converged(&varied, 0.045));
        assert!(converged(&varied, 0.05));
        // Without the pair, the plain variance of the first group (relative 0.32 per channel) would not
        // stop at 0.2.
        let px = pixel(&varied, 32);
        assert!(!super::converged(
            &Spread {
                pairs: 0,
                ..px.spread
            },
            px.n,
            Vec3::splat(0.5),
            0.2
        ));
        // Samples past the last whole group (spp 6) are in no quarter: they leave the pairs alone.
        assert_eq!(pixel(&[0.0, 1.0, 0.0, 1.0, 0.0, 1.0], 6).spread.pairs, 0);
        assert_eq!(rounds(32, 32, true), [4, 8, 16, 32]);
        assert_eq!(rounds(20, 20, true), [4, 8, 16, 20]);
        assert_eq!(rounds(32, 32, false), [32]);
        // aa_spp is one of the rounds.
        assert_eq!(rounds(128, 32, true), [4, 8, 16, 32, 64, 128]);
        assert_eq!(rounds(128, 20, true), [4, 8, 16, 20, 40, 80, 128]);
    }
}
