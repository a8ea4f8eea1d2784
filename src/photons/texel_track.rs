//! What an atlas texel's value was made of, kept over a sequence's frames so that the next frame
//! updates the texel by the photons that changed instead of estimating it again.
//!
//! A texel's photon irradiance is a sum over the photons in its disc (radius `r` about the texel's
//! middle, within the slab of its tangent plane) divided by the disc's surface area. Where neither the
//! geometry its disc probes nor its lights' shadow rays changed, that area stays what it was: adding
//! the photons that entered the disc and taking away those that left gives the sum over this frame's
//! photons at the same radius — a density estimate over a fixed disc instead of the k nearest. The
//! photons no mover touched contribute exactly as before, so a texel's value moves only by what
//! changed: no re-estimate's noise, and no drift left behind until it builds up.

use std::sync::Mutex;

use glam::Vec3;

/// What a texel holds: the diffuse radiance it reflects (its mean diffuse albedo / π × all of its
/// irradiance, direct from shadow rays and the rest from photons), and the irradiance of its indirect
/// photons only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexelIrradiance {
    pub radiance: Vec3,
    pub e_indirect: Vec3,
    /// Zero, except on an edge texel — one whose direct light from the point, spot and directional lights
    /// varies across it by more than [`EDGE_CONTRAST`](super::atlas::EDGE_CONTRAST) (a shadow's edge crosses it, or a light's falloff
    /// is steep there): its mean albedo / π, and `radiance` leaves that direct light out; the reader
    /// adds `albedo_pi` × that light at its own point ([`direct_at`](super::atlas::direct_at)).
    pub albedo_pi: Vec3,
}

/// A texel's estimate, in parts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// Irradiance of the photons that are not direct, and of the indirect ones.
    pub e_not_direct: Vec3,
    pub e_indirect: Vec3,
    /// The lights' direct irradiance added to the photons' (on an edge texel the area lights' only).
    pub light: Vec3,
    /// The texel's mean diffuse albedo / π.
    pub albedo_pi: Vec3,
    pub edge: bool,
    /// The disc: the squared distance its photons lie below (see [`photon::Estimate::within2`]), the
    /// slab's half thickness, and the surface area the sums are divided by (0: not measured, as no
    /// photon was found).
    pub within2: f32,
    pub half_thickness: f32,
    pub area: f32,
    /// Photons counted now, and when the texel was estimated.
    pub n: u32,
    pub n0: u32,
}

/// The photons that entered a texel's disc less those that left it: their power, not direct and
/// indirect, and their number (entered − left).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiscChange {
    pub not_direct: Vec3,
    pub indirect: Vec3,
    pub n: i32,
}

/// A fixed disc holding fewer than half or more than twice the photons it was estimated with is
/// estimated again (the k nearest then set a new radius): its estimate's noise, or its blur, has
/// left the k-nearest estimate's.
const MAX_COUNT_FACTOR: u32 = 2;

impl Track {
    /// The texel's value: the diffuse radiance it reflects and the irradiance of its indirect photons.
    pub fn texel(&self) -> TexelIrradiance {
        TexelIrradiance {
            radiance: self.albedo_pi * (self.light + self.e_not_direct),
            e_indirect: self.e_indirect,
            albedo_pi: if self.edge {
                self.albedo_pi
            } else {
                Vec3::ZERO
            },
        }
    }

    /// The track after `change` of its disc's photons; `None` where the texel is to be estimated
    /// again (its disc was not measured, or its count left the range it was estimated in).
    pub fn updated(&self, change: DiscChange) -> Option<Track> {
        if change == DiscChange::default() {
            return Some(*self);
        }
        let n = u32::try_from(self.n as i64 + change.n as i64).ok()?;
        if !(self.area > 0.0)
            || n * MAX_COUNT_FACTOR < self.n0
            || n > MAX_COUNT_FACTOR * self.n0.max(1)
        {
            return None;
        }
        Some(Track {
            e_not_direct: (self.e_not_direct + change.not_direct / self.area).max(Vec3::ZERO),
            e_indirect: (self.e_indirect + change.indirect / self.area).max(Vec3::ZERO),
            n,
            ..*self
        })
    }
}

/// The tracks of the texels estimated in a frame, by slot, gathered from every thread.
pub(crate) struct Tracks(Vec<Mutex<Vec<(u32, Track)>>>);

/// Lists the tracks are spread over (by slot), so that threads seldom wait on each other.
const SHARDS: usize = 64;

impl Tracks {
    pub fn new() -> Tracks {
        Tracks((0..SHARDS).map(|_| Mutex::new(Vec::new())).collect())
    }

    pub fn push(&self, slot: u32, track: Track) {
        let shard = &self.0[slot as usize % SHARDS];
        shard
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .push((slot, track));
    }

    /// The track of `slot`, if any.
    #[cfg(test)]
    pub fn find(&self, slot: u32) -> Option<Track> {
        let list = self.0[slot as usize % SHARDS].lock().ok()?;
        list.iter().find(|(s, _)| *s == slot).map(|(_, t)| *t)
    }

    /// Every track, found by slot (`slots` of them): 4 bytes a slot, not a track's 70.
    pub fn by_slot(self, slots: usize) -> BySlot {
        let mut found = BySlot {
            index: vec![u32::MAX; slots],
            tracks: Vec::new(),
        };
        for shard in self.0 {
            let list = shard
                .into_inner()
                .unwrap_or_else(|poisoned| poisoned.into_inner());
            for (slot, track) in list {
                if let Some(i) = found.index.get_mut(slot as usize) {
                    *i = found.tracks.len() as u32;
                    found.tracks.push(track);
                }
            }
        }
        found
    }
}

/// The tracks of a frame, found by slot ([`Tracks::by_slot`]).
pub(crate) struct BySlot {
    index: Vec<u32>,
    tracks: Vec<Track>,
}

impl BySlot {
    pub fn get(&self, slot: u32) -> Option<Track> {
        let i = *self.index.get(slot as usize)?;
        self.tracks.get(i as usize).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track() -> Track {
        Track {
            e_not_direct: Vec3::splat(2.0),
            e_indirect: Vec3::splat(1.0),
            light: Vec3::splat(3.0),
            albedo_pi: Vec3::splat(0.5),
            edge: false,
            within2: 0.01,
            half_thickness: 0.02,
            area: 0.5,
            n: 100,
            n0: 100,
        }
    }

    #[test]
    fn a_texel_moves_by_the_power_that_entered_its_disc_less_what_left() {
        let t = track();
        assert_eq!(t.texel().radiance, Vec3::splat(2.5));
        let change = DiscChange {
            not_direct: Vec3::new(0.1, 0.0, -0.1),
            indirect: Vec3::new(0.05, 0.0, 0.0),
            n: 1,
        };
        let u = t.updated(change).expect("kept");
        assert_eq!(u.e_not_direct, Vec3::new(2.2, 2.0, 1.8));
        assert_eq!(u.e_indirect, Vec3::new(1.1, 1.0, 1.0));
        assert_eq!(u.n, 101);
        // Edge texels leave the delta lights to their readers.
        let e = Track { edge: true, ..t };
        assert_eq!(e.texel().albedo_pi, Vec3::splat(0.5));
        assert_eq!(t.texel().albedo_pi, Vec3::ZERO);
    }

    #[test]
    fn a_disc_far_from_its_count_or_never_measured_is_estimated_again() {
        let t = track();
        let lost = |n: i32| DiscChange {
            n: -n,
            ..Default::default()
        };
        assert!(t.updated(lost(50)).is_some());
        assert!(t.updated(lost(51)).is_none());
        assert!(t.updated(lost(101)).is_none());
        assert!(t.updated(DiscChange { n: 101, ..lost(0) }).is_none());
        let unmeasured = Track { area: 0.0, ..t };
        assert_eq!(unmeasured.updated(lost(0)), Some(unmeasured));
        assert!(unmeasured.updated(DiscChange { n: 1, ..lost(0) }).is_none());
    }

    #[test]
    fn tracks_from_every_shard_come_back_by_slot() {
        let tracks = Tracks::new();
        for slot in [3u32, 70, 5] {
            tracks.push(slot, Track { n: slot, ..track() });
        }
        let by = tracks.by_slot(80);
        assert_eq!((0..80).filter(|&s| by.get(s).is_some()).count(), 3);
        assert_eq!(by.get(70).map(|t| t.n), Some(70));
        assert!(by.get(4).is_none());
    }
}
