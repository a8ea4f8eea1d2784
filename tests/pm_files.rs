//! Photon-map and cache files: save → load → identical render; a crop rendered with a loaded cache
//! equals the same pixels of the full render; damaged or mismatched files are clear errors (exit 2).

mod common;
use common::*;
use std::path::Path;

fn render(dir: &Path, name: &str, extra: &[&str]) -> std::process::Output {
    let scene = repo().join("scenes/cornell-caustics.toml");
    let out = dir.join(name);
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "64",
        "--spp",
        "2",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    run(&args)
}

#[test]
fn saved_maps_and_cache_reproduce_the_render() {
    let d = tempfile::tempdir().unwrap();
    let ph = p(d.path(), "maps.phot");
    let cache = p(d.path(), "cache.ic");
    let r = render(
        d.path(),
        "full.exr",
        &["--save-photons", &ph, "--save-cache", &cache],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = render(
        d.path(),
        "again.exr",
        &["--load-photons", &ph, "--load-cache", &cache],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let full = std::fs::read(d.path().join("full.exr")).unwrap();
    assert_eq!(full, std::fs::read(d.path().join("again.exr")).unwrap());
    // Photons alone: the cache is filled again, every atlas texel estimated from the loaded photons, so
    // each photon's kind (direct, caustic, indirect) must survive the file.
    let r = render(d.path(), "photons_only.exr", &["--load-photons", &ph]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(
        full,
        std::fs::read(d.path().join("photons_only.exr")).unwrap()
    );

    let r = render(
        d.path(),
        "crop.exr",
        &[
            "--load-photons",
            &ph,
            "--load-cache",
            &cache,
            "--crop",
            "10",
            "20",
            "40",
            "50",
        ],
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (a, b) = (
        read(&d.path().join("full.exr")),
        read(&d.path().join("crop.exr")),
    );
    for y in 20..50 {
        for x in 10..40 {
            let i = (y * 64 + x) as usize;
            assert_eq!(a.pixels[i], b.pixels[i], "pixel ({x}, {y})");
        }
    }
}

#[test]
fn damaged_and_mismatched_files_are_input_errors() {
    let d = tempfile::tempdir().unwrap();
    let ph = p(d.path(), "maps.phot");
    let cache = p(d.path(), "cache.ic");
    assert!(render(
        d.path(),
        "full.exr",
        &["--save-photons", &ph, "--save-cache", &cache]
    )
    .status
    .success());
    let bytes = std::fs::read(&ph).unwrap();
    let truncated = p(d.path(), "trunc.phot");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let mut flipped = bytes.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x40;
    let flipped_path = p(d.path(), "flip.phot");
    std::fs::write(&flipped_path, &flipped).unwrap();
    let cbytes = std::fs::read(&cache).unwrap();
    let ctrunc = p(d.path(), "trunc.ic");
    std::fs::write(&ctrunc, &cbytes[..cbytes.len() - 7]).unwrap();
    // Another scene: the furnace-free room.
    let room = room();
    let room_out = p(room.path(), "o.exr");
    let cases: Vec<Vec<&str>> = vec![
        vec!["--load-photons", &truncated],
        vec!["--load-photons", &flipped_path],
        vec!["--load-photons", &cache],
        vec!["--load-cache", &ctrunc],
        vec!["--load-cache", &ph],
    ];
    for extra in cases {
        let r = render(d.path(), "bad.exr", &extra);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{extra:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains(extra[0]), "{stderr}");
        assert!(!d.path().join("bad.exr").exists());
    }
    // Maps of one scene loaded into another.
    let r = run(&[
        "render",
        &p(room.path(), "scene.toml"),
        "-o",
        &room_out,
        "--load-photons",
        &ph,
        "--quiet",
    ]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--load-photons"), "{stderr}");
    assert!(!Path::new(&room_out).exists());
}

/// A cache whose pass B made records (the blinds room's sub-pixel slats) replays them: loaded, each
/// round reads the records it read when the cache was made, so the render is the same again, and a crop
/// (at fixed spp: adaptive sampling's edge pixels look at neighbours outside the window) equals the same
/// pixels of the full render.
#[test]
fn a_cache_with_pass_b_records_reproduces_the_render() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/blinds-room.toml");
    let (ph, cache) = (p(d.path(), "maps.phot"), p(d.path(), "cache.ic"));
    let render = |name: &str, extra: &[&str]| {
        let (out, stats) = (
            d.path().join(format!("{name}.exr")),
            d.path().join(format!("{name}.json")),
        );
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--quiet",
        ];
        args.extend_from_slice(extra);
        let r = run(&args);
        assert!(
            r.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
        (
            std::fs::read(&out).unwrap(),
            j["icache"]["records_pass_b"].as_u64().unwrap(),
        )
    };
    for spp in [&["--spp", "8", "--noise", "0"][..], &["--spp", "16"][..]] {
        let (full, records) = render(
            "full",
            &[spp, &["--save-photons", &ph, "--save-cache", &cache]].concat(),
        );
        assert!(records > 0, "the test needs pass-B records");
        let (again, _) = render(
            "again",
            &[spp, &["--load-photons", &ph, "--load-cache", &cache]].concat(),
        );
        assert!(
            full == again,
            "{spp:?}: the render with the loaded cache differs"
        );
    }
    let fixed = [
        "--spp",
        "8",
        "--noise",
        "0",
        "--load-photons",
        &ph,
        "--load-cache",
        &cache,
    ];
    render(
        "full",
        &[
            "--spp",
            "8",
            "--noise",
            "0",
            "--save-photons",
            &ph,
            "--save-cache",
            &cache,
        ],
    );
    render(
        "crop",
        &[&fixed[..], &["--crop", "10", "12", "50", "40"]].concat(),
    );
    let (a, b) = (
        read(&d.path().join("full.exr")),
        read(&d.path().join("crop.exr")),
    );
    for y in 12..40 {
        for x in 10..50 {
            let i = (y * 64 + x) as usize;
            assert_eq!(a.pixels[i], b.pixels[i], "pixel ({x}, {y})");
        }
    }
}

/// A cache saved with one texture does not load once the texture has changed: the scene's fingerprint
/// holds the texels (it held only geometry, materials and lights, and such a cache loaded with its
/// indirect light 65 % off).
#[test]
fn a_cache_does_not_load_after_its_texture_changed() {
    let d = room();
    let dir = d.path();
    let texture = |v: u8| {
        let mut ppm = b"P6\n2 2\n255\n".to_vec();
        ppm.extend(std::iter::repeat_n(v, 12));
        std::fs::write(dir.join("wall.ppm"), ppm).unwrap();
    };
    texture(200);
    let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd wall.ppm");
    std::fs::write(dir.join("room.mtl"), mtl).unwrap();
    let (scene, cache) = (p(dir, "scene.toml"), p(dir, "cache.ic"));
    let render = |out: &str, extra: &[&str]| {
        let o = p(dir, out);
        let mut args = vec!["render", &scene, "-o", &o, "--quiet"];
        args.extend_from_slice(extra);
        run(&args)
    };
    let r = render("a.exr", &["--save-cache", &cache]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let r = render("b.exr", &["--load-cache", &cache]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    texture(40);
    let r = render("c.exr", &["--load-cache", &cache]);
    assert_eq!(
        r.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    assert!(!dir.join("c.exr").exists());
}
