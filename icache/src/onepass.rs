//! The classic one-pass fill (Ward 1988), kept to measure what the two-pass fill removes.
//!
//! Pixels are visited in scanline order, one at a time: a shading point with no usable record gathers and
//! inserts one at once, and the pixel is shaded from the records that existed when it was visited. Records
//! created further down the image never reach back to pixels already shaded, which is what produces the
//! scanline-order discontinuities. Shading happens later, in parallel: [`OnePassFill::visible_records`]
//! tells the shader how many records (in insertion order) pixel (x, y) may use.
//! One difference from a truly lazy render: neighbor clamping may later shrink a record that an earlier
//! pixel saw at its full radius.
#![forbid(unsafe_code)]

use std::ops::AddAssign;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::cache::IrradianceCache;
use crate::params::Pass;
use crate::record::NewRecord;
use crate::stats::FillStats;
use crate::twopass::{GatherWithFn, PointsWithFn, ProgressFn};

/// The outcome of a one-pass fill: for each pixel, the record count after it was visited.
pub struct OnePassFill {
    width: u32,
    records_after: Vec<u32>,
}

impl OnePassFill {
    /// Records (a prefix in insertion order) that pixel (x, y) may use; every record outside the image.
    pub fn visible_records(&self, x: u32, y: u32) -> usize {
        let k = y as usize * self.width as usize + x as usize;
        self.records_after
            .get(k)
            .map_or(usize::MAX, |&n| n as usize)
    }
}

/// Fill the cache in scanline order, sequentially (so it does not depend on the thread count), with a
/// payload per shading point and statistics per gather (as
/// [`crate::fill_pass_a_cancellable`]), returning early soon after `cancel` is set (read before every
/// row). Returns the fill's statistics, the sum of the gathers' and the pixels' record counts.
pub fn fill_one_pass_cancellable<P, S: Default + AddAssign>(
    cache: &mut IrradianceCache,
    width: u32,
    height: u32,
    shading_points: &PointsWithFn<P>,
    gather: &GatherWithFn<P, S>,
    progress: &ProgressFn,
    cancel: &AtomicBool,
) -> (FillStats, S, OnePassFill) {
    let mut stats = FillStats {
        n_pixels: width as u64 * height as u64,
        ..FillStats::default()
    };
    let mut gathers = S::default();
    let mut records_after = Vec::with_capacity(stats.n_pixels as usize);
    for y in 0..height {
        if cancel.load(Ordering::Relaxed) {
            break;
        }
        for x in 0..width {
            for (i, (sp, payload)) in shading_points(x, y).into_iter().enumerate() {
                stats.n_points += 1;
                let hit = cache.lookup(sp.pos, sp.normal, Pass::A);
                stats.lookups.record(hit.as_ref());
                if hit.is_none() {
                    stats.n_gathers += 1;
                    let (rec, s) = gather(x, y, i, &sp, &payload);
                    gathers += s;
                    stats.insert += cache.insert(NewRecord {
                        pixel_world: sp.pixel_world,
                        ..rec
                    });
                }
            }
            records_after.push(cache.len().min(u32::MAX as usize) as u32);
        }
        progress((y as u64 + 1) * width as u64, stats.n_pixels);
    }
    (
        stats,
        gathers,
        OnePassFill {
            width,
            records_after,
        },
    )
}
