//! Which texels of the irradiance atlas a sequence's frame takes from the frame before when meshes
//! moved, instead of estimating them again: most of a re-gather's time goes into estimating the
//! texels its rays reach.
//!
//! Both frames trace the same photon paths, as many per map ([`photon::retrace_photons`]), so a path
//! that met nothing that moved leaves the same photons bit for bit. A texel's value is a function of
//! the photons near its middle, of the geometry its estimate's disc probes and of its lights' shadow
//! rays. The last two are tested against the moved meshes' bounding spheres, before and after their
//! step. The photons are compared per cell of a hierarchy of lattices: the paths a mover deflects
//! scatter their photons over the whole scene, a few per texel, so a texel that kept its value only
//! while none of its photons changed would keep nothing. A cell counts as changed once the net power
//! of the photons that entered or left it since its texels were last estimated exceeds both three
//! standard deviations of that exchange (a shadow or a bounce of the mover, not the reshuffle of a
//! few paths) and 2 % of its power; the texels in a changed cell are estimated again and the cell
//! starts afresh. Fine cells see a shadow's edge, coarse ones a room-wide dimming that no single
//! texel's few photons can tell from noise (a ball sinking into a spot aimed at a far wall: the
//! wall's bounce light in the whole room).

use std::collections::{HashMap, HashSet};
use std::hash::{BuildHasherDefault, Hasher};

use glam::{IVec3, Vec3};
use photon::map::Photon;
use photon::sampling::hash_keys;
use rayon::prelude::*;

use super::frame_pixels::{shadow_ends, sphere_meets_cone};
use super::temporal::SceneChange;
use crate::photons::atlas::IrradianceAtlas;
use crate::photons::PhotonData;
use crate::scene::Scene;

/// The global map's photons that the atlas's estimates sum (those not direct) by value: each one's
/// hash of every field's bits, position and power, sorted by hash.
pub(super) struct PhotonKeys(Vec<(u64, Vec3, Vec3)>);

impl PhotonKeys {
    pub(super) fn of(photons: &[Photon]) -> PhotonKeys {
        let mut keys: Vec<(u64, Vec3, Vec3)> = photons
            .par_iter()
            .filter(|ph| !ph.direct)
            .map(|ph| {
                let mut bits = [0u64; 13];
                for (k, v) in [ph.pos, ph.wi, ph.power, ph.normal].iter().enumerate() {
                    for (c, x) in v.to_array().into_iter().enumerate() {
                        bits[3 * k + c] = x.to_bits() as u64;
                    }
                }
                bits[12] = ph.indirect as u64;
                (hash_keys(&bits), ph.pos, ph.power)
            })
            .collect();
        keys.par_sort_unstable_by_key(|k| k.0);
        PhotonKeys(keys)
    }

    /// The photons of one map and not of the other (the symmetric difference): hash, position, and
    /// power counted positive for this map's, negative for `before`'s.
    fn changed(&self, before: &PhotonKeys) -> Vec<(u64, Vec3, Vec3)> {
        let (a, b) = (&self.0, &before.0);
        let (mut i, mut j, mut out) = (0, 0, Vec::new());
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => {
                    out.push(a[i]);
                    i += 1;
                }
                std::cmp::Ordering::Greater => {
                    out.push((b[j].0, b[j].1, -b[j].2));
                    j += 1;
                }
                std::cmp::Ordering::Equal => {
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend_from_slice(&a[i..]);
        out.extend(b[j..].iter().map(|k| (k.0, k.1, -k.2)));
        out
    }
}

/// What the frames before leave for this frame's atlas: the last one's atlas and photons, and the
/// photon changes accumulated per cell since each cell's texels were last estimated.
pub(super) struct AtlasBefore {
    pub(super) atlas: IrradianceAtlas,
    pub(super) keys: PhotonKeys,
    pub(super) drift: Drift,
}

/// How far about a texel's middle its photon estimate's disc probes the geometry, in maximum search
/// radii: the disc's radius, and the gap probes up to twice the radius along the normal.
const PROBE_REACH: f32 = 2.5;
/// Standard deviations of its photons' exchange a cell's net change must exceed to count …
const SIGNIFICANT: f32 = 3.0;
/// … and the fraction of the cell's photon power (the records' own tolerance: a region whose
/// texels are this much off moves the gathers that see it by at most as much).
const DRIFT_TOLERANCE: f32 = 0.02;

/// Photon changes per cell of a hierarchy of lattices — cells one maximum search radius wide, then
/// twice, four times … as wide, up to the scene — since each cell's texels were last estimated. A
/// cell holds its current photon power and, per photon (by hash) that entered or left it since, how
/// many times more it entered than left: the net change and its noise (the power a reshuffle of those
/// photons would move) are then exact, however often the same paths were deflected and restored. A
/// single texel's photons are too few to tell a dimming from a reshuffle; the coarser cells pool
/// many texels, and a room that loses 5 % of its bounce light shows there.
pub(super) struct Drift {
    levels: Vec<Level>,
}

struct Level {
    cell: f32,
    cells: FastMap<IVec3, Cell>,
}

#[derive(Default)]
struct Cell {
    power: Vec3,
    since: FastMap<u64, (i32, Vec3)>,
}

/// Maps keyed by photon hashes and cell coordinates, hashed by a multiply and a rotation (Fx): the
/// drift's maps take every changed photon at every level each frame, and the keys are hashes or
/// small integers already, for which SipHash's resistance to chosen keys buys nothing.
type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;
type FastSet<K> = HashSet<K, BuildHasherDefault<FxHasher>>;

#[derive(Default)]
struct FxHasher(u64);

impl Hasher for FxHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }

    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_i32(&mut self, x: i32) {
        self.write_u64(x as u32 as u64);
    }
}

impl Drift {
    /// The cells over `scene` for the global map's not-direct `photons` (search radius `radius`).
    pub(super) fn new(scene: &Scene, radius: f32, photons: &PhotonKeys) -> Drift {
        Self::over(
            (scene.bounds.1 - scene.bounds.0).max_element(),
            radius,
            photons,
        )
    }

    /// [`Drift::new`] over a scene whose longest side is `longest`.
    fn over(longest: f32, radius: f32, photons: &PhotonKeys) -> Drift {
        let mut levels = Vec::new();
        let mut cell = radius.max(longest / 256.0).max(1e-6);
        loop {
            let mut cells: FastMap<IVec3, Cell> = FastMap::default();
            for &(_, p, power) in &photons.0 {
                if p.is_finite() {
                    cells.entry(at(p, cell)).or_default().power += power;
                }
            }
            levels.push(Level { cell, cells });
            if cell >= longest || levels.len() >= 12 {
                break;
            }
            cell *= 2.0;
        }
        Drift { levels }
    }

    /// Adds this frame's photon changes; returns, per level, the cells whose net change became
    /// significant (and starts them afresh).
    fn add(&mut self, changed: &[(u64, Vec3, Vec3)]) -> Vec<FastSet<IVec3>> {
        self.levels
            .par_iter_mut()
            .map(|level| {
                let mut touched = FastSet::default();
                for &(hash, p, power) in changed {
                    if !p.is_finite() {
                        continue;
                    }
                    let key = at(p, level.cell);
                    touched.insert(key);
                    let cell = level.cells.entry(key).or_default();
                    cell.power += power;
                    let sign = if power.max_element() >= 0.0 { 1 } else { -1 };
                    let entry = cell.since.entry(hash).or_insert((0, power.abs()));
                    entry.0 += sign;
                    if entry.0 == 0 {
                        cell.since.remove(&hash);
                    }
                }
                let significant: FastSet<IVec3> = touched
                    .into_iter()
                    .filter(|key| level.cells[key].changed())
                    .collect();
                for key in &significant {
                    if let Some(cell) = level.cells.get_mut(key) {
                        cell.since.clear();
                    }
                }
                significant
            })
            .collect()
    }

    /// Whether a changed cell of some level holds `p` (at the finest level, any within `d` of it).
    fn near(&self, changed: &[FastSet<IVec3>], p: Vec3, d: f32) -> bool {
        self.levels
            .iter()
            .zip(changed)
            .enumerate()
            .any(|(l, (level, cells))| {
                if cells.is_empty() {
                    return false;
                }
                if l > 0 {
                    return cells.contains(&at(p, level.cell));
                }
                let (lo, hi) = (
                    at(p - Vec3::splat(d), level.cell),
                    at(p + Vec3::splat(d), level.cell),
                );
                (lo.z..=hi.z).any(|z| {
                    (lo.y..=hi.y)
                        .any(|y| (lo.x..=hi.x).any(|x| cells.contains(&IVec3::new(x, y, z))))
                })
            })
    }
}

impl Cell {
    /// Whether the photons that entered or left the cell since its snapshot moved more power, in
    /// some channel, than both their own noise and the tolerance allow.
    fn changed(&self) -> bool {
        let (mut net, mut var) = (Vec3::ZERO, Vec3::ZERO);
        for &(count, power) in self.since.values() {
            net += count as f32 * power;
            var += count.unsigned_abs() as f32 * power * power;
        }
        (0..3).any(|c| {
            net[c].abs() > SIGNIFICANT * var[c].sqrt()
                && net[c].abs() > DRIFT_TOLERANCE * (self.power[c] - net[c]).abs()
        })
    }
}

/// The cell of side `cell` holding `p`.
fn at(p: Vec3, cell: f32) -> IVec3 {
    (p / cell).floor().as_ivec3()
}

/// Gives `photons` (this frame's maps, over the same paths as the frame before's) the texels of
/// `before` that nothing in `change` touched; returns what the next frame needs.
pub(super) fn carry_atlas(
    scene: &Scene,
    photons: &mut PhotonData,
    before: AtlasBefore,
    change: &SceneChange,
) -> Option<(PhotonKeys, Drift)> {
    let keys = PhotonKeys::of(photons.maps().global.as_ref()?.photons());
    let radius = photons.settings().max_radius_global;
    if change.lights {
        let drift = Drift::new(scene, radius, &keys);
        return Some((keys, drift));
    }
    let mut drift = before.drift;
    let changed = drift.add(&keys.changed(&before.keys));
    let movers: Vec<(Vec3, f32)> = change.moved.iter().flat_map(|m| m.spheres).collect();
    let ends = shadow_ends(scene);
    photons.carry_atlas(before.atlas, |middle, reach| {
        let probed = PROBE_REACH * radius + reach;
        !drift.near(&changed, middle, radius)
            && !movers.iter().any(|&(c, r)| {
                middle.distance(c) < r + probed
                    || ends.iter().any(|end| {
                        let (c_l, r_l) = end.seen_from(middle);
                        sphere_meets_cone(c, r + reach, middle, c_l, r_l)
                    })
            })
    });
    Some((keys, drift))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photon(x: f32, power: f32) -> Photon {
        photon_at(Vec3::new(x, 0.5, 0.5), power)
    }

    fn photon_at(pos: Vec3, power: f32) -> Photon {
        Photon {
            pos,
            wi: Vec3::Y,
            power: Vec3::splat(power),
            normal: Vec3::Y,
            indirect: true,
            direct: false,
        }
    }

    #[test]
    fn the_photons_of_one_map_only_are_the_change_signed_by_map() {
        let before = PhotonKeys::of(&[photon(0.1, 1.0), photon(0.2, 1.0), photon(0.3, 1.0)]);
        let now = PhotonKeys::of(&[photon(0.3, 1.0), photon(0.1, 1.0), photon(0.4, 2.0)]);
        let mut changed: Vec<(Vec3, Vec3)> = now
            .changed(&before)
            .into_iter()
            .map(|c| (c.1, c.2))
            .collect();
        changed.sort_by(|a, b| a.0.x.total_cmp(&b.0.x));
        assert_eq!(
            changed,
            vec![
                (Vec3::new(0.2, 0.5, 0.5), Vec3::splat(-1.0)),
                (Vec3::new(0.4, 0.5, 0.5), Vec3::splat(2.0))
            ]
        );
        // Direct photons are not what the atlas estimates sum: they are not compared.
        let direct = Photon {
            direct: true,
            indirect: false,
            ..photon(0.5, 1.0)
        };
        assert!(PhotonKeys::of(&[direct])
            .changed(&PhotonKeys(Vec::new()))
            .is_empty());
    }

    #[test]
    fn a_cell_counts_as_changed_for_a_loss_not_for_a_reshuffle_and_a_room_for_its_sum() {
        // 100 photons of power 1 in each of the 8 cells of side 1 of a 2 × 2 × 2 room.
        let cube: Vec<IVec3> = (0..8)
            .map(|i| IVec3::new(i & 1, (i >> 1) & 1, i >> 2))
            .collect();
        let at_cell = |c: IVec3, i: i32| c.as_vec3() + Vec3::splat(0.05 + 0.009 * i as f32);
        let photons: Vec<Photon> = cube
            .iter()
            .flat_map(|&c| (0..100).map(move |i| photon_at(at_cell(c, i), 1.0)))
            .collect();
        let keys = PhotonKeys::of(&photons);
        let mut drift = Drift::over(2.0, 1.0, &keys);
        assert_eq!(drift.levels.len(), 2);
        let change = |ph: &Photon, sign: f32| {
            let k = PhotonKeys::of(std::slice::from_ref(ph)).0[0];
            (k.0, k.1, k.2 * sign)
        };
        // Ten photons leave cell 0 and ten others arrive there, as the paths a mover deflects do.
        let reshuffle: Vec<_> = (0..10)
            .map(|i| change(&photons[i], -1.0))
            .chain((0..10).map(|i| {
                change(
                    &photon_at(at_cell(IVec3::ZERO, 50) + 0.001 * i as f32, 1.0),
                    1.0,
                )
            }))
            .collect();
        assert!(drift.add(&reshuffle).iter().all(|c| c.is_empty()));
        // Sixteen leave cell 1: a shadow, seen by the fine cell (16 > 3 √16), not by the room
        // (the reshuffle's 20 exchanges add to its noise: 16 < 3 √36).
        let loss: Vec<_> = (100..116).map(|i| change(&photons[i], -1.0)).collect();
        let changed = drift.add(&loss);
        assert_eq!(changed[0], FastSet::from_iter([IVec3::new(1, 0, 0)]));
        assert!(changed[1].is_empty());
        assert!(drift.near(&changed, Vec3::new(0.9, 0.5, 0.5), 0.2));
        assert!(!drift.near(&changed, Vec3::new(0.5, 0.5, 0.5), 0.2));
        // The changed cell starts afresh; the others keep their accounts.
        assert!(drift.levels[0].cells[&IVec3::new(1, 0, 0)].since.is_empty());
        assert!(!drift.levels[0].cells[&IVec3::ZERO].since.is_empty());
        // Four photons leave each of the other six cells: no cell can tell (4 < 3 √4), the room
        // can (40 photons of 800 after the shadow's 16 and these 24, against 3 √60).
        let dimming: Vec<_> = cube[2..]
            .iter()
            .enumerate()
            .flat_map(|(k, _)| (0..4).map(move |i| 200 + 100 * k + i))
            .map(|i| change(&photons[i], -1.0))
            .collect();
        let changed = drift.add(&dimming);
        assert!(changed[0].is_empty());
        assert_eq!(changed[1], FastSet::from_iter([IVec3::ZERO]));
        assert!(drift.near(&changed, Vec3::new(1.5, 1.5, 1.5), 0.2));
    }
}
