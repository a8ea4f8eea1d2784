//! Turns a scene file into a [`Scene`]: validates every value, loads meshes and textures, creates lights.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::{Mat3, Mat4, Vec3};

use super::animation::{at_frame, Animation};
use super::context::Ctx;
use super::file::{self, line_of, line_of_key, SceneFile};
use super::held::{HeldInputs, ImageKey};
use super::input::{self, read_text, MAX_SCENE_BYTES, MAX_TEXTURE_BYTES};
use super::lights::{check_lights, lights, some_light_emits, Origin};
use super::media::{check_camera_medium, media};
use super::settings::{camera, settings};
use super::{limits, mtl, obj, Scene};
use crate::accel::embree::Bvh;
use crate::bump::{BumpMap, Statement};
use crate::camera::Camera;
use crate::cutout::{Cutouts, Mask};
use crate::error::{at_line, in_file, relative_to, Result};
use crate::geometry::{Geometry, Triangle};
use crate::gloss_map::GlossMaps;
use crate::light::Lights;
use crate::material::{Bsdf, Material};
use crate::texture::{self, Texture};

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Loads a scene file; of an animated one, frame 0.
pub fn load(path: &Path) -> Result<Scene> {
    let text = read_text(path, "scene file", MAX_SCENE_BYTES, None)?;
    let desc = file::parse(path, &text)?;
    match Animation::new(path, &text, &desc)? {
        None => build(path, &text, &desc, &HeldInputs::default()),
        Some(a) => load_frame(&a, 0),
    }
}

/// The keys of a scene file with `[animation]`, every frame's camera, mesh placements and light values
/// checked; `None` for a still scene.
pub fn load_animation(path: &Path) -> Result<Option<Animation>> {
    let text = read_text(path, "scene file", MAX_SCENE_BYTES, None)?;
    let desc = file::parse(path, &text)?;
    let Some(anim) = Animation::new(path, &text, &desc)? else {
        return Ok(None);
    };
    anim.check_every_frame(|cx, d| {
        camera(cx, d)?;
        for (i, m) in d.mesh.iter().enumerate() {
            transform(cx, i, m)?;
        }
        check_lights(cx, d)
    })?;
    Ok(Some(anim))
}

/// Frame `f` of an animated scene.
pub fn load_frame(anim: &Animation, f: u32) -> Result<Scene> {
    build(anim.path(), anim.text(), &anim.frame_desc(f), anim.held())
        .map_err(|e| at_frame(anim.at_key_toward(e, f), f))
}

/// What building frames `frames` of `anim` would refuse, found before any of them is rendered
/// (`first`: the scene of the first): each frame's lights without power (unless meshes emit), the
/// camera's declared medium at each frame's eye, and where a mesh moved or a light changed, the
/// frame's meshes and lights as a still's are checked. A frame where a medium's boundary mesh moved is
/// built (its media checked as a still's are), reported to `progress` frame by frame. Stops with
/// `Interrupted` once `cancel` is set.
///
/// Returns the frame whose render needs the most memory where that is more than the first's: the
/// one with the most triangles of those with a mirror or glass triangle if any has one (a scene with
/// one traces a caustic map), else of all. (A keyed scale from zero gives a mesh its triangles.)
pub fn check_sequence(
    anim: &Animation,
    frames: std::ops::RangeInclusive<u32>,
    first: &Scene,
    progress: &dyn crate::progress::Progress,
    cancel: &std::sync::atomic::AtomicBool,
) -> Result<Option<u32>> {
    let cx = Ctx {
        path: anim.path(),
        text: anim.text(),
    };
    let meshes_emit = (0..first.mesh_ranges.len()).any(|m| first.mesh_emits(m));
    let boundaries: Vec<usize> = (0..first.mesh_ranges.len())
        .filter(|&m| anim.is_boundary(m))
        .collect();
    let placed = |f: u32| -> Vec<Option<Mat4>> {
        boundaries
            .iter()
            .map(|&m| mesh_transform(anim, f, m))
            .collect()
    };
    let start = *frames.start();
    let (mut built, mut built_at) = (None, placed(start));
    let needs = |n_triangles: usize, specular: bool| (specular, n_triangles);
    let mut largest = (
        needs(first.geometry.triangles.len(), first.has_specular()),
        None,
    );
    for f in frames {
        if cancel.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(crate::error::Error::Interrupted);
        }
        progress.set(u64::from(f - start));
        let desc = anim.frame_desc(f);
        // A scene without any light renders only as occlusion, which the render's plan checks. (Before
        // the geometry's checks, which know no key line for a light keyed to nothing.)
        let has_lights = meshes_emit || !desc.light.is_empty();
        if has_lights
            && !meshes_emit
            && !some_light_emits(&cx, &desc).map_err(|e| at_frame(e, f))?
        {
            return Err(at_frame(
                at_line(
                    cx.path,
                    anim.light_power_line(f),
                    "every light has zero power",
                ),
                f,
            ));
        }
        // A frame where a mesh moved or a light changed is refused for what its still would be:
        // a vertex past the limits after a keyed scale, an emitted power over the cap (a scaled
        // emitter, a sun over grown bounds), no triangle left.
        if f > start && (!anim.moved_meshes(f - 1, f).is_empty() || anim.lights_changed(f - 1, f)) {
            let (n, specular) = check_geometry(&cx, &desc, anim.held())
                .map_err(|e| at_frame(anim.at_key_toward(e, f), f))?;
            if needs(n, specular) > largest.0 {
                largest = (needs(n, specular), Some(f));
            }
        }
        if f == start || first.media.is_none() {
            continue;
        }
        let at = placed(f);
        if at != built_at {
            built = Some(load_frame(anim, f)?);
            built_at = at;
            continue;
        }
        let scene = built.as_ref().unwrap_or(first);
        if let Some(media) = &scene.media {
            let eye = Vec3::from(desc.camera.eye);
            check_camera_medium(&cx, &desc, &media.list, media.medium_at(eye))
                .map_err(|e| at_frame(e, f))?;
        }
    }
    Ok(largest.1)
}

/// What building a scene from `desc` would refuse in its meshes and lights (see [`meshes`] and
/// [`lights`]), without its textures, media or BVH; else its number of triangles and whether one
/// of them is a mirror or glass.
fn check_geometry(cx: &Ctx, desc: &SceneFile, held: &HeldInputs) -> Result<(usize, bool)> {
    let m = meshes(cx, desc, held)?;
    lights(cx, desc, &m.geo, &m.materials, &m.emission_at)?;
    let specular =
        (m.geo.triangles.iter()).any(|t| m.materials[t.material as usize].bsdf.is_specular());
    Ok((m.geo.triangles.len(), specular))
}

/// The camera of frame `f` (checked by [`load_animation`]).
pub fn frame_camera(anim: &Animation, f: u32) -> Result<Camera> {
    let cx = Ctx {
        path: anim.path(),
        text: anim.text(),
    };
    camera(&cx, &anim.frame_desc(f)).map_err(|e| at_frame(e, f))
}

/// Frame `f`'s camera and each mesh's placement (`None` where it has none), from one reading of the
/// frame's description.
pub fn frame_view(anim: &Animation, f: u32) -> Result<(Camera, Vec<Option<Mat4>>)> {
    let cx = Ctx {
        path: anim.path(),
        text: anim.text(),
    };
    let desc = anim.frame_desc(f);
    let cam = camera(&cx, &desc).map_err(|e| at_frame(e, f))?;
    let placed = (0..desc.mesh.len())
        .map(|m| transform(&cx, m, &desc.mesh[m]).ok())
        .collect();
    Ok((cam, placed))
}

/// Where `[[mesh]]` entry `mesh` is placed at frame `f` (scale → rotate → translate), `None` for no
/// such mesh.
pub fn mesh_transform(anim: &Animation, f: u32, mesh: usize) -> Option<Mat4> {
    let cx = Ctx {
        path: anim.path(),
        text: anim.text(),
    };
    let desc = anim.frame_desc(f);
    transform(&cx, mesh, desc.mesh.get(mesh)?).ok()
}

/// A scene from its parsed file, its OBJ files read through `held`.
fn build(path: &Path, text: &str, desc: &SceneFile, held: &HeldInputs) -> Result<Scene> {
    let cx = Ctx { path, text };
    if let Some(v) = desc.version {
        if v != 1 {
            return Err(cx.err(
                "",
                0,
                "version",
                format!("unsupported version {v} (this renderer reads 1)"),
            ));
        }
    }
    let camera = camera(&cx, desc)?;
    let settings = settings(&cx, desc)?;
    let Meshes {
        geo: geometry,
        mut materials,
        tex_paths,
        mask_paths,
        ks_paths,
        ns_paths,
        bump_paths,
        emission_at,
        mesh_tris,
        warnings,
    } = meshes(&cx, desc, held)?;
    let textures = textures(&cx, &mut materials, tex_paths, held)?;
    let gloss_maps = gloss_maps(&cx, &materials, ks_paths, ns_paths, held)?;
    let (cutouts, mask_files) = cutouts(&cx, &geometry, &materials, mask_paths, held)?;
    let cutouts = cutouts.map(Arc::new);
    let bumps = bumps(&cx, &materials, bump_paths, held)?;
    let normal_mapped = |m: u32| matches!(bumps.get(m as usize), Some(Some(b)) if matches!(**b, BumpMap::Normal { .. }));
    let tangents = crate::tangents::Tangents::new(&geometry, &mesh_tris, normal_mapped);
    let bounds = geometry.bounds();
    let mut lights = lights(&cx, desc, &geometry, &materials, &emission_at)?;
    if let Some(c) = cutouts.as_ref().filter(|c| c.cuts_any(&lights)) {
        lights.cut_by(c.clone());
    }
    let media = media(&cx, desc, &geometry, &materials, &mesh_tris, &lights.lights)?;
    let fingerprint = fingerprint(
        &geometry,
        &materials,
        &textures,
        cutouts.as_deref(),
        &bumps,
        &lights,
        media.as_ref(),
    );
    let triangles: Vec<[u32; 3]> = geometry.triangles.iter().map(|t| t.v).collect();
    let bvh = match &cutouts {
        None => Bvh::build(&geometry.positions, &triangles)?,
        Some(c) => Bvh::build_with_cutout(&geometry.positions, &triangles, Box::new(c.clone()))?,
    };
    // The specular BVH only tells the photon pass whether a path may reach a mirror or glass at all:
    // without the cutouts it answers yes a little more often, never wrongly no.
    let specular: Vec<[u32; 3]> = geometry
        .triangles
        .iter()
        .filter(|t| materials[t.material as usize].bsdf.is_specular())
        .map(|t| t.v)
        .collect();
    let specular_bvh = if specular.is_empty() {
        None
    } else {
        Some(Bvh::build(&geometry.positions, &specular)?)
    };
    let texel_density = super::texel_densities(&geometry, &materials, &textures);
    Ok(Scene {
        path: path.to_path_buf(),
        camera,
        geometry,
        materials,
        textures,
        lights,
        bvh,
        specular_bvh,
        settings,
        bounds,
        fingerprint,
        media,
        mesh_ranges: mesh_tris,
        texel_density,
        gloss_maps,
        bumps,
        tangents,
        cutouts,
        mask_files,
        warnings,
        crossings_given_up: Default::default(),
    })
}

fn transform(cx: &Ctx, index: usize, m: &file::MeshDesc) -> Result<Mat4> {
    let s = match &m.scale {
        None => Vec3::ONE,
        Some(file::Scale::Uniform(s)) => Vec3::splat(*s),
        Some(file::Scale::PerAxis(a)) => Vec3::from(*a),
    };
    if !s.is_finite() || s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
        return Err(cx.err("mesh", index, "scale", "must be finite and non-zero"));
    }
    let r = m.rotate.unwrap_or([0.0; 3]);
    let t = m.translate.unwrap_or([0.0; 3]);
    if !finite3(r) {
        return Err(cx.err("mesh", index, "rotate", "must be finite"));
    }
    if let Some(p) = limits::position(Vec3::from(t)) {
        return Err(cx.err("mesh", index, "translate", p));
    }
    let rot = Mat4::from_rotation_z(r[2].to_radians())
        * Mat4::from_rotation_y(r[1].to_radians())
        * Mat4::from_rotation_x(r[0].to_radians());
    Ok(Mat4::from_translation(Vec3::from(t)) * rot * Mat4::from_scale(s))
}

type TexPaths = Vec<Option<(PathBuf, String)>>;
/// Each material's bump or normal map statement, with the directory its file is in.
type BumpPaths = Vec<Option<(PathBuf, mtl::BumpStatement)>>;

/// Every mesh's triangles (transformed), the materials (MTL, then the scene's overrides) and the images
/// they name, where each material's emission was set, each mesh's triangles, and the warnings about
/// the assets.
struct Meshes {
    geo: Geometry,
    materials: Vec<Material>,
    tex_paths: TexPaths,
    /// Each material's cutout mask (`map_d`).
    mask_paths: TexPaths,
    /// Each material's glossy maps (`map_Ks`, `map_Ns`).
    ks_paths: TexPaths,
    ns_paths: TexPaths,
    /// Each material's bump or normal map.
    bump_paths: BumpPaths,
    emission_at: Vec<Origin>,
    mesh_tris: Vec<std::ops::Range<usize>>,
    warnings: Vec<String>,
}

fn meshes(cx: &Ctx, desc: &SceneFile, held: &HeldInputs) -> Result<Meshes> {
    let mut geo = Geometry::default();
    let mut warnings = Vec::new();
    let mut loaded = LoadedMaterials::default();
    let mut mesh_tris = Vec::with_capacity(desc.mesh.len());
    for (mi, m) in desc.mesh.iter().enumerate() {
        let first_tri = geo.triangles.len();
        let xf = transform(cx, mi, m)?;
        let nxf = Mat3::from_mat4(xf).inverse().transpose();
        let path = obj_path(cx, mi, m)?;
        let data = held.obj(&path)?;
        for (name, line) in &data.undefined {
            let w = undefined_material_warning(&path, *line, name);
            // An OBJ placed by several meshes is warned about once.
            if !desc.materials.contains_key(name) && !warnings.contains(&w) {
                warnings.push(w);
            }
        }
        let base = loaded.materials.len();
        loaded.add_mtl(cx, &data, line_of_key(cx.text, "mesh", mi, "obj"));
        let first_vertex = geo.positions.len();
        for model in &data.models {
            let mat_index = match model.material {
                Some(k) if k < data.materials.len() => (base + k) as u32,
                _ => loaded.default_material(cx),
            };
            append_model(&mut geo, model, &xf, &nxf, mat_index);
        }
        if let Some(p) = geo.positions[first_vertex..]
            .iter()
            .find_map(|p| limits::position(*p))
        {
            return Err(cx.err(
                "mesh",
                mi,
                "obj",
                format!(
                    "a vertex of '{}' at {p} after scale, rotate and translate",
                    m.obj
                ),
            ));
        }
        mesh_tris.push(first_tri..geo.triangles.len());
    }
    if geo.triangles.is_empty() {
        return Err(at_line(
            cx.path,
            1,
            "the scene has no triangles (add a [[mesh]] with faces)",
        ));
    }
    apply_overrides(cx, desc, &mut loaded)?;
    let LoadedMaterials {
        materials,
        tex_paths,
        mask_paths,
        ks_paths,
        ns_paths,
        bump_paths,
        emission_at,
        ..
    } = loaded;
    Ok(Meshes {
        geo,
        materials,
        tex_paths,
        mask_paths,
        ks_paths,
        ns_paths,
        bump_paths,
        emission_at,
        mesh_tris,
        warnings,
    })
}

/// The warning for a `usemtl` name no library of the OBJ defines and the scene file does not either.
/// An asset as exported may lack a material (McGuire's CornellBox-Glossy.mtl has no `light`, which
/// its OBJ uses) and every other reader loads it with a default: so it renders, with a word, since a
/// misspelt name would otherwise render grey unnoticed.
fn undefined_material_warning(obj: &Path, line: usize, name: &str) -> String {
    format!(
        "{}:{line}: usemtl '{name}': no material library of this OBJ defines it; the default \
         material (diffuse 0.8) stands in (define it in the MTL, or with a [materials.{name}] table \
         in the scene)",
        obj.display()
    )
}

/// A mesh's `obj` path (relative to the scene file), checked to name a regular file.
fn obj_path(cx: &Ctx, index: usize, m: &file::MeshDesc) -> Result<PathBuf> {
    let obj_path = relative_to(cx.path, &m.obj);
    if !obj_path.exists() {
        return Err(cx.err(
            "mesh",
            index,
            "obj",
            format!("file '{}' not found", obj_path.display()),
        ));
    }
    if !obj_path.is_file() {
        return Err(cx.err(
            "mesh",
            index,
            "obj",
            format!("'{}' is not a regular file", obj_path.display()),
        ));
    }
    Ok(obj_path)
}

/// The meshes' materials with each one's texture path and where its emission was set.
#[derive(Default)]
struct LoadedMaterials {
    materials: Vec<Material>,
    tex_paths: TexPaths,
    mask_paths: TexPaths,
    ks_paths: TexPaths,
    ns_paths: TexPaths,
    bump_paths: BumpPaths,
    emission_at: Vec<Origin>,
    /// The indices of the materials of each name (several OBJs may use one name).
    by_name: HashMap<String, Vec<usize>>,
    /// The material of models that name none, once one needs it.
    default: Option<u32>,
}

impl LoadedMaterials {
    /// Adds an OBJ's MTL materials; an emission the MTL does not place is placed at `mesh_line`.
    fn add_mtl(&mut self, cx: &Ctx, data: &obj::ObjData, mesh_line: usize) {
        for tm in &data.materials {
            let (mat, maps) = mtl::from_mtl(tm);
            self.by_name
                .entry(mat.name.clone())
                .or_default()
                .push(self.materials.len());
            let in_dir = |t: String| (data.mtl_dir.clone(), t);
            self.tex_paths.push(maps.kd.map(in_dir));
            self.mask_paths.push(maps.d.map(in_dir));
            self.ks_paths.push(maps.ks.map(in_dir));
            self.ns_paths.push(maps.ns.map(in_dir));
            self.bump_paths
                .push(maps.bump.map(|b| (data.mtl_dir.clone(), b)));
            self.emission_at.push(
                data.ke_at
                    .get(&mat.name)
                    .cloned()
                    .unwrap_or_else(|| (cx.path.to_path_buf(), mesh_line)),
            );
            self.materials.push(mat);
        }
    }

    /// The index of the material for models that name none (or one their MTL lacks), added on
    /// first use.
    fn default_material(&mut self, cx: &Ctx) -> u32 {
        *self.default.get_or_insert_with(|| {
            self.materials.push(Material {
                name: "default".into(),
                bsdf: Bsdf::Diffuse {
                    albedo: Vec3::splat(0.8),
                    texture: None,
                },
                emission: Vec3::ZERO,
            });
            self.tex_paths.push(None);
            self.mask_paths.push(None);
            self.ks_paths.push(None);
            self.ns_paths.push(None);
            self.bump_paths.push(None);
            self.emission_at.push((cx.path.to_path_buf(), 1));
            (self.materials.len() - 1) as u32
        })
    }
}

/// Applies the scene file's `[materials.NAME]` tables to every material of that name; a table no
/// mesh uses is an error.
fn apply_overrides(cx: &Ctx, desc: &SceneFile, loaded: &mut LoadedMaterials) -> Result<()> {
    for (name, d) in &desc.materials {
        let line_of_mat = |key: &str| line_of(cx.text, &["materials", name, key], 0);
        let Some(idx) = loaded.by_name.get(name) else {
            return Err(at_line(
                cx.path,
                line_of_mat("type"),
                format!("materials.{name}: no mesh uses a material named '{name}'"),
            ));
        };
        for &i in idx {
            let mat = &mut loaded.materials[i];
            let was = textured_kind(&mat.bsdf);
            let tex = mtl::apply_override(cx.path, &line_of_mat, mat, d)?;
            if d.emission.is_some() {
                loaded.emission_at[i] = (cx.path.to_path_buf(), line_of_mat("emission"));
            }
            let is = textured_kind(&mat.bsdf);
            let tex_path = &mut loaded.tex_paths[i];
            if let Some(t) = tex {
                *tex_path = Some((cx.path.parent().unwrap_or(Path::new(".")).to_path_buf(), t));
            } else if is.is_none() || is != was {
                *tex_path = None;
            }
        }
    }
    Ok(())
}

/// The kinds of BSDF that take a texture: an override keeps a material's texture when it keeps its kind.
fn textured_kind(bsdf: &Bsdf) -> Option<&'static str> {
    match bsdf {
        Bsdf::Diffuse { .. } => Some("diffuse"),
        Bsdf::Glossy { .. } => Some("glossy"),
        _ => None,
    }
}

/// Appends one model's vertices and triangles, transformed. A mirroring transform (negative
/// determinant) reverses the winding, so that the face normal, and the side an emitter lights, is the
/// mirror image of the original one.
fn append_model(geo: &mut Geometry, model: &obj::ObjModel, xf: &Mat4, nxf: &Mat3, material: u32) {
    let base = geo.positions.len() as u32;
    let mirrored = Mat3::from_mat4(*xf).determinant() < 0.0;
    let has_normals = model.normals.len() == model.positions.len() && !model.normals.is_empty();
    let has_uv = model.uvs.len() == model.positions.len() && !model.uvs.is_empty();
    for (k, p) in model.positions.iter().enumerate() {
        geo.positions.push(xf.transform_point3(*p));
        let n = if has_normals {
            (*nxf * model.normals[k]).normalize_or_zero()
        } else {
            Vec3::ZERO
        };
        geo.normals.push(n);
        geo.uvs.push(if has_uv {
            model.uvs[k]
        } else {
            glam::Vec2::ZERO
        });
    }
    for f in model.indices.chunks_exact(3) {
        let v = if mirrored {
            [base + f[0], base + f[2], base + f[1]]
        } else {
            [base + f[0], base + f[1], base + f[2]]
        };
        let [a, b, c] = v.map(|i| geo.positions[i as usize]);
        let Some((ng, area)) = normal_and_area(a, b, c) else {
            geo.n_degenerate += 1;
            continue;
        };
        geo.triangles.push(Triangle {
            v,
            material,
            ng,
            area,
            has_normals,
            has_uv,
        });
    }
}

/// Unit normal (counter-clockwise) and area of a triangle; `None` when the area is zero. Edges of a
/// triangle within the coordinate limit fit f32, but their cross product's squared length may not: then
/// the same is computed in f64.
fn normal_and_area(a: Vec3, b: Vec3, c: Vec3) -> Option<(Vec3, f32)> {
    let cross = (b - a).cross(c - a);
    let (ng, area) = (cross.normalize(), 0.5 * cross.length());
    if area > 0.0 && area.is_finite() && ng.is_finite() {
        return Some((ng, area));
    }
    let cross = (b.as_dvec3() - a.as_dvec3()).cross(c.as_dvec3() - a.as_dvec3());
    let len = cross.length();
    let area = (0.5 * len) as f32;
    (len > 0.0 && area > 0.0 && area.is_finite()).then(|| ((cross / len).as_vec3(), area))
}

/// The file `name` in `dir` names for `statement` of material `mat`, checked to be a regular file
/// of at most [`MAX_TEXTURE_BYTES`].
fn image_path(cx: &Ctx, mat: &str, statement: &str, dir: &Path, name: &str) -> Result<PathBuf> {
    let resolved = texture::resolve(dir, name).map_err(|why| {
        in_file(
            cx.path,
            format!("material '{mat}': {statement} '{name}' {why}"),
        )
    })?;
    input::check_regular(&resolved, "texture", MAX_TEXTURE_BYTES)?;
    Ok(resolved)
}

/// The colour texture `name` in `dir` (for `statement` of material `mat`), through `held`.
fn held_texture(
    cx: &Ctx,
    held: &HeldInputs,
    (mat, statement): (&str, &str),
    dir: PathBuf,
    name: String,
) -> Result<(PathBuf, Arc<Texture>)> {
    let key = ImageKey {
        dir,
        name,
        read_as: "texture".into(),
    };
    held.texture(key.clone(), || {
        let path = image_path(cx, mat, statement, &key.dir, &key.name)?;
        let t = Texture::load(&path)
            .map_err(|e| in_file(&path, format!("cannot read texture: {e}")))?;
        Ok((path, t))
    })
}

/// The mask or map of values `name` in `dir` (for `statement` of material `mat`; with `alpha`, its
/// alpha channel where it has one), through `held`.
fn held_mask(
    cx: &Ctx,
    held: &HeldInputs,
    (mat, statement): (&str, &str),
    (dir, name): (PathBuf, String),
    alpha: bool,
) -> Result<(PathBuf, Arc<Mask>)> {
    let key = ImageKey {
        dir,
        name,
        read_as: format!("values alpha={alpha}"),
    };
    held.mask(key.clone(), || {
        let path = image_path(cx, mat, statement, &key.dir, &key.name)?;
        let what = if alpha { "mask" } else { "texture" };
        let m = Mask::load_values(&path, alpha)
            .map_err(|e| in_file(&path, format!("cannot read {what}: {e}")))?;
        Ok((path, m))
    })
}

fn textures(
    cx: &Ctx,
    materials: &mut [Material],
    tex_paths: TexPaths,
    held: &HeldInputs,
) -> Result<Vec<Arc<Texture>>> {
    let mut textures = Vec::new();
    let mut loaded: HashMap<PathBuf, usize> = HashMap::new();
    for (mat, tp) in materials.iter_mut().zip(tex_paths) {
        let Some((dir, name)) = tp else { continue };
        let (resolved, t) = held_texture(cx, held, (&mat.name, "texture"), dir, name)?;
        let idx = match loaded.get(&resolved) {
            Some(&i) => i,
            None => {
                textures.push(t);
                loaded.insert(resolved, textures.len() - 1);
                textures.len() - 1
            }
        };
        match &mut mat.bsdf {
            Bsdf::Diffuse { texture, .. } => *texture = Some(idx),
            Bsdf::Glossy {
                albedo,
                specular,
                texture,
                texel_scale,
                ..
            } => {
                *texture = Some(idx);
                *albedo = mean_glossy_texel(&textures[idx], *texel_scale, *specular);
            }
            _ => {}
        }
    }
    Ok(textures)
}

/// Each material's mask file and its index among the cutouts' masks; empty when no triangle is cut.
pub(super) type MaskFiles = Vec<Option<(PathBuf, u32)>>;

/// The cutouts of the triangles whose material names a `map_d` mask (each file read once), `None`
/// when none does, and each material's [`MaskFiles`] entry.
fn cutouts(
    cx: &Ctx,
    geo: &Geometry,
    materials: &[Material],
    mask_paths: TexPaths,
    held: &HeldInputs,
) -> Result<(Option<Cutouts>, MaskFiles)> {
    let mut masks = Vec::new();
    let mut loaded: HashMap<PathBuf, u32> = HashMap::new();
    let mut mask_of = vec![None; materials.len()];
    for (k, mp) in mask_paths.into_iter().enumerate() {
        let Some(file) = mp else { continue };
        let mat = (materials[k].name.as_str(), "map_d");
        let (resolved, m) = held_mask(cx, held, mat, file, true)?;
        let idx = match loaded.get(&resolved) {
            Some(&i) => i,
            None => {
                masks.push(m);
                loaded.insert(resolved.clone(), masks.len() as u32 - 1);
                masks.len() as u32 - 1
            }
        };
        mask_of[k] = Some((resolved, idx));
    }
    let masked = geo.triangles.iter().enumerate().filter_map(|(i, t)| {
        let (_, mask) = mask_of[t.material as usize].as_ref()?;
        Some((i, *mask, t.v.map(|k| geo.uvs[k as usize])))
    });
    let cutouts = Cutouts::new(masks, geo.triangles.len(), masked);
    if cutouts.is_none() {
        mask_of.clear();
    }
    Ok((cutouts, mask_of))
}

/// Each glossy material's `map_Ks` and `map_Ns` (`None` for a material with neither, or not glossy
/// once overrides are applied); empty when no material has one.
fn gloss_maps(
    cx: &Ctx,
    materials: &[Material],
    ks_paths: TexPaths,
    ns_paths: TexPaths,
    held: &HeldInputs,
) -> Result<Vec<Option<GlossMaps>>> {
    let mut maps = Vec::with_capacity(materials.len());
    for ((mat, ks), ns) in materials.iter().zip(ks_paths).zip(ns_paths) {
        if !matches!(mat.bsdf, Bsdf::Glossy { .. }) || (ks.is_none() && ns.is_none()) {
            maps.push(None);
            continue;
        }
        let specular = match ks {
            Some((dir, name)) => Some(held_texture(cx, held, (&mat.name, "map_Ks"), dir, name)?.1),
            None => None,
        };
        let exponent = match ns {
            Some(file) => Some(held_mask(cx, held, (&mat.name, "map_Ns"), file, false)?.1),
            None => None,
        };
        maps.push(Some(GlossMaps { specular, exponent }));
    }
    if maps.iter().all(Option::is_none) {
        maps.clear();
    }
    Ok(maps)
}

/// Each material's bump or normal map (`None` for a material without one, or a `null` boundary);
/// empty when no material has one. A file named by several materials with the same statement and
/// `-bm` is read once.
fn bumps(
    cx: &Ctx,
    materials: &[Material],
    bump_paths: BumpPaths,
    held: &HeldInputs,
) -> Result<Vec<Option<Arc<BumpMap>>>> {
    let mut loaded: HashMap<(PathBuf, Statement, Option<u32>), Arc<BumpMap>> = HashMap::new();
    let mut maps = Vec::with_capacity(materials.len());
    for (mat, bp) in materials.iter().zip(bump_paths) {
        let Some((dir, b)) = bp.filter(|_| !mat.bsdf.is_null()) else {
            maps.push(None);
            continue;
        };
        let name = match b.statement {
            Statement::Bump => "bump",
            Statement::Norm => "norm",
        };
        let key = ImageKey {
            dir,
            name: b.file.clone(),
            read_as: format!("{name} -bm {:?}", b.bm.map(f32::to_bits)),
        };
        let (resolved, read) = held.bump(key.clone(), || {
            let path = image_path(cx, &mat.name, name, &key.dir, &key.name)?;
            let m = BumpMap::load(&path, b.statement, b.bm)
                .map_err(|e| in_file(&path, format!("cannot read {name} map: {e}")))?;
            Ok((path, m))
        })?;
        // Two spellings of one file (another letter case, another directory) are one map.
        let map = loaded
            .entry((resolved, b.statement, b.bm.map(f32::to_bits)))
            .or_insert(read)
            .clone();
        maps.push(Some(map));
    }
    if maps.iter().all(Option::is_none) {
        maps.clear();
    }
    Ok(maps)
}

/// The mean diffuse colour of a textured glossy material over its texture: its `albedo`, for readers
/// that do not look the texel up (the irradiance atlas gives a glossy texel its material's albedo; the
/// scaled Kd there made pm 7.9 % bright on Sibenik with a polished marble floor).
fn mean_glossy_texel(t: &Texture, texel_scale: f32, specular: Vec3) -> Vec3 {
    let sum: glam::DVec3 = t
        .texels
        .iter()
        .map(|&c| crate::material::glossy_texel(c, texel_scale, specular).as_dvec3())
        .sum();
    (sum / t.texels.len().max(1) as f64).as_vec3()
}

/// FNV-1a (the cache file's checksum function) over positions, triangles, materials, the textures'
/// texels and lights: a saved cache or photon file loads only into the scene it was made of.
fn fingerprint(
    geo: &Geometry,
    materials: &[Material],
    textures: &[Arc<Texture>],
    cutouts: Option<&Cutouts>,
    bumps: &[Option<Arc<BumpMap>>],
    lights: &Lights,
    media: Option<&super::Media>,
) -> u64 {
    let mut bytes: Vec<u8> =
        Vec::with_capacity(geo.positions.len() * 12 + geo.triangles.len() * 16);
    for p in &geo.positions {
        bytes.extend(p.to_array().iter().flat_map(|x| x.to_le_bytes()));
    }
    for t in &geo.triangles {
        bytes.extend(
            t.v.iter()
                .chain([&t.material])
                .flat_map(|k| k.to_le_bytes()),
        );
    }
    for m in materials {
        bytes.extend(format!("{:?}{:?}", m.bsdf, m.emission).bytes());
    }
    // Each texture as the hash of its texels (not copied: they can be hundreds of MB).
    for t in textures {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let texel_bytes = t
            .texels
            .iter()
            .flat_map(|c| c.to_array())
            .flat_map(|x| x.to_le_bytes());
        for b in [t.width, t.height]
            .iter()
            .flat_map(|d| d.to_le_bytes())
            .chain(texel_bytes)
        {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        bytes.extend(h.to_le_bytes());
    }
    if let Some(c) = cutouts {
        bytes.extend(c.fingerprint().to_le_bytes());
    }
    for b in bumps.iter().flatten() {
        bytes.extend(b.fingerprint().to_le_bytes());
    }
    for l in &lights.lights {
        bytes.extend(format!("{l:?}").bytes());
    }
    if let Some(m) = media {
        bytes.extend(format!("{m:?}").bytes());
    }
    icache::file::fnv1a64(&bytes)
}
