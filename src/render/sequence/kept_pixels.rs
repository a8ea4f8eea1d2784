//! Which pixels of a sequence's frame must be rendered again when the camera stayed and meshes moved:
//! the window where the moved meshes may be seen (pass A visits only it, at a finer noise target),
//! outside what their moves changed the pixels kept from the frame before unsampled, and among the
//! rest those whose cached light alone changed, shaded again with the very samples they took.

use std::ops::RangeInclusive;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Mat4, Vec2, Vec3};
use rayon::prelude::*;

use icache::{IrradianceCache, Pass};

use pmbase::luminance;

use super::temporal::{Moved, SceneChange};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::Frame;
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
fn sphere_pixels(cam: &Camera, c: Vec3, r: f32) -> Option<(Vec2, Vec2)> {
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
fn pixel_window(cam: &Camera, lo: Vec2, hi: Vec2) -> Window {
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

/// The cached irradiance at each pixel's centre hit and, on a depth edge, at its corners' hits (where
/// its camera rays end), when the pixel was last shaded, while the camera stays: a pixel that a
/// changed record reaches keeps its value only while that light stays within [`LIGHT_TOLERANCE`] of
/// it. With it, where the camera rays ended the frame before.
#[derive(Default)]
pub struct ShadedLight {
    light: Vec<[Option<Vec3>; 5]>,
    rays: Option<CameraEnds>,
}

impl ShadedLight {
    /// Notes, for a frame whose every pixel was shaded anew, the light in `cache` at each pixel's
    /// points, when nothing has been noted since: without it, the next frame would shade again every
    /// pixel a changed record reaches (it could not tell that their light stayed).
    pub fn note_all(&mut self, scene: &Scene, cam: &Camera, cache: &IrradianceCache) {
        if !self.light.is_empty() {
            return;
        }
        let points = pixel_points(
            scene,
            cam,
            Window::full(cam.width, cam.height),
            &mut self.rays,
        );
        self.light = points.par_iter().map(|p| light_at(p, cache)).collect();
    }
}

/// The cached irradiance at a pixel's points (none where no record serves a point).
fn light_at(points: &[End; 5], cache: &IrradianceCache) -> [Option<Vec3>; 5] {
    points.map(|e| e.and_then(|(p, _, n, _)| cache.lookup(p, n, Pass::B).map(|l| l.e)))
}

/// Where the camera rays through the pixels' centres (row-major) and corners (`width + 1` a row)
/// end.
struct CameraEnds {
    centres: Vec<End>,
    corners: Vec<End>,
}

/// How far, per channel and relative to its value (at least 5 % of the luminance), the cached light
/// at a pixel's points may move from what the pixel was shaded with while the pixel keeps its value
/// where it cannot be relit (its light changed unevenly beside an edge); beyond it the pixel is
/// shaded again. The records a frame gathers again near a mover reach far past it (their reach is the
/// cache's largest spacing), and their light changes there by a fraction of a percent: shading every
/// pixel they reach again would cost most of a frame's shading, and each new shade brings new pixel
/// noise (flicker). Compared with what the pixel was shaded with, not with the frame before, so a slow
/// drift does not accumulate.
const LIGHT_TOLERANCE: f32 = 0.005;

/// A pixel whose corner rays end this much nearer or farther than its centre's (relative), or on a
/// surface turned by more than this cosine, or one where some hit and some miss, is on an edge: its
/// centre does not speak for all of it, and its corners are tested too.
const EDGE_DEPTH: f32 = 0.05;
const EDGE_COS: f32 = 0.95;

/// Where a camera ray ends: the point, the world size of a pixel there, the shading normal toward
/// the eye, and the distance.
type End = Option<(Vec3, f32, Vec3, f32)>;

/// The pixels a frame may take from the frame before (the camera stayed, a mesh moved, no light
/// changed): outside the moved meshes' window, or inside it where the pixel's cone of camera rays
/// passes every moved mesh before and after its step, where its camera rays end — at its centre, and
/// on a depth edge at its corners too — on diffuse surfaces (or nothing) whose shadow rays pass no
/// moved mesh; where a changed record reaches, the pixel is relit by its cached light's change (in
/// `cache`, against what it was shaded or last relit with: `shaded`, updated here) or, where that
/// change is uneven beside an edge, kept while within [`LIGHT_TOLERANCE`] and shaded again beyond.
/// `None` where the scene has more than diffuse surfaces without media (caustic and glossy terms read
/// photon maps traced again; media scatter along every ray), or when a light changed.
pub fn unchanged_pixels(
    scene: &Scene,
    cam: &Camera,
    change: &SceneChange,
    changed: &[(Vec3, f32)],
    window: Window,
    cache: &IrradianceCache,
    shaded: &mut ShadedLight,
) -> Option<Unchanged> {
    let plain = scene.specular_bvh.is_none()
        && scene.media.is_none()
        && scene
            .materials
            .iter()
            .all(|m| matches!(m.bsdf, crate::material::Bsdf::Diffuse { .. }));
    if change.lights || !plain {
        return None;
    }
    let (w, h) = (cam.width, cam.height);
    let movers: Vec<(Vec3, f32)> = change.moved.iter().flat_map(|m| m.spheres).collect();
    let points = pixel_points(scene, cam, window, &mut shaded.rays);
    let mut keep = clear_of_movers(scene, cam, window, &movers, &points);
    let reached = reached_by(cam, changed, &points, &keep);
    if shaded.light.len() != keep.len() {
        shaded.light = vec![[None; 5]; keep.len()];
    }
    // A pixel that nothing but its cached light changed for is relit (`relight`) or, where the
    // light changed unevenly beside an edge, takes its samples again (`repeat`).
    // The light now at the points of each pixel a changed record reaches, and of those shaded
    // again (what they are shaded with).
    let now: Vec<Option<[Option<Vec3>; 5]>> = (0..keep.len())
        .into_par_iter()
        .map(|i| {
            let p = &points[i];
            ((reached[i] || !keep[i]) && p.iter().any(Option::is_some)).then(|| light_at(p, cache))
        })
        .collect();
    let decided = decide(&points, &keep, &now, &shaded.light, (w, h));
    let mut repeat = vec![false; keep.len()];
    let mut relight: Vec<Option<Vec3>> = vec![None; keep.len()];
    for (i, (k, r, l)) in decided.into_iter().enumerate() {
        keep[i] = k;
        repeat[i] = r;
        relight[i] = l;
        if let Some(n) = now[i] {
            if !k || l.is_some() {
                shaded.light[i] = n;
            }
        }
    }
    Some(Unchanged {
        keep,
        repeat,
        relight,
    })
}

/// Each pixel's fate from the light at its points `now` against what it was shaded with (`then`):
/// (kept, shaded again with the samples it took, the factor relighting its indirect light). Pixels
/// beside an edge are relit only where the light changed evenly across them.
fn decide(
    points: &[[End; 5]],
    keep: &[bool],
    now: &[Option<[Option<Vec3>; 5]>],
    then: &[[Option<Vec3>; 5]],
    (w, h): (u32, u32),
) -> Vec<(bool, bool, Option<Vec3>)> {
    let edge_near = edge_neighbours(points, w, h);
    // Per channel, the factor by which the light at pixel i's centre changed: 1 where no changed
    // record reaches, `None` where it is not known (no hit, a channel that was dark, a pixel shaded
    // again for a mover).
    let centre_ratio = |i: usize| -> Option<Vec3> {
        match &now[i] {
            _ if !keep[i] => None,
            None => Some(Vec3::ONE),
            Some(n) => n[0].zip(then[i][0]).and_then(|(a, b)| light_ratio(a, b)),
        }
    };
    (0..keep.len())
        .into_par_iter()
        .map(|i| {
            let Some(n) = now[i].as_ref().filter(|_| keep[i]) else {
                return (keep[i], false, None);
            };
            if !then[i].iter().any(Option::is_some) {
                return (false, false, None);
            }
            // Relit by every change of its light, however small (relighting costs no sample): a
            // pixel kept while its light stayed within the tolerance would change in steps of it.
            let ratio = if edge_near[i] {
                even_ratio(i, n, &then[i], w, h, &centre_ratio)
            } else {
                centre_ratio(i)
            };
            let unchanged = || {
                points[i]
                    .iter()
                    .zip(n.iter().zip(then[i].iter()))
                    .all(|(e, (now, then))| {
                        e.is_none() || matches!((now, then), (Some(a), Some(b)) if close(*a, *b))
                    })
            };
            match ratio {
                Some(r) => (true, false, (r != Vec3::ONE).then_some(r)),
                None if unchanged() => (true, false, None),
                None => (false, true, None),
            }
        })
        .collect()
}

/// The pixels that may keep their value for the movers' sake: outside `window`, or inside it where
/// the pixel's cone of camera rays passes every moved mesh (`movers`' spheres, before and after the
/// step); and in either case where no shadow ray from its `points` to a light meets one.
fn clear_of_movers(
    scene: &Scene,
    cam: &Camera,
    window: Window,
    movers: &[(Vec3, f32)],
    points: &[[End; 5]],
) -> Vec<bool> {
    let (w, h) = (cam.width, cam.height);
    let ends = shadow_ends(scene);
    // A pixel's samples leave the eye within about a pixel of its centre's ray (a pixel's angle at
    // the image's middle, more than anywhere else): in the window, a pixel keeps its value only when
    // that cone passes every moved mesh before and after its step.
    let pixel_angle = 2.0 * (cam.fov_deg().to_radians() * 0.5).tan() / h as f32;
    let far = cam.eye.distance((scene.bounds.0 + scene.bounds.1) * 0.5) + scene.diagonal();
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if x >= window.x0 && x < window.x1 && y >= window.y0 && y < window.y1 {
                let end = cam.eye + cam.ray(x as f32 + 0.5, y as f32 + 0.5) * far;
                if movers
                    .iter()
                    .any(|&(c, r)| sphere_meets_cone(c, r, cam.eye, end, far * pixel_angle))
                {
                    return false;
                }
            }
            // The pixel's samples land within about a pixel of its points: each mover is widened
            // by that.
            points[i as usize]
                .iter()
                .flatten()
                .all(|&(p, pixel, _, _)| {
                    !ends.iter().any(|end| {
                        let (c_l, r_l) = end.seen_from(p);
                        movers
                            .iter()
                            .any(|&(c, r)| sphere_meets_cone(c, r + pixel, p, c_l, r_l))
                    })
                })
        })
        .collect()
}

/// The pixels `keep` marks whose points a changed record (`changed`: centre, reach) reaches.
fn reached_by(
    cam: &Camera,
    changed: &[(Vec3, f32)],
    points: &[[End; 5]],
    keep: &[bool],
) -> Vec<bool> {
    // The changed records' pixel rectangles (around or behind the eye, a record may reach
    // anywhere), then row by row in parallel the pixels whose points one of them reaches.
    let (w, h) = (cam.width, cam.height);
    let rects: Vec<(Window, Vec3, f32)> = changed
        .iter()
        .map(|&(c, reach)| {
            let rect = sphere_pixels(cam, c, reach)
                .map_or(Window::full(w, h), |(lo, hi)| pixel_window(cam, lo, hi));
            (rect, c, reach)
        })
        .collect();
    // Each kept pixel looks for the changed records near its points in a lattice of their spheres
    // (widened by the largest pixel), and takes a record where its pixel is in the record's rectangle.
    let widest = points
        .par_iter()
        .flat_map_iter(|p| p.iter().flatten().map(|e| e.1))
        .reduce(|| 0.0, f32::max);
    let bins = SphereBins::new(rects.iter().map(|&(_, c, reach)| (c, reach + widest)));
    let mut reached = vec![false; (w * h) as usize];
    reached
        .par_chunks_mut(w as usize)
        .zip(keep.par_chunks(w as usize))
        .enumerate()
        .for_each(|(y, (row, kept))| {
            let y = y as u32;
            for x in (0..w).filter(|&x| kept[x as usize]) {
                row[x as usize] =
                    points[(y * w + x) as usize]
                        .iter()
                        .flatten()
                        .any(|&(p, pixel, _, _)| {
                            bins.any_near(p, |j| {
                                let (rect, c, reach) = &rects[j as usize];
                                rect.contains(x, y) && p.distance(*c) < reach + pixel
                            })
                        });
            }
        });
    reached
}

/// The factor by which pixel `i`'s light changed, per channel, when it changed evenly: beside an
/// edge the light changes across a pixel (records are small there, and a record's cover may end
/// inside it), and the change at its centre need not be the pixel's. It is taken when the changes
/// at its own points (`now` against `then`) and at its eight neighbours' centres (`centre_ratio`)
/// lie within four times [`LIGHT_TOLERANCE`] of each other: the mean of its own, off by at most
/// twice that tolerance; `None` otherwise.
fn even_ratio(
    i: usize,
    now: &[Option<Vec3>; 5],
    then: &[Option<Vec3>; 5],
    w: u32,
    h: u32,
    centre_ratio: &(dyn Fn(usize) -> Option<Vec3> + Sync),
) -> Option<Vec3> {
    let mut own = Vec3::ZERO;
    let mut n_own = 0;
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (a, b) in now.iter().zip(then) {
        match (a, b) {
            (Some(a), Some(b)) => {
                let r = light_ratio(*a, *b)?;
                own += r;
                n_own += 1;
                (lo, hi) = (lo.min(r), hi.max(r));
            }
            (None, None) => {}
            _ => return None,
        }
    }
    if n_own == 0 {
        return None;
    }
    let (x, y) = ((i as u32 % w) as i64, (i as u32 / w) as i64);
    for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
        let (nx, ny) = (x + dx, y + dy);
        if (dx, dy) == (0, 0) || nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
            continue;
        }
        let r = centre_ratio((ny * w as i64 + nx) as usize)?;
        (lo, hi) = (lo.min(r), hi.max(r));
    }
    (hi - lo)
        .cmple(Vec3::splat(4.0 * LIGHT_TOLERANCE) * hi.max(Vec3::splat(1e-6)))
        .all()
        .then_some(own / n_own as f32)
}

/// Whether each pixel or one of its eight neighbours lies on a depth edge (has its corners among its
/// points): next to an edge the cached light changes across a pixel (records are small there, and a
/// record's cover may end inside it), and the change at its centre is not the pixel's.
fn edge_neighbours(points: &[[End; 5]], w: u32, h: u32) -> Vec<bool> {
    let edge = |x: i64, y: i64| {
        x >= 0
            && y >= 0
            && x < w as i64
            && y < h as i64
            && points[(y * w as i64 + x) as usize][1..]
                .iter()
                .any(Option::is_some)
    };
    (0..(w * h) as i64)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w as i64, i / w as i64);
            (-1..=1).any(|dy| (-1..=1).any(|dx| edge(x + dx, y + dy)))
        })
        .collect()
}

/// Per channel, the factor `now` / `then` by which a pixel's indirect light is scaled when only its
/// cached irradiance changed; `None` where a channel was dark and is not (nothing to scale).
fn light_ratio(now: Vec3, then: Vec3) -> Option<Vec3> {
    let mut r = Vec3::ONE;
    for c in 0..3 {
        if then[c] > 0.0 {
            r[c] = now[c] / then[c];
        } else if now[c] > 0.0 {
            return None;
        }
    }
    r.is_finite().then_some(r)
}

/// Each pixel's points: where its centre's camera ray ends, then on a depth edge (see [`EDGE_DEPTH`])
/// where its corners' do (corner rays are shared between neighbouring pixels). With `rays` from the
/// frame before (same camera), only the rays through `window` — where a moved mesh may be seen,
/// before or after its step — are traced again: nothing else moved.
fn pixel_points(
    scene: &Scene,
    cam: &Camera,
    window: Window,
    rays: &mut Option<CameraEnds>,
) -> Vec<[End; 5]> {
    let (w, h) = (cam.width, cam.height);
    let end_at = |x: f32, y: f32| -> End {
        let d = cam.ray(x, y);
        scene.intersect(cam.eye, d).map(|hit| {
            let n = Frame::new(&hit, -d).n;
            (hit.p, cam.pixel_world(d, hit.t, hit.ns.dot(d)), n, hit.t)
        })
    };
    // Whether pixel (x, y), or with `rim` 1 corner (x, y), lies in the window.
    let inside = |x: u32, y: u32, rim: u32| {
        x >= window.x0 && x < window.x1 + rim && y >= window.y0 && y < window.y1 + rim
    };
    let fresh = rays
        .as_ref()
        .is_none_or(|r| r.centres.len() != (w * h) as usize);
    let ends = rays.get_or_insert_with(|| CameraEnds {
        centres: Vec::new(),
        corners: Vec::new(),
    });
    if fresh {
        ends.centres = vec![None; (w * h) as usize];
        ends.corners = vec![None; ((w + 1) * (h + 1)) as usize];
    }
    ends.centres.par_iter_mut().enumerate().for_each(|(i, e)| {
        let (x, y) = (i as u32 % w, i as u32 / w);
        if fresh || inside(x, y, 0) {
            *e = end_at(x as f32 + 0.5, y as f32 + 0.5);
        }
    });
    ends.corners.par_iter_mut().enumerate().for_each(|(i, e)| {
        let (x, y) = (i as u32 % (w + 1), i as u32 / (w + 1));
        if fresh || inside(x, y, 1) {
            *e = end_at(x as f32, y as f32);
        }
    });
    let (centres, corners) = (&ends.centres, &ends.corners);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = centres[i as usize];
            let at = |dx: u32, dy: u32| corners[((y + dy) * (w + 1) + x + dx) as usize];
            let k = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
            let edge = k.iter().any(|e| match (c, e) {
                (Some((_, _, n0, t0)), Some((_, _, n, t))) => {
                    (t - t0).abs() > EDGE_DEPTH * t0 || n.dot(n0) < EDGE_COS
                }
                (None, None) => false,
                _ => true,
            });
            if edge {
                [c, k[0], k[1], k[2], k[3]]
            } else {
                [c, None, None, None, None]
            }
        })
        .collect()
}

/// Whether two irradiances agree within [`LIGHT_TOLERANCE`] in every channel.
fn close(a: Vec3, b: Vec3) -> bool {
    let floor = 0.05 * luminance(a).max(luminance(b));
    (0..3).all(|c| (a[c] - b[c]).abs() <= LIGHT_TOLERANCE * a[c].max(b[c]).max(floor))
}

/// The pixels a frame keeps, and those it shades again with the samples they took.
pub struct Unchanged {
    pub keep: Vec<bool>,
    pub repeat: Vec<bool>,
    /// Kept pixels whose indirect light is scaled by this, per channel: on no edge (one camera-ray
    /// end speaks for the pixel), nothing but the cached irradiance there changed, and the pixel's
    /// indirect layer is its samples' albedo times that irradiance, which varies slowly across it:
    /// the ratio at its centre relights it without a sample, and without new pixel noise.
    pub relight: Vec<Option<Vec3>>,
}

/// Where a light's shadow rays from a point end.
#[derive(Clone, Copy)]
pub(super) enum ShadowEnd {
    /// A ball every shadow ray ends in (centre, radius): all emissive triangles as one, a point or
    /// spot light.
    Ball(Vec3, f32),
    /// Far along a directional light's reverse direction from the point itself: its shadow rays are
    /// parallel (this offset).
    Along(Vec3),
}

impl ShadowEnd {
    /// The ball the shadow rays from `p` end in.
    pub(super) fn seen_from(self, p: Vec3) -> (Vec3, f32) {
        match self {
            ShadowEnd::Ball(c, r) => (c, r),
            ShadowEnd::Along(offset) => (p + offset, 0.0),
        }
    }
}

/// Where the lights' shadow rays end.
pub(super) fn shadow_ends(scene: &Scene) -> Vec<ShadowEnd> {
    let mut out = Vec::new();
    let (lo, hi) = scene.bounds;
    let far = (hi - lo).length() * 4.0 + 1.0;
    let mut area: Option<(Vec3, Vec3)> = None;
    for l in &scene.lights.lights {
        match *l {
            crate::light::Light::Area { tri, .. } => {
                for k in scene.geometry.triangles[tri as usize].v {
                    let p = scene.geometry.positions[k as usize];
                    area = Some(area.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
                }
            }
            crate::light::Light::Point { pos, .. } | crate::light::Light::Spot { pos, .. } => {
                out.push(ShadowEnd::Ball(pos, 0.0))
            }
            crate::light::Light::Directional { dir, .. } => out.push(ShadowEnd::Along(-dir * far)),
        }
    }
    if let Some((a, b)) = area {
        out.push(ShadowEnd::Ball((a + b) * 0.5, (b - a).length() * 0.5));
    }
    out
}

/// Whether the sphere (c, r) meets the cone from apex `p` to the ball (c_l, r_l): the rays from a
/// point to a light's ball (shadow rays), or a pixel's camera rays. The cone's cross-section at
/// t ∈ [0, 1] is the ball (p + t (c_l − p), t r_l): narrow at `p`, as wide as the ball at its end (a
/// mover near the floor and a light at the ceiling shade only the floor points whose narrow end of the
/// cone it crosses). The sphere meets it when g(t) = |c − p − t d| − t r_l falls below r for some t; g
/// is convex, its minimum found in closed form.
pub(super) fn sphere_meets_cone(c: Vec3, r: f32, p: Vec3, c_l: Vec3, r_l: f32) -> bool {
    let d = c_l - p;
    let len = d.length();
    if !(len > 0.0) {
        return c.distance(p) < r + r_l;
    }
    let w = c - p;
    let along = w.dot(d) / len;
    let across = (w.length_squared() - along * along).max(0.0).sqrt();
    let k = r_l / len;
    // g'(t) = 0 where (along − t len) = −k across / √(1 − k²); past k ≥ 1 g only falls.
    let t = if k >= 1.0 {
        1.0
    } else {
        ((along + k * across / (1.0 - k * k).sqrt()) / len).clamp(0.0, 1.0)
    };
    w.distance(d * t) - t * r_l < r
}

/// Spheres binned in a uniform lattice over their bounds, each in every cell its bounding box meets:
/// the spheres that may hold a point are those of its cell.
struct SphereBins {
    lo: Vec3,
    cell: f32,
    dims: [usize; 3],
    /// Per cell, its spheres' slice of `ids` (`start[c]..start[c + 1]`).
    start: Vec<u32>,
    ids: Vec<u32>,
}

/// Cells of a [`SphereBins`] lattice, at most.
const MAX_BIN_CELLS: f32 = 32_768.0;

impl SphereBins {
    fn new(spheres: impl Iterator<Item = (Vec3, f32)>) -> SphereBins {
        let spheres: Vec<(Vec3, f32)> = spheres
            .filter(|(c, r)| c.is_finite() && r.is_finite())
            .collect();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &(c, r) in &spheres {
            lo = lo.min(c - r);
            hi = hi.max(c + r);
        }
        let extent = (hi - lo).max(Vec3::splat(1e-6));
        // Cells about the mean sphere's diameter, fewer than MAX_BIN_CELLS.
        let mean = spheres.iter().map(|s| 2.0 * s.1).sum::<f32>() / spheres.len().max(1) as f32;
        let cell = mean
            .max((extent.x * extent.y * extent.z / MAX_BIN_CELLS).cbrt())
            .max(1e-6);
        let dims = (extent / cell).ceil().max(Vec3::ONE).as_uvec3();
        let dims = [dims.x as usize, dims.y as usize, dims.z as usize];
        let cell_of = |p: Vec3| {
            let c = ((p - lo) / cell).floor().max(Vec3::ZERO).as_uvec3();
            [
                (c.x as usize).min(dims[0] - 1),
                (c.y as usize).min(dims[1] - 1),
                (c.z as usize).min(dims[2] - 1),
            ]
        };
        let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let mut per_cell: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        for (id, &(c, r)) in spheres.iter().enumerate() {
            let (a, b) = (cell_of(c - r), cell_of(c + r));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        per_cell[index([x, y, z])].push(id as u32);
                    }
                }
            }
        }
        let mut start = Vec::with_capacity(per_cell.len() + 1);
        let mut ids = Vec::new();
        for c in per_cell {
            start.push(ids.len() as u32);
            ids.extend(c);
        }
        start.push(ids.len() as u32);
        SphereBins {
            lo,
            cell,
            dims,
            start,
            ids,
        }
    }

    /// Whether `test` holds for one of the spheres whose bounding box may hold `p`.
    fn any_near(&self, p: Vec3, mut test: impl FnMut(u32) -> bool) -> bool {
        let f = (p - self.lo) / self.cell;
        let top = Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        );
        if !(f.cmpge(Vec3::ZERO).all() && f.cmple(top).all()) {
            return false;
        }
        let c = f.min(top - 1.0).as_uvec3();
        let i = (c.z as usize * self.dims[1] + c.y as usize) * self.dims[0] + c.x as usize;
        self.ids[self.start[i] as usize..self.start[i + 1] as usize]
            .iter()
            .any(|&id| test(id))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// An edge pixel (centre and four corners) in a 3×3 image is relit by the mean change at its
    /// points when its own and its neighbours' changes agree within four times the tolerance, and shaded
    /// again when one neighbour's light changed by more, or is not known.
    #[test]
    fn an_edge_pixel_is_relit_only_where_the_light_changed_evenly() {
        let then = [Some(Vec3::ONE); 5];
        let now = [1.006, 1.004, 1.008, 1.005, 1.007].map(|r| Some(Vec3::splat(r)));
        let around = |bad: Option<f32>| {
            move |i: usize| match (i, bad) {
                (0, Some(r)) => (r > 0.0).then_some(Vec3::splat(r)),
                _ => Some(Vec3::splat(1.003)),
            }
        };
        let r = even_ratio(4, &now, &then, 3, 3, &around(None)).expect("an even change");
        assert!((r - Vec3::splat(1.006)).abs().max_element() < 1e-6, "{r}");
        assert!(even_ratio(4, &now, &then, 3, 3, &around(Some(1.03))).is_none());
        assert!(even_ratio(4, &now, &then, 3, 3, &around(Some(-1.0))).is_none());
        // A point that was dark and is lit now has no ratio: shaded again.
        let mut lit = now;
        lit[1] = Some(Vec3::new(0.1, 1.0, 1.0));
        let dark = [Some(Vec3::new(0.0, 1.0, 1.0)); 5];
        assert!(even_ratio(4, &lit, &dark, 3, 3, &around(None)).is_none());
    }

    /// The window of a whole sequence holds each step's window, found from the meshes of the frames'
    /// own scenes (a ball crossing a box under a fixed camera, turning as it goes here).
    #[test]
    fn a_sequence_window_holds_every_step_window() {
        let dir = std::env::temp_dir().join(format!("pm-seqwin-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(root.join("scenes/anim-ball.toml"))
            .unwrap()
            .replace("models/", &format!("{}/scenes/models/", root.display()))
            .replace("frames = 48", "frames = 12")
            .replace(
                "frame = 0\ntranslate",
                "frame = 0\nrotate = [0.0, 0.0, 0.0]\ntranslate",
            )
            .replace("frame = 47", "frame = 11\nrotate = [0.0, 90.0, 30.0]");
        let path = dir.join("ball.toml");
        std::fs::write(&path, text).unwrap();
        let anim = crate::scene::load_animation(&path).unwrap().unwrap();
        let first = crate::scene::load_frame(&anim, 0).unwrap();
        let no = crate::render::NoProgress;
        let (cam, all) = sequence_window(
            &anim,
            &first,
            0..=11,
            (64, 48),
            &no,
            &AtomicBool::new(false),
        )
        .unwrap()
        .expect("the ball moves");
        let mut before = first;
        for f in 1..=11 {
            let now = crate::scene::load_frame(&anim, f).unwrap();
            let moved = anim
                .moved_meshes(f - 1, f)
                .into_iter()
                .map(|m| {
                    let (a, b) = (before.mesh_sphere(m).unwrap(), now.mesh_sphere(m).unwrap());
                    Moved::new(a, b, None)
                })
                .collect();
            let change = SceneChange {
                moved,
                ..Default::default()
            };
            let w = screen_window(&change, &cam).unwrap();
            assert_eq!(all.union(w), all, "frame {f}: {w:?} not within {all:?}");
            before = now;
        }
        assert!(all.n_pixels() < 64 * 48, "{all:?}: the whole image");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The bins find every sphere holding a point, for spheres of mixed sizes (one spanning all).
    #[test]
    fn sphere_bins_find_what_a_search_of_every_sphere_finds() {
        let mut rng = photon::sampling::Rng::new(11);
        let mut v = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let mut spheres: Vec<(Vec3, f32)> =
            (0..300).map(|_| (v() * 4.0, 0.05 + v().x * 0.3)).collect();
        spheres.push((Vec3::splat(2.0), 5.0));
        let bins = SphereBins::new(spheres.iter().copied());
        for _ in 0..20_000 {
            let p = v() * 5.0 - 0.5;
            let mut found = Vec::new();
            bins.any_near(p, |j| {
                found.push(j);
                false
            });
            for (j, &(c, r)) in spheres.iter().enumerate() {
                if p.distance(c) < r {
                    assert!(
                        found.contains(&(j as u32)),
                        "sphere {j} holds {p} but was not found"
                    );
                }
            }
        }
    }

    #[test]
    fn a_pixel_is_relit_by_each_channel_s_change_unless_a_dark_channel_lit_up() {
        let r = light_ratio(Vec3::new(1.0, 0.5, 0.0), Vec3::new(2.0, 0.5, 0.0)).unwrap();
        assert_eq!(r, Vec3::new(0.5, 1.0, 1.0));
        assert_eq!(
            light_ratio(Vec3::new(1.0, 0.1, 1.0), Vec3::new(1.0, 0.0, 1.0)),
            None
        );
    }

    #[test]
    fn a_sphere_meets_a_cone_where_a_dense_search_says_so() {
        let mut rng = photon::sampling::Rng::new(7);
        let mut v = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0 - 2.0;
        let (mut met, mut missed) = (0, 0);
        for _ in 0..4000 {
            let (c, p, c_l) = (v(), v(), v());
            let (r, r_l) = (0.05 + 0.3 * v().x.abs(), 0.6 * v().y.abs());
            // The cone's balls at 20 001 steps of t, the sphere's distance to each.
            let dense = (0..=20_000).any(|i| {
                let t = i as f32 / 20_000.0;
                c.distance(p + (c_l - p) * t) < r + t * r_l - 1e-4
            });
            let near_edge = (0..=20_000).any(|i| {
                let t = i as f32 / 20_000.0;
                (c.distance(p + (c_l - p) * t) - r - t * r_l).abs() < 2e-3
            });
            let fast = sphere_meets_cone(c, r, p, c_l, r_l);
            if !near_edge {
                assert_eq!(fast, dense, "c {c} r {r} p {p} light {c_l} {r_l}");
            }
            if fast {
                met += 1;
            } else {
                missed += 1;
            }
        }
        assert!(met > 200 && missed > 200, "{met} {missed}");
    }
}
