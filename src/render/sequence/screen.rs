//! Where a sequence's changes land on screen: the window a moved mesh covers in one frame, and
//! the window its moving meshes may cover over a sequence whose camera stays.

use std::ops::RangeInclusive;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Mat4, Vec2, Vec3};

use super::temporal::{Moved, SceneChange};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::render::tiles::Window;
use crate::scene::{frame_view, Animation, Scene};

/// The pixels whose camera rays may meet a moved mesh, before or after its step (its bounding
/// spheres' projections, with a margin); `None` when that may be anywhere (a sphere around or behind
/// the eye).
pub fn screen_window(change: &SceneChange, cam: &Camera) -> Option<Window> {
    let mut lo = Vec2::splat(f32::INFINITY);
    let mut hi = Vec2::splat(f32::NEG_INFINITY);
    for &(c, r) in change.moved.iter().flat_map(|m| &m.spheres) {
        let (a, b) = sphere_pixels(cam, c, r)?;
        lo = lo.min(a);
        hi = hi.max(b);
    }
    Some(pixel_window(cam, lo, hi))
}

/// The pixels where the meshes that move over `frames` of `anim` may be seen while the camera (at
/// `width` × `height`) stays as in the first of them: the union of each step's [`screen_window`],
/// up to the first frame whose view differs, with that camera. `None` when no mesh moves before then,
/// or where one may be seen anywhere. `scene` is the first frame's. A phase of its own: one frame's
/// description read per frame, `cancel` read before each.
pub fn sequence_window(
    anim: &Animation,
    scene: &Scene,
    frames: RangeInclusive<u32>,
    (width, height): (u32, u32),
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Option<(Camera, Window)>> {
    let first = *frames.start();
    let (cam, placed_first) = frame_view(anim, first)?;
    let cam = cam.with_resolution(width, height);
    let spheres: Vec<Option<(Vec3, f32)>> = (0..scene.mesh_ranges.len())
        .map(|m| scene.mesh_sphere(m))
        .collect();
    // Mesh m's bounding sphere where placement `t` puts it: the first frame's, carried along.
    let sphere = |m: usize, t: Option<Mat4>| -> Option<(Vec3, f32)> {
        let (c, r) = spheres.get(m).copied().flatten()?;
        let t = t? * placed_first.get(m).copied().flatten()?.inverse();
        let stretch = [t.x_axis, t.y_axis, t.z_axis]
            .iter()
            .map(|a| a.truncate().length())
            .fold(0.0, f32::max);
        Some((t.transform_point3(c), r * stretch))
    };
    progress.start("moving pixels", frames.clone().count() as u64);
    let mut before = placed_first.clone();
    let mut union: Option<Window> = None;
    for (i, f) in frames.enumerate().skip(1) {
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Interrupted);
        }
        progress.set(i as u64);
        let (view, placed) = frame_view(anim, f)?;
        if !view.with_resolution(width, height).same_view(&cam) {
            break;
        }
        let mut moved = Vec::new();
        for (m, (&b, &a)) in before.iter().zip(&placed).enumerate() {
            if b == a {
                continue;
            }
            match (sphere(m, b), sphere(m, a)) {
                (Some(b), Some(a)) => moved.push(Moved::new(b, a, None)),
                _ => {
                    progress.finish();
                    return Ok(None);
                }
            }
        }
        before = placed;
        if moved.is_empty() {
            continue;
        }
        let change = SceneChange {
            moved,
            ..Default::default()
        };
        let Some(w) = screen_window(&change, &cam) else {
            progress.finish();
            return Ok(None);
        };
        union = Some(union.map_or(w, |u| u.union(w)));
    }
    progress.finish();
    Ok(union.map(|w| (cam, w)))
}

/// The pixel box a sphere may cover on screen (`None` when it surrounds or lies behind the eye): its
/// radius at its nearest depth, widened for the off-axis stretch.
pub(super) fn sphere_pixels(cam: &Camera, c: Vec3, r: f32) -> Option<(Vec2, Vec2)> {
    let depth = (c - cam.eye).dot(cam.forward());
    if depth <= 2.0 * r {
        return None;
    }
    let (x, y) = cam.project(c)?;
    let px_per_unit = cam.height as f32 / (2.0 * (cam.fov_deg().to_radians() * 0.5).tan());
    let reach = 2.0 * r * px_per_unit / (depth - r) + 2.0;
    Some((
        Vec2::new(x - reach, y - reach),
        Vec2::new(x + reach, y + reach),
    ))
}

/// The image's pixels within [lo, hi] (empty when lo > hi).
pub(super) fn pixel_window(cam: &Camera, lo: Vec2, hi: Vec2) -> Window {
    if lo.x > hi.x || lo.y > hi.y {
        return Window {
            x0: 0,
            y0: 0,
            x1: 0,
            y1: 0,
        };
    }
    let clamp = |v: f32, max: u32| v.clamp(0.0, max as f32) as u32;
    Window {
        x0: clamp(lo.x.floor(), cam.width),
        y0: clamp(lo.y.floor(), cam.height),
        x1: clamp(hi.x.ceil() + 1.0, cam.width),
        y1: clamp(hi.y.ceil() + 1.0, cam.height),
    }
}
