//! The scene file's `[camera]` and `[render]` tables, `[render.photons]` and `[render.icache]`
//! included, checked when the scene is loaded whatever the method; every message names the key at
//! fault and its line. What depends on the image size or the geometry is derived when a render is
//! planned, from values already checked here.

use glam::Vec3;
use photon::Filter;

use super::context::Ctx;
use super::file::{PhotonsDesc, SceneFile};
use super::icache_settings::icache as icache_table;
use super::limits::{self, MAX_COORD};
use super::{Method, RenderSettings, METHODS};
use crate::camera::Camera;
use crate::error::Result;

/// Largest samples-per-pixel count (the scene's `spp`, `--spp`, `--aa-spp`).
pub const MAX_SPP: u32 = 1 << 20;
/// Largest `max_depth`.
pub(crate) const MAX_DEPTH: i64 = 1024;
/// Largest image side (the scene's and `--width`, `--height`).
pub const MAX_SIDE: u32 = 65_536;
/// Longest time budget (`[render] time`, `--time`), in seconds: 115 days.
pub const MAX_TIME_S: f64 = 1e7;
/// Largest photon count (and lookup k, and photons per atlas texel).
pub const MAX_PHOTONS: i64 = 100_000_000;

/// `[render.photons]` checked: the file's values, `None` where the scene decides
/// (`PhotonSettings::resolve` derives those from the geometry when a render is planned).
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonConfig {
    pub global: Option<usize>,
    pub caustic: Option<usize>,
    pub lookup: Option<usize>,
    pub precompute_every: Option<usize>,
    pub max_radius: Option<f32>,
    pub caustic_filter: Filter,
}

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
        return Err(cx.err(
            "camera",
            0,
            "fov",
            format!("{} is outside (0, 180) degrees", c.fov),
        ));
    }
    for (k, v) in [("width", c.width), ("height", c.height)] {
        if !(1..=i64::from(MAX_SIDE)).contains(&v) {
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
    Ok(Camera::new(
        eye,
        target,
        up_dir,
        c.fov,
        c.width as u32,
        c.height as u32,
    ))
}

pub(super) fn settings(cx: &Ctx, desc: &SceneFile) -> Result<RenderSettings> {
    let r = &desc.render;
    let method = match &r.method {
        Some(m) => Some(Method::parse(m).ok_or_else(|| {
            cx.err(
                "render",
                0,
                "method",
                format!("unknown method '{m}' ({METHODS})"),
            )
        })?),
        None => None,
    };
    let spp = match r.spp {
        Some(s) if !(1..=i64::from(MAX_SPP)).contains(&s) => {
            return Err(cx.err("render", 0, "spp", format!("{s} must be in 1..={MAX_SPP}")))
        }
        s => s.map(|s| s as u32),
    };
    let aa_spp = match r.aa_spp {
        Some(s) if !(1..=i64::from(MAX_SPP)).contains(&s) => {
            return Err(cx.err(
                "render",
                0,
                "aa_spp",
                format!("{s} must be in 1..={MAX_SPP}"),
            ))
        }
        s => s.map(|s| s as u32),
    };
    let noise = match r.noise {
        Some(t) if !(0.0..=1.0).contains(&t) => {
            return Err(cx.err("render", 0, "noise", format!("{t} must be in 0..=1")))
        }
        t => t.map(|t| t as f32),
    };
    let max_depth = match r.max_depth {
        Some(d) if !(1..=MAX_DEPTH).contains(&d) => {
            return Err(cx.err(
                "render",
                0,
                "max_depth",
                format!("{d} must be in 1..={MAX_DEPTH}"),
            ))
        }
        d => d.unwrap_or(64) as u32,
    };
    if let Some(d) = r.ao_distance {
        if !(d > 0.0 && d <= 2.0 * MAX_COORD) {
            return Err(cx.err(
                "render",
                0,
                "ao_distance",
                format!("{d} is outside (0, {:e}]", 2.0 * MAX_COORD),
            ));
        }
    }
    let time = match r.time {
        Some(t) if !(t > 0.0 && t <= MAX_TIME_S) => {
            return Err(cx.err(
                "render",
                0,
                "time",
                format!("{t} must be in (0, {MAX_TIME_S:e}] seconds"),
            ))
        }
        t => t,
    };
    let icache = icache_table(cx, &r.icache.clone().unwrap_or_default())?;
    let photons = photons(cx, &r.photons.clone().unwrap_or_default())?;
    Ok(RenderSettings {
        method,
        spp,
        aa_spp,
        noise,
        seed: r.seed.unwrap_or(0),
        max_depth,
        ao_distance: r.ao_distance,
        time,
        photons,
        icache,
    })
}

/// Fewest photons per k-NN estimate. An estimate from k photons is biased by about k/(k − 1) and its
/// variance unbounded at k = 1: a fog's mean came out ×6.2 at k = 1, ×1.20 at k = 2, ×1.12 at k = 5.
pub const MIN_LOOKUP: i64 = 16;

/// `[render.photons]`: counts in range, a positive radius within the coordinate limit, a known filter.
fn photons(cx: &Ctx, d: &PhotonsDesc) -> Result<PhotonConfig> {
    let err = |key: &str, msg: String| cx.err("render.photons", 0, key, msg);
    let count = |key: &str, v: Option<i64>, min: i64| -> Result<Option<usize>> {
        match v {
            Some(x) if x < min || x > MAX_PHOTONS => {
                Err(err(key, format!("{x} must be in {min}..={MAX_PHOTONS}")))
            }
            x => Ok(x.map(|x| x as usize)),
        }
    };
    let global = count("global", d.global, 1)?;
    let caustic = count("caustic", d.caustic, 0)?;
    let lookup = count("lookup", d.lookup, MIN_LOOKUP)?;
    let precompute_every = count("precompute_every", d.precompute_every, 1)?;
    if let Some(r) = d.max_radius {
        if !(r > 0.0 && r <= 2.0 * MAX_COORD) {
            return Err(err(
                "max_radius",
                format!("{r} is outside (0, {:e}]", 2.0 * MAX_COORD),
            ));
        }
    }
    let caustic_filter = match d.caustic_filter.as_deref() {
        None | Some("cone") => Filter::Cone { k: 1.1 },
        Some("none") | Some("box") => Filter::None,
        Some(other) => {
            return Err(err(
                "caustic_filter",
                format!("unknown filter '{other}' (cone | none)"),
            ))
        }
    };
    Ok(PhotonConfig {
        global,
        caustic,
        lookup,
        precompute_every,
        max_radius: d.max_radius,
        caustic_filter,
    })
}
