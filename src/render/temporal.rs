//! Temporal irradiance caching (after Gautron, Bouatouch & Pattanaik 2007) for the frames of a
//! sequence where a mesh or a light changed: the records of the frame before stay where they are, so
//! that the image does not pop, and each one is re-gathered only when it must be.
//!
//! - A record whose surface is gone lay on a mesh that moved: it moves with that mesh's step (its
//!   gradients and direction turned with it) and is then treated like any other record — the light
//!   around a moving object changes at the rate its gathers measure, like that of a still one. One
//!   that lands on no surface is dropped; pass A makes new records where the frame needs them.
//! - A record is re-gathered at its own place, with its own jitter, when its lifespan is over, when a
//!   light changed, when geometry that moved (or turned: a mesh's step is how far any of its points
//!   went) comes near enough to take a noticeable part of its hemisphere, or when it sees light that
//!   changed far from it — a mover that blocks a spot or turns a mirror moves light across the room:
//!   the photon power deposited per cell of a lattice is compared with the frame before's. On a
//!   glossy surface the tolerance is the lobe's: (n + 2) / 2 times finer. Its temporal gradient
//!   ∂E/∂t is the change since its last gather per frame, and its
//!   next lifespan the frames that change takes to reach [`TOLERANCE`] of its irradiance (at most
//!   [`MAX_LIFESPAN`]). A new record on a moving mesh is due the next frame (its rate is not known
//!   yet); one elsewhere, where only the photons that meet a moved mesh change its light, after
//!   [`MAX_LIFESPAN`].
//! - A record due only because its lifespan ended, whose gather differs from its own in no channel
//!   by more than twice the gathers' own noise (or a quarter of [`TOLERANCE`]), stays as it was, due
//!   again after twice its last quiet lifespan (from [`MAX_LIFESPAN`] up to [`MAX_QUIET_LIFESPAN`]):
//!   where nothing happened the image stays the same, and records far from what moves are seldom
//!   gathered. After a light changed (a `[[light]]`'s values, or a mesh that emits moved), and where
//!   a record was due for a known reason (a mover near, light that changed in sight), it takes its
//!   new gather.
//! - Between gathers a record's irradiance follows its temporal gradient.
//!
//! Frames where only the camera moves keep every record of earlier frames that is fine enough for the
//! new view ([`Lifespans::for_view`]); records out of view for [`UNSEEN_FRAMES`] frames are deleted.
//!
//! Re-gathering with the record's own jitter rather than by reprojection: our gathers read photon
//! maps traced with the same photon sequence every frame, so the same gather differs between frames
//! only where the light did, and the rate measured is the light's, not noise.

use std::collections::HashMap;

use glam::{Mat3, Mat4, Vec2, Vec3};
use icache::{IrradianceCache, NewRecord, Record, ShadingPoint};
use rayon::prelude::*;

use super::tiles::Window;
use super::FrameStats;
use crate::camera::Camera;
use crate::error::{runtime, Result};
use crate::geometry::Hit;
use crate::integrator::cache_fill::gather_record;
use crate::integrator::pm::PmContext;
use crate::scene::Scene;

/// Relative change of its irradiance a record may build up before it is gathered again.
const TOLERANCE: f32 = 0.02;
/// Most frames between two gathers of a record whose light changed at its last gather (Gautron's
/// δt_max), and the first lifespan of a new record no moved mesh is near.
const MAX_LIFESPAN: u32 = 8;
/// Most frames between two gathers of a record whose light did not change: each gather that finds
/// no change doubles its lifespan, up to this. Where nothing moves near a record, its light changes
/// only through the photons that meet the moved meshes; a moved mesh that comes near makes it due
/// at once ([`near`]).
const MAX_QUIET_LIFESPAN: u32 = 32;
/// The noise target where something moved, as a fraction of the frame's: a pixel's Monte Carlo noise
/// there differs from frame to frame (its samples meet other things), and is seen as flicker.
pub const MOVING_NOISE: f32 = 0.5;

/// What changed since the frame before: every moved mesh, and whether a light changed.
#[derive(Clone, Debug, Default)]
pub struct SceneChange {
    pub moved: Vec<Moved>,
    /// Each moved mesh's bounding sphere before its step, and the step (new placement × old⁻¹): the
    /// records on it move with it.
    pub rigid: Vec<((Vec3, f32), Mat4)>,
    pub lights: bool,
}

/// A mesh that moved: its bounding sphere (centre, radius) before and after, and how far any of its
/// points moved (a mesh turning about its centre keeps its sphere but moves its points).
#[derive(Clone, Copy, Debug)]
pub struct Moved {
    pub spheres: [(Vec3, f32); 2],
    pub step: f32,
}

impl Moved {
    /// A mesh whose bounding sphere went from `before` to `after`, by the placement step `step` (new
    /// placement × old⁻¹) when known: its points within `before` move at most |step(c) − c| plus the
    /// radius times the norm of step's linear part less the identity (Frobenius, an upper bound).
    pub fn new(before: (Vec3, f32), after: (Vec3, f32), step: Option<Mat4>) -> Moved {
        let spheres_apart = before.0.distance(after.0) + (before.1 - after.1).abs();
        let points = step.map_or(0.0, |t| {
            let turn = Mat3::from_mat4(t) - Mat3::IDENTITY;
            let norm = (turn.x_axis.length_squared()
                + turn.y_axis.length_squared()
                + turn.z_axis.length_squared())
            .sqrt();
            t.transform_point3(before.0).distance(before.0) + norm * before.1
        });
        Moved {
            spheres: [before, after],
            step: spheres_apart.max(points),
        }
    }
}

/// A moved mesh as a bounding sphere: where it is, how large, how far it moved.
#[derive(Clone, Copy)]
struct Mover {
    center: Vec3,
    radius: f32,
    step: f32,
}

/// A record's life: when it was last gathered, to what, how fast it changes, when it is due again.
#[derive(Clone, Copy, Debug)]
struct Life {
    made: u32,
    due: u32,
    e: Vec3,
    de_dt: Vec3,
    /// Frames between its last two gathers that found no change (0: its last gather found one,
    /// or it has had none).
    quiet: u32,
    /// Whether it has been gathered again since it was made (its rate of change is known).
    measured: bool,
}

/// The lives of the records of a sequence's cache, by their position's bits: when each is due for a
/// gather, and since which frame it has been out of view.
#[derive(Default)]
pub struct Lifespans {
    by_pos: HashMap<[u32; 3], Life>,
    unseen_since: HashMap<[u32; 3], u32>,
    /// The photon power the last traced maps deposited, per cell.
    deposits: Option<Deposits>,
}

/// Photon power the global map deposited on surfaces, summed over the cells of a lattice fixed for
/// the sequence (photons outside it count in its border cells). Where it changed between two frames
/// the light changed there — a mover blocked a light or turned a mirror — and with it the indirect
/// light of every record that sees the place, however far from the mover ([`Lifespans::update`]).
struct Deposits {
    lo: Vec3,
    cell: f32,
    dims: [usize; 3],
    power: Vec<Vec3>,
    /// The mean photon's power: a cell whose power changed by less than [`NOISE_PHOTONS`] of it
    /// changed by the few paths a mover deflected there.
    photon: Vec3,
}

/// Cells along the deposit lattice's longest side.
const DEPOSIT_CELLS: f32 = 32.0;
/// Photons' worth of power a cell's change must exceed to count (see [`Deposits::photon`]).
const NOISE_PHOTONS: f32 = 4.0;

impl Deposits {
    /// The deposits of `photons` on the lattice of `like` (or a new one over `bounds`).
    fn of(
        photons: &[photon::map::Photon],
        bounds: (Vec3, Vec3),
        like: Option<&Deposits>,
    ) -> Deposits {
        let (lo, cell, dims) = match like {
            Some(d) => (d.lo, d.cell, d.dims),
            None => {
                let size = (bounds.1 - bounds.0).max(Vec3::splat(1e-6));
                let cell = size.max_element() / DEPOSIT_CELLS;
                let dims = (size / cell).ceil().as_uvec3().max(glam::UVec3::ONE);
                (
                    bounds.0,
                    cell,
                    [dims.x as usize, dims.y as usize, dims.z as usize],
                )
            }
        };
        let mut power = vec![Vec3::ZERO; dims[0] * dims[1] * dims[2]];
        let mut total = Vec3::ZERO;
        for ph in photons {
            let c = ((ph.pos - lo) / cell).floor();
            if !c.is_finite() {
                continue;
            }
            let at = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
            let (x, y, z) = (at(c.x, dims[0]), at(c.y, dims[1]), at(c.z, dims[2]));
            power[(z * dims[1] + y) * dims[0] + x] += ph.power;
            total += ph.power;
        }
        Deposits {
            lo,
            cell,
            dims,
            power,
            photon: total / photons.len().max(1) as f32,
        }
    }

    /// The cells whose deposited power changed since `before` by more than [`NOISE_PHOTONS`]
    /// photons' worth: (centre, change).
    fn changes(&self, before: &Deposits) -> Vec<(Vec3, Vec3)> {
        let floor = NOISE_PHOTONS * self.photon.max(before.photon).max_element();
        let [nx, ny, _] = self.dims;
        self.power
            .iter()
            .zip(&before.power)
            .enumerate()
            .filter_map(|(i, (now, was))| {
                let change = *now - *was;
                (change.abs().max_element() > floor).then(|| {
                    let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
                    let centre =
                        self.lo + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * self.cell;
                    (centre, change)
                })
            })
            .collect()
    }
}

/// Whether the deposits that changed (cells of size `cell`: centre, power change) change the
/// irradiance of record `r` by more than `tolerance` of its own: each cell as a Lambertian patch
/// reflecting all it received (an upper bound), seen at its distance (at least a cell's) and at the
/// record's cosine. The changes are summed with their signs: a mover's own deposits, leaving one
/// cell for the next, cancel at a distance.
fn sees_changed_light(r: &Record, changes: &[(Vec3, Vec3)], cell: f32, tolerance: f32) -> bool {
    if changes.is_empty() {
        return false;
    }
    let mut de = Vec3::ZERO;
    for &(q, dp) in changes {
        let to = q - r.pos;
        let d2 = to.length_squared().max(cell * cell);
        let cos = to.dot(r.normal).max(0.0) / d2.sqrt();
        de += dp * (cos / (std::f32::consts::PI * d2));
    }
    de.abs().max_element() > tolerance * luminance(r.e).max(1e-12)
}

/// Most times its pixel-spacing limit a record of an earlier frame may span in this frame's view
/// before it is dropped (and its surface gets finer records): the limit is in pixels, so a record
/// made far from the camera is too coarse once the camera comes close.
const VIEW_SLACK: f32 = 0.5;
/// Frames a record may stay out of view (beyond a margin of a quarter of the image around it) before
/// it is deleted: no pixel has used it, and a walk's cache should not grow with all it has passed.
const UNSEEN_FRAMES: u32 = 16;

/// The cache [`Lifespans::update`] made valid for a frame, what it did, and where the cached light
/// changed (spheres: centre, reach).
pub struct Updated {
    pub cache: IrradianceCache,
    pub stats: TemporalStats,
    pub changed: Vec<(Vec3, f32)>,
}

/// What the update did, for the frame's statistics.
#[derive(Clone, Copy, Debug, Default)]
pub struct TemporalStats {
    /// Records whose irradiance stayed (or followed its temporal gradient).
    pub n_kept: u64,
    /// Records gathered again in place.
    pub n_regathered: u64,
    /// Of those, the ones whose change was beyond their noise: replaced by the new gather.
    pub n_replaced: u64,
    /// Records whose surface moved away.
    pub n_gone: u64,
    /// Of the replaced, those that moved with their mesh.
    pub n_moved: u64,
    /// Records carried along with their mesh that kept their irradiance (not due, or gathered
    /// within their noise): it follows their temporal gradient.
    pub n_carried: u64,
    /// Seconds the update took (its gathers, mostly).
    pub update_s: f64,
}

/// What becomes of a record: its life, the hit to gather from (when due) and its new place (when it
/// moved with its mesh).
type Fate = (Life, Option<Hit>, Option<Record>, bool);

fn new_pos(r: &Record, moved: Option<Record>) -> Vec3 {
    moved.map_or(r.pos, |m| m.pos)
}

/// A record whose surface is gone, carried along by the step of the moved mesh it lay on: its new
/// place and the surface hit there (`None` when it lay on no moved mesh, or lands on no surface).
fn carried_along(
    scene: &Scene,
    r: &Record,
    rigid: &[((Vec3, f32), Mat4)],
) -> Option<(Record, Hit)> {
    rigid.iter().find_map(|&((c, radius), step)| {
        if r.pos.distance(c) > radius * 1.01 + r.pixel_world {
            return None;
        }
        let linear = Mat3::from_mat4(step);
        let cotangent = linear.inverse().transpose();
        let moved = Record {
            pos: step.transform_point3(r.pos),
            normal: (cotangent * r.normal).normalize(),
            grad_r: r.grad_r.map(|g| linear * g),
            grad_t: r.grad_t.map(|g| cotangent * g),
            dir: (linear * r.dir).normalize_or_zero(),
            ..*r
        };
        if !(moved.pos.is_finite() && moved.normal.is_finite()) {
            return None;
        }
        surface_at(scene, &moved).map(|hit| (moved, hit))
    })
}

fn key(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

fn luminance(e: Vec3) -> f32 {
    e.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

impl Mover {
    /// A mesh's bounding spheres before and after its step, each moving by that step.
    fn pair(m: &Moved) -> [Mover; 2] {
        m.spheres.map(|(center, radius)| Mover {
            center,
            radius,
            step: m.step,
        })
    }
}

impl Lifespans {
    /// The records of earlier frames for frame `frame.frame`'s view: those fine enough for it (R'
    /// within [`VIEW_SLACK`] times the largest spacing at the record's footprint in `cam`) and not out
    /// of view for [`UNSEEN_FRAMES`] frames.
    pub fn for_view(
        &mut self,
        cache: IrradianceCache,
        scene: &Scene,
        cam: &Camera,
        frame: &mut FrameStats,
    ) -> Result<IrradianceCache> {
        let params = *cache.params();
        let limit =
            VIEW_SLACK * params.max_spacing_px * if params.adaptive.is_some() { 2.0 } else { 1.0 };
        let n = cache.len();
        let now = frame.frame;
        let (w, h) = (cam.width as f32, cam.height as f32);
        let (mx, my) = (0.25 * w, 0.25 * h);
        let mut unseen = HashMap::new();
        let (cache, dropped) = cache
            .rebuilt(scene.bounds, |_, r| {
                let to = r.pos - cam.eye;
                let dist = to.length();
                let in_view = cam
                    .project(r.pos)
                    .is_some_and(|(x, y)| x > -mx && x < w + mx && y > -my && y < h + my);
                if !in_view {
                    let since = self.unseen_since.get(&key(r.pos)).copied().unwrap_or(now);
                    if now - since >= UNSEEN_FRAMES {
                        return None;
                    }
                    unseen.insert(key(r.pos), since);
                    return Some(r);
                }
                if !(dist > 0.0) {
                    return Some(r);
                }
                let dir = to / dist;
                (r.r_clamped <= limit * cam.pixel_world(dir, dist, r.normal.dot(dir))).then_some(r)
            })
            .map_err(runtime)?;
        self.unseen_since = unseen;
        frame.n_records_reused = (n - dropped) as u64;
        frame.n_records_dropped = dropped as u64;
        Ok(cache)
    }

    /// Records made in `frame` (none known before) start their life: one on a moving mesh is due
    /// again the next frame (its rate is not known yet), any other after [`MAX_LIFESPAN`] frames or
    /// as soon as a moved mesh comes near ([`Lifespans::update`]).
    pub fn note_new(&mut self, cache: &IrradianceCache, frame: u32) {
        for r in cache.records() {
            self.by_pos.entry(key(r.pos)).or_insert(Life {
                made: frame,
                due: frame + 1,
                e: r.e,
                de_dt: Vec3::ZERO,
                quiet: 0,
                measured: false,
            });
        }
    }

    /// Keeps the deposits of the maps a frame traced, when none are kept yet (the sequence's first
    /// frame; later frames' updates keep theirs).
    pub fn note_photons(&mut self, scene: &Scene, photons: &crate::photons::PhotonData) {
        if self.deposits.is_none() {
            if let Some(map) = &photons.maps().global {
                self.deposits = Some(Deposits::of(map.photons(), scene.bounds, None));
            }
        }
    }

    /// Where the deposits of `ctx`'s maps changed from those kept (and keeps the new ones): the
    /// cells (centre, power change) and their size; none without deposits to compare.
    fn deposit_changes(&mut self, ctx: &PmContext) -> (Vec<(Vec3, Vec3)>, f32) {
        let Some(map) = &ctx.photons.maps().global else {
            return (Vec::new(), 1.0);
        };
        let now = Deposits::of(map.photons(), ctx.scene.bounds, self.deposits.as_ref());
        let out = match &self.deposits {
            Some(before) => (now.changes(before), now.cell),
            None => (Vec::new(), now.cell),
        };
        self.deposits = Some(now);
        out
    }

    /// The cache of the frame before, made valid for `frame` of `ctx.scene` (see the module header).
    pub fn update(
        &mut self,
        ctx: &PmContext,
        cache: IrradianceCache,
        change: &SceneChange,
        frame: u32,
    ) -> Result<Updated> {
        let start = std::time::Instant::now();
        let scene = ctx.scene;
        let movers: Vec<Mover> = change.moved.iter().flat_map(Mover::pair).collect();
        let (changes, cell) = self.deposit_changes(ctx);
        let mut stats = TemporalStats::default();
        // What becomes of each record: gone (None), kept, or due for a gather from its hit.
        // Each record's life, the hit to gather from where it is due, and its new place when it moved
        // with its mesh (`None`: its surface is gone).
        let fate: Vec<Option<Fate>> = cache
            .records()
            .iter()
            .map(|r| {
                let life = self.by_pos.get(&key(r.pos)).copied().unwrap_or(Life {
                    made: frame.saturating_sub(1),
                    due: frame,
                    e: r.e,
                    de_dt: Vec3::ZERO,
                    quiet: 0,
                    measured: true,
                });
                let Some(hit) = surface_at(scene, r) else {
                    // Carried along with its mesh: what lit it moved relative to it at the rate
                    // its last gathers measured, so it is due like any other record.
                    let (moved, hit) = carried_along(scene, r, &change.rigid)?;
                    let due = frame >= life.due || change.lights;
                    return Some((life, due.then_some(hit), Some(moved), false));
                };
                // Where no moved mesh is near, the light changes only through the photons that
                // meet one: a new record's rate is measured with its first lifespan's change.
                let due_at = if life.measured {
                    life.due
                } else {
                    life.made + MAX_LIFESPAN
                };
                // A glossy lobe's light changes (n + 2) / 2 times as much as the irradiance.
                let tolerance = match scene.material(&hit).bsdf {
                    crate::material::Bsdf::Glossy { exponent, .. } => {
                        TOLERANCE * 2.0 / (exponent + 2.0)
                    }
                    _ => TOLERANCE,
                };
                let caused =
                    near(r, &movers, tolerance) || sees_changed_light(r, &changes, cell, tolerance);
                let due = frame >= due_at || change.lights || caused;
                Some((life, due.then_some(hit), None, caused))
            })
            .collect();
        let due: Vec<usize> = (0..fate.len())
            .filter(|&i| matches!(fate[i], Some((_, Some(_), _, _))))
            .collect();
        let gathered: Vec<NewRecord> = due
            .par_iter()
            .map(|&i| {
                let Some((_, Some(hit), moved, _)) = &fate[i] else {
                    unreachable!("only due records are gathered")
                };
                let r = moved.as_ref().unwrap_or(&cache.records()[i]);
                let sp = ShadingPoint {
                    pos: r.pos,
                    normal: r.normal,
                    pixel_world: r.pixel_world,
                };
                gather_record(ctx, r.at[0], r.at[1], r.at[2] as usize, &sp, hit).0
            })
            .collect();
        let mut replaced = vec![None; fate.len()];
        let mut lives = HashMap::with_capacity(fate.len());
        for (&i, new) in due.iter().zip(gathered) {
            let (old, _, moved, caused) = fate[i].expect("due records have a fate");
            let age = frame.saturating_sub(old.made).max(1);
            let de_dt = (new.e - old.e) / age as f32;
            let level = luminance(new.e).max(luminance(old.e)).max(1e-12);
            // Per channel: a light that changes colour may keep its luminance.
            let moved_by = (new.e - old.e).abs().max_element() / level;
            // A record due only because its lifespan ended, whose gather differs within the
            // gather's own noise, did not change: it stays as it was, and the image does not flicker
            // where nothing happened. A changed light changes every record (and the photons of every
            // path), and a record near a moved mesh or seeing light that changed changed for a known
            // reason (its gather has the same rays as before: what differs is the light): each takes
            // its new gather.
            let noise = 2.0 * new.rel_err.max(cache.records()[i].rel_err);
            let life = if !change.lights && !caused && moved_by <= noise.max(0.25 * TOLERANCE) {
                let quiet = (2 * old.quiet).clamp(MAX_LIFESPAN, MAX_QUIET_LIFESPAN);
                Life {
                    due: frame + quiet,
                    de_dt: Vec3::ZERO,
                    quiet,
                    measured: true,
                    ..old
                }
            } else {
                // Per channel, as the change: a light keyed to another hue at the same luminance
                // changes its records' colour, which their gradient goes on changing until due.
                let rate = de_dt.abs().max_element() / level;
                let lifespan = ((TOLERANCE / rate) as u32).clamp(1, MAX_LIFESPAN);
                replaced[i] = Some(new);
                if moved.is_some() {
                    stats.n_moved += 1;
                }
                Life {
                    made: frame,
                    due: frame + lifespan,
                    e: new.e,
                    de_dt,
                    quiet: 0,
                    measured: true,
                }
            };
            lives.insert(key(new_pos(&cache.records()[i], moved)), life);
        }
        // Where the cached light changed: records gone, replaced, or following their gradient.
        let mut changed = Vec::new();
        let max_spacing_px = cache.params().max_spacing_px
            * if cache.params().adaptive.is_some() {
                2.0
            } else {
                1.0
            };
        let (mut cache, _) = cache
            .rebuilt(scene.bounds, |i, mut r| {
                let Some((life, _, moved, _)) = fate[i] else {
                    changed.push((r.pos, r.r_clamped));
                    return None;
                };
                if let Some(m) = moved {
                    changed.push((r.pos, r.r_clamped));
                    changed.push((m.pos, r.pixel_world * max_spacing_px));
                    if replaced[i].is_some() {
                        return None;
                    }
                    let life = *lives.entry(key(m.pos)).or_insert(life);
                    stats.n_carried += 1;
                    return Some(Record {
                        e: (life.e + life.de_dt * (frame - life.made) as f32).max(Vec3::ZERO),
                        ..m
                    });
                }
                let life = *lives.entry(key(r.pos)).or_insert(life);
                if replaced[i].is_some() {
                    // Its new gather may reach as far as any record there.
                    changed.push((r.pos, r.pixel_world * max_spacing_px));
                } else if life.de_dt != Vec3::ZERO {
                    changed.push((r.pos, r.r_clamped));
                }
                if replaced[i].is_some() {
                    return None;
                }
                r.e = (life.e + life.de_dt * (frame - life.made) as f32).max(Vec3::ZERO);
                Some(r)
            })
            .map_err(runtime)?;
        stats.n_gone = fate.iter().filter(|f| f.is_none()).count() as u64;
        stats.n_regathered = due.len() as u64;
        for new in replaced.into_iter().flatten() {
            cache.insert(new);
            stats.n_replaced += 1;
        }
        stats.n_kept = cache.len() as u64 - stats.n_replaced;
        self.by_pos = lives;
        stats.update_s = start.elapsed().as_secs_f64();
        Ok(Updated {
            cache,
            stats,
            changed,
        })
    }
}

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

/// The surface a record was made on, hit again from just above it along its normal; `None` when it
/// is no longer there (a mesh moved away).
fn surface_at(scene: &Scene, r: &Record) -> Option<Hit> {
    let lift = (r.pixel_world * 0.1).max((r.pos.abs().max_element() + 1.0) * 1e-5);
    let hit = scene.intersect(r.pos + r.normal * lift, -r.normal)?;
    ((hit.t - lift).abs() < 0.5 * lift && hit.ng.dot(r.normal).abs() > 0.99).then_some(hit)
}

/// Whether a moved mesh is near enough to the record for its step to change the record's irradiance
/// by more than `tolerance` of it: a sphere of radius r at distance d covers about r²/d² of the sky, and
/// a step s changes that by about 2r²s/d³.
fn near(r: &Record, movers: &[Mover], tolerance: f32) -> bool {
    movers.iter().any(|m| {
        let to = m.center - r.pos;
        let d = to.length();
        d <= m.radius
            || (to.dot(r.normal) > -m.radius
                && 2.0 * m.radius * m.radius * m.step > tolerance * d * d * d)
    })
}

/// The pixels a frame may take from the frame before (the camera stayed, a mesh moved, no light
/// changed): outside the moved meshes' window, or inside it where the pixel's cone of camera rays
/// passes every moved mesh before and after its step, their centre's camera ray ends on a diffuse
/// surface (or nothing) whose shadow rays pass no moved mesh and whose cached light no changed record
/// reaches.
/// `None` where the scene has more than diffuse surfaces without media (caustic and glossy terms read
/// photon maps traced again; media scatter along every ray), or when a light changed.
pub fn unchanged_pixels(
    scene: &Scene,
    cam: &Camera,
    change: &SceneChange,
    changed: &[(Vec3, f32)],
    window: Window,
) -> Option<Vec<bool>> {
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
    let sources = light_spheres(scene);
    let hits: Vec<Option<(Vec3, f32)>> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let d = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            scene
                .intersect(cam.eye, d)
                .map(|hit| (hit.p, cam.pixel_world(d, hit.t, hit.ns.dot(d))))
        })
        .collect();
    // A pixel's samples leave the eye within about a pixel of its centre's ray (a pixel's angle at
    // the image's middle, more than anywhere else): in the window, a pixel keeps its value only when
    // that cone passes every moved mesh before and after its step.
    let pixel_angle = 2.0 * (cam.fov_deg().to_radians() * 0.5).tan() / h as f32;
    let far = cam.eye.distance((scene.bounds.0 + scene.bounds.1) * 0.5) + scene.diagonal();
    let mut keep: Vec<bool> = (0..w * h)
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
            let Some((p, pixel)) = hits[i as usize] else {
                return true;
            };
            // The pixel's samples land within about a pixel of its centre's point: each mover is
            // widened by that.
            !sources.iter().any(|end| {
                let (c_l, r_l) = end.seen_from(p);
                movers
                    .iter()
                    .any(|&(c, r)| sphere_meets_cone(c, r + pixel, p, c_l, r_l))
            })
        })
        .collect();
    for &(c, reach) in changed {
        let Some((lo, hi)) = sphere_pixels(cam, c, reach) else {
            // Around or behind the eye: it may reach anywhere.
            return None;
        };
        let rect = pixel_window(cam, lo, hi);
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                let i = (y * w + x) as usize;
                if let Some((p, pixel)) = hits[i] {
                    if p.distance(c) < reach + pixel {
                        keep[i] = false;
                    }
                }
            }
        }
    }
    Some(keep)
}

/// Where a light's shadow rays from a point end.
#[derive(Clone, Copy)]
enum ShadowEnd {
    /// A ball every shadow ray ends in (centre, radius): all emissive triangles as one, a point or
    /// spot light.
    Ball(Vec3, f32),
    /// Far along a directional light's reverse direction from the point itself: its shadow rays are
    /// parallel (this offset).
    Along(Vec3),
}

impl ShadowEnd {
    /// The ball the shadow rays from `p` end in.
    fn seen_from(self, p: Vec3) -> (Vec3, f32) {
        match self {
            ShadowEnd::Ball(c, r) => (c, r),
            ShadowEnd::Along(offset) => (p + offset, 0.0),
        }
    }
}

/// Where the lights' shadow rays end.
fn light_spheres(scene: &Scene) -> Vec<ShadowEnd> {
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
fn sphere_meets_cone(c: Vec3, r: f32, p: Vec3, c_l: Vec3, r_l: f32) -> bool {
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

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_mesh_turning_about_its_centre_moves_by_its_radius_times_the_angle() {
        let sphere = (Vec3::new(1.0, 2.0, 3.0), 0.5);
        // 30° about its own centre: the sphere stays, its points move up to 2 r sin 15° ≈ 0.26 r.
        let turn = Mat4::from_translation(sphere.0)
            * Mat4::from_rotation_z(30f32.to_radians())
            * Mat4::from_translation(-sphere.0);
        let m = Moved::new(sphere, sphere, Some(turn));
        assert!(m.step >= 0.5 * 2.0 * 15f32.to_radians().sin(), "{}", m.step);
        assert!(m.step <= 0.5 * 1.5, "{}", m.step);
        // A translation: its length, whatever the radius.
        let shift = Mat4::from_translation(Vec3::new(0.0, 0.3, 0.0));
        let after = (sphere.0 + Vec3::new(0.0, 0.3, 0.0), 0.5);
        assert!((Moved::new(sphere, after, Some(shift)).step - 0.3).abs() < 1e-5);
        // Without a known placement, the spheres' distance.
        assert!((Moved::new(sphere, after, None).step - 0.3).abs() < 1e-5);
    }

    #[test]
    fn records_see_deposits_that_changed_in_their_sky_and_not_a_mover_passing_by() {
        let photon = |pos: Vec3, power: f32| photon::map::Photon {
            pos,
            wi: Vec3::Y,
            power: Vec3::splat(power),
            normal: Vec3::Y,
            indirect: false,
            direct: true,
        };
        let bounds = (Vec3::ZERO, Vec3::splat(4.0));
        // A floor of photons, and a bright patch at (3, 0, 2) that a blocker takes away.
        let floor: Vec<_> = (0..400)
            .map(|i| {
                photon(
                    Vec3::new(
                        0.1 + 0.2 * (i % 20) as f32,
                        0.0,
                        0.1 + 0.2 * (i / 20) as f32,
                    ),
                    0.01,
                )
            })
            .collect();
        let lit: Vec<_> = floor
            .iter()
            .copied()
            .chain((0..50).map(|_| photon(Vec3::new(3.0, 0.0, 2.0), 0.02)))
            .collect();
        let before = Deposits::of(&lit, bounds, None);
        let after = Deposits::of(&floor, bounds, Some(&before));
        let changes = after.changes(&before);
        assert_eq!(changes.len(), 1, "{changes:?}");
        // A record on the ceiling above: its indirect 1.0 would change by about 1 / (π 16) ≈ 2 %…
        let rec = |pos: Vec3, normal: Vec3, e: f32| Record {
            pos,
            normal,
            e: Vec3::splat(e),
            grad_r: [Vec3::ZERO; 3],
            grad_t: [Vec3::ZERO; 3],
            r_harmonic: 1.0,
            r_clamped: 1.0,
            dir: normal,
            pixel_world: 0.01,
            rel_err: 0.0,
            at: [0; 3],
        };
        let ceiling = rec(Vec3::new(2.0, 4.0, 2.0), -Vec3::Y, 0.2);
        assert!(sees_changed_light(
            &ceiling, &changes, after.cell, TOLERANCE
        ));
        // …but not one facing away, nor a brighter one.
        assert!(!sees_changed_light(
            &rec(Vec3::new(2.0, 4.0, 2.0), Vec3::Y, 0.2),
            &changes,
            after.cell,
            TOLERANCE
        ));
        assert!(!sees_changed_light(
            &rec(Vec3::new(2.0, 4.0, 2.0), -Vec3::Y, 5.0),
            &changes,
            after.cell,
            TOLERANCE
        ));
        // A patch that moves one cell over: the changes cancel at a distance.
        let moved: Vec<_> = floor
            .iter()
            .copied()
            .chain((0..50).map(|_| photon(Vec3::new(3.15, 0.0, 2.0), 0.02)))
            .collect();
        let shifted = Deposits::of(&moved, bounds, Some(&before)).changes(&before);
        assert!(!sees_changed_light(
            &ceiling, &shifted, after.cell, TOLERANCE
        ));
    }

    #[test]
    fn a_record_is_near_a_mover_whose_step_changes_its_sky_by_more_than_the_tolerance() {
        let rec = |z: f32| Record {
            pos: Vec3::new(0.0, 0.0, z),
            normal: Vec3::Z,
            e: Vec3::ONE,
            grad_r: [Vec3::ZERO; 3],
            grad_t: [Vec3::ZERO; 3],
            r_harmonic: 1.0,
            r_clamped: 1.0,
            dir: Vec3::Z,
            pixel_world: 0.01,
            rel_err: 0.0,
            at: [0; 3],
        };
        let ball = Mover {
            center: Vec3::new(0.0, 0.0, 1.0),
            radius: 0.25,
            step: 0.025,
        };
        // 2 r² s / d³ = 0.003125 / d³ against 0.02: near within d ≈ 0.54.
        assert!(near(&rec(0.6), &[ball], TOLERANCE));
        assert!(!near(&rec(0.0), &[ball], TOLERANCE));
        // Below its tangent plane the mover is not in the record's sky.
        assert!(!near(
            &Record {
                pos: Vec3::new(0.0, 0.0, 1.5),
                ..rec(0.0)
            },
            &[ball],
            TOLERANCE
        ));
    }
}
