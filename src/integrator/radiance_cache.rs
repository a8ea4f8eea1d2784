//! Radiance caching on glossy surfaces (Křivánek et al. 2005, the course's chapter 7), on top of the
//! irradiance cache: a record made on a glossy surface also keeps the incident light of its final
//! gather, `L(ω)·cos θ`, as spherical-harmonic coefficients of the bands its lobe needs (see `sh`).
//! A glossy point the camera sees interpolates the coefficients of the records the irradiance lookup
//! uses there, with the same Ward/Tabellion–Lamorlette weights, each record's coefficients scaled by
//! the ratio its irradiance gradient extrapolates to the point, and reflects them toward the camera
//! with one dot product through the lobe's zonal kernel: no lobe sample, so no Monte Carlo noise.
//!
//! The coefficients are in world space (no rotation between a record's frame and the lookup's). The
//! lobes the cache serves are those whose kernel falls below [`TOLERANCE`] of its first band within
//! [`sh::MAX_ORDER`] bands (exponents up to about 37); it keeps all [`sh::MAX_ORDER`] bands for them.
//! Both limits are measured (docs/algorithms.md, "Glossy surfaces"): past them sampling the lobe is
//! as fast and the cache's error grows beyond sampling's, and fewer bands ring at the horizon.
//! Sharper lobes keep importance sampling.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use glam::Vec3;
use icache::IrradianceCache;

use crate::material::Bsdf;
use crate::scene::Scene;
use crate::sh::{self, PhongKernel};

/// A lobe is cached when its kernel's band `l` falls below this fraction of band 0 for some
/// `l < MAX_ORDER` (exponents up to about 37; see the module's measurements).
pub const TOLERANCE: f32 = 0.3;

/// The radiance cache of one render.
pub struct RadianceCache {
    /// Per material: the lobe's kernel and the bands kept, for glossy lobes the cache serves.
    lobes: Vec<Option<(PhongKernel, usize)>>,
    /// Coefficients made during the fill, by the bits of their record's position.
    made: Mutex<HashMap<[u32; 3], Arc<[Vec3]>>>,
    /// After the fill: each record's coefficients (`None` for records on other surfaces).
    by_record: OnceLock<Vec<Option<Arc<[Vec3]>>>>,
    lookups: AtomicU64,
    fallbacks: AtomicU64,
}

/// Counts for the statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RadianceCacheStats {
    pub records: u64,
    /// Bands kept by the cached lobes (the most of any material).
    pub max_order: u32,
    pub lookups: u64,
    /// Glossy points of a cached lobe that no record with coefficients reached: sampled instead.
    pub fallbacks: u64,
    pub memory_bytes: u64,
}

impl RadianceCache {
    /// The cache for the scene's glossy materials; `None` when no lobe is smooth enough for it.
    pub fn new(scene: &Scene) -> Option<RadianceCache> {
        let settings = &scene.settings.icache;
        if !settings.radiance_cache {
            return None;
        }
        let lobes: Vec<_> = scene
            .materials
            .iter()
            .enumerate()
            .map(|(k, m)| match m.bsdf {
                Bsdf::Glossy {
                    specular, exponent, ..
                } if specular != Vec3::ZERO && !scene.exponent_varies(k) => {
                    let kernel = PhongKernel::new(exponent);
                    kernel.order_for(TOLERANCE)?;
                    Some((kernel, settings.radiance_bands.unwrap_or(sh::MAX_ORDER)))
                }
                _ => None,
            })
            .collect();
        if lobes.iter().all(Option::is_none) {
            return None;
        }
        Some(RadianceCache {
            lobes,
            made: Mutex::new(HashMap::new()),
            by_record: OnceLock::new(),
            lookups: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
        })
    }

    /// The bands a record made on material `material` keeps; `None` for lobes the cache does not serve.
    pub fn order(&self, material: u32) -> Option<usize> {
        self.lobes
            .get(material as usize)
            .copied()
            .flatten()
            .map(|(_, o)| o)
    }

    /// Keeps the coefficients of the record the fill is making at `pos`.
    pub fn keep(&self, pos: Vec3, coefficients: Vec<Vec3>) {
        let key = pos.to_array().map(f32::to_bits);
        self.made
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(key, coefficients.into());
    }

    /// The coefficients made so far, by the bits of their record's position, in the order of those bits
    /// (a bake keeps them: see `render::baked`).
    pub fn coefficients(&self) -> Vec<([u32; 3], Arc<[Vec3]>)> {
        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        let mut all: Vec<_> = made.iter().map(|(k, c)| (*k, c.clone())).collect();
        all.sort_unstable_by_key(|(k, _)| *k);
        all
    }

    /// Before the next frame of a sequence fills the irradiance cache: the coefficients made so far stay,
    /// to be attached again to the records that remain.
    pub fn next_frame(&mut self) {
        self.by_record = OnceLock::new();
    }

    /// Once the fill is done: each record of `cache` with the coefficients made at its position.
    pub fn attach(&self, cache: &IrradianceCache) {
        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        let by_record = cache
            .records()
            .iter()
            .map(|r| made.get(&r.pos.to_array().map(f32::to_bits)).cloned())
            .collect();
        let _ = self.by_record.set(by_record);
    }

    /// The light the glossy lobe (material `material`, specular `ks`) at (p, n) reflects toward `wo`,
    /// interpolated from the records `cache` uses there (the first `n_records`, those `visible`
    /// accepts, found by the normal before a bump, `n_smooth`: the lobe follows the bumped `n`); `None` when the lobe is not cached or no record there has coefficients (the caller
    /// samples the lobe).
    #[allow(clippy::too_many_arguments)]
    pub fn reflected(
        &self,
        cache: &IrradianceCache,
        n_records: usize,
        visible: impl Fn(u32, &icache::Record) -> bool,
        (material, ks): (u32, Vec3),
        p: Vec3,
        (n_smooth, n): (Vec3, Vec3),
        wo: Vec3,
    ) -> Option<Vec3> {
        let (kernel, order) = self.lobes.get(material as usize).copied().flatten()?;
        let by_record = self.by_record.get()?;
        let records = cache.records();
        let mut sum = [Vec3::ZERO; sh::len(sh::MAX_ORDER)];
        let mut weight_sum = 0.0f32;
        cache.each_used_turned(
            p,
            n_smooth,
            n,
            icache::Pass::B,
            n_records,
            visible,
            |id, w, e| {
                // Records pass B's repairs made after `attach` are found by position.
                let later;
                let g = match by_record.get(id as usize) {
                    Some(Some(g)) => g,
                    Some(None) => return,
                    None => {
                        let key = records[id as usize].pos.to_array().map(f32::to_bits);
                        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
                        match made.get(&key) {
                            Some(g) => {
                                later = g.clone();
                                &later
                            }
                            None => return,
                        }
                    }
                };
                // The record's gradients move its irradiance to p: its light is scaled alike.
                let (e0, e1) = (
                    crate::warp::luminance(records[id as usize].e),
                    crate::warp::luminance(e),
                );
                let scale = if e0 > 0.0 {
                    (e1 / e0).clamp(0.0, 4.0)
                } else {
                    1.0
                };
                for (s, c) in sum.iter_mut().zip(g.iter().take(sh::len(order))) {
                    *s += w * scale * *c;
                }
                weight_sum += w;
            },
        );
        self.lookups.fetch_add(1, Ordering::Relaxed);
        if !(weight_sum > 0.0) {
            self.fallbacks.fetch_add(1, Ordering::Relaxed);
            return None;
        }
        let g: Vec<Vec3> = sum[..sh::len(order)]
            .iter()
            .map(|c| *c / weight_sum)
            .collect();
        let l = ks * sh::reflect(&g, order, &kernel, crate::warp::reflect(wo, n));
        Some(l.max(Vec3::ZERO))
    }

    /// Where the records with coefficients are (for `--cache-image`).
    pub fn positions(&self) -> Vec<Vec3> {
        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        made.keys()
            .map(|k| Vec3::from_array(k.map(f32::from_bits)))
            .collect()
    }

    pub fn stats(&self) -> RadianceCacheStats {
        let made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        let floats: usize = made.values().map(|g| g.len()).sum();
        RadianceCacheStats {
            records: made.len() as u64,
            max_order: self
                .lobes
                .iter()
                .flatten()
                .map(|l| l.1 as u32)
                .max()
                .unwrap_or(0),
            lookups: self.lookups.load(Ordering::Relaxed),
            fallbacks: self.fallbacks.load(Ordering::Relaxed),
            memory_bytes: (floats * 12 + made.len() * 48) as u64,
        }
    }
}
