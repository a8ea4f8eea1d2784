//! Pass A of the cached final gather: the shading points of each pixel (the first non-specular surface,
//! also through mirror and glass chains), each with the hit found there, and the final gather from that
//! hit that creates a record.

use glam::Vec3;
use icache::{NewRecord, ShadingPoint};

use super::pm::PmContext;
use crate::camera::Camera;
use crate::counters::SampleCounters;
use crate::geometry::Frame;
use crate::geometry::{spawn, Hit};
use crate::material::Bsdf;

/// Depth of the mirror/glass tree followed from each pixel (both branches at glass).
const MAX_SPECULAR_DEPTH: u32 = 4;

/// The non-specular points seen through pixel (x, y) that need soft indirect light: those through its
/// centre, and those through its top-left corner that the centre does not see (another surface, an edge,
/// a depth step). Pass B samples the whole pixel; with the centre alone, every surface smaller than a
/// pixel or cut by a pixel's edge became a pass-B miss.
pub fn shading_hits(ctx: &PmContext, camera: &Camera, x: u32, y: u32) -> Vec<(ShadingPoint, Hit)> {
    let mut out = Vec::new();
    let [sx, sy] = ctx.pass_a_shift;
    let d = camera.ray(x as f32 + (0.5 + sx).fract(), y as f32 + (0.5 + sy).fract());
    follow(ctx, camera, d, camera.eye, d, 0.0, 0, &mut out);
    let n_centre = out.len();
    let d = camera.ray(x as f32 + sx, y as f32 + sy);
    follow(ctx, camera, d, camera.eye, d, 0.0, 0, &mut out);
    let mut i = n_centre;
    while i < out.len() {
        if out[..n_centre]
            .iter()
            .any(|(c, _)| same_surface(c, &out[i].0))
        {
            out.remove(i);
        } else {
            i += 1;
        }
    }
    out
}

/// The non-specular points seen through pixel (x, y) at the given offsets within it (samples of pass B
/// that found no record). Not merged: the fill looks each up before its gather, and a point merged into
/// a neighbour half a pixel away was left uncovered as often as not (more misses left, for few records
/// saved).
pub fn sample_hits(
    ctx: &PmContext,
    camera: &Camera,
    x: u32,
    y: u32,
    offsets: &[[f32; 2]],
) -> Vec<(ShadingPoint, Hit)> {
    let mut out = Vec::new();
    for off in offsets {
        let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
        follow(ctx, camera, d, camera.eye, d, 0.0, 0, &mut out);
    }
    out
}

/// Half a pixel apart on one smooth surface: the centre's record will cover the corner.
pub(crate) fn same_surface(a: &ShadingPoint, b: &ShadingPoint) -> bool {
    a.normal.dot(b.normal) > 0.95
        && (a.pos - b.pos).dot(a.normal).abs() < a.pixel_world
        && (a.pos - b.pos).length() < 2.0 * a.pixel_world
}

#[allow(clippy::too_many_arguments)]
fn follow(
    ctx: &PmContext,
    camera: &Camera,
    d0: Vec3,
    o: Vec3,
    d: Vec3,
    dist: f32,
    depth: u32,
    out: &mut Vec<(ShadingPoint, Hit)>,
) {
    let Some(hit) = ctx.scene.intersect_visible(o, d) else {
        return;
    };
    // Mirror and glass chains follow the bumped normal, as pass B's rays do; the shading point takes
    // the smooth one (records are placed and spaced by it).
    let frame = ctx.scene.frame(&hit, -d);
    let bsdf = &ctx.scene.material(&hit).bsdf;
    let dist = dist + hit.t;
    match *bsdf {
        Bsdf::Mirror { .. } | Bsdf::Glass { .. } => {
            if depth >= MAX_SPECULAR_DEPTH {
                return;
            }
            // Both branches of glass (u below / above any Fresnel value).
            for u in [0.0f32, 0.999_999] {
                if let Some(s) = bsdf.sample(
                    Vec3::ZERO,
                    frame.n,
                    -d,
                    frame.front,
                    [0.5, 0.5, u],
                    crate::material::Transport::Radiance,
                ) {
                    follow(
                        ctx,
                        camera,
                        d0,
                        spawn(&hit, s.wi),
                        s.wi,
                        dist,
                        depth + 1,
                        out,
                    );
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
            let cos = frame.smooth.dot(-d);
            let pixel_world = camera.pixel_world(d0, dist, cos);
            out.push((
                ShadingPoint {
                    pos: hit.p,
                    normal: frame.smooth,
                    pixel_world,
                },
                hit,
            ));
        }
    }
}

/// The final gather at shading point `i` of pixel (x, y), from the hit [`shading_hits`] traced there, as
/// a record for the cache, with the gather's rays counted.
pub fn gather_record(
    ctx: &PmContext,
    x: u32,
    y: u32,
    i: usize,
    sp: &ShadingPoint,
    hit: &Hit,
) -> (NewRecord, SampleCounters) {
    gather_record_round(ctx, x, y, i, 0, sp, hit)
}

/// [`gather_record`]'s gather again, with the jitter of round `round` (0: the first gather's).
pub fn gather_record_round(
    ctx: &PmContext,
    x: u32,
    y: u32,
    i: usize,
    round: u32,
    sp: &ShadingPoint,
    hit: &Hit,
) -> (NewRecord, SampleCounters) {
    let mut counters = SampleCounters::default();
    let frame = Frame::new(hit, sp.normal);
    // The render's seed too: another seed must give another set of gathers (and so an independent
    // estimate: convergence tests over seeds), not the same strata jitter at every pixel.
    let seed = photon::sampling::hash_keys(&[ctx.seed, x as u64, y as u64, i as u64]);
    // A first gather on a glossy surface the radiance cache serves also keeps its light's harmonics.
    let order = ctx
        .radiance
        .filter(|_| round == 0)
        .and_then(|r| r.order(hit.material));
    let mut coefficients = Vec::new();
    let g = ctx.gather_projected(
        hit,
        &frame,
        seed,
        round,
        order.map(|o| (o, &mut coefficients)),
        &mut counters,
    );
    if let (Some(r), Some(_)) = (ctx.radiance, order) {
        r.keep(sp.pos, coefficients);
    }
    (new_record(&g, sp, [x, y, i as u32]), counters)
}

/// The record a gather at shading point `sp` makes (`at`: its pixel and point index).
pub(crate) fn new_record(g: &gather::GatherResult, sp: &ShadingPoint, at: [u32; 3]) -> NewRecord {
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
        rel_err: g.rel_err,
        at,
    }
}
