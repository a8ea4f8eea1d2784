//! Argument parsing, the progress bar, the render's top-level phases (check outputs, load, render,
//! write outputs) and the mapping of errors to exit codes (2 bad input, 1 runtime, 130/143 signals).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use pmrender::converge::{converge, Study};
use pmrender::error::{option, Error, Result};
use pmrender::render::budget::{env_max_memory, parse_size, MAX_SIDE, MAX_SPP};
use pmrender::render::files::FileOptions;
use pmrender::render::outputs::{check_distinct, check_output, scene_inputs, Output};
use pmrender::render::progressive::{Budget, MAX_PASSES};
use pmrender::render::stats::StopReason;
use pmrender::render::write::{write_outputs, OutputPaths};
use pmrender::render::{self, tiles::Window, Options, Progress};
use pmrender::scene::{self, Method, Scene, MAX_PHOTONS, MAX_TIME_S, METHODS};
use pmrender::signal;

mod landing;
mod sequence;

#[derive(Parser)]
#[command(
    name = "pmrender",
    version,
    about = "Two-pass photon-mapping renderer with a cached final gather"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a layered EXR (and optionally a PNG and a statistics JSON).
    Render(Box<RenderArgs>),
    /// Photon-count convergence: error of the image and of its caustic and indirect terms against the
    /// photon count, as a table (converge.md, converge.json) and a chart (converge.png).
    Converge(ConvergeArgs),
    /// Write the scene as a Mitsuba 3 scene (DIR/scene.xml + OBJs) for independent references.
    ExportMitsuba(ExportArgs),
}

#[derive(Args)]
struct ExportArgs {
    scene: PathBuf,
    dir: PathBuf,
    /// Samples per pixel written into the sensor.
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true)]
    spp: i64,
    /// Of an animated scene, the frame to export (default 0).
    #[arg(long, allow_negative_numbers = true)]
    frame: Option<i64>,
}

#[derive(Args)]
struct ConvergeArgs {
    scene: PathBuf,
    /// Photon counts, comma-separated (e.g. 1e4,3e4,1e5,3e5,1e6); each sets both maps' targets.
    #[arg(long, value_delimiter = ',', conflicts_with = "time")]
    photons: Vec<String>,
    /// Time budgets in seconds, comma-separated (e.g. 2,8,32): each a progressive render (--time)
    /// at the scene's photon counts.
    #[arg(long, value_delimiter = ',', value_name = "SECONDS")]
    time: Vec<String>,
    /// Reference EXR (its size sets the render size).
    #[arg(long)]
    reference: PathBuf,
    /// Output directory.
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// photons (default: the maps read directly) or pm.
    #[arg(long, default_value = "photons")]
    method: String,
    #[arg(long, allow_negative_numbers = true)]
    spp: Option<i64>,
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<i64>,
    #[arg(long)]
    seed: Option<u64>,
    #[arg(long)]
    quiet: bool,
}

#[derive(Args)]
struct RenderArgs {
    /// Scene file (TOML).
    scene: PathBuf,
    /// Output EXR (beauty in R,G,B; one layer per term for the photon-map methods).
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
    /// Also write an sRGB PNG of the beauty.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Print the statistics table and save it as JSON.
    #[arg(long)]
    stats: Option<PathBuf>,
    #[arg(long, help = METHODS)]
    method: Option<String>,
    /// Samples per pixel; with a noise target, the most a pixel takes.
    #[arg(long, allow_negative_numbers = true)]
    spp: Option<i64>,
    /// Adaptive sampling: a pixel stops once the relative standard error of its mean is below this
    /// (0: every pixel takes --spp). Default: 0.04 for pm, pm-fg and photons, 0 for path.
    #[arg(long, allow_negative_numbers = true)]
    noise: Option<f64>,
    /// With a noise target, the most samples of a pixel whose samples made no Monte Carlo estimate
    /// (no area light, glass, glossy lobe or medium on their way): default 32, at most --spp.
    #[arg(long, allow_negative_numbers = true)]
    aa_spp: Option<i64>,
    #[arg(long, allow_negative_numbers = true)]
    width: Option<i64>,
    #[arg(long, allow_negative_numbers = true)]
    height: Option<i64>,
    /// Worker threads (default: all cores). The image does not depend on it.
    #[arg(long, allow_negative_numbers = true)]
    threads: Option<i64>,
    #[arg(long)]
    seed: Option<u64>,
    /// Render only the window [X0, X1) × [Y0, Y1) of the image.
    #[arg(long, num_args = 4, value_names = ["X0", "Y0", "X1", "Y1"])]
    crop: Option<Vec<u32>>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Save the photon maps for later renders of the same scene.
    #[arg(long)]
    save_photons: Option<PathBuf>,
    /// Use photon maps saved by --save-photons instead of tracing them.
    #[arg(long)]
    load_photons: Option<PathBuf>,
    /// Write the photon maps as a PLY point cloud.
    #[arg(long)]
    dump_photons: Option<PathBuf>,
    /// Save the irradiance cache (methods pm and ao).
    #[arg(long)]
    save_cache: Option<PathBuf>,
    /// Use a cache saved by --save-cache instead of filling one (pass B only).
    #[arg(long)]
    load_cache: Option<PathBuf>,
    /// PNG of the render with every cache record drawn as a dot coloured by its radius.
    #[arg(long)]
    cache_image: Option<PathBuf>,
    /// Memory budget, e.g. 8G or 512M (default: PMRENDER_MAX_MEMORY, else 75 % of the RAM).
    #[arg(long, allow_hyphen_values = true)]
    max_memory: Option<String>,
    /// An animated scene's frames to render, A..B inclusive (default: all). Each is the frame the
    /// whole sequence renders: a range starting inside a chunk renders the chunk from its start.
    #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
    frames: Option<String>,
    /// Render a still (or each frame of a --shared-bake walk) as N bands of rows shaded apart from one
    /// bake (pass A over the whole image), as a farm's tiles are: the same pixels however the tiles
    /// are shared out.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    tiles: Option<i64>,
    /// A sequence's chunk length: the temporal cache starts afresh every N frames (default: never),
    /// so that chunks render apart (on a farm) and still give the same frames.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    chunk: Option<i64>,
    /// A camera walk (frames that share one scene) baked once: photon maps traced once, one cache
    /// filled over every frame's view, each frame shaded from it alone — the same frame whatever
    /// range, order or machine renders it.
    #[arg(long)]
    shared_bake: bool,
    /// A time budget: render progressive passes, each a whole render of its own seed, and stop with
    /// their mean before the budget is spent (a longer budget, a better image; not reproducible).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    time: Option<f64>,
    /// Render N progressive passes and write their mean: reproducible at any thread count.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    passes: Option<i64>,
}

/// The bar on stderr, hidden with --quiet or when stderr is not a terminal.
struct Bar {
    bar: ProgressBar,
}

impl Bar {
    fn new(quiet: bool) -> Bar {
        Bar {
            bar: styled_bar(
                quiet,
                0,
                "{msg:>12} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
            ),
        }
    }
}

/// A bar of `len` steps on stderr drawn with `template`, hidden with --quiet or when stderr is not a
/// terminal.
fn styled_bar(quiet: bool, len: u64, template: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if quiet || !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

impl Progress for Bar {
    fn start(&self, phase: &str, total: u64) {
        self.bar.reset();
        self.bar.set_length(total);
        self.bar.set_position(0);
        self.bar.set_message(phase.to_string());
    }
    fn set(&self, done: u64) {
        self.bar.set_position(done);
    }
    fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

fn in_range(name: &str, v: Option<i64>, max: u32) -> Result<Option<u32>> {
    match v {
        Some(x) if !(1..=max as i64).contains(&x) => {
            Err(option(name, format!("{x} must be in 1..={max}")))
        }
        x => Ok(x.map(|x| x as u32)),
    }
}

fn options(a: &RenderArgs) -> Result<Options> {
    let method = match &a.method {
        Some(m) => Some(
            Method::parse(m)
                .ok_or_else(|| option("--method", format!("unknown method '{m}' ({METHODS})")))?,
        ),
        None => None,
    };
    let crop = a.crop.as_ref().map(|c| Window {
        x0: c[0],
        y0: c[1],
        x1: c[2],
        y1: c[3],
    });
    let max_memory = match &a.max_memory {
        Some(t) => Some(parse_size(t).ok_or_else(|| {
            option(
                "--max-memory",
                format!("'{t}' is not a size (e.g. 8G, 512M)"),
            )
        })?),
        None => None,
    };
    env_max_memory()?;
    Ok(Options {
        method,
        spp: in_range("--spp", a.spp, MAX_SPP)?,
        aa_spp: in_range("--aa-spp", a.aa_spp, MAX_SPP)?,
        noise: match a.noise {
            Some(t) if !(0.0..=1.0).contains(&t) => {
                return Err(option("--noise", format!("{t} must be in 0..=1")))
            }
            t => t.map(|t| t as f32),
        },
        width: in_range("--width", a.width, MAX_SIDE)?,
        height: in_range("--height", a.height, MAX_SIDE)?,
        max_memory,
        seed: a.seed,
        chunk: in_range("--chunk", a.chunk, u32::MAX)?,
        budget: Budget {
            passes: in_range("--passes", a.passes, MAX_PASSES)?,
            seconds: match a.time {
                Some(t) if !(t > 0.0 && t <= MAX_TIME_S) => {
                    return Err(option(
                        "--time",
                        format!("{t} must be in (0, {MAX_TIME_S:e}] seconds"),
                    ))
                }
                t => t,
            },
        },
        crop,
        files: FileOptions {
            save_photons: a.save_photons.clone(),
            load_photons: a.load_photons.clone(),
            dump_photons: a.dump_photons.clone(),
            save_cache: a.save_cache.clone(),
            load_cache: a.load_cache.clone(),
            cache_image: a.cache_image.clone(),
            keep_maps: false,
        },
    })
}

/// Every file the render writes, with the option naming it.
fn outputs(a: &RenderArgs) -> Vec<Output<'_>> {
    let optional = [
        ("--png", &a.png),
        ("--stats", &a.stats),
        ("--save-photons", &a.save_photons),
        ("--dump-photons", &a.dump_photons),
        ("--save-cache", &a.save_cache),
        ("--cache-image", &a.cache_image),
    ];
    let mut out: Vec<Output> = vec![("-o", a.output.as_path())];
    out.extend(
        optional
            .into_iter()
            .filter_map(|(opt, p)| p.as_deref().map(|p| (opt, p))),
    );
    out
}

/// Input files named on the command line.
fn cli_inputs(a: &RenderArgs) -> Vec<(String, PathBuf)> {
    let mut inputs = vec![("scene file".to_string(), a.scene.clone())];
    for (what, p) in [
        ("photon file", &a.load_photons),
        ("cache file", &a.load_cache),
    ] {
        if let Some(p) = p {
            inputs.push((what.to_string(), p.clone()));
        }
    }
    inputs
}

/// Each output's extension names its format.
fn check_extensions(a: &RenderArgs) -> Result<()> {
    let ext_ok = |p: &Path, ext: &str| {
        p.extension()
            .map(|e| e.eq_ignore_ascii_case(ext))
            .unwrap_or(false)
    };
    for (opt, p, ext) in [
        ("-o", Some(&a.output), "exr"),
        ("--png", a.png.as_ref(), "png"),
        ("--cache-image", a.cache_image.as_ref(), "png"),
    ] {
        match p {
            Some(p) if !ext_ok(p, ext) => {
                return Err(option(opt, format!("'{}' must end in .{ext}", p.display())))
            }
            _ => {}
        }
    }
    Ok(())
}

/// `--stats` writes JSON: a name ending otherwise (`o-10.exr`) is a slip, found after the checks
/// that say worse (an output over an input, a path that names no file).
fn check_stats_extension(a: &RenderArgs) -> Result<()> {
    match &a.stats {
        Some(p)
            if !p
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("json")) =>
        {
            Err(option(
                "--stats",
                format!("'{}' must end in .json", p.display()),
            ))
        }
        _ => Ok(()),
    }
}

/// A still render's outputs can be written, and its input files given by options can be read.
fn check_outputs(a: &RenderArgs) -> Result<()> {
    for (opt, p) in outputs(a) {
        check_output(opt, p)?;
    }
    for (opt, p) in [
        ("--load-photons", &a.load_photons),
        ("--load-cache", &a.load_cache),
    ] {
        if let Some(p) = p {
            input_file(opt, p)?;
        }
    }
    check_distinct(&outputs(a), &cli_inputs(a))
}

/// An input file an option names: a missing one, a directory and anything else that is no regular
/// file are each called what they are.
fn input_file(opt: &str, p: &Path) -> Result<()> {
    let why = match std::fs::metadata(p) {
        Ok(m) if m.is_file() => return Ok(()),
        Ok(m) if m.is_dir() => "is a directory, not a file".to_string(),
        Ok(_) => "is not a regular file".to_string(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => "not found".to_string(),
        Err(e) => format!("cannot be read: {e}"),
    };
    Err(option(opt, format!("'{}' {why}", p.display())))
}

/// The `render` command's phases: check the outputs, load the scene, check the outputs against every
/// file the scene reads, render, write all outputs or none.
fn render_command(a: RenderArgs, cancel: &AtomicBool) -> Result<()> {
    let opts = options(&a)?;
    let threads = thread_count(a.threads)?;
    check_extensions(&a)?;
    // No file of ours exists until the outputs are written: a signal may end the process at any time.
    signal::arm(true);
    if a.tiles.is_some() {
        check_tiles(&a)?;
    }
    if let Some(anim) = scene::load_animation(&a.scene)? {
        if a.tiles.is_some() && !a.shared_bake {
            return Err(option(
                "--tiles",
                "shades a sequence's frames from a bake they share: add --shared-bake",
            ));
        }
        if a.shared_bake {
            check_shared_bake(&a)?;
        }
        // Each frame's outputs are checked once the frame numbers are known (`####` may stand in a
        // folder's name).
        let pool = pool(threads)?;
        return sequence::render_animation(&a, &opts, &anim, &pool, cancel);
    }
    // A `#` in a still's file name is a frame pattern given to a scene without frames.
    for (opt, p) in outputs(&a) {
        if p.file_name()
            .is_some_and(|n| n.to_string_lossy().contains('#'))
        {
            return Err(option(
                opt,
                format!(
                    "'{}' holds # for a frame number, but the scene has no [animation]",
                    p.display()
                ),
            ));
        }
    }
    // The checks create and remove a file beside each output: not while a signal ends the process.
    signal::arm(false);
    check_outputs(&a)?;
    signal::arm(true);
    for (opt, given) in [
        ("--frames", a.frames.is_some()),
        ("--chunk", a.chunk.is_some()),
        ("--shared-bake", a.shared_bake),
    ] {
        if given {
            return Err(option(opt, "the scene has no [animation]"));
        }
    }
    let scene = scene::load(&a.scene)?;
    let mut inputs = scene_inputs(&a.scene);
    inputs.extend(cli_inputs(&a));
    check_distinct(&outputs(&a), &inputs)?;
    check_stats_extension(&a)?;
    let pool = pool(threads)?;
    let bar = Bar::new(a.quiet);
    let tiles = in_range("--tiles", a.tiles, MAX_SIDE)?;
    let result = pool.install(|| match tiles {
        Some(n) => render::tiled::render_tiled(&scene, &opts, n, &bar, cancel),
        None => render::render(&scene, &opts, &bar, cancel),
    });
    signal::arm(false);
    let (out, stats) = result?;
    for w in stats.warnings() {
        eprintln!("pmrender: warning: {w}");
    }
    let paths = OutputPaths {
        exr: a.output.clone(),
        png: a.png.clone(),
        stats: a.stats.clone(),
        save_photons: a.save_photons.clone(),
        dump_photons: a.dump_photons.clone(),
        save_cache: a.save_cache.clone(),
        cache_image: a.cache_image.clone(),
    };
    let fingerprint = pmrender::render::files::cache_fingerprint(&scene, stats.setup.method);
    // A progressive render a signal ended after its first pass writes the mean of its passes.
    let signalled = stats
        .progressive
        .as_ref()
        .filter(|p| p.stopped == StopReason::Interrupted)
        .map(|p| p.pass_s.len());
    let unset = AtomicBool::new(false);
    let write_cancel = if signalled.is_some() { &unset } else { cancel };
    let report = write_outputs(&paths, fingerprint, &out, stats, write_cancel)?;
    if a.stats.is_some() {
        eprint!("{}", report.table());
    }
    match signalled {
        Some(n) => {
            eprintln!(
                "pmrender: the outputs hold the mean of the {n} pass(es) made before the signal"
            );
            Err(Error::Interrupted)
        }
        None => Ok(()),
    }
}

/// `--tiles` renders from a bake of its own: no photon or cache file is read or saved with it.
fn check_tiles(a: &RenderArgs) -> Result<()> {
    let mut left_out = bake_files(a);
    left_out.extend([
        ("--cache-image", a.cache_image.is_some()),
        ("--crop", a.crop.is_some()),
        ("--passes", a.passes.is_some()),
        ("--time", a.time.is_some()),
    ]);
    refuse_given("--tiles", "renders from a bake of its own", &left_out)
}

/// `--shared-bake` keeps its one bake in memory for the frames: no photon or cache file is read or
/// saved with it.
fn check_shared_bake(a: &RenderArgs) -> Result<()> {
    let mut left_out = bake_files(a);
    left_out.push(("--chunk", a.chunk.is_some()));
    let why = "shades every frame from one bake of its own";
    refuse_given("--shared-bake", why, &left_out)
}

/// Which of the options that read or save photon and cache files are given.
fn bake_files(a: &RenderArgs) -> Vec<(&'static str, bool)> {
    vec![
        ("--load-photons", a.load_photons.is_some()),
        ("--load-cache", a.load_cache.is_some()),
        ("--save-photons", a.save_photons.is_some()),
        ("--dump-photons", a.dump_photons.is_some()),
        ("--save-cache", a.save_cache.is_some()),
    ]
}

/// `opt`, which `why`, refused with the first of `options` given, named as the one to leave out.
fn refuse_given(opt: &str, why: &str, options: &[(&'static str, bool)]) -> Result<()> {
    match options.iter().find(|(_, given)| *given) {
        Some((other, _)) => Err(option(opt, format!("{why}: leave out {other}"))),
        None => Ok(()),
    }
}

/// Loads a scene while the watchdog may end the process on a signal (a read blocked on a FIFO cannot
/// poll the flag); nothing has been written yet.
fn load_interruptible(path: &Path) -> Result<Scene> {
    signal::arm(true);
    let scene = scene::load(path);
    signal::arm(false);
    scene
}

/// The scene `export-mitsuba` writes: a still scene, or the frame `--frame` names of an animated one.
fn export_scene(a: &ExportArgs) -> Result<Scene> {
    signal::arm(true);
    let scene = scene::load_animation(&a.scene).and_then(|anim| match (anim, a.frame) {
        (None, None) => scene::load(&a.scene),
        (None, Some(_)) => Err(option("--frame", "the scene has no [animation]")),
        (Some(anim), f) => {
            let f = f.unwrap_or(0);
            if !(0..i64::from(anim.frames())).contains(&f) {
                return Err(option(
                    "--frame",
                    format!("{f} is outside the sequence 0..={}", anim.frames() - 1),
                ));
            }
            scene::load_frame(&anim, f as u32)
        }
    });
    signal::arm(false);
    scene
}

/// `--threads` checked: at most 4 per core (at least 16). More only add stacks; 1024 of them did not
/// fit under a 3 GB address-space limit, and the pool failed with "os error 11".
fn thread_count(threads: Option<i64>) -> Result<Option<usize>> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = (4 * cores).max(16);
    match threads {
        Some(t) if !(1..=max as i64).contains(&t) => Err(option(
            "--threads",
            format!("{t} must be in 1..={max} (4 per core of this machine's {cores})"),
        )),
        t => Ok(t.map(|t| t as usize)),
    }
}

/// The worker pool: `threads`, or one per core. A system that cannot start them (a limit on processes
/// or address space) is named, with the option when it was given.
fn pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .map_err(|e| {
            let why = format!("cannot start the worker threads: {e}");
            match threads {
                Some(n) => option("--threads", format!("{n}: {why}; try fewer")),
                None => Error::Runtime(why),
            }
        })
}

fn converge_command(a: ConvergeArgs) -> Result<()> {
    let counts = a
        .photons
        .iter()
        .map(|s| match s.trim().parse::<f64>() {
            // Whole numbers only (1e4 is one): 1.5 ran 2 photons without a word.
            Ok(x) if (1.0..=MAX_PHOTONS as f64).contains(&x) && x.fract() == 0.0 => Ok(x as usize),
            _ => Err(option(
                "--photons",
                format!("'{s}' is not a whole photon count in 1..={MAX_PHOTONS}"),
            )),
        })
        .collect::<Result<Vec<_>>>()?;
    let times = a
        .time
        .iter()
        .map(|s| match s.trim().parse::<f64>() {
            Ok(t) if t > 0.0 && t <= MAX_TIME_S => Ok(t),
            _ => Err(option(
                "--time",
                format!("'{s}' is not a time in (0, {MAX_TIME_S:e}] seconds"),
            )),
        })
        .collect::<Result<Vec<_>>>()?;
    if counts.is_empty() && times.is_empty() {
        return Err(option(
            "--photons",
            "give photon counts (--photons 1e4,1e5) or time budgets (--time 2,8)",
        ));
    }
    let method = match Method::parse(&a.method) {
        Some(m @ (Method::Photons | Method::Pm)) => m,
        _ => {
            return Err(option(
                "--method",
                format!("'{}' must be photons or pm", a.method),
            ))
        }
    };
    input_file("--reference", &a.reference)?;
    let opts = Options {
        spp: in_range("--spp", a.spp, MAX_SPP)?,
        seed: a.seed,
        ..Default::default()
    };
    let threads = thread_count(a.threads)?;
    env_max_memory()?;
    check_output_dir(&a.output)?;
    // A study of an animated scene would silently be one of its first frame.
    if scene::load_animation(&a.scene)?.is_some() {
        return Err(Error::Input(format!(
            "{}: the scene is animated: converge studies a still scene",
            a.scene.display()
        )));
    }
    let mut scene = load_interruptible(&a.scene)?;
    let bar = Bar::new(a.quiet);
    let rows = pool(threads)?.install(|| {
        let study = Study {
            counts: &counts,
            times: &times,
            reference: &a.reference,
            method,
            out_dir: Some(&a.output),
        };
        converge(&mut scene, &study, &opts, &bar, &signal::CANCEL)
    })?;
    let timed = !times.is_empty();
    println!(
        "{:>10} {:>9} {:>14} {:>14} {:>14}",
        if timed { "budget s" } else { "photons" },
        "time s",
        "beauty relMSE",
        "caustic",
        "indirect"
    );
    let f = pmrender::converge::fmt_rel_mse;
    for r in &rows {
        println!(
            "{:>10} {:>9.2} {:>14} {:>14} {:>14}",
            r.budget_s.map_or(r.photons.to_string(), |b| b.to_string()),
            r.time_s,
            f(r.beauty),
            f(r.caustic),
            f(r.indirect)
        );
    }
    if let Some(note) = pmrender::converge::footnote(&rows) {
        println!("{note}");
    }
    println!(
        "wrote {}/converge.md, converge.json, converge.png",
        a.output.display()
    );
    Ok(())
}

fn export_command(a: ExportArgs) -> Result<()> {
    let spp = in_range("--spp", Some(a.spp), MAX_SPP)?.unwrap_or(1);
    let scene = export_scene(&a)?;
    pmrender::export::export_mitsuba(&scene, &a.dir, spp, &signal::CANCEL)
}

/// `converge -o`: an existing directory, or one that can be made below the nearest existing one
/// (made only when the outputs are written).
fn check_output_dir(dir: &Path) -> Result<()> {
    let existing = dir
        .ancestors()
        .find(|d| d.as_os_str().is_empty() || d.exists())
        .unwrap_or(Path::new("."));
    let existing = if existing.as_os_str().is_empty() {
        Path::new(".")
    } else {
        existing
    };
    if !existing.is_dir() {
        return Err(option(
            "-o",
            format!("'{}' is not a directory", existing.display()),
        ));
    }
    if existing == dir {
        for name in ["converge.md", "converge.json", "converge.png"] {
            check_output("-o", &dir.join(name))?;
        }
    }
    Ok(())
}

pub fn run() -> i32 {
    if let Err(e) = signal::install() {
        eprintln!("pmrender: cannot install the signal handler: {e}");
        return 1;
    }
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) if e.use_stderr() => {
            // One line, like every other input error; a first line ending in ':' (e.g. "the following
            // required arguments were not provided:") is joined with what it announces.
            let text = e.to_string();
            let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
            let mut first = lines
                .next()
                .unwrap_or("invalid arguments")
                .trim_start_matches("error: ")
                .to_string();
            if first.ends_with(':') {
                if let Some(next) = lines.next() {
                    first = format!("{first} {next}");
                }
            }
            eprintln!("pmrender: {first} (see pmrender --help)");
            return 2;
        }
        Err(e) => {
            let _ = e.print();
            return 0;
        }
    };
    let result = match cli.command {
        Command::Render(a) => render_command(*a, &signal::CANCEL),
        Command::Converge(a) => converge_command(a),
        Command::ExportMitsuba(a) => export_command(a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("pmrender: {e}");
            match e {
                Error::Input(_) => 2,
                Error::Interrupted => signal::exit_code(),
                Error::Runtime(_) => 1,
            }
        }
    }
}
