//! Memory limits the process did not choose: under an address-space limit (`ulimit -v`, as containers
//! and batch systems set it) a render, a texture, a photon file or a cache file too large for what is
//! left is refused with one line naming it (exit 2, nothing written) instead of aborting on a failed
//! allocation; and what the process already holds counts against the memory budget.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The limit every case runs under: 3 GB of address space.
const LIMIT_KB: u64 = 3_000_000;

/// Runs the binary under an address-space limit of `kb` KiB, with no budget from the environment.
fn run_limited(kb: u64, args: &[&str]) -> Output {
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    let cmd = format!(
        "ulimit -v {kb}; exec '{}' {}",
        bin().display(),
        quoted.join(" ")
    );
    Command::new("sh")
        .args(["-c", &cmd])
        .env_remove("PMRENDER_MAX_MEMORY")
        .output()
        .expect("sh runs")
}

/// Status 2 and one line on stderr containing every `expect`.
fn assert_refused(r: &Output, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "stderr: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "'{e}' not in: {stderr}");
    }
}

/// The room scene with an empty `out/` directory.
fn room_with_out() -> (tempfile::TempDir, PathBuf) {
    let d = room();
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    (d, out)
}

#[test]
fn a_render_larger_than_the_address_space_left_is_refused() {
    let (_d, out) = room_with_out();
    let scene = repo().join("scenes/cornell-caustics.toml");
    let o = p(&out, "o.exr");
    let t = Instant::now();
    let r = run_limited(
        LIMIT_KB,
        &[
            "render",
            scene.to_str().unwrap(),
            "-o",
            &o,
            "--width",
            "4096",
            "--height",
            "4096",
            "--method",
            "photons",
            "--spp",
            "1",
            "--quiet",
        ],
    );
    assert!(t.elapsed() < Duration::from_secs(10), "refused at once");
    // The scene named, and what to change.
    assert_refused(
        &r,
        &[
            "cornell-caustics.toml: memory",
            "image 4096×4096",
            "ulimit -v",
            "--width, --height",
        ],
    );
    assert!(listing(&out).is_empty());
}

/// Saves photon maps and a cache of the room, then rewrites `count_at` (a u64 in the header) of the
/// file to `count` and extends the file, sparsely, to the length the count implies: a valid header, a
/// wrong checksum, gigabytes of zeros.
fn inflated(file: &Path, count_at: u64, count: u64, item_bytes: u64) {
    use std::io::{Seek, SeekFrom, Write};
    let bytes = std::fs::read(file).unwrap();
    let at = count_at as usize;
    let old = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap());
    let mut f = std::fs::OpenOptions::new().write(true).open(file).unwrap();
    f.seek(SeekFrom::Start(count_at)).unwrap();
    f.write_all(&count.to_le_bytes()).unwrap();
    f.set_len(bytes.len() as u64 + (count - old) * item_bytes)
        .unwrap();
}

#[test]
fn photon_and_cache_files_claiming_more_than_the_address_space_are_refused() {
    let (d, out) = room_with_out();
    let dir = d.path();
    let (scene, photons, cache) = (
        p(dir, "scene.toml"),
        p(dir, "maps.phot"),
        p(dir, "cache.ic"),
    );
    let r = run(&[
        "render",
        &scene,
        "-o",
        &p(dir, "first.exr"),
        "--save-photons",
        &photons,
        "--save-cache",
        &cache,
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    // 1e8 global photons (52 B each): 5.2 GB; 2e7 cache records (132 B each): 2.6 GB.
    inflated(Path::new(&photons), 80, 100_000_000, 52);
    inflated(Path::new(&cache), 72, 20_000_000, 132);
    let o = p(&out, "o.exr");
    for (option, file) in [("--load-photons", &photons), ("--load-cache", &cache)] {
        let t = Instant::now();
        let r = run_limited(
            LIMIT_KB,
            &["render", &scene, "-o", &o, option, file, "--quiet"],
        );
        assert!(t.elapsed() < Duration::from_secs(20), "{option}: bounded");
        assert_refused(&r, &[option, file, "ulimit -v"]);
        assert!(listing(&out).is_empty());
    }
}

/// A 16-bit binary PPM of `w`×`h` black pixels, written sparsely.
fn black_ppm(path: &Path, w: u32, h: u32) {
    let header = format!("P6\n{w} {h}\n65535\n");
    std::fs::write(path, &header).unwrap();
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    f.set_len(header.len() as u64 + w as u64 * h as u64 * 6)
        .unwrap();
}

/// A flat Radiance HDR of `w`×`h` black pixels, written sparsely.
fn black_hdr(path: &Path, w: u32, h: u32) {
    let header = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n");
    std::fs::write(path, &header).unwrap();
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    f.set_len(header.len() as u64 + w as u64 * h as u64 * 4)
        .unwrap();
}

#[test]
fn what_textures_hold_counts_against_the_budget() {
    let (d, out) = room_with_out();
    let dir = d.path();
    black_ppm(&dir.join("big.ppm"), 4096, 4096);
    let (scene, o) = (p(dir, "scene.toml"), p(&out, "o.exr"));
    let args = [
        "render",
        &scene,
        "-o",
        &o,
        "--method",
        "path",
        "--max-memory",
        "260M",
        "--quiet",
    ];
    // Without the texture the render fits in 260 MiB; its 4096² texels (192 MiB) do not.
    let r = run(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    std::fs::remove_file(&o).unwrap();
    let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd big.ppm");
    std::fs::write(dir.join("room.mtl"), mtl).unwrap();
    let r = run(&args);
    assert_refused(
        &r,
        &[
            "scene.toml: memory",
            "already held",
            "budget of 260 MiB",
            "raise --max-memory",
        ],
    );
    assert!(listing(&out).is_empty());
}

#[test]
fn a_texture_larger_than_the_address_space_left_is_refused_before_decoding() {
    // An 8192² RGBA PNG (the largest texture) decodes through 2 GiB of floats: more than is left under
    // 2.4 GB. Only its header is real; the refusal must come from the size, before the pixels.
    let (d, out) = room_with_out();
    let dir = d.path();
    let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd big.png");
    std::fs::write(dir.join("room.mtl"), mtl).unwrap();
    std::fs::write(dir.join("big.png"), png_header(8192, 8192)).unwrap();
    let r = run_limited(
        2_400_000,
        &[
            "render",
            &p(dir, "scene.toml"),
            "-o",
            &p(&out, "o.exr"),
            "--quiet",
        ],
    );
    assert_refused(&r, &["big.png", "8192×8192", "ulimit -v"]);
    assert!(listing(&out).is_empty());
}

/// The header of an RGBA PNG of `w`×`h` with an empty image stream.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    fn crc(bytes: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut v = (data.len() as u32).to_be_bytes().to_vec();
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        v.extend(&body);
        v.extend(crc(&body).to_be_bytes());
        v
    };
    let mut ihdr = w.to_be_bytes().to_vec();
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    png.extend(chunk(b"IEND", &[]));
    png
}

#[test]
fn converge_against_a_reference_too_large_to_render_is_refused() {
    // A 4096² reference sets a 4096² render: more than the address space left.
    let (d, out) = room_with_out();
    black_hdr(&d.path().join("ref.hdr"), 4096, 4096);
    let t = Instant::now();
    let r = run_limited(
        LIMIT_KB,
        &[
            "converge",
            &p(d.path(), "scene.toml"),
            "--photons",
            "1000,2000",
            "--reference",
            &p(d.path(), "ref.hdr"),
            "-o",
            out.to_str().unwrap(),
            "--quiet",
        ],
    );
    assert!(t.elapsed() < Duration::from_secs(30), "refused at once");
    // The scene named, and what to change.
    assert_refused(
        &r,
        &[
            "scene.toml: memory",
            "image 4096×4096",
            "ulimit -v",
            "--width, --height",
        ],
    );
    assert!(listing(&out).is_empty());
}
