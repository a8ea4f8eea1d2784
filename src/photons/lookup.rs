//! The photon maps as the render uses them: tracing them, and the lookups the integrators make —
//! caustic and indirect irradiance, radiance at final-gather ends through the atlas, glossy estimates,
//! and the media's in-scattered radiance.

use std::sync::atomic::AtomicBool;

use glam::Vec3;
use icache::media::MediaCache;
use photon::reach::ReachGrid;
use photon::{PhotonMap, PhotonMaps, PhotonTargets, TraceStats};

use super::atlas::IrradianceAtlas;
use super::coverage::SceneCoverage;
use super::glossy_texels::GlossyTexels;
use super::photon_scene::PhotonView;
use super::settings::PhotonSettings;
use super::texel_track::DiscChange;
use super::volume_lattice::{LatticeRecord, Photons, Surroundings, VolumeGrid, LATTICE_WALLS};
use crate::counters::SampleCounters;
use crate::error::Result;
use crate::geometry::Hit;
use crate::scene::Scene;

/// Photons per atlas texel estimate: a third of the lookup's `k` (at least 8, at most `k`). A texel is
/// read only by final-gather rays, and a gather averages hundreds of texels, so a texel's noise averages
/// out while the blur of a wider disc does not; its direct part comes from shadow rays, so only the
/// smooth caustic and indirect part is estimated. Fewer photons per estimate also make the k-NN
/// searches, a large share of the render, cheaper.
pub fn atlas_k(lookup: usize) -> usize {
    (lookup / 3).max(8).min(lookup)
}

/// Where a final-gather ray ends on a non-specular surface: the `front` or back side of triangle `tri`
/// at `p`, and on a glossy surface its lobe.
#[derive(Clone, Copy, Debug)]
pub struct GatherHit {
    pub tri: u32,
    pub front: bool,
    pub p: Vec3,
    pub lobe: Option<GatherLobe>,
}

/// A glossy surface's lobe where a gather ray ends: its material, specular reflectance, shading normal
/// and the direction back along the ray.
#[derive(Clone, Copy, Debug)]
pub struct GatherLobe {
    pub material: u32,
    pub ks: Vec3,
    pub n: Vec3,
    pub wo: Vec3,
}

thread_local! {
    static NEIGHBORS: std::cell::RefCell<Vec<photon::Neighbor>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// The photon maps with what the render reads them through: the maps and their settings, the scene's
/// coverage of estimate discs, and lookup accelerators for the surfaces and for the media. Built once
/// by the `build_maps` phase; the atlas and the volume grid fill lazily as shading reads them.
pub struct PhotonData<'a> {
    maps: PhotonMaps,
    settings: PhotonSettings,
    /// What part of each estimate's disc is surface (the scene's geometry answers).
    coverage: SceneCoverage<'a>,
    surfaces: SurfaceLookups,
    media: MediaLookups,
}

/// Accelerators of the surface maps' lookups.
struct SurfaceLookups {
    /// Where the caustic map has a photon within its lookup radius (most shading samples have none).
    caustic_reach: Option<ReachGrid>,
    /// The global map's irradiance baked lazily onto the triangles, for final-gather rays.
    atlas: Option<IrradianceAtlas>,
    /// The light arriving at glossy surfaces per atlas texel, for gather rays ending there.
    glossy: Option<GlossyTexels>,
}

/// What the media's estimates read besides the volume maps.
struct MediaLookups {
    /// The volume map's in-scattered radiance baked lazily over the media, for final-gather rays.
    volume_grid: Option<VolumeGrid>,
    /// The photons camera rays' multiple scattering sums: without the L S+ V ones when the volume
    /// caustic map has them (denser).
    camera_photons: Photons,
}

impl<'a> PhotonData<'a> {
    /// Both maps, to their targets or as `over` says (an animation's frame: over the paths an
    /// earlier frame's maps took, copying those nothing that moved touched, see
    /// [`photon::retrace_photons`]), and the trace's path log if `over` asks for one; `Interrupted`
    /// soon after `cancel` is set.
    pub fn trace(
        scene: &Scene,
        settings: &PhotonSettings,
        over: photon::Over,
        seed: u64,
        progress: &(dyn Fn(u64, u64) + Sync),
        cancel: &AtomicBool,
    ) -> Result<(PhotonMaps, TraceStats, Option<photon::PathLog>)> {
        let (view, targets) = (PhotonView(scene), Self::targets(settings));
        match photon::retrace_photons(&view, &targets, over, seed, progress, cancel) {
            Ok(r) => Ok(r),
            Err(photon::Error::Cancelled) => Err(crate::error::Error::Interrupted),
            // No light reaches any non-specular surface: there is no caustic or indirect light to
            // estimate, so the render goes on with empty maps (counted in the statistics).
            Err(photon::Error::NothingStored { n_paths_emitted }) => Ok((
                PhotonMaps::default(),
                TraceStats {
                    n_paths_emitted,
                    ..Default::default()
                },
                None,
            )),
            Err(e) => Err(crate::error::runtime(format!("photon pass: {e}"))),
        }
    }

    /// Stored-photon targets, with a path budget after which the pass stops instead of looping.
    pub fn targets(settings: &PhotonSettings) -> PhotonTargets {
        let mut t = photon::defaults::default_targets(settings.global, settings.caustic);
        if settings.volume > 0 {
            t.volume = settings.volume;
            t.volume_caustic = settings.volume_caustic;
            let more = settings.volume.saturating_add(settings.volume_caustic);
            t.max_paths = photon::defaults::default_targets(
                settings.global.saturating_add(more),
                settings.caustic,
            )
            .max_paths;
        }
        t
    }

    /// In-scattered radiance σs·Li at `x` toward a final-gather ray travelling along `d` (medium asymmetry
    /// `g`), all volume photons counted (single scattering included): the volume grid's.
    pub fn gather_volume_radiance(&self, x: Vec3, d: Vec3, g: f32) -> Vec3 {
        match (&self.media.volume_grid, &self.maps.volume) {
            (Some(grid), Some(map)) => {
                grid.radiance(x, d, g, &|p| self.lattice_record(map, p, grid.cell()))
            }
            _ => Vec3::ZERO,
        }
    }

    /// The volume lattice's record at `p`: the estimate over all volume photons (with its gradient),
    /// fitted over what `p` sees as a camera ray's step is, and the occluders within reach of the
    /// reads that use it (a lattice cell's diagonal); `None` where `p` lies in no scattering medium,
    /// or sees no photon (inside an occluder, behind a wall).
    fn lattice_record(&self, map: &PhotonMap, p: Vec3, cell: f32) -> Option<LatticeRecord> {
        let scene = self.coverage.0;
        let media = scene.media.as_ref()?;
        let scatters = scene
            .medium(media.medium_at(p))
            .is_some_and(|m| m.sigma_s.max_element() > 0.0);
        if !scatters {
            return None;
        }
        let around = self.volume_view(p);
        let est = super::volume_lattice::estimate_within(
            map,
            p,
            (self.settings.lookup, self.settings.max_radius_volume),
            Photons::All,
            true,
            around.as_ref(),
            None,
        );
        (est.rec.s[0].max_element() > 0.0).then(|| LatticeRecord {
            rec: est.rec,
            walls: around.map_or([(Vec3::ZERO, f32::INFINITY); LATTICE_WALLS], |a| {
                a.occluders(cell * 3f32.sqrt())
            }),
        })
    }

    /// In-scattered radiance σs·Li at `x` toward a ray travelling along `d` (asymmetry `g`) from the
    /// volume caustic map: Jensen & Christensen's Σ p·ΔΦ / (4/3 π r³) over the k nearest photons, at
    /// full resolution where the beam is (zero where the map has no photon within reach).
    pub fn volume_caustic_radiance(
        &self,
        x: Vec3,
        d: Vec3,
        g: f32,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let Some(map) = &self.maps.volume_caustic else {
            return Vec3::ZERO;
        };
        let (k, cap) = (
            self.settings.lookup,
            self.settings.max_radius_volume_caustic,
        );
        NEIGHBORS.with(|nb| {
            let mut nb = nb.borrow_mut();
            map.knn(x, k, cap, &mut nb);
            let r2 = if nb.len() >= k {
                nb.last().map_or(0.0, |n| n.dist2)
            } else {
                cap * cap
            };
            if nb.is_empty() || r2.is_nan() || r2 <= 0.0 {
                return Vec3::ZERO;
            }
            c.photon_estimates += 1;
            let photons = map.photons();
            let sum: Vec3 = nb
                .iter()
                .map(|n| &photons[n.index as usize])
                .map(|ph| ph.power * crate::medium::phase(g, d, ph.wi))
                .sum();
            sum / (4.0 / 3.0 * std::f32::consts::PI * r2 * r2.sqrt())
        })
    }

    /// Multiply scattered radiance σs·Li at `x` toward a camera ray travelling along `d` (asymmetry
    /// `g`): the media radiance cache's where `cache` has records there, else the volume map's estimate.
    pub fn cached_multiple(
        &self,
        cache: Option<&MediaCache>,
        x: Vec3,
        d: Vec3,
        g: f32,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let Some(map) = &self.maps.volume else {
            return Vec3::ZERO;
        };
        let mut ratio = Vec3::ONE;
        let cached = cache.and_then(|cache| {
            c.media_lookups += 1;
            let found = cache.lookup(x, d);
            c.media_misses += found.is_none() as u64;
            found.map(|(s, r)| {
                ratio = r;
                s
            })
        });
        let s = cached.unwrap_or_else(|| {
            c.photon_estimates += 1;
            let (k, cap) = (self.settings.lookup, self.settings.max_radius_volume);
            let around = self.volume_view(x);
            let est = super::volume_lattice::estimate_within(
                map,
                x,
                (k, cap),
                self.media.camera_photons,
                false,
                around.as_ref(),
                Some((d, g)),
            );
            ratio = est.phase_ratio;
            est.rec.s
        });
        super::volume_lattice::phase_moments(s, d, g) * ratio
    }

    /// What a volume estimate at `x` fits its kernel over (`None`: the whole kernel, or visibility
    /// off): near a surface the kernel reaches past it, and the estimate is fitted over what the point
    /// sees — a coarse lattice's measurements, moved to the point where nothing lies between.
    pub(crate) fn volume_view(&self, x: Vec3) -> Option<Surroundings> {
        let scene = self.coverage.0;
        if !scene.settings.icache.media_visibility() {
            return None;
        }
        let measure = |p: Vec3| super::media_fill::surroundings(scene, p).0;
        match &self.media.volume_grid {
            Some(grid) => grid.surroundings(x, self.settings.max_radius_volume, measure, |a, b| {
                scene.segment_clear(a, b)
            }),
            None => Some(measure(x)),
        }
    }

    /// Wraps the maps for the render: the caustic map's reach grid is built here, and both caustic
    /// maps' lattices of cells for their searches at their radius.
    pub fn new(mut maps: PhotonMaps, settings: PhotonSettings, scene: &'a Scene) -> Self {
        maps.caustic = maps
            .caustic
            .take()
            .map(|m| m.with_cells(settings.max_radius_caustic));
        maps.volume_caustic = maps
            .volume_caustic
            .take()
            .map(|m| m.with_cells(settings.max_radius_volume_caustic));
        let caustic_reach = maps.caustic.as_ref().map(|m| {
            ReachGrid::build(
                m.photons().iter().map(|ph| ph.pos),
                settings.max_radius_caustic,
            )
        });
        let atlas = maps.global.as_ref().map(|g| {
            IrradianceAtlas::new(
                &scene.geometry,
                g.len(),
                settings.precompute_every,
                atlas_k(settings.lookup),
                settings.max_radius_global,
            )
        });
        let atlas = if maps.caustic.is_some() {
            atlas.map(IrradianceAtlas::with_caustic)
        } else {
            atlas
        };
        let glossy = atlas.as_ref().and_then(|a| GlossyTexels::new(scene, a));
        let volume_grid = match (&maps.volume, &scene.media) {
            (Some(_), Some(m)) => Some(VolumeGrid::new(
                m.bounds(),
                settings.max_radius_volume,
                scene.settings.icache.media_gradients(),
            )),
            _ => None,
        };
        let camera_photons = if maps.volume_caustic.is_some() {
            Photons::Indirect
        } else {
            Photons::NotDirect
        };
        PhotonData {
            maps,
            settings,
            coverage: SceneCoverage(scene),
            surfaces: SurfaceLookups {
                caustic_reach,
                atlas,
                glossy,
            },
            media: MediaLookups {
                volume_grid,
                camera_photons,
            },
        }
    }

    pub fn maps(&self) -> &PhotonMaps {
        &self.maps
    }

    /// The maps, for saving once the render is done.
    pub fn into_maps(self) -> PhotonMaps {
        self.maps
    }

    /// The irradiance atlas keeping what its texels are made of, for a sequence's next frame.
    pub fn track_atlas(&mut self) {
        self.surfaces.atlas = self.surfaces.atlas.take().map(IrradianceAtlas::tracking);
    }

    /// The maps and the irradiance atlas as the render left them (a sequence's next frame carries
    /// the atlas's texels where nothing changed: [`Self::carry_atlas`]).
    pub fn into_maps_and_atlas(self) -> (PhotonMaps, Option<IrradianceAtlas>) {
        (self.maps, self.surfaces.atlas)
    }

    /// The atlas of the frame before (`before`, over the same triangles) in place of this one's empty
    /// atlas, with the texels `keep` keeps, moved by the `change` of their photons (see
    /// [`IrradianceAtlas::carried`]).
    pub fn carry_atlas(
        &mut self,
        before: IrradianceAtlas,
        keep: impl Fn(Vec3, f32) -> bool + Sync,
        change: impl Fn(Vec3, Vec3, f32, f32) -> DiscChange + Sync,
    ) {
        if self.surfaces.atlas.is_none() {
            return;
        }
        let scene = self.coverage.0;
        let atlas = before.carried(&scene.geometry, keep, change);
        let atlas = if self.maps.caustic.is_some() {
            atlas.with_caustic()
        } else {
            atlas
        };
        self.surfaces.glossy = GlossyTexels::new(scene, &atlas);
        self.surfaces.atlas = Some(atlas);
    }

    pub fn settings(&self) -> &PhotonSettings {
        &self.settings
    }

    /// The irradiance atlas (there with a global map).
    pub fn atlas(&self) -> Option<&IrradianceAtlas> {
        self.surfaces.atlas.as_ref()
    }

    /// The volume grid (there with a volume map in a scene with media).
    /// Glossy texels estimated so far and their bytes; `None` without glossy materials.
    pub fn glossy_texel_stats(&self) -> Option<(u64, u64)> {
        self.surfaces.glossy.as_ref().map(GlossyTexels::stats)
    }

    pub fn volume_grid(&self) -> Option<&VolumeGrid> {
        self.media.volume_grid.as_ref()
    }

    /// The photons camera rays' multiple-scattering estimates sum.
    pub fn camera_photons(&self) -> Photons {
        self.media.camera_photons
    }

    pub fn caustic_irradiance(
        &self,
        hit: &Hit,
        front: bool,
        n: Vec3,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let p = hit.p;
        if self
            .surfaces
            .caustic_reach
            .as_ref()
            .is_some_and(|g| !g.may_reach(p))
        {
            return Vec3::ZERO;
        }
        let Some(m) = &self.maps.caustic else {
            return Vec3::ZERO;
        };
        let (k, r, filter) = (
            self.settings.lookup,
            self.settings.max_radius_caustic,
            self.settings.caustic_filter,
        );
        // A faint caustic's sparse photons make wide discs: one estimate per atlas texel serves it.
        let smooth = self.surfaces.atlas.as_ref().and_then(|a| {
            let ng = self.coverage.0.geometry.triangles[hit.tri as usize].ng;
            a.caustic(hit.tri, ng, front, p, |middle, n| {
                m.irradiance(middle, n, k, r, filter, &self.coverage)
            })
        });
        smooth.unwrap_or_else(|| {
            c.photon_estimates += 1;
            m.irradiance(p, n, k, r, filter, &self.coverage).e
        })
    }

    /// [`caustic_irradiance`](Self::caustic_irradiance) at a point whose shading normal a bump map
    /// turned from `frame.smooth` to `frame.n`: the photons are found and counted by the smooth normal
    /// (the surface they were stored on), each one's power scaled by the cosine ratio
    /// max(0, ωᵢ·n) / (ωᵢ·n_smooth) ([`turned_cosine`]), the irradiance on the bumped facet. Without a
    /// bump, `caustic_irradiance` itself.
    pub fn caustic_irradiance_at(
        &self,
        hit: &Hit,
        frame: &crate::geometry::Frame,
        c: &mut SampleCounters,
    ) -> Vec3 {
        if !frame.is_bumped() {
            return self.caustic_irradiance(hit, frame.front, frame.n, c);
        }
        let p = hit.p;
        if self
            .surfaces
            .caustic_reach
            .as_ref()
            .is_some_and(|g| !g.may_reach(p))
        {
            return Vec3::ZERO;
        }
        let Some(m) = &self.maps.caustic else {
            return Vec3::ZERO;
        };
        c.photon_estimates += 1;
        let (n, n_b) = (frame.smooth, frame.n);
        m.radiance_with(
            p,
            n,
            self.settings.lookup,
            self.settings.max_radius_caustic,
            self.settings.caustic_filter,
            &self.coverage,
            |wi| Vec3::splat(turned_cosine(wi, n, n_b)),
        )
        .e
    }

    /// A texel's radiance at point `p` of it: an edge texel's direct light is `p`'s own.
    fn texel_radiance(
        &self,
        t: &super::atlas::TexelIrradiance,
        tri: u32,
        front: bool,
        p: Vec3,
    ) -> Vec3 {
        if t.albedo_pi == Vec3::ZERO {
            t.radiance
        } else {
            t.radiance + t.albedo_pi * super::atlas::direct_at(self.coverage.0, tri, front, p)
        }
    }

    /// [`surface_radiance`](Self::surface_radiance) at many ends at once, appended to `out` in order
    /// (zero without a global map): the texels are found first, then read, so that the memory reads
    /// of neighbouring ends overlap.
    pub fn gather_radiance_batch(&self, ends: &[GatherHit], out: &mut Vec<Vec3>) {
        let (Some(atlas), Some(global)) = (self.surfaces.atlas.as_ref(), self.maps.global.as_ref())
        else {
            out.extend(ends.iter().map(|_| Vec3::ZERO));
            return;
        };
        let texels: Vec<_> = ends
            .iter()
            .map(|e| atlas.texel(e.tri, e.front, e.p))
            .collect();
        out.extend(
            texels
                .into_iter()
                .zip(ends)
                .map(|(t, e)| self.read_end(atlas, global, t, e)),
        );
    }

    /// The light leaving a surface toward a ray that ends there, read as a gather ray reads it: the
    /// atlas texel's mean albedo / π × all of its irradiance (an edge texel's direct light the point's
    /// own), and on a glossy surface its lobe from the texel's harmonics. `None` without a global map
    /// (no photon was stored).
    pub fn surface_radiance(&self, end: &GatherHit) -> Option<Vec3> {
        let (atlas, global) = (self.surfaces.atlas.as_ref()?, self.maps.global.as_ref()?);
        let texel = atlas.texel(end.tri, end.front, end.p);
        Some(self.read_end(atlas, global, texel, end))
    }

    /// [`surface_radiance`](Self::surface_radiance) at `texel`, the end's.
    fn read_end(
        &self,
        atlas: &super::atlas::IrradianceAtlas,
        global: &PhotonMap,
        texel: super::atlas::Texel,
        e: &GatherHit,
    ) -> Vec3 {
        let lobe = match (self.surfaces.glossy.as_ref(), e.lobe) {
            (Some(texels), Some(lobe)) => texels.radiance_at(
                atlas,
                &self.coverage,
                global,
                texel,
                (lobe.material, lobe.ks),
                (lobe.n, lobe.wo),
                false,
            ),
            _ => Vec3::ZERO,
        };
        self.texel_radiance(
            &atlas.read(&self.coverage, global, texel),
            e.tri,
            e.front,
            e.p,
        ) + lobe
    }

    /// Soft indirect irradiance (direct and caustic photons left out) at a point that has its own
    /// direct and caustic terms (one reached through a glossy lobe): the atlas texel's.
    pub fn indirect_irradiance(&self, tri: u32, front: bool, p: Vec3) -> Vec3 {
        self.texel(tri, front, p)
            .map_or(Vec3::ZERO, |t| t.e_indirect)
    }

    fn texel(&self, tri: u32, front: bool, p: Vec3) -> Option<super::atlas::TexelIrradiance> {
        let (atlas, global) = (self.surfaces.atlas.as_ref()?, self.maps.global.as_ref()?);
        Some(atlas.lookup(&self.coverage, global, tri, front, p))
    }

    /// Radiance leaving a glossy surface toward `wo` through its specular lobe, from the texel's
    /// harmonics of the global map's light (see `glossy_texels`): all of it where a final-gather ray
    /// ends, all but the direct light with `not_direct` (a point whose direct light is sampled); zero
    /// for other materials.
    pub fn glossy_radiance(
        &self,
        bsdf: &crate::material::Bsdf,
        hit: &crate::geometry::Hit,
        frame: &crate::geometry::Frame,
        wo: Vec3,
        not_direct: bool,
    ) -> Vec3 {
        let crate::material::Bsdf::Glossy { specular, .. } = *bsdf else {
            return Vec3::ZERO;
        };
        let (Some(texels), Some(atlas), Some(global)) = (
            self.surfaces.glossy.as_ref(),
            self.surfaces.atlas.as_ref(),
            self.maps.global.as_ref(),
        ) else {
            return Vec3::ZERO;
        };
        texels.radiance(
            atlas,
            &self.coverage,
            global,
            (hit.tri, frame.front, hit.p),
            (hit.material, specular),
            (frame.n, wo),
            not_direct,
        )
    }

    /// The caustic map's light reflected by a glossy lobe toward `wo` (Jensen's estimate with the lobe
    /// as BRDF), for glossy points whose lobe is not sampled: light that reaches them through mirrors
    /// and glass. Zero without a caustic map or where it has no photon within reach.
    pub fn caustic_glossy(
        &self,
        bsdf: &crate::material::Bsdf,
        hit: &crate::geometry::Hit,
        frame: &crate::geometry::Frame,
        wo: Vec3,
    ) -> Vec3 {
        let crate::material::Bsdf::Glossy {
            specular, exponent, ..
        } = *bsdf
        else {
            return Vec3::ZERO;
        };
        let Some(m) = &self.maps.caustic else {
            return Vec3::ZERO;
        };
        if self
            .surfaces
            .caustic_reach
            .as_ref()
            .is_some_and(|g| !g.may_reach(hit.p))
        {
            return Vec3::ZERO;
        }
        let lobe = crate::material::PhongLobe::new(wo, frame.n, exponent);
        m.radiance_with(
            hit.p,
            frame.n,
            self.settings.lookup,
            self.settings.max_radius_caustic,
            self.settings.caustic_filter,
            &self.coverage,
            |wi| specular * lobe.brdf(wi),
        )
        .e
    }

    /// Indirect-only irradiance read straight from the global map (method `photons`): photons that came
    /// straight from a light, or through specular bounces only, are left out — direct and caustic
    /// light have their own terms.
    pub fn global_indirect_irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        self.global(|m| {
            m.irradiance_indirect(
                p,
                n,
                self.settings.lookup,
                self.settings.max_radius_global,
                &self.coverage,
            )
            .e
        })
    }

    /// [`global_indirect_irradiance`](Self::global_indirect_irradiance) at a point whose shading
    /// normal a bump map turned from `frame.smooth` to `frame.n`, each photon scaled as in
    /// [`caustic_irradiance_at`](Self::caustic_irradiance_at).
    pub fn global_indirect_irradiance_at(&self, p: Vec3, frame: &crate::geometry::Frame) -> Vec3 {
        if !frame.is_bumped() {
            return self.global_indirect_irradiance(p, frame.n);
        }
        let (n, n_b) = (frame.smooth, frame.n);
        self.global(|m| {
            m.projected(
                p,
                n,
                self.settings.lookup,
                self.settings.max_radius_global,
                &self.coverage,
                |ph| {
                    let w = if ph.indirect {
                        turned_cosine(ph.wi, n, n_b)
                    } else {
                        0.0
                    };
                    [w]
                },
            )
            .1[0]
        })
    }

    fn global(&self, f: impl Fn(&PhotonMap) -> Vec3) -> Vec3 {
        self.maps.global.as_ref().map(f).unwrap_or(Vec3::ZERO)
    }
}

/// Most a bump scales a photon's power by: a photon arriving near grazing to the smooth surface would
/// otherwise weigh up to 1 / (ωᵢ·n_smooth) times its share, one bright speck in a caustic.
const MAX_TURNED_COSINE: f32 = 4.0;

/// The factor that makes a photon's power, stored on the smooth surface (ωᵢ toward where it came
/// from), a share of the irradiance on a facet of normal `n_bumped`: max(0, ωᵢ·n_b) / (ωᵢ·n), at most
/// [`MAX_TURNED_COSINE`].
pub(crate) fn turned_cosine(wi: Vec3, n: Vec3, n_bumped: Vec3) -> f32 {
    let cos = wi.dot(n);
    if cos > 0.0 {
        (wi.dot(n_bumped).max(0.0) / cos).min(MAX_TURNED_COSINE)
    } else {
        0.0
    }
}
