//! Where each sample falls: its offset in the pixel, its first glossy lobe's point and its first
//! hit's area-light points, from scrambled Sobol' sequences per quarter and group parity.

use super::*;

/// Where a sample falls: its offset in the pixel, and a second point of the unit square for the
/// first glossy lobe it samples ([`lobe_point`]).
#[derive(Clone, Copy, Debug)]
pub struct SamplePoint {
    pub offset: [f32; 2],
    /// Its first glossy lobe's point and its first hit's area-light points ([`light_points`]).
    pub points: Stratified,
}

/// Keys the stream of the lobe points apart from the samples' own.
pub(super) const LOBE_KEY: u64 = 0x10be;

/// Sample `s`'s point for the first glossy lobe it samples (of at most `spp` in pixel `pixel`). In a
/// whole group of four it lies in quarter π(s mod 4) of the unit square, as the sample's offset lies in
/// quarter s mod 4 of the pixel: each group then samples every quarter of the lobe once, which lowers
/// the noise of a lobe whose light varies smoothly across it. π is a random permutation shared by the two groups of a pair, so that
/// the variance estimate's differences compare samples of the same quarter in both, and drawn afresh
/// for each pair, so that over the pairs where a sample falls in the pixel and where in the lobe are
/// independent (a fixed pairing would weight the pixel's quarters by the lobe's). Anywhere otherwise.
/// Its own stream: the rest of the sample's random numbers stay as they are without glossy lobes.
pub(super) fn lobe_point(seed: u64, pixel: u64, s: u32, spp: u32) -> [f32; 2] {
    let mut rng = Rng::new(hash_keys(&[seed, pixel, s as u64, LOBE_KEY]));
    let (u, v) = (rng.uniform(), rng.uniform());
    if !in_whole_group(s, spp) {
        return [u, v];
    }
    let pair = (s / (2 * GROUP)) as u64;
    let mut perm = [0u32, 1, 2, 3];
    let mut shuffle = Rng::new(hash_keys(&[seed, pixel, pair, LOBE_KEY, 1]));
    for i in (1..perm.len()).rev() {
        let j = ((shuffle.uniform() * (i + 1) as f32) as usize).min(i);
        perm.swap(i, j);
    }
    let cell = perm[(s % GROUP) as usize];
    [((cell % 2) as f32 + u) * 0.5, ((cell / 2) as f32 + v) * 0.5]
}

/// Keys the scrambles of the offsets' Sobol' points.
pub(super) const OFFSET_KEY: u64 = 0x0ff5;

/// Sub-pixel offset of sample `s` (of at most `spp` in pixel `pixel`): in a whole group of four, a point
/// of quarter `s % 4`; anywhere otherwise, at (u, v). A quarter's points come from two Sobol' sequences
/// of their own, one for the even groups and one for the odd: each sequence's points stratify the
/// quarter ever more finely as the pixel takes samples (an edge's coverage converges faster than with
/// independent points), and the two samples of a pair of groups that the variance estimate compares
/// stay independent of each other, so that the estimate is what it was with independent points.
pub(super) fn offset(seed: u64, pixel: u64, s: u32, spp: u32, u: f32, v: f32) -> [f32; 2] {
    if !in_whole_group(s, spp) {
        return [u, v];
    }
    let (cell, stream, index) = quarter_sequence(seed, pixel, s, OFFSET_KEY);
    let [u, v] = sobol_2d(index, stream);
    [((cell % 2) as f32 + u) * 0.5, ((cell / 2) as f32 + v) * 0.5]
}

/// Sample `s`'s quarter of its pixel (in a whole group of four), the scramble of the Sobol' sequence
/// that `key` names for that quarter and the parity of the sample's group, and the sample's index in
/// that sequence (its group's among the groups of that parity).
pub(super) fn quarter_sequence(seed: u64, pixel: u64, s: u32, key: u64) -> (u32, u64, u32) {
    let (cell, group) = (s % GROUP, s / GROUP);
    let stream = hash_keys(&[seed, pixel, cell as u64, (group % 2) as u64, key]);
    (cell, stream, group / 2)
}

/// Keys the scrambles of the area-light points' Sobol' sequences.
pub(super) const LIGHT_KEY: u64 = 0x119b;

/// Sample `s`'s area-light points (of at most `spp` in pixel `pixel`): in a whole group of four, the
/// next [`AREA_LIGHT_SAMPLES`] points of a Sobol' sequence of the sample's quarter and group parity, as
/// its offset's (so that the variance estimate's pairs stay independent); `None` otherwise (the
/// sample's own random numbers).
pub(super) fn light_points(seed: u64, pixel: u64, s: u32, spp: u32) -> Option<LightPoints> {
    if !in_whole_group(s, spp) {
        return None;
    }
    let (_, stream, index) = quarter_sequence(seed, pixel, s, LIGHT_KEY);
    Some(LightPoints {
        stream,
        first: index * AREA_LIGHT_SAMPLES,
    })
}

/// True when sample `s` of at most `spp` belongs to a whole group of four (then it sits in quarter
/// `s % 4`).
pub(super) fn in_whole_group(s: u32, spp: u32) -> bool {
    (s / GROUP + 1) * GROUP <= spp
}
