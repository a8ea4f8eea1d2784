//! Deterministic random and low-discrepancy numbers, addressed by an index rather than by a thread.
//!
//! Every sample stream in the renderer is derived from `(seed, index, dimension)` so that results do not
//! depend on how work is split between threads.
#![forbid(unsafe_code)]

/// A 64-bit mix (SplitMix64 finaliser): decorrelates structured keys such as `(seed, pixel, sample)`.
#[inline]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of several keys into one stream seed.
#[inline]
pub fn hash_keys(keys: &[u64]) -> u64 {
    keys.iter().fold(0x5151_5151_u64, |h, &k| mix64(h ^ k))
}

/// A small, fast PCG32 generator. Seed it from [`hash_keys`] of the work item's identity.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut rng = Rng {
            state: 0,
            inc: (mix64(seed ^ 0xDA3E_39CB_94B9_5BDB) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(mix64(seed));
        rng.next_u32();
        rng
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), never 1.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    #[inline]
    pub fn uniform2(&mut self) -> [f32; 2] {
        [self.uniform(), self.uniform()]
    }
}

const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];

/// Radical inverse of `index` in the `dim`-th prime base, with a per-dimension random digit
/// permutation offset (Cranley–Patterson rotation) derived from `seed`. Dimensions beyond the table
/// fall back to hashed uniform numbers of `(seed, index, dim)`.
pub fn halton(index: u64, dim: usize, seed: u64) -> f32 {
    let shift = (mix64(seed ^ (dim as u64).wrapping_mul(0x2545_F491_4F6C_DD1D)) >> 40) as f32
        / 16_777_216.0;
    let v = if dim < PRIMES.len() {
        radical_inverse_in(dim, index) as f32
    } else {
        (mix64(hash_keys(&[seed, index, dim as u64])) >> 40) as f32 / 16_777_216.0
    };
    let x = v + shift;
    let x = if x >= 1.0 { x - 1.0 } else { x };
    x.min(1.0 - f32::EPSILON)
}

/// The radical inverse of `index` in the base of dimension `dim` (< 16): one instance per base, so that
/// division by the base is a multiply (a photon path draws five of these at emission; division by a
/// variable base was a third of a caustic-only path's cost).
fn radical_inverse_in(dim: usize, index: u64) -> f64 {
    match dim {
        0 => radical_inverse::<2>(index),
        1 => radical_inverse::<3>(index),
        2 => radical_inverse::<5>(index),
        3 => radical_inverse::<7>(index),
        4 => radical_inverse::<11>(index),
        5 => radical_inverse::<13>(index),
        6 => radical_inverse::<17>(index),
        7 => radical_inverse::<19>(index),
        8 => radical_inverse::<23>(index),
        9 => radical_inverse::<29>(index),
        10 => radical_inverse::<31>(index),
        11 => radical_inverse::<37>(index),
        12 => radical_inverse::<41>(index),
        13 => radical_inverse::<43>(index),
        14 => radical_inverse::<47>(index),
        _ => radical_inverse::<53>(index),
    }
}

/// The radical inverse of `index` in base `B`, summed in f64 from the least significant digit.
#[inline]
fn radical_inverse<const B: u64>(index: u64) -> f64 {
    let inv_base = 1.0 / B as f64;
    let (mut i, mut f, mut r) = (index, inv_base, 0.0f64);
    while i > 0 {
        r += (i % B) as f64 * f;
        i /= B;
        f *= inv_base;
    }
    r
}

/// Point `index` of a two-dimensional Sobol' sequence (a (0,2)-sequence in base 2), Owen-scrambled by
/// `seed`: every aligned run of 2^k points puts one point in each of the 2^k cells of every
/// subdivision of the unit square into 2^a × 2^b cells (a + b = k), so any prefix is stratified about
/// as well as a jittered grid of its size, and points of different seeds are independent. The
/// scramble is Burley's hash-based nested uniform scramble ("Practical hash-based Owen scrambling",
/// JCGT 2020).
pub fn sobol_2d(index: u32, seed: u64) -> [f32; 2] {
    // Second dimension: the generator matrix of the polynomial x + 1, v_j = v_{j-1} ^ (v_{j-1} >> 1).
    let (mut y, mut v, mut i) = (0u32, 1u32 << 31, index);
    while i != 0 {
        if i & 1 == 1 {
            y ^= v;
        }
        v ^= v >> 1;
        i >>= 1;
    }
    let x = index.reverse_bits();
    let seed = mix64(seed);
    let to_unit = |b: u32| (b >> 8) as f32 / 16_777_216.0;
    [
        to_unit(owen_scramble(x, seed as u32)),
        to_unit(owen_scramble(y, (seed >> 32) as u32)),
    ]
}

/// A nested uniform scramble of the bits of `x` (most significant first): each bit is flipped by a hash
/// of `seed` and the bits above it.
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut x = x.reverse_bits();
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x.reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_points_of_an_aligned_run_fill_every_elementary_cell_once() {
        for seed in [0u64, 1, 99] {
            for start in [0u32, 64, 128] {
                // 64 points: one in each cell of 64×1, 32×2, …, 1×64.
                for a in 0..=6u32 {
                    let (nx, ny) = (1u32 << a, 1u32 << (6 - a));
                    let mut seen = [false; 64];
                    for i in start..start + 64 {
                        let [x, y] = sobol_2d(i, seed);
                        assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                        let cell = (x * nx as f32) as u32 + nx * (y * ny as f32) as u32;
                        assert!(
                            !seen[cell as usize],
                            "seed {seed} start {start} cells {nx}×{ny}"
                        );
                        seen[cell as usize] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn sobol_points_of_different_seeds_differ_and_average_to_the_middle() {
        let (mut sum, n) = ([0.0f64; 2], 4096u64);
        for seed in 0..n {
            let p = sobol_2d(0, seed);
            assert_ne!(p, sobol_2d(0, seed + 1));
            sum[0] += p[0] as f64;
            sum[1] += p[1] as f64;
        }
        for s in sum {
            assert!((s / n as f64 - 0.5).abs() < 0.02, "{}", s / n as f64);
        }
    }

    #[test]
    fn uniform_is_in_unit_interval_and_unbiased() {
        let mut rng = Rng::new(7);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.01);
    }

    #[test]
    fn radical_inverse_per_base_matches_the_loop_over_a_variable_base() {
        let by_variable = |mut i: u64, base: u64| {
            let inv_base = 1.0 / base as f64;
            let (mut f, mut r) = (inv_base, 0.0f64);
            while i > 0 {
                r += (i % base) as f64 * f;
                i /= base;
                f *= inv_base;
            }
            r
        };
        let mut rng = Rng::new(3);
        for (dim, &base) in PRIMES.iter().enumerate() {
            for k in 0..2000u64 {
                let index = if k < 1000 {
                    k
                } else {
                    (rng.uniform() as f64 * 1e15) as u64
                };
                let (fast, slow) = (
                    radical_inverse_in(dim, index),
                    by_variable(index, base as u64),
                );
                assert_eq!(fast.to_bits(), slow.to_bits(), "dim {dim} index {index}");
            }
        }
    }

    #[test]
    fn halton_first_dimension_is_stratified() {
        let n = 1024u64;
        let mut bins = [0u32; 16];
        for i in 0..n {
            let u = halton(i, 0, 3);
            assert!((0.0..1.0).contains(&u));
            bins[(u * 16.0) as usize] += 1;
        }
        assert!(bins.iter().all(|&b| b == 64), "{bins:?}");
    }

    #[test]
    fn streams_differ_by_key() {
        let a = Rng::new(hash_keys(&[0, 1, 2])).next_u32();
        let b = Rng::new(hash_keys(&[0, 2, 1])).next_u32();
        assert_ne!(a, b);
    }
}
