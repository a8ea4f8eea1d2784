//! Bounded fuzzing of everything that reads user files: the scene TOML, OBJ/MTL, and photon-map and
//! cache files. Inputs are valid files mutated by deterministic random edits (byte flips, insertions,
//! deletions, truncation, splices of interesting tokens) or by hostile numbers put in place of valid ones
//! (out of range, overflow-sized, NaN — in binary files behind a recomputed checksum). The readers must
//! return Ok or an error — never panic, hang or allocate without bound — and what they accept must be in
//! range. `make fuzz` runs many more iterations (FUZZ_ITERS).

mod common;
use common::*;
use photon::sampling::Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};

fn iters(default: usize) -> usize {
    std::env::var("FUZZ_ITERS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e39",
    "-1",
    "0",
    "[",
    "]",
    "=",
    "\"",
    "\n",
    "[[mesh]]",
    "[render]",
    "[camera]",
    "fov",
    "width",
    "f 1 2 99999",
    "v 1e30 0 0",
    "usemtl",
    "mtllib",
    "Ke",
    "illum 7",
    "Ni 0",
    "Ns -5",
    "#",
    "\u{feff}",
    "0x10",
    "9999999999999",
];

fn mutate(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for _ in 0..1 + (rng.next_u32() % 4) {
        let pos = if b.is_empty() {
            0
        } else {
            rng.next_u32() as usize % b.len()
        };
        match rng.next_u32() % 6 {
            0 if !b.is_empty() => b[pos] ^= 1 << (rng.next_u32() % 8),
            1 => b.insert(pos, rng.next_u32() as u8),
            2 if !b.is_empty() => {
                b.remove(pos);
            }
            3 => b.truncate(pos),
            4 => {
                let t = TOKENS[rng.next_u32() as usize % TOKENS.len()];
                b.splice(pos..pos, t.bytes());
            }
            _ => {
                let end = (pos + 1 + rng.next_u32() as usize % 16).min(b.len());
                b.drain(pos..end);
            }
        }
    }
    b
}

#[test]
fn scene_obj_and_mtl_readers_never_panic() {
    let d = room();
    let files = [
        ("scene.toml", ROOM_TOML),
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
    ];
    let mut rng = Rng::new(2024);
    let n = iters(600);
    for i in 0..n {
        let (name, original) = files[i % 3];
        let mutated = mutate(original.as_bytes(), &mut rng);
        for (f, text) in files {
            std::fs::write(
                d.path().join(f),
                if f == name {
                    &mutated[..]
                } else {
                    text.as_bytes()
                },
            )
            .unwrap();
        }
        let path = d.path().join("scene.toml");
        let result = catch_unwind(AssertUnwindSafe(|| {
            pmrender::scene::load(&path).map(|_| ())
        }));
        match result {
            Ok(Ok(())) => {}
            Ok(Err(e)) => assert!(
                e.is_input() || matches!(e, pmrender::error::Error::Runtime(_)),
                "{e}"
            ),
            Err(_) => panic!(
                "panic on mutated {name} (iteration {i}):\n{}",
                String::from_utf8_lossy(&mutated)
            ),
        }
    }
}

/// A photon-map file and a cache file of `scene`, with the scene's fingerprint.
fn saved_files(scene: &std::path::Path) -> (Vec<u8>, Vec<u8>, u64) {
    let d = tempfile::tempdir().unwrap();
    let (ph, ic) = (d.path().join("m.phot"), d.path().join("c.ic"));
    let r = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        d.path().join("o.exr").to_str().unwrap(),
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "1",
        "--quiet",
        "--save-photons",
        ph.to_str().unwrap(),
        "--save-cache",
        ic.to_str().unwrap(),
    ]);
    assert!(r.status.success());
    let fp = pmrender::scene::load(scene).unwrap().fingerprint;
    (std::fs::read(&ph).unwrap(), std::fs::read(&ic).unwrap(), fp)
}

#[test]
fn photon_and_cache_file_readers_never_panic() {
    let (ph_bytes, ic_bytes, fp) = saved_files(&repo().join("scenes/cornell-caustics.toml"));
    let mut rng = Rng::new(7);
    for i in 0..iters(300) {
        let m = mutate(&ph_bytes, &mut rng);
        let ok = catch_unwind(AssertUnwindSafe(|| photon::file::read_maps(&m, fp).is_ok()));
        assert!(ok.is_ok(), "photon reader panicked (iteration {i})");
        let m = mutate(&ic_bytes, &mut rng);
        let ok = catch_unwind(AssertUnwindSafe(|| {
            icache::IrradianceCache::from_bytes(&m, fp).is_ok()
        }));
        assert!(ok.is_ok(), "cache reader panicked (iteration {i})");
    }
}

/// Numbers a hostile user tries: out of range, overflow-sized, not finite, denormal.
const HOSTILE_NUMBERS: &[&str] = &[
    "nan", "inf", "-inf", "3e38", "-3e38", "1e19", "-1e20", "1e30", "-1", "5", "0", "1e-45", "-0",
    "2000000",
];

/// Replaces one number of `text` (chosen by `rng`) by a hostile one.
fn replace_a_number(text: &str, rng: &mut Rng) -> String {
    let is_num = |c: char| c.is_ascii_digit() || c == '.' || c == '-' || c == 'e';
    let starts: Vec<usize> = text
        .char_indices()
        .filter(|&(i, c)| {
            c.is_ascii_digit() && (i == 0 || !is_num(text[..i].chars().last().unwrap_or(' ')))
        })
        .map(|(i, _)| i)
        .collect();
    if starts.is_empty() {
        return text.to_string();
    }
    let at = starts[rng.next_u32() as usize % starts.len()];
    let end = text[at..]
        .find(|c: char| !is_num(c))
        .map_or(text.len(), |k| at + k);
    let with = HOSTILE_NUMBERS[rng.next_u32() as usize % HOSTILE_NUMBERS.len()];
    format!("{}{}{}", &text[..at], with, &text[end..])
}

#[test]
fn out_of_range_values_are_refused_or_kept_in_range() {
    let d = room();
    let toml = format!("{ROOM_TOML}\n[[light]]\ntype = \"spot\"\nposition = [0.0, 1.5, 0.0]\ntarget = [0.0, 0.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n\n[[light]]\ntype = \"directional\"\ndirection = [0.0, -1.0, -1.0]\nirradiance = [1.0, 1.0, 1.0]\n\n[materials.wall]\ntype = \"glossy\"\nalbedo = [0.5, 0.5, 0.5]\nspecular = [0.2, 0.2, 0.2]\nexponent = 20.0\n");
    let mtl = format!("{ROOM_MTL}newmtl glass\nillum 7\nNi 1.5\nTf 0.9 0.9 0.9\nnewmtl mirror\nillum 3\nKs 0.9 0.9 0.9\n");
    let obj = ROOM_OBJ.replace("usemtl light", "usemtl light\nvn 0 -1 0\nvt 0.5 0.5");
    let files = [
        ("scene.toml", toml.as_str()),
        ("room.obj", obj.as_str()),
        ("room.mtl", mtl.as_str()),
    ];
    let mut rng = Rng::new(12);
    for i in 0..iters(400) {
        let (name, original) = files[i % 3];
        let mut mutated = original.to_string();
        for _ in 0..1 + rng.next_u32() % 3 {
            mutated = replace_a_number(&mutated, &mut rng);
        }
        for (f, text) in files {
            std::fs::write(d.path().join(f), if f == name { &mutated } else { text }).unwrap();
        }
        let path = d.path().join("scene.toml");
        let loaded = catch_unwind(AssertUnwindSafe(|| pmrender::scene::load(&path)))
            .unwrap_or_else(|_| panic!("panic on {name} (iteration {i}):\n{mutated}"));
        let Ok(scene) = loaded else { continue };
        // Accepted: every value must be in its documented range.
        let limit = pmrender::scene::limits::MAX_COORD;
        assert!(
            scene
                .geometry
                .positions
                .iter()
                .all(|p| p.is_finite() && p.abs().max_element() <= limit),
            "{name}:\n{mutated}"
        );
        let power = scene.lights.total_power();
        assert!(
            power.is_finite() && power.min_element() >= 0.0,
            "power {power} from {name}:\n{mutated}"
        );
        assert!(
            scene.camera.forward().is_finite() && scene.camera.up_vector().is_finite(),
            "{name}:\n{mutated}"
        );
        for m in &scene.materials {
            assert!(
                m.emission.is_finite() && m.emission.min_element() >= 0.0,
                "{name}:\n{mutated}"
            );
        }
    }
}

/// Writes `value` at the 4-byte offset `at` and recomputes the checksum over `bytes[hash_from..len-8]`.
fn with_float(bytes: &[u8], at: usize, value: f32, hash_from: usize) -> Vec<u8> {
    let mut b = bytes.to_vec();
    b[at..at + 4].copy_from_slice(&value.to_le_bytes());
    let end = b.len() - 8;
    let sum = icache::file::fnv1a64(&b[hash_from..end]);
    b[end..].copy_from_slice(&sum.to_le_bytes());
    b
}

#[test]
fn nan_in_binary_files_with_a_valid_checksum_is_refused() {
    // A small photon map keeps each accepted file's kd-tree rebuild cheap.
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        (
            "scene.toml",
            &format!("{ROOM_TOML}\n[render.photons]\nglobal = 2000\n"),
        ),
    ]);
    let (ph, ic, fp) = saved_files(&d.path().join("scene.toml"));
    // Photon files: every f32 after the 112-byte header is a photon or irradiance-point value.
    // Cache files: every f32 after the header (icache::file::HEADER_BYTES) and the stages (u32 each, their
    // count at byte 68) is a record value.
    let rec0 = icache::file::HEADER_BYTES
        + 4 * u32::from_le_bytes(ic[68..72].try_into().unwrap()) as usize;
    let mut rng = Rng::new(99);
    for i in 0..iters(300) {
        let bad = [f32::NAN, -f32::NAN, f32::from_bits(0x7fc0_1234)][i % 3];
        let at = 112 + 4 * (rng.next_u32() as usize % ((ph.len() - 120) / 4));
        let m = with_float(&ph, at, bad, 8);
        let r = catch_unwind(AssertUnwindSafe(|| {
            photon::file::read_maps(&m, fp).is_err()
        }));
        assert_eq!(
            r.ok(),
            Some(true),
            "NaN at photon-file byte {at} accepted (or panicked)"
        );
        let at = rec0 + 4 * (rng.next_u32() as usize % ((ic.len() - rec0 - 8) / 4));
        let m = with_float(&ic, at, bad, 0);
        let r = catch_unwind(AssertUnwindSafe(|| {
            icache::IrradianceCache::from_bytes(&m, fp).is_err()
        }));
        assert_eq!(
            r.ok(),
            Some(true),
            "NaN at cache-file byte {at} accepted (or panicked)"
        );
        // Other hostile values must never panic (some, like 0 in a gradient, are legal).
        let value = [3e38, -1.0, f32::INFINITY, 1e-45][rng.next_u32() as usize % 4];
        let m = with_float(
            &ph,
            112 + 4 * (rng.next_u32() as usize % ((ph.len() - 120) / 4)),
            value,
            8,
        );
        assert!(catch_unwind(AssertUnwindSafe(|| photon::file::read_maps(&m, fp).is_ok())).is_ok());
    }
}

/// Photon powers far beyond what the scene's lights give (1e30 W, 3e38 W), put in random photons behind
/// a recomputed checksum, are refused against the scene's bounds; the file as saved is accepted.
#[test]
fn photon_powers_beyond_the_scene_are_refused() {
    let d = scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", ROOM_MTL),
        (
            "scene.toml",
            &format!("{ROOM_TOML}\n[render.photons]\nglobal = 2000\n"),
        ),
    ]);
    let scene_path = d.path().join("scene.toml");
    let (ph, _, fp) = saved_files(&scene_path);
    let scene = pmrender::scene::load(&scene_path).unwrap();
    let bounds = pmrender::render::files::plausible(&scene);
    assert!(photon::file::read_maps_within(&ph, fp, &bounds).is_ok());
    // Version 5: a 160-byte header, the global photon count at byte 80, then 13 f32 per photon with
    // the power 24 bytes in.
    let n_global = u64::from_le_bytes(ph[80..88].try_into().unwrap()) as usize;
    let mut rng = Rng::new(5);
    for _ in 0..iters(200) {
        let photon = rng.next_u32() as usize % n_global;
        let channel = rng.next_u32() as usize % 3;
        let at = 160 + 52 * photon + 24 + 4 * channel;
        let value = [1e30, 3e38, 1e25][rng.next_u32() as usize % 3];
        let m = with_float(&ph, at, value, 8);
        let refused = catch_unwind(AssertUnwindSafe(|| {
            photon::file::read_maps_within(&m, fp, &bounds).is_err()
        }));
        assert_eq!(
            refused.ok(),
            Some(true),
            "power {value} in photon {photon} accepted (or panicked)"
        );
    }
}
