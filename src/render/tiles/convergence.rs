//! Adaptive sampling: how many samples each pixel takes, when its samples estimate it well enough,
//! the rounds, and which pixels (and their neighbours, and a sequence's kept pixels) take the next.

use super::*;

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
    pub(super) fn noise_at(&self, x: u32, y: u32) -> f32 {
        match self.finer {
            Some((w, noise)) if x >= w.x0 && x < w.x1 && y >= w.y0 && y < w.y1 => noise,
            _ => self.noise,
        }
    }
}

/// The fewest samples a pixel takes under a noise target (one group of strata).
pub const MIN_ADAPTIVE_SPP: u32 = 4;
/// Samples per group of strata.
pub(super) const GROUP: u32 = 4;
/// Floor of the squared mean in the relative variance, as in the relMSE of the accuracy figures.
pub(super) const REL_FLOOR: f64 = pmbase::REL_MSE_FLOOR;

/// True when a pixel's `n` samples, whose mean is `mean` and spread `spread`, estimate it well enough:
/// Σ_c Var[x̄_c] / (x̄_c² + 0.01) ≤ 3 noise² (each channel's relative variance, averaged). Var[x̄] comes
/// from within the quarters once the pixel has a pair of groups (see the module header), else from the
/// plain variance of its first group (a decision is due only at the end of a round, and the first round
/// is that group).
pub(super) fn converged(spread: &Spread, n: u32, mean: Vec3, noise: f32) -> bool {
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
pub(super) struct PixelSums {
    /// Samples taken.
    pub(super) n: u32,
    /// The spread of the beauty (adaptive sampling only).
    pub(super) spread: Spread,
    /// With [`Sampling::past_aa_layers`], the spread of the sum of those layers.
    pub(super) monte_carlo_spread: Option<Box<Spread>>,
    /// Whether a sample made a Monte Carlo estimate (the pixel may then go past `aa_spp`).
    pub(super) monte_carlo: bool,
}

/// How a value's samples differ within the quarters of a pixel.
#[derive(Clone, Default)]
pub(super) struct Spread {
    /// Pairs of whole groups (the 1st and 2nd, the 3rd and 4th, …), and per channel the sum over them
    /// of the squared difference between their samples in the same quarter.
    pub(super) pairs: u32,
    pub(super) diff2: [f32; 3],
    /// The value of each quarter's sample in the first group of a pair, until its second group comes.
    pub(super) first: [[f32; 3]; 4],
}

impl Spread {
    /// Adds sample `s` (of at most `spp`) of value `b`.
    pub(super) fn add(&mut self, s: u32, spp: u32, b: Vec3) {
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

/// Sample counts of the rounds: 4, 8, 16, … up to `spp` (one round of `spp` without a noise target),
/// `aa_spp` among them.
pub(super) fn rounds(spp: u32, aa_spp: u32, adaptive: bool) -> Vec<u32> {
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

/// One flag per pixel of a window (row-major).
pub(super) struct Active {
    pub(super) window: Window,
    pub(super) flags: Vec<bool>,
}

impl Active {
    /// Every pixel of the window but those `kept` marks (row-major over an image `width` wide).
    pub(super) fn all(window: Window, kept: Option<&[bool]>, width: u32) -> Active {
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

    pub(super) fn is(&self, x: u32, y: u32) -> bool {
        self.flags[self.at(x, y)]
    }

    pub(super) fn at(&self, x: u32, y: u32) -> usize {
        let w = self.window;
        (y - w.y0) as usize * (w.x1 - w.x0) as usize + (x - w.x0) as usize
    }
}

/// The canvas's per-pixel masks (row-major over an image `width` wide), after a round that took each
/// sampling pixel to `done` samples.
#[derive(Clone, Copy)]
pub(super) struct Masks<'a> {
    pub(super) width: u32,
    pub(super) kept: Option<&'a [bool]>,
    pub(super) kept_samples: Option<&'a [u32]>,
    pub(super) repeat: Option<&'a [bool]>,
    pub(super) done: u32,
}

/// The pixels that take the next round's samples: those not converged (at their noise target) and
/// their neighbours — a kept pixel counting as not converged while it took more samples than `done`
/// when last shaded; `past_aa`, only among those whose samples made Monte Carlo estimates. A pixel
/// that repeats its samples takes as many as it took when last shaded, no more, no fewer.
pub(super) fn next_round(
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
pub(super) const BRIGHTER_NEIGHBOUR: f32 = 4.0;

/// Opens each allowed pixel that has a neighbour [`BRIGHTER_NEIGHBOUR`] times brighter in some channel:
/// a few samples that all missed a bright sliver of the pixel (an emitter's edge seen at a grazing
/// angle, a sunlit gap) agree with one another, so the pixel's own spread says it has converged while
/// its mean may be off by the sliver's whole light. The neighbour rule then opens the pixels around it.
pub(super) fn open_beside_brighter(
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
