//! Renders an image in parallel tiles. Each pixel sample draws its random numbers from a stream seeded by
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
    /// The smallest window holding both (an empty one adds nothing).
    pub fn union(self, o: Window) -> Window {
        if o.x0 >= o.x1 || o.y0 >= o.y1 {
            return self;
        }
        if self.x0 >= self.x1 || self.y0 >= self.y1 {
            return o;
        }
        Window {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// Whether pixel (`x`, `y`) lies in the window.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    pub fn full(width: u32, height: u32) -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    pub fn n_pixels(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}

/// What a method computes for one pixel sample at image position (x + offset[0], y + offset[1]): beauty is
/// the sum of `layers` (or `layers[0]` when the method has a single layer).
/// `memo` is the pixel's, cleared before each round of its samples.
pub type SampleFn<'a> = dyn Fn(u32, u32, [f32; 2], &mut PixelMemo, &mut Rng, &mut SampleCounters) -> LayerValues
    + Sync
    + 'a;

/// A sample whose shading found no cache record for a surface it reached (a pass-B miss).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MissedSample {
    pub x: u32,
    pub y: u32,
    pub offset: [f32; 2],
}

/// What a method computes per sample ([`SampleFn`]) and, for a method that reads a cache it can grow
/// (`pm`), the records it makes between rounds for the samples that missed.
pub trait Sampler: Sync {
    /// With `defer_misses` (a round's first attempt, when [`Self::adds_records`]), a lookup that finds
    /// no record may answer anything cheap: every pixel with a miss takes the round again.
    #[allow(clippy::too_many_arguments)]
    fn sample(
        &self,
        x: u32,
        y: u32,
        at: SamplePoint,
        memo: &mut PixelMemo,
        rng: &mut Rng,
        c: &mut SampleCounters,
        defer_misses: bool,
    ) -> LayerValues;

    /// Whether [`Self::end_round`] can add records (then each round keeps what it needs to take a
    /// pixel's samples again).
    fn adds_records(&self) -> bool {
        false
    }

    /// After each round (when [`Self::adds_records`]): records for the round's missed samples (in pixel
    /// order), before the pixels of those samples take the round again.
    fn end_round(&mut self, _missed: &[MissedSample]) -> Result<()> {
        Ok(())
    }

    /// What [`Self::end_round`] did over the render.
    fn grown(&self) -> GrowStats {
        GrowStats::default()
    }
}

/// Records made between rounds for missed samples: the fills' statistics and their gathers' counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct GrowStats {
    /// Rounds after which records were made.
    pub rounds: u64,
    pub fill: icache::FillStats,
    pub counters: SampleCounters,
}

impl<
        F: Fn(u32, u32, SamplePoint, &mut PixelMemo, &mut Rng, &mut SampleCounters) -> LayerValues
            + Sync
            + ?Sized,
    > Sampler for F
{
    fn sample(
        &self,
        x: u32,
        y: u32,
        at: SamplePoint,
        memo: &mut PixelMemo,
        rng: &mut Rng,
        c: &mut SampleCounters,
        _: bool,
    ) -> LayerValues {
        self(x, y, at, memo, rng, c)
    }
}

/// How many samples each pixel takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampling {
    /// Samples per pixel; with a `noise` target, the most a pixel takes.
    pub spp: u32,
    /// Relative standard error of a pixel's mean at which it stops (0: every pixel takes `spp`).
    pub noise: f32,
    /// With a `noise` target, the most a pixel takes whose samples made no Monte Carlo estimate
    /// ([`SampleCounters::monte_carlo`]): they differ only by where they fall in the pixel (a texture's
    /// mortar lines, an edge), which more samples resolve slowly and nobody sees as noise. At most `spp`.
    pub aa_spp: u32,
    /// Past `aa_spp`, the layers (bit i: layer i) whose noise decides whether a pixel takes more
    /// samples; `None`: the beauty's.
    pub past_aa_layers: Option<u32>,
    /// Whether samples carry a stratified point for a glossy lobe ([`lobe_point`]; else its middle,
    /// unread): scenes with glossy lobes shaded by the photon-map methods.
    pub lobe_points: bool,
    /// A window of pixels held to a lower noise target than `noise` (a sequence's frame: where
    /// something moved, a pixel's noise changes from frame to frame and is seen as flicker).
    pub finer: Option<(Window, f32)>,
}

impl Sampling {
    /// The noise target of pixel (x, y).
    fn noise_at(&self, x: u32, y: u32) -> f32 {
        match self.finer {
            Some((w, noise)) if x >= w.x0 && x < w.x1 && y >= w.y0 && y < w.y1 => noise,
            _ => self.noise,
        }
    }
}

/// The fewest samples a pixel takes under a noise target (one group of strata).
pub const MIN_ADAPTIVE_SPP: u32 = 4;
/// Samples per group of strata.
const GROUP: u32 = 4;
/// Floor of the squared mean in the relative variance, as in the relMSE of the accuracy figures.
const REL_FLOOR: f64 = pmbase::REL_MSE_FLOOR;

/// Where a sample falls: its offset in the pixel, and a second point of the unit square for the
/// first glossy lobe it samples ([`lobe_point`]).
#[derive(Clone, Copy, Debug)]
pub struct SamplePoint {
    pub offset: [f32; 2],
    /// Its first glossy lobe's point and its first hit's area-light points ([`light_points`]).
    pub points: Stratified,
}

/// Keys the stream of the lobe points apart from the samples' own.
const LOBE_KEY: u64 = 0x10be;

/// Sample `s`'s point for the first glossy lobe it samples (of at most `spp` in pixel `pixel`). In a
/// whole group of four it lies in quarter π(s mod 4) of the unit square, as the sample's offset lies in
/// quarter s mod 4 of the pixel: each group then samples every quarter of the lobe once, which lowers
/// the noise of a lobe whose light varies smoothly across it. π is a random permutation shared by the two groups of a pair, so that
/// the variance estimate's differences compare samples of the same quarter in both, and drawn afresh
/// for each pair, so that over the pairs where a sample falls in the pixel and where in the lobe are
/// independent (a fixed pairing would weight the pixel's quarters by the lobe's). Anywhere otherwise.
/// Its own stream: the rest of the sample's random numbers stay as they are without glossy lobes.
fn lobe_point(seed: u64, pixel: u64, s: u32, spp: u32) -> [f32; 2] {
    let mut rng = Rng::new(hash_keys(&[seed, pixel, s as u64, LOBE_KEY]));
    let (u, v) = (rng.uniform(), rng.uniform());
    if !in_whole_group(s, spp) {
        return [u, v];
    }
    let pair = (s / (2 * GROUP)) as u64;
    let mut perm = [0u32, 1, 2, 3];
    let mut shuffle = Rng::new(hash_keys(&[seed, pixel, pair, LOBE_KEY, 1]));
    for i in (1..perm.len()).rev() {
        let j = ((shuffle.uniform() * (i + 1) as f32) as usize).min(i);
        perm.swap(i, j);
    }
    let cell = perm[(s % GROUP) as usize];
    [((cell % 2) as f32 + u) * 0.5, ((cell / 2) as f32 + v) * 0.5]
}

/// Keys the scrambles of the offsets' Sobol' points.
const OFFSET_KEY: u64 = 0x0ff5;

/// Sub-pixel offset of sample `s` (of at most `spp` in pixel `pixel`): in a whole group of four, a point
/// of quarter `s % 4`; anywhere otherwise, at (u, v). A quarter's points come from two Sobol' sequences
/// of their own, one for the even groups and one for the odd: each sequence's points stratify the
/// quarter ever more finely as the pixel takes samples (an edge's coverage converges faster than with
/// independent points), and the two samples of a pair of groups that the variance estimate compares
/// stay independent of each other, so that the estimate is what it was with independent points.
fn offset(seed: u64, pixel: u64, s: u32, spp: u32, u: f32, v: f32) -> [f32; 2] {
    if !in_whole_group(s, spp) {
        return [u, v];
    }
    let (cell, stream, index) = quarter_sequence(seed, pixel, s, OFFSET_KEY);
    let [u, v] = sobol_2d(index, stream);
    [((cell % 2) as f32 + u) * 0.5, ((cell / 2) as f32 + v) * 0.5]
}

/// Sample `s`'s quarter of its pixel (in a whole group of four), the scramble of the Sobol' sequence
/// that `key` names for that quarter and the parity of the sample's group, and the sample's index in
/// that sequence (its group's among the groups of that parity).
fn quarter_sequence(seed: u64, pixel: u64, s: u32, key: u64) -> (u32, u64, u32) {
    let (cell, group) = (s % GROUP, s / GROUP);
    let stream = hash_keys(&[seed, pixel, cell as u64, (group % 2) as u64, key]);
    (cell, stream, group / 2)
}

/// Keys the scrambles of the area-light points' Sobol' sequences.
const LIGHT_KEY: u64 = 0x119b;

/// Sample `s`'s area-light points (of at most `spp` in pixel `pixel`): in a whole group of four, the
/// next [`AREA_LIGHT_SAMPLES`] points of a Sobol' sequence of the sample's quarter and group parity, as
/// its offset's (so that the variance estimate's pairs stay independent); `None` otherwise (the
/// sample's own random numbers).
fn light_points(seed: u64, pixel: u64, s: u32, spp: u32) -> Option<LightPoints> {
    if !in_whole_group(s, spp) {
        return None;
    }
    let (_, stream, index) = quarter_sequence(seed, pixel, s, LIGHT_KEY);
    Some(LightPoints {
        stream,
        first: index * AREA_LIGHT_SAMPLES,
    })
}

/// True when sample `s` of at most `spp` belongs to a whole group of four (then it sits in quarter
/// `s % 4`).
fn in_whole_group(s: u32, spp: u32) -> bool {
    (s / GROUP + 1) * GROUP <= spp
}

/// True when a pixel's `n` samples, whose mean is `mean` and spread `spread`, estimate it well enough:
/// Σ_c Var[x̄_c] / (x̄_c² + 0.01) ≤ 3 noise² (each channel's relative variance, averaged). Var[x̄] comes
/// from within the quarters once the pixel has a pair of groups (see the module header), else from the
/// plain variance of its first group (a decision is due only at the end of a round, and the first round
/// is that group).
fn converged(spread: &Spread, n: u32, mean: Vec3, noise: f32) -> bool {
    let n = n as f64;
    let mut rel = 0.0;
    for c in 0..3 {
        let m = mean[c] as f64;
        let var_mean = if spread.pairs > 0 {
            // Σ over pairs and quarters of d² has mean 2 P Σ_q σ_q²; with n/4 samples per quarter the
            // stratified mean has variance Σ_q σ_q² / (16 n/4).
            spread.diff2[c] as f64 / (8.0 * spread.pairs as f64 * n)
        } else {
            let g = spread.first.map(|b| b[c] as f64);
            let gm = g.iter().sum::<f64>() / 4.0;
            g.iter().map(|x| (x - gm).powi(2)).sum::<f64>() / 3.0 / 4.0
        };
        rel += var_mean / (m * m + REL_FLOOR);
    }
    rel <= 3.0 * (noise as f64).powi(2)
}

/// Samples taken over the window, for the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleCount {
    pub samples: u64,
    pub pixels: u64,
    /// Pixels that took the most samples allowed them (`spp`, or `aa_spp` without Monte Carlo estimates)
    /// without meeting the noise target.
    pub at_limit: u64,
    /// Pixels whose samples made Monte Carlo estimates.
    pub monte_carlo_pixels: u64,
    /// Samples taken again, after records were made for a miss of their pixel's round.
    pub redone: u64,
    /// Pixels whose round was taken again (once per round).
    pub redone_pixels: u64,
}

/// One pixel's running sums (besides its layers').
#[derive(Clone, Default)]
struct PixelSums {
    /// Samples taken.
    n: u32,
    /// The spread of the beauty (adaptive sampling only).
    spread: Spread,
    /// With [`Sampling::past_aa_layers`], the spread of the sum of those layers.
    monte_carlo_spread: Option<Box<Spread>>,
    /// Whether a sample made a Monte Carlo estimate (the pixel may then go past `aa_spp`).
    monte_carlo: bool,
}

/// How a value's samples differ within the quarters of a pixel.
#[derive(Clone, Default)]
struct Spread {
    /// Pairs of whole groups (the 1st and 2nd, the 3rd and 4th, …), and per channel the sum over them
    /// of the squared difference between their samples in the same quarter.
    pairs: u32,
    diff2: [f32; 3],
    /// The value of each quarter's sample in the first group of a pair, until its second group comes.
    first: [[f32; 3]; 4],
}

impl Spread {
    /// Adds sample `s` (of at most `spp`) of value `b`.
    fn add(&mut self, s: u32, spp: u32, b: Vec3) {
        if !in_whole_group(s, spp) {
            return;
        }
        let (group, quarter) = ((s / GROUP) as usize, (s % GROUP) as usize);
        if group % 2 == 0 {
            self.first[quarter] = b.to_array();
            return;
        }
        for c in 0..3 {
            self.diff2[c] += (b[c] - self.first[quarter][c]).powi(2);
        }
        self.pairs += (quarter == GROUP as usize - 1) as u32;
    }
}

/// Bytes per pixel of the tiles' running sums besides their layers.
/// (the second spread only in scenes that name [`Sampling::past_aa_layers`]; 16 for its allocation).
pub const SUMS_BYTES_PER_PIXEL: u64 =
    (std::mem::size_of::<PixelSums>() + std::mem::size_of::<Spread>() + 16) as u64;

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

/// A pixel as it stood before a round in which some sample missed, to take the round again.
struct Redo {
    k: usize,
    sums: PixelSums,
    layers: [Vec3; MAX_LAYERS],
    memo_len: usize,
    /// The round's samples as first taken: what they counted, and where they missed.
    counters: SampleCounters,
    missed: Vec<[f32; 2]>,
}

/// Sample counts of the rounds: 4, 8, 16, … up to `spp` (one round of `spp` without a noise target),
/// `aa_spp` among them.
fn rounds(spp: u32, aa_spp: u32, adaptive: bool) -> Vec<u32> {
    if !adaptive {
        return vec![spp];
    }
    let mut r = vec![MIN_ADAPTIVE_SPP.min(spp)];
    while *r.last().unwrap_or(&spp) < spp {
        let last = r[r.len() - 1];
        let next = (last * 2).min(spp);
        r.push(if last < aa_spp && aa_spp < next {
            aa_spp
        } else {
            next
        });
    }
    r
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

/// One flag per pixel of a window (row-major).
struct Active {
    window: Window,
    flags: Vec<bool>,
}

impl Active {
    /// Every pixel of the window but those `kept` marks (row-major over an image `width` wide).
    fn all(window: Window, kept: Option<&[bool]>, width: u32) -> Active {
        let mut flags = vec![true; window.n_pixels() as usize];
        if let Some(kept) = kept {
            let ww = window.x1 - window.x0;
            for (i, f) in flags.iter_mut().enumerate() {
                let (x, y) = (window.x0 + i as u32 % ww, window.y0 + i as u32 / ww);
                *f = !kept[(y * width + x) as usize];
            }
        }
        Active { window, flags }
    }

    fn is(&self, x: u32, y: u32) -> bool {
        self.flags[self.at(x, y)]
    }

    fn at(&self, x: u32, y: u32) -> usize {
        let w = self.window;
        (y - w.y0) as usize * (w.x1 - w.x0) as usize + (x - w.x0) as usize
    }
}

/// The canvas's per-pixel masks (row-major over an image `width` wide), after a round that took each
/// sampling pixel to `done` samples.
#[derive(Clone, Copy)]
struct Masks<'a> {
    width: u32,
    kept: Option<&'a [bool]>,
    kept_samples: Option<&'a [u32]>,
    repeat: Option<&'a [bool]>,
    done: u32,
}

/// The pixels that take the next round's samples: those not converged (at their noise target) and
/// their neighbours — a kept pixel counting as not converged while it took more samples than `done`
/// when last shaded; `past_aa`, only among those whose samples made Monte Carlo estimates. A pixel
/// that repeats its samples takes as many as it took when last shaded, no more, no fewer.
fn next_round(
    tiles: &[TileState],
    window: Window,
    past_aa: bool,
    sampling: &Sampling,
    masks: Masks,
) -> Active {
    let (ww, wh) = (
        (window.x1 - window.x0) as usize,
        (window.y1 - window.y0) as usize,
    );
    let mut open = vec![false; ww * wh];
    let mut allowed = vec![true; ww * wh];
    let mut forced: Vec<Option<bool>> = vec![None; ww * wh];
    // The mean of each pixel that took samples of its own this round.
    let mut sampled: Vec<Option<Vec3>> = vec![None; ww * wh];
    for t in tiles {
        let w = t.window;
        for y in w.y0..w.y1 {
            for x in w.x0..w.x1 {
                let k = ((y - w.y0) * (w.x1 - w.x0) + (x - w.x0)) as usize;
                let px = &t.pixels[k];
                let mean = t.layers.iter().map(|l| l[k]).sum::<Vec3>() / px.n as f32;
                let at = (y - window.y0) as usize * ww + (x - window.x0) as usize;
                let i = (y * masks.width + x) as usize;
                let before = masks.kept_samples.map(|n| n[i]);
                if masks.kept.is_some_and(|k| k[i]) {
                    allowed[at] = false;
                    open[at] = before.is_some_and(|n| n > masks.done);
                    continue;
                }
                if let (Some(n), true) = (before, masks.repeat.is_some_and(|r| r[i])) {
                    open[at] = n > masks.done;
                    forced[at] = Some(px.n < n);
                    continue;
                }
                allowed[at] = !past_aa || px.monte_carlo;
                let spread = match &px.monte_carlo_spread {
                    Some(s) if past_aa => s,
                    _ => &px.spread,
                };
                open[at] = allowed[at] && !converged(spread, px.n, mean, sampling.noise_at(x, y));
                sampled[at] = Some(mean);
            }
        }
    }
    if !past_aa {
        open_beside_brighter(&mut open, &allowed, &sampled, ww, wh);
    }
    let mut active = vec![false; ww * wh];
    for y in 0..wh {
        for x in 0..ww {
            active[y * ww + x] = forced[y * ww + x].unwrap_or_else(|| {
                allowed[y * ww + x]
                    && (y.saturating_sub(1)..(y + 2).min(wh)).any(|yy| {
                        (x.saturating_sub(1)..(x + 2).min(ww)).any(|xx| open[yy * ww + xx])
                    })
            });
        }
    }
    Active {
        window,
        flags: active,
    }
}

/// How many times brighter than a pixel (over a floor of 0.1) a neighbour must be for the pixel to go on
/// sampling before `aa_spp` whatever its own samples say.
const BRIGHTER_NEIGHBOUR: f32 = 4.0;

/// Opens each allowed pixel that has a neighbour [`BRIGHTER_NEIGHBOUR`] times brighter in some channel:
/// a few samples that all missed a bright sliver of the pixel (an emitter's edge seen at a grazing
/// angle, a sunlit gap) agree with one another, so the pixel's own spread says it has converged while
/// its mean may be off by the sliver's whole light. The neighbour rule then opens the pixels around it.
fn open_beside_brighter(
    open: &mut [bool],
    allowed: &[bool],
    sampled: &[Option<Vec3>],
    ww: usize,
    wh: usize,
) {
    let floor = REL_FLOOR.sqrt() as f32;
    for y in 0..wh {
        for x in 0..ww {
            let at = y * ww + x;
            let (Some(m), true, false) = (sampled[at], allowed[at], open[at]) else {
                continue;
            };
            let limit = (m + Vec3::splat(floor)) * BRIGHTER_NEIGHBOUR;
            open[at] = (y.saturating_sub(1)..(y + 2).min(wh)).any(|yy| {
                (x.saturating_sub(1)..(x + 2).min(ww))
                    .any(|xx| sampled[yy * ww + xx].is_some_and(|n| n.cmpgt(limit).any()))
            });
        }
    }
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

/// What every round shares: where samples go and how their random numbers are drawn.
struct RoundSpec {
    width: u32,
    spp: u32,
    seed: u64,
    adaptive: bool,
    past_aa_layers: Option<u32>,
    lobe_points: bool,
}

impl RoundSpec {
    /// Pixel (x, y) of tile `t` takes samples until it has `target`; with `keep_redo`, a pixel whose
    /// samples missed keeps its state from before them (and their counters) in `t.redo` instead of
    /// adding the counters to `counters`. False when `cancel` stopped it.
    #[allow(clippy::too_many_arguments)]
    fn take(
        &self,
        t: &mut TileState,
        x: u32,
        y: u32,
        target: u32,
        sampler: &dyn Sampler,
        keep_redo: bool,
        counters: &mut SampleCounters,
        cancel: &AtomicBool,
    ) -> bool {
        let w = t.window;
        let k = ((y - w.y0) * (w.x1 - w.x0) + (x - w.x0)) as usize;
        let before = keep_redo.then(|| {
            let mut layers = [Vec3::ZERO; MAX_LAYERS];
            for (l, layer) in layers.iter_mut().zip(&t.layers) {
                *l = layer[k];
            }
            Redo {
                k,
                sums: t.pixels[k].clone(),
                layers,
                memo_len: t.memos[k].len(),
                counters: SampleCounters::default(),
                missed: Vec::new(),
            }
        });
        let mut own = SampleCounters::default();
        let mut missed = Vec::new();
        let pixel = y as u64 * self.width as u64 + x as u64;
        let px = &mut t.pixels[k];
        let memo = &mut t.memos[k];
        while px.n < target {
            // Read every sample: one relaxed load next to a whole camera path costs nothing, and a
            // single pixel at 100 000 spp must stop at once.
            if cancel.load(Ordering::Relaxed) {
                *counters += own;
                return false;
            }
            let mut rng = Rng::new(hash_keys(&[self.seed, pixel, px.n as u64]));
            let (u, v) = (rng.uniform(), rng.uniform());
            let off = offset(self.seed, pixel, px.n, self.spp, u, v);
            let at = SamplePoint {
                offset: off,
                points: Stratified {
                    lobe: if self.lobe_points {
                        lobe_point(self.seed, pixel, px.n, self.spp)
                    } else {
                        [0.5, 0.5]
                    },
                    light: light_points(self.seed, pixel, px.n, self.spp),
                },
            };
            let (misses, monte_carlo) = (own.lookups.n_misses, own.monte_carlo);
            let values = sampler.sample(x, y, at, memo, &mut rng, &mut own, keep_redo);
            px.monte_carlo |= own.monte_carlo > monte_carlo;
            if own.lookups.n_misses > misses {
                missed.push(off);
            }
            let (mut b, mut mc) = (Vec3::ZERO, Vec3::ZERO);
            for (i, (layer, l)) in t.layers.iter_mut().zip(values).enumerate() {
                let l = sanitize(l, &mut own);
                layer[k] += l;
                b += l;
                if self.past_aa_layers.is_some_and(|m| m >> i & 1 == 1) {
                    mc += l;
                }
            }
            if self.adaptive {
                px.spread.add(px.n, self.spp, b);
                if let Some(spread) = px.monte_carlo_spread.as_mut() {
                    spread.add(px.n, self.spp, mc);
                }
            }
            px.n += 1;
        }
        match before {
            Some(before) if !missed.is_empty() => t.redo.push(Redo {
                counters: own,
                missed,
                ..before
            }),
            _ => *counters += own,
        }
        true
    }
}

/// After a round: the samples that missed go to the sampler, which may add records for them; then their
/// pixels go back to where they stood before the round and take it again, misses answered in full this
/// time (the first attempt's rays count in `total`, its lookups do not).
fn redo_missed(
    tiles: &mut [TileState],
    round: &RoundSpec,
    target: u32,
    sampler: &mut dyn Sampler,
    total: &mut SampleCounters,
    count: &mut SampleCount,
    cancel: &AtomicBool,
) -> Result<()> {
    let mut missed = Vec::new();
    for t in tiles.iter() {
        let w = t.window;
        for r in &t.redo {
            let (x, y) = (
                w.x0 + r.k as u32 % (w.x1 - w.x0),
                w.y0 + r.k as u32 / (w.x1 - w.x0),
            );
            missed.extend(r.missed.iter().map(|&offset| MissedSample { x, y, offset }));
        }
    }
    missed.sort_by_key(|m| (m.y, m.x));
    sampler.end_round(&missed)?;
    if missed.is_empty() {
        return Ok(());
    }
    for t in tiles.iter_mut() {
        for r in &t.redo {
            *total += r.counters.work();
            count.redone += (target - r.sums.n) as u64;
            count.redone_pixels += 1;
            t.pixels[r.k] = r.sums.clone();
            for (layer, l) in t.layers.iter_mut().zip(r.layers) {
                layer[r.k] = l;
            }
            t.memos[r.k].truncate(r.memo_len);
        }
    }
    let sampler_ref: &dyn Sampler = sampler;
    let counters = tiles
        .par_iter_mut()
        .with_max_len(1)
        .map(|t| {
            let mut counters = SampleCounters::default();
            let redo = std::mem::take(&mut t.redo);
            let w = t.window;
            for r in redo {
                let (x, y) = (
                    w.x0 + r.k as u32 % (w.x1 - w.x0),
                    w.y0 + r.k as u32 / (w.x1 - w.x0),
                );
                if !round.take(t, x, y, target, sampler_ref, false, &mut counters, cancel) {
                    break;
                }
            }
            counters
        })
        .reduce(SampleCounters::default, |mut a, b| {
            a += b;
            a
        });
    *total += counters;
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::Interrupted);
    }
    Ok(())
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
