//! Progressive renders (`--passes N`, `--time SECONDS`, `[render] time`): a still made as a series of
//! passes, each a whole render of its own seed, the image their running mean — so that a longer wait
//! always buys a better image, which no fixed setting of the knobs does.
//!
//! Every pass of a method that bakes (`pm`, `pm-fg`, `photons`, `ao`) traces fresh photon maps and
//! fills a fresh cache, so that what one bake gets wrong by chance — a photon clump, records placed
//! where their interpolation errs — averages out over the passes instead of repeating:
//! - the photon estimates' radius shrinks as in progressive photon mapping with a global radius
//!   (Knaus & Zwicker 2011): pass i's k-NN lookups take the first's k times i^(α−1), α = 2/3 as in
//!   pbrt-v4 (a radius² ∝ k), and their radius caps shrink with them, so the maps' blur (bias) falls
//!   while the mean's noise still falls;
//! - the cache's accuracy tightens as i^−1/6 (records grow as i^1/3), and pass A traces each lattice
//!   pixel at a point of its own (a Halton shift), so records land elsewhere every pass;
//! - every pass samples each pixel up to the plan's cap again, so the mean's cap grows with the passes.
//!
//! `path` and `ao-direct` bake nothing: their passes are independent images of the plan's samples
//! (under a time budget, an eighth of them, so that the budget is met closely).
//!
//! Without a budget nothing here runs, and renders are those of [`super::render`]. A pass-bounded
//! render is reproducible at any thread count (each pass is); a time-bounded one is not (how many
//! passes fit depends on the machine). Pass 1 is the default render, so `--passes 1` is it exactly.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;

use super::stats::{ProgressiveStats, RenderStats, StopReason};
use super::{bake, budget, interrupted, plan, shade_and_finish, Options, Plan, RenderOutput};
use crate::camera::Camera;
use crate::error::{option, Error, Result};
use crate::io::output::Image;
use crate::progress::Progress;
use crate::scene::{Method, Scene, MIN_RECORD_REACH_PX};

/// How long a progressive render goes on: at most `passes` passes, and at most `seconds` of wall time
/// (whichever ends first); neither set: not a progressive render.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Budget {
    pub passes: Option<u32>,
    pub seconds: Option<f64>,
}

impl Budget {
    /// The command line's budget, else the scene's `[render] time`.
    pub fn of(scene: &Scene, opts: &Options) -> Budget {
        Budget {
            passes: opts.budget.passes,
            seconds: opts.budget.seconds.or(scene.settings.time),
        }
    }

    pub fn is_set(&self) -> bool {
        self.passes.is_some() || self.seconds.is_some()
    }
}

/// Most passes `--passes` asks for.
pub const MAX_PASSES: u32 = 1 << 20;

/// A sequence's frames are single passes: its temporal cache carries one pass's records from frame
/// to frame. A budget set for one is refused, naming where it was set.
pub fn refuse_in_sequence(scene: &Scene, opts: &Options) -> Result<()> {
    let refuse = |what: &str| {
        option(
            what,
            "is for stills: a sequence's frames are rendered in one pass each (its temporal cache \
             carries each frame's records to the next)",
        )
    };
    if opts.budget.passes.is_some() {
        return Err(refuse("--passes"));
    }
    if opts.budget.seconds.is_some() {
        return Err(refuse("--time"));
    }
    if scene.settings.time.is_some() {
        return Err(crate::error::at_line(
            &scene.path,
            time_line(scene),
            "[render] time is for stills: a sequence's frames are rendered in one pass each \
             (its temporal cache carries each frame's records to the next)",
        ));
    }
    Ok(())
}

/// A render from one shared bake (`--tiles`, a module's or a farm's bake) is one pass: a budget set
/// for one is refused.
pub fn refuse_in_bake(scene: &Scene, opts: &Options, what: &str) -> Result<()> {
    let why = format!("{what} renders one pass from one bake");
    if opts.budget.passes.is_some() {
        return Err(option("--passes", format!("{why}: leave out --passes")));
    }
    if opts.budget.seconds.is_some() {
        return Err(option("--time", format!("{why}: leave out --time")));
    }
    if scene.settings.time.is_some() {
        return Err(crate::error::at_line(
            &scene.path,
            time_line(scene),
            format!("[render] time: {why}; remove the time budget from the scene"),
        ));
    }
    Ok(())
}

/// The line of the scene file's `[render] time`.
fn time_line(scene: &Scene) -> usize {
    std::fs::read_to_string(&scene.path).map_or(1, |text| {
        crate::scene::file::line_of_key(&text, "render", 0, "time")
    })
}

/// Progressive photon mapping's α: pass i's lookup radius² is the first's times i^(α−1).
const ALPHA: f64 = 2.0 / 3.0;
/// Pass i's cache accuracy (Ward's a) is the first's times i^−ACCURACY_DECAY.
const ACCURACY_DECAY: f64 = 1.0 / 6.0;
/// The accuracy no pass tightens past (unless the first is already tighter): records grow as 1/a².
const MIN_ACCURACY: f32 = 0.15;
/// Pass i's least record spacing (pixels) is the first's times i^−SPACING_DECAY, down to
/// MIN_SPACING_PX.
const SPACING_DECAY: f64 = 0.5;
const MIN_SPACING_PX: f32 = 1.0;
/// Share of pass A's covered points that passes after the first gather at to check the records
/// there ([`icache::Validation`]): interpolation's bias repeats in every pass, averaging removes
/// only noise.
const VALIDATE_FRACTION: f32 = 1.0 / 16.0;
/// Relative error beyond the gathers' noise a record may have at a checked point.
const VALIDATE_TOLERANCE: f32 = 0.05;
/// Under a time budget, a pass of a method that bakes nothing takes this fraction of its samples.
const TIME_PASS_SPP_DIVISOR: u32 = 8;
/// Keys the seeds of passes after the first.
const PASS_KEY: u64 = 0x7061_7373;
/// The relMSE metric's denominator offset (tools/chart.py, tools/compare.py).
const RELMSE_EPS: f64 = 0.01;

/// Whether `method` bakes photon maps or a cache, which its passes make afresh.
fn bakes(method: Method) -> bool {
    method.uses_photon_maps() || method == Method::Ao
}

/// The plan of pass `i` (from 1) of a progressive render whose first pass is `first`; `timed`: under
/// a time budget.
pub fn pass_plan(first: &Plan, i: u32, timed: bool) -> Plan {
    let mut p = first.clone();
    if i > 1 {
        p.seed = photon::sampling::hash_keys(&[first.seed, PASS_KEY, u64::from(i)]);
        p.pass_a_shift = [halton(i - 1, 2), halton(i - 1, 3)];
    }
    if bakes(first.method) {
        let r2 = f64::from(i).powf(ALPHA - 1.0);
        let floor = (crate::scene::MIN_LOOKUP as usize).min(first.photons.lookup);
        p.photons.lookup = ((first.photons.lookup as f64 * r2).round() as usize).max(floor);
        // The caps shrink with the radius the lookups reach: r ∝ √k.
        let shrink = (p.photons.lookup as f64 / first.photons.lookup as f64).sqrt() as f32;
        p.photons.max_radius_global *= shrink;
        p.photons.max_radius_caustic *= shrink;
        p.photons.max_radius_volume *= shrink;
        p.photons.max_radius_volume_caustic *= shrink;
        let tighten = f64::from(i).powf(-ACCURACY_DECAY) as f32;
        p.cache.accuracy = tightened(first.cache.accuracy, tighten);
        p.cache.pass_b_accuracy = first.cache.pass_b_accuracy.map(|a| tightened(a, tighten));
        // The spacing clamp's bias (records kept apart across a thin gap, a crease) vanishes with it.
        // Never below the least reach a scene file may ask for (accuracy × spacing, in pixels).
        let spacing = f64::from(i).powf(-SPACING_DECAY) as f32;
        let least = (MIN_RECORD_REACH_PX / p.cache.accuracy).max(MIN_SPACING_PX);
        p.cache.min_spacing_px =
            (first.cache.min_spacing_px * spacing).max(least.min(first.cache.min_spacing_px));
        if i > 1 {
            p.cache_validation = Some(icache::Validation {
                fraction: VALIDATE_FRACTION,
                seed: p.seed,
                tolerance: VALIDATE_TOLERANCE,
            });
        }
    } else if timed {
        p.spp = (first.spp / TIME_PASS_SPP_DIVISOR).max(1);
        p.aa_spp = first.aa_spp.min(p.spp);
    }
    p
}

/// Accuracy `a` times `factor`, down to [`MIN_ACCURACY`] (or `a`, if tighter already).
fn tightened(a: f32, factor: f32) -> f32 {
    (a * factor).max(MIN_ACCURACY.min(a))
}

/// The radical inverse of `i` in `base`: a pass's pass-A shift, in [0, 1).
fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f64, 0.0f64);
    while i > 0 {
        f /= f64::from(base);
        r += f * f64::from(i % base);
        i /= base;
    }
    r as f32
}

/// The files a progressive render cannot make or read: each pass traces its own maps and fills its
/// own cache.
pub fn check_files(opts: &Options, budget: &Budget) -> Result<()> {
    let name = if budget.passes.is_some() {
        "--passes"
    } else {
        "--time"
    };
    let f = &opts.files;
    for (opt, given) in [
        ("--load-photons", f.load_photons.is_some()),
        ("--save-photons", f.save_photons.is_some()),
        ("--dump-photons", f.dump_photons.is_some()),
        ("--load-cache", f.load_cache.is_some()),
        ("--save-cache", f.save_cache.is_some()),
    ] {
        if given {
            return Err(option(
                name,
                format!(
                    "makes every pass's photon maps and cache afresh: leave out {opt} \
                     (save or load them from a render without {name})"
                ),
            ));
        }
    }
    Ok(())
}

/// A render's beauty and its named layers.
type Images = (Image, Vec<(&'static str, Image)>);

/// The running mean of the passes' images and the spread of their luminance, per layer (beauty first).
struct Mean {
    names: Vec<&'static str>,
    /// Per layer, per pixel: the mean so far.
    mean: Vec<Vec<Vec3>>,
    /// Per layer, per pixel: Welford's sum of squared luminance deviations.
    m2: Vec<Vec<f32>>,
    passes: u32,
    width: u32,
    height: u32,
}

fn luminance(v: Vec3) -> f32 {
    0.2126 * v.x + 0.7152 * v.y + 0.0722 * v.z
}

impl Mean {
    fn new((beauty, layers): &Images) -> Mean {
        let n = beauty.pixels.len();
        let count = 1 + layers.len();
        Mean {
            names: std::iter::once("beauty")
                .chain(layers.iter().map(|(n, _)| *n))
                .collect(),
            mean: vec![vec![Vec3::ZERO; n]; count],
            m2: vec![vec![0.0; n]; count],
            passes: 0,
            width: beauty.width,
            height: beauty.height,
        }
    }

    /// One more pass's images taken in.
    fn add(&mut self, (beauty, layers): &Images) {
        self.passes += 1;
        let w = 1.0 / self.passes as f32;
        let images = std::iter::once(beauty).chain(layers.iter().map(|(_, im)| im));
        for ((mean, m2), image) in self.mean.iter_mut().zip(&mut self.m2).zip(images) {
            for ((m, s), &x) in mean.iter_mut().zip(m2.iter_mut()).zip(&image.pixels) {
                let before = luminance(*m);
                *m += (x - *m) * w;
                *s += (luminance(x) - before) * (luminance(x) - luminance(*m));
            }
        }
    }

    /// Per layer, the relMSE the mean's noise alone gives (the spread between passes over their
    /// number, against the mean's luminance, as the chart's metric); `None` before two passes.
    fn noise_relmse(&self) -> Vec<(&'static str, f64)> {
        if self.passes < 2 {
            return Vec::new();
        }
        let n = f64::from(self.passes);
        self.names
            .iter()
            .zip(self.mean.iter().zip(&self.m2))
            .map(|(name, (mean, m2))| {
                let sum: f64 = mean
                    .iter()
                    .zip(m2)
                    .map(|(m, &s)| {
                        let y = f64::from(luminance(*m));
                        (f64::from(s) / (n - 1.0) / n) / (y * y + RELMSE_EPS)
                    })
                    .sum();
                (*name, sum / mean.len().max(1) as f64)
            })
            .collect()
    }

    fn images(self) -> Images {
        let (w, h) = (self.width, self.height);
        let mut images = self.mean.into_iter().map(|pixels| Image {
            width: w,
            height: h,
            pixels,
        });
        let beauty = images.next().unwrap_or_else(|| Image::new(w, h));
        let layers = self.names[1..].iter().copied().zip(images).collect();
        (beauty, layers)
    }
}

/// A phase's progress labelled with its pass.
struct PassProgress<'a> {
    inner: &'a dyn Progress,
    pass: u32,
}

impl Progress for PassProgress<'_> {
    fn start(&self, phase: &str, total: u64) {
        self.inner
            .start(&format!("{phase} (pass {})", self.pass), total);
    }
    fn set(&self, done: u64) {
        self.inner.set(done);
    }
    fn finish(&self) {
        self.inner.finish();
    }
}

/// Renders `scene` progressively within `budget` (see the module header), seen by `camera` or the
/// scene's. A user's `cancel` after the first pass ends the render with the mean of the passes made
/// (its statistics say so); before it, `Interrupted`.
pub fn render_progressive(
    scene: &Scene,
    opts: &Options,
    budget: Budget,
    camera: Option<&Camera>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let start = Instant::now();
    check_files(opts, &budget)?;
    let first = plan(scene, opts, camera)?;
    budget::check(scene, &first, opts)?;
    // Set by the user's cancel, or once a pass is made and the budget is spent: the pass under way
    // is then dropped.
    let stop = AtomicBool::new(false);
    let made = AtomicBool::new(false);
    let finished = AtomicBool::new(false);
    let deadline = budget.seconds.map(|s| start + Duration::from_secs_f64(s));
    std::thread::scope(|s| {
        s.spawn(|| {
            while !finished.load(Ordering::Relaxed) {
                let late = deadline.is_some_and(|d| Instant::now() >= d);
                if cancel.load(Ordering::Relaxed) || (late && made.load(Ordering::Relaxed)) {
                    stop.store(true, Ordering::Relaxed);
                }
                std::thread::sleep(Duration::from_millis(5));
            }
        });
        let r = passes(
            scene,
            &first,
            opts,
            budget,
            start,
            (&stop, &made),
            progress,
            cancel,
        );
        finished.store(true, Ordering::Relaxed);
        r
    })
}

/// The passes of [`render_progressive`], from `start`, until `budget` ends or `stop` is set; `made`
/// is set once one is.
#[allow(clippy::too_many_arguments)]
fn passes(
    scene: &Scene,
    first: &Plan,
    opts: &Options,
    budget: Budget,
    start: Instant,
    (stop, made): (&AtomicBool, &AtomicBool),
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let timed = budget.seconds.is_some();
    let mut mean: Option<Mean> = None;
    let mut last = None;
    let mut total = ProgressiveStats {
        budget_s: budget.seconds,
        ..Default::default()
    };
    let mut shade = super::stats::ShadeStats::default();
    let mut last_pass_s = 0.0;
    let mut i = 1u32;
    let reason = loop {
        if budget.passes.is_some_and(|n| i > n) {
            break StopReason::Passes;
        }
        if let (Some(t), true) = (budget.seconds, i > 1) {
            // The next pass, as long as the last and for its records' growth, must fit.
            let growth = if bakes(first.method) {
                (f64::from(i) / f64::from(i - 1)).powf(2.0 * ACCURACY_DECAY)
            } else {
                1.0
            };
            if start.elapsed().as_secs_f64() + last_pass_s * growth > t {
                break StopReason::Time;
            }
        }
        if i == u32::MAX {
            break StopReason::Passes;
        }
        let p = pass_plan(first, i, timed);
        let t = Instant::now();
        let labelled = PassProgress {
            inner: progress,
            pass: i,
        };
        match one_pass(scene, &p, opts, &labelled, stop) {
            Ok((images, stats, output)) => {
                mean.get_or_insert_with(|| Mean::new(&images)).add(&images);
                total.add_pass(&stats, &p, first);
                shade.add(&stats.shade);
                last = Some((stats, output));
                made.store(true, Ordering::Relaxed);
            }
            Err(Error::Interrupted) if mean.is_some() => {
                break if cancel.load(Ordering::Relaxed) {
                    StopReason::Interrupted
                } else {
                    StopReason::Time
                };
            }
            Err(e) => return Err(e),
        }
        last_pass_s = t.elapsed().as_secs_f64();
        i += 1;
    };
    let (Some(mean), Some((mut stats, output))) = (mean, last) else {
        // No pass was made: only a cancel ends the loop so.
        interrupted(cancel)?;
        return Err(Error::Interrupted);
    };
    total.stopped = reason;
    total.noise_relmse = mean.noise_relmse();
    let first_pass_s = total.pass_s.first().copied().unwrap_or(0.0);
    if let Some(t) = budget.seconds.filter(|&t| first_pass_s > t) {
        total.warnings.push(format!(
            "the first pass took {first_pass_s:.2} s, past the time budget of {t} s (--time or \
             [render] time): the image is that one pass; lower --spp or the photon counts for a \
             shorter pass"
        ));
    }
    // Samples and their work summed over the passes; what counts pixels is the last pass's.
    let per_pass = stats.shade.samples;
    stats.shade = shade;
    let s = &mut stats.shade.samples;
    s.pixels = per_pass.pixels;
    s.at_limit = per_pass.at_limit;
    s.monte_carlo_pixels = per_pass.monte_carlo_pixels;
    s.redone_pixels = per_pass.redone_pixels;
    stats.total_s = start.elapsed().as_secs_f64();
    stats.progressive = Some(total);
    let (beauty, layers) = mean.images();
    Ok((
        RenderOutput {
            beauty,
            layers,
            ..output
        },
        stats,
    ))
}

/// One pass: the bake and the shading of `plan` (the still's phases), its images, statistics and
/// output (which keeps the pass's caches for `--cache-image`; its images are the mean's).
fn one_pass(
    scene: &Scene,
    plan: &Plan,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Images, RenderStats, RenderOutput)> {
    let start = Instant::now();
    let mut stats = RenderStats::new(scene, plan);
    let bake = bake(scene, plan, &opts.files, &mut stats, progress, cancel)?;
    let (mut output, stats) = shade_and_finish(scene, plan, bake, stats, start, progress, cancel)?;
    interrupted(cancel)?;
    let beauty = std::mem::replace(&mut output.beauty, Image::new(0, 0));
    let layers = std::mem::take(&mut output.layers);
    Ok(((beauty, layers), stats, output))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_points_fill_the_unit_interval() {
        let xs: Vec<f32> = (1..=4).map(|i| halton(i, 2)).collect();
        assert_eq!(xs, vec![0.5, 0.25, 0.75, 0.125]);
        assert!((1..1000).all(|i| (0.0..1.0).contains(&halton(i, 3))));
    }

    #[test]
    fn the_mean_of_two_passes_and_its_spread_are_the_textbook_ones() {
        let im = |v: f32| {
            (
                Image {
                    width: 1,
                    height: 1,
                    pixels: vec![Vec3::splat(v)],
                },
                Vec::new(),
            )
        };
        let mut m = Mean::new(&im(1.0));
        m.add(&im(1.0));
        m.add(&im(3.0));
        // Mean 2, sample variance 2, the mean's variance 1, over 2² + 0.01.
        let noise = m.noise_relmse();
        assert!((noise[0].1 - 1.0 / 4.01).abs() < 1e-6, "{noise:?}");
        let (beauty, _) = m.images();
        assert_eq!(beauty.pixels[0], Vec3::splat(2.0));
    }
}
