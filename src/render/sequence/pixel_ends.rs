//! Where each pixel's camera rays end (its centre, and its corners on an edge), kept while the camera
//! stays, and which pixels lie beside an edge.

use glam::Vec3;
use rayon::prelude::*;

use crate::camera::Camera;
use crate::geometry::Frame;
use crate::render::tiles::Window;
use crate::scene::Scene;

/// Where the camera rays through the pixels' centres (row-major) and corners (`width + 1` a row)
/// end.
pub(super) struct CameraEnds {
    pub(super) centres: Vec<End>,
    pub(super) corners: Vec<End>,
}

/// A pixel whose corner rays end this much nearer or farther than its centre's (relative), or on a
/// surface turned by more than this cosine, or one where some hit and some miss, is on an edge: its
/// centre does not speak for all of it, and its corners are tested too.
pub(super) const EDGE_DEPTH: f32 = 0.05;
pub(super) const EDGE_COS: f32 = 0.95;

/// Where a camera ray ends: the point, the world size of a pixel there, the shading normal toward
/// the eye, and the distance.
pub(super) type End = Option<(Vec3, f32, Vec3, f32)>;

/// Whether each pixel or one of its eight neighbours lies on a depth edge (has its corners among its
/// points): next to an edge the cached light changes across a pixel (records are small there, and a
/// record's cover may end inside it), and the change at its centre is not the pixel's.
pub(super) fn edge_neighbours(points: &[[End; 5]], w: u32, h: u32) -> Vec<bool> {
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

/// Each pixel's points: where its centre's camera ray ends, then on a depth edge (see [`EDGE_DEPTH`])
/// where its corners' do (corner rays are shared between neighbouring pixels). With `rays` from the
/// frame before (same camera), only the rays through `window` — where a moved mesh may be seen,
/// before or after its step — are traced again: nothing else moved.
pub(super) fn pixel_points(
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
