//! `render` of an animated scene: output patterns (`walk-####.exr`), `--frames A..B`, one progress
//! bar over the frames, each frame written as soon as it is done, and a sequence summary.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use indicatif::ProgressBar;
use serde_json::json;

use super::landing::Landings;
use super::{cli_inputs, styled_bar, RenderArgs};
use pmrender::error::{option, Error, Result};
use pmrender::render::outputs::{
    check_distinct_from, check_target, probe_writable, scene_inputs, KnownInputs,
};
use pmrender::render::sequence::render_sequence;
use pmrender::render::shared_bake::render_walk;
use pmrender::render::write::{write_outputs, OutputPaths, SequenceSummary};
use pmrender::render::{Options, Progress};
use pmrender::scene::Animation;
use pmrender::signal;

/// Frames whose outputs are checked between two reads of the interrupt flag (and reports of progress).
const CANCEL_EVERY: u32 = 1024;

/// An output path with one run of `#`, replaced by the frame number.
struct Pattern {
    opt: &'static str,
    /// The text before and after the run, and the run's length.
    head: String,
    tail: String,
    digits: usize,
}

impl Pattern {
    fn new(opt: &'static str, path: &Path) -> Result<Pattern> {
        let text = path
            .to_str()
            .ok_or_else(|| option(opt, format!("'{}' is not valid UTF-8", path.display())))?;
        let runs = text
            .as_bytes()
            .chunk_by(|a, b| (*a == b'#') == (*b == b'#'))
            .filter(|r| r[0] == b'#')
            .count();
        if runs != 1 {
            return Err(option(
                opt,
                format!(
                    "'{text}' must hold one run of # for the frame number (e.g. walk-####.exr): the scene is animated"
                ),
            ));
        }
        let start = text.find('#').unwrap_or(0);
        let digits = text[start..].bytes().take_while(|&b| b == b'#').count();
        // A frame number (a u32) has at most 10 digits; a longer run would only pad it with zeros.
        if digits > 10 {
            return Err(option(
                opt,
                format!("'{text}' has a run of {digits} #: a frame number takes at most 10"),
            ));
        }
        Ok(Pattern {
            opt,
            head: text[..start].to_string(),
            tail: text[start + digits..].to_string(),
            digits,
        })
    }

    fn at(&self, frame: u32) -> PathBuf {
        PathBuf::from(format!(
            "{}{:0width$}{}",
            self.head,
            frame,
            self.tail,
            width = self.digits
        ))
    }

    /// The run replaced by a word (the sequence summary's name). A run in a folder's name would make
    /// a folder no frame has (`out/d#/s.json` → `out/dsequence/`): the summary then goes beside the
    /// frames' folders, named after their file (`out/s-sequence.json`).
    fn named(&self, word: &str) -> PathBuf {
        let Some((_, file)) = self.tail.rsplit_once('/') else {
            return PathBuf::from(format!("{}{word}{}", self.head, self.tail));
        };
        let file = Path::new(file);
        let stem = file
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let name = match file.extension() {
            Some(e) => format!("{stem}-{word}.{}", e.to_string_lossy()),
            None => format!("{stem}-{word}"),
        };
        Path::new(&self.head)
            .parent()
            .unwrap_or(Path::new(""))
            .join(name)
    }
}

/// The frames `--frames A..B` asks for (inclusive; `N` alone is one frame), all by default.
fn frame_range(arg: Option<&str>, frames: u32) -> Result<std::ops::RangeInclusive<u32>> {
    let Some(s) = arg else {
        return Ok(0..=frames - 1);
    };
    let bad = || {
        option(
            "--frames",
            format!(
                "'{s}' is not a range A..B of frames within 0..{} (inclusive)",
                frames - 1
            ),
        )
    };
    let parse = |t: &str| t.trim().parse::<u32>().map_err(|_| bad());
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (parse(a)?, parse(b.trim_start_matches('='))?),
        None => {
            let n = parse(s)?;
            (n, n)
        }
    };
    if a > b || b >= frames {
        return Err(bad());
    }
    Ok(a..=b)
}

/// The outputs' patterns, in the order of [`outputs`].
struct Patterns {
    exr: Pattern,
    png: Option<Pattern>,
    stats: Option<Pattern>,
    cache_image: Option<Pattern>,
}

impl Patterns {
    fn new(a: &RenderArgs) -> Result<Patterns> {
        for (opt, given) in [
            ("--save-photons", a.save_photons.is_some()),
            ("--load-photons", a.load_photons.is_some()),
            ("--dump-photons", a.dump_photons.is_some()),
            ("--save-cache", a.save_cache.is_some()),
            ("--load-cache", a.load_cache.is_some()),
        ] {
            if given {
                return Err(option(
                    opt,
                    "is for still scenes: a sequence traces its photon maps and fills its cache as its frames need",
                ));
            }
        }
        let opt =
            |name, p: &Option<PathBuf>| p.as_deref().map(|p| Pattern::new(name, p)).transpose();
        Ok(Patterns {
            exr: Pattern::new("-o", &a.output)?,
            png: opt("--png", &a.png)?,
            stats: opt("--stats", &a.stats)?,
            cache_image: opt("--cache-image", &a.cache_image)?,
        })
    }

    fn at(&self, f: u32) -> OutputPaths {
        OutputPaths {
            exr: self.exr.at(f),
            png: self.png.as_ref().map(|p| p.at(f)),
            stats: self.stats.as_ref().map(|p| p.at(f)),
            cache_image: self.cache_image.as_ref().map(|p| p.at(f)),
            ..Default::default()
        }
    }

    /// Every frame's outputs can be written and none names an input. A directory is tried with a
    /// file once per length of name, not once per frame: creating and removing a file for each of a
    /// long sequence's frames is most of the check. Reports to `progress`; stops on `cancel`.
    fn check(
        &self,
        a: &RenderArgs,
        frames: &std::ops::RangeInclusive<u32>,
        progress: &dyn Progress,
        cancel: &AtomicBool,
    ) -> Result<()> {
        progress.start(
            "checking outputs",
            u64::from(frames.end() - frames.start()) + 1,
        );
        let mut inputs = scene_inputs(&a.scene);
        inputs.extend(cli_inputs(a));
        let inputs = KnownInputs::new(&inputs);
        let summary = self.stats.as_ref().map(|p| p.named("sequence"));
        // Outputs of different frames (or options) that are one file, found before any is written.
        let mut landings = Landings::default();
        if let Some(s) = &summary {
            landings.add(2, None, s)?;
        }
        let mut probed = HashSet::new();
        for f in frames.clone() {
            if f % CANCEL_EVERY == 0 {
                if cancel.load(Ordering::Relaxed) {
                    return Err(Error::Interrupted);
                }
                progress.set(u64::from(f - frames.start()));
            }
            let paths = self.at(f);
            let each = [
                Some(paths.exr.as_path()),
                paths.png.as_deref(),
                paths.stats.as_deref(),
                paths.cache_image.as_deref(),
            ];
            for (i, p) in each.into_iter().enumerate() {
                if let Some(p) = p {
                    landings.add(i, Some(f), p)?;
                }
            }
            let named: Vec<(&'static str, &Path)> = [
                (self.exr.opt, Some(paths.exr.as_path())),
                ("--png", paths.png.as_deref()),
                ("--stats", paths.stats.as_deref()),
                ("--cache-image", paths.cache_image.as_deref()),
                ("--stats", summary.as_deref()),
            ]
            .into_iter()
            .filter_map(|(o, p)| p.map(|p| (o, p)))
            .collect();
            for (opt, p) in &named {
                check_target(opt, p)?;
                let length = p.file_name().map_or(0, |n| n.len());
                if probed.insert((p.parent().map(Path::to_path_buf), length)) {
                    probe_writable(opt, p)?;
                }
            }
            check_distinct_from(&named, &inputs)?;
        }
        Ok(())
    }
}

/// One bar over the frames, its message naming the frame, the phase and how far the phase is (a phase
/// over the whole sequence, such as finding the movers' window, can take seconds before frame 0).
struct FramesBar {
    bar: ProgressBar,
    frame: AtomicU32,
    /// The current phase's name and total, and the percentage last shown.
    phase: Mutex<(String, u64)>,
    shown: AtomicU64,
}

impl FramesBar {
    fn new(quiet: bool, n: u64) -> FramesBar {
        let bar = styled_bar(
            quiet,
            n,
            "{msg:>28} [{bar:40}] {pos}/{len} frames {elapsed_precise} eta {eta}",
        );
        FramesBar {
            bar,
            frame: Default::default(),
            phase: Mutex::new((String::new(), 0)),
            shown: AtomicU64::new(u64::MAX),
        }
    }

    fn show(&self, name: &str, percent: Option<u64>) {
        let f = self.frame.load(Ordering::Relaxed);
        self.bar.set_message(match percent {
            Some(p) => format!("frame {f} {name} {p}%"),
            None => format!("frame {f} {name}"),
        });
    }
}

impl Progress for FramesBar {
    fn start(&self, phase: &str, total: u64) {
        if let Ok(mut p) = self.phase.lock() {
            *p = (phase.to_string(), total);
        }
        self.shown.store(u64::MAX, Ordering::Relaxed);
        self.show(phase, None);
    }
    /// Shows the phase's percentage when it changes (the phases call this from every worker).
    fn set(&self, done: u64) {
        let Ok(p) = self.phase.try_lock() else {
            return;
        };
        let (name, total) = &*p;
        if *total == 0 {
            return;
        }
        let percent = (done.min(*total) * 100) / total;
        if self.shown.swap(percent, Ordering::Relaxed) != percent {
            self.show(name, Some(percent));
        }
    }
    fn finish(&self) {}
}

/// Renders the frames the command asks for, writing each one (all its outputs or none) when done.
pub(super) fn render_animation(
    a: &RenderArgs,
    opts: &Options,
    anim: &Animation,
    pool: &rayon::ThreadPool,
    cancel: &AtomicBool,
) -> Result<()> {
    let frames = frame_range(a.frames.as_deref(), anim.frames())?;
    let patterns = Patterns::new(a)?;
    let bar = FramesBar::new(a.quiet, (frames.end() - frames.start() + 1) as u64);
    bar.frame.store(*frames.start(), Ordering::Relaxed);
    patterns.check(a, &frames, &bar, cancel)?;
    super::check_stats_extension(a)?;
    let start = Instant::now();
    // Rows only for --stats: a sequence without it keeps nothing per frame.
    let mut summary = SequenceSummary::new();
    let mut warned = std::collections::HashSet::new();
    let mut on_frame =
        |f: u32, scene: &pmrender::scene::Scene, out: &_, stats: &pmrender::render::RenderStats| {
            signal::arm(false);
            let written = write_outputs(
                &patterns.at(f),
                scene.fingerprint,
                out,
                stats.clone(),
                cancel,
            );
            signal::arm(true);
            written?;
            // Each distinct warning once, with the first frame that gave it.
            for w in stats.warnings() {
                if warned.insert(w.clone()) {
                    eprintln!("pmrender: warning: frame {f}: {w}");
                }
            }
            if patterns.stats.is_some() {
                summary.push(&frame_summary(f, stats))?;
            }
            bar.bar.inc(1);
            bar.frame.store(f + 1, Ordering::Relaxed);
            Ok(())
        };
    signal::arm(true);
    let tiles = super::in_range("--tiles", a.tiles, pmrender::render::budget::MAX_SIDE)?;
    let result = pool.install(|| match a.shared_bake {
        true => render_walk(
            anim,
            frames.clone(),
            opts,
            tiles,
            &bar,
            cancel,
            &mut on_frame,
        ),
        false => render_sequence(anim, frames.clone(), opts, &bar, cancel, &mut on_frame),
    });
    signal::arm(false);
    bar.bar.finish_and_clear();
    if let (Some(p), false) = (&patterns.stats, summary.is_empty()) {
        summary.write(
            &p.named("sequence"),
            start.elapsed().as_secs_f64(),
            result.is_ok(),
        )?;
        // After a failure its message is the one line said: the rows are in the summary file.
        if !matches!(result, Err(Error::Input(_) | Error::Runtime(_))) {
            for row in summary.rows()? {
                eprintln!("{}", summary_line(&row));
            }
        }
    }
    result
}

/// One frame's line of the sequence summary.
fn frame_summary(f: u32, stats: &pmrender::render::RenderStats) -> serde_json::Value {
    let report = stats.report().to_json();
    let get = |k: &str| {
        k.split('.')
            .try_fold(&report, |v, part| v.get(part))
            .cloned()
            .unwrap_or(serde_json::Value::Null)
    };
    json!({
        "frame": f,
        "time_s": stats.total_s,
        "photons": get("frame.photons"),
        "image_reused": stats.frame.is_some_and(|f| f.image_reused),
        "records_reused": get("frame.records_reused"),
        "records_dropped": get("frame.records_dropped"),
        "records_unread": get("frame.records_unread"),
        "records_after": get("frame.records_after"),
        "records_regathered": get("frame.records_regathered"),
        "records_replaced": get("frame.records_replaced"),
        "records_gone": get("frame.records_gone"),
        "records_carried": get("frame.records_carried"),
        "pixels_kept": get("frame.pixels_kept"),
        "pixels_relit": get("frame.pixels_relit"),
        "memory_peak_rss_bytes": get("memory.peak_rss_bytes"),
        "fill_cache_s": get("time.fill_cache_s"),
        "trace_photons_s": get("time.trace_photons_s"),
        "temporal_update_s": get("time.temporal_update_s"),
    })
}

fn summary_line(row: &serde_json::Value) -> String {
    format!(
        "frame {:>5}  {:>8.2} s  photons {:<7}  records reused {:>8}  after {:>8}",
        row["frame"],
        row["time_s"].as_f64().unwrap_or(0.0),
        row["photons"].as_str().unwrap_or("-"),
        row["records_reused"],
        row["records_after"],
    )
}
