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

/// Most times the global count the volume map holds for a forward- or back-scattering medium.
const MAX_PHASE_CONCENTRATION: f64 = 8.0;

/// The growth of an estimate's variance, over an isotropic medium's, below which the volume map keeps
/// the global count: on the fogged Cornell box (g = 0.3, growth 1.3) a third more photons cost 15 %
/// more time for no less error.
const PHASE_GROWTH_FREE: f64 = 1.5;

/// How many times more volume photons an estimate of the light scattered toward one direction needs
/// in the most anisotropic of `media` (Henyey–Greenstein |g|) to be about as good as in an isotropic
/// medium: each photon is weighted by its own phase toward the ray, and the more peaked the phase, the
/// fewer photons carry the estimate. The variance grows by about (1 + g²)/(1 − g²)² (measured on a
/// room's image mean, camera in dense fog, k = 100: 2.3 times at g = 0.5 and 9.7 times at g = 0.8, and
/// falling as 1/N with the volume photon count N, whatever k); the map grows by what exceeds
/// [`PHASE_GROWTH_FREE`], at most [`MAX_PHASE_CONCENTRATION`] times.
fn phase_concentration(media: &[crate::medium::Medium]) -> f64 {
    let g = media
        .iter()
        .filter(|m| m.sigma_s.max_element() > 0.0)
        .map(|m| (m.g as f64).abs())
        .fold(0.0, f64::max);
    let g2 = g * g;
    let growth = (1.0 + g2) / ((1.0 - g2) * (1.0 - g2)).max(1e-9);
    (1.0 + (growth - PHASE_GROWTH_FREE).max(0.0)).min(MAX_PHASE_CONCENTRATION)
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
        // Media: as many volume photons as global ones, times the phase's concentration (below), the
        // radius cap from the media's volume as the surface caps come from the area (twice the radius
        // holding k photons at the mean density of the global count: thin media stop a map short of
        // its count, and the lattices over the media are sized by the cap).
        let (volume, max_radius_volume) = match &scene.media {
            Some(m) => {
                let volume = (global as f64 * phase_concentration(&m.list)).round() as usize;
                let v = m.volume().max(1e-30);
                let r = (3.0 * lookup as f64 * v
                    / (4.0 * std::f64::consts::PI * global.max(1) as f64))
                    .cbrt() as f32;
                (volume, (2.0 * r).min(scene.diagonal() * 0.25))
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::Medium;
    use glam::Vec3;

    fn medium(sigma_s: f32, g: f32) -> Medium {
        Medium {
            name: "m".into(),
            sigma_a: Vec3::splat(0.1),
            sigma_s: Vec3::splat(sigma_s),
            sigma_t: Vec3::splat(0.1 + sigma_s),
            g,
        }
    }

    #[test]
    fn the_volume_map_grows_with_the_most_peaked_phase_that_scatters() {
        assert_eq!(phase_concentration(&[medium(1.0, 0.0)]), 1.0);
        assert_eq!(phase_concentration(&[medium(1.0, 0.3)]), 1.0);
        let forward = phase_concentration(&[medium(1.0, 0.0), medium(1.0, 0.6)]);
        assert!((forward - (1.36 / 0.4096 - 0.5)).abs() < 1e-6, "{forward}");
        // Back-scattering counts as forward does; a medium that only absorbs has no phase to sample.
        assert_eq!(phase_concentration(&[medium(1.0, -0.6)]), forward);
        assert_eq!(phase_concentration(&[medium(0.0, 0.9)]), 1.0);
        assert_eq!(
            phase_concentration(&[medium(1.0, 0.95)]),
            MAX_PHASE_CONCENTRATION
        );
    }
}
