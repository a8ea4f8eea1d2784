//! What a photon trace leaves for a later trace over the same paths (an animation's next frame): each
//! path's segments — emission to first event, event to event, the last one out to far away if it
//! escaped — and the photons it left in each map, before normalisation. A path whose segments meet
//! nothing that moved since would be traced again exactly as it was (its random numbers are its
//! own): the later trace copies its photons instead ([`Reuse`]).

use glam::Vec3;

use crate::map::Photon;

/// Segments a log keeps at most (24 bytes each): a longer trace (a caustic map's millions of paths)
/// keeps none, and the next frame traces every path again.
const MAX_SEGMENTS: usize = 1 << 21;
/// How far an escaping path's last segment reaches.
pub(crate) const ESCAPE_LENGTH: f32 = 1.0e6;

/// The paths of a trace, in path order (see the module header).
#[derive(Default)]
pub struct PathLog {
    segments: Vec<[Vec3; 2]>,
    photons: [Vec<Photon>; 4],
    ends: Vec<PathEnds>,
    overflowed: bool,
}

/// Where a path's segments and photons end in the log, which maps it was traced for and how it
/// ended.
#[derive(Clone, Copy)]
struct PathEnds {
    segments: u32,
    photons: [u32; 4],
    want: u8,
    end: u8,
}

/// One path as a log holds it: its segments, its photons per map (global, caustic, volume, volume
/// caustic), the maps it was traced for and how it ended (bit sets and codes of `trace`).
pub(crate) struct LoggedPath<'a> {
    pub(crate) segments: &'a [[Vec3; 2]],
    pub(crate) photons: [&'a [Photon]; 4],
    pub(crate) want: u8,
    pub(crate) end: u8,
}

/// A trace over an earlier trace's paths that copies the paths nothing moved touched: `touched(a, b)`
/// says whether the segment from a to b may meet something that moved since the log's trace.
#[derive(Clone, Copy)]
pub struct Reuse<'a> {
    pub log: &'a PathLog,
    pub touched: &'a (dyn Fn(Vec3, Vec3) -> bool + Sync),
}

impl PathLog {
    /// Paths logged; 0 once the log overflowed (it serves no later trace).
    pub fn len(&self) -> usize {
        if self.overflowed {
            0
        } else {
            self.ends.len()
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn memory_bytes(&self) -> usize {
        self.segments.capacity() * std::mem::size_of::<[Vec3; 2]>()
            + self
                .photons
                .iter()
                .map(|p| p.capacity() * std::mem::size_of::<Photon>())
                .sum::<usize>()
            + self.ends.capacity() * std::mem::size_of::<PathEnds>()
    }

    /// Appends the next path.
    pub(crate) fn push(&mut self, path: LoggedPath) {
        if self.overflowed {
            return;
        }
        if self.segments.len() + path.segments.len() > MAX_SEGMENTS {
            *self = PathLog {
                overflowed: true,
                ..PathLog::default()
            };
            return;
        }
        self.segments.extend_from_slice(path.segments);
        for (log, new) in self.photons.iter_mut().zip(path.photons) {
            log.extend_from_slice(new);
        }
        self.ends.push(PathEnds {
            segments: self.segments.len() as u32,
            photons: [0, 1, 2, 3].map(|m| self.photons[m].len() as u32),
            want: path.want,
            end: path.end,
        });
    }

    /// Path `i`, if logged.
    pub(crate) fn path(&self, i: u64) -> Option<LoggedPath<'_>> {
        if self.overflowed {
            return None;
        }
        let i = usize::try_from(i).ok()?;
        let now = self.ends.get(i)?;
        let before = i.checked_sub(1).map(|j| self.ends[j]);
        let s0 = before.map_or(0, |b| b.segments) as usize;
        let p0 = before.map_or([0; 4], |b| b.photons);
        Some(LoggedPath {
            segments: &self.segments[s0..now.segments as usize],
            photons: [0, 1, 2, 3]
                .map(|m| &self.photons[m][p0[m] as usize..now.photons[m] as usize]),
            want: now.want,
            end: now.end,
        })
    }
}

/// Whether the segment from `a` to `b` passes within `r` of `c`.
pub fn segment_meets_sphere(a: Vec3, b: Vec3, c: Vec3, r: f32) -> bool {
    let d = b - a;
    let len2 = d.length_squared();
    let t = if len2 > 0.0 {
        ((c - a).dot(d) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + d * t).distance_squared(c) <= r * r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_meets_a_sphere_where_its_closest_point_is_inside() {
        let (a, b) = (Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0));
        assert!(segment_meets_sphere(a, b, Vec3::new(5.0, 0.9, 0.0), 1.0));
        assert!(!segment_meets_sphere(a, b, Vec3::new(5.0, 1.1, 0.0), 1.0));
        // Past the ends only the ends count.
        assert!(!segment_meets_sphere(a, b, Vec3::new(11.5, 0.0, 0.0), 1.0));
        assert!(segment_meets_sphere(a, b, Vec3::new(-0.5, 0.5, 0.0), 1.0));
        assert!(segment_meets_sphere(a, a, Vec3::new(0.5, 0.0, 0.0), 1.0));
    }
}
