//! Bounded fuzzing of everything that reads user files: the scene TOML, OBJ/MTL, and photon-map and
//! cache files. Inputs are valid files mutated by deterministic random edits (byte flips, insertions,
//! deletions, truncation, splices of interesting tokens). The readers must return Ok or an error — never
//! panic, hang or allocate without bound. `make fuzz` runs many more iterations (FUZZ_ITERS).

mod common;
use common::*;
use photon::sampling::Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};

fn iters(default: usize) -> usize {
    std::env::var("FUZZ_ITERS").ok().and_then(|s| s.parse().ok()).unwrap_or(default)
}

const TOKENS: &[&str] = &[
    "nan", "inf", "-inf", "1e39", "-1", "0", "[", "]", "=", "\"", "\n", "[[mesh]]", "[render]", "[camera]", "fov", "width",
    "f 1 2 99999", "v 1e30 0 0", "usemtl", "mtllib", "Ke", "illum 7", "Ni 0", "Ns -5", "#", "\u{feff}", "0x10", "9999999999999",
];

fn mutate(bytes: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for _ in 0..1 + (rng.next_u32() % 4) {
        let pos = if b.is_empty() { 0 } else { rng.next_u32() as usize % b.len() };
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
    let files = [("scene.toml", ROOM_TOML), ("room.obj", ROOM_OBJ), ("room.mtl", ROOM_MTL)];
    let mut rng = Rng::new(2024);
    let n = iters(600);
    for i in 0..n {
        let (name, original) = files[i % 3];
        let mutated = mutate(original.as_bytes(), &mut rng);
        for (f, text) in files {
            std::fs::write(d.path().join(f), if f == name { &mutated[..] } else { text.as_bytes() }).unwrap();
        }
        let path = d.path().join("scene.toml");
        let result = catch_unwind(AssertUnwindSafe(|| pmrender::scene::load(&path).map(|_| ())));
        match result {
            Ok(Ok(())) => {}
            Ok(Err(e)) => assert!(e.is_input() || matches!(e, pmrender::error::Error::Runtime(_)), "{e}"),
            Err(_) => panic!("panic on mutated {name} (iteration {i}):\n{}", String::from_utf8_lossy(&mutated)),
        }
    }
}

#[test]
fn photon_and_cache_file_readers_never_panic() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-caustics.toml");
    let (ph, ic) = (d.path().join("m.phot"), d.path().join("c.ic"));
    let r = run(&[
        "render", scene.to_str().unwrap(), "-o", d.path().join("o.exr").to_str().unwrap(), "--width", "24", "--height", "24",
        "--spp", "1", "--quiet", "--save-photons", ph.to_str().unwrap(), "--save-cache", ic.to_str().unwrap(),
    ]);
    assert!(r.status.success());
    let fp = pmrender::scene::load(&scene).unwrap().fingerprint;
    let (ph_bytes, ic_bytes) = (std::fs::read(&ph).unwrap(), std::fs::read(&ic).unwrap());
    let mut rng = Rng::new(7);
    for i in 0..iters(300) {
        let m = mutate(&ph_bytes, &mut rng);
        let ok = catch_unwind(AssertUnwindSafe(|| photon::file::read_maps(&m, fp).is_ok()));
        assert!(ok.is_ok(), "photon reader panicked (iteration {i})");
        let m = mutate(&ic_bytes, &mut rng);
        let ok = catch_unwind(AssertUnwindSafe(|| icache::IrradianceCache::from_bytes(&m, fp).is_ok()));
        assert!(ok.is_ok(), "cache reader panicked (iteration {i})");
    }
}
