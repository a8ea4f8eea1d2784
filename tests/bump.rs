//! Bump and normal maps against twins that need no texture: the same shading normals given as vertex
//! normals. Each floor is flat; only its shading normal differs, so direct light, the photon
//! estimates and the irradiance cache's turned records must all follow it.

mod common;

use std::time::Duration;

use common::*;
use glam::Vec3;
use pmrender::io::output::Image;

/// The floor's texture coordinates run over [UV_LO, UV_HI] (u along +x, v along −z), away from the
/// wrap at 0 and 1 where a height map's differences would straddle the seam.
const UV_LO: f32 = 0.05;
const UV_HI: f32 = 0.95;
/// The floor's side (x and z in [−2, 2]).
const SIDE: f32 = 4.0;
const TILT_DEGREES: f32 = 25.0;

/// A floor (its statements `floor` in the MTL, vertex normals `vn` when given) and a back wall under a
/// point light to the floor's +x side, rendered by `pm` at 64×48, 16 spp and `seed`; the images in
/// `images` (name, encoded file) sit beside it.
fn render_floor(floor: &str, vn: Option<Vec3>, images: &[(&str, Vec<u8>)], seed: u32) -> Render {
    let (lo, hi) = (UV_LO, UV_HI);
    let mut obj = format!(
        "mtllib m.mtl\nv -2 0 2\nv 2 0 2\nv 2 0 -2\nv -2 0 -2\nv -2 3 -2\nv 2 3 -2\n\
         vt {lo} {lo}\nvt {hi} {lo}\nvt {hi} {hi}\nvt {lo} {hi}\n"
    );
    obj += &match vn {
        Some(n) => format!(
            "vn {} {} {}\nusemtl floor\nf 1/1/1 2/2/1 3/3/1 4/4/1\n",
            n.x, n.y, n.z
        ),
        None => "usemtl floor\nf 1/1 2/2 3/3 4/4\n".into(),
    };
    obj += "usemtl wall\nf 4 3 6 5\n";
    let d = scene_dir(&[
        ("m.obj", &obj),
        (
            "m.mtl",
            &format!("newmtl wall\nKd 0.6 0.6 0.6\nnewmtl floor\nKd 0.5 0.5 0.5\n{floor}"),
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 1.6, 3.0]\ntarget = [0.0, 0.2, -0.5]\nfov = 45.0\n\
             width = 64\nheight = 48\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [1.6, 0.9, 0.0]\nintensity = [3.0, 3.0, 3.0]\n",
        ),
    ]);
    render_in(&d, images, seed)
}

/// The scene `s.toml` of `d` with the images in `images` (name, encoded file) written beside it,
/// rendered by `pm` at 16 spp and `seed`.
fn render_in(d: &tempfile::TempDir, images: &[(&str, Vec<u8>)], seed: u32) -> Render {
    for (name, bytes) in images {
        std::fs::write(d.path().join(name), bytes).unwrap();
    }
    let (out, stats) = (p(d.path(), "o.exr"), p(d.path(), "o.json"));
    let seed = seed.to_string();
    let r = run_bounded(
        &[
            "render",
            &p(d.path(), "s.toml"),
            "-o",
            &out,
            "--stats",
            &stats,
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
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    Render {
        image: read(std::path::Path::new(&out)),
        bump_rotated: json["icache"]["bump_rotated_pass_b"].as_u64().unwrap(),
    }
}

/// A render's image and the pass-B lookups a bump turned.
struct Render {
    image: Image,
    bump_rotated: u64,
}

/// A binary PPM (P6) of `w` × `h` texels all of colour `rgb`.
fn ppm(w: u32, h: u32, rgb: [u8; 3]) -> Vec<u8> {
    let mut b = format!("P6\n{w} {h}\n255\n").into_bytes();
    (0..w * h).for_each(|_| b.extend(rgb));
    b
}

/// A binary PGM (P5), 256 × 4, each column's grey value its index: a height ramp along u.
fn ramp_pgm() -> Vec<u8> {
    let mut b = b"P5\n256 4\n255\n".to_vec();
    (0..4).for_each(|_| b.extend(0..=255u8));
    b
}

fn rel(a: &Image, b: &Image) -> f32 {
    (mean(a) - mean(b)).length() / mean(b).length()
}

fn blocks(a: &Image, b: &Image) -> f64 {
    rel_mse(&block_means(a, 4), &block_means(b, 4))
}

/// A constant tangent-space normal map (`norm`, 8-bit, read linearly) tilting the floor's normal 25°
/// toward +u renders as the floor whose vertex normals have that tilt; under `map_Bump` the same
/// image is told to be a normal map. The cache places its records by the flat normal and turns them
/// at every lookup (counted); the twin's records sit on its tilted normals.
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–2, `norm` and `map_Bump` alike: mean
/// +0.10 … +0.17 %, block relMSE 1.3–1.5e-5 (seeds 1001–1002: +0.31, +0.08 %, 1.3e-5, 1.2e-5; the
/// mean's bound, 1 %, is 3× the worst); the twin against itself at another seed +0.23 % and
/// 3.7e-5; the flat floor (no map) against the twin +13.6 % and 2.2e-2. The bound, 1e-4, is about
/// three times the twin's seed-to-seed spread.
#[test]
fn a_constant_normal_map_renders_as_tilted_vertex_normals() {
    const BLOCK_BOUND: f64 = 1e-4;
    let (s, c) = TILT_DEGREES.to_radians().sin_cos();
    let texel = [0.5 + 0.5 * s, 0.5, 0.5 + 0.5 * c].map(|x| (x * 255.0).round() as u8);
    // The twin's normal is the texel as decoded (2c − 1 of its 8-bit values), x along +u = +x.
    let t = Vec3::from_array(texel.map(|x| x as f32 / 255.0)) * 2.0 - Vec3::ONE;
    let twin_n = Vec3::new(t.x, t.z, -t.y).normalize();
    let image = [("n.ppm", ppm(4, 4, texel))];
    for seed in 1..=2 {
        for statement in ["norm n.ppm", "map_Bump -bm 1 n.ppm"] {
            let mapped = render_floor(&format!("{statement}\n"), None, &image, seed);
            let twin = render_floor("", Some(twin_n), &[], seed);
            let (m, b) = (
                rel(&mapped.image, &twin.image),
                blocks(&mapped.image, &twin.image),
            );
            eprintln!("seed {seed}, {statement}: mean {m:+.4}, block relMSE {b:.2e}");
            assert!(
                m < 0.01 && b < BLOCK_BOUND,
                "seed {seed}, {statement}: {m} {b}"
            );
            assert!(mapped.bump_rotated > 0 && twin.bump_rotated == 0);
        }
    }
    // The test tells the map from its absence.
    let flat = render_floor("", None, &[], 1);
    let twin = render_floor("", Some(twin_n), &[], 1);
    let (m, b) = (
        rel(&flat.image, &twin.image),
        blocks(&flat.image, &twin.image),
    );
    eprintln!("flat: mean {m:+.4}, block relMSE {b:.2e}");
    assert!(m > 0.05 && b > 100.0 * BLOCK_BOUND, "{m} {b}");
}

/// A height map that is a linear ramp along u (`bump -bm s`, a grey image) renders as the floor whose
/// vertex normals have the ramp's slope: displacement s·h over ∂p/∂u = (SIDE / (UV_HI − UV_LO)) x̂,
/// h rising 256/255 per unit of u, tilts the normal toward −x by atan(slope).
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–2: mean +0.15 … +0.17 %, block relMSE
/// 1.2–1.5e-5; seeds 1001–1002: +0.13, +0.10 %, 1.6e-5, 1.4e-5 (the tilt is the normal map's,
/// toward −x: the twin's spread is the same). Bounds 1 % and 1e-4.
#[test]
fn a_height_ramp_renders_as_its_slope_in_the_normals() {
    const BLOCK_BOUND: f64 = 1e-4;
    let slope = TILT_DEGREES.to_radians().tan();
    let dpdu = SIDE / (UV_HI - UV_LO);
    let bm = slope * dpdu / (256.0 / 255.0);
    let twin_n = Vec3::new(-slope, 1.0, 0.0).normalize();
    let image = [("h.pgm", ramp_pgm())];
    for seed in 1..=2 {
        let bumped = render_floor(&format!("bump -bm {bm} h.pgm\n"), None, &image, seed);
        let twin = render_floor("", Some(twin_n), &[], seed);
        let (m, b) = (
            rel(&bumped.image, &twin.image),
            blocks(&bumped.image, &twin.image),
        );
        eprintln!("seed {seed}: mean {m:+.4}, block relMSE {b:.2e}");
        assert!(m < 0.01 && b < BLOCK_BOUND, "seed {seed}: {m} {b}");
        assert!(bumped.bump_rotated > 0);
    }
}

/// Bump statements that cannot be read are refused with a line naming the material or the file; a
/// scale so large that every slope overflows leaves the normal as it was (no NaN, no crash).
#[test]
fn bad_bump_maps_are_refused_or_harmless() {
    let scene = |floor: &str, images: &[(&str, Vec<u8>)]| {
        let d = scene_dir(&[
            (
                "m.obj",
                "mtllib m.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                 usemtl floor\nf 1/1 2/2 3/3 4/4\n",
            ),
            ("m.mtl", &format!("newmtl floor\nKd 0.5 0.5 0.5\n{floor}")),
            (
                "s.toml",
                "version = 1\n[camera]\neye = [0.0, 2.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 45.0\n\
                 width = 16\nheight = 12\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
                 position = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n[render]\nspp = 2\n",
            ),
        ]);
        for (name, bytes) in images {
            std::fs::write(d.path().join(name), bytes).unwrap();
        }
        d
    };
    let render = |d: &tempfile::TempDir| {
        run_bounded(
            &[
                "render",
                &p(d.path(), "s.toml"),
                "-o",
                &p(d.path(), "o.exr"),
                "--method",
                "pm",
                "--quiet",
            ],
            Duration::from_secs(120),
        )
    };
    let grey = [("g.pgm", ramp_pgm())];
    for (floor, images, want) in [
        ("norm missing.png\n", &[][..], "norm 'missing.png'"),
        (
            "map_Bump -bm 0.5 missing.png\n",
            &[][..],
            "bump 'missing.png'",
        ),
        ("norm g.pgm\n", &grey[..], "needs a colour image"),
    ] {
        let d = scene(floor, images);
        let r = render(&d);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{floor}: {stderr}");
        assert!(
            stderr.contains(want) && stderr.lines().count() == 1,
            "{floor}: {stderr}"
        );
    }
    let d = scene("bump -bm 1e38 g.pgm\n", &grey);
    let r = render(&d);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let m = mean(&read(&d.path().join("o.exr")));
    assert!(m.is_finite() && m.min_element() > 0.0, "{m}");
}

/// `export-mitsuba` wraps a height map's material in Mitsuba 3's `bumpmap` (scale `-bm`) and a
/// normal map's in `normalmap`, both images read raw.
#[test]
fn export_writes_bumpmap_and_normalmap_wrappers() {
    let d = scene_dir(&[
        (
            "m.obj",
            "mtllib m.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\n",
        ),
        (
            "m.mtl",
            "newmtl a\nKd 0.5 0.5 0.5\nbump -bm 0.25 h.pgm\nnewmtl b\nKd 0.5 0.5 0.5\n\
             map_Bump n.ppm\n",
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 2.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
        ),
    ]);
    std::fs::write(d.path().join("h.pgm"), ramp_pgm()).unwrap();
    std::fs::write(d.path().join("n.ppm"), ppm(2, 2, [128, 128, 255])).unwrap();
    let out = d.path().join("mi");
    let r = run(&[
        "export-mitsuba",
        &p(d.path(), "s.toml"),
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    let raw = r#"<boolean name="raw" value="true"/>"#;
    let bump = xml.lines().find(|l| l.contains("bumpmap")).expect(&xml);
    assert!(bump.contains("h.pgm") && bump.contains(raw), "{bump}");
    assert!(
        bump.contains(r#"<float name="scale" value="0.25"/>"#),
        "{bump}"
    );
    let normal = xml.lines().find(|l| l.contains("normalmap")).expect(&xml);
    assert!(normal.contains("n.ppm") && normal.contains(raw), "{normal}");
    assert!(
        normal.contains(r#"<texture type="bitmap" name="normalmap">"#),
        "{normal}"
    );
}

/// Mitsuba's `normalmap` has no strength: a normal map of `-bm` 0.5 is exported as an EXR of its
/// texels turned halfway to the surface's normal, encoded as the image was; at strength 1 the map's
/// own image is named.
#[test]
fn export_bakes_a_normal_maps_strength() {
    let d = scene_dir(&[
        (
            "m.obj",
            "mtllib m.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\n",
        ),
        (
            "m.mtl",
            "newmtl a\nKd 0.5 0.5 0.5\nnorm -bm 0.5 n.ppm\nnewmtl b\nKd 0.5 0.5 0.5\n\
             norm -bm 1 n.ppm\n",
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 2.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
        ),
    ]);
    // (0.6, 0, 0.8) encoded; halfway to +z it is normalize(0.3, 0, 0.9).
    let texel = [204, 128, 230];
    std::fs::write(d.path().join("n.ppm"), ppm(2, 2, texel)).unwrap();
    let out = d.path().join("mi");
    let r = run(&[
        "export-mitsuba",
        &p(d.path(), "s.toml"),
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    let files: Vec<&str> = xml
        .lines()
        .filter(|l| l.contains("normalmap"))
        .map(|l| {
            let at = l.find(r#"name="normalmap">"#).expect(l);
            let key = r#"<string name="filename" value=""#;
            let start = at + l[at..].find(key).expect(l) + key.len();
            &l[start..start + l[start..].find('"').unwrap()]
        })
        .collect();
    assert_eq!(files.len(), 2, "{xml}");
    let (baked, own): (Vec<&str>, Vec<&str>) = files.iter().partition(|f| f.ends_with(".exr"));
    assert!(own.len() == 1 && own[0].ends_with("n.ppm"), "{files:?}");
    assert!(
        baked.len() == 1 && baked[0].starts_with("normal_"),
        "{files:?}"
    );
    let img = pmrender::io::oiio::read(&out.join(baked[0])).unwrap();
    assert_eq!((img.width, img.height, img.channels), (2, 2, 3));
    let c = Vec3::from_array(texel.map(|v| v as f32 / 255.0)) * 2.0 - Vec3::ONE;
    let want = (Vec3::Z + (c.normalize() - Vec3::Z) * 0.5).normalize();
    for px in img.data.chunks_exact(3) {
        let got = Vec3::from_slice(px) * 2.0 - Vec3::ONE;
        assert!((got - want).length() < 1e-5, "{got} vs {want}");
    }
}

/// Segments of the torus around its axis (u) and around its tube (v): coarse enough that a frame
/// taken per triangle shows its facets.
const TORUS_NU: usize = 16;
const TORUS_NV: usize = 12;
/// The tilt of the torus's normal map: a steep one, whose normal a twisted tangent moves the most.
const TORUS_TILT_DEGREES: f32 = 45.0;

/// A smooth torus (major radius 1, tube 0.45, axis +z, centre (0, 1.2, 0)), its texture coordinates
/// u around the axis and v around the tube, its vertex normals those of the exact torus turned by
/// `turn` (the tangent-space vector the twin's normal takes: x along ∂p/∂u, y along ∂p/∂v, z along the
/// normal), as an OBJ using material `torus` of `m.mtl`. The seams of u and v repeat their vertices.
fn torus_obj(turn: Vec3) -> String {
    let (big_r, r) = (1.0f32, 0.45f32);
    let mut obj = String::from("mtllib m.mtl\n");
    for j in 0..=TORUS_NV {
        for i in 0..=TORUS_NU {
            let (u, v) = (i as f32 / TORUS_NU as f32, j as f32 / TORUS_NV as f32);
            let (st, ct) = (std::f32::consts::TAU * u).sin_cos();
            let (sp, cp) = (std::f32::consts::TAU * v).sin_cos();
            let p = Vec3::new((big_r + r * cp) * ct, 1.2 + (big_r + r * cp) * st, r * sp);
            let n = Vec3::new(cp * ct, cp * st, sp);
            let (t, b) = (Vec3::new(-st, ct, 0.0), Vec3::new(-sp * ct, -sp * st, cp));
            let m = (t * turn.x + b * turn.y + n * turn.z).normalize();
            obj += &format!(
                "v {} {} {}\nvt {u} {v}\nvn {} {} {}\n",
                p.x, p.y, p.z, m.x, m.y, m.z
            );
        }
    }
    obj += "usemtl torus\n";
    let at = |i: usize, j: usize| j * (TORUS_NU + 1) + i + 1;
    for j in 0..TORUS_NV {
        for i in 0..TORUS_NU {
            let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            obj += &format!(
                "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\nf {a}/{a}/{a} {c}/{c}/{c} {d}/{d}/{d}\n"
            );
        }
    }
    obj
}

/// The torus of [`torus_obj`] (`turn` its normals' turn, `torus` its material's statements) standing
/// on a floor before a wall, lit by a point light to its upper right, seen from the front at 64×48 by
/// `pm` at 16 spp and `seed`.
fn render_torus(turn: Vec3, torus: &str, images: &[(&str, Vec<u8>)], seed: u32) -> Render {
    let room = "o room\nv -4 0 3\nv 4 0 3\nv 4 0 -2\nv -4 0 -2\nv -4 5 -2\nv 4 5 -2\n\
                usemtl wall\nf -6 -5 -4 -3\nf -3 -4 -1 -2\n";
    let d = scene_dir(&[
        ("t.obj", &torus_obj(turn)),
        ("r.obj", &format!("mtllib m.mtl\n{room}")),
        (
            "m.mtl",
            &format!("newmtl wall\nKd 0.6 0.6 0.6\nnewmtl torus\nKd 0.5 0.5 0.5\n{torus}"),
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 1.3, 4.2]\ntarget = [0.0, 1.1, 0.0]\nfov = 40.0\n\
             width = 64\nheight = 48\n[[mesh]]\nobj = \"t.obj\"\n[[mesh]]\nobj = \"r.obj\"\n\
             [[light]]\ntype = \"point\"\nposition = [2.5, 3.0, 2.5]\nintensity = [12.0, 12.0, 12.0]\n",
        ),
    ]);
    render_in(&d, images, seed)
}

/// A flat normal map ((128, 128, 255): 8-bit's nearest to +z, 0.2° off it) on a smooth, coarsely
/// tessellated torus renders as the torus without it: the per-vertex tangent frame turns nothing
/// where the map does not.
///
/// Measured (64×48, pm, 16 spp, 4×4-pixel blocks), seeds 1–2: mean +0.045 … +0.055 % (bound 0.5 %),
/// block relMSE 3.0–3.1e-6 (bound 1e-5).
#[test]
fn a_flat_normal_map_on_a_smooth_torus_changes_nothing() {
    const MEAN_BOUND: f32 = 0.005;
    const BLOCK_BOUND: f64 = 1e-5;
    let image = [("n.ppm", ppm(4, 4, [128, 128, 255]))];
    for seed in 1..=2 {
        let mapped = render_torus(Vec3::Z, "norm n.ppm\n", &image, seed);
        let plain = render_torus(Vec3::Z, "", &[], seed);
        let (m, b) = (
            rel(&mapped.image, &plain.image),
            blocks(&mapped.image, &plain.image),
        );
        eprintln!("seed {seed}: mean {m:+.5}, block relMSE {b:.2e}");
        assert!(m < MEAN_BOUND && b < BLOCK_BOUND, "seed {seed}: {m} {b}");
        assert!(mapped.bump_rotated > 0);
    }
}

/// A constant normal map tilting the normal 45° toward +u on the coarse smooth torus renders as the
/// torus whose vertex normals have that tilt in the exact surface's frame: the tangents, averaged
/// per vertex and interpolated, turn the normal continuously across the triangles' edges, where a
/// frame per triangle (its own ∂p/∂u) twists from one triangle of a quad to the other and shows
/// the facets.
///
/// Measured per pixel (facets are a pixel or two wide here; blocks would average their error away),
/// 64×48, pm, 16 spp, seeds 1–2: relMSE 2.6–2.7e-4, mean +0.12 … +0.16 %; the twin against itself at
/// another seed 2.4e-4 (its noise); the per-triangle frame this replaced 5.2e-4 (seed 1). Bound 3.5e-4.
#[test]
fn a_tilted_normal_map_on_a_smooth_torus_shows_no_facets() {
    const PIXEL_BOUND: f64 = 3.5e-4;
    let (s, c) = TORUS_TILT_DEGREES.to_radians().sin_cos();
    let texel = [0.5 + 0.5 * s, 0.5, 0.5 + 0.5 * c].map(|x| (x * 255.0).round() as u8);
    let turn = Vec3::from_array(texel.map(|x| x as f32 / 255.0)) * 2.0 - Vec3::ONE;
    let image = [("n.ppm", ppm(4, 4, texel))];
    // The twin against itself at another seed: the noise the bounds stand above.
    let (a, b) = (
        render_torus(turn, "", &[], 1),
        render_torus(turn, "", &[], 2),
    );
    eprintln!(
        "twin, seeds 1 and 2: pixel relMSE {:.2e}",
        rel_mse(&a.image, &b.image)
    );
    for seed in 1..=2 {
        let mapped = render_torus(Vec3::Z, "norm n.ppm\n", &image, seed);
        let twin = render_torus(turn, "", &[], seed);
        let (m, b) = (
            rel(&mapped.image, &twin.image),
            rel_mse(&mapped.image, &twin.image),
        );
        eprintln!("seed {seed}: mean {m:+.5}, pixel relMSE {b:.2e}");
        assert!(m < 0.01 && b < PIXEL_BOUND, "seed {seed}: {m} {b}");
    }
}

/// A height map read from a colour image (ours: its channels' mean; Mitsuba's `bitmap` would take its
/// luminance) is exported as `height_<material>.exr` holding our values; a grey one is named as it is.
#[test]
fn export_writes_a_colour_height_map_as_our_values() {
    let d = scene_dir(&[
        (
            "m.obj",
            "mtllib m.mtl\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/4\n",
        ),
        (
            "m.mtl",
            "newmtl a\nKd 0.5 0.5 0.5\nbump -bm 0.25 c.ppm\nnewmtl b\nKd 0.5 0.5 0.5\n\
             bump -bm 0.25 h.pgm\n",
        ),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [0.0, 2.0, 2.0]\ntarget = [0.0, 0.0, 0.0]\n\
             fov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [0.0, 1.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
        ),
    ]);
    // (200, 100, 0) decodes to a vector below the surface: no normal map, a height of mean 100/255.
    std::fs::write(d.path().join("c.ppm"), ppm(2, 2, [200, 100, 0])).unwrap();
    std::fs::write(d.path().join("h.pgm"), ramp_pgm()).unwrap();
    let out = d.path().join("mi");
    let r = run(&[
        "export-mitsuba",
        &p(d.path(), "s.toml"),
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    let bumps: Vec<&str> = xml.lines().filter(|l| l.contains("bumpmap")).collect();
    assert_eq!(bumps.len(), 2, "{xml}");
    assert!(
        bumps.iter().any(|l| l.contains(r#"value="height_0.exr""#)),
        "{xml}"
    );
    assert!(bumps.iter().any(|l| l.contains("h.pgm")), "{xml}");
    let img = pmrender::io::oiio::read(&out.join("height_0.exr")).unwrap();
    assert_eq!((img.width, img.height, img.channels), (2, 2, 1));
    for v in &img.data {
        assert!((v - 100.0 / 255.0).abs() < 1e-6, "{v}");
    }
}
