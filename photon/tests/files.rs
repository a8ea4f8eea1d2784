//! Photon-map files: round trip, and clear errors for damaged, truncated or foreign files.

mod common;

use common::*;
use photon::file::{load, read_maps, save, write_maps};
use photon::{trace_photons, Error, MapsInfo, PhotonTargets, PrecomputedIrradiance};

const FINGERPRINT: u64 = 0xFEED_F00D_1234_5678;

fn encoded() -> (Vec<u8>, MapsInfo) {
    let scene = mirror_wall();
    let targets = PhotonTargets { global: 3_000, caustic: 500, volume: 0, volume_caustic: 0, max_paths: 1_000_000 };
    let (maps, stats) = trace_photons(&scene, &targets, 5, &|_, _| {}).unwrap();
    let (pre, _) = PrecomputedIrradiance::build(maps.global.as_ref().unwrap(), 4, 50, 0.5, &photon::FullDisc).unwrap();
    let info = MapsInfo::new(FINGERPRINT, 5, targets, &stats);
    let mut bytes = Vec::new();
    write_maps(&mut bytes, &info, &maps, Some(&pre)).unwrap();
    // The decoded maps must equal what was written.
    let loaded = read_maps(&bytes, FINGERPRINT).unwrap();
    assert_eq!(loaded.info, info);
    assert_eq!(loaded.maps.global.unwrap().photons(), maps.global.unwrap().photons());
    assert_eq!(loaded.maps.caustic.unwrap().photons(), maps.caustic.unwrap().photons());
    assert_eq!(loaded.precomputed.unwrap().points(), pre.points());
    (bytes, info)
}

#[test]
fn round_trip_through_a_file() {
    let (bytes, info) = encoded();
    let loaded = read_maps(&bytes, FINGERPRINT).unwrap();
    let path = std::env::temp_dir().join(format!("photon-files-test-{}.pmap", std::process::id()));
    save(&path, &info, &loaded.maps, loaded.precomputed.as_ref()).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
    let again = load(&path, FINGERPRINT).unwrap();
    assert_eq!(again.info, info);
    // A truncated file on disk is refused before its payload is read.
    std::fs::write(&path, &bytes[..bytes.len() - 100]).unwrap();
    assert!(matches!(load(&path, FINGERPRINT), Err(Error::BadLength { .. })));
    std::fs::write(&path, &bytes[..50]).unwrap();
    assert!(matches!(load(&path, FINGERPRINT), Err(Error::BadLength { .. })));
    std::fs::remove_file(&path).unwrap();
    assert!(matches!(load(&path, FINGERPRINT), Err(Error::Io { .. })));
}

#[test]
fn damaged_files_give_clear_errors() {
    let (bytes, _) = encoded();
    assert!(matches!(read_maps(&bytes, FINGERPRINT ^ 1), Err(Error::SceneMismatch { .. })));
    for cut in [0, 7, 8, 60, 111, 112, bytes.len() - 1] {
        let r = read_maps(&bytes[..cut], FINGERPRINT);
        assert!(matches!(r, Err(Error::BadMagic | Error::BadLength { .. })), "cut {cut}");
    }
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(read_maps(&longer, FINGERPRINT), Err(Error::BadLength { .. })));
    let mut flipped = bytes.clone();
    flipped[bytes.len() / 2] ^= 0x10;
    assert!(matches!(read_maps(&flipped, FINGERPRINT), Err(Error::Checksum)));
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert!(matches!(read_maps(&magic, FINGERPRINT), Err(Error::BadMagic)));
    let mut version = bytes.clone();
    version[8] = 99;
    assert!(matches!(read_maps(&version, FINGERPRINT), Err(Error::UnsupportedVersion { found: 99, .. })));
    // Absurd photon counts are caught from the length, without allocating for them.
    let mut huge = bytes.clone();
    huge[80..88].copy_from_slice(&(1u64 << 40).to_le_bytes());
    assert!(matches!(read_maps(&huge, FINGERPRINT), Err(Error::BadLength { .. })));
    huge[80..88].copy_from_slice(&u64::MAX.to_le_bytes());
    assert!(matches!(read_maps(&huge, FINGERPRINT), Err(Error::Corrupt(_))));
}
