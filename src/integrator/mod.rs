//! Integrators: the path-tracing reference and the photon-map methods built on Jensen's split.
pub mod cache_fill;
pub mod in_scatter;
pub mod occlusion;
pub mod path;
pub mod pm;
pub mod radiance_cache;
pub mod terms;

use glam::Vec3;

use crate::counters::SampleCounters;

/// The points of the unit square a camera sample's area-light samples at its first hit take: points
/// `first`, `first + 1`, … of a scrambled Sobol' sequence of the pixel's own, so that over the pixel's
/// samples the light's area is stratified ever more finely (a soft shadow's noise falls faster than
/// with independent points).
#[derive(Clone, Copy, Debug)]
pub struct LightPoints {
    pub stream: u64,
    pub first: u32,
}

/// A camera sample's points stratified over its pixel's samples: for the first glossy lobe it samples
/// (`lobe`) and for the area-light samples at its first hit (`light`; `None`: the sample's own random
/// numbers).
#[derive(Clone, Copy, Debug)]
pub struct Stratified {
    pub lobe: [f32; 2],
    pub light: Option<LightPoints>,
}

impl LightPoints {
    /// Point `j` of this sample's.
    pub fn point(&self, j: u32) -> [f32; 2] {
        photon::sampling::sobol_2d(self.first + j, self.stream)
    }
}

/// Soft indirect (and faint caustic) irradiance already computed in one pixel, per surface the camera
/// sees there (triangle and side), for the pixel's later samples on that surface; kept across the rounds
/// of adaptive sampling while the pixel takes samples. Why: each cache lookup (the index's candidates,
/// in a sequence a shadow ray to each record of an earlier frame), like each caustic k-NN estimate
/// with its coverage probes, costs more than the rest of a sample. Where the first sample's lookup
/// interpolated records that disagree there (a contact shadow, a crease: the light changes within the
/// pixel), the memo also keeps how the interpolation of those records changes across the pixel
/// ([`Slope`]), and the later samples follow it: one value for the whole pixel was an error there that
/// no number of samples reduced. A bright caustic is estimated again at every sample: its edges are
/// sharp within a pixel, and reusing it blurred them. Each sample still traces its own camera ray,
/// shadow rays and texture lookups.
#[derive(Clone, Debug, Default)]
pub struct PixelMemo {
    entries: Vec<MemoEntry>,
}

#[derive(Clone, Debug)]
struct MemoEntry {
    tri: u32,
    front: bool,
    /// `None` when too bright to reuse.
    caustic: Option<Vec3>,
    indirect: Vec3,
    slope: Option<Slope>,
    /// The cache lookups the first sample made, counted again for each reuse.
    lookups: Replay,
}

/// A [`icache::LookupStats`] of one sample's lookups, in 8 bytes (a memo lives as long as its pixel
/// takes samples: up to every pixel of the image at once). Counts above the field's range saturate.
#[derive(Clone, Copy, Debug)]
struct Replay {
    lookups: u8,
    misses: u8,
    single_record: u8,
    extrapolated: u8,
    gathered: u8,
    bump_rotated: u8,
    records_used: u16,
}

impl Replay {
    fn of(s: &icache::LookupStats) -> Replay {
        let n = |v: u64| v.min(u8::MAX as u64) as u8;
        Replay {
            lookups: n(s.n_lookups),
            misses: n(s.n_misses),
            single_record: n(s.n_single_record),
            extrapolated: n(s.n_extrapolated),
            gathered: n(s.n_gathered),
            bump_rotated: n(s.n_bump_rotated),
            records_used: s.n_records_used.min(u16::MAX as u64) as u16,
        }
    }

    fn stats(&self) -> icache::LookupStats {
        icache::LookupStats {
            n_lookups: self.lookups as u64,
            n_misses: self.misses as u64,
            n_single_record: self.single_record as u64,
            n_extrapolated: self.extrapolated as u64,
            n_gathered: self.gathered as u64,
            n_records_used: self.records_used as u64,
            n_reused: 0,
            n_bump_rotated: self.bump_rotated as u64,
        }
    }
}

/// Surfaces remembered per pixel (later ones are estimated at every sample).
const MEMO_SURFACES: usize = 4;

/// How the soft indirect irradiance changes across a pixel's surface from the first sample's point:
/// per unit length along the two tangent axes of the surface's normal
/// ([`glam::Vec3::any_orthonormal_pair`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slope {
    pub at: Vec3,
    pub along: [Vec3; 2],
}

impl Slope {
    /// The irradiance `e` at `at` carried to `p` (normal `n`), at least 0.
    pub fn carry(&self, e: Vec3, p: Vec3, n: Vec3) -> Vec3 {
        let (s, t) = n.any_orthonormal_pair();
        let d = p - self.at;
        (e + self.along[0] * d.dot(s) + self.along[1] * d.dot(t)).max(Vec3::ZERO)
    }
}

/// What a pixel's memo holds for a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Remembered {
    /// The caustic irradiance, `None` when too bright to reuse.
    pub caustic: Option<Vec3>,
    /// The soft indirect irradiance of the first sample.
    pub indirect: Vec3,
    /// How it changes across the pixel, where it does.
    pub slope: Option<Slope>,
}

/// The most a pixel's memo holds while its pixel takes samples: the vector, its entries (grown one at a
/// time) and the allocator's overhead. Below pass A's per-pixel bytes, which are freed before shading.
pub const MEMO_BYTES_PER_PIXEL: u64 =
    (std::mem::size_of::<PixelMemo>() + 16 + MEMO_SURFACES * std::mem::size_of::<MemoEntry>())
        as u64;

impl PixelMemo {
    /// Surfaces remembered.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Forget the surfaces remembered after the first `n`.
    pub fn truncate(&mut self, n: usize) {
        self.entries.truncate(n);
    }

    /// Forget every surface and free the memory.
    pub fn clear(&mut self) {
        self.entries = Vec::new();
    }

    /// What an earlier sample computed on side `front` of triangle `tri`, if one did; its cache
    /// lookups are counted again in `c`.
    pub fn get(&self, tri: u32, front: bool, c: &mut SampleCounters) -> Option<Remembered> {
        let e = self
            .entries
            .iter()
            .find(|e| e.tri == tri && e.front == front)?;
        c.lookups.replay(&e.lookups.stats());
        Some(Remembered {
            caustic: e.caustic,
            indirect: e.indirect,
            slope: e.slope,
        })
    }

    pub fn put(
        &mut self,
        tri: u32,
        front: bool,
        remembered: Remembered,
        lookups: icache::LookupStats,
    ) {
        if self.entries.len() < MEMO_SURFACES {
            // One surface is the common case: no room for four.
            self.entries.reserve_exact(1);
            self.entries.push(MemoEntry {
                tri,
                front,
                caustic: remembered.caustic,
                indirect: remembered.indirect,
                slope: remembered.slope,
                lookups: Replay::of(&lookups),
            });
        }
    }
}

/// Replaces a non-finite or negative radiance by zero, counting it.
pub fn sanitize(l: Vec3, counters: &mut SampleCounters) -> Vec3 {
    if l.is_finite() && l.min_element() >= 0.0 {
        l
    } else {
        counters.nan_or_negative += 1;
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(n: u64) -> icache::LookupStats {
        icache::LookupStats {
            n_lookups: n,
            n_records_used: 2 * n,
            ..Default::default()
        }
    }

    /// An entry gives back what was put, replaying its lookups each time; a slope carries the value
    /// across the surface.
    #[test]
    fn a_memo_gives_back_its_surfaces_and_carries_a_slope() {
        let mut m = PixelMemo::default();
        let n = Vec3::Z;
        let (s, t) = n.any_orthonormal_pair();
        let slope = Slope {
            at: Vec3::ZERO,
            along: [Vec3::splat(2.0), Vec3::ZERO],
        };
        let r = Remembered {
            caustic: None,
            indirect: Vec3::ONE,
            slope: Some(slope),
        };
        m.put(7, true, r, stats(1));
        let mut c = SampleCounters::default();
        assert_eq!(m.get(7, true, &mut c), Some(r));
        assert_eq!((c.lookups.n_lookups, c.lookups.n_reused), (1, 1));
        assert!(m.get(7, false, &mut c).is_none());
        let at = |p: Vec3| slope.carry(Vec3::ONE, p, n);
        assert!((at(0.1 * s) - Vec3::splat(1.2)).abs().max_element() < 1e-6);
        assert!((at(0.1 * t) - Vec3::ONE).abs().max_element() < 1e-6);
        // Never below zero.
        assert_eq!(at(-s), Vec3::ZERO);
    }
}
