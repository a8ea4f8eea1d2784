//! `pmrender export-mitsuba SCENE.toml DIR`: the scene as a Mitsuba 3 scene (scene.xml + one OBJ per
//! material group, transforms applied), for rendering independent references. Same camera (vertical fov,
//! box filter), materials, lights and resolution. The glossy model has no Mitsuba 3 plugin: it is written
//! as `pm_phong`, which `tools/mref_phong.py` registers (tools/mitsuba_reference.py renders these scenes).
//! Participating media become `homogeneous` media (albedo, σt, HG phase) attached to their boundary
//! shapes as interior/exterior, the camera's by reference in the sensor, rendered by `volpath`.
//! A `map_d` cutout becomes a `mask` BSDF around the material's; where Mitsuba would read a map's
//! image differently from us (a mask in an alpha channel, a normal map at a strength other than 1),
//! the export writes the values we read as an EXR beside the XML.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use crate::error::{option, Error, Result};
use crate::io::atomic::{CreatedDirs, OutputSet};
use crate::io::oiio::{self, Pixels};
use crate::light::Light;
use crate::medium::{MediumId, VACUUM};
use crate::render::outputs::{check_distinct, scene_inputs, Output};
use crate::scene::Scene;

mod bsdf;

fn rgb(name: &str, c: Vec3) -> String {
    format!(r#"<rgb name="{name}" value="{} {} {}"/>"#, c.x, c.y, c.z)
}

/// `text` as the value of an XML attribute (in double quotes): the five characters XML gives a meaning
/// (`&`, `<`, `>`, `"`, `'`) as their entities, so that a file named `a&b.png` leaves scene.xml readable.
fn xml_attr(text: &str) -> Cow<'_, str> {
    if !text.contains(['&', '<', '>', '"', '\'']) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

fn v(p: Vec3) -> String {
    format!("{}, {}, {}", p.x, p.y, p.z)
}

/// A file of the export: text (the XML, the OBJs) or a float image (EXR) of values we read from one
/// of the scene's maps.
enum Body<'a> {
    Text(String),
    Image {
        width: u32,
        height: u32,
        channels: &'static [&'static str],
        values: Cow<'a, [f32]>,
    },
}

/// An exported file's name in DIR and its contents.
type File<'a> = (String, Body<'a>);

/// A group of triangles written as one OBJ shape: material, kind ([`EMISSIVE`], [`SMOOTH`] or
/// [`FLAT`]) and, for a medium's boundary, the media on the normal's side and behind it.
type GroupKey = (usize, u8, Option<[MediumId; 2]>);
/// Triangles of an emitting material, written flat.
const EMISSIVE: u8 = 0;
/// Triangles with vertex normals.
const SMOOTH: u8 = 1;
/// Other triangles, written flat.
const FLAT: u8 = 2;

/// Writes DIR/scene.xml, DIR/mesh_<material>_<kind>.obj and the images the BSDFs need
/// (`mask_<material>.exr`, `normal_<material>.exr`): all of them or none. A file that would
/// overwrite one the scene reads (the scene itself, an OBJ, MTL or texture: `export-mitsuba scene.xml .`
/// or an input named `mesh_0_2.obj` in DIR) is refused before anything is written, and the folders
/// this command made are removed again when it fails or `cancel` is set (a signal).
pub fn export_mitsuba(scene: &Scene, dir: &Path, spp: u32, cancel: &AtomicBool) -> Result<()> {
    let files = mitsuba_files(scene, spp);
    let paths: Vec<PathBuf> = files.iter().map(|(name, _)| dir.join(name)).collect();
    let outputs: Vec<Output> = paths.iter().map(|p| ("DIR", p.as_path())).collect();
    check_distinct(&outputs, &scene_inputs(&scene.path))?;
    let interrupted = || {
        if cancel.load(Ordering::SeqCst) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    };
    interrupted()?;
    let dirs = CreatedDirs::create(dir)
        .map_err(|e| option("DIR", format!("cannot create '{}': {e}", dir.display())))?;
    let mut set = OutputSet::new();
    for ((_, body), path) in files.iter().zip(&paths) {
        match body {
            Body::Text(text) => set.stage_bytes(path, text.as_bytes())?,
            Body::Image {
                width,
                height,
                channels,
                values,
            } => set.stage(path, |tmp| {
                oiio::write(tmp, *width, *height, channels, Pixels::F32(values))
            })?,
        }
        interrupted()?;
    }
    set.commit()?;
    dirs.keep();
    Ok(())
}

/// The files of the export, by name: one OBJ per triangle group, the images of the materials'
/// BSDFs, then scene.xml.
fn mitsuba_files(scene: &Scene, spp: u32) -> Vec<File<'_>> {
    let mut files = Vec::new();
    let mut images = Vec::new();
    // Each material's BSDF once, however many groups share it.
    let mut bsdfs: BTreeMap<usize, String> = BTreeMap::new();
    let mut xml = String::from("<scene version=\"3.0.0\">\n");
    media_xml(&mut xml, scene);
    integrator_and_sensor_xml(&mut xml, scene, spp);
    for (g, (key, tris)) in triangle_groups(scene).iter().enumerate() {
        let (m, kind, sides) = *key;
        let name = if sides.is_some() {
            format!("mesh_{m}_{kind}_b{g}.obj")
        } else {
            format!("mesh_{m}_{kind}.obj")
        };
        let bsdf = bsdfs
            .entry(m)
            .or_insert_with(|| bsdf::bsdf_xml(scene, m, &mut images));
        shape_xml(&mut xml, scene, key, &name, bsdf);
        files.push((name, Body::Text(group_obj(scene, kind, tris))));
    }
    files.append(&mut images);
    for l in &scene.lights.lights {
        if let Some(line) = light_xml(l) {
            let _ = writeln!(xml, "  {line}");
        }
    }
    xml.push_str("</scene>\n");
    files.push(("scene.xml".into(), Body::Text(xml)));
    files
}

/// The scene's triangles grouped by [`GroupKey`], in key order.
fn triangle_groups(scene: &Scene) -> BTreeMap<GroupKey, Vec<u32>> {
    let mut groups: BTreeMap<GroupKey, Vec<u32>> = BTreeMap::new();
    for (i, t) in scene.geometry.triangles.iter().enumerate() {
        let emissive = scene.materials[t.material as usize].emission.max_element() > 0.0;
        let kind = if emissive {
            EMISSIVE
        } else if t.has_normals {
            SMOOTH
        } else {
            FLAT
        };
        let sides = scene.media.as_ref().and_then(|m| m.sides(i as u32));
        groups
            .entry((t.material as usize, kind, sides))
            .or_default()
            .push(i as u32);
    }
    groups
}

fn medium_id(m: MediumId) -> String {
    format!("medium{m}")
}

/// One homogeneous medium element per medium of the scene.
fn media_xml(xml: &mut String, scene: &Scene) {
    let Some(media) = &scene.media else { return };
    for (k, m) in media.list.iter().enumerate() {
        let _ = writeln!(
            xml,
            r#"  <medium type="homogeneous" id="{}">{}{}<phase type="hg"><float name="g" value="{}"/></phase></medium>"#,
            medium_id(k as MediumId),
            rgb("albedo", m.albedo()),
            rgb("sigma_t", m.sigma_t),
            m.g
        );
    }
}

/// The integrator and the camera as a perspective sensor with `spp` samples. The integrator is
/// `volpath` with media or cutouts: Mitsuba's `path` lets camera rays through a `mask` but stops
/// shadow rays at it (a cut card's holes would cast shadows).
fn integrator_and_sensor_xml(xml: &mut String, scene: &Scene, spp: u32) {
    let cam = &scene.camera;
    let (eye, target, up) = (cam.eye, cam.eye + cam.forward(), cam.up_vector());
    let integrator = if scene.media.is_some() || scene.has_cutouts() {
        "volpath"
    } else {
        "path"
    };
    let _ = writeln!(
        xml,
        r#"  <integrator type="{integrator}"><integer name="max_depth" value="{}"/></integrator>"#,
        scene.settings.max_depth + 1
    );
    let camera_medium = match scene.camera_medium() {
        VACUUM => String::new(),
        m => format!(r#"<ref id="{}"/>"#, medium_id(m)),
    };
    let _ = writeln!(
        xml,
        r#"  <sensor type="perspective"><string name="fov_axis" value="y"/><float name="fov" value="{}"/><transform name="to_world"><lookat origin="{}" target="{}" up="{}"/></transform><sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler><film type="hdrfilm"><integer name="width" value="{}"/><integer name="height" value="{}"/><rfilter type="box"/><string name="pixel_format" value="rgb"/></film>{camera_medium}</sensor>"#,
        cam.fov_deg(),
        v(eye),
        v(target),
        v(up),
        cam.width,
        cam.height
    );
}

/// The OBJ text of a group's triangles, each with its own three vertices (and normals for
/// [`SMOOTH`] ones).
fn group_obj(scene: &Scene, kind: u8, tris: &[u32]) -> String {
    let mut obj = String::new();
    for &ti in tris {
        let t = &scene.geometry.triangles[ti as usize];
        let mut vs = t.v;
        if kind == EMISSIVE && scene.geometry.emit_normal(ti).dot(t.ng) < 0.0 {
            vs.swap(1, 2); // Mitsuba emits along the face normal: wind it toward our emitting side.
        }
        for k in vs {
            let p = scene.geometry.positions[k as usize];
            let uv = scene.geometry.uvs[k as usize];
            let _ = writeln!(obj, "v {} {} {}\nvt {} {}", p.x, p.y, p.z, uv.x, uv.y);
            if kind == SMOOTH {
                let n = scene.geometry.normals[k as usize];
                let _ = writeln!(obj, "vn {} {} {}", n.x, n.y, n.z);
            }
        }
    }
    for i in 0..tris.len() {
        let b = 3 * i + 1;
        let _ = match kind {
            SMOOTH => writeln!(
                obj,
                "f {b}/{b}/{b} {}/{}/{} {}/{}/{}",
                b + 1,
                b + 1,
                b + 1,
                b + 2,
                b + 2,
                b + 2
            ),
            _ => writeln!(obj, "f {b}/{b} {}/{} {}/{}", b + 1, b + 1, b + 2, b + 2),
        };
    }
    obj
}

/// The shape element of a group written to `file`: its BSDF (`bsdf`), its emitter if it emits, and
/// the media on its sides if it bounds a medium.
fn shape_xml(xml: &mut String, scene: &Scene, key: &GroupKey, file: &str, bsdf: &str) {
    let (m, kind, sides) = *key;
    // Mitsuba's interior is behind the face normal, which is our winding normal here.
    let interface: String = match sides {
        Some([front, back]) => [("interior", back), ("exterior", front)]
            .iter()
            .filter(|(_, id)| *id != VACUUM)
            .map(|(side, id)| format!(r#"<ref name="{side}" id="{}"/>"#, medium_id(*id)))
            .collect(),
        None => String::new(),
    };
    let mat = &scene.materials[m];
    let emitter = if kind == EMISSIVE {
        format!(
            r#"<emitter type="area">{}</emitter>"#,
            rgb("radiance", mat.emission)
        )
    } else {
        String::new()
    };
    let flat = if kind == SMOOTH {
        ""
    } else {
        r#"<boolean name="face_normals" value="true"/>"#
    };
    let _ = writeln!(
        xml,
        r#"  <shape type="obj"><string name="filename" value="{file}"/>{flat}{bsdf}{emitter}{interface}</shape>"#
    );
}

/// The emitter element of a point, spot or directional light; `None` for an area light, which is
/// its shape's emitter.
fn light_xml(l: &Light) -> Option<String> {
    let line = match *l {
        Light::Area { .. } => return None,
        Light::Point { pos, intensity } => format!(
            r#"<emitter type="point"><point name="position" value="{}"/>{}</emitter>"#,
            v(pos),
            rgb("intensity", intensity)
        ),
        Light::Spot {
            pos,
            dir,
            intensity,
            cone,
            falloff,
        } => format!(
            r#"<emitter type="spot"><transform name="to_world"><lookat origin="{}" target="{}" up="{}"/></transform>{}<float name="cutoff_angle" value="{}"/><float name="beam_width" value="{}"/></emitter>"#,
            v(pos),
            v(pos + dir),
            v(if dir.y.abs() > 0.9 { Vec3::X } else { Vec3::Y }),
            rgb("intensity", intensity),
            cone.to_degrees(),
            falloff.to_degrees()
        ),
        Light::Directional {
            dir, irradiance, ..
        } => format!(
            r#"<emitter type="directional"><vector name="direction" value="{}"/>{}</emitter>"#,
            v(dir),
            rgb("irradiance", irradiance)
        ),
    };
    Some(line)
}
