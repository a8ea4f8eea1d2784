//! Pass A of the cached final gather: the shading points of each pixel (the first non-specular surface,
//! also through mirror and glass chains) and the final gather that creates a record there.

use glam::Vec3;
use icache::{NewRecord, ShadingPoint};

use super::pm::PmContext;
use super::{Frame, SampleCounters};
use crate::camera::Camera;
use crate::geometry::{spawn, Hit};
use crate::material::Bsdf;

/// Depth of the mirror/glass tree followed from each pixel (both branches at glass).
const MAX_SPECULAR_DEPTH: u32 = 4;

/// The non-specular points seen through pixel (x, y) that need soft indirect light: those through its
/// centre, and those through its top-left corner that the centre does not see (another surface, an edge,
/// a depth step). Pass B samples the whole pixel; with the centre alone, every surface smaller than a
/// pixel or cut by a pixel's edge became a pass-B miss (1 % of Sibenik's lookups at 250²).
pub fn shading_hits(ctx: &PmContext, camera: &Camera, x: u32, y: u32) -> Vec<(ShadingPoint, Hit)> {
    let mut out = Vec::new();
    let d = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    follow(ctx, camera, d, camera.eye, d, 0.0, 0, &mut out);
    let n_centre = out.len();
    let d = camera.ray(x as f32, y as f32);
    follow(ctx, camera, d, camera.eye, d, 0.0, 0, &mut out);
    let mut i = n_centre;
    while i < out.len() {
        if out[..n_centre].iter().any(|(c, _)| same_surface(c, &out[i].0)) {
            out.remove(i);
        } else {
            i += 1;
        }
    }
    out
}

/// Half a pixel apart on one smooth surface: the centre's record will cover the corner.
fn same_surface(a: &ShadingPoint, b: &ShadingPoint) -> bool {
    a.normal.dot(b.normal) > 0.95 && (a.pos - b.pos).dot(a.normal).abs() < a.pixel_world && (a.pos - b.pos).length() < 2.0 * a.pixel_world
}

#[allow(clippy::too_many_arguments)]
fn follow(ctx: &PmContext, camera: &Camera, d0: Vec3, o: Vec3, d: Vec3, dist: f32, depth: u32, out: &mut Vec<(ShadingPoint, Hit)>) {
    let Some(hit) = ctx.scene.intersect(o, d) else { return };
    let frame = Frame::new(&hit, -d);
    let bsdf = &ctx.scene.material(&hit).bsdf;
    let dist = dist + hit.t;
    match *bsdf {
        Bsdf::Mirror { .. } | Bsdf::Glass { .. } => {
            if depth >= MAX_SPECULAR_DEPTH {
                return;
            }
            // Both branches of glass (u below / above any Fresnel value).
            for u in [0.0f32, 0.999_999] {
                if let Some(s) = bsdf.sample(Vec3::ZERO, frame.n, -d, frame.front, [0.5, 0.5, u], crate::material::Transport::Radiance) {
                    follow(ctx, camera, d0, spawn(&hit, s.wi), s.wi, dist, depth + 1, out);
                }
                if matches!(bsdf, Bsdf::Mirror { .. }) {
                    break;
                }
            }
        }
        _ => {
            if bsdf.diffuse_albedo(ctx.scene.albedo(&hit)) == Vec3::ZERO {
                return;
            }
            let cos = frame.n.dot(-d);
            let pixel_world = camera.pixel_world(d0, dist, cos);
            out.push((ShadingPoint { pos: hit.p, normal: frame.n, pixel_world }, hit));
        }
    }
}

/// The final gather for shading point `i` of pixel (x, y), as a record for the cache.
pub fn gather_record(ctx: &PmContext, camera: &Camera, x: u32, y: u32, i: usize, sp: &ShadingPoint, counters: &mut SampleCounters) -> NewRecord {
    let hits = shading_hits(ctx, camera, x, y);
    let (hit, frame) = match hits.get(i) {
        Some((_, h)) => (*h, Frame::new(h, sp.normal)),
        None => unreachable_point(sp),
    };
    let seed = photon::sampling::hash_keys(&[x as u64, y as u64, i as u64]);
    let g = ctx.final_gather(&hit, &frame, seed, counters);
    NewRecord {
        pos: sp.pos,
        normal: sp.normal,
        e: g.e,
        grad_r: g.grad_r,
        grad_t: g.grad_t,
        r_harmonic: g.r_harmonic,
        r_min: g.r_min,
        dir: g.dir,
        pixel_world: sp.pixel_world,
    }
}

/// Shading points are recomputed deterministically, so index `i` always exists; this keeps the code
/// total if that ever changes (a hit at the point itself, facing its normal).
fn unreachable_point(sp: &ShadingPoint) -> (Hit, Frame) {
    let hit = Hit { p: sp.pos, t: 0.0, ng: sp.normal, ns: sp.normal, uv: glam::Vec2::ZERO, tri: 0, material: 0 };
    (hit, Frame { n: sp.normal, ng: sp.normal, front: true })
}
