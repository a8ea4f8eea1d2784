//! Tests of insertion and interpolation: exact reproduction of constant and linear fields, neighbor
//! clamping's triangle inequality, the octree against brute force, gradient limit and sanitising.
#![forbid(unsafe_code)]

use glam::Vec3;
use photon::sampling::Rng;

use crate::{CacheParams, IrradianceCache, NewRecord, Pass, Weighting};

fn rand01(rng: &mut Rng) -> Vec3 {
    Vec3::new(rng.uniform(), rng.uniform(), rng.uniform())
}

pub(crate) fn new_rec(pos: Vec3, normal: Vec3, e: Vec3, r: f32, pixel_world: f32) -> NewRecord {
    NewRecord {
        pos,
        normal,
        e,
        grad_r: [Vec3::ZERO; 3],
        grad_t: [Vec3::ZERO; 3],
        r_harmonic: r,
        r_min: r,
        dir: normal,
        pixel_world,
        rel_err: 0.0,
        at: crate::record::NO_PIXEL,
    }
}

fn cache(params: CacheParams) -> IrradianceCache {
    IrradianceCache::new(Vec3::ZERO, Vec3::splat(10.0), params).unwrap()
}

/// Records on the plane z = 5 with random spacing radii; queries on the same plane.
fn plane_points(rng: &mut Rng, n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|_| Vec3::new(10.0 * rng.uniform(), 10.0 * rng.uniform(), 5.0))
        .collect()
}

#[test]
fn constant_field_reproduced() {
    for weight in [Weighting::TabellionLamorlette, Weighting::Ward] {
        let mut rng = Rng::new(11);
        let mut c = cache(CacheParams {
            weight,
            accuracy: 0.3,
            pass_b_accuracy: Some(0.6),
            ..Default::default()
        });
        let e0 = Vec3::new(0.7, 1.3, 2.9);
        for p in plane_points(&mut rng, 3000) {
            c.insert(new_rec(p, Vec3::Z, e0, 0.05 + rng.uniform(), 0.02));
        }
        let mut n_hits = 0;
        for p in plane_points(&mut rng, 3000) {
            for pass in [Pass::A, Pass::B] {
                if let Some(hit) = c.lookup(p, Vec3::Z, pass) {
                    n_hits += 1;
                    // Tolerance: a weighted mean of identical f32 values, a few ulps of rounding.
                    assert!(
                        ((hit.e - e0) / e0).abs().max_element() < 1e-6,
                        "{:?} vs {e0}",
                        hit.e
                    );
                }
            }
        }
        assert!(n_hits > 3000, "too few hits to test anything: {n_hits}");
    }
}

#[test]
fn linear_field_reproduced_with_gradients() {
    let mut rng = Rng::new(12);
    let mut c = cache(CacheParams::default());
    // E_c(p) = e0_c + g_c · p, gradients in the plane. E ≥ 90 and |g| ≤ 1.5 make the gradient limit
    // (E/|g| ≥ 60) larger than R' (≤ 20 px × 0.01), so insertion leaves the gradients untouched.
    let e0 = Vec3::new(100.0, 120.0, 140.0);
    let g = [
        Vec3::new(1.0, 0.5, 0.0),
        Vec3::new(-0.7, 0.2, 0.0),
        Vec3::new(0.0, -1.0, 0.0),
    ];
    let field = |p: Vec3| Vec3::new(e0.x + g[0].dot(p), e0.y + g[1].dot(p), e0.z + g[2].dot(p));
    for p in plane_points(&mut rng, 4000) {
        let mut r = new_rec(p, Vec3::Z, field(p), 1000.0, 0.01);
        r.grad_t = g;
        let stats = c.insert(r);
        assert_eq!(stats.n_inserted, 1);
    }
    assert!(c.records().iter().all(|r| r.grad_t == g));
    let mut n_hits = 0;
    for p in plane_points(&mut rng, 4000) {
        if let Some(hit) = c.lookup(p, Vec3::Z, Pass::B) {
            n_hits += 1;
            // Tolerance: f32 sums of values ≈ 100 with weights ≤ 1 over ≲ 30 records: ~1e-6 relative.
            let rel = ((hit.e - field(p)) / field(p)).abs().max_element();
            assert!(rel < 1e-5, "rel error {rel}");
        }
    }
    assert!(n_hits > 2000, "{n_hits}");
}

#[test]
fn rotational_gradient_applied() {
    let mut c = cache(CacheParams::default());
    let mut r = new_rec(Vec3::splat(5.0), Vec3::Z, Vec3::ONE, 1.0, 0.05);
    r.grad_r = [Vec3::X, Vec3::Y, Vec3::ZERO];
    c.insert(r);
    // A query normal tilted by a small angle about x: n_i × n points along -x·sin θ.
    let th: f32 = 0.05;
    let n = Vec3::new(0.0, th.sin(), th.cos());
    let hit = c.lookup(Vec3::splat(5.0), n, Pass::A).unwrap();
    let axis = Vec3::Z.cross(n);
    // Single record: E = E_i + (n_i × n)·∇r exactly (up to f32 rounding of the cross product).
    assert!((hit.e.x - (1.0 + axis.x)).abs() < 1e-6);
    assert!((hit.e.y - (1.0 + axis.y)).abs() < 1e-6);
    assert_eq!(hit.e.z, 1.0);
}

#[test]
fn neighbor_clamping_keeps_triangle_inequality() {
    let mut rng = Rng::new(13);
    let params = CacheParams {
        adaptive: None,
        ..Default::default()
    };
    let mut c = cache(params);
    for step in 0..600 {
        let p = rand01(&mut rng) * 10.0;
        let n = (rand01(&mut rng) - Vec3::splat(0.5)).normalize_or(Vec3::Z);
        let r = match step % 7 {
            0 => f32::INFINITY, // a gather whose rays all leaked
            1 => 0.001,
            _ => 0.01 + 3.0 * rng.uniform(),
        };
        let pixel_world = 0.005 + 0.03 * rng.uniform();
        let mut rec = new_rec(p, n, Vec3::ONE, r, pixel_world);
        rec.grad_t = [Vec3::X * 0.1; 3];
        c.insert(rec);
        let recs = c.records();
        for (j, a) in recs.iter().enumerate() {
            // R' is R clamped to this record's bounds; ∇t carries the factor min(1, R/R').
            let (lo, hi) = (
                params.min_spacing_px * a.pixel_world,
                params.max_spacing_px * a.pixel_world,
            );
            assert_eq!(a.r_clamped, a.r_harmonic.clamp(lo, hi));
            let scale = if a.r_harmonic < a.r_clamped {
                a.r_harmonic / a.r_clamped
            } else {
                1.0
            };
            // Tolerance: the scale is applied as a product of ratios, each adding a few f32 roundings.
            assert!(
                (a.grad_t[0].x - 0.1 * scale).abs() <= 1e-5 * 0.1,
                "record {j}"
            );
            for b in &recs[j + 1..] {
                let d = (a.pos - b.pos).length();
                if d < a.r_clamped + b.r_clamped {
                    // Exact in f32: clamping stores R_k + d computed with the same d.
                    assert!(
                        a.r_harmonic <= b.r_harmonic + d,
                        "step {step}: {} > {} + {d}",
                        a.r_harmonic,
                        b.r_harmonic
                    );
                    assert!(
                        b.r_harmonic <= a.r_harmonic + d,
                        "step {step}: {} > {} + {d}",
                        b.r_harmonic,
                        a.r_harmonic
                    );
                }
            }
        }
    }
    assert!(c.insert_totals().n_shrunk_by_neighbors > 0);
}

#[test]
fn octree_lookup_matches_brute_force() {
    for weight in [Weighting::TabellionLamorlette, Weighting::Ward] {
        let mut rng = Rng::new(14);
        let params = CacheParams {
            weight,
            accuracy: 0.4,
            pass_b_accuracy: Some(0.9),
            ..Default::default()
        };
        let mut c = IrradianceCache::new(Vec3::splat(1.0), Vec3::splat(9.0), params).unwrap();
        // Records on a few tilted planes, some outside the index bounds.
        let normals = [
            Vec3::Z,
            Vec3::new(0.3, 0.0, 1.0).normalize(),
            Vec3::X,
            -Vec3::Y,
        ];
        for i in 0..3000 {
            let n = normals[i % normals.len()];
            let p = rand01(&mut rng) * 10.0;
            let mut rec = new_rec(
                p,
                n,
                rand01(&mut rng) + Vec3::splat(0.1),
                0.02 + rng.uniform(),
                0.01 + 0.02 * rng.uniform(),
            );
            rec.grad_t = [n.any_orthonormal_vector() * 0.05; 3];
            rec.grad_r = [n.any_orthonormal_vector() * 0.02; 3];
            c.insert(rec);
        }
        let mut n_hits = 0;
        for i in 0..5000 {
            let n = (normals[i % normals.len()] + 0.05 * (rand01(&mut rng) - Vec3::splat(0.5)))
                .normalize();
            let p = rand01(&mut rng) * 10.0;
            for pass in [Pass::A, Pass::B] {
                let fast = c.lookup(p, n, pass);
                let slow = c.lookup_brute(p, n, pass);
                let usable = c.usable_records_brute(p, n, pass);
                assert_eq!(fast.map_or(0, |l| l.n_used as usize), usable.len());
                match (fast, slow) {
                    (None, None) => {}
                    (Some(f), Some(s)) => {
                        n_hits += 1;
                        // Tolerance: same terms summed in another order (f32), ~n_used ulps.
                        assert!(
                            (f.e - s.e).abs().max_element() <= 1e-5 * s.e.max_element().max(1.0)
                        );
                    }
                    (f, s) => panic!("octree {f:?} vs brute {s:?}"),
                }
            }
        }
        assert!(n_hits > 300, "{n_hits}");
    }
}

#[test]
fn gradient_limit_and_min_clamp() {
    let mut c = cache(CacheParams {
        adaptive: None,
        ..Default::default()
    });
    let mut r = new_rec(
        Vec3::splat(5.0),
        Vec3::Z,
        Vec3::new(1.0, 2.0, 2.0),
        5.0,
        0.1,
    );
    r.grad_t = [Vec3::X * 10.0, Vec3::X, Vec3::ZERO];
    let s = c.insert(r);
    // R = min(5, 1/10, 2/1) = 0.1 < R_min = 3 px × 0.1 = 0.3, so R' = 0.3 and ∇t scales by 1/3.
    assert_eq!(
        (s.n_shrunk_by_gradient, s.n_clamped_min, s.n_clamped_max),
        (1, 1, 0)
    );
    let rec = c.records()[0];
    assert_eq!(rec.r_harmonic, 0.1);
    assert!((rec.r_clamped - 0.3).abs() < 1e-6);
    assert!((rec.grad_t[0].x - 10.0 / 3.0).abs() < 1e-5);
    // First-order extrapolation to the border of the record's reach stays non-negative.
    let hit = c
        .lookup(Vec3::new(5.0 - 0.149, 5.0, 5.0), Vec3::Z, Pass::A)
        .unwrap();
    assert!(hit.e.x >= 0.0 && hit.e.x < 1.0);
}

#[test]
fn bad_gathers_are_rejected_or_repaired() {
    let mut c = cache(CacheParams::default());
    let s = c.insert(new_rec(
        Vec3::splat(f32::NAN),
        Vec3::Z,
        Vec3::ONE,
        1.0,
        0.01,
    ));
    assert_eq!((s.n_rejected, s.n_inserted), (1, 0));
    let s = c.insert(new_rec(Vec3::ONE, Vec3::ZERO, Vec3::ONE, 1.0, 0.01));
    assert_eq!(s.n_rejected, 1);
    let s = c.insert(new_rec(Vec3::ONE, Vec3::Z, Vec3::ONE, 1.0, 0.0));
    assert_eq!(s.n_rejected, 1);
    let s = c.insert(new_rec(
        Vec3::ONE,
        Vec3::Z * 2.0,
        Vec3::new(f32::NAN, -1.0, 1.0),
        f32::NAN,
        0.01,
    ));
    assert_eq!((s.n_inserted, s.n_sanitized), (1, 1));
    let hit = c.lookup(Vec3::ONE, Vec3::Z, Pass::A).unwrap();
    assert_eq!(hit.e, Vec3::new(0.0, 0.0, 1.0));
    assert!(c
        .lookup(Vec3::ONE, Vec3::splat(f32::NAN), Pass::A)
        .is_none());
}

#[test]
fn get_or_insert_gathers_only_on_miss() {
    let mut c = cache(CacheParams::default());
    let mut n_gathers = 0;
    for i in 0..20 {
        let p = Vec3::new(5.0 + 0.001 * i as f32, 5.0, 5.0);
        let e = c.get_or_insert_with(p, Vec3::Z, 0.01, || {
            n_gathers += 1;
            new_rec(p, Vec3::Z, Vec3::splat(2.0), 1.0, 123.0)
        });
        assert_eq!(e, Vec3::splat(2.0));
    }
    assert_eq!(n_gathers, 1);
    // The caller's footprint overrides the one the gather returned.
    assert_eq!(c.records()[0].pixel_world, 0.01);
    assert!(c.memory_bytes() > std::mem::size_of::<IrradianceCache>());
}

/// A record that neighbor clamping shrinks is logged with its radii before the shrink, and loses
/// exactly the points between its old and new pass-A reach: the repair sweeps look up only those.
#[test]
fn shrink_log_names_the_points_a_record_lost() {
    let mut c = cache(CacheParams::default());
    c.log_shrinks(true);
    let (n, e) = (Vec3::Z, Vec3::ONE);
    let a = Vec3::new(5.0, 5.0, 5.0);
    // R' clamped to the 20 px maximum (0.2); a = 0.5 in pass A, so it reaches 0.1.
    c.insert(new_rec(a, n, e, 1.0, 0.01));
    assert!(c.take_shrink_log().is_empty());
    // A small record 0.15 away clamps A's R to 0.03 + 0.15 = 0.18: pass-A reach 0.09.
    c.insert(new_rec(a + Vec3::new(0.15, 0.0, 0.0), n, e, 0.03, 0.01));
    let log = c.take_shrink_log();
    assert_eq!(log.len(), 1, "{log:?}");
    assert_eq!(log[0].id, 0);
    assert!(
        (c.records()[0].r_clamped - 0.18).abs() < 1e-5,
        "{}",
        c.records()[0].r_clamped
    );
    let (pos, reach) = c.reach_before(&log[0]);
    assert_eq!(pos, a);
    assert!((reach - 0.1).abs() < 1e-5, "{reach}");
    let at = |d: f32| a - Vec3::new(d, 0.0, 0.0);
    assert!(
        c.lost_cover(&log[0], at(0.095), n),
        "between the new and the old reach"
    );
    assert!(
        !c.lost_cover(&log[0], at(0.05), n),
        "still inside the new reach"
    );
    assert!(!c.lost_cover(&log[0], at(0.12), n), "never inside");
    assert!(
        !c.lost_cover(&log[0], at(0.095), -n),
        "facing away: never usable"
    );
}

/// A wave's insertions with the neighbours searched at the wave's start (`insert_near`, as the two-pass
/// fill does them in parallel) give bitwise the records of plain insertions, neighbor clamping included.
#[test]
fn insertion_with_neighbours_found_at_the_wave_start_is_exact() {
    let mut rng = Rng::new(23);
    let news: Vec<NewRecord> = plane_points(&mut rng, 400)
        .into_iter()
        .map(|p| {
            new_rec(
                p,
                Vec3::Z,
                Vec3::ONE,
                0.05 + 2.0 * rng.uniform() * rng.uniform(),
                0.01,
            )
        })
        .collect();
    let mut plain = cache(CacheParams::default());
    let mut near = cache(CacheParams::default());
    for wave in news.chunks(16) {
        let since = near.len();
        let found: Vec<Option<Vec<u32>>> =
            wave.iter().map(|r| near.neighbor_candidates(r)).collect();
        for (r, ids) in wave.iter().zip(&found) {
            plain.insert(*r);
            near.insert_near(*r, ids.as_deref().map(|ids| (ids, since)));
        }
    }
    assert!(
        plain.insert_totals().n_shrunk_by_neighbors > 100,
        "{:?}",
        plain.insert_totals()
    );
    assert_eq!(plain.insert_totals(), near.insert_totals());
    for (a, b) in plain.records().iter().zip(near.records()) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
}

/// Records on z = 5 at x = 4.9 (irradiance `left`) and x = 5.1 (irradiance 1), reach 1, unclamped.
fn two_records(left: f32) -> IrradianceCache {
    let mut c = cache(CacheParams {
        neighbor_clamping: false,
        ..Default::default()
    });
    for (x, e) in [(4.9, left), (5.1, 1.0)] {
        c.insert(new_rec(
            Vec3::new(x, 5.0, 5.0),
            Vec3::Z,
            Vec3::splat(e),
            1.0,
            0.01,
        ));
    }
    c
}

#[test]
fn a_lookup_leaves_out_the_records_its_visibility_test_rejects() {
    // Two records on z = 5 either side of the query, one bright, one dark.
    let c = two_records(2.0);
    let p = Vec3::new(5.0, 5.0, 5.0);
    let all = c.lookup(p, Vec3::Z, Pass::B).unwrap();
    assert_eq!(
        c.lookup_first_visible(p, Vec3::Z, Pass::B, usize::MAX, |_, _| true),
        Some(all)
    );
    assert!(
        (all.e - Vec3::splat(1.5)).abs().max_element() < 1e-5,
        "{:?}",
        all.e
    );
    // The bright record hidden: the dark one alone.
    let dark = c
        .lookup_first_visible(p, Vec3::Z, Pass::B, usize::MAX, |_, r| r.e.x < 1.5)
        .unwrap();
    assert!(
        (dark.e - Vec3::ONE).abs().max_element() < 1e-6,
        "{:?}",
        dark.e
    );
    assert_eq!(dark.n_used, 1);
    // Both hidden: a miss.
    assert_eq!(
        c.lookup_first_visible(p, Vec3::Z, Pass::B, usize::MAX, |_, _| false),
        None
    );
}

/// A lookup notes the records it interpolates only where they disagree, and interpolating those records
/// alone at a nearby point gives the full lookup's answer there (no other record reaches it).
#[test]
fn records_noted_where_they_disagree_interpolate_as_the_full_lookup() {
    let c = two_records(0.2);
    let p = Vec3::new(5.0, 5.0, 5.0);
    let mut ids = Vec::new();
    let found = c.lookup_noting(p, Vec3::Z, Pass::B, usize::MAX, |_, _| true, 0.2, &mut ids);
    assert_eq!(found, c.lookup(p, Vec3::Z, Pass::B));
    assert_eq!(ids, vec![0, 1]);
    for q in [Vec3::new(4.95, 5.02, 5.0), Vec3::new(5.04, 4.97, 5.0)] {
        let among = c.lookup_among(q, Vec3::Z, Pass::B, &ids).unwrap();
        let full = c.lookup(q, Vec3::Z, Pass::B).unwrap();
        assert!(
            (among.e - full.e).abs().max_element() < 1e-6,
            "{among:?} {full:?}"
        );
        assert!(
            (among.e - found.unwrap().e).abs().max_element() > 1e-3,
            "moved with q"
        );
    }
    // Records that agree within the fraction: none noted, the value serves the pixel.
    let near = c.lookup_noting(p, Vec3::Z, Pass::B, usize::MAX, |_, _| true, 2.0, &mut ids);
    assert!(near.is_some() && ids.is_empty());
    // A miss notes nothing; records past the cache's end are skipped.
    let far = Vec3::new(0.5, 0.5, 5.0);
    assert_eq!(
        c.lookup_noting(
            far,
            Vec3::Z,
            Pass::B,
            usize::MAX,
            |_, _| true,
            0.0,
            &mut ids
        ),
        None
    );
    assert!(ids.is_empty());
    assert_eq!(c.lookup_among(p, Vec3::Z, Pass::B, &[99]), None);
}

/// Pass A's coverage test finds a record exactly where the full interpolation over the records the
/// visibility test accepts exists, and names one of those records.
#[test]
fn pass_a_cover_exists_where_the_interpolation_does() {
    let mut rng = Rng::new(31);
    let mut c = cache(CacheParams::default());
    for p in plane_points(&mut rng, 400) {
        let n = (Vec3::Z + 0.2 * (rand01(&mut rng) - Vec3::splat(0.5))).normalize();
        c.insert(new_rec(p, n, rand01(&mut rng), 0.2 + rng.uniform(), 0.05));
    }
    // Visibility by a fixed pseudo-random half of the records.
    let visible = |id: u32, _: &crate::Record| id.wrapping_mul(2_654_435_761) >> 31 == 0;
    let (mut covered, mut missed) = (0, 0);
    for p in plane_points(&mut rng, 4000) {
        let full = c.lookup_first_visible(p, Vec3::Z, Pass::A, usize::MAX, visible);
        let cover = c.cover(p, Vec3::Z, visible);
        assert_eq!(cover.is_some(), full.is_some(), "at {p:?}");
        if let Some(one) = cover {
            assert_eq!(one.n_used, 1);
            covered += 1;
        } else {
            missed += 1;
        }
    }
    assert!(
        covered > 500 && missed > 100,
        "{covered} covered, {missed} missed"
    );
}

/// `lookup_with_noise`: one record gives its own σ = rel_err · L(E); two records of equal weight at the
/// same point give √(σ₁² + σ₂²)/2 (their gathers are independent).
#[test]
fn interpolation_noise_from_the_records_noise() {
    let mut c = cache(CacheParams::default());
    let p = Vec3::new(5.0, 5.0, 5.0);
    let e = Vec3::splat(2.0);
    c.insert(NewRecord {
        rel_err: 0.1,
        ..new_rec(p, Vec3::Z, e, 1.0, 0.01)
    });
    let (l, sd) = c.lookup_with_noise(p, Vec3::Z, Pass::B).unwrap();
    assert_eq!(l, c.lookup(p, Vec3::Z, Pass::B).unwrap());
    assert!((sd - 0.2).abs() < 1e-5, "{sd}");
    c.insert(NewRecord {
        rel_err: 0.05,
        ..new_rec(p, Vec3::Z, e, 1.0, 0.01)
    });
    let (_, sd) = c.lookup_with_noise(p, Vec3::Z, Pass::B).unwrap();
    let want = (0.2f32.powi(2) + 0.1f32.powi(2)).sqrt() / 2.0;
    assert!((sd - want).abs() < 1e-5, "{sd} against {want}");
    assert!(c
        .lookup_with_noise(Vec3::new(9.0, 9.0, 9.0), Vec3::Z, Pass::B)
        .is_none());
    // A gather whose noise estimate is not a number is kept as unknown (0), not spread into lookups.
    let q = Vec3::new(2.0, 2.0, 5.0);
    for bad in [f32::NAN, f32::INFINITY, -1.0] {
        c.insert(NewRecord {
            rel_err: bad,
            ..new_rec(q, Vec3::Z, e, 1.0, 0.01)
        });
        assert_eq!(c.records().last().unwrap().rel_err, 0.0);
    }
    assert_eq!(c.lookup_with_noise(q, Vec3::Z, Pass::B).unwrap().1, 0.0);
}

/// `refine` folds a further gather in by its share of the rays: E and both gradients are the weighted
/// means (∇t with the record's own scale R/R'), the noise that of the weighted sum, position and radii
/// unchanged.
#[test]
fn refine_folds_a_further_gather_in() {
    let mut c = cache(CacheParams::default());
    let p = Vec3::new(5.0, 5.0, 5.0);
    // R = 0.01, clamped up to R' = 3 px × 0.01 = 0.03: insertion scales ∇t by R/R' = 1/3.
    let first = NewRecord {
        rel_err: 0.2,
        grad_t: [Vec3::X; 3],
        grad_r: [Vec3::Y; 3],
        ..new_rec(p, Vec3::Z, Vec3::splat(1.0), 0.01, 0.01)
    };
    c.insert(first);
    let before = c.records()[0];
    let scale = before.grad_t[0].x;
    assert!((scale - 1.0 / 3.0).abs() < 1e-5, "{scale}");
    let more = NewRecord {
        rel_err: 0.1,
        e: Vec3::splat(2.0),
        grad_t: [Vec3::Y; 3],
        grad_r: [Vec3::X; 3],
        ..first
    };
    c.refine(0, &more, 0.5);
    let after = c.records()[0];
    assert_eq!(
        (after.pos, after.normal, after.r_harmonic, after.r_clamped),
        (
            before.pos,
            before.normal,
            before.r_harmonic,
            before.r_clamped
        )
    );
    assert!(
        (after.e - Vec3::splat(1.5)).abs().max_element() < 1e-6,
        "{}",
        after.e
    );
    assert!(
        (after.grad_r[1] - Vec3::new(0.5, 0.5, 0.0))
            .abs()
            .max_element()
            < 1e-6
    );
    assert!(
        (after.grad_t[2] - Vec3::new(0.5 * scale, 0.5 * scale, 0.0))
            .abs()
            .max_element()
            < 1e-6,
        "{}",
        after.grad_t[2]
    );
    // σ = √((0.5 · 0.2 · 1)² + (0.5 · 0.1 · 2)²) = √0.02 over E = 1.5.
    assert!(
        (after.rel_err - 0.02f32.sqrt() / 1.5).abs() < 1e-5,
        "{}",
        after.rel_err
    );
    // Shares outside (0, 1) and non-finite gathers change nothing.
    for (share, e) in [
        (0.0, Vec3::ONE),
        (1.0, Vec3::ONE),
        (0.5, Vec3::splat(f32::NAN)),
    ] {
        c.refine(0, &NewRecord { e, ..more }, share);
        assert_eq!(c.records()[0], after);
    }
}

/// A further gather whose ray met a surface almost at the record's point brings a translational
/// gradient without bound; the fold keeps the gradient limit (|∇t E_c|·R' ≤ E_c), so no lookup
/// within R' extrapolates a channel by more than 100 %.
#[test]
fn refine_keeps_the_gradient_limit() {
    let mut c = cache(CacheParams::default());
    let p = Vec3::new(5.0, 5.0, 5.0);
    let first = new_rec(p, Vec3::Z, Vec3::splat(1.0), 0.5, 0.01);
    c.insert(first);
    let more = NewRecord {
        grad_t: [Vec3::X * 1e4, Vec3::ZERO, Vec3::ZERO],
        ..first
    };
    c.refine(0, &more, 0.25);
    let rec = c.records()[0];
    for ch in 0..3 {
        assert!(
            rec.grad_t[ch].length() * rec.r_clamped <= rec.e[ch] * 1.0001,
            "channel {ch}: |∇t| {} R' {} E {}",
            rec.grad_t[ch].length(),
            rec.r_clamped,
            rec.e[ch]
        );
    }
    let near = p + Vec3::X * 0.3 * rec.r_clamped;
    let l = c.lookup(near, Vec3::Z, Pass::B).unwrap();
    assert!(l.e.x <= 2.0 * rec.e.x + 1e-4, "{}", l.e);
}

/// A lookup at a bumped normal weighs records by the smooth normal (the same records, the same
/// weights as an unbumped lookup) and turns each one's irradiance by its rotational gradient; a
/// bumped normal 30° off, beyond any record's normal reach, still finds them. Without gradients the
/// record's dominant direction turns it; either way, only the share of the turned hemisphere above
/// the smooth surface counts.
#[test]
fn a_bumped_lookup_turns_records_found_by_the_smooth_normal() {
    let turned = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
    let grad = Vec3::new(0.0, 0.4, 0.0);
    for gradients in [true, false] {
        let mut c = cache(CacheParams {
            gradients,
            ..Default::default()
        });
        let mut r = new_rec(Vec3::splat(5.0), Vec3::Z, Vec3::ONE, 1.0, 0.02);
        r.grad_r = [grad; 3];
        r.dir = Vec3::new(1.0, 0.0, 1.0).normalize();
        c.insert(r);
        let p = Vec3::new(5.01, 5.0, 5.0);
        let mut ids = Vec::new();
        let smooth = c
            .lookup_noting(p, Vec3::Z, Pass::B, usize::MAX, |_, _| true, 0.0, &mut ids)
            .unwrap();
        let bumped = c
            .lookup_noting_turned(
                p,
                Vec3::Z,
                turned,
                Pass::B,
                usize::MAX,
                |_, _| true,
                0.0,
                &mut ids,
            )
            .unwrap();
        assert_eq!(
            (bumped.n_used, bumped.weight_sum),
            (smooth.n_used, smooth.weight_sum)
        );
        assert!(c.lookup(p, turned, Pass::B).is_none());
        let turn = if gradients {
            // (n_i × n_turned)·∇r: (0, 0.5, 0)·(0, 0.4, 0).
            1.0 + 0.2
        } else {
            // 1 + (n_turned − n)·d / (n·d).
            1.0 + (turned - Vec3::Z).dot(r.dir) / Vec3::Z.dot(r.dir)
        };
        // The share of the turned lobe above the smooth plane: (1 + cos 30°)/2.
        let want = turn * 0.5 * (1.0 + turned.z);
        assert!(
            (bumped.e.x - want).abs() < 1e-5,
            "{gradients}: {} {want}",
            bumped.e.x
        );
    }
}
