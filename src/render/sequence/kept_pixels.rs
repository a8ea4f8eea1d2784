//! Which pixels of a sequence's frame must be rendered again when the camera stayed and meshes moved:
//! the window where the moved meshes may be seen (pass A visits only it, at a finer noise target),
//! outside what their moves changed the pixels kept from the frame before unsampled, and among the
//! rest those whose cached light alone changed, shaded again with the very samples they took.

use glam::Vec3;
use rayon::prelude::*;

use icache::{IrradianceCache, Pass};

use pmbase::luminance;

pub(super) use super::cones::*;
use super::pixel_ends::*;
pub(super) use super::screen::*;
use super::temporal::SceneChange;
use crate::camera::Camera;
use crate::render::tiles::Window;
use crate::scene::Scene;

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

/// How far, per channel and relative to its value (at least 5 % of the luminance), the cached light
/// at a pixel's points may move from what the pixel was shaded with while the pixel keeps its value
/// where it cannot be relit (its light changed unevenly beside an edge); beyond it the pixel is
/// shaded again. The records a frame gathers again near a mover reach far past it (their reach is the
/// cache's largest spacing), and their light changes there by a fraction of a percent: shading every
/// pixel they reach again would cost most of a frame's shading, and each new shade brings new pixel
/// noise (flicker). Compared with what the pixel was shaded with, not with the frame before, so a slow
/// drift does not accumulate.
const LIGHT_TOLERANCE: f32 = 0.005;

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::sequence::temporal::Moved;
    use std::path::Path;
    use std::sync::atomic::AtomicBool;

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
