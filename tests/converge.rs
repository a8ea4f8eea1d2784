//! `pmrender converge` writes its table and chart, and the error of the caustic and indirect terms falls
//! as the photon count grows (on the shipped caustic scene, against its Mitsuba reference).

mod common;
use common::*;

#[test]
fn converge_writes_chart_and_errors_fall() {
    let d = tempfile::tempdir().unwrap();
    let scene = repo().join("scenes/cornell-caustics.toml");
    let reference = repo().join("tests/reference/cornell-caustics-path.exr");
    let r = run(&[
        "converge",
        scene.to_str().unwrap(),
        "--photons",
        "3e3,1e4,3e4,1e5",
        "--reference",
        reference.to_str().unwrap(),
        "-o",
        d.path().to_str().unwrap(),
        "--spp",
        "4",
        "--quiet",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    for f in ["converge.md", "converge.json", "converge.png"] {
        assert!(d.path().join(f).exists(), "{f}");
    }
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("converge.json")).unwrap())
            .unwrap();
    let col = |k: &str| -> Vec<f64> {
        rows.as_array()
            .unwrap()
            .iter()
            .map(|r| r[k].as_f64().unwrap_or(f64::NAN))
            .collect()
    };
    let (beauty, caustic, indirect) = (col("beauty"), col("caustic"), col("indirect"));
    // Measured (spp 4): beauty 0.0198 → 0.0138, caustic 0.0029 → 0.00014, indirect 0.0107 → 0.0050
    // (terms against the 1e5 render). Each must fall over the range: caustic by 2×, indirect by 1.25×.
    assert!(beauty[3] < beauty[0], "{beauty:?}");
    assert!(caustic[2] < 0.5 * caustic[0], "{caustic:?}");
    assert!(indirect[2] < 0.8 * indirect[0], "{indirect:?}");
    assert!(
        caustic[3].is_nan() && indirect[3].is_nan(),
        "the largest count is the terms' own reference"
    );
}
