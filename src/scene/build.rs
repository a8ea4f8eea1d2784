//! Turns a scene file into a [`Scene`]: validates every value, loads meshes and textures, creates lights.

use std::collections::HashMap;
use std::f32::consts::PI;
use std::path::Path;

use glam::{Mat3, Mat4, Vec3};

use super::file::{self, line_of_key, LightDesc, SceneFile};
use super::{mtl, obj, Method, RenderSettings, Scene, METHODS};
use crate::accel::embree::Bvh;
use crate::camera::Camera;
use crate::error::{at_line, in_file, relative_to, runtime, Error, Result};
use crate::geometry::{Geometry, Triangle};
use crate::light::{Light, Lights};
use crate::material::{Bsdf, Material};
use crate::texture::{self, Texture};

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    fn err(&self, table: &str, index: usize, key: &str, msg: impl std::fmt::Display) -> Error {
        let line = line_of_key(self.text, table, index, key);
        let dotted = if table.is_empty() { key.to_string() } else { format!("{table}.{key}") };
        at_line(self.path, line, format!("{dotted}: {msg}"))
    }
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

pub fn load(path: &Path) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| in_file(path, format!("cannot read scene: {e}")))?;
    let desc = file::parse(path, &text)?;
    let cx = Ctx { path, text: &text };
    if let Some(v) = desc.version {
        if v != 1 {
            return Err(cx.err("", 0, "version", format!("unsupported version {v} (this renderer reads 1)")));
        }
    }
    let camera = camera(&cx, &desc)?;
    let settings = settings(&cx, &desc)?;
    let (geometry, mut materials, tex_paths) = meshes(&cx, &desc)?;
    let textures = textures(&cx, &mut materials, tex_paths)?;
    let bounds = geometry.bounds();
    let lights = lights(&cx, &desc, &geometry, &materials, bounds)?;
    let bvh = Bvh::build(&geometry.positions, &geometry.triangles.iter().map(|t| t.v).collect::<Vec<_>>())
        .map_err(runtime)?;
    let fingerprint = fingerprint(&geometry, &materials, &lights);
    Ok(Scene { path: path.to_path_buf(), camera, geometry, materials, textures, lights, bvh, settings, bounds, fingerprint })
}

fn camera(cx: &Ctx, desc: &SceneFile) -> Result<Camera> {
    let c = &desc.camera;
    for (k, v) in [("eye", c.eye), ("target", c.target), ("up", c.up.unwrap_or([0.0, 1.0, 0.0]))] {
        if !finite3(v) {
            return Err(cx.err("camera", 0, k, "must be finite numbers"));
        }
    }
    if !(c.fov > 0.0 && c.fov < 180.0) {
        return Err(cx.err("camera", 0, "fov", format!("{} is outside (0, 180) degrees", c.fov)));
    }
    for (k, v) in [("width", c.width), ("height", c.height)] {
        if !(1..=65536).contains(&v) {
            return Err(cx.err("camera", 0, k, format!("{v} must be in 1..=65536")));
        }
    }
    let (eye, target, up) = (Vec3::from(c.eye), Vec3::from(c.target), Vec3::from(c.up.unwrap_or([0.0, 1.0, 0.0])));
    let fwd = target - eye;
    if fwd.length() == 0.0 {
        return Err(cx.err("camera", 0, "target", "equals eye"));
    }
    if fwd.normalize().cross(up).length() < 1e-6 {
        return Err(cx.err("camera", 0, "up", "is parallel to the viewing direction"));
    }
    Ok(Camera::new(eye, target, up, c.fov, c.width as u32, c.height as u32))
}

fn settings(cx: &Ctx, desc: &SceneFile) -> Result<RenderSettings> {
    let r = &desc.render;
    let method = match &r.method {
        Some(m) => Some(Method::parse(m).ok_or_else(|| cx.err("render", 0, "method", format!("unknown method '{m}' ({METHODS})")))?),
        None => None,
    };
    let spp = match r.spp {
        Some(s) if !(1..=1 << 20).contains(&s) => return Err(cx.err("render", 0, "spp", format!("{s} must be ≥ 1"))),
        s => s.map(|s| s as u32),
    };
    let max_depth = match r.max_depth {
        Some(d) if !(1..=1024).contains(&d) => return Err(cx.err("render", 0, "max_depth", format!("{d} must be in 1..=1024"))),
        d => d.unwrap_or(64) as u32,
    };
    Ok(RenderSettings {
        method,
        spp,
        seed: r.seed.unwrap_or(0),
        max_depth,
        photons: r.photons.clone().unwrap_or_default(),
        icache: r.icache.clone().unwrap_or_default(),
    })
}

fn transform(cx: &Ctx, index: usize, m: &file::MeshDesc) -> Result<Mat4> {
    let s = match &m.scale {
        None => Vec3::ONE,
        Some(file::Scale::Uniform(s)) => Vec3::splat(*s),
        Some(file::Scale::PerAxis(a)) => Vec3::from(*a),
    };
    if !s.is_finite() || s.x * s.y * s.z == 0.0 {
        return Err(cx.err("mesh", index, "scale", "must be finite and non-zero"));
    }
    let r = m.rotate.unwrap_or([0.0; 3]);
    let t = m.translate.unwrap_or([0.0; 3]);
    if !finite3(r) {
        return Err(cx.err("mesh", index, "rotate", "must be finite"));
    }
    if !finite3(t) {
        return Err(cx.err("mesh", index, "translate", "must be finite"));
    }
    let rot = Mat4::from_rotation_z(r[2].to_radians()) * Mat4::from_rotation_y(r[1].to_radians()) * Mat4::from_rotation_x(r[0].to_radians());
    Ok(Mat4::from_translation(Vec3::from(t)) * rot * Mat4::from_scale(s))
}

type TexPaths = Vec<Option<(std::path::PathBuf, String)>>;

fn meshes(cx: &Ctx, desc: &SceneFile) -> Result<(Geometry, Vec<Material>, TexPaths)> {
    let mut geo = Geometry::default();
    let mut materials: Vec<Material> = Vec::new();
    let mut tex_paths: TexPaths = Vec::new();
    let mut by_name: HashMap<String, Vec<usize>> = HashMap::new();
    let mut default_material = None;
    for (mi, m) in desc.mesh.iter().enumerate() {
        let xf = transform(cx, mi, m)?;
        let nxf = Mat3::from_mat4(xf).inverse().transpose();
        let obj_path = relative_to(cx.path, &m.obj);
        if !obj_path.is_file() {
            return Err(cx.err("mesh", mi, "obj", format!("file '{}' not found", obj_path.display())));
        }
        let data = obj::load(&obj_path)?;
        let base = materials.len();
        for tm in &data.materials {
            let (mat, tex) = mtl::from_mtl(tm);
            by_name.entry(mat.name.clone()).or_default().push(materials.len());
            tex_paths.push(tex.map(|t| (data.mtl_dir.clone(), t)));
            materials.push(mat);
        }
        for model in &data.models {
            let mat_index = match model.material {
                Some(k) if k < data.materials.len() => (base + k) as u32,
                _ => *default_material.get_or_insert_with(|| {
                    materials.push(Material { name: "default".into(), bsdf: Bsdf::Diffuse { albedo: Vec3::splat(0.8), texture: None }, emission: Vec3::ZERO });
                    tex_paths.push(None);
                    (materials.len() - 1) as u32
                }),
            };
            append_model(&mut geo, model, &xf, &nxf, mat_index);
        }
    }
    if geo.triangles.is_empty() {
        return Err(at_line(cx.path, 1, "the scene has no triangles (add a [[mesh]] with faces)"));
    }
    for (name, d) in &desc.materials {
        let line = line_of_key(cx.text, &format!("materials.{name}"), 0, "type");
        let Some(idx) = by_name.get(name) else {
            return Err(at_line(cx.path, line, format!("materials.{name}: no mesh uses a material named '{name}'")));
        };
        for &i in idx {
            let was_diffuse = matches!(materials[i].bsdf, Bsdf::Diffuse { .. });
            let tex = mtl::apply_override(cx.path, line, &mut materials[i], d)?;
            let is_diffuse = matches!(materials[i].bsdf, Bsdf::Diffuse { .. });
            if let Some(t) = tex {
                tex_paths[i] = Some((cx.path.parent().unwrap_or(Path::new(".")).to_path_buf(), t));
            } else if !is_diffuse || !was_diffuse {
                tex_paths[i] = None;
            }
        }
    }
    Ok((geo, materials, tex_paths))
}

fn append_model(geo: &mut Geometry, model: &obj::ObjModel, xf: &Mat4, nxf: &Mat3, material: u32) {
    let base = geo.positions.len() as u32;
    let has_normals = model.normals.len() == model.positions.len() && !model.normals.is_empty();
    let has_uv = model.uvs.len() == model.positions.len() && !model.uvs.is_empty();
    for (k, p) in model.positions.iter().enumerate() {
        geo.positions.push(xf.transform_point3(*p));
        let n = if has_normals { (*nxf * model.normals[k]).normalize_or_zero() } else { Vec3::ZERO };
        geo.normals.push(n);
        geo.uvs.push(if has_uv { model.uvs[k] } else { glam::Vec2::ZERO });
    }
    for f in model.indices.chunks_exact(3) {
        let v = [base + f[0], base + f[1], base + f[2]];
        let [a, b, c] = v.map(|i| geo.positions[i as usize]);
        let cross = (b - a).cross(c - a);
        let area = 0.5 * cross.length();
        if !(area > 0.0 && area.is_finite() && cross.normalize().is_finite()) {
            geo.n_degenerate += 1;
            continue;
        }
        geo.triangles.push(Triangle { v, material, ng: cross.normalize(), area, has_normals, has_uv });
    }
}

fn textures(cx: &Ctx, materials: &mut [Material], tex_paths: TexPaths) -> Result<Vec<Texture>> {
    let mut textures = Vec::new();
    let mut loaded: HashMap<std::path::PathBuf, usize> = HashMap::new();
    for (mat, tp) in materials.iter_mut().zip(tex_paths) {
        let Some((dir, name)) = tp else { continue };
        let Some(resolved) = texture::resolve(&dir, &name) else {
            return Err(in_file(cx.path, format!("material '{}': texture '{}' not found in '{}'", mat.name, name, dir.display())));
        };
        let idx = match loaded.get(&resolved) {
            Some(&i) => i,
            None => {
                let t = Texture::load(&resolved).map_err(|e| in_file(&resolved, format!("cannot read texture: {e}")))?;
                textures.push(t);
                loaded.insert(resolved, textures.len() - 1);
                textures.len() - 1
            }
        };
        if let Bsdf::Diffuse { texture, .. } = &mut mat.bsdf {
            *texture = Some(idx);
        }
    }
    Ok(textures)
}

fn lights(cx: &Ctx, desc: &SceneFile, geo: &Geometry, materials: &[Material], bounds: (Vec3, Vec3)) -> Result<Lights> {
    let mut lights = Vec::new();
    let mut n_emissive = 0usize;
    for (i, t) in geo.triangles.iter().enumerate() {
        let le = materials[t.material as usize].emission;
        if le.max_element() > 0.0 {
            n_emissive += 1;
            lights.push(Light::Area { tri: i as u32, le, n: geo.emit_normal(i as u32), area: t.area });
        }
    }
    let center = (bounds.0 + bounds.1) * 0.5;
    let radius = ((bounds.1 - bounds.0).length() * 0.5).max(1e-6);
    for (i, l) in desc.light.iter().enumerate() {
        lights.push(light(cx, i, l, center, radius)?);
    }
    if lights.is_empty() {
        let zero_area_emitters = materials.iter().any(|m| m.emission.max_element() > 0.0) && n_emissive == 0;
        let msg = if zero_area_emitters {
            "the only emitters are triangles of zero area: the scene has no light"
        } else {
            "the scene has no lights (add a [[light]] or a material with Ke > 0)"
        };
        return Err(at_line(cx.path, 1, msg));
    }
    Lights::new(lights, geo.triangles.len()).ok_or_else(|| at_line(cx.path, 1, "every light has zero power"))
}

fn light(cx: &Ctx, i: usize, l: &LightDesc, center: Vec3, radius: f32) -> Result<Light> {
    let need = |k: &str, v: Option<[f32; 3]>| -> Result<Vec3> {
        let v = v.ok_or_else(|| cx.err("light", i, "type", format!("a {} light needs '{k}'", l.kind)))?;
        if !finite3(v) {
            return Err(cx.err("light", i, k, "must be finite"));
        }
        Ok(Vec3::from(v))
    };
    let non_negative = |k: &str, v: Vec3| -> Result<Vec3> {
        if v.min_element() < 0.0 {
            return Err(cx.err("light", i, k, "must be ≥ 0"));
        }
        Ok(v)
    };
    let allowed: &[&str] = match l.kind.as_str() {
        "point" => &["position", "intensity"],
        "spot" => &["position", "target", "intensity", "cone_angle", "falloff_start"],
        "directional" => &["direction", "irradiance"],
        other => return Err(cx.err("light", i, "type", format!("unknown light type '{other}' (point | spot | directional)"))),
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
        return Err(cx.err("light", i, k, format!("does not apply to a {} light", l.kind)));
    }
    Ok(match l.kind.as_str() {
        "point" => Light::Point { pos: need("position", l.position)?, intensity: non_negative("intensity", need("intensity", l.intensity)?)? },
        "spot" => {
            let pos = need("position", l.position)?;
            let target = need("target", l.target)?;
            if (target - pos).length() == 0.0 {
                return Err(cx.err("light", i, "target", "equals position"));
            }
            let cone = l.cone_angle.unwrap_or(30.0);
            if !(cone > 0.0 && cone <= 180.0) {
                return Err(cx.err("light", i, "cone_angle", format!("{cone} must be in (0, 180]")));
            }
            let falloff = l.falloff_start.unwrap_or(cone * 0.75);
            if !(falloff >= 0.0 && falloff <= cone) {
                return Err(cx.err("light", i, "falloff_start", format!("{falloff} must be in [0, cone_angle]")));
            }
            Light::Spot {
                pos,
                dir: (target - pos).normalize(),
                intensity: non_negative("intensity", need("intensity", l.intensity)?)?,
                cone: cone.to_radians().min(PI),
                falloff: falloff.to_radians(),
            }
        }
        _ => {
            let dir = need("direction", l.direction)?;
            if dir.length() == 0.0 {
                return Err(cx.err("light", i, "direction", "must be non-zero"));
            }
            Light::Directional { dir: dir.normalize(), irradiance: non_negative("irradiance", need("irradiance", l.irradiance)?)?, center, radius }
        }
    })
}

/// FNV-1a (the cache file's checksum function) over positions, triangles, materials and lights.
fn fingerprint(geo: &Geometry, materials: &[Material], lights: &Lights) -> u64 {
    let mut bytes: Vec<u8> = Vec::with_capacity(geo.positions.len() * 12 + geo.triangles.len() * 16);
    for p in &geo.positions {
        bytes.extend(p.to_array().iter().flat_map(|x| x.to_le_bytes()));
    }
    for t in &geo.triangles {
        bytes.extend(t.v.iter().chain([&t.material]).flat_map(|k| k.to_le_bytes()));
    }
    for m in materials {
        bytes.extend(format!("{:?}{:?}", m.bsdf, m.emission).bytes());
    }
    for l in &lights.lights {
        bytes.extend(format!("{l:?}").bytes());
    }
    icache::file::fnv1a64(&bytes)
}
