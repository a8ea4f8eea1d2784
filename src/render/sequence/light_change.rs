//! Where the light of a sequence's scene changed between two frames, from its photon maps: both are
//! traced with the same photon sequence, so the power deposited per cell of a lattice differs only
//! where what moved blocked, turned or sent light ([`super::temporal`] makes the records that see
//! those cells due).

use glam::Vec3;
use icache::Record;

use pmbase::luminance;

/// Photon power the global map deposited on surfaces, summed over the cells of a lattice fixed for
/// the sequence (photons outside it count in its border cells). Where it changed between two frames
/// the light changed there — a mover blocked a light or turned a mirror — and with it the indirect
/// light of every record that sees the place, however far from the mover ([`super::temporal::Lifespans::update`]).
pub(super) struct Deposits {
    lo: Vec3,
    pub(super) cell: f32,
    dims: [usize; 3],
    power: Vec<Vec3>,
    /// The mean photon's power: a cell whose power changed by less than [`NOISE_PHOTONS`] of it
    /// changed by the few paths a mover deflected there.
    photon: Vec3,
}

/// Cells along the deposit lattice's longest side.
const DEPOSIT_CELLS: f32 = 32.0;
/// Photons' worth of power a cell's change must exceed to count (see [`Deposits::photon`]).
const NOISE_PHOTONS: f32 = 4.0;

impl Deposits {
    /// The deposits of `photons` on the lattice of `like` (or a new one over `bounds`).
    pub(super) fn of(
        photons: &[photon::map::Photon],
        bounds: (Vec3, Vec3),
        like: Option<&Deposits>,
    ) -> Deposits {
        let (lo, cell, dims) = match like {
            Some(d) => (d.lo, d.cell, d.dims),
            None => {
                let size = (bounds.1 - bounds.0).max(Vec3::splat(1e-6));
                let cell = size.max_element() / DEPOSIT_CELLS;
                let dims = (size / cell).ceil().as_uvec3().max(glam::UVec3::ONE);
                (
                    bounds.0,
                    cell,
                    [dims.x as usize, dims.y as usize, dims.z as usize],
                )
            }
        };
        let mut power = vec![Vec3::ZERO; dims[0] * dims[1] * dims[2]];
        let mut total = Vec3::ZERO;
        for ph in photons {
            let c = ((ph.pos - lo) / cell).floor();
            if !c.is_finite() {
                continue;
            }
            let at = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
            let (x, y, z) = (at(c.x, dims[0]), at(c.y, dims[1]), at(c.z, dims[2]));
            power[(z * dims[1] + y) * dims[0] + x] += ph.power;
            total += ph.power;
        }
        Deposits {
            lo,
            cell,
            dims,
            power,
            photon: total / photons.len().max(1) as f32,
        }
    }

    /// The cells whose deposited power changed since `before` by more than [`NOISE_PHOTONS`]
    /// photons' worth: (centre, change).
    pub(super) fn changes(&self, before: &Deposits) -> Vec<(Vec3, Vec3)> {
        let floor = NOISE_PHOTONS * self.photon.max(before.photon).max_element();
        let [nx, ny, _] = self.dims;
        self.power
            .iter()
            .zip(&before.power)
            .enumerate()
            .filter_map(|(i, (now, was))| {
                let change = *now - *was;
                (change.abs().max_element() > floor).then(|| {
                    let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
                    let centre =
                        self.lo + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * self.cell;
                    (centre, change)
                })
            })
            .collect()
    }
}

/// Whether the deposits that changed (cells of size `cell`: centre, power change) change the
/// irradiance of record `r` by more than `tolerance` of its own: each cell as a Lambertian patch
/// reflecting all it received (an upper bound), seen at its distance (at least a cell's) and at the
/// record's cosine. The changes are summed with their signs: a mover's own deposits, leaving one
/// cell for the next, cancel at a distance.
pub(super) fn sees_changed_light(
    r: &Record,
    changes: &[(Vec3, Vec3)],
    cell: f32,
    tolerance: f32,
) -> bool {
    if changes.is_empty() {
        return false;
    }
    let mut de = Vec3::ZERO;
    for &(q, dp) in changes {
        let to = q - r.pos;
        let d2 = to.length_squared().max(cell * cell);
        let cos = to.dot(r.normal).max(0.0) / d2.sqrt();
        de += dp * (cos / (std::f32::consts::PI * d2));
    }
    de.abs().max_element() > tolerance * luminance(r.e).max(1e-12)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sequence::record_life::TOLERANCE;
    use crate::render::sequence::temporal::tests::record;

    #[test]
    fn records_see_deposits_that_changed_in_their_sky_and_not_a_mover_passing_by() {
        let photon = |pos: Vec3, power: f32| photon::map::Photon {
            pos,
            wi: Vec3::Y,
            power: Vec3::splat(power),
            normal: Vec3::Y,
            indirect: false,
            direct: true,
        };
        let bounds = (Vec3::ZERO, Vec3::splat(4.0));
        // A floor of photons, and a bright patch at (3, 0, 2) that a blocker takes away.
        let floor: Vec<_> = (0..400)
            .map(|i| {
                photon(
                    Vec3::new(
                        0.1 + 0.2 * (i % 20) as f32,
                        0.0,
                        0.1 + 0.2 * (i / 20) as f32,
                    ),
                    0.01,
                )
            })
            .collect();
        let lit: Vec<_> = floor
            .iter()
            .copied()
            .chain((0..50).map(|_| photon(Vec3::new(3.0, 0.0, 2.0), 0.02)))
            .collect();
        let before = Deposits::of(&lit, bounds, None);
        let after = Deposits::of(&floor, bounds, Some(&before));
        let changes = after.changes(&before);
        assert_eq!(changes.len(), 1, "{changes:?}");
        // A record on the ceiling above: its indirect 1.0 would change by about 1 / (π 16) ≈ 2 %…
        let rec = |pos: Vec3, normal: Vec3, e: f32| record(pos, normal, e, 1.0, 0.01);
        let ceiling = rec(Vec3::new(2.0, 4.0, 2.0), -Vec3::Y, 0.2);
        assert!(sees_changed_light(
            &ceiling, &changes, after.cell, TOLERANCE
        ));
        // …but not one facing away, nor a brighter one.
        assert!(!sees_changed_light(
            &rec(Vec3::new(2.0, 4.0, 2.0), Vec3::Y, 0.2),
            &changes,
            after.cell,
            TOLERANCE
        ));
        assert!(!sees_changed_light(
            &rec(Vec3::new(2.0, 4.0, 2.0), -Vec3::Y, 5.0),
            &changes,
            after.cell,
            TOLERANCE
        ));
        // A patch that moves one cell over: the changes cancel at a distance.
        let moved: Vec<_> = floor
            .iter()
            .copied()
            .chain((0..50).map(|_| photon(Vec3::new(3.15, 0.0, 2.0), 0.02)))
            .collect();
        let shifted = Deposits::of(&moved, bounds, Some(&before)).changes(&before);
        assert!(!sees_changed_light(
            &ceiling, &shifted, after.cell, TOLERANCE
        ));
    }
}
