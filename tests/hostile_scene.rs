//! Hostile scene content: values outside their physical range, coordinates whose
//! differences overflow, directions that normalise badly, mirrored meshes, odd textures, non-regular
//! and oversized input files, malformed OBJ/MTL/TOML, and photon or cache files with bad values behind a
//! valid checksum. Bad input ends with exit status 2, one line on stderr naming the file and line, no
//! output file and every input file unchanged — in bounded time.

mod common;
use common::*;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// Every regular file under `dir` with its contents.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect()
}

/// A render of `scene` that must be refused: status 2, one line containing every `expect`, no output,
/// the inputs untouched.
fn refused(dir: &Path, scene: &str, extra: &[&str], expect: &[&str]) {
    let before = snapshot(dir);
    let out = p(dir, "out.exr");
    let png = p(dir, "out.png");
    let mut args = vec!["render", scene, "-o", &out, "--png", &png, "--quiet"];
    args.extend_from_slice(extra);
    let r = run_bounded(&args, Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{args:?}: {stderr}");
    assert_eq!(
        stderr.trim().lines().count(),
        1,
        "one line expected: {stderr}"
    );
    for e in expect {
        assert!(stderr.contains(e), "'{e}' not in: {stderr}");
    }
    assert!(
        !Path::new(&out).exists() && !Path::new(&png).exists(),
        "no output on failure"
    );
    assert_eq!(snapshot(dir), before, "input files changed");
}

/// The room with `mtl` and `toml` in place of the defaults (the OBJ is the room's).
fn room_with(mtl: &str, toml: &str) -> tempfile::TempDir {
    scene_dir(&[
        ("room.obj", ROOM_OBJ),
        ("room.mtl", mtl),
        ("scene.toml", toml),
    ])
}

fn refused_room(mtl: &str, toml: &str, expect: &[&str]) {
    let d = room_with(mtl, toml);
    refused(d.path(), &p(d.path(), "scene.toml"), &[], expect);
}

/// Renders and returns the image.
fn renders(dir: &Path, extra: &[&str]) -> pmrender::io::output::Image {
    let (scene, out) = (p(dir, "scene.toml"), dir.join("ok.exr"));
    let mut args = vec!["render", &scene, "-o", out.to_str().unwrap(), "--quiet"];
    args.extend_from_slice(extra);
    let r = run_bounded(&args, Duration::from_secs(120));
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let img = read(&out);
    std::fs::remove_file(&out).unwrap();
    img
}

#[test]
fn reflectances_outside_zero_one_in_mtl() {
    for (bad, line) in [
        ("Kd -1 -1 -1", 2),
        ("Kd 5 5 5", 2),
        ("Kd 1e30 1e30 1e30", 2),
        ("Kd 0.5 nan 0.5", 2),
        ("illum 3\nKs -1 -1 -1", 3),
        ("illum 7\nTf -2 -2 -2", 3),
        ("illum 5\nKs 1.5 1 1", 3),
    ] {
        let mtl = ROOM_MTL.replace("Kd 0.6 0.6 0.6", bad);
        refused_room(&mtl, ROOM_TOML, &[&format!("room.mtl:{line}:")]);
    }
}

#[test]
fn reflectances_outside_zero_one_in_toml() {
    for (key, value) in [
        ("albedo", "[10.0, 10.0, 10.0]"),
        ("albedo", "[-0.1, 0.5, 0.5]"),
        ("albedo", "[0.5, 0.5, 1e39]"),
    ] {
        let toml = format!("{ROOM_TOML}\n[materials.wall]\ntype = \"diffuse\"\n{key} = {value}\n");
        refused_room(
            ROOM_MTL,
            &toml,
            &["scene.toml:17:", "materials.wall.albedo"],
        );
    }
    for (kind, key) in [
        ("mirror", "reflectance"),
        ("glass", "transmittance"),
        ("glossy", "specular"),
    ] {
        let toml =
            format!("{ROOM_TOML}\n[materials.wall]\ntype = \"{kind}\"\n{key} = [2.0, 2.0, 2.0]\n");
        refused_room(ROOM_MTL, &toml, &["scene.toml:17:", key]);
    }
    for (kind, key, value) in [
        ("glass", "ior", "0.5"),
        ("glass", "ior", "1e30"),
        ("glossy", "exponent", "1e30"),
        ("glossy", "exponent", "-1.0"),
    ] {
        let toml = format!("{ROOM_TOML}\n[materials.wall]\ntype = \"{kind}\"\n{key} = {value}\n");
        refused_room(ROOM_MTL, &toml, &["scene.toml:17:", key]);
    }
}

#[test]
fn emission_out_of_range_or_overflowing_power() {
    for ke in ["Ke 3e38 3e38 3e38", "Ke -1 -1 -1", "Ke 1e21 0 0"] {
        refused_room(
            &ROOM_MTL.replace("Ke 10 10 10", ke),
            ROOM_TOML,
            &["room.mtl:5:", "Ke"],
        );
    }
    for intensity in ["[3e38, 3e38, 3e38]", "[-1.0, 1.0, 1.0]", "[1.0, inf, 1.0]"] {
        let toml = format!("{ROOM_TOML}\n[[light]]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\nintensity = {intensity}\n");
        refused_room(ROOM_MTL, &toml, &["scene.toml:18:", "light.intensity"]);
    }
    // Every value in range, but the power (Ke × area) overflows: blamed on the Ke line.
    let toml = ROOM_TOML.replace("obj = \"room.obj\"", "obj = \"room.obj\"\nscale = 1e14");
    refused_room(
        &ROOM_MTL.replace("Ke 10 10 10", "Ke 1e20 1e20 1e20"),
        &toml,
        &["room.mtl:5:", "power"],
    );
    let toml = format!("{toml}\n[[light]]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nirradiance = [1e20, 1e20, 1e20]\n");
    refused_room(ROOM_MTL, &toml, &["scene.toml:", "power"]);
}

#[test]
fn coordinates_beyond_the_limit() {
    let light = |pos: &str| {
        format!("{ROOM_TOML}\n[[light]]\ntype = \"point\"\nposition = {pos}\nintensity = [1.0, 1.0, 1.0]\n")
    };
    for pos in ["[0.0, 1e19, 0.0]", "[3e38, 0.0, 0.0]", "[0.0, 0.0, -1e16]"] {
        refused_room(
            ROOM_MTL,
            &light(pos),
            &["scene.toml:17:", "light.position", "coordinate limit"],
        );
    }
    for (eye, target) in [
        ("[0.0, 1.0, 3e38]", "[0.0, 1.0, -3e38]"),
        ("[1e19, 1.0, 3.0]", "[0.0, 1.0, 0.0]"),
    ] {
        let toml = ROOM_TOML
            .replace("eye = [0.0, 1.0, 3.0]", &format!("eye = {eye}"))
            .replace("target = [0.0, 1.0, 0.0]", &format!("target = {target}"));
        refused_room(ROOM_MTL, &toml, &["scene.toml:3:", "camera.eye"]);
    }
    for transform in [
        "translate = [3e38, 0.0, 0.0]",
        "scale = 1e30",
        "scale = [1.0, 1e16, 1.0]",
    ] {
        let toml = ROOM_TOML.replace(
            "obj = \"room.obj\"",
            &format!("obj = \"room.obj\"\n{transform}"),
        );
        refused_room(ROOM_MTL, &toml, &["scene.toml:1", "coordinate limit"]);
    }
    // Two tiny triangles at x = ±3e38: an extent that overflows f32 (the cache octree once recursed forever).
    let far = format!("{ROOM_OBJ}v 3e38 0 0\nv 3e38 1 0\nv 3e38 0 1\nv -3e38 0 0\nv -3e38 1 0\nv -3e38 0 1\nf 13 14 15\nf 16 17 18\n");
    let d = scene_dir(&[
        ("room.obj", &far),
        ("room.mtl", ROOM_MTL),
        ("scene.toml", ROOM_TOML),
    ]);
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &["--method", "pm"],
        &["scene.toml:10:", "coordinate limit"],
    );
}

#[test]
fn far_directions_are_normalised_in_double_precision() {
    let with_light = |light: &str| format!("{ROOM_TOML}\n[[light]]\n{light}\n");
    let pairs = [
        ("type = \"directional\"\ndirection = [0.0, -1e20, -1e20]\nirradiance = [1.0, 1.0, 1.0]", "type = \"directional\"\ndirection = [0.0, -1.0, -1.0]\nirradiance = [1.0, 1.0, 1.0]"),
        ("type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ntarget = [0.0, -1e20, 0.0]\nintensity = [5.0, 5.0, 5.0]", "type = \"spot\"\nposition = [0.0, 1.5, 0.0]\ntarget = [0.0, 0.0, 0.0]\nintensity = [5.0, 5.0, 5.0]"),
    ];
    let no_ceiling_light = ROOM_MTL.replace("Ke 10 10 10", "");
    for (far, near) in pairs {
        let a = renders(
            room_with(&no_ceiling_light, &with_light(far)).path(),
            &["--method", "path"],
        );
        let b = renders(
            room_with(&no_ceiling_light, &with_light(near)).path(),
            &["--method", "path"],
        );
        assert!(
            mean(&a).max_element() > 0.0,
            "the far-aimed light must light the room"
        );
        assert_eq!(a.pixels, b.pixels, "{far}");
    }
    let far_target = ROOM_TOML.replace("target = [0.0, 1.0, 0.0]", "target = [0.0, 1.0, -3e38]");
    let a = renders(
        room_with(ROOM_MTL, &far_target).path(),
        &["--method", "path"],
    );
    let b = renders(room_with(ROOM_MTL, ROOM_TOML).path(), &["--method", "path"]);
    assert_eq!(
        a.pixels, b.pixels,
        "a far camera target looks the same way as a near one"
    );
}

#[test]
fn mirrored_meshes_keep_the_side_their_emitters_light() {
    let plain = mean(&renders(
        room().path(),
        &["--method", "path", "--spp", "16"],
    ))
    .x;
    // The room is symmetric in x and z: each mirror gives the same room, lit from the same ceiling light.
    // (Mirroring z and turning half a turn about y is the same room again; a stretched mirror is darker.)
    for transform in [
        "scale = [-1.0, 1.0, 1.0]",
        "scale = [1.0, 1.0, -1.0]\nrotate = [0.0, 180.0, 0.0]",
        "scale = [-2.0, 1.0, 1.0]",
    ] {
        let toml = ROOM_TOML.replace(
            "obj = \"room.obj\"",
            &format!("obj = \"room.obj\"\n{transform}"),
        );
        let mirrored = mean(&renders(
            room_with(ROOM_MTL, &toml).path(),
            &["--method", "path", "--spp", "16"],
        ))
        .x;
        let expected = if transform.contains("-2") {
            0.3 * plain
        } else {
            0.75 * plain
        };
        assert!(
            mirrored > expected,
            "{transform}: mean {mirrored} against {plain} unmirrored"
        );
    }
}

/// A PNG file (8-bit, colour type `ct`) holding `rows` (filter byte + pixels per row, or anything).
fn png(width: u32, height: u32, ct: u8, rows: &[u8]) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend(&body);
        out.extend(crc32(&body).to_be_bytes());
    }
    // Stored (uncompressed) deflate blocks inside a zlib stream, Adler-32 at the end.
    let mut z = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = rows.chunks(65535).collect();
    for (i, b) in blocks.iter().enumerate() {
        z.push((i + 1 == blocks.len()) as u8);
        z.extend((b.len() as u16).to_le_bytes());
        z.extend((!(b.len() as u16)).to_le_bytes());
        z.extend(*b);
    }
    let (mut a, mut s) = (1u32, 0u32);
    for &x in rows {
        a = (a + x as u32) % 65521;
        s = (s + a) % 65521;
    }
    z.extend(((s << 16) | a).to_be_bytes());
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(width.to_be_bytes());
    ihdr.extend(height.to_be_bytes());
    ihdr.extend([8, ct, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &z);
    chunk(&mut out, b"IEND", &[]);
    out
}

fn textured(texture: &[u8], map: &str) -> tempfile::TempDir {
    let d = room_with(
        &ROOM_MTL.replace("Kd 0.6 0.6 0.6", &format!("Kd 0.6 0.6 0.6\nmap_Kd {map}")),
        ROOM_TOML,
    );
    std::fs::write(d.path().join("tex.png"), texture).unwrap();
    d
}

#[test]
fn grey_alpha_textures_read_as_grey() {
    // 2×2, grey 128, alpha 255: the walls are grey, not cyan (alpha read as green and blue).
    let rows: Vec<u8> = (0..2).flat_map(|_| [0u8, 128, 255, 128, 255]).collect();
    let img = renders(
        textured(&png(2, 2, 4, &rows), "tex.png").path(),
        &["--method", "path"],
    );
    let m = mean(&img);
    assert!(
        m.x > 0.0
            && (m.y - m.x).abs() < 1e-4 * m.x.max(1e-3)
            && (m.z - m.x).abs() < 1e-4 * m.x.max(1e-3),
        "mean {m}"
    );
}

#[test]
fn corrupt_and_oversized_textures_give_one_line() {
    let rows: Vec<u8> = (0..2)
        .flat_map(|_| [0u8, 128, 128, 128, 128, 128, 128])
        .collect();
    let good = png(2, 2, 2, &rows);
    let mut crc = good.clone();
    crc[45] ^= 0xFF; // inside IDAT's data: a CRC error
    let truncated = good[..good.len() - 20].to_vec();
    for bad in [crc, truncated, b"\x89PNG\r\n\x1a\nnot a png".to_vec()] {
        let d = textured(&bad, "tex.png");
        refused(d.path(), &p(d.path(), "scene.toml"), &[], &["tex.png"]);
    }
    // The header claims 23170×23170 RGBA (8.6 GB as float): refused before decoding.
    for (w, h) in [(23170, 23170), (40000, 40000), (8193, 8193)] {
        let d = textured(&png(w, h, 6, &[0, 0, 0, 0, 0]), "tex.png");
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &[],
            &["tex.png", &format!("{w}×{h}"), "67108864"],
        );
    }
}

fn mkfifo(path: &Path) {
    assert!(Command::new("mkfifo").arg(path).status().unwrap().success());
}

#[test]
fn only_regular_files_are_read() {
    // Textures: a directory, a FIFO found by the case-insensitive lookup, a device.
    let d = textured(b"", "TEX.PNG");
    std::fs::remove_file(d.path().join("tex.png")).unwrap();
    mkfifo(&d.path().join("tex.png"));
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[],
        &["TEX.PNG", "not a regular file"],
    );
    for map in ["/dev/zero", "sub"] {
        let d = textured(b"", map);
        std::fs::create_dir(d.path().join("sub")).unwrap();
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &[],
            &[map, "not a regular file"],
        );
    }
    // Scene, OBJ and MTL that are not regular files.
    let d = room();
    refused(
        d.path(),
        "/dev/zero",
        &[],
        &["/dev/zero", "not a regular file"],
    );
    mkfifo(&d.path().join("fifo.toml"));
    refused(
        d.path(),
        &p(d.path(), "fifo.toml"),
        &[],
        &["fifo.toml", "not a regular file"],
    );
    let d = room();
    std::fs::remove_file(d.path().join("room.mtl")).unwrap();
    mkfifo(&d.path().join("room.mtl"));
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[],
        &["room.obj:1:", "not a regular file"],
    );
    let d = room();
    std::fs::remove_file(d.path().join("room.obj")).unwrap();
    std::fs::create_dir(d.path().join("room.obj")).unwrap();
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[],
        &["scene.toml:10:", "not a regular file"],
    );
}

#[test]
fn oversized_inputs_are_refused_before_reading() {
    // Sparse files: large on paper, nothing on disk.
    for (name, len, limit) in [
        ("scene.toml", 16u64 << 20, "16 MiB"),
        ("room.obj", 1 << 30, "1 GiB"),
        ("room.mtl", 64 << 20, "64 MiB"),
    ] {
        let d = room();
        let f = std::fs::OpenOptions::new()
            .append(true)
            .open(d.path().join(name))
            .unwrap();
        f.set_len(len + 1).unwrap();
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &[],
            &[name, "larger than the limit", limit],
        );
    }
    let d = textured(b"", "tex.png");
    std::fs::File::create(d.path().join("tex.png"))
        .unwrap()
        .set_len((1 << 30) + 1)
        .unwrap();
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[],
        &["tex.png", "larger than the limit"],
    );
}

/// The text with every character below U+0100 as one Latin-1 byte (é → 0xE9).
fn latin1(s: &str) -> Vec<u8> {
    s.chars().map(|c| c as u32 as u8).collect()
}

#[test]
fn obj_statements_are_reported_at_their_line() {
    for bad in [
        "v 1 0",
        "v",
        "v 1 2 3 4 5 6 7",
        "v 1 0 1 0",
        "vn 1 0",
        "usemtl caf\u{e9}",
    ] {
        let d = room();
        std::fs::write(
            d.path().join("room.obj"),
            latin1(&ROOM_OBJ.replacen("v 1 0 1", bad, 1)),
        )
        .unwrap();
        refused(d.path(), &p(d.path(), "scene.toml"), &[], &["room.obj:3:"]);
    }
    let d = room();
    std::fs::write(
        d.path().join("room.mtl"),
        latin1(&format!("newmtl caf\u{e9}\n{ROOM_MTL}")),
    )
    .unwrap();
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[],
        &["room.mtl:1:", "0xE9"],
    );
}

#[test]
fn legal_obj_mtl_and_toml_variants_are_accepted() {
    // `vt u`, several libraries on one `mtllib`, Latin-1 in comments, byte-order marks, inline comments.
    const BOM: &[u8] = b"\xEF\xBB\xBF";
    let obj = format!(
        "# caf\u{e9}\nmtllib room.mtl extra.mtl\nvt 0.5\nvt 0.5 0.5 0\n{}",
        ROOM_OBJ
            .replace("mtllib room.mtl\n", "")
            .replace("v -1 0 1", "v -1 0 1 # corner")
    );
    let mtl = ROOM_MTL.replace("newmtl light", "# lumi\u{e8}re\nnewmtl light");
    let d = scene_dir(&[("extra.mtl", "newmtl unused\nKd 0.5\n")]);
    std::fs::write(d.path().join("room.obj"), [BOM, &latin1(&obj)].concat()).unwrap();
    std::fs::write(d.path().join("room.mtl"), [BOM, &latin1(&mtl)].concat()).unwrap();
    std::fs::write(
        d.path().join("scene.toml"),
        [BOM, ROOM_TOML.as_bytes()].concat(),
    )
    .unwrap();
    let img = renders(d.path(), &["--method", "path"]);
    assert!(
        mean(&img).x > 0.0,
        "the room is lit: the BOM did not drop the mtllib line"
    );
}

#[test]
fn toml_range_errors_name_the_right_line() {
    let dotted = "version = 1\ncamera.eye = [0.0, 1.0, 3.0]\ncamera.target = [0.0, 1.0, 0.0]\ncamera.width = 24\ncamera.height = 16\ncamera.fov = 400.0\nmesh = [{ obj = \"room.obj\" }]\n";
    refused_room(ROOM_MTL, dotted, &["scene.toml:6:", "camera.fov"]);
    let inline = "version = 1\n\n\ncamera = { eye = [0.0, 1.0, 3.0], target = [0.0, 1.0, 0.0], fov = 0.0, width = 24, height = 16 }\n[[mesh]]\nobj = \"room.obj\"\n";
    refused_room(ROOM_MTL, inline, &["scene.toml:4:", "camera.fov"]);
    let mesh_inline = "version = 1\ncamera = { eye = [0.0, 1.0, 3.0], target = [0.0, 1.0, 0.0], fov = 40.0, width = 24, height = 16 }\nmesh = [\n  { obj = \"room.obj\" },\n  { obj = \"room.obj\", translate = [1e20, 0.0, 0.0] },\n]\n";
    refused_room(ROOM_MTL, mesh_inline, &["scene.toml:5:", "mesh.translate"]);
    let quoted = format!(
        "{ROOM_TOML}\n[materials.\"wall\"]\ntype = \"diffuse\"\n\nalbedo = [2.0, 0.5, 0.5]\n"
    );
    refused_room(
        ROOM_MTL,
        &quoted,
        &["scene.toml:18:", "materials.wall.albedo"],
    );
    let spacing = format!("{ROOM_TOML}\n[render.icache]\naccuracy = 0.5\nmin_spacing_px = 30.0\nmax_spacing_px = 20.0\n");
    refused_room(
        ROOM_MTL,
        &spacing,
        &["scene.toml:17:", "min_spacing_px", "max_spacing_px"],
    );
    let pass_b = format!("{ROOM_TOML}\n[render.icache]\naccuracy = 0.5\npass_b_accuracy = 0.25\n");
    refused_room(
        ROOM_MTL,
        &pass_b,
        &["scene.toml:17:", "render.icache.pass_b_accuracy"],
    );
    for (from, to, expect) in [
        ("spp = 2", "spp = 2000000", "1..=1048576"),
        ("spp = 2", "spp = 0", "1..=1048576"),
        ("spp = 2", "max_depth = 5000", "1..=1024"),
    ] {
        refused_room(
            ROOM_MTL,
            &ROOM_TOML.replace(from, to),
            &["scene.toml:13:", expect],
        );
    }
}

/// A record reaching far less than a pixel (tiny `accuracy` or `min_spacing_px`) makes pass B create a
/// record per sample, memory and time growing as 1/reach²: refused on its key.
#[test]
fn cache_records_reaching_less_than_a_pixel_are_refused() {
    for (key, value) in [
        ("accuracy", "0.01"),
        ("accuracy", "1e-30"),
        ("min_spacing_px", "0.001"),
    ] {
        let toml = format!("{ROOM_TOML}\n[render.icache]\n{key} = {value}\n");
        refused_room(
            ROOM_MTL,
            &toml,
            &["scene.toml:16:", &format!("render.icache.{key}"), "0.3 px"],
        );
    }
}

/// Gather rays past 65536 only make the fill longer (1 M, the old maximum, took 73 s at 32²): refused
/// on their line; the maximum renders.
#[test]
fn gather_rays_are_bounded() {
    let toml = format!("{ROOM_TOML}\n[render.icache]\nrays = 1000000\n");
    refused_room(
        ROOM_MTL,
        &toml,
        &["scene.toml:16:", "render.icache.rays", "4..=65536"],
    );
    let d = room_with(
        ROOM_MTL,
        &format!("{ROOM_TOML}\n[render.icache]\nrays = 65536\n"),
    );
    renders(d.path(), &["--method", "pm"]);
}

/// A huge `max_spacing_px` is legal (no upper clamp) and renders in bounded time: pass A's repair
/// queries spanned 2^21 cells per axis, whose product overflowed.
#[test]
fn a_huge_max_spacing_renders_in_bounded_time() {
    for value in ["1e8", "3e38"] {
        let d = room_with(
            ROOM_MTL,
            &format!("{ROOM_TOML}\n[render.icache]\nmax_spacing_px = {value}\n"),
        );
        renders(d.path(), &["--method", "pm"]);
    }
}

/// One face line of 3 M vertex references (`1 2 3` repeated) fans into 333 k copies of one triangle and
/// 667 k degenerate ones: the copies are one place every ray had to test them all (74 s at 32²). They
/// are dropped at load; the render takes about as long as the plain room's.
#[test]
fn a_face_line_repeating_one_triangle_renders_in_bounded_time() {
    let face = format!("usemtl wall\nf {}\n", ["1 2 3"; 1_000_000].join(" "));
    let d = room_with(ROOM_MTL, ROOM_TOML);
    std::fs::write(d.path().join("room.obj"), format!("{ROOM_OBJ}{face}")).unwrap();
    let start = std::time::Instant::now();
    renders(
        d.path(),
        &["--method", "pm", "--width", "32", "--height", "32"],
    );
    assert!(
        start.elapsed() < Duration::from_secs(30),
        "{:?}",
        start.elapsed()
    );
}

/// Saves photons and a cache for the room; returns the directory, the two files and the fingerprint.
fn saved_files() -> (tempfile::TempDir, Vec<u8>, Vec<u8>, u64) {
    let d = room();
    let (ph, ic) = (d.path().join("m.phot"), d.path().join("c.ic"));
    let r = run(&[
        "render",
        &p(d.path(), "scene.toml"),
        "-o",
        &p(d.path(), "o.exr"),
        "--method",
        "pm",
        "--quiet",
        "--save-photons",
        ph.to_str().unwrap(),
        "--save-cache",
        ic.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    std::fs::remove_file(d.path().join("o.exr")).unwrap();
    let fp = pmrender::scene::load(&d.path().join("scene.toml"))
        .unwrap()
        .fingerprint;
    let (a, b) = (std::fs::read(&ph).unwrap(), std::fs::read(&ic).unwrap());
    std::fs::remove_file(ph).unwrap();
    std::fs::remove_file(ic).unwrap();
    (d, a, b, fp)
}

/// Writes each `value` at its byte offset and recomputes the checksum (photon files hash from byte 8,
/// caches from 0).
fn patched(bytes: &[u8], edits: &[(usize, f32)], hash_from: usize) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for &(at, value) in edits {
        b[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }
    let end = b.len() - 8;
    let sum = icache::file::fnv1a64(&b[hash_from..end]);
    b[end..].copy_from_slice(&sum.to_le_bytes());
    b
}

#[test]
fn photon_and_cache_files_with_bad_values_are_refused() {
    let (d, photons, cache, fp) = saved_files();
    assert!(
        photon::file::read_maps(&photons, fp).is_ok()
            && icache::IrradianceCache::from_bytes(&cache, fp).is_ok()
    );
    // Photon layout (version 5): 160-byte header, then pos, wi, power, normal, kind (13 f32) of the
    // global, caustic and volume maps.
    let h = 160;
    let n_global = u64::from_le_bytes(photons[80..88].try_into().unwrap()) as usize;
    let n_caustic = u64::from_le_bytes(photons[88..96].try_into().unwrap()) as usize;
    let photon_cases = [
        (h + 24, f32::NAN, "power"),
        (h + 28, -1.0, "power"),
        (h + 24, f32::INFINITY, "power"),
        (h + 36, f32::NAN, "normal"),
        (h + 40, 5.0, "normal"),
        (h + 12, f32::NAN, "direction"),
        (h, f32::NAN, "position"),
        (h + 48, 0.5, "kind"),
    ];
    for (at, value, expect) in photon_cases {
        let bad = patched(&photons, &[(at, value)], 8);
        assert!(
            photon::file::read_maps(&bad, fp).is_err(),
            "{expect} = {value} accepted"
        );
        std::fs::write(d.path().join("bad.phot"), &bad).unwrap();
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &["--method", "pm", "--load-photons", &p(d.path(), "bad.phot")],
            &["--load-photons", expect],
        );
        std::fs::remove_file(d.path().join("bad.phot")).unwrap();
    }
    // Every photon's power 1e30 W: finite and non-negative, but more than the room's lights give any
    // photon (it rendered a mean of 3.8e30).
    let n_photons = n_global + n_caustic;
    let edits: Vec<(usize, f32)> = (0..n_photons)
        .flat_map(|i| (0..3).map(move |c| (h + 52 * i + 24 + 4 * c, 1e30)))
        .collect();
    std::fs::write(d.path().join("bright.phot"), patched(&photons, &edits, 8)).unwrap();
    refused(
        d.path(),
        &p(d.path(), "scene.toml"),
        &[
            "--method",
            "pm",
            "--load-photons",
            &p(d.path(), "bright.phot"),
        ],
        &[
            "--load-photons",
            "bright.phot",
            "more than the scene's lights",
        ],
    );
    std::fs::remove_file(d.path().join("bright.phot")).unwrap();
    // Cache layout (version 3): 44-byte prefix, bounds min and max (6 f32) at 44, stage count u32 at 68,
    // record count, the stages (u32 each) from 80, then records of 33 f32.
    let n_stages = u32::from_le_bytes(cache[68..72].try_into().unwrap()) as usize;
    let rec0 = icache::file::HEADER_BYTES + 4 * n_stages;
    let cache_cases: [(&[(usize, f32)], &str); 5] = [
        (&[(44, -3e38), (56, 3e38)], "bounds"),
        (&[(48, f32::NAN)], "bounds"),
        (&[(rec0 + 24, f32::NAN)], "record 0"),
        (&[(rec0 + 24, -1.0)], "record 0"),
        (&[(rec0 + 12, 5.0)], "record 0"),
    ];
    for (edits, expect) in cache_cases {
        let bad = patched(&cache, edits, 0);
        assert!(
            icache::IrradianceCache::from_bytes(&bad, fp).is_err(),
            "{expect}: {edits:?} accepted"
        );
        std::fs::write(d.path().join("bad.ic"), &bad).unwrap();
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &["--method", "pm", "--load-cache", &p(d.path(), "bad.ic")],
            &["--load-cache", expect],
        );
        std::fs::remove_file(d.path().join("bad.ic")).unwrap();
    }
    for name in ["fifo.phot", "dir.phot"] {
        let path = d.path().join(name);
        if name.starts_with("fifo") {
            mkfifo(&path)
        } else {
            std::fs::create_dir(&path).unwrap()
        }
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &["--method", "pm", "--load-photons", path.to_str().unwrap()],
            &["--load-photons"],
        );
    }
}

/// A texture is an albedo: a float texel outside [0, 1] (an EXR of 5.0 made the walls 12× brighter,
/// where `Kd 5` is refused) or not a number is refused, naming the texture and the texel.
#[test]
fn float_texels_outside_zero_one_are_refused() {
    for (value, expect) in [
        (5.0f32, "(5, 5, 5)"),
        (-0.5, "(-0.5, -0.5, -0.5)"),
        (f32::NAN, "NaN"),
    ] {
        let d = room_with(
            &ROOM_MTL.replace("Kd 0.6 0.6 0.6", "Kd 0.6 0.6 0.6\nmap_Kd tex.exr"),
            ROOM_TOML,
        );
        let mut pixels = vec![0.5f32; 2 * 2 * 3];
        pixels[9..12].copy_from_slice(&[value; 3]);
        pmrender::io::oiio::write(
            &d.path().join("tex.exr"),
            2,
            2,
            &["R", "G", "B"],
            pmrender::io::oiio::Pixels::F32(&pixels),
        )
        .unwrap();
        refused(
            d.path(),
            &p(d.path(), "scene.toml"),
            &[],
            &["tex.exr", "texel (1, 1)", expect, "[0, 1]"],
        );
    }
}

/// A k-NN estimate from too few photons is biased (k = 2: a fog ×1.20) or unbounded (k = 1: ×6.2):
/// `lookup` below 16 is refused on its line; 16 renders.
#[test]
fn photon_lookups_below_sixteen_are_refused() {
    for k in [1, 2, 15] {
        let toml = format!("{ROOM_TOML}\n[render.photons]\nlookup = {k}\n");
        refused_room(
            ROOM_MTL,
            &toml,
            &["scene.toml:16:", "render.photons.lookup", "16..="],
        );
    }
    let d = room_with(
        ROOM_MTL,
        &format!("{ROOM_TOML}\n[render.photons]\nlookup = 16\n"),
    );
    renders(d.path(), &["--method", "pm"]);
}

/// An MTL statement the format does not have — a misspelling (`kd`, `Kx`), or a file that is no MTL
/// (`mtllib` naming /etc/passwd) — gave the default material without a word: refused with file:line.
#[test]
fn unknown_mtl_statements_are_refused() {
    for (bad, expect) in [
        ("kd 0.6 0.6 0.6", "'Kd'?"),
        ("Kx 1", "'Kx'"),
        ("root:x:0:0:root:/root:/bin/bash", "MTL file"),
    ] {
        refused_room(
            &ROOM_MTL.replace("Kd 0.6 0.6 0.6", bad),
            ROOM_TOML,
            &["room.mtl:2:", expect],
        );
    }
}

/// `usemtl` of a name no library defines (a misspelt name, a missing `newmtl`, as McGuire's
/// CornellBox-Glossy.mtl lacks the `light` its OBJ uses) renders with the default material and one
/// warning naming the OBJ's line, printed under `--quiet` and counted in the statistics; a
/// `[materials.NAME]` table defines it without a warning.
#[test]
fn usemtl_of_an_undefined_material_warns_and_takes_the_default() {
    let d = room();
    std::fs::write(
        d.path().join("room.obj"),
        ROOM_OBJ.replace("usemtl wall", "usemtl wal"),
    )
    .unwrap();
    let (out, stats) = (p(d.path(), "o.exr"), p(d.path(), "o.json"));
    let scene = p(d.path(), "scene.toml");
    let r = run_bounded(
        &["render", &scene, "-o", &out, "--stats", &stats, "--quiet"],
        Duration::from_secs(120),
    );
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    for e in ["room.obj:14:", "usemtl 'wal'", "default material"] {
        assert!(warnings[0].contains(e), "'{e}' not in: {stderr}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    assert_eq!(json["scene"]["warnings"], 1, "{json}");
    // The default (diffuse 0.8) stood in for the walls' 0.6: brighter.
    let plain = renders(room().path(), &[]);
    assert!(mean(&read(Path::new(&out))).x > mean(&plain).x);
    let lacking_light = ROOM_MTL.replace("newmtl light\nKd 0 0 0\nKe 10 10 10\n", "");
    let defined = format!(
        "{ROOM_TOML}\n[materials.light]\ntype = \"diffuse\"\nalbedo = [0, 0, 0]\nemission = [10, 10, 10]\n"
    );
    let d = room_with(&lacking_light, &defined);
    let r = run_bounded(
        &[
            "render",
            &p(d.path(), "scene.toml"),
            "-o",
            &p(d.path(), "o.exr"),
            "--quiet",
        ],
        Duration::from_secs(120),
    );
    assert!(
        r.status.success() && r.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    assert_eq!(read(&d.path().join("o.exr")).pixels, plain.pixels);
    // A table of the scene file that no mesh uses stays an error: the scene file is ours to fix.
    refused_room(
        ROOM_MTL,
        &format!("{ROOM_TOML}\n[materials.wal]\ntype = \"diffuse\"\n"),
        &["scene.toml:", "no mesh uses a material named 'wal'"],
    );
}
