//! Methods `ao` and `ao-direct`: ambient occlusion at a camera ray's first hit — the fraction of
//! cosine-weighted directions about the geometric normal (turned toward the camera) whose ray meets no
//! surface within the occlusion distance. Materials and lights play no part: every surface occludes,
//! an emitter too (an invisible medium boundary is no surface and does not).
//!
//! A final gather whose open rays carry radiance 1/π and whose blocked rays carry 0 has irradiance
//! E = (π / N) Σ L = the open fraction, so the gather crate's strata and gradients and the irradiance
//! cache serve occlusion as they serve `pm`'s soft indirect light, one band in all three channels
//! (Christensen's occlusion caching in RenderMan). A ray's distance is its hit's, clipped to the
//! occlusion distance (an open ray's is that distance): records are spaced by what lies within reach,
//! and a wide open space needs no denser records than one wall at the occlusion distance.

use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::{AtomicBool, Ordering};

use gather::{GatherParams, GatherRay, GatherResult};
use glam::Vec3;
use icache::{IrradianceCache, NewRecord, Pass, ShadingPoint};
use photon::sampling::{hash_keys, Rng};

use super::cache_fill::{new_record, same_surface};
use super::terms::LayerValues;
use crate::camera::Camera;
use crate::counters::SampleCounters;
use crate::geometry::{spawn, spawn_clear, Frame, Hit};
use crate::scene::Scene;

/// Where the open fraction at a camera ray's first hit comes from.
#[derive(Clone, Copy)]
pub enum OcclusionSource<'a> {
    /// A gather at every camera sample (`ao-direct`).
    Gather,
    /// The first n records of the cache, read with pass-B accuracy (`ao`; see
    /// [`super::pm::IndirectSource::CacheUpTo`]).
    CacheUpTo(&'a IrradianceCache, usize),
}

/// The occlusion integrator: the scene, the occlusion distance and the gathers' rays.
#[derive(Clone, Copy)]
pub struct Occlusion<'a> {
    pub scene: &'a Scene,
    /// Scene units beyond which a surface no longer occludes.
    pub distance: f32,
    pub gather: GatherParams,
    pub seed: u64,
    pub source: OcclusionSource<'a>,
    /// As [`super::pm::PmContext::defer_misses`].
    pub defer_misses: bool,
    /// A gather that sees it set stops tracing (its result is then discarded).
    pub cancel: &'a AtomicBool,
}

impl Occlusion<'_> {
    /// The open fraction seen by the camera ray through (x, y) + `offset` (0 where it meets nothing).
    pub fn sample(
        &self,
        camera: &Camera,
        (x, y): (u32, u32),
        offset: [f32; 2],
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> LayerValues {
        let d = camera.ray(x as f32 + offset[0], y as f32 + offset[1]);
        c.rays += 1;
        let Some(hit) = self.scene.intersect_visible(camera.eye, d) else {
            return LayerValues::one(Vec3::ZERO);
        };
        let n = Frame::new(&hit, -d).ng;
        let open = match self.source {
            OcclusionSource::Gather => {
                c.monte_carlo += 1;
                self.gather(&hit, n, rng.next_u32() as u64, 0, c).e
            }
            OcclusionSource::CacheUpTo(cache, k) => self.cached(cache, k, &hit, n, rng, c),
        };
        // Gradients may carry an interpolation a little past the fraction's range.
        LayerValues::one(open.clamp(Vec3::ZERO, Vec3::ONE))
    }

    /// A pass-B lookup of the cache's first `k` records; where none interpolates, records whose
    /// normal differs more extrapolate; where none does either, this sample gathers for itself
    /// (a miss, counted). With `defer_misses`, a miss answers zero: the sample is taken again.
    fn cached(
        &self,
        cache: &IrradianceCache,
        k: usize,
        hit: &Hit,
        n: Vec3,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let visible = |_: u32, rec: &icache::Record| self.record_in_sight(hit, n, rec);
        let found = cache.lookup_first_visible(hit.p, n, Pass::B, k, visible);
        c.lookups.record(found.as_ref());
        if let Some(l) = found {
            return l.e;
        }
        if self.defer_misses {
            return Vec3::ZERO;
        }
        match cache.lookup_first_visible(hit.p, n, Pass::Extrapolate, k, visible) {
            Some(l) => {
                c.lookups.n_extrapolated += 1;
                l.e
            }
            None => {
                c.lookups.n_gathered += 1;
                c.monte_carlo += 1;
                self.gather(hit, n, rng.next_u32() as u64, 0, c).e
            }
        }
    }

    /// With `[render.icache] visibility`, a shadow ray from `hit` must reach the record (just off its
    /// surface), as for `pm`.
    fn record_in_sight(&self, hit: &Hit, n: Vec3, rec: &icache::Record) -> bool {
        if !self.scene.settings.icache.visibility() {
            return true;
        }
        let o = spawn(hit, n);
        let d = rec.pos + rec.normal * (1e-3 * rec.r_clamped) - o;
        let len = d.length();
        !(len > 0.0) || !self.scene.bvh.occluded(o, d / len, len)
    }

    /// One occlusion gather at `hit` about `n` (round `round` of the gathers from `seed`, see
    /// `gather::gather_batch_round`), its rays counted in `c`.
    pub fn gather(
        &self,
        hit: &Hit,
        n: Vec3,
        seed: u64,
        round: u32,
        c: &mut SampleCounters,
    ) -> GatherResult {
        let mut rays = 0u64;
        let result = gather::gather_batch_round(
            hit.p,
            n,
            &self.gather,
            seed,
            round,
            &mut |dirs: &[Vec3], out: &mut Vec<GatherRay>| {
                for &dir in dirs {
                    if self.cancel.load(Ordering::Relaxed) {
                        out.push(GatherRay::miss(Vec3::ZERO));
                        continue;
                    }
                    rays += 1;
                    out.push(self.ray(hit, dir));
                }
            },
        );
        c.rays += rays;
        c.gathers += 1;
        c.gather_rays += rays;
        c.gather_noise.record(result.rel_err);
        result
    }

    /// One gather ray from `from` along `dir`: radiance 1/π if it meets no surface within the
    /// occlusion distance, else 0; its distance clipped to the occlusion distance.
    fn ray(&self, from: &Hit, dir: Vec3) -> GatherRay {
        let o = spawn_clear(from, dir);
        match self.scene.intersect_solid(o, dir, self.distance) {
            Some(raw) => GatherRay {
                radiance: Vec3::ZERO,
                distance: raw.t.min(self.distance),
            },
            None => GatherRay {
                radiance: Vec3::splat(FRAC_1_PI),
                distance: self.distance,
            },
        }
    }

    /// The points pass A gathers at for pixel (x, y): where the rays through its centre and through
    /// its top-left corner first meet a surface, the corner's only where the centre's does not cover
    /// it (as `pm`'s [`super::cache_fill::shading_hits`], without its mirror and glass chains: occlusion
    /// stops at the first surface), both moved by `shift` ([`crate::render::Plan::pass_a_shift`]).
    pub fn shading_hits(
        &self,
        camera: &Camera,
        x: u32,
        y: u32,
        [sx, sy]: [f32; 2],
    ) -> Vec<(ShadingPoint, Hit)> {
        let centre = [(0.5 + sx).fract(), (0.5 + sy).fract()];
        let mut out = self.sample_hits(camera, x, y, &[centre]);
        for corner in self.sample_hits(camera, x, y, &[[sx, sy]]) {
            if !out.iter().any(|(c, _)| same_surface(c, &corner.0)) {
                out.push(corner);
            }
        }
        out
    }

    /// The first hits of the camera rays through pixel (x, y) at `offsets` within it.
    pub fn sample_hits(
        &self,
        camera: &Camera,
        x: u32,
        y: u32,
        offsets: &[[f32; 2]],
    ) -> Vec<(ShadingPoint, Hit)> {
        offsets
            .iter()
            .filter_map(|off| {
                let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
                let hit = self.scene.intersect_visible(camera.eye, d)?;
                let n = Frame::new(&hit, -d).ng;
                let pixel_world = camera.pixel_world(d, hit.t, n.dot(-d));
                Some((
                    ShadingPoint {
                        pos: hit.p,
                        normal: n,
                        pixel_world,
                    },
                    hit,
                ))
            })
            .collect()
    }

    /// The gather at shading point `i` of pixel (x, y) as a record, with its rays counted; `round`
    /// as for [`Self::gather`] (0: the first gather there).
    pub fn record(
        &self,
        (x, y, i): (u32, u32, usize),
        round: u32,
        sp: &ShadingPoint,
        hit: &Hit,
    ) -> (NewRecord, SampleCounters) {
        let mut c = SampleCounters::default();
        let seed = hash_keys(&[self.seed, x as u64, y as u64, i as u64]);
        let g = self.gather(hit, sp.normal, seed, round, &mut c);
        (new_record(&g, sp, [x, y, i as u32]), c)
    }
}
