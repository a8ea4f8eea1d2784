//! The scene file's `[camera]` and `[render]` tables, checked when the scene is loaded; every message
//! names the key at fault and its line.

use glam::Vec3;

use super::build::Ctx;
use super::file::SceneFile;
use super::limits::{self, MAX_COORD};
use super::{Method, RenderSettings, METHODS};
use crate::camera::Camera;
use crate::error::Result;

/// Largest `spp` and `max_depth`.
pub const MAX_SPP: i64 = 1 << 20;
pub const MAX_DEPTH: i64 = 1024;
/// Largest image side.
pub const MAX_SIDE: i64 = 65536;

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// The camera: `eye` within the coordinate limit, `target` any finite point other than `eye` (only its
/// direction matters), `up` non-zero and not parallel to the view.
pub(super) fn camera(cx: &Ctx, desc: &SceneFile) -> Result<Camera> {
    let c = &desc.camera;
    let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
    for (k, v) in [("eye", c.eye), ("target", c.target), ("up", up)] {
        if !finite3(v) {
            return Err(cx.err("camera", 0, k, "must be finite numbers"));
        }
    }
    if let Some(p) = limits::position(Vec3::from(c.eye)) {
        return Err(cx.err("camera", 0, "eye", p));
    }
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(cx.err("camera", 0, "fov", format!("{} is outside (0, 180) degrees", c.fov)));
    }
    for (k, v) in [("width", c.width), ("height", c.height)] {
        if !(1..=MAX_SIDE).contains(&v) {
            return Err(cx.err("camera", 0, k, format!("{v} must be in 1..={MAX_SIDE}")));
        }
    }
    let (eye, target) = (Vec3::from(c.eye), Vec3::from(c.target));
    let Some(fwd) = limits::direction_between(eye, target) else {
        return Err(cx.err("camera", 0, "target", "equals eye"));
    };
    let Some(up_dir) = limits::direction(Vec3::from(up)) else {
        return Err(cx.err("camera", 0, "up", "must be non-zero"));
    };
    if fwd.cross(up_dir).length() < 1e-6 {
        return Err(cx.err("camera", 0, "up", "is parallel to the viewing direction"));
    }
    Ok(Camera::new(eye, target, up_dir, c.fov, c.width as u32, c.height as u32))
}

pub(super) fn settings(cx: &Ctx, desc: &SceneFile) -> Result<RenderSettings> {
    let r = &desc.render;
    let method = match &r.method {
        Some(m) => Some(Method::parse(m).ok_or_else(|| cx.err("render", 0, "method", format!("unknown method '{m}' ({METHODS})")))?),
        None => None,
    };
    let spp = match r.spp {
        Some(s) if !(1..=MAX_SPP).contains(&s) => return Err(cx.err("render", 0, "spp", format!("{s} must be in 1..={MAX_SPP}"))),
        s => s.map(|s| s as u32),
    };
    let noise = match r.noise {
        Some(t) if !(0.0..=1.0).contains(&t) => return Err(cx.err("render", 0, "noise", format!("{t} must be in 0..=1"))),
        t => t.map(|t| t as f32),
    };
    let max_depth = match r.max_depth {
        Some(d) if !(1..=MAX_DEPTH).contains(&d) => return Err(cx.err("render", 0, "max_depth", format!("{d} must be in 1..={MAX_DEPTH}"))),
        d => d.unwrap_or(64) as u32,
    };
    let icache = r.icache.clone().unwrap_or_default();
    check_icache(cx, &icache)?;
    if let Some(r) = r.photons.as_ref().and_then(|p| p.max_radius) {
        if !(r > 0.0 && r <= 2.0 * MAX_COORD) {
            return Err(cx.err("render.photons", 0, "max_radius", format!("{r} is outside (0, {:e}]", 2.0 * MAX_COORD)));
        }
    }
    Ok(RenderSettings { method, spp, noise, seed: r.seed.unwrap_or(0), max_depth, photons: r.photons.clone().unwrap_or_default(), icache })
}

/// `[render.icache]` numbers, each blamed on its own key: accuracies and spacings positive and finite,
/// `min_spacing_px ≤ max_spacing_px`, `pass_b_accuracy ≥ accuracy` (defaults fill the keys not given).
fn check_icache(cx: &Ctx, d: &super::IcacheDesc) -> Result<()> {
    let err = |key: &str, msg: String| cx.err("render.icache", 0, key, msg);
    let defaults = icache::CacheParams::default();
    for (key, v) in [
        ("accuracy", d.accuracy),
        ("pass_b_accuracy", d.pass_b_accuracy),
        ("min_spacing_px", d.min_spacing_px),
        ("max_spacing_px", d.max_spacing_px),
        ("adaptive_threshold", d.adaptive_threshold),
    ] {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => return Err(err(key, format!("{x} must be a positive number"))),
            _ => {}
        }
    }
    let min = d.min_spacing_px.unwrap_or(defaults.min_spacing_px);
    let max = d.max_spacing_px.unwrap_or(defaults.max_spacing_px);
    if min > max {
        let key = if d.min_spacing_px.is_some() { "min_spacing_px" } else { "max_spacing_px" };
        return Err(err(key, format!("min_spacing_px = {min} is larger than max_spacing_px = {max}")));
    }
    let a = d.accuracy.unwrap_or(defaults.accuracy);
    let b = d.pass_b_accuracy.or(defaults.pass_b_accuracy).unwrap_or(a);
    if b < a {
        let key = if d.pass_b_accuracy.is_some() { "pass_b_accuracy" } else { "accuracy" };
        return Err(err(key, format!("pass_b_accuracy = {b} is smaller than accuracy = {a}")));
    }
    match d.rays {
        Some(r) if !(4..=1_000_000).contains(&r) => Err(err("rays", format!("{r} must be in 4..=1000000"))),
        _ => Ok(()),
    }
}
