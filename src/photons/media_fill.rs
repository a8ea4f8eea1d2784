//! Pass A of the media radiance cache for `pm` (Jarosz, Donner, Zwicker & Jensen 2008): the points
//! where camera rays of a pixel lattice cross a medium (through invisible boundaries, glass and
//! mirrors), and the record made at such a point — the volume photon map's estimate of the light
//! scattered more than once (over the photons its radius holds, [`REACH_KERNEL`]), its gradient, and
//! its validity radius.
//!
//! Around each record 96 rays ([`Surroundings`]) measure the distance to the first surface; with
//! `[render.icache] media_visibility` the estimate also leaves out photons behind occluders and is
//! divided by the kernel's visible share. The radius R of a record at x is the smallest of
//! - the harmonic mean of those distances (boundaries included: the light in a medium changes at its
//!   walls, at occluders and at the shadows they cast), times [`HARMONIC_SCALE`] — Ward's split
//!   sphere, each distance cut at the mean free path;
//! - the distance over which the gradient changes the estimate by [`GRADIENT_CHANGE`] of itself (a
//!   record's first-order extrapolation is trusted that far), the estimate taken over the gradient's
//!   wider kernel: a radius that grows with the record's own noisy value lets the records that came
//!   out high cover more of the image than those that came out low, and biases the blend upward;
//! - the medium's mean free path 1/σt and a quarter of the scene's diagonal;
//! - [`MAX_ANGLE`] times the distance from the camera along the record's path,
//!
//! but not below [`KERNEL_REACH`] times the estimate's own kernel radius (records closer than that
//! hold nearly the same photons) nor below [`LATTICE_REACH`] lattice spacings of pixels at x (pass B's
//! rays between the lattice's find it).

use glam::Vec3;
use icache::media::{MediaPoint, VolumeRecord};

use super::volume_lattice::{estimate_within, Surroundings};
use super::PhotonData;
use crate::camera::Camera;
use crate::geometry::spawn;
use crate::material::{glass_lobes, Bsdf};
use crate::medium::MediumId;
use crate::scene::Scene;

/// Camera rays of the lattice, at most (the lattice spacing grows to stay under it).
const MAX_LATTICE_RAYS: u64 = 16_384;
/// Points per march step along a ray (the march of `media::in_scattered` takes one per 1/32 of the
/// scene's diagonal).
const POINTS_PER_STEP: u32 = 2;
/// Points in all, at most (40 MiB): rays beyond are left to pass B's misses.
pub const MAX_POINTS: usize = 1 << 21;
/// Points per stretch of medium, at most.
const MAX_POINTS_PER_SEGMENT: u32 = 64;
/// Glass and mirror bounces followed from the camera.
const MAX_SPECULAR_DEPTH: u32 = 2;
/// R from the harmonic mean distance.
pub const HARMONIC_SCALE: f32 = 0.5;
/// R from the gradient: R·|∇S| ≤ this fraction of S.
pub const GRADIENT_CHANGE: f32 = 0.5;
/// R is at least this many kernel radii: the records' values are already blurred over the kernel, so a
/// smaller R only makes more records (and a longer pass A) for no less error.
const KERNEL_REACH: f32 = 1.0;
/// R is at most this many radians seen from the camera along the record's path: one record's estimate
/// (and its noise) is then shared by a bounded part of the image; unbounded, with the camera inside a
/// medium, the records near the eye spanned the whole image and biased it.
const MAX_ANGLE: f32 = 0.15;
/// R is at least this many lattice spacings (pixels × stride) at the record's point.
const LATTICE_REACH: f32 = 1.5;
/// A record's value is estimated over a kernel this share of R wide (with k scaled by the volume),
/// where that is wider than the k nearest photons reach;
const REACH_KERNEL: f32 = 0.7;
/// over this many photons at most.
const MAX_REACH_K: usize = 16_000;

/// Pixel lattice spacing for a `width` × `height` image.
pub fn lattice_stride(width: u32, height: u32) -> u32 {
    let pixels = width as u64 * height as u64;
    let mut s = 1u32;
    while pixels / (s as u64 * s as u64) > MAX_LATTICE_RAYS {
        s += 1;
    }
    s
}

/// The points where camera rays through the centres of every `stride`-th pixel (in hierarchical order)
/// cross a medium; each point's `max_radius` is the medium's mean free path (capped by a quarter of the
/// scene's diagonal).
/// Points are ordered coarse to fine along the rays as across the image: first every ray's point of
/// index 0 along its path, then those of index 1/2 of the way (bit-reversed index order), and so on —
/// so that a wave of estimates seldom holds two points one record would cover (in ray order a third
/// of fog-cornell's estimates were covered by an earlier one of their wave).
pub fn media_points(
    scene: &Scene,
    camera: &Camera,
    width: u32,
    height: u32,
    stride: u32,
) -> Vec<MediaPoint> {
    let mut keyed = Vec::new();
    let mut out = Vec::new();
    let step = scene.diagonal() / 32.0 / POINTS_PER_STEP as f32;
    for (x, y) in icache::order::HierarchicalOrder::new(width, height)
        .filter(|&(x, y)| x % stride == 0 && y % stride == 0)
    {
        if keyed.len() >= MAX_POINTS {
            break;
        }
        let d = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
        let pixel = |dist: f32| camera.pixel_world(d, dist, 1.0);
        follow(
            scene,
            camera.eye,
            d,
            scene.camera_medium(),
            0.0,
            0,
            step,
            &pixel,
            &mut out,
        );
        keyed.extend(
            out.drain(..)
                .enumerate()
                .map(|(k, p)| ((k as u32).reverse_bits(), p)),
        );
    }
    // Stable: equal keys keep the rays' hierarchical order.
    keyed.sort_by_key(|(key, _)| *key);
    keyed.into_iter().map(|(_, p)| p).collect()
}

#[allow(clippy::too_many_arguments)]
fn follow(
    scene: &Scene,
    o: Vec3,
    d: Vec3,
    medium: MediumId,
    dist: f32,
    depth: u32,
    step: f32,
    pixel: &dyn Fn(f32) -> f32,
    out: &mut Vec<MediaPoint>,
) {
    let mut rays = 0;
    let max_radius = |sigma_t: Vec3| (1.0 / sigma_t.max_element()).min(0.25 * scene.diagonal());
    let end = scene.intersect_through(o, d, medium, &mut rays, |start, len, m, _| {
        if !len.is_finite() || len <= 0.0 || m.sigma_t.max_element() <= 0.0 {
            return;
        }
        let n = ((len / step).ceil() as u32).clamp(1, MAX_POINTS_PER_SEGMENT);
        let along = dist + (start - o).length();
        for k in 0..n {
            let t = (k as f32 + 0.5) / n as f32 * len;
            out.push(MediaPoint {
                pos: start + d * t,
                pixel_world: pixel(along + t),
                max_radius: max_radius(m.sigma_t).min(MAX_ANGLE * (along + t)),
                dir: d,
                g: m.g,
            });
        }
    });
    let Some((hit, _, medium)) = end else { return };
    if depth >= MAX_SPECULAR_DEPTH {
        return;
    }
    let frame = crate::geometry::Frame::new(&hit, -d);
    let dist = dist + hit.t;
    match scene.material(&hit).bsdf {
        Bsdf::Glass { ior, transmittance } => {
            for (wi, w) in glass_lobes(ior, transmittance, frame.n, -d, frame.front) {
                if w != Vec3::ZERO {
                    follow(
                        scene,
                        spawn(&hit, wi),
                        wi,
                        scene.medium_after(&hit, wi, medium),
                        dist,
                        depth + 1,
                        step,
                        pixel,
                        out,
                    );
                }
            }
        }
        Bsdf::Mirror { .. } => {
            let wi = d - 2.0 * d.dot(frame.n) * frame.n;
            follow(
                scene,
                spawn(&hit, wi),
                wi,
                scene.medium_after(&hit, wi, medium),
                dist,
                depth + 1,
                step,
                pixel,
                out,
            );
        }
        _ => {}
    }
}

/// The record for `p`: the estimate over the photons camera rays read (with its gradient), fitted over
/// the same view of its surroundings as a camera ray's step without the cache ([`PhotonData::volume_view`]),
/// and its radius from the walls measured at the point (see the module header); `stride` is the
/// pixel lattice's. The shared view makes the cache estimate what a step without it would (a view
/// measured at the point reads high in dense fog: docs/validation.md).
pub fn media_record(
    scene: &Scene,
    photons: &PhotonData,
    p: &MediaPoint,
    stride: u32,
) -> VolumeRecord {
    let Some(map) = &photons.maps().volume else {
        return VolumeRecord::default();
    };
    let around = photons.volume_view(p.pos);
    let (_, walls) = surroundings(scene, p.pos);
    let (k, cap) = (
        photons.settings().lookup,
        photons.settings().max_radius_volume,
    );
    let est = estimate_within(
        map,
        p.pos,
        (k, cap),
        photons.camera_photons(),
        true,
        around.as_ref(),
        Some((p.dir, p.g)),
    );
    let (rec, r_kernel) = (est.rec, est.radius);
    let mut radius = p
        .max_radius
        .min(HARMONIC_SCALE * walls.harmonic_mean(p.max_radius));
    let lum = pmbase::luminance;
    let grad = Vec3::new(
        lum(rec.grad[0][0]),
        lum(rec.grad[0][1]),
        lum(rec.grad[0][2]),
    )
    .length();
    if grad > 0.0 {
        radius = radius.min(GRADIENT_CHANGE * lum(est.wide_power) / grad);
    }
    radius = radius
        .max(KERNEL_REACH * r_kernel)
        .max(LATTICE_REACH * stride as f32 * p.pixel_world);
    // The value estimated again over about as many photons as the record's reach holds: with the k
    // nearest alone most photons counted in no record, and each record's noise was shared by all the
    // image it covers. The gradient stays the first estimate's (over twice its kernel).
    let reach = REACH_KERNEL * radius / r_kernel.max(1e-12);
    let (value, ratio) = if reach > 1.0 {
        let k_reach = ((k as f32 * reach.powi(3)) as usize).clamp(k, MAX_REACH_K);
        let wide = estimate_within(
            map,
            p.pos,
            (k_reach, cap),
            photons.camera_photons(),
            false,
            around.as_ref(),
            Some((p.dir, p.g)),
        );
        (wide.rec.s, wide.phase_ratio)
    } else {
        (rec.s, est.phase_ratio)
    };
    VolumeRecord {
        pos: p.pos,
        radius,
        value,
        grad: rec.grad,
        dir: p.dir,
        ratio,
    }
}

/// What a point in a medium sees around it: as far as a volume estimate's kernel reaches (through
/// faces shared by two media: their photons are in the one map), and up to the first surface of any
/// kind (a record's radius stops at every boundary: the light changes there).
pub(crate) fn surroundings(scene: &Scene, x: Vec3) -> (Surroundings, Surroundings) {
    let mut first = Vec::with_capacity(96);
    let around = Surroundings::measure(|dir| {
        let (wall, reach) = extent(scene, x, dir);
        first.push(wall);
        reach
    });
    let mut first = first.into_iter();
    let walls =
        Surroundings::measure(|_| first.next().unwrap_or((f32::INFINITY, false, Vec3::ZERO)));
    (around, walls)
}

/// Along `dir` from `x` (in a medium): the first surface, and how far the volume photons reach — to
/// the first occluder, or to the first invisible boundary with no medium beyond (one between two media
/// does not stop them). Each as its distance, whether it is an occluder, and its normal.
type Reach = (f32, bool, Vec3);
fn extent(scene: &Scene, x: Vec3, dir: Vec3) -> (Reach, Reach) {
    const MAX_CROSSINGS: u32 = 16;
    const NOTHING: Reach = (f32::INFINITY, false, Vec3::ZERO);
    let mut first = None;
    let mut t0 = 0.0;
    for _ in 0..MAX_CROSSINGS {
        let Some(h) = scene.intersect_after(x, dir, t0) else {
            return (first.unwrap_or(NOTHING), NOTHING);
        };
        let solid = !scene.material(&h).bsdf.is_null();
        let here = (h.t, solid, h.ng);
        let first = *first.get_or_insert(here);
        if solid {
            return (first, here);
        }
        let (beyond, next) = scene.cross(x, dir, h.tri, h.t, crate::medium::VACUUM);
        if scene.medium(beyond).is_none() {
            return (first, here);
        }
        t0 = next;
    }
    (first.unwrap_or(NOTHING), (t0, false, Vec3::ZERO))
}
