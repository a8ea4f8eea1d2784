//! Public assets as exported: files other readers load render here too, with a warning where they lack
//! something.

mod common;

use std::time::Duration;

use common::*;
use pmrender::io::output::Image;

/// McGuire's CornellBox-Glossy.obj says `usemtl light` (line 3009) and its MTL defines no `light`: it
/// loads as it is, the default material standing in, with exactly one warning naming that line.
/// A point light under the ceiling lights it (the light quad, grey, does not emit).
#[test]
fn the_glossy_cornell_box_loads_as_exported_with_one_warning() {
    let obj = repo().join("../shared/scenes/cornell-box/CornellBox-Glossy.obj");
    let d = scene_dir(&[(
        "scene.toml",
        &format!(
            "version = 1\n[camera]\neye = [0.0, 1.0, 3.9]\ntarget = [0.0, 1.0, 0.0]\nfov = 39.0\n\
             width = 32\nheight = 32\n[[mesh]]\nobj = {:?}\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 1.4, 0.0]\nintensity = [2.0, 2.0, 2.0]\n[render]\nspp = 4\n",
            obj.to_str().unwrap()
        ),
    )]);
    let (out, stats) = (p(d.path(), "o.exr"), p(d.path(), "o.json"));
    let r = run_bounded(
        &[
            "render",
            &p(d.path(), "scene.toml"),
            "-o",
            &out,
            "--stats",
            &stats,
            "--method",
            "pm",
            "--quiet",
        ],
        Duration::from_secs(300),
    );
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for e in ["CornellBox-Glossy.obj:3009:", "usemtl 'light'"] {
        assert!(warnings[0].contains(e), "'{e}' not in: {stderr}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["scene"]["warnings"], 1, "{json}");
    let m = mean(&read(std::path::Path::new(&out)));
    assert!(m.is_finite() && m.min_element() > 0.0, "{m}");
}

/// The card of the cutout scenes: 1.5 × 1.5 at height 1 over x, z ∈ [−0.75, 0.75], u along +x and v
/// along −z; its 4 × 4 checker keeps the cells (i, j) (column i, row j from the top of the mask) with
/// i + j even.
const CHECKER: u32 = 4;

fn card_point(u: f32, v: f32) -> (f32, f32) {
    (-0.75 + 1.5 * u, 0.75 - 1.5 * v)
}

/// The floor, a back wall, and the card as one quad with `usemtl card`.
fn cutout_obj(card: &str) -> String {
    format!(
        "mtllib m.mtl\nusemtl room\n\
         v -2 0 2\nv 2 0 2\nv 2 0 -2\nv -2 0 -2\nv -2 3 -2\nv 2 3 -2\n\
         f 1 2 3 4\nf 4 3 6 5\nusemtl card\n{card}"
    )
}

/// The card as one quad cut by a `map_d` mask.
fn masked_card() -> String {
    let mut s = String::new();
    for (u, v) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
        let (x, z) = card_point(u, v);
        s += &format!("v {x} 1 {z}\nvt {u} {v}\n");
    }
    s + "f 7/1 8/2 9/3 10/4\n"
}

/// The card's kept cells as quads of their own: the checker as geometry.
fn modelled_card() -> String {
    let mut s = String::new();
    let mut k = 7;
    let n = CHECKER as f32;
    for j in 0..CHECKER {
        for i in 0..CHECKER {
            if (i + j) % 2 != 0 {
                continue;
            }
            let (u0, u1) = (i as f32 / n, (i + 1) as f32 / n);
            let (v0, v1) = (1.0 - (j + 1) as f32 / n, 1.0 - j as f32 / n);
            for (u, v) in [(u0, v0), (u1, v0), (u1, v1), (u0, v1)] {
                let (x, z) = card_point(u, v);
                s += &format!("v {x} 1 {z}\n");
            }
            s += &format!("f {} {} {} {}\n", k, k + 1, k + 2, k + 3);
            k += 4;
        }
    }
    s
}

/// The checker mask: white everywhere, alpha 0 in the cut cells (so the grey value would keep all).
fn write_checker_mask(path: &std::path::Path) {
    let mut px = Vec::new();
    for j in 0..CHECKER {
        for i in 0..CHECKER {
            px.extend([255, 255, 255, if (i + j) % 2 == 0 { 255 } else { 0 }]);
        }
    }
    pmrender::io::oiio::write(
        path,
        CHECKER,
        CHECKER,
        &["R", "G", "B", "A"],
        pmrender::io::oiio::Pixels::U8(&px),
    )
    .unwrap();
}

/// `s.toml` of `dir` rendered with pm at 16 spp and `seed`, which must say nothing on stderr.
fn render_pm(dir: &std::path::Path, seed: u32) -> Image {
    let out = p(dir, "o.exr");
    let seed = seed.to_string();
    let r = run_bounded(
        &[
            "render",
            &p(dir, "s.toml"),
            "-o",
            &out,
            "--method",
            "pm",
            "--spp",
            "16",
            "--seed",
            &seed,
            "--quiet",
        ],
        Duration::from_secs(300),
    );
    assert!(
        r.status.success() && r.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    read(std::path::Path::new(&out))
}

const CUTOUT_SCENE: &str =
    "version = 1\n[camera]\neye = [0.0, 2.6, 3.2]\ntarget = [0.0, 0.5, -0.2]\n\
    fov = 45.0\nwidth = 64\nheight = 48\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
    position = [0.4, 2.5, 0.6]\nintensity = [4.0, 4.0, 4.0]\n";

/// Renders the cutout scene with `card` (OBJ text) and `card_mtl` (its material's statements) by `pm`
/// at `seed`.
fn render_card(card: &str, card_mtl: &str, seed: u32) -> Image {
    let d = scene_dir(&[
        ("m.obj", &cutout_obj(card)),
        (
            "m.mtl",
            &format!("newmtl room\nKd 0.6 0.6 0.6\nnewmtl card\nKd 0.8 0.5 0.3\n{card_mtl}"),
        ),
        ("s.toml", CUTOUT_SCENE),
    ]);
    write_checker_mask(&d.path().join("mask.png"));
    render_pm(d.path(), seed)
}

/// A quad cut to a checker by `map_d` renders as the checker modelled as triangles: the holes are
/// invisible to camera rays, the shadow rays that draw the checker's shadow on the floor, the gathers
/// and the photons. `d` as a constant cuts nothing, and the mask's alpha decides, not its white colour.
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–4: against the twin at the same seed the
/// mean within +0.01 … +0.11 % and the block relMSE 0.7–2.8e-6 (seeds 1001–1003: +0.01 … +0.04 %,
/// 1.3–1.9e-6; the mean's bound, 1 %, is 9× the worst); the twin against itself at another
/// seed (its noise) 0.05–0.40 % and 3.5–6.2e-5; the opaque card (no mask) +6.7 % and 5.2e-2. The
/// bound, 2e-4, is three times the twin's own seed-to-seed spread: a cutout drawn by other random
/// numbers than its twin's passes it too.
#[test]
fn a_map_d_cutout_renders_as_its_geometric_twin() {
    const BLOCK_BOUND: f64 = 2e-4;
    let rel = |a: &Image, b: &Image| (mean(a) - mean(b)).length() / mean(b).length();
    let blocks = |a: &Image, b: &Image| rel_mse(&block_means(a, 4), &block_means(b, 4));
    for seed in 1..=3 {
        let cut = render_card(&masked_card(), "map_d -clamp on mask.png\nd 0.3\n", seed);
        let twin = render_card(&modelled_card(), "", seed);
        let (m, b) = (rel(&cut, &twin), blocks(&cut, &twin));
        eprintln!("seed {seed}: mean {m:+.4}, block relMSE {b:.2e}");
        assert!(m < 0.01 && b < BLOCK_BOUND, "seed {seed}: {m} {b}");
    }
    // The test tells a cutout from an opaque card.
    let (opaque, twin) = (
        render_card(&masked_card(), "d 0.3\n", 1),
        render_card(&modelled_card(), "", 1),
    );
    let (m, b) = (rel(&opaque, &twin), blocks(&opaque, &twin));
    eprintln!("opaque: mean {m:+.4}, block relMSE {b:.2e}");
    assert!(m > 0.03 && b > 100.0 * BLOCK_BOUND, "{m} {b}");
}

/// `obj` with each face's corners in reverse order: the card then faces, and emits, downward.
fn flipped(obj: &str) -> String {
    obj.lines()
        .map(|l| match l.strip_prefix("f ") {
            Some(corners) => {
                let mut c: Vec<&str> = corners.split_whitespace().collect();
                c.reverse();
                format!("f {}\n", c.join(" "))
            }
            None => format!("{l}\n"),
        })
        .collect()
}

/// An emitting card cut by `map_d` emits from its kept cells only: the floor under it is lit as by
/// the checker modelled as emitting quads. Light samples and photons that start on a cut texel
/// carry nothing, as camera rays pass through it.
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–2: mean +0.22 … +0.32 %, block relMSE
/// 1.6–2.0e-4 (seeds 1001–1002: +0.13, +0.14 %, 1.9e-4, 2.5e-4: the bound is 3.2× the worst of the
/// four, the mean's 1 % 3×); the cut emitter against itself at another seed +0.42 % and 4.1e-4 (half its light
/// samples land on cut texels and carry nothing: twice the twin's variance, whose own spread is
/// 4.3e-5); the whole card emitting +41 % and 9.9e-2. The bound, 8e-4, is twice the cut emitter's
/// seed-to-seed spread.
#[test]
fn a_map_d_cutout_cuts_emission_too() {
    const BLOCK_BOUND: f64 = 8e-4;
    let rel = |a: &Image, b: &Image| (mean(a) - mean(b)).length() / mean(b).length();
    let blocks = |a: &Image, b: &Image| rel_mse(&block_means(a, 4), &block_means(b, 4));
    for seed in 1..=2 {
        let cut = render_card(&flipped(&masked_card()), "Ke 2 2 2\nmap_d mask.png\n", seed);
        let twin = render_card(&flipped(&modelled_card()), "Ke 2 2 2\n", seed);
        let (m, b) = (rel(&cut, &twin), blocks(&cut, &twin));
        eprintln!("seed {seed}: mean {m:+.4}, block relMSE {b:.2e}");
        assert!(m < 0.01 && b < BLOCK_BOUND, "seed {seed}: {m} {b}");
    }
    // The test tells the cut emitter from the whole card emitting.
    let whole = render_card(&flipped(&masked_card()), "Ke 2 2 2\n", 1);
    let twin = render_card(&flipped(&modelled_card()), "Ke 2 2 2\n", 1);
    let (m, b) = (rel(&whole, &twin), blocks(&whole, &twin));
    eprintln!("whole: mean {m:+.4}, block relMSE {b:.2e}");
    assert!(m > 0.1 && b > 100.0 * BLOCK_BOUND, "{m} {b}");
}

/// A glossy floor (u along x, v along −z) under a point light, with a diffuse back wall, seen at a
/// slant so that the highlight fills part of the image; the floor's material statements are `floor`.
fn render_glossy_floor(floor: &str, seed: u32) -> Image {
    let obj = "mtllib m.mtl\nv -2 0 2\nv 2 0 2\nv 2 0 -2\nv -2 0 -2\nv -2 3 -2\nv 2 3 -2\n\
               vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl floor\nf 1/1 2/2 3/3 4/4\n\
               usemtl wall\nf 4 3 6 5\n";
    let d = scene_dir(&[
        ("m.obj", obj),
        (
            "m.mtl",
            &format!("newmtl wall\nKd 0.6 0.6 0.6\nnewmtl floor\nKd 0.2 0.2 0.2\n{floor}"),
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 1.2, 3.0]\ntarget = [0.0, 0.3, -0.5]\nfov = 45.0\n\
             width = 64\nheight = 48\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 1.0, -1.5]\nintensity = [3.0, 3.0, 3.0]\n",
        ),
    ]);
    // Uniform maps as linear EXRs: a colour for map_Ks, a grey value for map_Ns.
    let write = |name: &str, rgb: [f32; 3]| {
        let px: Vec<f32> = (0..16).flat_map(|_| rgb).collect();
        pmrender::io::oiio::write(
            &d.path().join(name),
            4,
            4,
            &["R", "G", "B"],
            pmrender::io::oiio::Pixels::F32(&px),
        )
        .unwrap();
    };
    write("ks.exr", [0.5, 0.25, 1.0]);
    write("ns.exr", [0.2, 0.2, 0.2]);
    render_pm(d.path(), seed)
}

/// `map_Ks` scales the lobe's colour and `map_Ns` its exponent: uniform maps render as the constants
/// they scale to (Ks 0.6 × (0.5, 0.25, 1) against Ks (0.3, 0.15, 0.6); Ns 200 × 0.2 against Ns 40).
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–3: map_Ks renders the same pixels as its
/// constant (the same lobe to the bit); map_Ns +0.16 … +0.34 % in the mean, block relMSE 0.65–1.4e-4
/// (its lobe is sampled, the constant's read from the radiance cache; seeds 1001–1003: +0.07 …
/// +0.22 %, 0.87–2.8e-4, the bound 2.1× the worst); the constant Ns 40 against
/// itself at another seed 0.18–0.33 % and 1.9–2.6e-4; the unmapped Ns 200 against Ns 40 +0.5 % and
/// 4.5e-2 (the mean hardly moves, an energy-conserving lobe only narrows). The bound, 6e-4, is about
/// twice the seed-to-seed spread.
#[test]
fn map_ks_and_map_ns_scale_the_glossy_lobe() {
    const BLOCK_BOUND: f64 = 6e-4;
    let rel = |a: &Image, b: &Image| (mean(a) - mean(b)).length() / mean(b).length();
    let blocks = |a: &Image, b: &Image| rel_mse(&block_means(a, 4), &block_means(b, 4));
    for seed in 1..=3 {
        let ks_map = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 40\nmap_Ks ks.exr\n", seed);
        let ks = render_glossy_floor("Ks 0.3 0.15 0.6\nNs 40\n", seed);
        let (m, b) = (rel(&ks_map, &ks), blocks(&ks_map, &ks));
        eprintln!("seed {seed}: map_Ks {m:+.4} {b:.2e}");
        assert!(m < 0.01 && b < BLOCK_BOUND, "map_Ks, seed {seed}: {m} {b}");
        let ns_map = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 200\nmap_Ns ns.exr\n", seed);
        let ns = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 40\n", seed);
        let (m, b) = (rel(&ns_map, &ns), blocks(&ns_map, &ns));
        eprintln!("seed {seed}: map_Ns {m:+.4} {b:.2e}");
        assert!(m < 0.01 && b < BLOCK_BOUND, "map_Ns, seed {seed}: {m} {b}");
    }
    // The test tells the maps from their absence.
    let ks = render_glossy_floor("Ks 0.3 0.15 0.6\nNs 40\n", 1);
    let unmapped = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 40\n", 1);
    assert!(blocks(&unmapped, &ks) > 10.0 * BLOCK_BOUND);
    let ns = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 40\n", 1);
    let unmapped = render_glossy_floor("Ks 0.6 0.6 0.6\nNs 200\n", 1);
    assert!(blocks(&unmapped, &ns) > 10.0 * BLOCK_BOUND);
}
