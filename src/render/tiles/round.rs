//! One round of a pixel's samples, and the round taken again for the pixels whose samples missed
//! the cache (after the sampler made records for them).

use super::*;

/// A pixel as it stood before a round in which some sample missed, to take the round again.
pub(super) struct Redo {
    pub(super) k: usize,
    pub(super) sums: PixelSums,
    pub(super) layers: [Vec3; MAX_LAYERS],
    pub(super) memo_len: usize,
    /// The round's samples as first taken: what they counted, and where they missed.
    pub(super) counters: SampleCounters,
    pub(super) missed: Vec<[f32; 2]>,
}

/// What every round shares: where samples go and how their random numbers are drawn.
pub(super) struct RoundSpec {
    pub(super) width: u32,
    pub(super) spp: u32,
    pub(super) seed: u64,
    pub(super) adaptive: bool,
    pub(super) past_aa_layers: Option<u32>,
    pub(super) lobe_points: bool,
}

impl Redo {
    /// Pixel `k` of tile `t` as it stands, to take a round again from.
    fn of(t: &TileState, k: usize) -> Redo {
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
    }
}

impl RoundSpec {
    /// Where sample `n` of pixel `pixel` falls, `uv` its own random numbers for an offset outside a
    /// whole group.
    fn sample_point(&self, pixel: u64, n: u32, (u, v): (f32, f32)) -> SamplePoint {
        SamplePoint {
            offset: offset(self.seed, pixel, n, self.spp, u, v),
            points: Stratified {
                lobe: if self.lobe_points {
                    lobe_point(self.seed, pixel, n, self.spp)
                } else {
                    [0.5, 0.5]
                },
                light: light_points(self.seed, pixel, n, self.spp),
            },
        }
    }

    /// Pixel (x, y) of tile `t` takes samples until it has `target`; with `keep_redo`, a pixel whose
    /// samples missed keeps its state from before them (and their counters) in `t.redo` instead of
    /// adding the counters to `counters`. False when `cancel` stopped it.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn take(
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
        let before = keep_redo.then(|| Redo::of(t, k));
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
            let at = self.sample_point(pixel, px.n, (u, v));
            let off = at.offset;
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
pub(super) fn redo_missed(
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
