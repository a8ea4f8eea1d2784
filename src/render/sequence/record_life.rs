//! One record's life in the temporal cache: when it is due, how its light drifts, what becomes of it
//! when its surface moves or its new gather differs, and the surface it was made on.

use std::collections::HashMap;

use glam::{Mat3, Vec3};
use icache::{IrradianceCache, NewRecord, Record};
use pmbase::luminance;

use super::temporal::Rigid;
use crate::error::{runtime, Result};
use crate::geometry::Hit;
use crate::render::stats::TemporalStats;
use crate::scene::Scene;

/// Relative change of its irradiance a record may build up before it is gathered again.
pub(super) const TOLERANCE: f32 = 0.02;

/// Most frames between two gathers of a record whose light changed at its last gather (Gautron's
/// δt_max), and the first lifespan of a new record no moved mesh is near.
pub(super) const MAX_LIFESPAN: u32 = 8;

/// Most frames between two gathers of a record whose light did not change: each gather that finds
/// no change doubles its lifespan, up to this. Where nothing moves near a record, its light changes
/// only through the photons that meet the moved meshes; a moved mesh that comes near makes it due
/// at once ([`near`]).
pub(super) const MAX_QUIET_LIFESPAN: u32 = 32;

pub(super) fn key(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
}

/// A record's life: when it was last gathered, to what, how fast it changes, when it is due again.
#[derive(Clone, Copy, Debug)]
pub(super) struct Life {
    pub(super) made: u32,
    pub(super) due: u32,
    pub(super) e: Vec3,
    pub(super) de_dt: Vec3,
    /// Frames between its last two gathers that found no change (0: its last gather found one,
    /// or it has had none).
    pub(super) quiet: u32,
    /// Whether it has been gathered again since it was made (its rate of change is known).
    pub(super) measured: bool,
    /// Whether its last gather found a change for no known reason (its value slides toward that
    /// gather), rather than for a known one (its value is that gather's, followed along its
    /// temporal gradient).
    pub(super) slides: bool,
}

impl Life {
    /// The record's irradiance at `frame`: its last gather's (or the value it slides from) followed
    /// along its temporal gradient.
    pub(super) fn at(&self, frame: u32) -> Vec3 {
        (self.e + self.de_dt * frame.saturating_sub(self.made) as f32).max(Vec3::ZERO)
    }
}

/// What becomes of a record: its life, the hit to gather from (when due) and its new place (when it
/// moved with its mesh).
pub(super) type Fate = (Life, Option<Hit>, Option<Record>, bool);

pub(super) fn new_pos(r: &Record, moved: Option<Record>) -> Vec3 {
    moved.map_or(r.pos, |m| m.pos)
}

/// A record whose surface is gone, carried along by the step of the moved mesh it lay on: its new
/// place and the surface hit there (`None` when it lay on no moved mesh, or lands on no surface).
pub(super) fn carried_along(scene: &Scene, r: &Record, rigid: &[Rigid]) -> Option<(Record, Hit)> {
    rigid.iter().find_map(|m| {
        let ((c, radius), step) = (m.before, m.step);
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

/// The cache after an update: records whose surface is gone or whose new gather replaces them
/// dropped, carried records at their new place, the others at their life's value at `frame`; with
/// where the cached light changed (spheres: centre, reach).
pub(super) fn rebuilt(
    cache: IrradianceCache,
    scene: &Scene,
    fate: &[Option<Fate>],
    replaced: &[Option<NewRecord>],
    lives: &mut HashMap<[u32; 3], Life>,
    frame: u32,
    stats: &mut TemporalStats,
) -> Result<(IrradianceCache, Vec<(Vec3, f32)>)> {
    // Where the cached light changed: records gone, replaced, or following their gradient.
    let mut changed = Vec::new();
    let max_spacing_px = cache.params().max_spacing_px
        * if cache.params().adaptive.is_some() {
            2.0
        } else {
            1.0
        };
    let (cache, _) = cache
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
                    e: life.at(frame),
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
            r.e = life.at(frame);
            Some(r)
        })
        .map_err(runtime)?;
    Ok((cache, changed))
}

/// A due record's next life from its new gather `new` at `frame` (`known`: due for a known cause;
/// `rel_err`: its last gather's noise), and whether the new gather replaces it.
pub(super) fn next_life(
    old: &Life,
    new: &NewRecord,
    frame: u32,
    known: bool,
    rel_err: f32,
) -> (Life, bool) {
    let age = frame.saturating_sub(old.made).max(1);
    let de_dt = (new.e - old.e) / age as f32;
    let level = luminance(new.e).max(luminance(old.e)).max(1e-12);
    // Per channel (a light that changes colour may keep its luminance), against the value
    // the record has now.
    let now = old.at(frame);
    let moved_by = (new.e - now).abs().max_element() / level;
    let noise = 2.0 * new.rel_err.max(rel_err);
    let within = moved_by <= noise.max(0.25 * TOLERANCE);
    // A record due only because its lifespan ended changed for no known reason: its light
    // drifts as the photons that meet the movers change, slowly. Taking the new gather at
    // once would make the drift a pop where nothing happened, keeping the old one would
    // let it build up into one: the record slides from its value to the new gather over its
    // next lifespan, so that the image follows the drift a little each frame. That
    // lifespan is the frames the drift takes to reach [`TOLERANCE`]; where the gather
    // differs within twice the gathers' own noise (or a quarter of [`TOLERANCE`]) the record
    // is quiet, and it may double, up to [`MAX_QUIET_LIFESPAN`]: records far from what moves
    // are seldom gathered. One whose last gather was taken for a known reason first goes
    // back to it when within that noise (the change its gradient measured has stopped).
    // After a light changed (every record and the photons of every path change), where a
    // record was due for a known reason (a mover near, light that changed in sight, or it
    // moved with its mesh), or one that had not slid differs by more than its noise, it
    // takes its new gather: its gather has the same rays as before, what differs is the
    // light.
    let quiet = (2 * old.quiet).clamp(MAX_LIFESPAN, MAX_QUIET_LIFESPAN);
    let life = if !known && (old.slides || !old.measured) {
        let most = if within { quiet } else { MAX_LIFESPAN };
        let span = ((TOLERANCE * age as f32 / moved_by.max(1e-12)) as u32).clamp(1, most);
        Life {
            made: frame,
            due: frame + span,
            e: now,
            de_dt: (new.e - now) / span as f32,
            quiet: if within { span } else { 0 },
            measured: true,
            slides: true,
        }
    } else if !known && within {
        Life {
            due: frame + quiet,
            de_dt: Vec3::ZERO,
            quiet,
            measured: true,
            slides: true,
            ..*old
        }
    } else {
        // Per channel, as the change: a light keyed to another hue at the same luminance
        // changes its records' colour, which their gradient goes on changing until due.
        let rate = de_dt.abs().max_element() / level;
        let lifespan = ((TOLERANCE / rate) as u32).clamp(1, MAX_LIFESPAN);
        let life = Life {
            made: frame,
            due: frame + lifespan,
            e: new.e,
            de_dt,
            quiet: 0,
            measured: true,
            slides: false,
        };
        return (life, true);
    };
    (life, false)
}

/// The surface a record was made on, hit again from just above it along its normal; `None` when it
/// is no longer there (a mesh moved away). Only a surface within a tenth of the lift of the record's
/// point counts: a moved mesh that came closer to it than the lift (the gap beside a ball resting on
/// the floor) would otherwise hide the floor, and the floor's record would be carried along with the
/// ball.
pub(super) fn surface_at(scene: &Scene, r: &Record) -> Option<Hit> {
    let lift = (r.pixel_world * 0.1).max((r.pos.abs().max_element() + 1.0) * 1e-5);
    let from = |p: Vec3| {
        let hit = scene.intersect_after(p + r.normal * lift, -r.normal, 0.9 * lift)?;
        ((hit.t - lift).abs() < 0.1 * lift && hit.ng.dot(r.normal).abs() > 0.99).then_some(hit)
    };
    // A record made on an edge (a pixel's ray that met the corner of a room) may find no surface
    // straight below its lift: the same test a lift's length to each side looks for it there, and
    // the hit keeps the record's point (its gather is taken from where it was).
    let (t, b) = r.normal.any_orthonormal_pair();
    from(r.pos).or_else(|| {
        [t, -t, b, -b]
            .into_iter()
            .find_map(|side| from(r.pos + side * lift).map(|hit| Hit { p: r.pos, ..hit }))
    })
}
