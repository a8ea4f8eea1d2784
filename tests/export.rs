//! `pmrender export-mitsuba`: the XML names the same camera, materials and lights, and the OBJs hold every
//! triangle. (Rendering it needs Mitsuba, which CI does not install; measured by hand: Mitsuba 3 at 256 spp
//! vs our pm on cornell-caustics at 320², 8×8-block relMSE 0.00036, image means within 0.1 %.)

mod common;
use common::*;

#[test]
fn export_writes_camera_materials_lights_and_all_triangles() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-caustics.toml");
    let r = run(&[
        "export-mitsuba",
        scene.to_str().unwrap(),
        d.path().to_str().unwrap(),
        "--spp",
        "64",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let xml = std::fs::read_to_string(d.path().join("scene.xml")).unwrap();
    for needle in [
        r#"name="fov" value="39""#,
        r#"<rfilter type="box"/>"#,
        r#"type="dielectric""#,
        r#"type="conductor""#,
        r#"<emitter type="area">"#,
        r#"name="width" value="320""#,
        r#"value="64""#,
    ] {
        assert!(xml.contains(needle), "{needle} missing");
    }
    let loaded = pmrender::scene::load(&scene).unwrap();
    let mut faces = 0;
    for e in std::fs::read_dir(d.path()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().and_then(|x| x.to_str()) == Some("obj") {
            assert!(xml.contains(p.file_name().unwrap().to_str().unwrap()));
            faces += std::fs::read_to_string(&p)
                .unwrap()
                .lines()
                .filter(|l| l.starts_with("f "))
                .count();
        }
    }
    assert_eq!(faces, loaded.geometry.triangles.len());
}

/// Every file the export would write is checked against the files the scene reads before anything is
/// written: a scene named `scene.xml` exported into its own folder, or an input OBJ named like an
/// output group (`mesh_0_2.obj`), was overwritten.
#[test]
fn export_never_overwrites_its_inputs() {
    let listing = |d: &std::path::Path| {
        let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| {
                let p = e.unwrap().path();
                (p.display().to_string(), std::fs::read(&p).unwrap())
            })
            .collect();
        v.sort();
        v
    };
    let scene_xml = room();
    let d = scene_xml.path();
    std::fs::rename(d.join("scene.toml"), d.join("scene.xml")).unwrap();
    let obj_named_like_a_group = room();
    let e = obj_named_like_a_group.path();
    std::fs::rename(e.join("room.obj"), e.join("mesh_0_2.obj")).unwrap();
    let toml = std::fs::read_to_string(e.join("scene.toml")).unwrap();
    std::fs::write(
        e.join("scene.toml"),
        toml.replace("room.obj", "mesh_0_2.obj"),
    )
    .unwrap();
    for (dir, scene, what) in [
        (d, "scene.xml", "the scene file"),
        (e, "scene.toml", "the OBJ file"),
    ] {
        let before = listing(dir);
        let r = run(&["export-mitsuba", &p(dir, scene), dir.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains("DIR") && stderr.contains(what), "{stderr}");
        assert_eq!(listing(dir), before, "nothing written, nothing changed");
    }
    // Exported elsewhere, the same scenes are fine.
    let out = tempfile::tempdir().unwrap();
    let r = run(&[
        "export-mitsuba",
        &p(d, "scene.xml"),
        out.path().to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
}

/// Exports `mtl` for an OBJ of three quads using materials `a`, `b` and `c` (images `images` beside
/// it) and returns the export's folder and its scene.xml.
fn export_quads(mtl: &str, images: &[(&str, Vec<u8>)]) -> (tempfile::TempDir, String) {
    let mut obj = String::from("mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n");
    for (k, m) in ["a", "b", "c"].iter().enumerate() {
        let x = 3.0 * k as f32;
        obj += &format!(
            "v {} 0 1\nv {} 0 1\nv {} 0 -1\nv {} 0 -1\nusemtl {m}\nf {}/1 {}/2 {}/3 {}/4\n",
            x - 1.0,
            x + 1.0,
            x + 1.0,
            x - 1.0,
            4 * k + 1,
            4 * k + 2,
            4 * k + 3,
            4 * k + 4
        );
    }
    let d = scene_dir(&[
        ("m.obj", &obj),
        ("m.mtl", mtl),
        (
            "s.toml",
            "version = 1\n[camera]\neye = [3.0, 4.0, 4.0]\ntarget = [3.0, 0.0, 0.0]\n\
             fov = 45.0\nwidth = 16\nheight = 12\n[[mesh]]\nobj = \"m.obj\"\n[[light]]\ntype = \"point\"\n\
             position = [3.0, 2.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n",
        ),
    ]);
    for (name, bytes) in images {
        std::fs::write(d.path().join(name), bytes).unwrap();
    }
    let out = d.path().join("mi");
    let r = run(&[
        "export-mitsuba",
        &p(d.path(), "s.toml"),
        out.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let xml = std::fs::read_to_string(out.join("scene.xml")).unwrap();
    (d, xml)
}

/// The shape line of the material whose Kd is `kd` (each material of a test has its own).
fn shape_of<'a>(xml: &'a str, kd: &str) -> &'a str {
    let needle = format!(r#"name="reflectance" value="{kd}""#);
    xml.lines().find(|l| l.contains(&needle)).expect(xml)
}

/// A binary PGM (P5) of `w` × `h` texels, each `grey`.
fn pgm(w: u32, h: u32, grey: u8) -> Vec<u8> {
    let mut b = format!("P5\n{w} {h}\n255\n").into_bytes();
    b.extend(std::iter::repeat_n(grey, (w * h) as usize));
    b
}

/// A material with `map_d` is wrapped in Mitsuba 3's `mask`, outside its bump map's `bumpmap`, the
/// opacity its mask image read raw, bilinearly and wrapping; one without `map_d` has no mask. A mask
/// read from alpha, which Mitsuba's `bitmap` drops, is written as an EXR of the alpha values.
#[test]
fn export_wraps_cutouts_in_a_mask_outside_the_bump_map() {
    let dir = tempfile::tempdir().unwrap();
    let rgba = dir.path().join("leaf.png");
    // 2×1: white, opaque then transparent.
    pmrender::io::oiio::write(
        &rgba,
        2,
        1,
        &["R", "G", "B", "A"],
        pmrender::io::oiio::Pixels::U8(&[255, 255, 255, 255, 255, 255, 255, 0]),
    )
    .unwrap();
    let (d, xml) = export_quads(
        "newmtl a\nKd 0.5 0.1 0.1\nmap_d -clamp on cut.pgm\nbump -bm 0.25 h.pgm\n\
         newmtl b\nKd 0.1 0.5 0.1\nbump -bm 0.25 h.pgm\n\
         newmtl c\nKd 0.1 0.1 0.5\nmap_d leaf.png\n",
        &[
            ("cut.pgm", pgm(4, 4, 255)),
            ("h.pgm", pgm(4, 4, 128)),
            ("leaf.png", std::fs::read(&rgba).unwrap()),
        ],
    );
    let opacity = r#"<bsdf type="mask"><texture type="bitmap" name="opacity"><boolean name="raw" value="true"/><string name="filter_type" value="bilinear"/><string name="wrap_mode" value="repeat"/><string name="filename" value=""#;
    let a = shape_of(&xml, "0.5 0.1 0.1");
    let (mask, bump) = (a.find(opacity).expect(a), a.find("bumpmap").expect(a));
    assert!(mask < bump, "the mask wraps the bump map: {a}");
    let file = &a[mask + opacity.len()..];
    let cut = std::fs::canonicalize(d.path().join("cut.pgm")).unwrap();
    assert!(file.starts_with(&format!("{}\"", cut.display())), "{a}");
    assert!(
        a.ends_with("</bsdf></bsdf></bsdf></bsdf></shape>"),
        "mask(bumpmap(twosided(diffuse))): {a}"
    );
    let b = shape_of(&xml, "0.1 0.5 0.1");
    assert!(!b.contains("mask") && b.contains("bumpmap"), "{b}");
    let c = shape_of(&xml, "0.1 0.1 0.5");
    let at = c.find(opacity).expect(c) + opacity.len();
    let name = &c[at..at + c[at..].find('"').unwrap()];
    assert!(name.starts_with("mask_") && name.ends_with(".exr"), "{c}");
    let alpha = pmrender::io::oiio::read(&d.path().join("mi").join(name)).unwrap();
    assert_eq!(
        (alpha.width, alpha.height, alpha.channels, alpha.data),
        (2, 1, 1, vec![1.0, 0.0])
    );
    assert!(xml.contains(r#"<integrator type="volpath">"#), "{xml}");

    let (_d, xml) = export_quads(
        "newmtl a\nKd 0.5 0.1 0.1\nbump -bm 0.25 h.pgm\nnewmtl b\nKd 0.1 0.5 0.1\n\
         newmtl c\nKd 0.1 0.1 0.5\n",
        &[("h.pgm", pgm(4, 4, 128))],
    );
    assert!(!xml.contains("mask"), "{xml}");
    assert!(xml.contains(r#"<integrator type="path">"#), "{xml}");
}

/// Whether `xml` is well-formed as far as an XML reader's tokenizer sees it: every `<` opens a tag
/// that closes with `>`, attribute values are quoted and hold neither `<` nor their own quote, and
/// every `&` starts one of XML's five entities or a character reference. Returns the first fault.
fn xml_fault(xml: &str) -> Option<String> {
    let entity_ok = |rest: &str| {
        ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;"]
            .iter()
            .any(|e| rest.starts_with(e))
            || (rest.starts_with("&#") && rest[2..].find(';').is_some_and(|k| k > 0))
    };
    let b = xml.as_bytes();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'&' if !entity_ok(&xml[i..]) => return Some(format!("bare & at {i}")),
            b'>' => return Some(format!("bare > at {i}")),
            b'<' => {
                // Inside a tag: names, spaces, `=`, `/` and quoted values up to its `>`.
                i += 1;
                loop {
                    match b.get(i) {
                        None => return Some("unclosed tag".into()),
                        Some(b'>') => break,
                        Some(b'<') => return Some(format!("< inside a tag at {i}")),
                        Some(&q) if q == b'"' || q == b'\'' => {
                            let Some(k) = xml[i + 1..].find(q as char) else {
                                return Some(format!("unterminated value at {i}"));
                            };
                            let end = i + 1 + k;
                            let value = &xml[i + 1..end];
                            if value.contains('<') {
                                return Some(format!("< in the value {value}"));
                            }
                            if let Some(k) = value.find('&').filter(|&k| !entity_ok(&value[k..])) {
                                return Some(format!("bare & in the value {value} at {k}"));
                            }
                            i = end;
                        }
                        Some(&c) if c.is_ascii_alphanumeric() || b" \n\t=/_-:.?!".contains(&c) => {}
                        Some(&c) => return Some(format!("{:?} inside a tag at {i}", c as char)),
                    }
                    i += 1;
                }
            }
            _ => {}
        }
        i += 1;
    }
    None
}

/// The value of XML attribute text `v` with its entities replaced.
fn unescape(v: &str) -> String {
    v.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// Image files named with `&`, `<`, `>`, `"` and `'` (a texture, a height map, a mask) give a
/// well-formed scene.xml whose filename values, unescaped, are the files' paths.
#[test]
fn export_escapes_file_names_in_the_xml() {
    let names = ["a&b<c>.ppm", "h\"1'&.pgm", "m<&>'.pgm"];
    let mtl = format!(
        "newmtl a\nKd 0.5 0.1 0.1\nmap_Kd {}\nnewmtl b\nKd 0.1 0.5 0.1\nbump -bm 0.25 {}\n\
         newmtl c\nKd 0.1 0.1 0.5\nmap_d {}\n",
        names[0], names[1], names[2]
    );
    let images = [
        (names[0], b"P6\n1 1\n255\n\x80\x40\x20".to_vec()),
        (names[1], pgm(2, 2, 100)),
        (names[2], pgm(2, 2, 255)),
    ];
    let (d, xml) = export_quads(&mtl, &images);
    assert_eq!(xml_fault(&xml), None, "{xml}");
    let key = r#"<string name="filename" value=""#;
    let values: Vec<String> = xml
        .match_indices(key)
        .map(|(at, _)| {
            let start = at + key.len();
            unescape(&xml[start..start + xml[start..].find('"').unwrap()])
        })
        .collect();
    for name in names {
        let path = std::fs::canonicalize(d.path().join(name)).unwrap();
        assert!(
            values.iter().any(|v| std::path::Path::new(v) == path),
            "{name}: {values:?}"
        );
    }
    // The check itself finds what an unescaped name would have written.
    assert!(xml_fault(r#"<string name="filename" value="a&b<c>.ppm"/>"#).is_some());
    assert!(xml_fault(r#"<string name="filename" value="h"1'.pgm"/>"#).is_some());
}
