//! The scene's lights: emissive triangles and `[[light]]` tables, checked for range (positions within
//! the coordinate limit, directions normalised in f64, emission in [0, MAX_EMISSION]) and for a total
//! power that stays finite.

use std::collections::HashMap;
use std::f32::consts::PI;
use std::path::PathBuf;

use glam::Vec3;

use super::context::Ctx;
use super::file::{LightDesc, SceneFile};
use super::limits::{self, MAX_POWER};
use crate::error::{at_line, Error, Result};
use crate::geometry::Geometry;
use crate::light::{Light, Lights};
use crate::material::Material;

/// Where a light's emission was given: a file and line.
pub(super) type Origin = (PathBuf, usize);

/// All lights; `emission_at[m]` is where material `m`'s emission was set.
pub(super) fn lights(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    materials: &[Material],
    emission_at: &[Origin],
) -> Result<Lights> {
    let mut lights = Vec::new();
    let mut origins = Vec::new();
    for (i, t) in geo.triangles.iter().enumerate() {
        let le = materials[t.material as usize].emission;
        if le.max_element() > 0.0 {
            lights.push(Light::Area {
                tri: i as u32,
                le,
                n: geo.emit_normal(i as u32),
                area: t.area,
            });
            origins.push(emission_at[t.material as usize].clone());
        }
    }
    let n_emissive = lights.len();
    let bounds = geo.bounds();
    let center = (bounds.0 + bounds.1) * 0.5;
    let radius = ((bounds.1.as_dvec3() - bounds.0.as_dvec3()).length() * 0.5).max(1e-6) as f32;
    // What a message about a `[[light]]` entry's power names: its key, and for a directional light
    // the bounds its disc covers (a mesh scaled up grows them).
    let mut names: HashMap<Origin, (String, String)> = HashMap::new();
    for (i, l) in desc.light.iter().enumerate() {
        lights.push(light(cx, i, l, center, radius)?);
        let key = if l.kind == "directional" {
            "irradiance"
        } else {
            "intensity"
        };
        let origin = (
            cx.path.to_path_buf(),
            super::file::line_of_key(cx.text, "light", i, key),
        );
        let over = if l.kind == "directional" {
            format!(" over the disc of the scene's bounding sphere (radius {radius:.3e})")
        } else {
            String::new()
        };
        names.insert(origin.clone(), (format!("light.{key}: "), over));
        origins.push(origin);
    }
    if lights.is_empty() {
        let zero_area_emitters =
            materials.iter().any(|m| m.emission.max_element() > 0.0) && n_emissive == 0;
        if zero_area_emitters {
            return Err(at_line(
                cx.path,
                1,
                "the only emitters are triangles of zero area: the scene has no light",
            ));
        }
        // Geometry alone: an occlusion pass renders it; the other methods refuse it at their plan.
        return Ok(Lights::none(geo.triangles.len()));
    }
    check_power(&lights, &origins, &names)?;
    Lights::new(lights, geo.triangles.len())
        .ok_or_else(|| at_line(cx.path, 1, "every light has zero power"))
}

/// Every `[[light]]` entry's values (the checks [`lights`] makes per entry).
pub(super) fn check_lights(cx: &Ctx, desc: &SceneFile) -> Result<()> {
    for (i, l) in desc.light.iter().enumerate() {
        light(cx, i, l, Vec3::ZERO, 1.0)?;
    }
    Ok(())
}

/// Whether some `[[light]]` entry emits (their values checked already by [`check_lights`]).
pub(super) fn some_light_emits(cx: &Ctx, desc: &SceneFile) -> Result<bool> {
    for (i, l) in desc.light.iter().enumerate() {
        if power_f64(&light(cx, i, l, Vec3::ZERO, 1.0)?) > 0.0 {
            return Ok(true);
        }
    }
    Ok(false)
}

/// Emitted power in f64, where the f32 product could overflow.
fn power_f64(l: &Light) -> f64 {
    let pi = std::f64::consts::PI;
    let max = |c: Vec3| c.max_element() as f64;
    match *l {
        Light::Area { le, area, .. } => max(le) * pi * area as f64,
        Light::Point { intensity, .. } => max(intensity) * 4.0 * pi,
        Light::Spot { intensity, .. } => max(intensity) * 4.0 * pi,
        Light::Directional {
            irradiance, radius, ..
        } => max(irradiance) * pi * (radius as f64).powi(2),
    }
}

/// The total emitted power must stay below [`MAX_POWER`]; the message names the largest source, by
/// its key where `names` has one ("light.intensity: …", which a sequence moves to the key's line).
fn check_power(
    lights: &[Light],
    origins: &[Origin],
    names: &HashMap<Origin, (String, String)>,
) -> Result<()> {
    let mut by_origin: HashMap<&Origin, f64> = HashMap::new();
    for (l, o) in lights.iter().zip(origins) {
        *by_origin.entry(o).or_default() += power_f64(l);
    }
    let total: f64 = by_origin.values().sum();
    if total <= MAX_POWER {
        return Ok(());
    }
    let (origin, power) =
        by_origin.into_iter().fold(
            (&origins[0], -1.0),
            |best, (o, p)| if p > best.1 { (o, p) } else { best },
        );
    let (name, over) = names.get(origin).cloned().unwrap_or_default();
    Err(at_line(&origin.0, origin.1, format!("{name}emitted power {power:.3e} W{over} (scene total {total:.3e} W) exceeds the limit of {MAX_POWER:e} W")))
}

/// One `[[light]]` entry with what its messages need to name its keys.
struct Entry<'a> {
    cx: &'a Ctx<'a>,
    i: usize,
    l: &'a LightDesc,
}

impl Entry<'_> {
    fn err(&self, key: &str, msg: impl std::fmt::Display) -> Error {
        self.cx.err("light", self.i, key, msg)
    }

    /// A vector key this light's type needs, finite.
    fn need(&self, k: &str, v: Option<[f32; 3]>) -> Result<Vec3> {
        let v =
            v.ok_or_else(|| self.err("type", format!("a {} light needs '{k}'", self.l.kind)))?;
        if !v.iter().all(|x| x.is_finite()) {
            return Err(self.err(k, "must be finite"));
        }
        Ok(Vec3::from(v))
    }

    fn position(&self, k: &str, v: Option<[f32; 3]>) -> Result<Vec3> {
        let p = self.need(k, v)?;
        limits::position(p).map_or(Ok(p), |msg| Err(self.err(k, msg)))
    }

    fn emission(&self, k: &str, v: Option<[f32; 3]>) -> Result<Vec3> {
        let e = self.need(k, v)?;
        limits::emission(e.to_array()).map_or(Ok(e), |msg| Err(self.err(k, msg)))
    }

    /// The entry's type is known and every key it gives applies to that type.
    fn check_keys(&self) -> Result<()> {
        let l = self.l;
        let allowed: &[&str] = match l.kind.as_str() {
            "point" => &["position", "intensity"],
            "spot" => &[
                "position",
                "target",
                "intensity",
                "cone_angle",
                "falloff_start",
            ],
            "directional" => &["direction", "irradiance"],
            other => {
                return Err(self.err(
                    "type",
                    format!("unknown light type '{other}' (point | spot | directional)"),
                ))
            }
        };
        let given = [
            ("position", l.position.is_some()),
            ("target", l.target.is_some()),
            ("intensity", l.intensity.is_some()),
            ("cone_angle", l.cone_angle.is_some()),
            ("falloff_start", l.falloff_start.is_some()),
            ("direction", l.direction.is_some()),
            ("irradiance", l.irradiance.is_some()),
        ];
        if let Some((k, _)) = given.iter().find(|(k, g)| *g && !allowed.contains(k)) {
            return Err(self.err(k, format!("does not apply to a {} light", l.kind)));
        }
        Ok(())
    }

    fn spot(&self) -> Result<Light> {
        let l = self.l;
        let pos = self.position("position", l.position)?;
        // Only the direction toward the target matters: any finite point will do.
        let Some(dir) = limits::direction_between(pos, self.need("target", l.target)?) else {
            return Err(self.err("target", "equals position"));
        };
        let cone = l.cone_angle.unwrap_or(30.0);
        if !(cone > 0.0 && cone <= 180.0) {
            return Err(self.err("cone_angle", format!("{cone} must be in (0, 180]")));
        }
        let falloff = l.falloff_start.unwrap_or(cone * 0.75);
        if !(falloff >= 0.0 && falloff <= cone) {
            return Err(self.err(
                "falloff_start",
                format!("{falloff} must be in [0, cone_angle]"),
            ));
        }
        let intensity = self.emission("intensity", l.intensity)?;
        Ok(Light::Spot {
            pos,
            dir,
            intensity,
            cone: cone.to_radians().min(PI),
            falloff: falloff.to_radians(),
        })
    }
}

fn light(cx: &Ctx, i: usize, l: &LightDesc, center: Vec3, radius: f32) -> Result<Light> {
    let e = Entry { cx, i, l };
    e.check_keys()?;
    Ok(match l.kind.as_str() {
        "point" => Light::Point {
            pos: e.position("position", l.position)?,
            intensity: e.emission("intensity", l.intensity)?,
        },
        "spot" => e.spot()?,
        _ => {
            let Some(dir) = limits::direction(e.need("direction", l.direction)?) else {
                return Err(e.err("direction", "must be non-zero"));
            };
            Light::Directional {
                dir,
                irradiance: e.emission("irradiance", l.irradiance)?,
                center,
                radius,
            }
        }
    })
}
