//! Whole-gather checks with analytic answers: a constant environment, a closed sphere seen from its
//! centre, a half-blocked sky, the dominant direction, and determinism.
use gather::{gather, gather_batch_round, GatherParams, GatherRay, GatherResult};
use glam::Vec3;
use photon::sampling::{hash_keys, Rng};
use std::f32::consts::PI;

/// A few unit normals, axis-aligned and random, including the Duff frame's z = −1 special case.
fn normals() -> Vec<Vec3> {
    let mut out = vec![
        Vec3::Y,
        Vec3::Z,
        -Vec3::Z,
        Vec3::new(1.0, 1.0, 1.0).normalize(),
    ];
    let mut rng = Rng::new(99);
    for _ in 0..4 {
        let [a, b] = rng.uniform2();
        let z = 1.0 - 2.0 * a;
        let r = (1.0 - z * z).sqrt();
        out.push(Vec3::new(
            r * (2.0 * PI * b).cos(),
            r * (2.0 * PI * b).sin(),
            z,
        ));
    }
    out
}

fn run(n: Vec3, rays: usize, seed: u64, trace: &mut dyn FnMut(Vec3) -> GatherRay) -> GatherResult {
    gather(Vec3::ZERO, n, &GatherParams { rays }, seed, trace)
}

/// A constant environment L gives E = π L up to rounding (gather sums in f64, so 1e-6 relative
/// is generous), no translational gradient at all (every neighbour difference is exactly 0) and
/// a rotational gradient that is only the rounding of Σ_k v_k = 0 (1e-5 of L).
#[test]
fn constant_environment() {
    let l = Vec3::new(0.7, 1.4, 2.1);
    for n in normals() {
        for rays in [1usize, 37, 500, 4000] {
            let mut directions_ok = true;
            let g = run(n, rays, 3, &mut |d| {
                directions_ok &= d.dot(n) >= -1e-6 && (d.length() - 1.0).abs() < 1e-5;
                GatherRay::miss(l)
            });
            assert!(
                directions_ok,
                "gather rays must be unit and in the hemisphere of {n}"
            );
            assert!(
                (g.e - PI * l).abs().max_element() <= 1e-6 * PI * l.max_element(),
                "{n} {rays}: {}",
                g.e
            );
            for c in 0..3 {
                assert_eq!(g.grad_t[c], Vec3::ZERO);
                assert!(
                    g.grad_r[c].length() <= 1e-5 * l[c],
                    "{n} {rays}: {}",
                    g.grad_r[c]
                );
            }
            assert_eq!((g.r_harmonic, g.r_min), (f32::INFINITY, f32::INFINITY));
            // Cosine-weighted directions average to (2/3) n; M = 1 grids are too coarse to check.
            if rays >= 37 {
                assert!(g.dir.dot(n) > 0.999, "{n} {rays}: dir {}", g.dir);
            }
        }
    }
}

/// Inside a closed sphere of uniform radiance, seen from off-centre, hit distances vary but the
/// irradiance is still π L and both gradients vanish: the gradients must not react to distance alone.
#[test]
fn uniform_sphere_off_centre_has_no_gradient() {
    let (l, radius, p) = (Vec3::splat(2.0), 3.0f32, Vec3::new(1.0, -0.5, 2.0));
    for n in normals() {
        let g = run(n, 500, 5, &mut |d| {
            // Far root of |p + t d| = radius, p inside the sphere.
            let b = p.dot(d);
            let t = -b + (b * b - (p.length_squared() - radius * radius)).sqrt();
            GatherRay {
                radiance: l,
                distance: t,
            }
        });
        assert!((g.e - PI * l).abs().max_element() <= 1e-5 * PI * 2.0);
        for c in 0..3 {
            assert_eq!(g.grad_t[c], Vec3::ZERO);
            assert!(g.grad_r[c].length() <= 1e-5 * 2.0);
        }
        assert!(g.r_min < g.r_harmonic && g.r_harmonic < 2.0 * radius);
    }
}

/// From the centre of a sphere of radius ρ every ray hits at ρ: r_harmonic = r_min = ρ (the
/// harmonic mean's f32 sum of M·N equal terms is good to 1e-5 relative).
#[test]
fn sphere_centre_distances() {
    let rho = 2.5f32;
    for n in normals() {
        let g = run(n, 500, 1, &mut |_| GatherRay {
            radiance: Vec3::ONE,
            distance: rho,
        });
        assert_eq!(g.r_min, rho);
        assert!((g.r_harmonic - rho).abs() <= 1e-5 * rho, "{}", g.r_harmonic);
        assert_eq!(g.n_rays, 494);
    }
}

/// A floor under a black sky half blocked by geometry at distance ρ (every ray with x > 0 hits):
/// the harmonic mean counts misses as infinitely far, so r_harmonic = ρ · n_rays / n_hits ≈ 2ρ
/// (the exact ratio depends on how the strata straddle x = 0), and r_min = ρ.
#[test]
fn half_blocked_sky_distances() {
    let rho = 1.5f32;
    let mut n_hits = 0u32;
    let g = run(Vec3::Y, 500, 2, &mut |d| {
        if d.x > 0.0 {
            n_hits += 1;
            GatherRay {
                radiance: Vec3::ONE,
                distance: rho,
            }
        } else {
            GatherRay::miss(Vec3::ZERO)
        }
    });
    let expected = rho * g.n_rays as f32 / n_hits as f32;
    assert!((g.r_harmonic - expected).abs() <= 1e-5 * expected);
    // One azimuthal column of 38 may fall on either side: n_hits / n_rays ∈ 1/2 ± 1/38.
    assert!(
        (g.r_harmonic / (2.0 * rho) - 1.0).abs() < 0.1,
        "{}",
        g.r_harmonic
    );
    assert_eq!(g.r_min, rho);
    // All light arrives from +x: the dominant direction leans that way, above the floor.
    assert!(g.dir.x > 0.5 && g.dir.y > 0.0, "{}", g.dir);
    // And the rotational gradient says turning the normal toward +x (about −z) brightens it.
    assert!(g.grad_r[0].dot(-Vec3::Z) > 0.0);
}

/// All rays missing: both distances are infinite, as the cache expects.
#[test]
fn all_misses_give_infinite_distances() {
    let g = run(Vec3::Y, 500, 4, &mut |_| GatherRay::miss(Vec3::ZERO));
    assert_eq!((g.r_harmonic, g.r_min), (f32::INFINITY, f32::INFINITY));
    assert_eq!(g.e, Vec3::ZERO);
    assert_eq!(
        g.dir,
        Vec3::Y,
        "no light: the dominant direction falls back to the normal"
    );
}

/// A scene with structure, so that every output field depends on the jitter.
fn lumpy(d: Vec3) -> GatherRay {
    let radiance = Vec3::new(d.x.max(0.0), (3.0 * d.z).sin().abs(), d.y * d.y);
    GatherRay {
        radiance,
        distance: 1.0 + d.x.abs() + 0.5 * d.z.abs(),
    }
}

/// Same seed → bitwise the same result; another seed → another result.
#[test]
fn deterministic_per_seed() {
    let n = Vec3::new(0.2, 0.9, -0.3).normalize();
    let seed = hash_keys(&[7, 42]);
    let a = run(n, 500, seed, &mut lumpy);
    let b = run(n, 500, seed, &mut lumpy);
    let bits = |g: &GatherResult| {
        let mut v = vec![g.e, g.dir];
        v.extend(g.grad_r);
        v.extend(g.grad_t);
        let mut out: Vec<u32> = v
            .iter()
            .flat_map(|x| x.to_array())
            .map(f32::to_bits)
            .collect();
        out.extend([g.r_harmonic.to_bits(), g.r_min.to_bits(), g.n_rays]);
        out
    };
    assert_eq!(bits(&a), bits(&b));
    let c = run(n, 500, seed ^ 1, &mut lumpy);
    assert_ne!(a.e, c.e);
}

/// The gather's own noise estimate (`rel_err`, from strata paired side by side) is 0 where every ray
/// sees the same radiance, and close to the true relative standard error of E where a small bright
/// spot makes the gather noisy: over 400 gathers with different jitter, the mean estimate is within
/// 0.7–2× the spread of E itself (measured 0.282 against 0.234; pairing is conservative where radiance
/// varies smoothly).
#[test]
fn own_noise_estimate_matches_the_spread_of_e() {
    let n = Vec3::Z;
    let flat = run(n, 500, 3, &mut |_| GatherRay {
        radiance: Vec3::splat(0.4),
        distance: 1.0,
    });
    assert_eq!(flat.rel_err, 0.0);
    // A dim sky with a spot 8° wide, 200× brighter, 40° off the normal.
    let spot = Vec3::new(40f32.to_radians().sin(), 0.0, 40f32.to_radians().cos());
    let mut sky = |d: Vec3| GatherRay {
        radiance: Vec3::splat(if d.dot(spot) > 4f32.to_radians().cos() {
            20.0
        } else {
            0.1
        }),
        distance: 1.0,
    };
    let results: Vec<GatherResult> = (0..400).map(|seed| run(n, 500, seed, &mut sky)).collect();
    let es: Vec<f64> = results.iter().map(|g| g.e.x as f64).collect();
    let mean = es.iter().sum::<f64>() / es.len() as f64;
    let sd = (es.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (es.len() - 1) as f64).sqrt();
    let true_rel = sd / mean;
    let est = results.iter().map(|g| g.rel_err as f64).sum::<f64>() / results.len() as f64;
    eprintln!("[gather noise] estimated {est:.4}, spread of E {true_rel:.4}");
    assert!(
        true_rel > 0.005,
        "the spot must make the gather noisy: {true_rel}"
    );
    assert!(
        est > 0.7 * true_rel && est < 2.0 * true_rel,
        "estimated {est:.4} against the spread's {true_rel:.4}"
    );
}

/// Rounds of a gather from one seed (`gather_batch_round`, how `pm` adds rays to its records): each
/// round alone is an unbiased gather, round 0 is `gather`'s, and four rounds of 250 rays together
/// stratify the hemisphere like one gather of 1000 — their mean's spread is that of a 1000-ray gather,
/// well below that of four independent 250-ray gathers (for a bright spot, whose edge is where a
/// stratified estimate's error lives).
#[test]
fn rounds_of_one_gather_stratify_together() {
    let n = Vec3::Z;
    let spot = Vec3::new(30f32.to_radians().sin(), 0.0, 30f32.to_radians().cos());
    let mut sky = |d: Vec3| GatherRay {
        radiance: Vec3::splat(if d.dot(spot) > 6f32.to_radians().cos() {
            20.0
        } else {
            0.1
        }),
        distance: 1.0,
    };
    let round = |rays: usize, seed: u64, k: u32, sky: &mut dyn FnMut(Vec3) -> GatherRay| {
        gather_batch_round(
            Vec3::ZERO,
            n,
            &GatherParams { rays },
            seed,
            k,
            &mut |dirs: &[Vec3], out: &mut Vec<GatherRay>| out.extend(dirs.iter().map(|&d| sky(d))),
        )
        .e
        .x as f64
    };
    assert_eq!(
        round(250, 5, 0, &mut sky),
        run(n, 250, 5, &mut sky).e.x as f64,
        "round 0 is the plain gather"
    );
    let spread = |xs: &[f64]| {
        let m = xs.iter().sum::<f64>() / xs.len() as f64;
        (
            m,
            (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt(),
        )
    };
    // E of the sky: π·0.1 plus the spot's (20 − 0.1)·cos 30°·solid angle (6° cap) — from 4000-ray gathers.
    let truth = spread(
        &(0..200)
            .map(|s| run(n, 4000, 10_000 + s, &mut sky).e.x as f64)
            .collect::<Vec<_>>(),
    )
    .0;
    let seeds = 0..600u64;
    let rounds: Vec<[f64; 4]> = seeds
        .clone()
        .map(|s| std::array::from_fn(|k| round(250, s, k as u32, &mut sky)))
        .collect();
    for k in 0..4 {
        let (m, sd) = spread(&rounds.iter().map(|r| r[k]).collect::<Vec<_>>());
        let se = sd / (rounds.len() as f64).sqrt();
        assert!(
            (m - truth).abs() < 4.0 * se + 1e-3 * truth,
            "round {k}: mean {m} against {truth} (se {se})"
        );
    }
    let together = spread(
        &rounds
            .iter()
            .map(|r| r.iter().sum::<f64>() / 4.0)
            .collect::<Vec<_>>(),
    )
    .1;
    let one_grid = spread(
        &seeds
            .clone()
            .map(|s| run(n, 1000, 50_000 + s, &mut sky).e.x as f64)
            .collect::<Vec<_>>(),
    )
    .1;
    let independent = spread(
        &seeds
            .map(|s| {
                (0..4)
                    .map(|k| run(n, 250, 90_000 + 4 * s + k, &mut sky).e.x as f64)
                    .sum::<f64>()
                    / 4.0
            })
            .collect::<Vec<_>>(),
    )
    .1;
    eprintln!("[gather rounds] sd of E: 4 rounds {together:.5}, one 1000-ray grid {one_grid:.5}, 4 independent gathers {independent:.5}");
    assert!(
        together < 1.25 * one_grid,
        "4 rounds {together} against one grid {one_grid}"
    );
    assert!(
        together < 0.8 * independent,
        "4 rounds {together} against 4 independent gathers {independent}"
    );
}
