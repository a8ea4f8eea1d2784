//! Default photon counts, lookup sizes and radii, scaled with the scene so that a scene file needs no
//! tuning.
//!
//! The global count grows with the scene's geometric detail: `DEFAULT_GLOBAL_PHOTONS` up to
//! `DETAIL_TRIANGLES` triangles, then as the square root of the triangle count, at most
//! `MAX_DEFAULT_GLOBAL_PHOTONS`. A density estimate blurs light over its disc; what the blur costs is
//! set by how much surface detail (edges, mouldings, columns) lies within it, and the triangle count is
//! the scene's own measure of that: a detailed scene needs more photons for the same error against a
//! reference, a box scene does not.
//!
//! The radius rule: with `n` photons spread over surfaces of area `A`, `k` photons are found within
//! `r_k = sqrt(k · A / (π n))` at the mean density. The maximum radius is `MAX_RADIUS_FACTOR` times
//! that, so that it only limits the search where photons are sparser than average, and never more than
//! `MAX_RADIUS_FRACTION` of the diagonal.
#![forbid(unsafe_code)]

use crate::trace::PhotonTargets;

pub(crate) const DEFAULT_GLOBAL_PHOTONS: usize = 200_000;
/// Scenes up to this many triangles get [`DEFAULT_GLOBAL_PHOTONS`].
pub(crate) const DETAIL_TRIANGLES: usize = 5_000;
pub(crate) const MAX_DEFAULT_GLOBAL_PHOTONS: usize = 2_000_000;
pub(crate) const DEFAULT_CAUSTIC_PHOTONS: usize = 100_000;
pub(crate) const MAX_RADIUS_FACTOR: f32 = 2.0;
pub(crate) const MAX_RADIUS_FRACTION: f32 = 0.1;
/// Paths allowed per photon wanted before the pass gives up, and a floor for tiny targets.
pub(crate) const PATHS_PER_TARGET_PHOTON: u64 = 100;
pub(crate) const MIN_MAX_PATHS: u64 = 1_000_000;

/// Default global photon count for a scene of `n_triangles` (see the module header), in steps of 10 k.
pub fn default_global_photons(n_triangles: usize) -> usize {
    let scale = (n_triangles.max(1) as f64 / DETAIL_TRIANGLES as f64)
        .sqrt()
        .max(1.0);
    let n = (DEFAULT_GLOBAL_PHOTONS as f64 * scale / 10_000.0).round() as usize * 10_000;
    n.clamp(DEFAULT_GLOBAL_PHOTONS, MAX_DEFAULT_GLOBAL_PHOTONS)
}

/// Maximum lookup radius for estimates of `k` photons out of `n_photons` spread over `area` (the scene's
/// real surface area), `MAX_RADIUS_FACTOR` times the radius holding `k` at that mean density, at most
/// `MAX_RADIUS_FRACTION` of the diagonal.
pub fn max_radius_for_area(area: f32, scene_diagonal: f32, n_photons: usize, k: usize) -> f32 {
    let d = if scene_diagonal.is_finite() && scene_diagonal > 0.0 {
        scene_diagonal
    } else {
        1.0
    };
    let cap = MAX_RADIUS_FRACTION * d;
    if n_photons == 0 || !(area.is_finite() && area > 0.0) {
        return cap;
    }
    let r_k = (k as f32 * area / (std::f32::consts::PI * n_photons as f32)).sqrt();
    (MAX_RADIUS_FACTOR * r_k).min(cap)
}

/// Default targets: the default counts, and a path budget of `PATHS_PER_TARGET_PHOTON` per photon.
pub fn default_targets(global: usize, caustic: usize) -> PhotonTargets {
    let wanted = (global as u64).saturating_add(caustic as u64);
    PhotonTargets {
        global,
        caustic,
        volume: 0,
        volume_caustic: 0,
        max_paths: wanted
            .saturating_mul(PATHS_PER_TARGET_PHOTON)
            .max(MIN_MAX_PATHS),
    }
}

impl Default for PhotonTargets {
    fn default() -> Self {
        default_targets(DEFAULT_GLOBAL_PHOTONS, DEFAULT_CAUSTIC_PHOTONS)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Estimates of this many photons in the 2 d² oracle below.
    const K: usize = 64;

    /// The radius rule with the surface area taken as `2 d²` for a scene of bounding-box diagonal `d`
    /// (the surface of a cube of diagonal `d` is `6 (d/√3)² = 2 d²`), written out on its own.
    fn default_max_radius(scene_diagonal: f32, n_photons: usize) -> f32 {
        let d = if scene_diagonal.is_finite() && scene_diagonal > 0.0 {
            scene_diagonal
        } else {
            1.0
        };
        let cap = MAX_RADIUS_FRACTION * d;
        if n_photons == 0 {
            return cap;
        }
        let r_k = (K as f32 * 2.0 * d * d / (std::f32::consts::PI * n_photons as f32)).sqrt();
        (MAX_RADIUS_FACTOR * r_k).min(cap)
    }

    #[test]
    fn radius_scales_with_scene_and_count() {
        let r = default_max_radius(10.0, 100_000);
        // 2 · sqrt(64 · 200 / (π · 1e5)) ≈ 0.404
        assert!((r - 0.4037).abs() < 1e-3, "{r}");
        assert!((default_max_radius(20.0, 100_000) - 2.0 * r).abs() < 1e-3);
        assert!((default_max_radius(10.0, 400_000) - 0.5 * r).abs() < 1e-3);
        assert_eq!(default_max_radius(10.0, 10), 1.0);
        assert_eq!(default_max_radius(10.0, 0), 1.0);
        assert_eq!(default_max_radius(f32::NAN, 0), 0.1);
    }

    #[test]
    fn global_count_grows_with_detail() {
        assert_eq!(default_global_photons(12), 200_000);
        assert_eq!(default_global_photons(5_000), 200_000);
        // Sibenik, Sponza.
        assert_eq!(default_global_photons(75_300), 780_000);
        assert_eq!(default_global_photons(262_000), 1_450_000);
        assert_eq!(default_global_photons(10_000_000), 2_000_000);
        // The area rule agrees with the 2 d² rule where the area is 2 d².
        assert!(
            (max_radius_for_area(200.0, 10.0, 100_000, 64) - default_max_radius(10.0, 100_000))
                .abs()
                < 1e-4
        );
    }

    #[test]
    fn path_budget_has_a_floor() {
        assert_eq!(default_targets(10, 0).max_paths, MIN_MAX_PATHS);
        assert_eq!(PhotonTargets::default().max_paths, 30_000_000);
    }
}
