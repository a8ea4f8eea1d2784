//! Photon-map files: round trip, and clear errors for damaged, truncated or foreign files.

mod common;

use std::sync::atomic::AtomicBool;

use common::*;
use photon::file::{load, read_maps, read_maps_within, save, write_maps, Plausible};
use photon::{trace_photons_cancellable, Error, MapsInfo, PhotonTargets};

const FINGERPRINT: u64 = 0xFEED_F00D_1234_5678;

fn encoded() -> (Vec<u8>, MapsInfo) {
    let scene = mirror_wall();
    let targets = PhotonTargets {
        global: 3_000,
        caustic: 500,
        volume: 0,
        volume_caustic: 0,
        max_paths: 1_000_000,
    };
    let (maps, stats) =
        trace_photons_cancellable(&scene, &targets, 5, &|_, _| {}, &AtomicBool::new(false))
            .unwrap();
    let info = MapsInfo::new(FINGERPRINT, 5, targets, &stats);
    let mut bytes = Vec::new();
    write_maps(&mut bytes, &info, &maps).unwrap();
    // The decoded maps must equal what was written.
    let loaded = read_maps(&bytes, FINGERPRINT).unwrap();
    assert_eq!(loaded.info, info);
    assert_eq!(
        loaded.maps.global.unwrap().photons(),
        maps.global.unwrap().photons()
    );
    assert_eq!(
        loaded.maps.caustic.unwrap().photons(),
        maps.caustic.unwrap().photons()
    );
    (bytes, info)
}

#[test]
fn round_trip_through_a_file() {
    let (bytes, info) = encoded();
    let loaded = read_maps(&bytes, FINGERPRINT).unwrap();
    let path = std::env::temp_dir().join(format!("photon-files-test-{}.pmap", std::process::id()));
    save(&path, &info, &loaded.maps).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
    let again = load(&path, FINGERPRINT, &Plausible::ANY).unwrap();
    assert_eq!(again.info, info);
    // A truncated file on disk is refused before its payload is read.
    std::fs::write(&path, &bytes[..bytes.len() - 100]).unwrap();
    assert!(matches!(
        load(&path, FINGERPRINT, &Plausible::ANY),
        Err(Error::BadLength { .. })
    ));
    std::fs::write(&path, &bytes[..50]).unwrap();
    assert!(matches!(
        load(&path, FINGERPRINT, &Plausible::ANY),
        Err(Error::BadLength { .. })
    ));
    std::fs::remove_file(&path).unwrap();
    assert!(matches!(
        load(&path, FINGERPRINT, &Plausible::ANY),
        Err(Error::Io { .. })
    ));
}

#[test]
fn damaged_files_give_clear_errors() {
    let (bytes, _) = encoded();
    assert!(matches!(
        read_maps(&bytes, FINGERPRINT ^ 1),
        Err(Error::SceneMismatch { .. })
    ));
    for cut in [0, 7, 8, 60, 111, 112, bytes.len() - 1] {
        let r = read_maps(&bytes[..cut], FINGERPRINT);
        assert!(
            matches!(r, Err(Error::BadMagic | Error::BadLength { .. })),
            "cut {cut}"
        );
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(
        read_maps(&longer, FINGERPRINT),
        Err(Error::BadLength { .. })
    ));
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 0x10;
    assert!(matches!(
        read_maps(&flipped, FINGERPRINT),
        Err(Error::Checksum)
    ));
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert!(matches!(
        read_maps(&magic, FINGERPRINT),
        Err(Error::BadMagic)
    ));
    let mut version = bytes.clone();
    version[8] = 99;
    assert!(matches!(
        read_maps(&version, FINGERPRINT),
        Err(Error::UnsupportedVersion { found: 99, .. })
    ));
    // Absurd photon counts are caught from the length, without allocating for them.
    let mut huge = bytes.clone();
    huge[80..88].copy_from_slice(&(1u64 << 40).to_le_bytes());
    assert!(matches!(
        read_maps(&huge, FINGERPRINT),
        Err(Error::BadLength { .. })
    ));
    huge[80..88].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(
        read_maps(&huge, FINGERPRINT),
        Err(Error::Corrupt(_))
    ));
}

/// Maps with volume photons (normal zero) in both volume maps.
fn with_volume_maps() -> (Vec<u8>, MapsInfo, photon::PhotonMaps) {
    let scene = mirror_wall();
    let targets = PhotonTargets {
        global: 2_000,
        caustic: 300,
        volume: 0,
        volume_caustic: 0,
        max_paths: 1_000_000,
    };
    let (mut maps, stats) =
        trace_photons_cancellable(&scene, &targets, 7, &|_, _| {}, &AtomicBool::new(false))
            .unwrap();
    // Volume photons made from the surface ones: positions off the surfaces, no normal.
    let to_volume = |m: &photon::PhotonMap, lift: f32| -> Vec<photon::Photon> {
        m.photons()
            .iter()
            .map(|ph| photon::Photon {
                pos: ph.pos + glam::Vec3::splat(lift),
                normal: glam::Vec3::ZERO,
                ..*ph
            })
            .collect()
    };
    maps.volume =
        Some(photon::PhotonMap::new(to_volume(maps.global.as_ref().unwrap(), 0.1)).unwrap());
    maps.volume_caustic =
        Some(photon::PhotonMap::new(to_volume(maps.caustic.as_ref().unwrap(), 0.2)).unwrap());
    let targets = PhotonTargets {
        volume: 2_000,
        volume_caustic: 300,
        ..targets
    };
    let stats = photon::TraceStats {
        n_volume_paths: 12_345,
        n_volume_caustic_paths: 67_890,
        ..stats
    };
    let info = MapsInfo::new(FINGERPRINT, 7, targets, &stats);
    let mut bytes = Vec::new();
    write_maps(&mut bytes, &info, &maps).unwrap();
    (bytes, info, maps)
}

#[test]
fn volume_maps_round_trip_and_a_volume_photon_with_a_normal_is_refused() {
    let (bytes, info, maps) = with_volume_maps();
    let loaded = read_maps(&bytes, FINGERPRINT).unwrap();
    assert_eq!(loaded.info, info);
    assert_eq!(
        (
            loaded.info.n_volume_paths,
            loaded.info.n_volume_caustic_paths
        ),
        (12_345, 67_890)
    );
    for (a, b) in [
        (&loaded.maps.global, &maps.global),
        (&loaded.maps.caustic, &maps.caustic),
        (&loaded.maps.volume, &maps.volume),
        (&loaded.maps.volume_caustic, &maps.volume_caustic),
    ] {
        assert_eq!(a.as_ref().unwrap().photons(), b.as_ref().unwrap().photons());
    }
    // The first volume photon's normal (pos, wi, power, then normal: 36 bytes in), made unit, checksum
    // recomputed: refused.
    let n = maps.global.as_ref().unwrap().len() + maps.caustic.as_ref().unwrap().len();
    let at = 160 + 52 * n + 36;
    let mut bad = bytes.clone();
    bad[at..at + 4].copy_from_slice(&1.0f32.to_le_bytes());
    let end = bad.len() - 8;
    let sum = fnv(&bad[8..end]);
    bad[end..].copy_from_slice(&sum.to_le_bytes());
    assert!(
        matches!(read_maps(&bad, FINGERPRINT), Err(Error::Corrupt(m)) if m.contains("volume photon 0"))
    );
}

fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

#[test]
fn a_version_4_file_is_still_read() {
    // Version 4 had no media words: the 112-byte header, then the photons.
    let (v5, info) = encoded();
    let mut v4 = v5[..112].to_vec();
    v4[8..12].copy_from_slice(&4u32.to_le_bytes());
    v4.extend_from_slice(&v5[160..v5.len() - 8]);
    let sum = fnv(&v4[8..]);
    v4.extend_from_slice(&sum.to_le_bytes());
    let (a, b) = (
        read_maps(&v4, FINGERPRINT).unwrap(),
        read_maps(&v5, FINGERPRINT).unwrap(),
    );
    assert_eq!(
        a.info,
        MapsInfo {
            n_volume_paths: 0,
            n_volume_caustic_paths: 0,
            ..info
        }
    );
    assert_eq!(
        a.maps.global.unwrap().photons(),
        b.maps.global.unwrap().photons()
    );
    assert_eq!(
        a.maps.caustic.unwrap().photons(),
        b.maps.caustic.unwrap().photons()
    );
    assert!(a.maps.volume.is_none() && a.maps.volume_caustic.is_none());
}

/// A file edited with its checksum recomputed: a photon of 1e30 W, or one beyond the coordinate limit,
/// is refused against what the scene allows (its light emits 4π W; no path carries more).
#[test]
fn photons_beyond_what_the_scene_allows_are_refused() {
    let (bytes, _) = encoded();
    let scene = Plausible {
        max_path_power: 4.0 * std::f64::consts::PI * 1.0001,
        max_coord: 1e15,
    };
    assert!(read_maps_within(&bytes, FINGERPRINT, &scene).is_ok());
    // The first global photon: pos at 160, power 24 bytes in.
    for (at, value, expect) in [
        (160 + 24, 1e30f32, "more than the scene's lights"),
        (160 + 28, 1e30, "more than the scene's lights"),
        (160, 1e20, "coordinate limit"),
    ] {
        let mut bad = bytes.clone();
        bad[at..at + 4].copy_from_slice(&value.to_le_bytes());
        let end = bad.len() - 8;
        let sum = fnv(&bad[8..end]);
        bad[end..].copy_from_slice(&sum.to_le_bytes());
        assert!(read_maps(&bad, FINGERPRINT).is_ok());
        assert!(
            matches!(read_maps_within(&bad, FINGERPRINT, &scene), Err(Error::Corrupt(m))
                if m.contains("global photon 0") && m.contains(expect)),
            "{value} at {at}"
        );
    }
}

/// A file of an earlier release holding precomputed irradiance points (flag 4, their count in the
/// header's eleventh word, 13 f32 each after the photons) loads with the same maps, its points skipped.
#[test]
fn a_file_with_an_earlier_releases_irradiance_points_is_read() {
    let (now, info) = encoded();
    let mut old = now[..now.len() - 8].to_vec();
    let flags = u32::from_le_bytes(old[12..16].try_into().unwrap()) | 4;
    old[12..16].copy_from_slice(&flags.to_le_bytes());
    old[96..104].copy_from_slice(&2u64.to_le_bytes());
    old[104..108].copy_from_slice(&0.5f32.to_le_bytes());
    for x in (0..26).map(|i| i as f32 * 0.25) {
        old.extend_from_slice(&x.to_le_bytes());
    }
    let sum = fnv(&old[8..]);
    old.extend_from_slice(&sum.to_le_bytes());
    let (a, b) = (
        read_maps(&old, FINGERPRINT).unwrap(),
        read_maps(&now, FINGERPRINT).unwrap(),
    );
    assert_eq!(a.info, info);
    assert_eq!(
        a.maps.global.unwrap().photons(),
        b.maps.global.unwrap().photons()
    );
    // Its length must still match its counts.
    let short = [&old[..old.len() - 12], &old[old.len() - 8..]].concat();
    assert!(matches!(
        read_maps(&short, FINGERPRINT),
        Err(Error::BadLength { .. })
    ));
}
