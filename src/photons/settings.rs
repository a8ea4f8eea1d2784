//! `[render.photons]` resolved: the scene's values, and defaults derived from its geometry and media
//! where it gives none.

use photon::Filter;

use crate::scene::Scene;

/// Default size of an irradiance-atlas texel, in global photons at the scene's mean density
/// (`[render.photons] precompute_every`). A k = 100 estimate blurs over ~12 texels; coarser texels
/// showed in scenes with few photons (their blur adds to the estimate's) and shifted large walls.
pub const DEFAULT_PHOTONS_PER_TEXEL: usize = 8;

/// `[render.photons]` resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonSettings {
    pub global: usize,
    pub caustic: usize,
    pub lookup: usize,
    pub max_radius_global: f32,
    pub max_radius_caustic: f32,
    pub precompute_every: usize,
    pub caustic_filter: Filter,
    /// Photons stored at scattering events in media (0 without media) and their estimate's radius cap.
    pub volume: usize,
    pub max_radius_volume: f32,
    /// L S+ V photons (scenes with media and specular surfaces; 0 otherwise), and their radius cap.
    pub volume_caustic: usize,
    pub max_radius_volume_caustic: f32,
}

impl PhotonSettings {
    /// `[render.photons]` (checked when the scene was loaded) with the scene's defaults where it gives no
    /// value: global photons from the triangle count (200 k up to 5 k triangles, growing as its square
    /// root, at most 2 M), 100 k caustic photons when the scene has mirror or glass (none otherwise),
    /// k = 100, radii from the scene's real surface area and the photon count (see `photon::defaults`);
    /// the caustic radius half the global one (or less, with more caustic photons).
    pub fn resolve(scene: &Scene) -> PhotonSettings {
        let d = &scene.settings.photons;
        let global = d.global.unwrap_or_else(|| {
            photon::defaults::default_global_photons(scene.geometry.triangles.len())
        });
        let caustic = d
            .caustic
            .unwrap_or(if scene.has_specular() { 100_000 } else { 0 });
        let lookup = d.lookup.unwrap_or(100);
        let precompute_every = d.precompute_every.unwrap_or(DEFAULT_PHOTONS_PER_TEXEL);
        let (max_radius_global, max_radius_caustic) = match d.max_radius {
            Some(r) => (r, r),
            None => {
                let area: f32 = scene.geometry.triangles.iter().map(|t| t.area).sum();
                let diag = scene.diagonal();
                (
                    photon::defaults::max_radius_for_area(area, diag, global, lookup),
                    // Caustics are concentrated light: their estimates reach no farther than half the
                    // global map's. Sized from the caustic count alone, Sibenik's sparse red-pane photons
                    // (0.1 % of the image) were looked up 1.5 m around nearly every shading sample.
                    photon::defaults::max_radius_for_area(
                        area,
                        diag,
                        caustic.max(global).max(1),
                        lookup,
                    ) * 0.5,
                )
            }
        };
        // Media: as many volume photons as global ones, the radius cap from the media's volume as the
        // surface caps come from the area (twice the radius holding k photons at the mean density).
        let (volume, max_radius_volume) = match &scene.media {
            Some(m) => {
                let v = m.volume().max(1e-30);
                let r = (3.0 * lookup as f64 * v
                    / (4.0 * std::f64::consts::PI * global.max(1) as f64))
                    .cbrt() as f32;
                (global, (2.0 * r).min(scene.diagonal() * 0.25))
            }
            None => (0, 0.0),
        };
        // The volume caustic map as the surface one: 100 k photons, half the radius.
        let volume_caustic = if volume > 0 && scene.has_specular() {
            100_000
        } else {
            0
        };
        let max_radius_volume_caustic = max_radius_volume * 0.5;
        PhotonSettings {
            global,
            caustic,
            lookup,
            max_radius_global,
            max_radius_caustic,
            precompute_every,
            caustic_filter: d.caustic_filter,
            volume,
            max_radius_volume,
            volume_caustic,
            max_radius_volume_caustic,
        }
    }
}
