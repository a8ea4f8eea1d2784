//! A loaded scene: camera, triangles in an Embree BVH, materials, textures, lights and render settings.

pub mod animation;
mod build;
mod context;
pub(crate) mod file;
mod held;
mod icache_settings;
pub(crate) mod input;
mod lights;
pub mod limits;
mod media;
mod mtl;
mod obj;
mod objcheck;
mod settings;

use std::cmp::Ordering;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

pub use animation::{at_frame, Animation, Change};
pub use build::{
    check_sequence, frame_camera, frame_view, load, load_animation, load_frame, mesh_transform,
};
pub use icache_settings::{FillMode, IcacheSettings, MIN_RECORD_REACH_PX, SPACING_REFERENCE_SIDE};
pub use media::{Media, MAX_SIGMA};
pub use settings::{PhotonConfig, MAX_PHOTONS, MAX_SIDE, MAX_SPP, MAX_TIME_S, MIN_LOOKUP};

use crate::accel::embree::Bvh;
use crate::camera::Camera;
use crate::geometry::{spawn, Frame, Geometry, Hit};
use crate::light::Lights;
use crate::material::Material;
use crate::medium::{Medium, MediumId, VACUUM};
use crate::texture::Texture;

/// The rendering method (a closed set).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    Path,
    Pm,
    PmFg,
    Photons,
    /// Ambient occlusion through the irradiance cache.
    Ao,
    /// Ambient occlusion gathered at every camera sample (`ao`'s reference).
    AoDirect,
}

impl Method {
    pub fn parse(s: &str) -> Option<Method> {
        match s {
            "path" => Some(Method::Path),
            "pm" => Some(Method::Pm),
            "pm-fg" => Some(Method::PmFg),
            "photons" => Some(Method::Photons),
            "ao" => Some(Method::Ao),
            "ao-direct" => Some(Method::AoDirect),
            _ => None,
        }
    }

    /// Whether the method traces photon maps (all but `path` and the occlusion methods).
    pub fn uses_photon_maps(self) -> bool {
        !matches!(self, Method::Path | Method::Ao | Method::AoDirect)
    }

    /// Whether the method reads an irradiance cache it fills (or loads) before shading.
    pub fn uses_cache(self) -> bool {
        matches!(self, Method::Pm | Method::Ao)
    }

    /// Whether the method's image is ambient occlusion.
    pub fn is_occlusion(self) -> bool {
        matches!(self, Method::Ao | Method::AoDirect)
    }

    pub fn name(self) -> &'static str {
        match self {
            Method::Path => "path",
            Method::Pm => "pm",
            Method::PmFg => "pm-fg",
            Method::Photons => "photons",
            Method::Ao => "ao",
            Method::AoDirect => "ao-direct",
        }
    }
}

pub const METHODS: &str = "path | pm | pm-fg | photons | ao | ao-direct";

/// Null boundaries a ray may cross before it is given up. Crossing one is no bounce: a ray through
/// 130 thin slabs of clear medium crosses 260 (at 256 it was given up, its light lost: `path` 14 %
/// dark). A crossing always moves the ray on ([`past`]), so this only bounds the work per ray; a
/// ray given up is counted ([`Scene::give_up_crossings`]) and the render warns.
pub(crate) const MAX_NULL_CROSSINGS: u32 = 1 << 16;

/// Where a ray continues after crossing an invisible boundary at distance `t` from its origin: just
/// past it on the same line. Moving the origin off the boundary instead (as after a bounce) shifts a
/// grazing ray sideways, toward or away from what lies just beyond: a shadow ray from a wall to a
/// light just above a fog boundary would hit the light's own triangle and darken the wall.
#[inline]
pub(crate) fn past(t: f32, origin: Vec3) -> f32 {
    t + (t + origin.abs().max_element()) * 4e-7
}

/// A stretch of ray: from `origin` along `dir` over (0, `tmax`).
#[derive(Clone, Copy)]
struct RaySpan {
    origin: Vec3,
    dir: Vec3,
    tmax: f32,
}

/// `[render]` after validation; `None` means "derive from the scene/method".
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub method: Option<Method>,
    pub spp: Option<u32>,
    /// Under a noise target, the most samples of a pixel without Monte Carlo estimates.
    pub aa_spp: Option<u32>,
    /// Adaptive sampling's noise target; `None`: the method's default.
    pub noise: Option<f32>,
    pub seed: u64,
    pub max_depth: u32,
    /// `ao`'s occlusion distance in scene units; `None`: a tenth of the bounding box's diagonal.
    pub ao_distance: Option<f32>,
    /// `[render] time`: a time budget in seconds (a progressive render; see `render::progressive`).
    pub time: Option<f64>,
    pub photons: PhotonConfig,
    pub icache: IcacheSettings,
}

pub struct Scene {
    pub path: PathBuf,
    pub camera: Camera,
    pub geometry: Geometry,
    pub materials: Vec<Material>,
    pub textures: Vec<std::sync::Arc<Texture>>,
    pub lights: Lights,
    pub bvh: Bvh,
    /// The specular (mirror, glass) triangles alone, for the photon pass's caustic-only paths; `None`
    /// without any.
    pub specular_bvh: Option<Bvh>,
    pub settings: RenderSettings,
    pub bounds: (Vec3, Vec3),
    /// Hash of everything that affects light transport (not the camera), for photon and cache files.
    pub fingerprint: u64,
    /// Participating media; `None` for a scene without `[[medium]]` (no media code runs).
    pub media: Option<Media>,
    /// Each `[[mesh]]` entry's triangles.
    pub mesh_ranges: Vec<std::ops::Range<usize>>,
    /// Per triangle, its material's texels per world unit ([`texel_density`]; 0 without a texture).
    texel_density: Vec<f32>,
    /// Each material's glossy maps (`map_Ks`, `map_Ns`); empty when no material has any.
    gloss_maps: Vec<Option<crate::gloss_map::GlossMaps>>,
    /// Each material's bump or normal map; empty when no material has any.
    bumps: Vec<Option<std::sync::Arc<crate::bump::BumpMap>>>,
    /// The per-vertex tangents of the meshes with a normal map; empty without one.
    tangents: crate::tangents::Tangents,
    /// The `map_d` cutouts; `None` when no triangle has one.
    cutouts: Option<std::sync::Arc<crate::cutout::Cutouts>>,
    /// Each material's `map_d` file and mask among `cutouts`; empty when `cutouts` is `None`.
    mask_files: build::MaskFiles,
    /// What the loader accepted but a user should hear about (an OBJ's `usemtl` of a material no
    /// library defines), each naming its file and line; the render's warnings begin with these.
    pub warnings: Vec<String>,
    /// Rays given up after [`MAX_NULL_CROSSINGS`] boundary crossings so far (a render's statistics
    /// count those during it).
    crossings_given_up: std::sync::atomic::AtomicU64,
}

/// Texels of `texture` per world unit on triangle `tri` of `g`, along the direction where they are
/// sparsest (the smaller singular value of the map from the triangle's plane to texels): a
/// stretched mapping is then never averaged over more than the footprint across its stretch.
fn texel_density(g: &Geometry, tri: u32, texture: &crate::texture::Texture) -> f32 {
    let t = &g.triangles[tri as usize];
    if !t.has_uv || t.area <= 0.0 {
        return 0.0;
    }
    let [p0, p1, p2] = t.v.map(|i| g.positions[i as usize]);
    let size = Vec2::new(texture.width as f32, texture.height as f32);
    let [t0, t1, t2] = t.v.map(|i| g.uvs[i as usize] * size);
    // The edges in an orthonormal basis of the plane (x along the first edge).
    let (e1, e2) = (p1 - p0, p2 - p0);
    let len1 = e1.length();
    if !(len1 > 0.0) {
        return 0.0;
    }
    let x = e1 / len1;
    let (e2x, e2y) = (e2.dot(x), (e2 - x * e2.dot(x)).length());
    if !(e2y > 0.0) {
        return 0.0;
    }
    // J = D · E⁻¹ with D = [t1 − t0, t2 − t0] and E = [[len1, e2x], [0, e2y]].
    let (d1, d2) = (t1 - t0, t2 - t0);
    let col_x = d1 / len1;
    let col_y = (d2 - col_x * e2x) / e2y;
    // Singular values of [col_x col_y]: eigenvalues of JᵀJ.
    let (a, b, c) = (col_x.dot(col_x), col_x.dot(col_y), col_y.dot(col_y));
    let half_trace = 0.5 * (a + c);
    let root = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let smallest = (half_trace - root).max(0.0).sqrt();
    if smallest.is_finite() {
        smallest
    } else {
        0.0
    }
}

/// Each triangle's [`texel_density`] for its material's texture (0 where it has none).
fn texel_densities(
    g: &Geometry,
    materials: &[Material],
    textures: &[std::sync::Arc<crate::texture::Texture>],
) -> Vec<f32> {
    use crate::material::Bsdf;
    g.triangles
        .iter()
        .enumerate()
        .map(|(i, t)| match &materials[t.material as usize].bsdf {
            Bsdf::Diffuse {
                texture: Some(k), ..
            }
            | Bsdf::Glossy {
                texture: Some(k), ..
            } => texel_density(g, i as u32, &textures[*k]),
            _ => 0.0,
        })
        .collect()
}

impl Scene {
    /// Counts a ray given up after [`MAX_NULL_CROSSINGS`] boundary crossings.
    pub(crate) fn give_up_crossings(&self) {
        (self.crossings_given_up).fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }

    /// Rays given up after [`MAX_NULL_CROSSINGS`] boundary crossings since the scene was loaded.
    pub fn n_crossings_given_up(&self) -> u64 {
        (self.crossings_given_up).load(std::sync::atomic::Ordering::Relaxed)
    }

    /// A bounding sphere of `[[mesh]]` entry `mesh`'s triangles: the centre of their box and the
    /// farthest vertex from it (`None` for a mesh without triangles).
    pub fn mesh_sphere(&self, mesh: usize) -> Option<(Vec3, f32)> {
        let tris = &self.geometry.triangles[self.mesh_ranges.get(mesh)?.clone()];
        let points = || {
            tris.iter()
                .flat_map(|t| t.v)
                .map(|k| self.geometry.positions[k as usize])
        };
        let (lo, hi) = points().fold(None, |b, p| match b {
            None => Some((p, p)),
            Some((lo, hi)) => Some((p.min(lo), p.max(hi))),
        })?;
        let center = (lo + hi) * 0.5;
        Some((
            center,
            points().map(|p| p.distance(center)).fold(0.0, f32::max),
        ))
    }

    /// Places the eye at `eye` for a frame that reuses this scene (only the camera moved): camera rays
    /// start in the medium around it.
    pub fn place_eye(&self, eye: Vec3) {
        if let Some(m) = &self.media {
            m.place_eye(eye);
        }
    }

    /// Whether `[[mesh]]` entry `mesh` has a triangle that emits light (an area light).
    pub fn mesh_emits(&self, mesh: usize) -> bool {
        self.mesh_ranges.get(mesh).is_some_and(|r| {
            self.geometry.triangles[r.clone()]
                .iter()
                .any(|t| self.materials[t.material as usize].emission.max_element() > 0.0)
        })
    }

    pub fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        self.bvh
            .intersect(origin, dir, f32::INFINITY)
            .map(|raw| self.geometry.hit(origin, dir, raw))
    }

    /// The closest hit beyond distance `t0` along the ray (its `t` measured from `origin`).
    pub(crate) fn intersect_after(&self, origin: Vec3, dir: Vec3, t0: f32) -> Option<Hit> {
        self.bvh
            .intersect_range(origin, dir, t0, f32::INFINITY)
            .map(|raw| self.geometry.hit(origin, dir, raw))
    }

    /// The first hit of a final-gather ray: on a plain diffuse surface the light hit of
    /// [`Geometry::hit_flat`] (all a gather reads there), elsewhere the full one.
    pub(crate) fn intersect_gather(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let raw = self.bvh.intersect(origin, dir, f32::INFINITY)?;
        let tri = &self.geometry.triangles[raw.prim as usize];
        Some(match &self.materials[tri.material as usize].bsdf {
            crate::material::Bsdf::Diffuse { .. } => self.geometry.hit_flat(origin, dir, raw),
            _ => self.geometry.hit(origin, dir, raw),
        })
    }

    /// Whether no surface of any kind (invisible boundaries included) lies between points `a` and `b`.
    pub(crate) fn segment_clear(&self, a: Vec3, b: Vec3) -> bool {
        let (d, len) = ((b - a).normalize_or_zero(), (b - a).length());
        d == Vec3::ZERO || !self.bvh.occluded(a, d, len)
    }

    /// Whether the segment from `hit` toward a light point is blocked.
    pub(crate) fn occluded(&self, hit: &Hit, wi: Vec3, dist: f32) -> bool {
        let o = spawn(hit, wi);
        let tmax = if dist.is_finite() {
            (dist - (o - hit.p).length()) * (1.0 - 1e-4)
        } else {
            f32::INFINITY
        };
        tmax > 0.0 && self.bvh.occluded(o, wi, tmax)
    }

    /// The participating medium with id `id`, if the scene has media and it is not clear.
    #[inline]
    pub(crate) fn medium(&self, id: MediumId) -> Option<&Medium> {
        self.media.as_ref()?.get(id)
    }

    /// The medium a ray leaving `hit` toward `dir` travels in, given the one the arriving ray was in.
    #[inline]
    pub(crate) fn medium_after(&self, hit: &Hit, dir: Vec3, current: MediumId) -> MediumId {
        match &self.media {
            Some(m) => m.after(hit.tri, hit.ng, dir, current),
            None => current,
        }
    }

    /// A ray from `origin` along `dir` in `medium` crossing the null boundary triangle `tri` at distance
    /// `t`: the medium beyond, and where the search for the next surface resumes ([`past`]). That step
    /// passes over every face within it: a ray entering a box within a micrometre of an edge leaves it
    /// there through the next face, and missing that face carried the box's medium on outside (photons
    /// stored in fog across the room). So the medium beyond is the one past the last boundary face in
    /// the step, found by a ray back from one step further on; a face in that further step is met again
    /// ahead to the same effect, as the medium past a face depends only on the face and the direction.
    pub(crate) fn cross(
        &self,
        origin: Vec3,
        dir: Vec3,
        tri: u32,
        t: f32,
        medium: MediumId,
    ) -> (MediumId, f32) {
        let t0 = past(t, origin);
        let Some(media) = &self.media else {
            return (medium, t0);
        };
        let end = past(t0, origin);
        let last = media
            .first_boundary(origin + dir * end, -dir, end - t)
            .unwrap_or(tri);
        let ng = self.geometry.triangles[last as usize].ng;
        (media.after(last, ng, dir, medium), t0)
    }

    /// The medium the camera sits in.
    pub(crate) fn camera_medium(&self) -> MediumId {
        self.media.as_ref().map_or(VACUUM, |m| m.camera())
    }

    /// What reaches `hit` from a light point in direction `wi` at distance `dist`, per channel: 0 or 1
    /// without media; with media, the transmittance through the media on the way (in `medium`, the
    /// medium of the ray that arrived at `hit`), crossing null boundaries. Counts its rays in `rays`.
    pub(crate) fn visibility(
        &self,
        hit: &Hit,
        wi: Vec3,
        dist: f32,
        medium: MediumId,
        rays: &mut u64,
    ) -> Vec3 {
        *rays += 1;
        let Some(media) = &self.media else {
            return if self.occluded(hit, wi, dist) {
                Vec3::ZERO
            } else {
                Vec3::ONE
            };
        };
        let o = spawn(hit, wi);
        let tmax = if dist.is_finite() {
            (dist - (o - hit.p).length()) * (1.0 - 1e-4)
        } else {
            f32::INFINITY
        };
        // The light is no farther than the offset origin (or the distance is NaN): nothing blocks it.
        if tmax.partial_cmp(&0.0) != Some(Ordering::Greater) {
            return Vec3::ONE;
        }
        self.transmittance(
            media,
            o,
            wi,
            tmax,
            media.after(hit.tri, hit.ng, wi, medium),
            rays,
        )
    }

    /// [`visibility`](Self::visibility) from a point inside a medium (no surface to offset from).
    pub(crate) fn visibility_from(
        &self,
        p: Vec3,
        wi: Vec3,
        dist: f32,
        medium: MediumId,
        rays: &mut u64,
    ) -> Vec3 {
        *rays += 1;
        match &self.media {
            Some(media) => self.transmittance(
                media,
                p,
                wi,
                if dist.is_finite() {
                    dist * (1.0 - 1e-4)
                } else {
                    dist
                },
                medium,
                rays,
            ),
            None => {
                let blocked = self.bvh.occluded(
                    p,
                    wi,
                    if dist.is_finite() {
                        dist * (1.0 - 1e-4)
                    } else {
                        dist
                    },
                );
                if blocked {
                    Vec3::ZERO
                } else {
                    Vec3::ONE
                }
            }
        }
    }

    /// Embree's closest hit in (0, tmax) that is not an invisible medium boundary (its `t` from
    /// `origin`): what probes of the geometry (photon-disc coverage) see.
    pub(crate) fn intersect_solid(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmax: f32,
    ) -> Option<crate::accel::embree::RawHit> {
        let mut t0 = 0.0f32;
        for _ in 0..MAX_NULL_CROSSINGS {
            let raw = self.bvh.intersect_range(origin, dir, t0, tmax)?;
            let tri = &self.geometry.triangles[raw.prim as usize];
            if self.media.is_none() || !self.materials[tri.material as usize].bsdf.is_null() {
                return Some(raw);
            }
            t0 = past(raw.t, origin);
        }
        self.give_up_crossings();
        None
    }

    /// The first hit that is not an invisible medium boundary (its `t` from `origin`).
    pub(crate) fn intersect_visible(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        self.intersect_solid(origin, dir, f32::INFINITY)
            .map(|raw| self.geometry.hit(origin, dir, raw))
    }

    /// The first surface other than a null boundary along a ray starting in `medium` (scenes with
    /// media): the hit (its `t` the whole distance), the transmittance on the way and the medium it is
    /// reached in. Counts the rays after the first in `rays`. `segment(start, length, medium,
    /// transmittance before it)` is called for each stretch in a participating medium (a miss's last
    /// one is infinite).
    pub(crate) fn intersect_through(
        &self,
        origin: Vec3,
        dir: Vec3,
        medium: MediumId,
        rays: &mut u64,
        segment: impl FnMut(Vec3, f32, &Medium, Vec3),
    ) -> Option<(Hit, Vec3, MediumId)> {
        let media = self.media.as_ref()?;
        let span = RaySpan {
            origin,
            dir,
            tmax: f32::INFINITY,
        };
        let (raw, tr, medium) = self.walk(media, span, medium, rays, segment);
        raw.map(|raw| (self.geometry.hit(origin, dir, raw), tr, medium))
    }

    /// Transmittance from `o` along `dir` over `(0, tmax)` starting in `medium`: through null boundaries
    /// (each crossing changes the medium), zero at any other surface.
    fn transmittance(
        &self,
        media: &Media,
        o: Vec3,
        dir: Vec3,
        tmax: f32,
        medium: MediumId,
        rays: &mut u64,
    ) -> Vec3 {
        let span = RaySpan {
            origin: o,
            dir,
            tmax,
        };
        match self.walk(media, span, medium, rays, |_, _, _, _| {}) {
            (None, tr, _) => tr,
            (Some(_), _, _) => Vec3::ZERO,
        }
    }

    /// A ray along `span` starting in `medium`, crossing null boundaries on its own line: the first
    /// other surface it meets (`t` from the span's origin; `None` if it meets none), the
    /// transmittance before it and the medium it is in there. `segment` sees each stretch in a
    /// participating medium (start, length, medium, transmittance before it).
    fn walk(
        &self,
        media: &Media,
        span: RaySpan,
        mut medium: MediumId,
        rays: &mut u64,
        mut segment: impl FnMut(Vec3, f32, &Medium, Vec3),
    ) -> (Option<crate::accel::embree::RawHit>, Vec3, MediumId) {
        let RaySpan {
            origin: o,
            dir,
            tmax,
        } = span;
        let (mut tr, mut t0) = (Vec3::ONE, 0.0f32);
        for crossing in 0..MAX_NULL_CROSSINGS {
            if crossing > 0 {
                *rays += 1;
            }
            let raw = self.bvh.intersect_range(o, dir, t0, tmax);
            if let Some(m) = media.get(medium) {
                let len = raw.map_or(tmax, |r| r.t) - t0;
                segment(o + dir * t0, len, m, tr);
                tr *= m.transmittance(len);
            }
            let Some(raw) = raw else {
                return (None, tr, medium);
            };
            let tri = &self.geometry.triangles[raw.prim as usize];
            if !self.materials[tri.material as usize].bsdf.is_null() {
                return (Some(raw), tr, medium);
            }
            (medium, t0) = self.cross(o, dir, raw.prim, raw.t, medium);
            if t0.partial_cmp(&tmax) != Some(Ordering::Less) {
                return (None, tr, medium);
            }
        }
        // Given up: nothing gets through.
        self.give_up_crossings();
        (None, Vec3::ZERO, medium)
    }

    /// [`albedo`](Self::albedo) with its texture averaged over `footprint` (a width in world units
    /// at the hit, converted to texels by the triangle's texture density).
    pub(crate) fn albedo_over(&self, hit: &Hit, footprint: f32) -> Vec3 {
        self.albedo_read(hit, |t| {
            t.lookup_filtered(hit.uv, footprint * self.texel_density[hit.tri as usize])
        })
    }

    /// Diffuse albedo at a hit (texture-resolved; for glossy, the diffuse part of Phong).
    pub(crate) fn albedo(&self, hit: &Hit) -> Vec3 {
        self.albedo_read(hit, |t| t.lookup(hit.uv))
    }

    /// The hit's diffuse albedo, its texture (if any) read by `read`.
    fn albedo_read(&self, hit: &Hit, read: impl Fn(&crate::texture::Texture) -> Vec3) -> Vec3 {
        use crate::material::{glossy_texel, Bsdf};
        match &self.materials[hit.material as usize].bsdf {
            Bsdf::Diffuse { albedo, texture } => match texture {
                Some(t) => read(&self.textures[*t]),
                None => *albedo,
            },
            Bsdf::Glossy {
                albedo,
                specular,
                texture,
                texel_scale,
                ..
            } => match texture {
                Some(t) => glossy_texel(read(&self.textures[*t]), *texel_scale, *specular),
                None => *albedo,
            },
            _ => Vec3::ZERO,
        }
    }

    /// Whether some material has a glossy lobe (the render then has a `glossy` layer).
    pub fn has_glossy(&self) -> bool {
        self.materials.iter().any(|m| {
            matches!(m.bsdf, crate::material::Bsdf::Glossy { specular, .. } if specular != Vec3::ZERO)
        })
    }

    pub(crate) fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }

    /// The BSDF at a hit: its material's, the glossy lobe scaled by the material's `map_Ks` and
    /// `map_Ns` at the hit's texture coordinates.
    pub(crate) fn bsdf(&self, hit: &Hit) -> crate::material::Bsdf {
        let bsdf = &self.materials[hit.material as usize].bsdf;
        match self.gloss_maps.get(hit.material as usize) {
            Some(Some(maps)) => maps.apply(bsdf, hit.uv),
            _ => bsdf.clone(),
        }
    }

    /// The shading frame at `hit` seen from `wo`: [`Frame::new`]'s, its normal turned by the
    /// material's bump or normal map where it has one ([`Frame::smooth`] keeps the normal before it).
    pub(crate) fn frame(&self, hit: &Hit, wo: Vec3) -> Frame {
        let frame = Frame::new(hit, wo);
        match self.bumps.get(hit.material as usize) {
            Some(Some(map)) => match crate::bump::uv_tangents(&self.geometry, hit.tri) {
                Some(d) => {
                    let tangent = self.tangents.at(&self.geometry, hit);
                    frame.bumped(map.normal(hit.ns, d, tangent, hit.uv))
                }
                None => frame,
            },
            _ => frame,
        }
    }

    /// Material `material`'s bump or normal map, if it has one.
    pub(crate) fn bump_map(&self, material: usize) -> Option<&crate::bump::BumpMap> {
        self.bumps.get(material)?.as_deref()
    }

    /// Material `material`'s cutout (`map_d`): the file it was read from and its values.
    pub(crate) fn cutout(&self, material: usize) -> Option<(&Path, &crate::cutout::Mask)> {
        let (path, k) = self.mask_files.get(material)?.as_ref()?;
        Some((path, self.cutouts.as_ref()?.mask(*k)))
    }

    /// Whether some triangle has a cutout (`map_d`).
    pub fn has_cutouts(&self) -> bool {
        self.cutouts.is_some()
    }

    /// Whether some material has a bump or normal map.
    pub fn has_bumps(&self) -> bool {
        !self.bumps.is_empty()
    }

    /// Whether material `material`'s glossy exponent varies over its surface (a `map_Ns`): the
    /// radiance cache, which holds one lobe per material, leaves it out.
    pub(crate) fn exponent_varies(&self, material: usize) -> bool {
        matches!(self.gloss_maps.get(material), Some(Some(m)) if m.exponent.is_some())
    }

    /// Radiance emitted from `hit` toward `wo` (one-sided emitters).
    pub(crate) fn emitted(&self, hit: &Hit, wo: Vec3) -> Vec3 {
        let m = self.material(hit);
        if m.emission == Vec3::ZERO || wo.dot(self.geometry.emit_normal(hit.tri)) <= 0.0 {
            Vec3::ZERO
        } else {
            m.emission
        }
    }

    pub(crate) fn diagonal(&self) -> f32 {
        (self.bounds.1 - self.bounds.0).length()
    }

    /// The occlusion methods' distance: `[render] ao_distance`, else a tenth of the diagonal.
    pub fn ao_distance(&self) -> f32 {
        self.settings.ao_distance.unwrap_or(0.1 * self.diagonal())
    }

    /// Whether any triangle is mirror or glass (unused MTL entries do not count).
    pub(crate) fn has_specular(&self) -> bool {
        self.specular_bvh.is_some()
    }
}
