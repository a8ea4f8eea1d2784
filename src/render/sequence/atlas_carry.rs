//! Which texels of the irradiance atlas a sequence's frame takes from the frame before when meshes
//! moved, and how they follow the photons that changed, instead of being estimated again: most of a
//! re-gather's time goes into estimating the texels its rays reach.
//!
//! Both frames trace the same photon paths, as many per map ([`photon::retrace_photons`]), so a path
//! that met nothing that moved leaves the same photons bit for bit. A texel's value is a function of
//! the photons in its estimate's disc, of the geometry that disc probes and of its lights' shadow
//! rays. The last two are tested against the moved meshes' bounding spheres, before and after their
//! step: a texel near a mover or in its shadow's reach is estimated again. Every other texel keeps its
//! disc and adds the photons that entered it less those that left (see
//! [`crate::photons::texel_track`]): the paths a mover deflects scatter their photons over the whole
//! scene, a few per texel, and a room that loses some of its bounce light to a mover's shadow loses
//! it in every texel's disc, which a texel kept until its own few photons could tell would miss.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::{IVec3, Vec3};
use photon::map::{counts_at, dist2, Photon};
use photon::sampling::hash_keys;
use rayon::prelude::*;

use super::kept_pixels::{shadow_ends, sphere_meets_cone};
use super::temporal::SceneChange;
use crate::photons::atlas::IrradianceAtlas;
use crate::photons::texel_track::DiscChange;
use crate::photons::PhotonData;
use crate::scene::Scene;

/// The global map's photons that the atlas's estimates sum (those not direct), each with the hash of
/// every field's bits, sorted by hash.
pub(super) struct PhotonKeys(Vec<(u64, Photon)>);

impl PhotonKeys {
    pub(super) fn of(photons: &[Photon]) -> PhotonKeys {
        let mut keys: Vec<(u64, Photon)> = photons
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
                (hash_keys(&bits), *ph)
            })
            .collect();
        keys.par_sort_unstable_by_key(|k| k.0);
        PhotonKeys(keys)
    }

    /// The photons of one map and not of the other (the symmetric difference), in the order of their
    /// hashes: this map's signed 1, `before`'s −1.
    fn changed(&self, before: &PhotonKeys) -> Vec<(Photon, i32)> {
        let (a, b) = (&self.0, &before.0);
        let gone = |ph: &Photon| (*ph, -1);
        let (mut i, mut j, mut out) = (0, 0, Vec::new());
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => {
                    out.push((a[i].1, 1));
                    i += 1;
                }
                std::cmp::Ordering::Greater => {
                    out.push(gone(&b[j].1));
                    j += 1;
                }
                std::cmp::Ordering::Equal => {
                    i += 1;
                    j += 1;
                }
            }
        }
        out.extend(a[i..].iter().map(|k| (k.1, 1)));
        out.extend(b[j..].iter().map(|k| gone(&k.1)));
        out
    }
}

/// What the frames before leave for this frame's atlas: the last one's atlas and photons.
pub(super) struct AtlasBefore {
    pub(super) atlas: IrradianceAtlas,
    pub(super) keys: PhotonKeys,
}

/// How far about a texel's middle its photon estimate's disc probes the geometry, in maximum search
/// radii: the disc's radius, and the gap probes up to twice the radius along the normal.
const PROBE_REACH: f32 = 2.5;

/// The changed photons in cells one maximum search radius wide: a disc's photons lie in the
/// (at most 8) cells its bounding box meets.
struct ChangedPhotons {
    cell: f32,
    photons: Vec<(Photon, i32)>,
    cells: FastMap<IVec3, Vec<u32>>,
}

impl ChangedPhotons {
    fn new(photons: Vec<(Photon, i32)>, radius: f32) -> ChangedPhotons {
        let cell = radius.max(1e-6);
        let mut cells: FastMap<IVec3, Vec<u32>> = FastMap::default();
        for (i, (ph, _)) in photons.iter().enumerate() {
            if ph.pos.is_finite() {
                cells.entry(at(ph.pos, cell)).or_default().push(i as u32);
            }
        }
        ChangedPhotons {
            cell,
            photons,
            cells,
        }
    }

    /// The change of the disc about `p` whose photons lie below squared distance `within2`, facing
    /// `n`, within `half_thickness` of its plane: the photons an estimate there counts, as the photon
    /// map's.
    fn in_disc(&self, p: Vec3, n: Vec3, within2: f32, half_thickness: f32) -> DiscChange {
        let mut change = DiscChange::default();
        if self.cells.is_empty() {
            return change;
        }
        let r = within2.sqrt();
        let (lo, hi) = (
            at(p - Vec3::splat(r), self.cell),
            at(p + Vec3::splat(r), self.cell),
        );
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let Some(list) = self.cells.get(&IVec3::new(x, y, z)) else {
                        continue;
                    };
                    for &i in list {
                        let (ph, sign) = &self.photons[i as usize];
                        if dist2(p, ph.pos) < within2 && counts_at(ph, p, n, half_thickness) {
                            let power = *sign as f32 * ph.power;
                            change.not_direct += power;
                            if ph.indirect {
                                change.indirect += power;
                            }
                            change.n += sign;
                        }
                    }
                }
            }
        }
        change
    }
}

/// Maps keyed by cell coordinates, hashed by a multiply and a rotation (Fx): the keys are small
/// integers, for which SipHash's resistance to chosen keys buys nothing.
type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

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

/// The cell of side `cell` holding `p`.
fn at(p: Vec3, cell: f32) -> IVec3 {
    (p / cell).floor().as_ivec3()
}

/// Gives `photons` (this frame's maps, over the same paths as the frame before's) the texels of
/// `before` that nothing in `change` touched, moved by their photons' change; returns what the next
/// frame needs.
pub(super) fn carry_atlas(
    scene: &Scene,
    photons: &mut PhotonData,
    before: AtlasBefore,
    change: &SceneChange,
) -> Option<PhotonKeys> {
    let keys = PhotonKeys::of(photons.maps().global.as_ref()?.photons());
    if change.lights {
        return Some(keys);
    }
    let radius = photons.settings().max_radius_global;
    let changed = ChangedPhotons::new(keys.changed(&before.keys), radius);
    let movers: Vec<(Vec3, f32)> = change.moved.iter().flat_map(|m| m.spheres).collect();
    let ends = shadow_ends(scene);
    photons.carry_atlas(
        before.atlas,
        |middle, reach| {
            let probed = PROBE_REACH * radius + reach;
            !movers.iter().any(|&(c, r)| {
                middle.distance(c) < r + probed
                    || ends.iter().any(|end| {
                        let (c_l, r_l) = end.seen_from(middle);
                        sphere_meets_cone(c, r + reach, middle, c_l, r_l)
                    })
            })
        },
        |middle, n, r, half_thickness| changed.in_disc(middle, n, r, half_thickness),
    );
    Some(keys)
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
            .map(|(c, sign)| (c.pos, sign as f32 * c.power))
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
    fn a_disc_changes_by_the_photons_an_estimate_there_counts() {
        // A floor disc of radius 0.1 facing up at the origin, its slab 0.02 thick each way.
        let on_floor = |x: f32, z: f32, power: f32| Photon {
            pos: Vec3::new(x, 0.0, z),
            ..photon(0.0, power)
        };
        let changed = ChangedPhotons::new(
            vec![
                // Counted: one entered (power 2, indirect), one left (power 1, not indirect).
                (on_floor(0.05, 0.0, 2.0), 1),
                (
                    Photon {
                        indirect: false,
                        ..on_floor(0.0, -0.08, 1.0)
                    },
                    -1,
                ),
                // Not counted: past the radius, above the slab, arriving from below, on a wall.
                (on_floor(0.0, 0.11, 4.0), 1),
                (
                    Photon {
                        pos: Vec3::new(0.0, 0.05, 0.0),
                        ..on_floor(0.0, 0.0, 4.0)
                    },
                    1,
                ),
                (
                    Photon {
                        wi: Vec3::NEG_Y,
                        ..on_floor(0.01, 0.0, 4.0)
                    },
                    1,
                ),
                (
                    Photon {
                        normal: Vec3::X,
                        ..on_floor(0.02, 0.0, 4.0)
                    },
                    1,
                ),
            ],
            0.15,
        );
        let d = changed.in_disc(Vec3::ZERO, Vec3::Y, 0.01, 0.02);
        assert_eq!(d.not_direct, Vec3::splat(1.0));
        assert_eq!(d.indirect, Vec3::splat(2.0));
        assert_eq!(d.n, 0);
        // A disc elsewhere sees nothing.
        assert_eq!(
            changed.in_disc(Vec3::new(1.0, 0.0, 0.0), Vec3::Y, 0.01, 0.02),
            DiscChange::default()
        );
    }

    /// anim-ball's frames 10 and 11 (the ball moved a step), over the same photon paths: every texel
    /// frame 11 carries from frame 10 holds what a disc of its radius sums over frame 11's photons
    /// (within rounding), most of them moved by the photons that changed; none lies near the ball.
    #[test]
    fn a_carried_texel_sums_the_new_frames_photons_in_its_disc() {
        use std::sync::atomic::AtomicBool;

        use crate::photons::coverage::SceneCoverage;
        use crate::photons::PhotonSettings;

        let (anim, before, after) = crate::render::photons::anim_ball_frames(10, 11);
        let settings = PhotonSettings::resolve(&before);
        let cancel = AtomicBool::new(false);
        let (maps, s0, _) = PhotonData::trace(
            &before,
            &settings,
            photon::Over::default(),
            0,
            &|_, _| {},
            &cancel,
        )
        .unwrap();
        let paths = photon::Over {
            paths: Some(photon::MapPaths::of(&s0)),
            ..Default::default()
        };
        let (maps_after, _, _) =
            PhotonData::trace(&after, &settings, paths, 0, &|_, _| {}, &cancel).unwrap();
        let keys = PhotonKeys::of(maps.global.as_ref().unwrap().photons());
        let mut data = PhotonData::new(maps, settings.clone(), &before);
        data.track_atlas();
        // The box's texels at a lattice of 36 points of each triangle, on both sides, estimated in
        // frame 10.
        let ball = before.mesh_ranges[1].clone();
        let texels: Vec<(u32, bool, Vec3)> = (0..before.geometry.triangles.len() as u32)
            .filter(|t| !ball.contains(&(*t as usize)))
            .flat_map(|t| {
                let tri = &before.geometry.triangles[t as usize];
                let c = tri.v.map(|i| before.geometry.positions[i as usize]);
                (0..8u32).flat_map(move |i| {
                    (0..8 - i).flat_map(move |j| {
                        let (u, v) = ((i as f32 + 0.3) / 8.0, (j as f32 + 0.3) / 8.0);
                        let p = c[0] + u * (c[1] - c[0]) + v * (c[2] - c[0]);
                        [(t, true, p), (t, false, p)]
                    })
                })
            })
            .collect();
        {
            let atlas = data.atlas().unwrap();
            let global = data.maps().global.as_ref().unwrap();
            for &(t, front, p) in &texels {
                atlas.lookup(&SceneCoverage(&before), global, t, front, p);
            }
        }
        let (_, atlas) = data.into_maps_and_atlas();
        let m = anim.moved_meshes(10, 11)[0];
        let moved = super::super::temporal::Moved::new(
            before.mesh_sphere(m).unwrap(),
            after.mesh_sphere(m).unwrap(),
            None,
        );
        let change = SceneChange {
            moved: vec![moved],
            rigid: Vec::new(),
            lights: false,
        };
        let mut next = PhotonData::new(maps_after, settings, &after);
        let before_atlas = AtlasBefore {
            atlas: atlas.unwrap(),
            keys,
        };
        carry_atlas(&after, &mut next, before_atlas, &change).unwrap();
        let atlas = next.atlas().unwrap();
        let photons = next.maps().global.as_ref().unwrap().photons();
        let stats = atlas.stats();
        assert!(
            stats.carried > texels.len() as u64 / 2 && stats.updated > stats.carried / 4,
            "{} of {} texels carried, {} updated",
            stats.carried,
            texels.len(),
            stats.updated
        );
        let ball_at = after.mesh_sphere(m).unwrap();
        let (mut checked, mut changed) = (0, 0);
        for &(t, front, p) in &texels {
            let texel = atlas.texel(t, front, p);
            let Some(track) = atlas.track(&texel) else {
                continue;
            };
            let middle = atlas.middle(&texel);
            assert!(middle.distance(ball_at.0) > ball_at.1 + track.within2.sqrt());
            let ng = after.geometry.triangles[t as usize].ng;
            let n = if front { ng } else { -ng };
            let sum: Vec3 = photons
                .iter()
                .filter(|ph| {
                    !ph.direct
                        && dist2(middle, ph.pos) < track.within2
                        && counts_at(ph, middle, n, track.half_thickness)
                })
                .map(|ph| ph.power)
                .sum();
            if track.area == 0.0 {
                // No photon in its disc when estimated: carried only while none arrives.
                assert_eq!((sum, track.e_not_direct), (Vec3::ZERO, Vec3::ZERO));
                continue;
            }
            let fresh = sum / track.area;
            let off = (track.e_not_direct - fresh).abs().max_element();
            assert!(
                off <= 1e-3 * fresh.max_element().max(1e-3),
                "texel {t}/{front}: carried {} against {fresh}",
                track.e_not_direct
            );
            checked += 1;
            changed += (track.n != track.n0) as u32;
        }
        assert!(
            checked > 500 && changed > 50,
            "{checked} checked, {changed} changed in count"
        );
    }
}
