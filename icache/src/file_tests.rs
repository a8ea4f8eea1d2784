//! Tests of cache files: round trip, and every kind of damage gives its own error without panicking.
#![forbid(unsafe_code)]

use glam::Vec3;
use photon::sampling::Rng;

use crate::cache_tests::new_rec;
use crate::file::fnv1a64;
use crate::{CacheParams, Error, IrradianceCache, Pass, Weighting};

const FP: u64 = 0xDEAD_BEEF_1234_5678;

fn sample_cache() -> IrradianceCache {
    let params = CacheParams {
        weight: Weighting::Ward,
        accuracy: 0.3,
        pass_b_accuracy: None,
        ..Default::default()
    };
    let mut c = IrradianceCache::new(Vec3::ZERO, Vec3::splat(4.0), params).unwrap();
    let mut rng = Rng::new(3);
    for i in 0..200 {
        let p = Vec3::new(4.0 * rng.uniform(), 4.0 * rng.uniform(), 1.0);
        let r = if i % 9 == 0 {
            f32::INFINITY
        } else {
            0.1 + rng.uniform()
        };
        let mut rec = new_rec(p, Vec3::Z, Vec3::splat(rng.uniform()), r, 0.01);
        rec.grad_t = [Vec3::X * 0.01; 3];
        c.insert(rec);
        if i == 149 {
            // Pass A ends; a round of pass B adds the rest.
            c.end_stage();
            c.freeze();
        }
    }
    c.end_stage();
    c
}

/// Bytes before the first record: the header and the sample cache's two stages.
const RECORDS_AT: usize = crate::file::HEADER_BYTES + 8;

/// Rewrite the trailing checksum so a deliberate edit reaches the field validation.
fn reseal(bytes: &mut [u8]) {
    let body = bytes.len() - 8;
    let sum = fnv1a64(&bytes[..body]);
    bytes[body..].copy_from_slice(&sum.to_le_bytes());
}

#[test]
fn round_trip_is_exact() {
    let c = sample_cache();
    let dir = std::env::temp_dir().join(format!("icache_test_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cache.bin");
    std::fs::write(&path, c.to_bytes(FP)).unwrap();
    let d = IrradianceCache::load(&path, FP).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(c.params(), d.params());
    assert_eq!(c.bounds(), d.bounds());
    assert_eq!(c.len(), d.len());
    assert_eq!((c.stages(), d.stages()), (&[150, 200][..], &[150, 200][..]));
    for (a, b) in c.records().iter().zip(d.records()) {
        assert_eq!(a.to_bits(), b.to_bits());
    }
    let mut rng = Rng::new(4);
    for _ in 0..500 {
        let p = Vec3::new(4.0 * rng.uniform(), 4.0 * rng.uniform(), 1.0);
        assert_eq!(c.lookup(p, Vec3::Z, Pass::B), d.lookup(p, Vec3::Z, Pass::B));
    }
}

#[test]
fn damaged_files_give_clear_errors() {
    let good = sample_cache().to_bytes(FP);
    assert!(matches!(
        IrradianceCache::from_bytes(&good, FP + 1),
        Err(Error::FingerprintMismatch { .. })
    ));

    let mut bad = good.clone();
    bad[0] = b'X';
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::BadMagic)
    ));

    let mut bad = good.clone();
    bad[8] = 99;
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::UnsupportedVersion { found: 99, .. })
    ));

    let mut bad = good.clone();
    let mid = good.len() / 2;
    bad[mid] ^= 0x10;
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::ChecksumMismatch { .. })
    ));

    // Every truncation is an error, never a panic.
    for len in (0..good.len())
        .step_by(37)
        .chain([good.len() - 1, 7, 11, 12])
    {
        assert!(
            IrradianceCache::from_bytes(&good[..len], FP).is_err(),
            "len {len}"
        );
    }
    let mut padded = good.clone();
    padded.push(0);
    assert!(matches!(
        IrradianceCache::from_bytes(&padded, FP),
        Err(Error::Truncated { .. })
    ));

    // A huge record count is caught by the length check before any allocation.
    let mut bad = good.clone();
    bad[72..80].copy_from_slice(&u64::MAX.to_le_bytes());
    reseal(&mut bad);
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::Truncated { .. })
    ));

    // Stages: too many, out of order, past the record count.
    let mut bad = good.clone();
    bad[68..72].copy_from_slice(&u32::MAX.to_le_bytes());
    reseal(&mut bad);
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::InvalidParams(_))
    ));
    for stages in [[160u32, 150], [150, 201]] {
        let mut bad = good.clone();
        bad[80..84].copy_from_slice(&stages[0].to_le_bytes());
        bad[84..88].copy_from_slice(&stages[1].to_le_bytes());
        reseal(&mut bad);
        assert!(
            matches!(
                IrradianceCache::from_bytes(&bad, FP),
                Err(Error::InvalidParams(_))
            ),
            "{stages:?}"
        );
    }

    // A NaN inside a record, with a valid checksum.
    let mut bad = good.clone();
    bad[RECORDS_AT + 132 + 24..RECORDS_AT + 132 + 28].copy_from_slice(&f32::NAN.to_le_bytes()); // record 1, e.x
    reseal(&mut bad);
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::CorruptRecord { index: 1, .. })
    ));

    // Irradiance near f32's limit (interpolation overflowed it to inf pixels), with a valid checksum;
    // likewise a gradient component (the first of the rotational gradient).
    for at in [RECORDS_AT + 132 + 24, RECORDS_AT + 132 + 36] {
        let mut bad = good.clone();
        bad[at..at + 4].copy_from_slice(&3e38f32.to_le_bytes());
        reseal(&mut bad);
        assert!(
            matches!(
                IrradianceCache::from_bytes(&bad, FP),
                Err(Error::CorruptRecord { index: 1, .. })
            ),
            "byte {at}"
        );
    }

    // Invalid parameters, with a valid checksum.
    let mut bad = good.clone();
    bad[20..24].copy_from_slice(&(-1.0f32).to_le_bytes()); // accuracy
    reseal(&mut bad);
    assert!(matches!(
        IrradianceCache::from_bytes(&bad, FP),
        Err(Error::InvalidParams(_))
    ));
}
