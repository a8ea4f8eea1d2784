//! What a method computes per sample, and the records a method that grows its cache makes between
//! rounds.

use super::*;

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
