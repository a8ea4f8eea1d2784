//! Methods `pm`, `pm-fg` and `photons`: Jensen's split of the light leaving a visible point into
//! emission, direct, specular, caustic and soft indirect. They differ only in where the soft indirect
//! irradiance comes from: the irradiance cache (`pm`), a fresh final gather per sample (`pm-fg`), or the
//! global photon map read directly (`photons`).

use std::f32::consts::PI;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::camera::PixelSpan;
use gather::{GatherParams, GatherRay, GatherResult};
use glam::Vec3;
use icache::media::MediaCache;
use icache::{IrradianceCache, Pass};
use photon::sampling::{hash_keys, Rng};

use super::in_scatter;
use super::radiance_cache::RadianceCache;
use super::terms::Terms;
use crate::counters::SampleCounters;
use crate::geometry::Frame;
use crate::geometry::{spawn, spawn_clear, Hit};
use crate::material::{glass_lobes, Bsdf, PhongLobe, Transport};
use crate::medium::MediumId;
use crate::photons::{GatherHit, GatherLobe, PhotonData};
use crate::scene::Scene;
use crate::warp::power_heuristic;

/// Area-light samples per non-specular hit in `direct` (chosen from the chart's error/time trade-off).
pub const AREA_LIGHT_SAMPLES: u32 = 4;
/// Most points a gather ray reads the volume lattice at along one stretch through a medium (one per
/// lattice cell crossed, up to this): on the shipped fog-spot scene at 240×180, 16 halved the records'
/// predicted gather noise for 0.9 s more pass A (12.9 s in all; 64 gained little more).
const MARCH_POINTS: usize = 16;

/// Where soft indirect irradiance comes from.
#[derive(Clone, Copy)]
pub enum IndirectSource<'a> {
    /// The first n records of the cache, read with pass-B accuracy: of a one-pass cache, what the fill had
    /// made when it reached the pixel (so the two fills differ only in which records a pixel can see); of
    /// a two-pass cache, the records of the stages before the current round of samples.
    CacheUpTo(&'a IrradianceCache, usize),
    Gather,
    PhotonMap,
}

/// Which records of a cache were made for other views than the one rendered: a sequence's earlier
/// frames' (the first `below`), and a walk's later frames' (`from..to`). Records made after all of
/// them (pass B's, or this view's pass A's) are the view's own.
#[derive(Clone, Copy, Debug, Default)]
pub struct OtherViews<'a> {
    pub below: usize,
    pub from: usize,
    pub to: usize,
    /// For a walk's shared cache: the view's pixels, and the most of them another view's record may
    /// span here — one made far from the camera is too coarse once it comes close (a sequence drops
    /// such records instead; a shared cache keeps them for the views they suit).
    pub fine: Option<(PixelSpan, f32)>,
    /// Set for each record of the first `below` that pass B read (found in sight and weighted
    /// above zero): a sequence retires the records no pixel reads.
    pub reads: Option<&'a [AtomicBool]>,
}

impl OtherViews<'_> {
    /// The first `n` records: a sequence's frames before.
    pub fn first(n: usize) -> OtherViews<'static> {
        OtherViews {
            below: n,
            ..Default::default()
        }
    }

    /// Whether another view's record `rec` is fine enough to be read in this one.
    fn fits(&self, rec: &icache::Record) -> bool {
        self.fine
            .is_none_or(|(span, most)| span.of(rec.pos, rec.normal, rec.r_clamped) <= most)
    }

    /// Whether record `id` was made for another view.
    pub fn has(&self, id: u32) -> bool {
        let id = id as usize;
        id < self.below || (self.from..self.to).contains(&id)
    }

    /// Notes that pass B read record `id` (when reads are kept).
    fn note_read(&self, id: u32) {
        if let Some(flag) = self.reads.and_then(|r| r.get(id as usize)) {
            // Most reads find the flag set: loading first keeps the line shared between threads.
            if !flag.load(Ordering::Relaxed) {
                flag.store(true, Ordering::Relaxed);
            }
        }
    }
}

#[derive(Clone, Copy)]
pub struct PmContext<'a> {
    pub scene: &'a Scene,
    pub photons: &'a PhotonData<'a>,
    /// The media radiance cache camera rays read (`pm`, filled by its own phase before pass A; the
    /// other methods estimate at every step).
    pub media_cache: Option<&'a MediaCache>,
    pub source: IndirectSource<'a>,
    pub gather: GatherParams,
    pub max_depth: u32,
    pub seed: u64,
    /// Interrupt flag: a final gather that sees it set stops tracing (its result is then discarded).
    pub cancel: &'a AtomicBool,
    /// A pass-B lookup that finds no record is counted and answered with zero, without the fallbacks:
    /// the sample is taken again once records are made for it (see `render::tiles`).
    pub defer_misses: bool,
    /// The glossy lobes' radiance cache (`pm`): filled beside the irradiance cache's records, read at
    /// glossy points instead of sampling their lobe.
    pub radiance: Option<&'a RadianceCache>,
    /// The records of the cache made for other views: pass B interpolates them only where they are
    /// in sight (see `record_in_sight`).
    pub foreign: OtherViews<'a>,
    /// Where a camera ray first meets a textured surface, the width (per unit of distance along the
    /// ray) its texture is averaged over; 0: read at the point ([`crate::render::plan::TEXTURE_FILTER`]).
    pub texture_filter: f32,
    /// The camera's pixel, in radians: a pixel memo's [`super::Slope`] is measured across it (0: none).
    pub pixel_angle: f32,
    /// Where pass A traces in a pixel ([`crate::render::Plan::pass_a_shift`]).
    pub pass_a_shift: [f32; 2],
}

/// A caustic irradiance at most this fraction of the soft indirect one is reused within a pixel (see
/// `PixelMemo`).
const FAINT_CAUSTIC: f32 = 0.05;

/// A pixel memo keeps how the cache's light changes across the pixel (`Slope`) where the records
/// the first sample interpolated differ there by more than this fraction of their interpolation:
/// about the records' own gather noise, below which the change across a pixel is mostly noise.
const MEMO_AGREE: f32 = 0.05;

/// A surface point being shaded: the hit, its frame seen from `wo`, the medium the ray arrived in, the
/// path's depth and throughput there, and the points its area-light samples take (a camera sample's
/// first hit; `None`: its own random numbers).
#[derive(Clone, Copy)]
struct Vertex<'h> {
    hit: &'h Hit,
    frame: Frame,
    wo: Vec3,
    medium: MediumId,
    depth: u32,
    beta: f32,
    light: Option<super::LightPoints>,
}

/// How the ray being shaded was generated, for MIS of emission.
#[derive(Clone, Copy)]
enum Via {
    /// From the camera or through Dirac lobes only: emission counts fully. `lobe`: the camera sample's
    /// stratified point for the first glossy lobe it samples (`None` after a mirror or glass).
    Delta {
        lobe: Option<[f32; 2]>,
        light: Option<super::LightPoints>,
    },
    /// Sampled from a glossy lobe at `from` with solid-angle pdf `pdf`.
    Glossy { from: Vec3, pdf: f32 },
}

impl PmContext<'_> {
    /// Radiance along a camera ray, split into terms; a glossy surface it meets first samples its lobe
    /// at `at.lobe`, and the area-light samples at its first hit take `at.light`. With a `memo`, the
    /// caustic and soft indirect irradiance of the surface the ray hits first come from the pixel's
    /// earlier samples on that surface when there are some (not for `pm-fg`, whose per-sample gathers
    /// are what it averages).
    pub fn shade(
        &self,
        origin: Vec3,
        dir: Vec3,
        at: super::Stratified,
        memo: Option<&mut super::PixelMemo>,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Terms {
        let memo = if matches!(self.source, IndirectSource::Gather) {
            None
        } else {
            memo
        };
        self.shade_ray(
            origin,
            dir,
            0.0,
            0,
            1.0,
            Via::Delta {
                lobe: Some(at.lobe),
                light: at.light,
            },
            memo,
            self.scene.camera_medium(),
            rng,
            c,
        )
    }

    /// The terms along one ray travelling in `medium`: in a participating medium, the light it scatters
    /// toward the ray up to the surface, plus the surface's terms times the transmittance; invisible
    /// boundaries are crossed (not a bounce), the ray going on along its line beyond `t0`.
    #[allow(clippy::too_many_arguments)]
    fn shade_ray(
        &self,
        o: Vec3,
        d: Vec3,
        t0: f32,
        depth: u32,
        beta: f32,
        via: Via,
        memo: Option<&mut super::PixelMemo>,
        medium: MediumId,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Terms {
        c.rays += 1;
        let hit = self.scene.intersect_after(o, d, t0);
        let Some(m) = self.scene.medium(medium) else {
            return self.shade_hit(o, hit, d, depth, beta, via, memo, medium, rng, c);
        };
        let t_end = hit.map_or(f32::INFINITY, |h| h.t - t0);
        let (single, multiple) = if t_end.is_finite() {
            let sources = in_scatter::Sources {
                scene: self.scene,
                photons: self.photons,
                media_cache: self.media_cache,
            };
            in_scatter::in_scattered(&sources, o + d * t0, d, t_end, medium, m, rng, c)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        let mut t = self
            .shade_hit(o, hit, d, depth, beta, via, memo, medium, rng, c)
            .scaled(m.transmittance(t_end));
        t.media_single += single;
        t.media_multiple += multiple;
        t
    }

    /// The terms at the end of a ray from `o` (`hit`, reached travelling along `d` in `medium`).
    #[allow(clippy::too_many_arguments)]
    fn shade_hit(
        &self,
        o: Vec3,
        hit: Option<Hit>,
        d: Vec3,
        depth: u32,
        beta: f32,
        via: Via,
        memo: Option<&mut super::PixelMemo>,
        medium: MediumId,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Terms {
        let mut t = Terms::default();
        let Some(hit) = hit else { return t };
        if self.scene.material(&hit).bsdf.is_null() {
            let (next, t0) = self.scene.cross(o, d, hit.tri, hit.t, medium);
            return self.shade_ray(o, d, t0, depth, beta, via, memo, next, rng, c);
        }
        let wo = -d;
        let le = self.scene.emitted(&hit, wo);
        t.emission = match via {
            Via::Delta { .. } => le,
            Via::Glossy { from, pdf } if le != Vec3::ZERO => {
                le * power_heuristic(pdf, self.scene.lights.pdf_hit_area(hit.tri, from, hit.p))
            }
            Via::Glossy { .. } => Vec3::ZERO,
        };
        let frame = self.scene.frame(&hit, wo);
        let bsdf = &self.scene.bsdf(&hit);
        if let (Via::Glossy { .. }, false) = (via, bsdf.is_specular()) {
            // After a glossy reflection the point is not shaded again: its light is read as a
            // final-gather ray reads it (the caller sums the terms).
            if let Some(read) = self
                .photons
                .surface_radiance(&gather_hit(&hit, &frame, bsdf, wo))
            {
                t.indirect = read.max(Vec3::ZERO);
                return t;
            }
        }
        // A camera sample's texture is averaged over a fraction of the pixel (see `texture_filter`).
        let kd = if depth == 0 && self.texture_filter > 0.0 {
            self.scene.albedo_over(&hit, self.texture_filter * hit.t)
        } else {
            self.scene.albedo(&hit)
        };
        let v = Vertex {
            hit: &hit,
            frame,
            wo,
            medium,
            depth,
            beta,
            light: match via {
                Via::Delta { light, .. } => light,
                Via::Glossy { .. } => None,
            },
        };
        if bsdf.is_specular() {
            if depth + 1 < self.max_depth {
                t.specular = self.specular(&v, bsdf, kd, rng, c);
            }
            return t;
        }
        if let Via::Glossy { .. } = via {
            // Without a global map (no photon stored), direct light is sampled and the glossy
            // lobe's light other than direct read from the texels.
            t.direct = self.direct(&v, kd, bsdf, true, rng, c);
            let rho_d = bsdf.diffuse_albedo(kd) / PI;
            if rho_d != Vec3::ZERO {
                let caustic = self.photons.caustic_irradiance_at(&hit, &frame, c);
                t.caustic = rho_d * caustic;
                t.indirect = rho_d
                    * self
                        .photons
                        .indirect_irradiance(hit.tri, frame.front, hit.p);
            }
            let glossy = self.photons.glossy_radiance(bsdf, &hit, &frame, wo, true);
            t.glossy = glossy.max(-(t.direct + t.caustic + t.indirect));
            return t;
        }
        let cached_glossy = self.cached_glossy(&hit, &frame, wo, bsdf);
        t.direct = self.direct(&v, kd, bsdf, cached_glossy.is_some(), rng, c);
        let rho_d = bsdf.diffuse_albedo(kd) / PI;
        if rho_d != Vec3::ZERO {
            let (caustic, indirect) = self.irradiance(&v, via, memo, rng, c);
            t.caustic = rho_d * caustic;
            t.indirect = rho_d * indirect;
        }
        if let Some(glossy) = cached_glossy {
            t.glossy = glossy;
            t.caustic += self.photons.caustic_glossy(bsdf, &hit, &frame, wo);
        } else if let Bsdf::Glossy {
            specular, exponent, ..
        } = *bsdf
        {
            if depth + 1 < self.max_depth && specular.max_element() > 0.0 {
                let u = match via {
                    Via::Delta { lobe: Some(u), .. } => u,
                    _ => [rng.uniform(), rng.uniform()],
                };
                t.glossy = self.glossy_lobe(&v, specular, exponent, u, rng, c);
            }
        }
        t
    }

    /// Whether pass B may interpolate record `id` at `hit`: with `visibility`, or for a record made for
    /// another view of a sequence ([`PmContext::foreign`]), a shadow ray to it (just off its surface)
    /// must reach it. A still's records lie on surfaces its camera sees; another view's may lie behind
    /// an occluder of this one and lend its light across it.
    fn record_in_sight(&self, hit: &Hit, frame: &Frame, id: u32, rec: &icache::Record) -> bool {
        let other = self.foreign.has(id);
        if !self.scene.settings.icache.visibility() && !other {
            return true;
        }
        let seen = (!other || self.foreign.fits(rec)) && self.in_sight(hit, frame.smooth, rec);
        if seen && other {
            self.foreign.note_read(id);
        }
        seen
    }

    /// Whether a fill may count record `id` as covering the point `hit` (shading normal `n`): one made
    /// for another view of a sequence only where pass B will read it, else pass B misses the point,
    /// gathers for it between its rounds and shades its pixel again. (`visibility` stays pass B's
    /// alone, as in a still.)
    pub fn fill_may_use(&self, hit: &Hit, n: Vec3, id: u32, rec: &icache::Record) -> bool {
        !self.foreign.has(id) || (self.foreign.fits(rec) && self.in_sight(hit, n, rec))
    }

    /// A shadow ray from `hit` (off its side `n`) reaches the record, just off its surface. Both ends
    /// are lifted along their normals by a tenth of their distance: the chord between two points of
    /// a convex surface (a ball) runs inside it, by d·θ/8 for normals θ apart — under 0.1 d for any
    /// record whose normal is close enough to be used — and without the lift every record of an
    /// earlier view on a curved surface was hidden by that surface beyond a few hundredths of its
    /// radius, and made again beside it.
    fn in_sight(&self, hit: &Hit, n: Vec3, rec: &icache::Record) -> bool {
        let lift = 0.1 * rec.pos.distance(hit.p);
        let o = spawn(hit, n) + n * lift;
        let d = rec.pos + rec.normal * (1e-3 * rec.r_clamped + lift) - o;
        let len = d.length();
        !(len > 0.0) || !self.scene.bvh.occluded(o, d / len, len)
    }

    /// The glossy lobe's light at a visible point from the radiance cache, where it serves the lobe and
    /// has records there (else `None`: the lobe is sampled).
    fn cached_glossy(&self, hit: &Hit, frame: &Frame, wo: Vec3, bsdf: &Bsdf) -> Option<Vec3> {
        let (Some(radiance), IndirectSource::CacheUpTo(cache, n), Bsdf::Glossy { specular, .. }) =
            (self.radiance, self.source, bsdf)
        else {
            return None;
        };
        radiance.reflected(
            cache,
            n,
            |id, rec| self.record_in_sight(hit, frame, id, rec),
            (hit.material, *specular),
            hit.p,
            (frame.smooth, frame.n),
            wo,
        )
    }

    /// The light a mirror or glass reflects or refracts toward `wo` (at a depth below the limit).
    fn specular(
        &self,
        v: &Vertex,
        bsdf: &Bsdf,
        kd: Vec3,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let Vertex {
            hit,
            frame,
            wo,
            medium,
            depth,
            beta,
            ..
        } = *v;
        let mut specular = Vec3::ZERO;
        // Glass met at the first GLASS_SPLIT_DEPTH bounces of a camera path is followed both
        // ways, reflected and refracted, weighted by Fresnel: no choice, no noise. Deeper, one
        // way is chosen (Fresnel's odds), a Monte Carlo estimate where the path still carries
        // MONTE_CARLO_MIN_THROUGHPUT of the sample.
        if let (&Bsdf::Glass { ior, transmittance }, true) = (bsdf, depth < GLASS_SPLIT_DEPTH) {
            for (wi, weight) in glass_lobes(ior, transmittance, frame.n, wo, frame.front) {
                if weight == Vec3::ZERO {
                    continue;
                }
                let next = self.scene.medium_after(hit, wi, medium);
                let sub = self.shade_ray(
                    spawn(hit, wi),
                    wi,
                    0.0,
                    depth + 1,
                    beta * weight.max_element(),
                    Via::Delta {
                        lobe: None,
                        light: None,
                    },
                    None,
                    next,
                    rng,
                    c,
                );
                specular += weight * sub.sum();
            }
            return specular;
        }
        c.monte_carlo +=
            (matches!(bsdf, Bsdf::Glass { .. }) && beta >= MONTE_CARLO_MIN_THROUGHPUT) as u64;
        let u = [rng.uniform(), rng.uniform(), rng.uniform()];
        match bsdf.sample(kd, frame.n, wo, frame.front, u, Transport::Radiance) {
            Some(s) => {
                let next = self.scene.medium_after(hit, s.wi, medium);
                let sub = self.shade_ray(
                    spawn(hit, s.wi),
                    s.wi,
                    0.0,
                    depth + 1,
                    beta * s.weight.max_element(),
                    Via::Delta {
                        lobe: None,
                        light: None,
                    },
                    None,
                    next,
                    rng,
                    c,
                );
                specular = s.weight * sub.sum();
            }
            None => c.zero_pdf += 1,
        }
        specular
    }

    /// (caustic, soft indirect) irradiance at a non-specular point: from the pixel's `memo` when an
    /// earlier sample there computed them, else estimated (and remembered).
    fn irradiance(
        &self,
        v: &Vertex,
        via: Via,
        memo: Option<&mut super::PixelMemo>,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> (Vec3, Vec3) {
        let (hit, frame) = (v.hit, &v.frame);
        let via_glossy = matches!(via, Via::Glossy { .. });
        let caustic_here =
            |c: &mut SampleCounters| self.photons.caustic_irradiance_at(hit, frame, c);
        if let Some(r) = memo.as_ref().and_then(|m| m.get(hit.tri, frame.front, c)) {
            let caustic = r.caustic.unwrap_or_else(|| caustic_here(c));
            let indirect = r
                .slope
                .map_or(r.indirect, |s| s.carry(r.indirect, hit.p, frame.smooth));
            return (caustic, indirect);
        }
        let caustic = caustic_here(c);
        let before = c.lookups;
        let mut records = Vec::new();
        let indirect = self.indirect(hit, frame, via_glossy, rng, c, &mut records);
        if let Some(m) = memo {
            let faint = caustic.max_element() <= FAINT_CAUSTIC * indirect.max_element();
            let remembered = super::Remembered {
                caustic: faint.then_some(caustic),
                indirect,
                slope: self.slope(hit, frame, indirect, &records),
            };
            m.put(hit.tri, frame.front, remembered, c.lookups.since(&before));
        }
        (caustic, indirect)
    }

    /// How the interpolation of `records` (their value `e` at the hit) changes across the camera
    /// pixel's footprint there: measured half a pixel away along each tangent axis. `None` without
    /// records (they agreed, or the light did not come from the cache), and on a bumped surface, whose
    /// light changes with its normal texel by texel, not as the records' interpolation does.
    fn slope(&self, hit: &Hit, frame: &Frame, e: Vec3, records: &[u32]) -> Option<super::Slope> {
        let IndirectSource::CacheUpTo(cache, _) = self.source else {
            return None;
        };
        if records.is_empty() || !(self.pixel_angle > 0.0) || frame.is_bumped() {
            return None;
        }
        let step = 0.5 * self.pixel_angle * hit.t;
        let (s, t) = frame.n.any_orthonormal_pair();
        let along = |axis: Vec3| {
            cache
                .lookup_among(hit.p + step * axis, frame.n, Pass::B, records)
                .map_or(Vec3::ZERO, |l| (l.e - e) / step)
        };
        Some(super::Slope {
            at: hit.p,
            along: [along(s), along(t)],
        })
    }

    /// Direct light with the full BRDF: every point, spot and directional light exactly (a shadow ray
    /// each: a scene has few of them, and choosing one at random was the main noise left in `pm`), plus
    /// one sample of the area lights. For glossy surfaces the area sample's specular part is MIS-weighted
    /// against the glossy-lobe ray of `glossy_lobe` (the diffuse part has no other strategy: weight 1).
    /// With `lobe_cached`, the lobe is not sampled (the radiance cache answers for it): light sampling
    /// is then the only strategy for its share too.
    fn direct(
        &self,
        v: &Vertex,
        kd: Vec3,
        bsdf: &Bsdf,
        lobe_cached: bool,
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let (hit, frame, wo, medium) = (v.hit, &v.frame, v.wo, v.medium);
        let mis = !lobe_cached;
        let lights = &self.scene.lights;
        let mut l = Vec3::ZERO;
        for ls in lights.delta_samples(&self.scene.geometry, hit.p) {
            l += self.light_contribution(hit, frame, wo, kd, bsdf, &ls, medium, mis, c);
        }
        // Shadow rays are cheap next to the rest of a pm sample: several area samples per hit.
        c.monte_carlo += lights.has_area() as u64;
        for j in 0..AREA_LIGHT_SAMPLES {
            let ls = match v.light {
                Some(points) => lights.sample_area_at(&self.scene.geometry, hit.p, points.point(j)),
                None => {
                    let u = [rng.uniform(), rng.uniform(), rng.uniform()];
                    lights.sample_area(&self.scene.geometry, hit.p, u)
                }
            };
            if let Some(ls) = ls {
                l += self.light_contribution(hit, frame, wo, kd, bsdf, &ls, medium, mis, c)
                    / AREA_LIGHT_SAMPLES as f32;
            }
        }
        l
    }

    #[allow(clippy::too_many_arguments)]
    fn light_contribution(
        &self,
        hit: &Hit,
        frame: &Frame,
        wo: Vec3,
        kd: Vec3,
        bsdf: &Bsdf,
        ls: &crate::light::LightSample,
        medium: MediumId,
        mis: bool,
        c: &mut SampleCounters,
    ) -> Vec3 {
        if !(ls.pdf > 0.0) {
            c.zero_pdf += 1;
            return Vec3::ZERO;
        }
        if !frame.same_side(ls.wi) {
            return Vec3::ZERO;
        }
        let cos = ls.wi.dot(frame.n).max(0.0);
        let f = bsdf.eval(kd, frame.n, wo, ls.wi);
        if f == Vec3::ZERO || cos == 0.0 {
            return Vec3::ZERO;
        }
        let vis = self
            .scene
            .visibility(hit, ls.wi, ls.dist, medium, &mut c.shadow_rays);
        if vis == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let f_diffuse = bsdf.diffuse_albedo(kd) / PI;
        let f_spec = f - f_diffuse;
        let w = match *bsdf {
            Bsdf::Glossy { exponent, .. } if mis && !ls.delta => {
                power_heuristic(ls.pdf, PhongLobe::new(wo, frame.n, exponent).pdf(ls.wi))
            }
            _ => 1.0,
        };
        (f_diffuse + f_spec * w) * ls.li * cos / ls.pdf * vis
    }

    /// The glossy lobe of modified Phong, sampled exactly at `u`; its light is all of the next hit's
    /// radiance.
    fn glossy_lobe(
        &self,
        v: &Vertex,
        ks: Vec3,
        exponent: f32,
        u: [f32; 2],
        rng: &mut Rng,
        c: &mut SampleCounters,
    ) -> Vec3 {
        let Vertex {
            hit,
            frame,
            wo,
            medium,
            depth,
            beta,
            ..
        } = *v;
        let lobe = PhongLobe::new(wo, frame.n, exponent);
        c.monte_carlo += 1;
        let wi = lobe.sample(u);
        let cos_i = wi.dot(frame.n);
        if cos_i <= 0.0 || !frame.same_side(wi) {
            return Vec3::ZERO;
        }
        let weight = ks * lobe.sampled_weight(cos_i);
        let pdf = lobe.pdf(wi);
        let next = self.scene.medium_after(hit, wi, medium);
        let sub = self.shade_ray(
            spawn(hit, wi),
            wi,
            0.0,
            depth + 1,
            beta * weight.max_element(),
            Via::Glossy { from: hit.p, pdf },
            None,
            next,
            rng,
            c,
        );
        weight * sub.sum()
    }

    /// Soft indirect irradiance at a non-specular point; where a pass-B lookup interpolated records
    /// that disagree there, their ids in `records` (else it is left empty).
    fn indirect(
        &self,
        hit: &Hit,
        frame: &Frame,
        via_glossy: bool,
        rng: &mut Rng,
        c: &mut SampleCounters,
        records: &mut Vec<u32>,
    ) -> Vec3 {
        // Points reached through glossy lobes are blurred by the lobe: the photon map suffices there. The
        // point has its own direct and caustic terms, so only the photons that are neither count.
        if via_glossy {
            return self
                .photons
                .indirect_irradiance(hit.tri, frame.front, hit.p);
        }
        match self.source {
            IndirectSource::PhotonMap => {
                c.photon_estimates += 1;
                self.photons.global_indirect_irradiance_at(hit.p, frame)
            }
            IndirectSource::CacheUpTo(cache, n) => {
                let visible = |id, rec: &icache::Record| self.record_in_sight(hit, frame, id, rec);
                // Records are found by the smooth normal and turned to the bumped one.
                self.cached(
                    |pass, ids| {
                        cache.lookup_noting_turned(
                            hit.p,
                            frame.smooth,
                            frame.n,
                            pass,
                            n,
                            visible,
                            MEMO_AGREE,
                            ids,
                        )
                    },
                    hit,
                    frame,
                    rng,
                    c,
                    records,
                )
            }
            IndirectSource::Gather => {
                c.monte_carlo += 1;
                self.final_gather(hit, frame, rng.next_u32() as u64, c).e
            }
        }
    }

    /// A pass-B cache lookup's irradiance; where no record interpolates, records of the same reach whose
    /// normal differs more (a curved silhouette) extrapolate; only where there is none either, this sample
    /// gathers for itself, creating no record (a miss, counted). With `defer_misses`, a miss is counted
    /// and answers zero: the sample will be taken again.
    fn cached(
        &self,
        lookup: impl Fn(Pass, &mut Vec<u32>) -> Option<icache::Lookup>,
        hit: &Hit,
        frame: &Frame,
        rng: &mut Rng,
        c: &mut SampleCounters,
        records: &mut Vec<u32>,
    ) -> Vec3 {
        let found = lookup(Pass::B, records);
        c.lookups.record(found.as_ref());
        let bumped = frame.is_bumped() as u64;
        if let Some(l) = found {
            c.lookups.n_bump_rotated += bumped;
            return l.e;
        }
        if self.defer_misses {
            return Vec3::ZERO;
        }
        let extrapolated = lookup(Pass::Extrapolate, records);
        // An extrapolation's records do not interpolate here: later samples reuse its value.
        records.clear();
        match extrapolated {
            Some(l) => {
                c.lookups.n_extrapolated += 1;
                c.lookups.n_bump_rotated += bumped;
                l.e
            }
            None => {
                c.lookups.n_gathered += 1;
                c.monte_carlo += 1;
                self.final_gather(hit, frame, rng.next_u32() as u64, c).e
            }
        }
    }

    /// One final gather from `hit`: each ray reads the global map's irradiance where it ends (its atlas
    /// texel).
    /// A gather that sees the stop flag traces no more rays and returns at once (its result is never used).
    pub fn final_gather(
        &self,
        hit: &Hit,
        frame: &Frame,
        seed: u64,
        c: &mut SampleCounters,
    ) -> GatherResult {
        self.final_gather_round(hit, frame, seed, 0, c)
    }

    /// [`final_gather`](Self::final_gather) as round `round` of gathers from the same `seed` (see
    /// `gather::gather_batch_round`); round 0 is that gather.
    pub fn final_gather_round(
        &self,
        hit: &Hit,
        frame: &Frame,
        seed: u64,
        round: u32,
        c: &mut SampleCounters,
    ) -> GatherResult {
        self.gather_projected(hit, frame, seed, round, None, c)
    }

    /// [`final_gather_round`](Self::final_gather_round), also projecting the rays' `L·cos θ` on the
    /// spherical harmonics of `sh`'s bands (written to its coefficients: see `radiance_cache`).
    pub fn gather_projected(
        &self,
        hit: &Hit,
        frame: &Frame,
        seed: u64,
        round: u32,
        mut sh: Option<(usize, &mut Vec<Vec3>)>,
        c: &mut SampleCounters,
    ) -> GatherResult {
        if let Some((order, g)) = sh.as_mut() {
            g.clear();
            g.resize(crate::sh::len(*order), Vec3::ZERO);
        }
        if self.cancel.load(Ordering::Relaxed) {
            return interrupted_gather(frame);
        }
        let keys = [self.seed, 0x6a7e, seed, round as u64];
        let mut rng = Rng::new(hash_keys(if round == 0 { &keys[..3] } else { &keys }));
        let mut rays = 0u64;
        // Σ 1 / light_distance over the rays, for the harmonic mean in media.
        let mut inv_light_distance = 0.0f64;
        // In a scene with media, the medium on the gather's side of the surface.
        let medium = self
            .scene
            .media
            .as_ref()
            .map(|m| m.medium_at(spawn(hit, frame.n)));
        // Every ray is traced to its end first (in order: specular chains draw from `rng`), then the
        // texels of the diffuse ends are read together.
        let result = gather::gather_batch_round(
            hit.p,
            frame.n,
            &self.gather,
            seed,
            round,
            &mut |dirs: &[Vec3], out: &mut Vec<GatherRay>| {
                let mut ends = Vec::with_capacity(dirs.len());
                for &dir in dirs {
                    if self.cancel.load(Ordering::Relaxed) {
                        ends.push(GatherEnd::MISS);
                        continue;
                    }
                    rays += 1;
                    ends.push(self.gather_ray(hit, dir, medium, &mut rng, &mut rays));
                }
                let diffuse: Vec<GatherHit> = ends
                    .iter()
                    .filter(|e| e.weight != Vec3::ZERO)
                    .map(|e| e.hit)
                    .collect();
                let mut texels = Vec::with_capacity(diffuse.len());
                self.photons.gather_radiance_batch(&diffuse, &mut texels);
                let mut texels = texels.into_iter();
                let first = out.len();
                out.extend(ends.iter().map(|end| {
                    let lit = if end.weight != Vec3::ZERO {
                        end.weight * texels.next().unwrap_or(Vec3::ZERO)
                    } else {
                        Vec3::ZERO
                    };
                    inv_light_distance += 1.0 / end.light_distance(lit) as f64;
                    GatherRay {
                        radiance: (lit + end.scattered).max(Vec3::ZERO),
                        distance: end.distance,
                    }
                }));
                if let Some((order, g)) = sh.as_mut() {
                    let mut y = [0.0f32; crate::sh::len(crate::sh::MAX_ORDER)];
                    for (&dir, ray) in dirs.iter().zip(&out[first..]) {
                        crate::sh::eval(*order, dir, &mut y);
                        for (gi, yi) in g.iter_mut().zip(&y) {
                            *gi += ray.radiance * *yi;
                        }
                    }
                }
            },
        );
        let mut result = result;
        if medium.is_some() && inv_light_distance > 0.0 {
            // The record's radius from where the light comes from; the translational gradient keeps
            // the surfaces' distances (Ward's formula is about the edges of what the rays hit).
            result.r_harmonic = (result.n_rays as f64 / inv_light_distance) as f32;
        }
        if let Some((_, g)) = sh.as_mut() {
            // Cosine-distributed rays: each stands for π/N of ∫ L·cos θ·Y dω.
            let w = PI / result.n_rays.max(1) as f32;
            g.iter_mut().for_each(|gi| *gi *= w);
        }
        if self.cancel.load(Ordering::Relaxed) {
            return interrupted_gather(frame);
        }
        c.rays += rays;
        c.gathers += 1;
        c.gather_rays += rays;
        c.gather_noise.record(result.rel_err);
        result
    }

    /// Where one gather ray ends: the first non-specular surface it reaches (following mirror and glass
    /// for a few bounces), whose radiance toward the ray is `weight` (the throughput of the specular
    /// chain) × its texel's diffuse radiance, plus a glossy surface's lobe. Emitters count zero (direct light is its own term) except
    /// for what they reflect; a miss is zero.
    /// In a scene with media (`medium` is then the one the ray starts in), the ray crosses invisible
    /// boundaries and its throughput holds the transmittance; the light the media scatter into it, on
    /// every stretch, is `scattered`.
    fn gather_ray(
        &self,
        from: &Hit,
        dir: Vec3,
        medium: Option<MediumId>,
        rng: &mut Rng,
        rays: &mut u64,
    ) -> GatherEnd {
        const MAX_SPECULAR: u32 = 4;
        let (mut scattered, mut nearness) = (Vec3::ZERO, 0.0);
        let mut in_scatter = |o: Vec3, len: f32, m: &crate::medium::Medium, tr: Vec3| {
            let (l, near) = self.in_scattered(from.p, (o, dir), len, m, tr, rng);
            scattered += l;
            nearness += near;
        };
        let o0 = spawn_clear(from, dir);
        let (first, mut beta, mut medium) = match medium {
            None => (
                self.scene.intersect_gather(o0, dir),
                Vec3::ONE,
                crate::medium::VACUUM,
            ),
            Some(m) => {
                match self
                    .scene
                    .intersect_through(o0, dir, m, rays, &mut in_scatter)
                {
                    Some((h, tr, m)) => (Some(h), tr, m),
                    None => (None, Vec3::ONE, m),
                }
            }
        };
        let Some(first) = first else {
            return GatherEnd {
                scattered,
                nearness,
                ..GatherEnd::MISS
            };
        };
        let distance = first.t;
        let (mut hit, mut d) = (first, dir);
        for bounce in 0..=MAX_SPECULAR {
            let bsdf = &self.scene.bsdf(&hit);
            // A gather's end reads the photon map's texels, blurred far beyond a bump's texels: its
            // smooth normal serves, without the bump map's random reads (a third of Sponza's fill
            // time). Mirror and glass on the way reflect about the bumped normal.
            let frame = if bsdf.is_specular() {
                self.scene.frame(&hit, -d)
            } else {
                Frame::new(&hit, -d)
            };
            if !bsdf.is_specular() {
                return GatherEnd {
                    hit: gather_hit(&hit, &frame, bsdf, -d),
                    weight: beta,
                    scattered,
                    nearness,
                    distance,
                };
            }
            let kd = self.scene.albedo(&hit);
            if bounce == MAX_SPECULAR {
                break;
            }
            let u = [rng.uniform(), rng.uniform(), rng.uniform()];
            let Some(s) = bsdf.sample(kd, frame.n, -d, frame.front, u, Transport::Radiance) else {
                break;
            };
            beta *= s.weight;
            *rays += 1;
            let next = match self.scene.media {
                None => self.scene.intersect(spawn(&hit, s.wi), s.wi),
                Some(_) => {
                    medium = self.scene.medium_after(&hit, s.wi, medium);
                    // After a mirror or glass the ray goes on through the media: their light counts
                    // there too.
                    let chain = beta;
                    let in_scatter = |o: Vec3, len: f32, m: &crate::medium::Medium, tr: Vec3| {
                        let (l, near) =
                            self.in_scattered(from.p, (o, s.wi), len, m, chain * tr, rng);
                        scattered += l;
                        nearness += near;
                    };
                    self.scene
                        .intersect_through(spawn(&hit, s.wi), s.wi, medium, rays, in_scatter)
                        .map(|(h, tr, m)| {
                            beta *= tr;
                            medium = m;
                            h
                        })
                }
            };
            match next {
                Some(h) => {
                    hit = h;
                    d = s.wi;
                }
                None => break,
            }
        }
        GatherEnd {
            distance,
            scattered,
            nearness,
            ..GatherEnd::MISS
        }
    }

    /// The light medium `m` scatters into a gather ray's stretch of `len` from `o` along `d`, times
    /// `weight` (the throughput before the stretch), from the volume lattice: one point jittered in each
    /// of up to [`MARCH_POINTS`] equal parts of the stretch, about a lattice cell long (one point for
    /// `pm-fg`). A single point along the whole stretch rarely lands in a narrow beam and then counts
    /// it many times over: with it, the records' gathers under a spot in fog were twice as noisy.
    /// Also returns Σ luminance / distance from `from` (the gather's point) over that light, each point
    /// at least a lattice cell away ([`GatherEnd::light_distance`]).
    fn in_scattered(
        &self,
        from: Vec3,
        (o, d): (Vec3, Vec3),
        len: f32,
        m: &crate::medium::Medium,
        weight: Vec3,
        rng: &mut Rng,
    ) -> (Vec3, f32) {
        if !(len.is_finite() && m.sigma_s != Vec3::ZERO) {
            return (Vec3::ZERO, 0.0);
        }
        // `pm-fg` gathers at every sample: its pixels average the single points' noise.
        let most = match self.source {
            IndirectSource::Gather => 1,
            _ => MARCH_POINTS,
        };
        let cell = self.photons.volume_grid().map_or(len, |g| g.cell());
        let parts = ((len / cell).ceil() as usize).clamp(1, most);
        let step = len / parts as f32;
        let (mut sum, mut near) = (Vec3::ZERO, 0.0);
        for i in 0..parts {
            let t = (i as f32 + rng.uniform()) * step;
            let x = o + d * t;
            let l = weight * m.transmittance(t) * self.photons.gather_volume_radiance(x, d, m.g);
            sum += l;
            near += pmbase::luminance(l) / (x - from).length().max(cell);
        }
        (sum * step, near * step)
    }
}

/// A non-specular surface where a ray ends, seen from `wo`, as the texels are read there.
fn gather_hit(hit: &Hit, frame: &Frame, bsdf: &Bsdf, wo: Vec3) -> GatherHit {
    let lobe = match *bsdf {
        Bsdf::Glossy { specular, .. } => Some(GatherLobe {
            material: hit.material,
            ks: specular,
            n: frame.n,
            wo,
        }),
        _ => None,
    };
    GatherHit {
        tri: hit.tri,
        front: frame.front,
        p: hit.p,
        lobe,
    }
}

/// The end of one gather ray (see `gather_ray`).
struct GatherEnd {
    /// The surface, the side the ray reached, and a glossy surface's lobe.
    hit: GatherHit,
    /// Throughput of the specular chain to the end (times the texel's radiance there, diffuse and
    /// the lobe's).
    weight: Vec3,
    /// Radiance participating media scatter into the ray before its first surface.
    scattered: Vec3,
    /// Σ luminance / distance from the gather's point over the light the media scatter into the ray
    /// (each part at least a lattice cell away): where that light comes from, for the ray's distance.
    nearness: f32,
    distance: f32,
}

impl GatherEnd {
    /// The distance the ray's light comes from, for the record's radius (Ward's harmonic mean): its
    /// surface's, or with light scattered in by a medium, the luminance-weighted harmonic mean of
    /// the surface's (lit by `lit`) and the scattering's distances. In fog the light on a ceiling
    /// comes from the fog just below it, not from the wall a gather ray ends on.
    fn light_distance(&self, lit: Vec3) -> f32 {
        let (surface, scattered) = (pmbase::luminance(lit), pmbase::luminance(self.scattered));
        if scattered <= 0.0 || !(self.nearness > 0.0) {
            return self.distance;
        }
        (surface + scattered) / (surface / self.distance + self.nearness)
    }

    const MISS: GatherEnd = GatherEnd {
        hit: GatherHit {
            tri: 0,
            front: true,
            p: Vec3::ZERO,
            lobe: None,
        },
        weight: Vec3::ZERO,
        scattered: Vec3::ZERO,
        nearness: 0.0,
        distance: f32::INFINITY,
    };
}

/// Glass at the first this many bounces of a camera path is followed both ways (see `shade_hit`).
const GLASS_SPLIT_DEPTH: u32 = 2;
/// A glass's reflect-or-refract choice deeper than [`GLASS_SPLIT_DEPTH`] counts as a Monte Carlo estimate
/// (letting its pixel take up to `spp` samples) only where the path carries at least this share of the
/// sample: a pane's light reflected twice inside it (F² ≈ 0.2 %) does not.
const MONTE_CARLO_MIN_THROUGHPUT: f32 = 0.1;

/// What a final gather returns once the render is interrupted (its result is discarded): skipping the
/// strata loops and the batched lookups keeps a 1M-ray gather from delaying the stop.
fn interrupted_gather(frame: &Frame) -> GatherResult {
    GatherResult {
        e: Vec3::ZERO,
        grad_r: [Vec3::ZERO; 3],
        grad_t: [Vec3::ZERO; 3],
        r_harmonic: f32::INFINITY,
        r_min: f32::INFINITY,
        dir: frame.n,
        n_rays: 0,
        rel_err: 0.0,
    }
}
