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
//! - A record due only because its lifespan ended changed for no known reason (its light drifts as
//!   the photons that meet the movers change): it slides from its value to its new gather over its
//!   next lifespan — the frames that drift takes to reach [`TOLERANCE`] — so that the image follows
//!   a slow drift a little each frame instead of popping when a record is gathered. Where the
//!   gather differs from the record in no channel by more than twice the gathers' own noise (or a
//!   quarter of [`TOLERANCE`]) the record is quiet and that lifespan may reach twice its last quiet
//!   one (from [`MAX_LIFESPAN`] up to [`MAX_QUIET_LIFESPAN`]): records far from what moves are
//!   seldom gathered. After a light changed (a `[[light]]`'s values, or a mesh that emits moved),
//!   and where a record was due for a known reason (a mover near, light that changed in sight, or
//!   it moved with its mesh: its small drifts would otherwise add up over the quiet lifespans), it
//!   takes its new gather.
//! - Between gathers a record's irradiance follows its temporal gradient.
//!
//! Frames where only the camera moves keep every record of earlier frames that is fine enough for the
//! new view ([`Lifespans::for_view`]); records out of view for [`UNSEEN_FRAMES`] frames are deleted,
//! and so are those in view that no pixel read for [`UNREAD_FRAMES`] frames (hidden behind what
//! the camera passes, or facing away from it).
//!
//! Re-gathering with the record's own jitter rather than by reprojection: our gathers read photon
//! maps traced with the same photon sequence every frame, so the same gather differs between frames
//! only where the light did, and the rate measured is the light's, not noise.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Mat3, Mat4, Vec3};
use icache::{IrradianceCache, NewRecord, Record, ShadingPoint};
use rayon::prelude::*;

use super::light_change::{sees_changed_light, Deposits};
use super::record_life::*;
use crate::camera::Camera;
use crate::error::{runtime, Result};
use crate::geometry::Hit;
use crate::integrator::cache_fill::gather_record;
use crate::integrator::pm::PmContext;
use crate::render::stats::{FrameStats, TemporalStats};
use crate::scene::Scene;

/// The noise target where something moved, as a fraction of the frame's: a pixel's Monte Carlo noise
/// there differs from frame to frame (its samples meet other things), and is seen as flicker.
pub const MOVING_NOISE: f32 = 0.5;

/// What changed since the frame before: every moved mesh, and whether a light changed.
#[derive(Clone, Debug, Default)]
pub struct SceneChange {
    pub moved: Vec<Moved>,
    /// Each moved mesh whose step is known: the records on it move with it.
    pub rigid: Vec<Rigid>,
    pub lights: bool,
}

/// A moved mesh's `[[mesh]]` index, its bounding sphere before its step, and the step (new placement
/// × old⁻¹).
#[derive(Clone, Copy, Debug)]
pub struct Rigid {
    pub mesh: usize,
    pub before: (Vec3, f32),
    pub step: Mat4,
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

/// The lives of the records of a sequence's cache, by their position's bits: when each is due for a
/// gather, and since which frame it has been out of view.
#[derive(Default)]
pub struct Lifespans {
    by_pos: HashMap<[u32; 3], Life>,
    unseen_since: HashMap<[u32; 3], u32>,
    /// For each record of an earlier view that pass B did not read in the last frames where the
    /// camera moved: how many such frames in a row.
    unread: HashMap<[u32; 3], u32>,
    /// The pixels each record's radius spanned in the view it was made for (where it was in view).
    made_px: HashMap<[u32; 3], f32>,
    /// The photon power the last traced maps deposited, per cell.
    deposits: Option<Deposits>,
}

/// Most times its pixel-spacing limit a record of an earlier frame may span in this frame's view
/// before it is dropped (and its surface gets finer records): the limit is in pixels, so a record
/// made far from the camera is too coarse once the camera comes close.
const VIEW_SLACK: f32 = 0.5;
/// A record spanning more than [`VIEW_SLACK`] of the limit stays, up to the limit, while it spans at
/// most this many times the pixels it spanned in the view it was made for: a record made in the upper
/// half of the limit is as fine as a new one would be there, and dropping it would only make it again
/// in the same place.
const VIEW_GROWTH: f32 = 1.25;
/// Frames a record may stay out of view (beyond a margin of a quarter of the image around it) before
/// it is deleted: no pixel has used it, and a walk's cache should not grow with all it has passed.
const UNSEEN_FRAMES: u32 = 16;
/// Frames where the camera moved that a record in view may go unread by every pixel before it is
/// deleted: like one out of view, it serves no pixel, and a walk past walls would otherwise keep
/// all it saw behind them (and gather it again as its lifespans end).
const UNREAD_FRAMES: u32 = 16;

/// The cache [`Lifespans::update`] made valid for a frame, what it did, and where the cached light
/// changed (spheres: centre, reach).
pub struct Updated {
    pub cache: IrradianceCache,
    pub stats: TemporalStats,
    pub changed: Vec<(Vec3, f32)>,
}

/// The pixels a record's radius spans in `cam`'s view (its position not at the eye).
fn span_px(r: &Record, cam: &Camera) -> f32 {
    let to = r.pos - cam.eye;
    let dist = to.length();
    let dir = to / dist;
    r.r_clamped / cam.pixel_world(dir, dist, r.normal.dot(dir))
}

impl Lifespans {
    /// The records of earlier frames for frame `frame.frame`'s view: those fine enough for it (R'
    /// within [`VIEW_SLACK`] times the largest spacing at the record's footprint in `cam`, or within
    /// it and [`VIEW_GROWTH`] times what it spanned when made) and not out of view for
    /// [`UNSEEN_FRAMES`] frames.
    pub fn for_view(
        &mut self,
        cache: IrradianceCache,
        scene: &Scene,
        cam: &Camera,
        frame: &mut FrameStats,
    ) -> Result<IrradianceCache> {
        let params = *cache.params();
        let full = params.max_spacing_px * if params.adaptive.is_some() { 2.0 } else { 1.0 };
        let limit = VIEW_SLACK * full;
        let n = cache.len();
        let now = frame.frame;
        let (w, h) = (cam.width as f32, cam.height as f32);
        let (mx, my) = (0.25 * w, 0.25 * h);
        let mut unseen = HashMap::new();
        let mut unread = 0;
        let (cache, dropped) = cache
            .rebuilt(scene.bounds, |_, r| {
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
                if self
                    .unread
                    .get(&key(r.pos))
                    .is_some_and(|&n| n >= UNREAD_FRAMES)
                {
                    unread += 1;
                    return None;
                }
                if r.pos == cam.eye {
                    return Some(r);
                }
                let span = span_px(&r, cam);
                let grown = self
                    .made_px
                    .get(&key(r.pos))
                    .is_some_and(|&made| span <= (VIEW_GROWTH * made).min(full));
                (span <= limit || grown).then_some(r)
            })
            .map_err(runtime)?;
        self.unseen_since = unseen;
        // A dropped record's life goes with it: a record made later at the very same place (a camera
        // back at a pose it had) starts a life of its own, not the old one's rate and due frame.
        if dropped > 0 {
            let kept: std::collections::HashSet<[u32; 3]> =
                cache.records().iter().map(|r| key(r.pos)).collect();
            self.by_pos.retain(|k, _| kept.contains(k));
            self.made_px.retain(|k, _| kept.contains(k));
        }
        frame.n_records_reused = (n - dropped) as u64;
        frame.n_records_dropped = dropped as u64;
        frame.n_records_unread = unread;
        Ok(cache)
    }

    /// Records made in `frame` (none known before) start their life: one on a moving mesh is due
    /// again the next frame (its rate is not known yet), any other after [`MAX_LIFESPAN`] frames or
    /// as soon as a moved mesh comes near ([`Lifespans::update`]); the pixels each spans in `cam`,
    /// the frame's camera, are noted.
    pub fn note_new(&mut self, cache: &IrradianceCache, frame: u32, cam: &Camera) {
        for r in cache.records() {
            if let Entry::Vacant(v) = self.made_px.entry(key(r.pos)) {
                if r.pos != cam.eye && cam.project(r.pos).is_some() {
                    v.insert(span_px(r, cam));
                }
            }
            self.by_pos.entry(key(r.pos)).or_insert(Life {
                made: frame,
                due: frame + 1,
                e: r.e,
                de_dt: Vec3::ZERO,
                quiet: 0,
                measured: false,
                slides: false,
            });
        }
    }

    /// Counts the frame's unread records of earlier views: `reads` says whether pass B read each of
    /// the first records of `records` (those a frame where the camera moved kept from the frames
    /// before). A record read starts counting again; the counts of records not among them are
    /// forgotten.
    pub fn note_reads(&mut self, records: &[Record], reads: &[AtomicBool]) {
        let before = std::mem::take(&mut self.unread);
        for (r, read) in records.iter().zip(reads) {
            if !read.load(Ordering::Relaxed) {
                let k = key(r.pos);
                self.unread.insert(k, before.get(&k).map_or(1, |n| n + 1));
            }
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
    /// What becomes of record `r` at `frame` after `change`: `None` when its surface is gone, else its
    /// life, the hit to gather from when it is due, its new place when it moved with its mesh, and
    /// whether a known cause (a mover near, changed light in sight, its own move) made it due.
    fn fate_of(
        &self,
        scene: &Scene,
        r: &Record,
        frame: u32,
        change: &SceneChange,
        movers: &[Mover],
        (changes, cell): (&[(Vec3, Vec3)], f32),
    ) -> Option<Fate> {
        let life = self.by_pos.get(&key(r.pos)).copied().unwrap_or(Life {
            made: frame.saturating_sub(1),
            due: frame,
            e: r.e,
            de_dt: Vec3::ZERO,
            quiet: 0,
            measured: true,
            slides: false,
        });
        // Carried along with its mesh: what lit it moved relative to it at the rate its last
        // gathers measured, so it is due like any other record; and what it sees changed for a
        // known reason (it moved), so its gather is always taken.
        let carried = |(moved, hit): (Record, Hit)| {
            let due = frame >= life.due || change.lights;
            (life, due.then_some(hit), Some(moved), true)
        };
        let Some(hit) = surface_at(scene, r) else {
            return carried_along(scene, r, &change.rigid).map(carried);
        };
        // A record whose surface is a moved mesh's goes with it even where the step was too small
        // to take the surface from under it (a mesh moving across its own normal): left in place
        // it falls behind its mesh frame after frame, inside it or off it, where no pixel can use
        // it, and new records pile up beside it (a camera following the mesh sees it in the same
        // place every frame).
        let on_moved = change.rigid.iter().filter(|m| {
            scene
                .mesh_ranges
                .get(m.mesh)
                .is_some_and(|t| t.contains(&(hit.tri as usize)))
        });
        if let Some(fate) = carried_along(scene, r, &on_moved.copied().collect::<Vec<_>>()) {
            return Some(carried(fate));
        }
        // Where no moved mesh is near, the light changes only through the photons that
        // meet one: a new record's rate is measured with its first lifespan's change.
        let due_at = if life.measured {
            life.due
        } else {
            life.made + MAX_LIFESPAN
        };
        // A glossy lobe's light changes (n + 2) / 2 times as much as the irradiance.
        let tolerance = match scene.material(&hit).bsdf {
            crate::material::Bsdf::Glossy { exponent, .. } => TOLERANCE * 2.0 / (exponent + 2.0),
            _ => TOLERANCE,
        };
        let caused = near(r, movers, tolerance) || sees_changed_light(r, changes, cell, tolerance);
        let due = frame >= due_at || change.lights || caused;
        Some((life, due.then_some(hit), None, caused))
    }

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
            .map(|r| self.fate_of(scene, r, frame, change, &movers, (&changes, cell)))
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
            let known = change.lights || caused;
            let rel_err = cache.records()[i].rel_err;
            let (life, replace) = next_life(&old, &new, frame, known, rel_err);
            if replace {
                replaced[i] = Some(new);
                if moved.is_some() {
                    stats.n_moved += 1;
                }
            }
            lives.insert(key(new_pos(&cache.records()[i], moved)), life);
        }
        let (mut cache, changed) = rebuilt(
            cache, scene, &fate, &replaced, &mut lives, frame, &mut stats,
        )?;
        stats.n_gone = fate.iter().filter(|f| f.is_none()).count() as u64;
        stats.n_regathered = due.len() as u64;
        for new in replaced.into_iter().flatten() {
            cache.insert(new);
            stats.n_replaced += 1;
        }
        stats.n_kept = cache.len() as u64 - stats.n_replaced;
        self.by_pos = lives;
        // Records that moved with their mesh have new keys: what the old ones spanned goes.
        let by_pos = &self.by_pos;
        self.made_px.retain(|k, _| by_pos.contains_key(k));
        stats.update_s = start.elapsed().as_secs_f64();
        Ok(Updated {
            cache,
            stats,
            changed,
        })
    }
}

/// A moved mesh as a bounding sphere: where it is, how large, how far it moved.
#[derive(Clone, Copy)]
pub(super) struct Mover {
    pub(super) center: Vec3,
    pub(super) radius: f32,
    pub(super) step: f32,
}

impl Mover {
    /// A mesh's bounding spheres before and after its step, each moving by that step.
    pub(super) fn pair(m: &Moved) -> [Mover; 2] {
        m.spheres.map(|(center, radius)| Mover {
            center,
            radius,
            step: m.step,
        })
    }
}

/// Whether a moved mesh is near enough to the record for its step to change the record's irradiance
/// by more than `tolerance` of it: a sphere of radius r at distance d covers about r²/d² of the sky, and
/// a step s changes that by about 2r²s/d³.
pub(super) fn near(r: &Record, movers: &[Mover], tolerance: f32) -> bool {
    movers.iter().any(|m| {
        let to = m.center - r.pos;
        let d = to.length();
        d <= m.radius
            || (to.dot(r.normal) > -m.radius
                && 2.0 * m.radius * m.radius * m.step > tolerance * d * d * d)
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A record at `pos` facing `normal` with irradiance `e` in every channel, of radius `r` (R and R'),
    /// made where a pixel spans `pixel_world`.
    pub(in crate::render) fn record(
        pos: Vec3,
        normal: Vec3,
        e: f32,
        r: f32,
        pixel_world: f32,
    ) -> Record {
        Record {
            pos,
            normal,
            e: Vec3::splat(e),
            grad_r: [Vec3::ZERO; 3],
            grad_t: [Vec3::ZERO; 3],
            r_harmonic: r,
            r_clamped: r,
            dir: normal,
            pixel_world,
            rel_err: 0.0,
            at: [0; 3],
        }
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
    fn a_record_is_near_a_mover_whose_step_changes_its_sky_by_more_than_the_tolerance() {
        let rec = |z: f32| record(Vec3::new(0.0, 0.0, z), Vec3::Z, 1.0, 1.0, 0.01);
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

    /// Records on the box's edges (made where a pixel's ray met the corner of floor or ceiling and a
    /// wall) find their surface and keep their point: they vanished on a sequence's second frame, and
    /// the pixels they served changed by 2–20 % where nothing had moved.
    #[test]
    fn a_record_on_an_edge_of_the_room_keeps_its_surface() {
        let scene = anim_ball_frames(0, "edges");
        let rec = |pos: Vec3, normal: Vec3| record(pos, normal, 1.0, 0.2, 0.057);
        for (pos, normal) in [
            (Vec3::new(1.0, 0.0, 0.772), Vec3::Y),
            (Vec3::new(1.0, 2.0, 0.772), -Vec3::Y),
            (Vec3::new(1.0, 2.0, -0.426), -Vec3::X),
            (Vec3::new(-1.0, 0.0, 0.454), Vec3::X),
        ] {
            let hit = surface_at(&scene, &rec(pos, normal));
            let hit = hit.unwrap_or_else(|| panic!("no surface for the record at {pos}"));
            // The record's point, to a millionth of the 2-unit room: the hit straight below a record
            // is measured from the wall's corners, whose last bit need not be the record's.
            assert!((hit.p - pos).length() < 2e-6, "{} for {pos}", hit.p);
            assert!(hit.ng.dot(normal).abs() > 0.99, "{:?} at {pos}", hit.ng);
        }
    }

    /// Frame `f` of scenes/anim-ball.toml (its models found from a copy in a folder of `tag`).
    fn anim_ball_frames(f: u32, tag: &str) -> Scene {
        let dir = std::env::temp_dir().join(format!("pm-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let text = std::fs::read_to_string(root.join("scenes/anim-ball.toml"))
            .unwrap()
            .replace("models/", &format!("{}/scenes/models/", root.display()));
        let path = dir.join("ball.toml");
        std::fs::write(&path, text).unwrap();
        let anim = crate::scene::load_animation(&path).unwrap().unwrap();
        let scene = crate::scene::load_frame(&anim, f).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        scene
    }

    /// A floor record beside a ball resting on the floor, closer to the ball than its lift, still finds
    /// the floor (it was carried along with the ball, a dark record at the ball's contact that the ball
    /// pushed ahead of it); a record on the ball's side finds nothing once the ball has moved.
    #[test]
    fn a_record_in_the_gap_under_a_ball_keeps_its_floor() {
        let (frame0, frame1) = (anim_ball_frames(0, "gap"), anim_ball_frames(1, "gap"));
        // 96 px across the box: a lift of 6.8 mm, the gap 4.5 cm from the contact about 4 mm.
        let rec = |pos: Vec3, normal: Vec3| record(pos, normal, 1.0, 0.2, 0.0676);
        // The ball (radius 0.25) rests at x = -0.6, z = 0.3 in frame 0.
        let floor = rec(Vec3::new(-0.6 + 0.03, 0.0, 0.3 + 0.033), Vec3::Y);
        let gap = 0.25 - (0.25f32 * 0.25 - (0.03f32 * 0.03 + 0.033 * 0.033)).sqrt();
        assert!(gap < 0.1 * floor.pixel_world, "gap {gap}");
        let hit = surface_at(&frame0, &floor).expect("the floor is still there");
        assert!(hit.p.y.abs() < 1e-4, "{:?}", hit.p);
        let side = rec(Vec3::new(-0.85, 0.25, 0.3), -Vec3::X);
        let on_ball = surface_at(&frame0, &side).expect("the ball's side in frame 0");
        assert!((on_ball.p.x + 0.85).abs() < 0.01, "{:?}", on_ball.p);
        assert!(surface_at(&frame1, &side).is_none(), "the ball moved on");
    }
}
