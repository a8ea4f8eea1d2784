//! The geometry's answer to "how much of this estimate's disc is surface" (`SceneCoverage`), on scenes
//! where the answer is known: a floor that ends, a floor under a wall, a cylinder, stacked slats.

mod common;

use glam::Vec3;
use photon::Coverage;
use pmrender::photons::coverage::SceneCoverage;

/// Loads a scene made of `obj` (faces of material `m`) with a point light, from a temp dir.
fn scene(obj: &str) -> (tempfile::TempDir, pmrender::scene::Scene) {
    let toml = "version = 1\n[camera]\neye = [0.0, 3.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 45.0\nwidth = 8\nheight = 8\n\n\
                [[mesh]]\nobj = \"s.obj\"\n\n[[light]]\ntype = \"point\"\nposition = [0.0, 2.0, 0.0]\nintensity = [1.0, 1.0, 1.0]\n";
    let d = common::scene_dir(&[
        ("s.obj", &format!("mtllib s.mtl\nusemtl m\n{obj}")),
        ("s.mtl", "newmtl m\nKd 0.5 0.5 0.5\n"),
        ("scene.toml", toml),
    ]);
    let s = pmrender::scene::load(&d.path().join("scene.toml")).expect("scene loads");
    (d, s)
}

/// A quad at height `y` over x ∈ [x0, x1], z ∈ [z0, z1], facing +y; `base` is the first vertex index.
fn quad_y(y: f32, (x0, x1): (f32, f32), (z0, z1): (f32, f32), base: usize) -> String {
    format!(
        "v {x0} {y} {z1}\nv {x1} {y} {z1}\nv {x1} {y} {z0}\nv {x0} {y} {z0}\nf {} {} {} {}\n",
        base + 1,
        base + 2,
        base + 3,
        base + 4
    )
}

#[test]
fn a_floor_that_ends_covers_the_part_of_the_disc_over_it() {
    let (_d, s) = scene(&quad_y(0.0, (-2.0, 0.0), (-2.0, 2.0), 0));
    let cov = SceneCoverage(&s);
    let at = |x: f32| {
        cov.measure(Vec3::new(x, 0.0, 0.0), Vec3::Y, 0.5, 0.1)
            .fraction
    };
    // 24 probes: the fraction is good to about one probe (1/24).
    assert!((at(-1.0) - 1.0).abs() < 0.05, "inside: {}", at(-1.0));
    assert!((at(0.0) - 0.5).abs() < 0.08, "on the edge: {}", at(0.0));
    // 0.25 past the centre line of a disc of radius 0.5: the circular segment is 19.6 % of the disc.
    assert!(
        (at(-0.25) - (1.0 - 0.196)).abs() < 0.08,
        "a quarter radius inside: {}",
        at(-0.25)
    );
}

#[test]
fn a_slat_close_above_thins_the_slab_and_counts_once() {
    // Two parallel floors 3 cm apart: the slab of the lower one stops halfway to the upper one.
    let obj = quad_y(0.0, (-2.0, 2.0), (-2.0, 2.0), 0) + &quad_y(0.03, (-2.0, 2.0), (-2.0, 2.0), 4);
    let (_d, s) = scene(&obj);
    let disc = SceneCoverage(&s).measure(Vec3::ZERO, Vec3::Y, 0.5, 0.1);
    assert!((disc.half_thickness - 0.015).abs() < 1e-3, "{disc:?}");
    assert!((disc.fraction - 1.0).abs() < 0.05, "{disc:?}");
    // Alone, the floor keeps the slab it was given.
    let (_d, s) = scene(&quad_y(0.0, (-2.0, 2.0), (-2.0, 2.0), 0));
    assert_eq!(
        SceneCoverage(&s)
            .measure(Vec3::ZERO, Vec3::Y, 0.5, 0.1)
            .half_thickness,
        0.1
    );
}

#[test]
fn a_curved_surface_counts_its_true_area() {
    // A cylinder of radius 1 along z, faceted finely; the query on top, facing +y. Over the disc of
    // radius 0.4 within 0.1 of the tangent plane the surface reaches |x| ≤ sin(acos 0.9) = 0.436 > 0.4,
    // so the whole disc is over surface, and the true area exceeds the projected one by up to 1/cos.
    let n = 720;
    let mut obj = String::new();
    for i in 0..n {
        let a = std::f32::consts::TAU * i as f32 / n as f32;
        obj += &format!(
            "v {} {} -2\nv {} {} 2\n",
            a.cos(),
            a.sin(),
            a.cos(),
            a.sin()
        );
    }
    for i in 0..n {
        let (a, b) = (2 * i + 1, 2 * ((i + 1) % n) + 1);
        obj += &format!("f {a} {b} {} {}\n", b + 1, a + 1);
    }
    let (_d, s) = scene(&obj);
    let f = SceneCoverage(&s)
        .measure(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 0.4, 0.1)
        .fraction;
    // Mean of 1/cos over the disc: ≈ 1.03; projected area alone would give 1.
    assert!(f > 1.01 && f < 1.08, "{f}");
}
