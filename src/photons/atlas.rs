//! Irradiance baked lazily onto the triangles: what a final-gather ray reads where it ends.
//!
//! Each side of each triangle is cut into square texels along its longest edge and across it, each
//! holding about `every` global photons at the scene's mean density (a sliver along a floor seam gets a
//! row of texels, not a grid of slivers). The first ray that reaches a texel computes the irradiance at
//! the middle of the texel's part of the triangle and stores it in the texel's slot; every later ray
//! reads the slot. Direct light comes from shadow rays to the lights; the caustic and indirect part from
//! a k-NN estimate of the global map's other photons (with the coverage of its disc, as everywhere
//! else). Estimating the direct part from photons too left `pm-fg` 1.1 % dark on Sibenik: the disc
//! blurs the lights' sharp direct light and loses it off edges. A texel's value is a function of its
//! position alone, so which thread computes it first does not change a bit of the image.
//!
//! This replaced Christensen's precomputed irradiance at every fourth photon, read through a
//! nearest-neighbour search with a compatibility test: on Sibenik the search was a quarter of the cache
//! fill, and the 4.6 % of gather rays whose nearest points faced another way (corners, mouldings, the
//! undersides of things) fell back to a full k-NN estimate each — another 40 %. Here a ray reads the
//! surface it hit, whatever its neighbours face; texels nobody reaches are never estimated (the
//! precomputation estimated 195 k points on Sibenik before the first ray; the atlas makes 141 k at 1000²).

use std::f32::consts::SQRT_2;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

use glam::{Vec2, Vec3};
use photon::sampling::{hash_keys, Rng};
use photon::{Estimate, PhotonMap};
use rayon::prelude::*;

use super::coverage::SceneCoverage;
pub use super::texel_track::TexelIrradiance;
use super::texel_track::{DiscChange, Track, Tracks};
use crate::geometry::{Geometry, Hit};
use crate::light::LightSample;
use crate::material::Bsdf;
use crate::scene::Scene;
use crate::warp::luminance;

/// Texels per triangle side at most, per barycentric axis.
pub const MAX_TEXELS_PER_AXIS: u32 = 255;
/// Texel slots at most (40 bytes each, allocated up front, and 20 more with a caustic map); a scene that
/// would need more gets coarser texels.
pub const MAX_TEXEL_SLOTS: u64 = 4 << 20;
/// A texel's caustic estimate serves the whole texel when its disc's radius is at least this many texels
/// (see [`IrradianceAtlas::caustic`]).
pub const CAUSTIC_TEXEL_REACH: f32 = 2.0;

/// The direct light of the point, spot and directional lights at point `p` of the `front` or back side of
/// triangle `tri`: what a reader of an edge texel multiplies by its `albedo_pi`.
pub fn direct_at(scene: &Scene, tri: u32, front: bool, p: Vec3) -> Vec3 {
    let ng = scene.geometry.triangles[tri as usize].ng;
    direct_irradiance(scene, tri, p, if front { ng } else { -ng }, 0, true, false)
}

pub struct IrradianceAtlas {
    /// Each triangle's texel grid, and the first of its slots (front side, then back side).
    grids: Vec<(Grid, u32)>,
    slots: Vec<OnceLock<TexelIrradiance>>,
    /// With a caustic map: each texel's caustic irradiance at its middle, and whether it serves the whole
    /// texel ([`Self::caustic`]).
    caustic: Vec<OnceLock<(Vec3, bool)>>,
    caustic_estimated: AtomicU64,
    /// Edge texels among those estimated (see [`TexelIrradiance::albedo_pi`]).
    edges: AtomicU64,
    k: usize,
    max_radius: f32,
    /// The side of a texel (coarser on triangles too long for [`MAX_TEXELS_PER_AXIS`]).
    spacing: f32,
    estimated: AtomicU64,
    /// Texels holding a value carried from the frame before ([`IrradianceAtlas::carried`]), and
    /// those of them whose photons changed.
    carried: u64,
    updated: u64,
    /// In a sequence's frames: what each estimated texel's value was made of, for the next frame.
    tracks: Option<Tracks>,
}

/// A triangle's texels: square cells of side `cell` along its longest edge PQ (u) and across it toward
/// the third vertex R (v); R sits at (u_r, height).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Grid {
    origin: Vec3,
    u_dir: Vec3,
    v_dir: Vec3,
    cell: f32,
    long: f32,
    u_r: f32,
    height: f32,
    nu: u8,
    nv: u8,
}

impl Grid {
    fn of(a: Vec3, b: Vec3, c: Vec3, spacing: f32) -> Grid {
        let edges = [(a, b, c), (b, c, a), (c, a, b)];
        let (p, q, r) = edges.into_iter().fold(edges[0], |best, e| {
            if (e.1 - e.0).length_squared() > (best.1 - best.0).length_squared() {
                e
            } else {
                best
            }
        });
        let long = (q - p).length();
        let u_dir = (q - p) / long;
        let u_r = (r - p).dot(u_dir);
        let across = (r - p) - u_r * u_dir;
        let height = across.length();
        let v_dir = if height > 0.0 {
            across / height
        } else {
            Vec3::ZERO
        };
        let cell = spacing
            .max(long / MAX_TEXELS_PER_AXIS as f32)
            .max(height / MAX_TEXELS_PER_AXIS as f32);
        if !(long.is_finite() && long > 0.0 && cell.is_finite() && cell > 0.0 && u_dir.is_finite())
        {
            return Grid {
                origin: a,
                u_dir: Vec3::ZERO,
                v_dir: Vec3::ZERO,
                cell: 1.0,
                long: 0.0,
                u_r: 0.0,
                height: 0.0,
                nu: 1,
                nv: 1,
            };
        }
        let count = |len: f32| (len / cell).ceil().clamp(1.0, MAX_TEXELS_PER_AXIS as f32) as u8;
        Grid {
            origin: p,
            u_dir,
            v_dir,
            cell,
            long,
            u_r: u_r.clamp(0.0, long),
            height,
            nu: count(long),
            nv: count(height),
        }
    }

    fn cell(&self, p: Vec3) -> (u32, u32) {
        let d = p - self.origin;
        let at = |x: f32, n: u8| {
            if x.is_finite() {
                (x.max(0.0) as u32).min(n as u32 - 1)
            } else {
                0
            }
        };
        (
            at(d.dot(self.u_dir) / self.cell, self.nu),
            at(d.dot(self.v_dir) / self.cell, self.nv),
        )
    }

    /// Height of the triangle above PQ at `u`.
    fn v_max(&self, u: f32) -> f32 {
        let h = if u <= self.u_r {
            self.height * u / self.u_r
        } else {
            self.height * (self.long - u) / (self.long - self.u_r)
        };
        if h.is_finite() {
            h.clamp(0.0, self.height)
        } else {
            0.0
        }
    }

    /// The middle of the part of cell (i, j) inside the triangle (of its row's part, when the cell misses
    /// the triangle): a texel's estimate is made there. At a slat's edge instead (a cell's middle clamped
    /// into a sliver), the slats of the blinds room came out 7 % dark.
    fn middle(&self, i: u32, j: u32) -> Vec3 {
        let (lo, hi) = (
            i as f32 * self.cell,
            ((i + 1) as f32 * self.cell).min(self.long),
        );
        let u = 0.5 * (lo + hi);
        let top = self.v_max(u);
        let (lo, hi) = (j as f32 * self.cell, ((j + 1) as f32 * self.cell).min(top));
        let v = if hi > lo { 0.5 * (lo + hi) } else { 0.5 * top };
        self.origin + u * self.u_dir + v * self.v_dir
    }
}

/// Texture samples averaged into a texel's albedo (4 × 4, stratified over its part of the triangle).
const TEXEL_ALBEDO_SIDE: u32 = 2;

/// The mean diffuse albedo of texel (i, j) of triangle `tri`: the material's constant one, or the mean of
/// its texture at [`TEXEL_ALBEDO_SIDE`]² stratified points of the texel's part of the triangle (jittered
/// by a generator seeded with `seed`). Gather rays read it with the texel's irradiance instead of a
/// texture lookup each: on Sibenik those lookups, a cache miss each, were a tenth of the cache fill.
/// The rays that reach a texel land about uniformly over it, so the mean is what they would have averaged.
/// Each triangle's texel grid at texel side `spacing`.
fn grids(geometry: &Geometry, spacing: f32) -> Vec<Grid> {
    geometry
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.v.map(|i| geometry.positions[i as usize]);
            Grid::of(a, b, c, spacing)
        })
        .collect()
}

fn texel_albedo(scene: &Scene, tri: u32, grid: &Grid, i: u32, j: u32, seed: u64) -> Vec3 {
    let t = &scene.geometry.triangles[tri as usize];
    let material = &scene.materials[t.material as usize].bsdf;
    // A glossy material's texel is scaled as at a hit (`Scene::albedo`).
    let (texture, glossy) = match *material {
        Bsdf::Diffuse {
            texture: Some(k), ..
        } => (&scene.textures[k], None),
        Bsdf::Glossy {
            texture: Some(k),
            texel_scale,
            specular,
            ..
        } => (&scene.textures[k], Some((texel_scale, specular))),
        Bsdf::Diffuse { albedo, .. } | Bsdf::Glossy { albedo, .. } => {
            return material.diffuse_albedo(albedo)
        }
        _ => return Vec3::ZERO,
    };
    let [a, b, c] = t.v.map(|k| scene.geometry.positions[k as usize]);
    let [ua, ub, uc] = if t.has_uv {
        t.v.map(|k| scene.geometry.uvs[k as usize])
    } else {
        [Vec2::ZERO; 3]
    };
    let (e1, e2) = (b - a, c - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let det = d11 * d22 - d12 * d12;
    let uv_at = |p: Vec3| -> Vec2 {
        let d = p - a;
        let (q1, q2) = (d.dot(e1), d.dot(e2));
        let (b1, b2) = ((d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det);
        let (b1, b2) = if b1.is_finite() && b2.is_finite() {
            (b1, b2)
        } else {
            (0.0, 0.0)
        };
        // As at a hit: a mesh without texture coordinates reads its texture at the barycentrics.
        if t.has_uv {
            ua * (1.0 - b1 - b2) + ub * b1 + uc * b2
        } else {
            Vec2::new(b1, b2)
        }
    };
    let points = texel_points(grid, i, j, TEXEL_ALBEDO_SIDE, hash_keys(&[seed, 0xa1bed0]));
    let mean = points
        .iter()
        .map(|&q| {
            let t = texture.lookup(uv_at(q));
            glossy.map_or(t, |(scale, ks)| crate::material::glossy_texel(t, scale, ks))
        })
        .sum::<Vec3>()
        / points.len() as f32;
    material.diffuse_albedo(mean)
}

/// Shadow rays per area light sample set at a texel (stratified over the light's surface).
const TEXEL_AREA_SAMPLES: u32 = 16;

/// Irradiance straight from the lights at point `p` of triangle `tri` on the side facing `n`, by shadow
/// rays: every point, spot and directional light once (`delta`), and area lights by
/// [`TEXEL_AREA_SAMPLES`] samples from a generator seeded with `seed` (`area`; the texel's value stays a
/// function of the texel).
pub(crate) fn direct_irradiance(
    scene: &Scene,
    tri: u32,
    p: Vec3,
    n: Vec3,
    seed: u64,
    delta: bool,
    area: bool,
) -> Vec3 {
    let hit = Hit {
        p,
        t: 0.0,
        ng: n,
        ns: n,
        uv: Vec2::ZERO,
        tri,
        material: scene.geometry.triangles[tri as usize].material,
    };
    // With media: the medium on the texel's side, and shadow rays through it.
    let medium = scene.media.as_ref().map_or(crate::medium::VACUUM, |m| {
        m.medium_at(crate::geometry::spawn(&hit, n))
    });
    let arrive = |ls: &LightSample| -> Vec3 {
        let cos = ls.wi.dot(n);
        if !(ls.pdf > 0.0 && cos > 0.0) {
            return Vec3::ZERO;
        }
        let vis = scene.visibility(&hit, ls.wi, ls.dist, medium, &mut 0);
        if vis == Vec3::ZERO {
            return Vec3::ZERO;
        }
        ls.li * cos / ls.pdf * vis
    };
    let lights = &scene.lights;
    let mut e = Vec3::ZERO;
    if delta {
        e += lights
            .delta_samples(&scene.geometry, p)
            .map(|ls| arrive(&ls))
            .sum::<Vec3>();
    }
    if area && lights.has_area() {
        let mut rng = Rng::new(hash_keys(&[seed, 0x7e7e1]));
        let side = (TEXEL_AREA_SAMPLES as f32).sqrt() as u32;
        for s in 0..TEXEL_AREA_SAMPLES {
            let (a, b) = ((s % side) as f32, (s / side) as f32);
            let u = [
                rng.uniform(),
                (a + rng.uniform()) / side as f32,
                (b + rng.uniform()) / side as f32,
            ];
            if let Some(ls) = lights.sample_area(&scene.geometry, p, u) {
                e += arrive(&ls) / TEXEL_AREA_SAMPLES as f32;
            }
        }
    }
    e
}

/// Points per texel side at which the point, spot and directional lights are tested (2 × 2, stratified
/// over the texel's part of the triangle).
const EDGE_PROBE_SIDE: u32 = 2;
/// A texel whose direct light from those lights differs between its probe points by more than this
/// fraction of their mean (luminance) is an edge texel (see [`TexelIrradiance::albedo_pi`]).
const EDGE_CONTRAST: f32 = 0.25;

/// `side`² stratified points of texel (i, j)'s part of the triangle (jittered by a generator seeded with
/// `seed`); its middle when no stratum meets the triangle.
fn texel_points(grid: &Grid, i: u32, j: u32, side: u32, seed: u64) -> Vec<Vec3> {
    let mut rng = Rng::new(seed);
    let mut points = Vec::with_capacity((side * side) as usize);
    for s in 0..side * side {
        let (ku, kv) = ((s % side) as f32, (s / side) as f32);
        let u = (i as f32 + (ku + rng.uniform()) / side as f32) * grid.cell;
        let v_lo = j as f32 * grid.cell;
        let v_hi = ((j + 1) as f32 * grid.cell).min(grid.v_max(u.min(grid.long)));
        if !(u <= grid.long && v_hi > v_lo) {
            continue;
        }
        let v = v_lo + (kv + rng.uniform()) / side as f32 * (v_hi - v_lo);
        points.push(grid.origin + u * grid.u_dir + v * grid.v_dir);
    }
    if points.is_empty() {
        points.push(grid.middle(i, j));
    }
    points
}

/// The direct light of the point, spot and directional lights over texel (i, j): the mean over its probe
/// points, and whether they disagree (an edge texel).
fn delta_over_texel(
    scene: &Scene,
    tri: u32,
    grid: &Grid,
    i: u32,
    j: u32,
    n: Vec3,
    seed: u64,
) -> (Vec3, bool) {
    if scene
        .lights
        .delta_samples(&scene.geometry, grid.middle(i, j))
        .next()
        .is_none()
    {
        return (Vec3::ZERO, false);
    }
    let values: Vec<Vec3> = texel_points(grid, i, j, EDGE_PROBE_SIDE, hash_keys(&[seed, 0xed6e]))
        .into_iter()
        .map(|q| direct_irradiance(scene, tri, q, n, seed, true, false))
        .collect();
    let mean = values.iter().copied().sum::<Vec3>() / values.len() as f32;
    let lum: Vec<f32> = values.iter().map(|&v| luminance(v)).collect();
    let (lo, hi) = lum.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &l| {
        (lo.min(l), hi.max(l))
    });
    (mean, hi - lo > EDGE_CONTRAST * luminance(mean))
}

/// A texel: its slot, and the triangle side and cell it belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    pub(crate) index: u32,
    pub(crate) tri: u32,
    pub(crate) front: bool,
    i: u32,
    j: u32,
}

/// Counts for the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AtlasStats {
    /// Texels of the scene (estimated or not).
    pub slots: u64,
    pub estimates: u64,
    /// Texels whose value the frame before of a sequence estimated (see [`IrradianceAtlas::carried`]),
    /// and those of them whose photons changed.
    pub carried: u64,
    pub updated: u64,
    /// Caustic estimates made at texel middles ([`IrradianceAtlas::caustic`]).
    pub caustic_estimates: u64,
    /// Estimated texels whose direct light varies across them: their readers shade it at their own point.
    pub edges: u64,
    pub memory_bytes: u64,
}

impl IrradianceAtlas {
    /// An empty atlas over `geometry` whose texels hold `every` global photons of `n_photons` spread over
    /// the scene's surface.
    pub fn new(
        geometry: &Geometry,
        n_photons: usize,
        every: usize,
        k: usize,
        max_radius: f32,
    ) -> Self {
        let area: f64 = geometry.triangles.iter().map(|t| t.area as f64).sum();
        let per_texel = (area * every.max(1) as f64 / n_photons.max(1) as f64).sqrt() as f32;
        let mut spacing = if per_texel.is_finite() && per_texel > 0.0 {
            per_texel
        } else {
            f32::INFINITY
        };
        loop {
            let grids = grids(geometry, spacing);
            let n_slots: u64 = grids.iter().map(|g| 2 * g.nu as u64 * g.nv as u64).sum();
            if n_slots > MAX_TEXEL_SLOTS && spacing.is_finite() {
                spacing *= 1.5;
                continue;
            }
            return Self::of_grids(grids, spacing, k, max_radius);
        }
    }

    /// An empty atlas of these texel grids.
    fn of_grids(grids: Vec<Grid>, spacing: f32, k: usize, max_radius: f32) -> Self {
        let mut first = 0u32;
        let grids: Vec<(Grid, u32)> = grids
            .into_iter()
            .map(|g| {
                let at = first;
                first += 2 * g.nu as u32 * g.nv as u32;
                (g, at)
            })
            .collect();
        IrradianceAtlas {
            grids,
            slots: (0..first).map(|_| OnceLock::new()).collect(),
            caustic: Vec::new(),
            caustic_estimated: AtomicU64::new(0),
            edges: AtomicU64::new(0),
            k,
            max_radius,
            spacing,
            estimated: AtomicU64::new(0),
            carried: 0,
            updated: 0,
            tracks: None,
        }
    }

    /// The atlas keeping what each texel's value is made of, so that the next frame of a sequence
    /// can carry it ([`Self::carried`]).
    pub fn tracking(mut self) -> Self {
        self.tracks = Some(Tracks::new());
        self
    }

    /// The atlas of the next frame of a sequence over `geometry` (the same triangles, some of them
    /// moved), with this one's texels: a texel estimated here keeps its value where its triangle did
    /// not move and `keep(texel middle, reach)` finds that neither the geometry its estimate's disc
    /// probes nor its lights' shadow rays changed within `reach` of the middle; its value then moves
    /// by `change(middle, normal, squared radius, half thickness)`, the photons that entered its
    /// disc less those that left (see [`Track`]). Every other texel is estimated again when a ray reaches it.
    /// Its caustic slots, if any, start empty. The next atlas keeps tracks too.
    pub fn carried(
        self,
        geometry: &Geometry,
        keep: impl Fn(Vec3, f32) -> bool + Sync,
        change: impl Fn(Vec3, Vec3, f32, f32) -> DiscChange + Sync,
    ) -> IrradianceAtlas {
        let mut next = Self::of_grids(
            grids(geometry, self.spacing),
            self.spacing,
            self.k,
            self.max_radius,
        )
        .tracking();
        let Some(tracks) = self.tracks else {
            return next;
        };
        if next.grids.len() != self.grids.len() {
            return next;
        }
        let tracks = tracks.by_slot(self.slots.len());
        let kept: Vec<Vec<(u32, Track, bool)>> = (0..self.grids.len())
            .into_par_iter()
            .map(|tri| {
                let ((grid, first), (now, at)) = (self.grids[tri], next.grids[tri]);
                if grid != now {
                    return Vec::new();
                }
                let ng = geometry.triangles[tri].ng;
                let side = grid.nu as u32 * grid.nv as u32;
                (0..2 * side)
                    .filter_map(|s| {
                        let track = tracks.get(first + s)?;
                        let (i, j) = ((s % side) % grid.nu as u32, (s % side) / grid.nu as u32);
                        let middle = grid.middle(i, j);
                        if !keep(middle, grid.cell * SQRT_2) {
                            return None;
                        }
                        let n = if s < side { ng } else { -ng };
                        let d = change(middle, n, track.within2, track.half_thickness);
                        let moved = d != DiscChange::default();
                        Some((at + s, track.updated(d)?, moved))
                    })
                    .collect()
            })
            .collect();
        let next_tracks = Tracks::new();
        for (slot, track, moved) in kept.into_iter().flatten() {
            next.slots[slot as usize] = OnceLock::from(track.texel());
            next_tracks.push(slot, track);
            next.carried += 1;
            next.updated += moved as u64;
        }
        next.tracks = Some(next_tracks);
        next
    }

    /// Irradiance of the global map on the `front` (winding) or back side of triangle `tri`, at the texel
    /// holding `p`.
    pub fn lookup(
        &self,
        cov: &SceneCoverage,
        global: &PhotonMap,
        tri: u32,
        front: bool,
        p: Vec3,
    ) -> TexelIrradiance {
        self.read(cov, global, self.texel(tri, front, p))
    }

    /// The texel holding `p` on the `front` (winding) or back side of triangle `tri`.
    pub fn texel(&self, tri: u32, front: bool, p: Vec3) -> Texel {
        let (grid, first) = &self.grids[tri as usize];
        let (i, j) = grid.cell(p);
        let side = if front {
            0
        } else {
            grid.nu as u32 * grid.nv as u32
        };
        Texel {
            index: first + side + j * grid.nu as u32 + i,
            tri,
            front,
            i,
            j,
        }
    }

    /// Texels of triangle `tri` (both sides), and the index of its first.
    pub fn texel_range(&self, tri: u32) -> (u32, u32) {
        let (grid, first) = &self.grids[tri as usize];
        (2 * grid.nu as u32 * grid.nv as u32, *first)
    }

    /// Photons per texel estimate, and the search radius's limit.
    pub fn search(&self) -> (usize, f32) {
        (self.k, self.max_radius)
    }

    /// The middle of a texel's part of its triangle (where its estimates are made).
    pub fn middle(&self, texel: &Texel) -> Vec3 {
        self.grids[texel.tri as usize].0.middle(texel.i, texel.j)
    }

    /// A texel's value: its slot's, estimated first if no ray has reached it yet.
    pub fn read(&self, cov: &SceneCoverage, global: &PhotonMap, texel: Texel) -> TexelIrradiance {
        self.read_given(cov, global, texel, None)
    }

    /// [`read`](Self::read), given the estimate of the texel's photons that are not direct (its `e`)
    /// and the irradiance of the indirect ones when the caller has made it over the texel's
    /// neighbourhood already (the glossy texels do: one search then serves both). The same sums either
    /// way, so the value does not depend on who reaches the texel first.
    pub fn read_given(
        &self,
        cov: &SceneCoverage,
        global: &PhotonMap,
        texel: Texel,
        given: Option<(Estimate, Vec3)>,
    ) -> TexelIrradiance {
        let Texel {
            index,
            tri,
            front,
            i,
            j,
        } = texel;
        *self.slots[index as usize].get_or_init(|| {
            let grid = &self.grids[tri as usize].0;
            let scene = cov.0;
            let t = &scene.geometry.triangles[tri as usize];
            let n = if front { t.ng } else { -t.ng };
            let middle = grid.middle(i, j);
            let (est, e_indirect) = given.unwrap_or_else(|| {
                global.irradiance_not_direct(middle, n, self.k, self.max_radius, cov)
            });
            self.estimated.fetch_add(1, Ordering::Relaxed);
            let area = direct_irradiance(scene, tri, middle, n, index as u64, false, true);
            let (delta, edge) = delta_over_texel(scene, tri, grid, i, j, n, index as u64);
            let albedo_pi =
                texel_albedo(scene, tri, grid, i, j, index as u64) / std::f32::consts::PI;
            if edge {
                self.edges.fetch_add(1, Ordering::Relaxed);
            }
            let track = Track {
                e_not_direct: est.e,
                e_indirect,
                light: if edge { area } else { delta + area },
                albedo_pi,
                edge,
                within2: est.within2,
                half_thickness: est.half_thickness,
                area: est.area,
                n: est.n_found,
                n0: est.n_found,
            };
            if let Some(tracks) = &self.tracks {
                tracks.push(index, track);
            }
            track.texel()
        })
    }

    /// What texel `texel`'s value is made of, where the atlas keeps it.
    #[cfg(test)]
    pub(crate) fn track(&self, texel: &Texel) -> Option<Track> {
        let tracks = self.tracks.as_ref()?;
        tracks.find(texel.index)
    }

    pub fn stats(&self) -> AtlasStats {
        AtlasStats {
            slots: self.slots.len() as u64,
            estimates: self.estimated.load(Ordering::Relaxed),
            carried: self.carried,
            updated: self.updated,
            caustic_estimates: self.caustic_estimated.load(Ordering::Relaxed),
            edges: self.edges.load(Ordering::Relaxed),
            memory_bytes: (self.slots.len() * std::mem::size_of::<OnceLock<TexelIrradiance>>()
                + self.caustic.len() * std::mem::size_of::<OnceLock<(Vec3, bool)>>()
                + self.grids.len() * std::mem::size_of::<(Grid, u32)>())
                as u64,
        }
    }

    /// Caustic texels too (a slot per texel, empty until read): see [`Self::caustic`].
    pub fn with_caustic(mut self) -> Self {
        self.caustic = (0..self.slots.len()).map(|_| OnceLock::new()).collect();
        self
    }

    /// The caustic irradiance at the texel holding `p` on the `front` or back side of triangle `tri`
    /// (geometric normal `ng`), where the caustic is smooth at the texel's scale: `estimate(middle, normal)` is made once per
    /// texel, at its middle, and its value serves the whole texel when its disc is wide next to the
    /// texel — [`CAUSTIC_TEXEL_REACH`] texels in radius, or the lookup's maximum radius (fewer than k
    /// caustic photons within it: a faint caustic of sparse photons) and at least a texel. `None` where
    /// the texel's estimate is sharper (a focused caustic): the caller estimates at `p` itself. The
    /// value is a function of the texel alone, whichever sample reads it first.
    pub fn caustic(
        &self,
        tri: u32,
        ng: Vec3,
        front: bool,
        p: Vec3,
        estimate: impl FnOnce(Vec3, Vec3) -> Estimate,
    ) -> Option<Vec3> {
        if self.caustic.is_empty() {
            return None;
        }
        let t = self.texel(tri, front, p);
        let grid = &self.grids[tri as usize].0;
        let (e, smooth) = *self.caustic[t.index as usize].get_or_init(|| {
            self.caustic_estimated.fetch_add(1, Ordering::Relaxed);
            let est = estimate(grid.middle(t.i, t.j), if front { ng } else { -ng });
            (
                est.e,
                est.radius >= CAUSTIC_TEXEL_REACH * grid.cell
                    || (est.hit_max_radius && est.radius >= grid.cell),
            )
        });
        smooth.then_some(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;

    #[test]
    fn a_sliver_gets_a_row_of_texels_and_centres_stay_on_it() {
        // 10 m long, 2 cm wide, texels of 0.5 m: 20 × 1.
        let (a, b, c) = (
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(5.0, 0.02, 0.0),
        );
        let g = Grid::of(a, b, c, 0.5);
        assert_eq!((g.nu, g.nv), (20, 1));
        assert_eq!(g.cell(Vec3::new(7.3, 0.01, 0.0)), (14, 0));
        // Outside the triangle: clamped to the grid.
        assert_eq!(g.cell(Vec3::new(-1.0, 5.0, 0.0)), (0, 0));
        assert_eq!(g.cell(Vec3::new(11.0, -5.0, 0.0)), (19, 0));
        // The middle of the first texel: 0.25 m along, halfway up the sliver's height there.
        let m = g.middle(0, 0);
        assert!((m - Vec3::new(0.25, 0.0005, 0.0)).length() < 1e-5, "{m}");
        // The last texel is cut at the far vertex: its middle too.
        let m = g.middle(19, 0);
        assert!((m - Vec3::new(9.75, 0.0005, 0.0)).length() < 1e-5, "{m}");
        // A right triangle 2 × 1 m: 4 × 2 texels (its longest edge is the hypotenuse).
        let g = Grid::of(
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            0.5,
        );
        assert_eq!((g.nu, g.nv), (5, 2));
    }

    #[test]
    fn a_wide_caustic_estimate_serves_its_texel_and_a_narrow_one_does_not() {
        // One triangle of 2 m² (its longest edge along x), 100 photons, 8 a texel: texels of 0.4 m.
        let tri = Triangle {
            v: [0, 1, 2],
            material: 0,
            ng: Vec3::Z,
            area: 2.0,
            has_normals: false,
            has_uv: false,
        };
        let geometry = Geometry {
            positions: vec![
                Vec3::ZERO,
                Vec3::new(4.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
            ],
            triangles: vec![tri],
            ..Default::default()
        };
        let atlas = IrradianceAtlas::new(&geometry, 100, 8, 50, 1.0);
        let cell = atlas.grids[0].0.cell;
        assert!((cell - 0.4).abs() < 1e-4, "{cell}");
        assert_eq!(
            atlas.caustic(
                0,
                Vec3::Z,
                true,
                Vec3::new(0.1, 0.1, 0.0),
                |_, _| unreachable!()
            ),
            None,
            "no caustic map"
        );
        let atlas = atlas.with_caustic();
        let calls = &std::cell::Cell::new(0);
        let estimate = |radius: f32, hit_max_radius: bool| {
            move |middle: Vec3, n: Vec3| {
                calls.set(calls.get() + 1);
                assert_eq!(n.z.abs(), 1.0);
                Estimate {
                    e: middle,
                    radius,
                    hit_max_radius,
                    ..Default::default()
                }
            }
        };
        // Two points of one texel: one estimate, at the texel's middle (0.2 along, halfway up the
        // triangle's 0.1 m there), for both.
        let (p, q) = (Vec3::new(0.05, 0.01, 0.0), Vec3::new(0.35, 0.1, 0.0));
        let first = atlas.caustic(0, Vec3::Z, true, p, estimate(2.0 * cell, false));
        assert!(
            first.is_some_and(|e| (e - Vec3::new(0.2, 0.05, 0.0)).length() < 1e-5),
            "{first:?}"
        );
        assert_eq!(
            atlas.caustic(0, Vec3::Z, true, q, estimate(0.0, false)),
            first
        );
        assert_eq!(calls.get(), 1);
        // The back side is another texel (estimated with the back's normal). A disc of a texel and a
        // half: per sample, unless it reached the lookup's maximum radius (a faint caustic).
        let back = |m: Vec3, n: Vec3| {
            assert_eq!(n, Vec3::NEG_Z);
            estimate(1.5 * cell, false)(m, n)
        };
        assert_eq!(atlas.caustic(0, Vec3::Z, false, p, back), None);
        assert!(atlas
            .caustic(
                0,
                Vec3::Z,
                true,
                Vec3::new(1.0, 0.1, 0.0),
                estimate(1.5 * cell, true)
            )
            .is_some());
        assert_eq!(
            atlas.caustic(
                0,
                Vec3::Z,
                true,
                Vec3::new(2.0, 0.1, 0.0),
                estimate(0.5 * cell, true)
            ),
            None
        );
        assert_eq!(calls.get(), 4);
        assert_eq!(atlas.stats().caustic_estimates, 4);
    }
}
