//! Public assets as exported: files other readers load render here too, with a warning where they lack
//! something.

mod common;

use std::time::Duration;

use common::*;

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
