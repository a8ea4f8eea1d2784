//! `[[medium]]`, `[[mesh]] interior` and `[camera] medium`: checks them and works out which medium lies
//! on each side of every boundary triangle, where the camera and each light sit, and how media nest.
//!
//! A boundary mesh must be closed and consistently oriented (every edge shared by exactly two faces that
//! run it in opposite directions, vertices matched by position). Its inside is found from the sign of
//! its volume, so either winding works. The medium outside a boundary mesh is that of the smallest other
//! boundary mesh containing it (a glass of liquid standing in fog), vacuum if none.

mod overlap;

use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicU16, Ordering};

use glam::Vec3;
use rayon::prelude::*;

use super::context::Ctx;
use super::file::SceneFile;
use crate::accel::embree::Bvh;
use crate::error::{at_line, Result};
use crate::geometry::Geometry;
use crate::light::Light;
use crate::material::Material;
use crate::medium::{Medium, MediumId, VACUUM};

/// Largest σa or σs per channel (per scene unit).
pub const MAX_SIGMA: f32 = 1e9;

/// The scene's media and where they are.
pub struct Media {
    pub list: Vec<Medium>,
    /// Per triangle: `[medium on the side ng points to, medium behind]`, for boundary triangles only.
    sides: Vec<Option<[MediumId; 2]>>,
    /// The medium the camera's eye is in: set when the scene is built, and again for each frame of a
    /// sequence that reuses the scene with another eye ([`crate::scene::Scene::place_eye`]).
    camera: AtomicU16,
    /// The medium each light emits into (indexed as `Lights::lights`).
    pub lights: Vec<MediumId>,
    /// The boundary meshes, and a BVH of their triangles alone ([`Media::first_boundary`]).
    boundaries: Vec<Boundary>,
    boundary_bvh: Bvh,
    /// One BVH per boundary mesh, for the parity rays of [`Media::medium_at`] ([`Parity`]).
    parity: Parity,
    /// Per triangle of `boundary_bvh`: its index among the scene's triangles.
    triangle_of: Vec<u32>,
    bounds: (Vec3, Vec3),
}

/// What the scene fingerprint hashes: the media and which sides they fill.
impl std::fmt::Debug for Media {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Media")
            .field("list", &self.list)
            .field("sides", &self.sides)
            .field("camera", &self.camera())
            .field("lights", &self.lights)
            .finish()
    }
}

impl Media {
    /// The medium the camera's eye is in.
    pub fn camera(&self) -> MediumId {
        self.camera.load(Ordering::Relaxed)
    }

    /// Places the camera's eye at `eye`.
    pub(crate) fn place_eye(&self, eye: Vec3) {
        self.camera.store(self.medium_at(eye), Ordering::Relaxed);
    }

    /// The medium a ray leaving triangle `tri` (geometric normal `ng`) in direction `dir` travels in,
    /// when it was in `current` before: changed only at a boundary.
    pub(crate) fn after(&self, tri: u32, ng: Vec3, dir: Vec3, current: MediumId) -> MediumId {
        match self.sides[tri as usize] {
            Some([front, back]) => {
                if dir.dot(ng) >= 0.0 {
                    front
                } else {
                    back
                }
            }
            None => current,
        }
    }

    pub(crate) fn get(&self, id: MediumId) -> Option<&Medium> {
        self.list.get(id as usize).filter(|m| !m.is_clear())
    }

    /// `[medium on the side ng points to, medium behind]` of a boundary triangle; `None` elsewhere.
    pub(crate) fn sides(&self, tri: u32) -> Option<[MediumId; 2]> {
        self.sides[tri as usize]
    }

    /// The bounding box of the boundary meshes.
    pub(crate) fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The summed volume of the boundary meshes (nested ones counted again).
    pub(crate) fn volume(&self) -> f64 {
        self.boundaries.iter().map(|b| b.volume).sum()
    }

    /// The boundary triangle (its index in the scene's triangles) that a ray from `origin` along `dir`
    /// meets first in (0, `tmax`), if any.
    pub(crate) fn first_boundary(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<u32> {
        self.boundary_bvh
            .intersect(origin, dir, tmax)
            .map(|raw| self.triangle_of[raw.prim as usize])
    }

    /// The medium at point `p` (not on a boundary): the innermost boundary mesh around it, found by the
    /// parity of a ray's crossings with each boundary mesh (through the boundaries' own BVH).
    pub(crate) fn medium_at(&self, p: Vec3) -> MediumId {
        innermost_by_bvh(&self.boundaries, &self.parity, p, None)
    }
}

/// The medium of the smallest boundary mesh (other than `skip`) around `p`, by the parity of a ray's
/// crossings with each boundary mesh through its BVH; vacuum if none.
fn innermost_by_bvh(
    boundaries: &[Boundary],
    parity: &Parity,
    p: Vec3,
    skip: Option<usize>,
) -> MediumId {
    innermost_along(boundaries, parity, p, PARITY_DIR, skip)
}

/// One BVH per boundary mesh, so that each boundary's crossings are counted on their own. Two media
/// that share a face have two coincident triangles there, one of each boundary; a ray through one BVH
/// of them all meets only one of the two (which one, Embree's kernels decide on the tie) and steps
/// past both, and the other boundary's parity comes out wrong. Within one closed mesh no faces
/// coincide.
struct Parity(Vec<Bvh>);

impl Parity {
    fn build(geo: &Geometry, boundaries: &[Boundary]) -> Result<Parity> {
        boundaries
            .iter()
            .map(|b| {
                let tris: Vec<[u32; 3]> = b.tris.clone().map(|t| geo.triangles[t].v).collect();
                Ok(Bvh::build(&geo.positions, &tris)?)
            })
            .collect::<Result<Vec<_>>>()
            .map(Parity)
    }
}

/// The direction of parity rays: off every axis, so that it runs along no face of an axis-aligned box.
const PARITY_DIR: Vec3 = Vec3::new(0.5711, 0.6353, 0.5198);

/// [`innermost_by_bvh`] with the parity ray along `d` (need not be unit length).
fn innermost_along(
    boundaries: &[Boundary],
    parity: &Parity,
    p: Vec3,
    d: Vec3,
    skip: Option<usize>,
) -> MediumId {
    let inside = containing(boundaries, parity, p, d);
    (0..boundaries.len())
        .filter(|&b| inside[b] && Some(b) != skip)
        .min_by(|&a, &b| boundaries[a].volume.total_cmp(&boundaries[b].volume))
        .map_or(VACUUM, |b| boundaries[b].medium)
}

/// Which of the `n_boundaries` boundary meshes contain `p`, by the parity of a ray's crossings with
/// each along `d` (need not be unit length).
fn containing(boundaries: &[Boundary], parity: &Parity, p: Vec3, d: Vec3) -> Vec<bool> {
    let d = d.normalize();
    boundaries
        .iter()
        .zip(&parity.0)
        .map(|(b, bvh)| {
            let mut inside = false;
            let mut o = p;
            // Every crossing counts: a ray crosses each face at most once.
            for _ in 0..=b.tris.len() {
                let Some(raw) = bvh.intersect(o, d, f32::INFINITY) else {
                    break;
                };
                inside = !inside;
                let q = o + d * raw.t;
                o = crate::geometry::offset_origin(q, d);
                if (o - q).dot(d) <= 0.0 {
                    o = q + d * (q.abs().max_element() * 1e-6).max(1e-6);
                }
            }
            inside
        })
        .collect()
}

/// One closed boundary mesh.
#[derive(Debug)]
struct Boundary {
    /// Its `[[mesh]]` entry.
    mesh: usize,
    medium: MediumId,
    tris: Range<usize>,
    /// |volume|, to pick the innermost of nested meshes.
    volume: f64,
    /// Whether the winding normals point out of the mesh.
    outward: bool,
}

/// Builds the media from the scene file, or `None` when it has no `[[medium]]` (then nothing else may
/// name one). `mesh_tris[i]` are the triangles of `[[mesh]]` entry `i`.
pub(super) fn media(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    materials: &[Material],
    mesh_tris: &[Range<usize>],
    lights: &[Light],
) -> Result<Option<Media>> {
    let list = medium_list(cx, desc)?;
    let boundaries = boundaries(cx, desc, geo, &list, mesh_tris)?;
    if boundaries.is_empty() {
        check_no_medium_used(cx, desc, geo, materials, &list)?;
        return Ok(None);
    }
    let triangle_of: Vec<u32> = boundaries
        .iter()
        .flat_map(|b| b.tris.clone().map(|t| t as u32))
        .collect();
    let boundary_tris: Vec<[u32; 3]> = triangle_of
        .iter()
        .map(|&t| geo.triangles[t as usize].v)
        .collect();
    let boundary_bvh = Bvh::build(&geo.positions, &boundary_tris)?;
    let parity = Parity::build(geo, &boundaries)?;
    let innermost = |p: Vec3, skip: Option<usize>| innermost_by_bvh(&boundaries, &parity, p, skip);
    check_nesting(cx, desc, geo, &boundaries, &parity)?;
    overlap::check_overlaps(cx, desc, geo, &boundaries)?;
    // Each boundary mesh's outside: the innermost other boundary containing a point just inside it;
    // face by face where other boundaries could meet it (two media sharing a face).
    let mut sides = vec![None; geo.triangles.len()];
    for (bi, b) in boundaries.iter().enumerate() {
        let outside = innermost(point_inside(geo, b), Some(bi));
        let face_outside = |t: usize| {
            if boundaries.len() == 1 {
                return outside;
            }
            let (p, away) = point_outside(geo, t, b.outward);
            innermost_along(&boundaries, &parity, p, away, Some(bi))
        };
        let outsides: Vec<MediumId> = b.tris.clone().into_par_iter().map(face_outside).collect();
        for (t, outside) in b.tris.clone().zip(outsides) {
            sides[t] = Some(if b.outward {
                [outside, b.medium]
            } else {
                [b.medium, outside]
            });
        }
    }
    for (t, tri) in geo.triangles.iter().enumerate() {
        let m = &materials[tri.material as usize];
        if m.bsdf.is_null() && sides[t].is_none() {
            return Err(null_error(cx, m));
        }
    }
    let camera = innermost(desc.camera.eye.into(), None);
    check_camera_medium(cx, desc, &list, camera)?;
    let lights = lights
        .iter()
        .map(|l| innermost(light_point(geo, l), None))
        .collect();
    let bounds = boundary_tris.iter().flatten().fold(
        (Vec3::INFINITY, Vec3::NEG_INFINITY),
        |(lo, hi), &k| {
            (
                lo.min(geo.positions[k as usize]),
                hi.max(geo.positions[k as usize]),
            )
        },
    );
    Ok(Some(Media {
        list,
        sides,
        camera: AtomicU16::new(camera),
        lights,
        boundaries,
        boundary_bvh,
        parity,
        triangle_of,
        bounds,
    }))
}

/// The `[[medium]]` entries checked: unique names, coefficients within range, fewer than
/// [`VACUUM`] of them.
fn medium_list(cx: &Ctx, desc: &SceneFile) -> Result<Vec<Medium>> {
    let mut list: Vec<Medium> = Vec::new();
    for (i, m) in desc.medium.iter().enumerate() {
        if m.name.is_empty() || list.iter().any(|o| o.name == m.name) {
            return Err(cx.err(
                "medium",
                i,
                "name",
                format!("'{}' is empty or names an earlier medium too", m.name),
            ));
        }
        for (k, v) in [("sigma_a", m.sigma_a), ("sigma_s", m.sigma_s)] {
            if let Some(x) = v.iter().find(|x| !(**x >= 0.0 && **x <= MAX_SIGMA)) {
                return Err(cx.err(
                    "medium",
                    i,
                    k,
                    format!("{x} is outside [0, {MAX_SIGMA:e}] (per scene unit)"),
                ));
            }
        }
        let given = m.g.unwrap_or(0.0);
        let g = given as f32;
        if !(given > -1.0 && given < 1.0) {
            return Err(cx.err("medium", i, "g", format!("{given} is outside (-1, 1)")));
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(cx.err(
                "medium",
                i,
                "g",
                format!("must be within (-1, 1); {given} rounds to {g} in single precision"),
            ));
        }
        list.push(Medium::new(
            m.name.clone(),
            Vec3::from(m.sigma_a),
            Vec3::from(m.sigma_s),
            g,
        ));
    }
    if list.len() >= VACUUM as usize {
        return Err(cx.err(
            "medium",
            VACUUM as usize,
            "name",
            format!("more than {} media", VACUUM - 1),
        ));
    }
    Ok(list)
}

fn id_of(list: &[Medium], name: &str) -> Option<MediumId> {
    list.iter()
        .position(|m| m.name == name)
        .map(|i| i as MediumId)
}

/// The meshes with an `interior`, each checked to name a medium and to be closed.
fn boundaries(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    list: &[Medium],
    mesh_tris: &[Range<usize>],
) -> Result<Vec<Boundary>> {
    let mut boundaries = Vec::new();
    for (mi, m) in desc.mesh.iter().enumerate() {
        let Some(name) = &m.interior else { continue };
        let Some(medium) = id_of(list, name) else {
            return Err(cx.err(
                "mesh",
                mi,
                "interior",
                format!("no [[medium]] is named '{name}'"),
            ));
        };
        let tris = mesh_tris[mi].clone();
        if let Some(why) = not_closed(geo, tris.clone()) {
            return Err(cx.err(
                "mesh",
                mi,
                "interior",
                format!("'{}' cannot bound a medium: {why}", m.obj),
            ));
        }
        let volume = signed_volume(geo, tris.clone());
        boundaries.push(Boundary {
            mesh: mi,
            medium,
            tris,
            volume: volume.abs(),
            outward: volume > 0.0,
        });
    }
    Ok(boundaries)
}

/// Deepest nesting of boundary meshes. Every ray crosses each boundary it passes as a separate trace,
/// so a render's time grows with the depth (80 nested boxes took 75 s at 32²); real scenes nest a
/// handful (a liquid in a glass in fog).
pub const MAX_NESTED_BOUNDARIES: usize = 16;

/// Refuses, naming the mesh, a boundary inside more than [`MAX_NESTED_BOUNDARIES`] − 1 others, and
/// two boundaries enclosing the same space (the same box listed twice, or bounding two media): which
/// medium fills it would depend on the order of the meshes (`pm` and `path` then disagreed, and
/// neither matched either medium alone). Faces shared between boundaries stay legal.
fn check_nesting(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    boundaries: &[Boundary],
    parity: &Parity,
) -> Result<()> {
    // Per boundary: the boundaries around a point just inside it (itself included).
    let around: Vec<Vec<usize>> = boundaries
        .par_iter()
        .map(|b| {
            let inside = containing(boundaries, parity, point_inside(geo, b), PARITY_DIR);
            (0..boundaries.len()).filter(|&a| inside[a]).collect()
        })
        .collect();
    let name = |b: usize| &desc.mesh[boundaries[b].mesh].obj;
    if let Some(b) = (0..boundaries.len()).find(|&b| around[b].len() > MAX_NESTED_BOUNDARIES) {
        return Err(cx.err(
            "mesh",
            boundaries[b].mesh,
            "interior",
            format!(
                "'{}' lies inside {} other medium boundaries: at most {MAX_NESTED_BOUNDARIES} may \
                 nest (every ray crosses each one)",
                name(b),
                around[b].len() - 1
            ),
        ));
    }
    // The same surface: the same triangles (by position, either winding) in any order. A parity ray
    // cannot tell (Embree reports one of two coincident faces), so the surfaces are compared.
    let surface = |b: &Boundary| {
        let mut tris: Vec<[[u32; 3]; 3]> = geo.triangles[b.tris.clone()]
            .iter()
            .map(|t| {
                let mut v =
                    t.v.map(|i| geo.positions[i as usize].to_array().map(f32::to_bits));
                v.sort_unstable();
                v
            })
            .collect();
        tris.sort_unstable();
        tris
    };
    let mut seen: HashMap<Vec<[[u32; 3]; 3]>, usize> = HashMap::new();
    for (b, boundary) in boundaries.iter().enumerate() {
        if let Some(&a) = seen.get(&surface(boundary)) {
            return Err(cx.err(
                "mesh",
                boundary.mesh,
                "interior",
                format!(
                    "'{}' encloses the same space as the boundary '{}' before it: which medium \
                     fills it would be undefined",
                    name(b),
                    name(a)
                ),
            ));
        }
        seen.insert(surface(boundary), b);
    }
    Ok(())
}

fn camera_line(cx: &Ctx) -> usize {
    super::file::line_of_key(cx.text, "camera", 0, "medium")
}

/// Without boundary meshes, neither the camera nor a material may use a medium.
fn check_no_medium_used(
    cx: &Ctx,
    desc: &SceneFile,
    geo: &Geometry,
    materials: &[Material],
    list: &[Medium],
) -> Result<()> {
    if let Some(name) = &desc.camera.medium {
        let why = if id_of(list, name).is_some() {
            format!("no [[mesh]] has interior = '{name}'")
        } else {
            format!("no [[medium]] is named '{name}'")
        };
        return Err(at_line(
            cx.path,
            camera_line(cx),
            format!("camera.medium: {why}"),
        ));
    }
    if let Some(t) = geo
        .triangles
        .iter()
        .find(|t| materials[t.material as usize].bsdf.is_null())
    {
        return Err(null_error(cx, &materials[t.material as usize]));
    }
    Ok(())
}

/// The camera's `medium`, if given, must be the one the eye is in (`camera`, by the boundaries).
pub(super) fn check_camera_medium(
    cx: &Ctx,
    desc: &SceneFile,
    list: &[Medium],
    camera: MediumId,
) -> Result<()> {
    let Some(name) = &desc.camera.medium else {
        return Ok(());
    };
    let Some(given) = id_of(list, name) else {
        return Err(at_line(
            cx.path,
            camera_line(cx),
            format!("camera.medium: no [[medium]] is named '{name}'"),
        ));
    };
    if given != camera {
        let is_in = if camera == VACUUM {
            "no medium".to_string()
        } else {
            format!("medium '{}'", list[camera as usize].name)
        };
        return Err(at_line(
            cx.path,
            camera_line(cx),
            format!(
                "camera.medium: the eye is inside {is_in} (by the boundary meshes), not '{name}'"
            ),
        ));
    }
    Ok(())
}

fn null_error(cx: &Ctx, m: &Material) -> crate::error::Error {
    let line = super::file::line_of(cx.text, &["materials", &m.name, "type"], 0);
    at_line(cx.path, line, format!("materials.{}: type 'null' is only for the boundary of a medium (a [[mesh]] with interior)", m.name))
}

/// Where a light's photons start, for the medium they start in: just off an emitting triangle.
fn light_point(geo: &Geometry, l: &Light) -> Vec3 {
    match *l {
        Light::Area { tri, n, .. } => {
            let c = geo.point_on(tri, 1.0 / 3.0, 1.0 / 3.0);
            c + n
                * (1e-4 * geo.triangles[tri as usize].area.sqrt()).max(c.abs().max_element() * 1e-6)
        }
        Light::Point { pos, .. } | Light::Spot { pos, .. } => pos,
        Light::Directional {
            center,
            radius,
            dir,
            ..
        } => center - dir * (2.0 * radius),
    }
}

/// A point just inside a boundary mesh: the centre of its largest face, moved inward a little.
fn point_inside(geo: &Geometry, b: &Boundary) -> Vec3 {
    let t = b
        .tris
        .clone()
        .max_by(|&i, &j| geo.triangles[i].area.total_cmp(&geo.triangles[j].area))
        .unwrap_or(b.tris.start);
    let tri = &geo.triangles[t];
    let c = geo.point_on(t as u32, 1.0 / 3.0, 1.0 / 3.0);
    let inward = if b.outward { -tri.ng } else { tri.ng };
    c + inward * (1e-3 * tri.area.sqrt())
}

/// A point just outside boundary triangle `t` (on the side away from its mesh's inside) and a
/// direction for its parity ray that leaves the triangle's plane on that side at once: the ray then
/// never crosses a face lying in that plane (another medium's face shared with this one).
fn point_outside(geo: &Geometry, t: usize, outward: bool) -> (Vec3, Vec3) {
    let tri = &geo.triangles[t];
    let n = if outward { tri.ng } else { -tri.ng };
    let c = geo.point_on(t as u32, 1.0 / 3.0, 1.0 / 3.0);
    let eps = (c.abs().max_element() * 1e-5).max(1e-5);
    (c + n * eps, n + 0.25 * PARITY_DIR.normalize())
}

fn signed_volume(geo: &Geometry, tris: Range<usize>) -> f64 {
    geo.triangles[tris]
        .iter()
        .map(|t| {
            let [a, b, c] = t.v.map(|k| geo.positions[k as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// Vertices of a boundary mesh closer than this fraction of its extent are the same vertex (a sphere's
/// pole written once per meridian, as sin π ≠ 0 in floating point).
const WELD_TOLERANCE: f32 = 1e-6;

/// Merges points closer than `eps` (a hash grid of cells `eps` wide, each point checked against the 27
/// cells around it).
struct Weld {
    eps: f32,
    cells: HashMap<[i64; 3], Vec<u32>>,
    points: Vec<Vec3>,
}

impl Weld {
    fn new(eps: f32) -> Weld {
        Weld {
            eps: eps.max(f32::MIN_POSITIVE),
            cells: HashMap::new(),
            points: Vec::new(),
        }
    }

    fn id(&mut self, p: Vec3) -> u32 {
        let c = (p / self.eps).floor().as_i64vec3().to_array();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        if let Some(&i) = ids
                            .iter()
                            .find(|&&i| self.points[i as usize].distance(p) <= self.eps)
                        {
                            return i;
                        }
                    }
                }
            }
        }
        let i = self.points.len() as u32;
        self.points.push(p);
        self.cells.entry(c).or_default().push(i);
        i
    }
}

/// Why the triangles `tris` do not form a closed, consistently oriented surface; `None` if they do.
/// Vertices are matched by position (within [`WELD_TOLERANCE`]), so meshes that repeat vertices per face (for normals or texture
/// coordinates) still count as closed.
fn not_closed(geo: &Geometry, tris: Range<usize>) -> Option<String> {
    if tris.is_empty() {
        return Some("it has no faces".into());
    }
    let (lo, hi) = geo.triangles[tris.clone()].iter().flat_map(|t| t.v).fold(
        (Vec3::INFINITY, Vec3::NEG_INFINITY),
        |(lo, hi), k| {
            let p = geo.positions[k as usize];
            (lo.min(p), hi.max(p))
        },
    );
    let mut weld = Weld::new(WELD_TOLERANCE * (hi - lo).length());
    let mut key = |k: u32| weld.id(geo.positions[k as usize]);
    // A sliver whose corners weld together (a pole triangle of a latitude–longitude sphere) is no face.
    let faces: Vec<[u32; 3]> = geo.triangles[tris]
        .iter()
        .map(|t| t.v.map(&mut key))
        .filter(|v| v[0] != v[1] && v[1] != v[2] && v[2] != v[0])
        .collect();
    let edges = |v: &[u32; 3]| [(v[0], v[1]), (v[1], v[2]), (v[2], v[0])];
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for v in &faces {
        for e in edges(v) {
            *directed.entry(e).or_default() += 1;
        }
    }
    let at = |a: u32| {
        let p = weld.points[a as usize];
        format!("({}, {}, {})", p.x, p.y, p.z)
    };
    let (mut open, mut flipped) = (0usize, 0usize);
    let mut example = None;
    // In face order, so that the message names the same edge every time.
    for (a, b) in faces.iter().flat_map(edges) {
        let (n, back) = (
            directed[&(a, b)],
            directed.get(&(b, a)).copied().unwrap_or(0),
        );
        if n + back != 2 {
            open += 1;
            example.get_or_insert((a, b, "is not shared by exactly two faces"));
        } else if n != 1 {
            flipped += 1;
            example.get_or_insert((a, b, "is run the same way by both its faces"));
        }
    }
    let (a, b, what) = example?;
    let summary = if open > 0 {
        format!("it is not closed ({open} face edges without exactly one opposite)")
    } else {
        format!("its faces are not consistently oriented ({flipped} edges)")
    };
    Some(format!(
        "{summary}; e.g. the edge {} – {} {what}",
        at(a),
        at(b)
    ))
}
