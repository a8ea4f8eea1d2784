//! Keyframed scenes: `[animation]` and the `key` tables of the camera, meshes and lights, checked when
//! the scene is loaded, and each frame's scene file made from them by linear interpolation.
//!
//! Each keyable value is a track of its own: between two keys that set it, it is interpolated per
//! component; before its first key and after its last it holds that key's value; a value no key sets
//! keeps the base value. `rotate` is interpolated in degrees per axis and applied, as in a still, in the
//! order scale → rotate → translate.

use std::path::{Path, PathBuf};

use super::context::Ctx;
use super::file::{self, line_of_path, Scale, SceneFile};
use crate::error::{at_line, Error, Result};

/// Most frames of a sequence.
pub const MAX_FRAMES: i64 = 1_000_000;

/// A scene file with `[animation]`: its base values, keys, and the number of frames.
#[derive(Clone, Debug)]
pub struct Animation {
    path: PathBuf,
    text: String,
    desc: SceneFile,
    frames: u32,
    /// The file without its keys, and each keyed value's track: a frame's scene file costs its
    /// values' binary searches, not a pass over every key.
    base: SceneFile,
    tracks: Tracks,
    /// The OBJ files the frames read, each read once for the whole sequence.
    held: std::sync::Arc<super::held::HeldInputs>,
}

/// The tracks of every keyable value, made once.
#[derive(Clone, Debug)]
struct Tracks {
    /// eye, target, up.
    camera: [Track<[f32; 3]>; 3],
    fov: Track<f32>,
    /// Per mesh: scale (per axis), rotate, translate.
    meshes: Vec<[Track<[f32; 3]>; 3]>,
    /// Per light: position, target, direction, intensity, irradiance.
    lights: Vec<[Track<[f32; 3]>; 5]>,
}

impl Tracks {
    fn new(desc: &SceneFile) -> Tracks {
        let ck = &desc.camera.key;
        Tracks {
            camera: [
                Track::new(ck.iter().map(|k| (k.frame, k.eye))),
                Track::new(ck.iter().map(|k| (k.frame, k.target))),
                Track::new(ck.iter().map(|k| (k.frame, k.up))),
            ],
            fov: Track::new(ck.iter().map(|k| (k.frame, k.fov))),
            meshes: desc
                .mesh
                .iter()
                .map(|m| {
                    [
                        Track::new(m.key.iter().map(|k| (k.frame, k.scale.map(per_axis)))),
                        Track::new(m.key.iter().map(|k| (k.frame, k.rotate))),
                        Track::new(m.key.iter().map(|k| (k.frame, k.translate))),
                    ]
                })
                .collect(),
            lights: desc
                .light
                .iter()
                .map(|l| {
                    [
                        Track::new(l.key.iter().map(|k| (k.frame, k.position))),
                        Track::new(l.key.iter().map(|k| (k.frame, k.target))),
                        Track::new(l.key.iter().map(|k| (k.frame, k.direction))),
                        Track::new(l.key.iter().map(|k| (k.frame, k.intensity))),
                        Track::new(l.key.iter().map(|k| (k.frame, k.irradiance))),
                    ]
                })
                .collect(),
        }
    }
}

/// What moves between frames, for deciding what a frame may reuse from the one before.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Change {
    /// The camera moved or changed its field of view.
    pub camera: bool,
    /// A mesh moved or a light changed: light transport differs.
    pub scene: bool,
}

impl Animation {
    /// Checks `[animation]` and every key (`None` for a still scene: no `[animation]`, no keys).
    pub(super) fn new(path: &Path, text: &str, desc: &SceneFile) -> Result<Option<Animation>> {
        let cx = Ctx { path, text };
        let Some(anim) = &desc.animation else {
            return match first_key(desc) {
                Some(keys) => Err(at_line(
                    path,
                    line_of_path(text, &keys.0, &keys.1),
                    "a key needs an [animation] table giving the number of frames",
                )),
                None => Ok(None),
            };
        };
        if !(1..=MAX_FRAMES).contains(&anim.frames) {
            return Err(cx.err(
                "animation",
                0,
                "frames",
                format!("{} must be in 1..={MAX_FRAMES}", anim.frames),
            ));
        }
        let frames = anim.frames as u32;
        check_frames(
            &cx,
            "camera",
            0,
            desc.camera.key.iter().map(|k| k.frame),
            frames,
        )?;
        for (i, m) in desc.mesh.iter().enumerate() {
            check_frames(&cx, "mesh", i, m.key.iter().map(|k| k.frame), frames)?;
        }
        for (i, l) in desc.light.iter().enumerate() {
            check_frames(&cx, "light", i, l.key.iter().map(|k| k.frame), frames)?;
            check_light_keys(&cx, i, l)?;
        }
        check_finite_keys(&cx, desc)?;
        let mut base = desc.clone();
        base.camera.key.clear();
        base.mesh.iter_mut().for_each(|m| m.key.clear());
        base.light.iter_mut().for_each(|l| l.key.clear());
        base.animation = None;
        Ok(Some(Animation {
            path: path.to_path_buf(),
            text: text.to_string(),
            desc: desc.clone(),
            frames,
            tracks: Tracks::new(desc),
            base,
            held: Default::default(),
        }))
    }

    /// The inputs the frames read, held for the sequence.
    pub(super) fn held(&self) -> &super::held::HeldInputs {
        &self.held
    }

    pub fn frames(&self) -> u32 {
        self.frames
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub(super) fn text(&self) -> &str {
        &self.text
    }

    /// The scene file of frame `f`: every keyed value at that frame, no keys left.
    pub(super) fn frame_desc(&self, f: u32) -> SceneFile {
        let mut d = self.base.clone();
        let t = &self.tracks;
        let c = &mut d.camera;
        c.eye = t.camera[0].at(Some(c.eye), f).unwrap_or(c.eye);
        c.target = t.camera[1].at(Some(c.target), f).unwrap_or(c.target);
        c.up = t.camera[2].at(c.up, f);
        c.fov = t.fov.at(Some(c.fov), f).unwrap_or(c.fov);
        for (m, [scale, rotate, translate]) in d.mesh.iter_mut().zip(&t.meshes) {
            m.scale = scale.at(m.scale.map(per_axis), f).map(Scale::PerAxis);
            m.rotate = rotate.at(m.rotate, f);
            m.translate = translate.at(m.translate, f);
        }
        for (l, [position, target, direction, intensity, irradiance]) in
            d.light.iter_mut().zip(&t.lights)
        {
            l.position = position.at(l.position, f);
            l.target = target.at(l.target, f);
            l.direction = direction.at(l.direction, f);
            l.intensity = intensity.at(l.intensity, f);
            l.irradiance = irradiance.at(l.irradiance, f);
        }
        d
    }

    /// Whether `[[mesh]]` entry `m` bounds a medium (it has an `interior`).
    pub(super) fn is_boundary(&self, m: usize) -> bool {
        self.desc.mesh.get(m).is_some_and(|d| d.interior.is_some())
    }

    /// The line to name when the lights of frame `f` have no power: of the keys that set a light's
    /// intensity or irradiance, the last at or before `f` (else the first after it); the first light's
    /// table when no key sets one.
    pub(super) fn light_power_line(&self, f: u32) -> usize {
        let candidates = ["intensity", "irradiance"].into_iter().flat_map(|field| {
            let entries = self.keys_setting("light", field).unwrap_or_default();
            entries.into_iter().enumerate().flat_map(move |(i, keys)| {
                keys.into_iter()
                    .enumerate()
                    .filter(|(_, (_, sets))| *sets)
                    .map(move |(k, (frame, _))| ((i, k, field), frame))
            })
        });
        match nearest_key(candidates, f) {
            Some((i, k, field)) => line_of_path(&self.text, &["light", "key", field], &[i, k]),
            None => line_of_path(&self.text, &["light"], &[0]),
        }
    }

    /// Per entry of `table` (the camera, each mesh, each light), its keys' frames and whether each sets
    /// `field`; `None` for a table without keys.
    fn keys_setting(&self, table: &str, field: &str) -> Option<Vec<Vec<(i64, bool)>>> {
        Some(match table {
            "camera" => vec![self
                .desc
                .camera
                .key
                .iter()
                .map(|k| {
                    (
                        k.frame,
                        match field {
                            "eye" => k.eye.is_some(),
                            "target" => k.target.is_some(),
                            "up" => k.up.is_some(),
                            "fov" => k.fov.is_some(),
                            _ => false,
                        },
                    )
                })
                .collect()],
            "mesh" => self
                .desc
                .mesh
                .iter()
                .map(|m| {
                    m.key
                        .iter()
                        .map(|k| {
                            (
                                k.frame,
                                match field {
                                    "scale" => k.scale.is_some(),
                                    "rotate" => k.rotate.is_some(),
                                    "translate" => k.translate.is_some(),
                                    _ => false,
                                },
                            )
                        })
                        .collect()
                })
                .collect(),
            "light" => self
                .desc
                .light
                .iter()
                .map(|l| {
                    l.key
                        .iter()
                        .map(|k| {
                            (
                                k.frame,
                                match field {
                                    "position" => k.position.is_some(),
                                    "target" => k.target.is_some(),
                                    "direction" => k.direction.is_some(),
                                    "intensity" => k.intensity.is_some(),
                                    "irradiance" => k.irradiance.is_some(),
                                    _ => false,
                                },
                            )
                        })
                        .collect()
                })
                .collect(),
            _ => return None,
        })
    }

    /// What differs between frames `a` and `b`.
    pub fn change(&self, a: u32, b: u32) -> Change {
        let (da, db) = (self.frame_desc(a), self.frame_desc(b));
        let cam = |d: &SceneFile| {
            let c = &d.camera;
            (c.eye, c.target, c.up, c.fov.to_bits())
        };
        Change {
            camera: cam(&da) != cam(&db),
            scene: moving_values(&da) != moving_values(&db),
        }
    }

    /// The `[[mesh]]` entries placed differently at frames `a` and `b`.
    pub fn moved_meshes(&self, a: u32, b: u32) -> Vec<usize> {
        let (da, db) = (self.frame_desc(a), self.frame_desc(b));
        let place = |m: &file::MeshDesc| (m.scale.map(per_axis), m.rotate, m.translate);
        (0..da.mesh.len())
            .filter(|&i| place(&da.mesh[i]) != place(&db.mesh[i]))
            .collect()
    }

    /// Whether a light differs between frames `a` and `b`.
    pub fn lights_changed(&self, a: u32, b: u32) -> bool {
        let (da, db) = (self.frame_desc(a), self.frame_desc(b));
        let values =
            |l: &file::LightDesc| (l.position, l.target, l.direction, l.intensity, l.irradiance);
        da.light
            .iter()
            .zip(&db.light)
            .any(|(x, y)| values(x) != values(y))
    }

    /// Checks the camera, mesh placements and lights of every frame (interpolation between valid keys
    /// may still pass through an invalid value: a scale through zero, an eye through its target).
    pub(super) fn check_every_frame(
        &self,
        check: impl Fn(&Ctx, &SceneFile) -> Result<()>,
    ) -> Result<()> {
        let cx = Ctx {
            path: &self.path,
            text: &self.text,
        };
        let mut overflow = self.first_overflow();
        for f in 0..self.frames {
            if let Some((_, e)) = overflow.take_if(|(at, _)| *at == i64::from(f)) {
                return Err(at_frame(e, f));
            }
            check(&cx, &self.frame_desc(f)).map_err(|e| at_frame(self.at_key(e, f), f))?;
        }
        Ok(())
    }

    /// The first frame where interpolating a keyed value overflows f32 (see [`Track::overflow`]),
    /// and the error that names the key before it: the key whose value the frame moves away from.
    fn first_overflow(&self) -> Option<(i64, Error)> {
        let t = &self.tracks;
        let camera = ["eye", "target", "up"]
            .into_iter()
            .zip(&t.camera)
            .map(|(field, track)| ("camera", 0, field, track.overflow()))
            .chain([("camera", 0, "fov", t.fov.overflow())]);
        let meshes = t.meshes.iter().enumerate().flat_map(|(i, tracks)| {
            ["scale", "rotate", "translate"]
                .into_iter()
                .zip(tracks)
                .map(move |(field, track)| ("mesh", i, field, track.overflow()))
        });
        let lights = t.lights.iter().enumerate().flat_map(|(i, tracks)| {
            ["position", "target", "direction", "intensity", "irradiance"]
                .into_iter()
                .zip(tracks)
                .map(move |(field, track)| ("light", i, field, track.overflow()))
        });
        let (table, i, field, o) = camera
            .chain(meshes)
            .chain(lights)
            .filter_map(|(table, i, field, o)| Some((table, i, field, o?)))
            .min_by_key(|(.., o)| o.frame)?;
        let line = |k: usize| {
            let indices = if table == "camera" {
                vec![k]
            } else {
                vec![i, k]
            };
            line_of_path(&self.text, &[table, "key", field], &indices)
        };
        let [a, b] = o.values;
        let msg = format!(
            "{table}.{field}: this key's {a:?} and the next key's {b:?} (line {}) differ by more \
             than f32's range ({max:.1e}), so the frames between them overflow; keep consecutive \
             keys within {max:.1e} of each other",
            line(o.keys[1]),
            max = f32::MAX
        );
        Some((o.frame, at_line(&self.path, line(o.keys[0]), msg)))
    }

    /// An error about a keyed value of frame `f` ("file:line: table.field: …", the line of the base
    /// value or of its table) moved to the line of the key that set that value at `f`: the last key
    /// at or before `f` that sets it, else the first after. Unchanged when no key sets it.
    fn at_key(&self, e: Error, f: u32) -> Error {
        self.at_key_picked(e, f, nearest_key)
    }

    /// [`Self::at_key`] at the key frame `f`'s value moves toward: the first at or after `f` that
    /// sets it, else the last before. Of the frames checked in order, the first whose power grew
    /// past the cap lies before the key past it.
    pub(super) fn at_key_toward(&self, e: Error, f: u32) -> Error {
        self.at_key_picked(e, f, next_key)
    }

    /// [`Self::at_key`] at the key `pick` chooses of (key index, frame).
    fn at_key_picked(
        &self,
        e: Error,
        f: u32,
        pick: fn(std::vec::IntoIter<(usize, i64)>, u32) -> Option<usize>,
    ) -> Error {
        let Error::Input(msg) = &e else {
            return e;
        };
        let Some((at, what)) = msg.split_once(": ") else {
            return e;
        };
        let Some((table, field)) = what
            .split_once(": ")
            .and_then(|(name, _)| name.split_once('.'))
        else {
            return e;
        };
        let Some(line) = at
            .rsplit_once(':')
            .and_then(|(_, l)| l.parse::<usize>().ok())
        else {
            return e;
        };
        let Some(entries) = self.keys_setting(table, field) else {
            return e;
        };
        let array = table != "camera";
        let indices = |i: usize, rest: &[usize]| -> Vec<usize> {
            if array {
                [&[i], rest].concat()
            } else {
                rest.to_vec()
            }
        };
        let Some(i) = (0..entries.len()).find(|&i| {
            line == line_of_path(&self.text, &[table, field], &indices(i, &[]))
                || line == line_of_path(&self.text, &[table], &indices(i, &[]))
        }) else {
            return e;
        };
        let setting = entries[i]
            .iter()
            .enumerate()
            .filter(|(_, (_, sets))| *sets)
            .map(|(k, &(frame, _))| (k, frame))
            .collect::<Vec<_>>();
        let Some(k) = pick(setting.into_iter(), f) else {
            return e;
        };
        at_line(
            &self.path,
            line_of_path(&self.text, &[table, "key", field], &indices(i, &[k])),
            what,
        )
    }
}

/// Of keys (what, frame), the one a value at frame `f` moves toward: the first at or after `f`,
/// else the last before it.
fn next_key<T>(keys: impl Iterator<Item = (T, i64)>, f: u32) -> Option<T> {
    let f = f as i64;
    keys.max_by_key(|&(_, k)| if k >= f { (true, -k) } else { (false, k) })
        .map(|(t, _)| t)
}

/// Of keys (what, frame), the one that sets a value at frame `f`: the last at or before `f`, else
/// the first after it.
fn nearest_key<T>(keys: impl Iterator<Item = (T, i64)>, f: u32) -> Option<T> {
    let f = f as i64;
    keys.max_by_key(|&(_, k)| if k <= f { (true, k) } else { (false, -k) })
        .map(|(t, _)| t)
}

/// The values keys can change that affect light transport (mesh placements and light values), as bits.
fn moving_values(d: &SceneFile) -> Vec<u32> {
    let mut v = Vec::new();
    let mut put = |x: Option<[f32; 3]>| match x {
        Some(a) => v.extend(a.iter().map(|c| c.to_bits())),
        None => v.push(u32::MAX),
    };
    for m in &d.mesh {
        put(m.scale.map(per_axis));
        put(m.rotate);
        put(m.translate);
    }
    for l in &d.light {
        put(l.position);
        put(l.target);
        put(l.direction);
        put(l.intensity);
        put(l.irradiance);
    }
    v
}

/// An error of one frame's values, saying which frame.
pub fn at_frame(e: Error, f: u32) -> Error {
    match e {
        Error::Input(msg) => {
            // "file:line: what" → "file:line: frame f: what".
            match msg.split_once(": ") {
                Some((at, what)) => Error::Input(format!("{at}: frame {f}: {what}")),
                None => Error::Input(format!("frame {f}: {msg}")),
            }
        }
        other => other,
    }
}

fn per_axis(s: Scale) -> [f32; 3] {
    match s {
        Scale::Uniform(s) => [s; 3],
        Scale::PerAxis(a) => a,
    }
}

/// A value that can be interpolated linearly.
trait Lerp: Copy {
    fn lerp(a: Self, b: Self, t: f32) -> Self;

    /// The first pair of components, both finite, whose difference overflows f32: [`Lerp::lerp`]
    /// between `a` and `b` is infinite there for every `t` strictly between 0 and 1.
    fn overflowing(a: Self, b: Self) -> Option<[f32; 2]>;
}

impl Lerp for f32 {
    fn lerp(a: f32, b: f32, t: f32) -> f32 {
        // Exact at both ends, so a key's frame shows the key's value.
        if t <= 0.0 {
            a
        } else if t >= 1.0 {
            b
        } else {
            a + (b - a) * t
        }
    }

    fn overflowing(a: f32, b: f32) -> Option<[f32; 2]> {
        (a.is_finite() && b.is_finite() && !(b - a).is_finite()).then_some([a, b])
    }
}

impl Lerp for [f32; 3] {
    fn lerp(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
        std::array::from_fn(|i| f32::lerp(a[i], b[i], t))
    }

    fn overflowing(a: [f32; 3], b: [f32; 3]) -> Option<[f32; 2]> {
        (0..3).find_map(|i| f32::overflowing(a[i], b[i]))
    }
}

/// One keyable value's keys that set it, in frame order: frame, value, and the key's index among its
/// table's keys in the file (for messages).
#[derive(Clone, Debug)]
struct Track<T>(Vec<(i64, T, usize)>);

/// Two consecutive keys of a track whose interpolation overflows ([`Track::overflow`]).
struct Overflow {
    /// The first frame between them.
    frame: i64,
    /// The keys' indices in the file, the earlier first.
    keys: [usize; 2],
    /// Their values of the first component that overflows.
    values: [f32; 2],
}

impl<T: Lerp> Track<T> {
    fn new(keys: impl Iterator<Item = (i64, Option<T>)>) -> Track<T> {
        let mut set: Vec<(i64, T, usize)> = keys
            .enumerate()
            .filter_map(|(i, (k, v))| Some((k, v?, i)))
            .collect();
        set.sort_by_key(|(k, ..)| *k);
        Track(set)
    }

    /// The first consecutive keys, both finite and with a frame between them, whose values differ by
    /// more than f32's range: every frame between them would be infinite.
    fn overflow(&self) -> Option<Overflow> {
        self.0.windows(2).find_map(|w| {
            let ((k0, a, i0), (k1, b, i1)) = (w[0], w[1]);
            let values = T::overflowing(a, b).filter(|_| k1 - k0 > 1)?;
            Some(Overflow {
                frame: k0 + 1,
                keys: [i0, i1],
                values,
            })
        })
    }

    /// The value at frame `f`: `base` where no key sets it, else held before the first key and after
    /// the last, linear between neighbours.
    fn at(&self, base: Option<T>, f: u32) -> Option<T> {
        let set = &self.0;
        let f = f as i64;
        let (first, last) = match (set.first(), set.last()) {
            (Some(a), Some(b)) => (*a, *b),
            _ => return base,
        };
        if f <= first.0 {
            return Some(first.1);
        }
        if f >= last.0 {
            return Some(last.1);
        }
        let i = set.partition_point(|(k, ..)| *k <= f);
        let ((k0, v0, _), (k1, v1, _)) = (set[i - 1], set[i]);
        Some(T::lerp(v0, v1, (f - k0) as f32 / (k1 - k0) as f32))
    }
}

/// Every key's frame lies in the sequence, and no two keys of one object share a frame.
fn check_frames(
    cx: &Ctx,
    table: &str,
    index: usize,
    frames_of_keys: impl Iterator<Item = i64>,
    frames: u32,
) -> Result<()> {
    let mut seen = std::collections::HashSet::new();
    // The line is looked up only for an error: finding it reads the file's text.
    let line = |k: usize| line_of_path(cx.text, &[table, "key", "frame"], &[index, k]);
    for (k, f) in frames_of_keys.enumerate() {
        if !(0..frames as i64).contains(&f) {
            return Err(at_line(
                cx.path,
                line(k),
                format!(
                    "{table}.key.frame: {f} is outside the sequence 0..={}",
                    frames - 1
                ),
            ));
        }
        if !seen.insert(f) {
            return Err(at_line(
                cx.path,
                line(k),
                format!("{table}.key.frame: a second key of this {table} at frame {f}"),
            ));
        }
    }
    Ok(())
}

/// A light's keys set only values its type has.
fn check_light_keys(cx: &Ctx, i: usize, l: &file::LightDesc) -> Result<()> {
    let allowed: &[&str] = match l.kind.as_str() {
        "point" => &["position", "intensity"],
        "spot" => &["position", "target", "intensity"],
        "directional" => &["direction", "irradiance"],
        // An unknown type is reported by the light loader.
        _ => return Ok(()),
    };
    for (k, key) in l.key.iter().enumerate() {
        let given = [
            ("position", key.position.is_some()),
            ("target", key.target.is_some()),
            ("direction", key.direction.is_some()),
            ("intensity", key.intensity.is_some()),
            ("irradiance", key.irradiance.is_some()),
        ];
        if let Some((name, _)) = given.iter().find(|(n, g)| *g && !allowed.contains(n)) {
            return Err(at_line(
                cx.path,
                line_of_path(cx.text, &["light", "key", name], &[i, k]),
                format!("light.key.{name}: a {} light has no {name}", l.kind),
            ));
        }
    }
    Ok(())
}

/// Every key's values are finite numbers, each refused at its own line: a NaN or infinite key makes
/// every frame it is interpolated into NaN, and the check of those frames would name the key before
/// it (the one setting the value at the first such frame).
fn check_finite_keys(cx: &Ctx, desc: &SceneFile) -> Result<()> {
    let check = |table: &str, indices: &[usize], field: &str, v: Option<&[f32]>| match v
        .and_then(|v| v.iter().find(|x| !x.is_finite()))
    {
        Some(x) => Err(at_line(
            cx.path,
            line_of_path(cx.text, &[table, "key", field], indices),
            format!("{table}.key.{field}: {x} is not a finite number"),
        )),
        None => Ok(()),
    };
    for (k, key) in desc.camera.key.iter().enumerate() {
        check("camera", &[k], "eye", key.eye.as_ref().map(|v| &v[..]))?;
        check(
            "camera",
            &[k],
            "target",
            key.target.as_ref().map(|v| &v[..]),
        )?;
        check("camera", &[k], "up", key.up.as_ref().map(|v| &v[..]))?;
        check(
            "camera",
            &[k],
            "fov",
            key.fov.as_ref().map(std::slice::from_ref),
        )?;
    }
    for (i, m) in desc.mesh.iter().enumerate() {
        for (k, key) in m.key.iter().enumerate() {
            let scale = key.scale.map(per_axis);
            check("mesh", &[i, k], "scale", scale.as_ref().map(|v| &v[..]))?;
            check(
                "mesh",
                &[i, k],
                "rotate",
                key.rotate.as_ref().map(|v| &v[..]),
            )?;
            check(
                "mesh",
                &[i, k],
                "translate",
                key.translate.as_ref().map(|v| &v[..]),
            )?;
        }
    }
    for (i, l) in desc.light.iter().enumerate() {
        for (k, key) in l.key.iter().enumerate() {
            let fields = [
                ("position", key.position),
                ("target", key.target),
                ("direction", key.direction),
                ("intensity", key.intensity),
                ("irradiance", key.irradiance),
            ];
            for (field, v) in fields {
                check("light", &[i, k], field, v.as_ref().map(|v| &v[..]))?;
            }
        }
    }
    Ok(())
}

/// The path and indices of the first key in the file, for the error when `[animation]` is missing.
type KeyPath = (Vec<&'static str>, Vec<usize>);

fn first_key(desc: &SceneFile) -> Option<KeyPath> {
    if !desc.camera.key.is_empty() {
        return Some((vec!["camera", "key"], vec![0]));
    }
    if let Some(i) = desc.mesh.iter().position(|m| !m.key.is_empty()) {
        return Some((vec!["mesh", "key"], vec![i, 0]));
    }
    desc.light
        .iter()
        .position(|l| !l.key.is_empty())
        .map(|i| (vec!["light", "key"], vec![i, 0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track<T: Lerp>(
        base: Option<T>,
        keys: impl Iterator<Item = (i64, Option<T>)>,
        f: u32,
    ) -> Option<T> {
        Track::new(keys).at(base, f)
    }

    #[test]
    fn the_key_that_sets_a_value_is_the_last_before_else_the_first_after() {
        let keys = || [("a", 2), ("b", 6), ("c", 9)].into_iter();
        assert_eq!(nearest_key(keys(), 7), Some("b"));
        assert_eq!(nearest_key(keys(), 6), Some("b"));
        assert_eq!(nearest_key(keys(), 20), Some("c"));
        assert_eq!(nearest_key(keys(), 0), Some("a"));
        assert_eq!(nearest_key(std::iter::empty::<((), i64)>(), 3), None);
    }

    #[test]
    fn a_track_holds_before_and_after_its_keys_and_is_linear_between() {
        let keys = [(10, Some(1.0f32)), (20, Some(3.0)), (15, None)];
        let at = |f| track(Some(0.0), keys.iter().copied(), f).unwrap();
        assert_eq!(at(0), 1.0);
        assert_eq!(at(10), 1.0);
        assert_eq!(at(15), 2.0);
        assert_eq!(at(20), 3.0);
        assert_eq!(at(99), 3.0);
        assert_eq!(track(Some(5.0f32), [(3, None)].into_iter(), 7), Some(5.0));
        assert_eq!(track::<f32>(None, std::iter::empty(), 7), None);
    }

    /// Keys whose difference overflows f32 are found where a frame lies between them, named by
    /// their indices in the file; keys as far apart as f32 allows, or with no frame between, are not.
    #[test]
    fn an_overflowing_interpolation_is_found_between_its_keys() {
        let keys = [
            (6, Some([0.0f32, -3e38, 0.0])),
            (0, Some([0.0, 1.0, 0.0])),
            (2, Some([0.0, 3e38, 0.0])),
        ];
        let o = Track::new(keys.into_iter()).overflow().unwrap();
        assert_eq!((o.frame, o.keys, o.values), (3, [2, 0], [3e38, -3e38]));
        // What the check keeps from the frames: every one between those keys is infinite.
        assert!((3..6).all(|f| !track(None, keys.into_iter(), f).unwrap()[1].is_finite()));
        let near = [(0, Some(1.7e38f32)), (4, Some(-1.6e38))];
        assert!(Track::new(near.into_iter()).overflow().is_none());
        assert!(track(None, near.into_iter(), 2).unwrap().is_finite());
        let adjacent = [(0, Some(3e38f32)), (1, Some(-3e38))];
        assert!(Track::new(adjacent.into_iter()).overflow().is_none());
    }

    #[test]
    fn keys_in_any_order_give_the_same_track() {
        let a = [(0, Some([0.0f32, 0.0, 0.0])), (4, Some([4.0, 8.0, -4.0]))];
        let b = [a[1], a[0]];
        for f in 0..6 {
            assert_eq!(track(None, a.into_iter(), f), track(None, b.into_iter(), f));
        }
        assert_eq!(track(None, a.into_iter(), 1), Some([1.0, 2.0, -1.0]));
    }
}
