//! Argument parsing, the progress bar, and the mapping of errors to exit codes (2 bad input, 1 runtime).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use pmrender::error::{option, Error, Result};
use pmrender::io::atomic::{check_writable, write_bytes};
use pmrender::io::output::{write_exr, write_png, Layers};
use pmrender::render::files::{cache_image, save_cache, FileOptions};
use pmrender::render::{self, tiles::Window, Options, Progress};
use pmrender::scene::{self, Method, METHODS};

#[derive(Parser)]
#[command(name = "pmrender", version, about = "Two-pass photon-mapping renderer with a cached final gather")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a layered EXR (and optionally a PNG and a statistics JSON).
    Render(RenderArgs),
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
    #[arg(long, default_value_t = 1024)]
    spp: u32,
}

#[derive(Args)]
struct ConvergeArgs {
    scene: PathBuf,
    /// Photon counts, comma-separated (e.g. 1e4,3e4,1e5,3e5,1e6); each sets both maps' targets.
    #[arg(long, value_delimiter = ',', required = true)]
    photons: Vec<String>,
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
    /// Samples per pixel.
    #[arg(long, allow_negative_numbers = true)]
    spp: Option<i64>,
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
    /// Save the photon maps (and precomputed irradiance) for later renders of the same scene.
    #[arg(long)]
    save_photons: Option<PathBuf>,
    /// Use photon maps saved by --save-photons instead of tracing them.
    #[arg(long)]
    load_photons: Option<PathBuf>,
    /// Write the photon maps as a PLY point cloud.
    #[arg(long)]
    dump_photons: Option<PathBuf>,
    /// Save the irradiance cache (method pm).
    #[arg(long)]
    save_cache: Option<PathBuf>,
    /// Use a cache saved by --save-cache instead of filling one (pass B only).
    #[arg(long)]
    load_cache: Option<PathBuf>,
    /// PNG of the render with every cache record drawn as a dot coloured by its radius.
    #[arg(long)]
    cache_image: Option<PathBuf>,
}

/// The bar on stderr, hidden with --quiet or when stderr is not a terminal.
struct Bar {
    bar: ProgressBar,
}

impl Bar {
    fn new(quiet: bool) -> Bar {
        let bar = ProgressBar::with_draw_target(Some(0), ProgressDrawTarget::stderr());
        if quiet || !std::io::stderr().is_terminal() {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        bar.set_style(
            ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        Bar { bar }
    }
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

fn positive(name: &str, v: Option<i64>) -> Result<Option<u32>> {
    match v {
        Some(x) if !(1..=1 << 20).contains(&x) => Err(option(name, format!("{x} must be a positive integer"))),
        x => Ok(x.map(|x| x as u32)),
    }
}

fn options(a: &RenderArgs) -> Result<Options> {
    let method = match &a.method {
        Some(m) => Some(Method::parse(m).ok_or_else(|| option("--method", format!("unknown method '{m}' ({METHODS})")))?),
        None => None,
    };
    let crop = a.crop.as_ref().map(|c| Window { x0: c[0], y0: c[1], x1: c[2], y1: c[3] });
    Ok(Options {
        method,
        spp: positive("--spp", a.spp)?,
        width: positive("--width", a.width)?,
        height: positive("--height", a.height)?,
        seed: a.seed,
        crop,
        files: FileOptions {
            save_photons: a.save_photons.clone(),
            load_photons: a.load_photons.clone(),
            dump_photons: a.dump_photons.clone(),
            save_cache: a.save_cache.clone(),
            load_cache: a.load_cache.clone(),
            cache_image: a.cache_image.clone(),
        },
    })
}

fn check_outputs(a: &RenderArgs) -> Result<()> {
    let ext_ok = |p: &Path, ext: &str| p.extension().map(|e| e.eq_ignore_ascii_case(ext)).unwrap_or(false);
    if !ext_ok(&a.output, "exr") {
        return Err(option("-o", format!("'{}' must end in .exr", a.output.display())));
    }
    check_writable(&a.output, "-o")?;
    if let Some(p) = &a.png {
        if !ext_ok(p, "png") {
            return Err(option("--png", format!("'{}' must end in .png", p.display())));
        }
        check_writable(p, "--png")?;
    }
    for (opt, p) in [("--stats", &a.stats), ("--save-photons", &a.save_photons), ("--dump-photons", &a.dump_photons), ("--save-cache", &a.save_cache), ("--cache-image", &a.cache_image)] {
        if let Some(p) = p {
            check_writable(p, opt)?;
        }
    }
    for (opt, p) in [("--load-photons", &a.load_photons), ("--load-cache", &a.load_cache)] {
        if let Some(p) = p {
            if !p.is_file() {
                return Err(option(opt, format!("'{}' not found", p.display())));
            }
        }
    }
    Ok(())
}

fn render_command(a: RenderArgs, cancel: &AtomicBool) -> Result<()> {
    let opts = options(&a)?;
    let threads = match a.threads {
        Some(t) if !(1..=1024).contains(&t) => return Err(option("--threads", format!("{t} must be in 1..=1024"))),
        t => t.map(|t| t as usize).unwrap_or(0),
    };
    check_outputs(&a)?;
    let scene = scene::load(&a.scene)?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| Error::Runtime(e.to_string()))?;
    let bar = Bar::new(a.quiet);
    let (out, mut report) = pool.install(|| render::render(&scene, &opts, &bar, cancel))?;
    let t = std::time::Instant::now();
    let layers = Layers { beauty: &out.beauty, named: out.layers.iter().map(|(n, i)| (*n, i)).collect() };
    write_exr(&a.output, &layers)?;
    if let Some(p) = &a.png {
        write_png(p, &out.beauty)?;
    }
    match (&out.cache, &a.save_cache, &a.cache_image) {
        (None, Some(_), _) | (None, _, Some(_)) => eprintln!("pmrender: note: no irradiance cache with this method; --save-cache/--cache-image ignored"),
        (Some(c), save, img) => {
            if let Some(p) = save {
                save_cache(p, c, scene.fingerprint)?;
            }
            if let Some(p) = img {
                let cam = scene.camera.with_resolution(out.beauty.width, out.beauty.height);
                cache_image(p, &out.beauty, c, &cam)?;
            }
        }
        _ => {}
    }
    report.seconds("Time", "Write outputs", "time.write_outputs_s", t.elapsed().as_secs_f64());
    if let Some(p) = &a.stats {
        eprint!("{}", report.table());
        let json = serde_json::to_string_pretty(&report.to_json()).map_err(|e| Error::Runtime(e.to_string()))?;
        write_bytes(p, json.as_bytes())?;
    }
    Ok(())
}

fn pool(threads: Option<i64>) -> Result<rayon::ThreadPool> {
    let n = match threads {
        Some(t) if !(1..=1024).contains(&t) => return Err(option("--threads", format!("{t} must be in 1..=1024"))),
        t => t.map(|t| t as usize).unwrap_or(0),
    };
    rayon::ThreadPoolBuilder::new().num_threads(n).build().map_err(|e| Error::Runtime(e.to_string()))
}

fn converge_command(a: ConvergeArgs) -> Result<()> {
    let counts = a
        .photons
        .iter()
        .map(|s| match s.trim().parse::<f64>() {
            Ok(x) if (1.0..=1e9).contains(&x) => Ok(x.round() as usize),
            _ => Err(option("--photons", format!("'{s}' is not a photon count in 1..1e9"))),
        })
        .collect::<Result<Vec<_>>>()?;
    let method = match Method::parse(&a.method) {
        Some(m @ (Method::Photons | Method::Pm)) => m,
        _ => return Err(option("--method", format!("'{}' must be photons or pm", a.method))),
    };
    if !a.reference.is_file() {
        return Err(option("--reference", format!("'{}' not found", a.reference.display())));
    }
    if !a.output.is_dir() {
        std::fs::create_dir_all(&a.output).map_err(|e| option("-o", format!("cannot create '{}': {e}", a.output.display())))?;
    }
    let mut scene = scene::load(&a.scene)?;
    let opts = Options { spp: positive("--spp", a.spp)?, seed: a.seed, ..Default::default() };
    let bar = Bar::new(a.quiet);
    let rows = pool(a.threads)?.install(|| pmrender::converge::converge(&mut scene, &counts, &a.reference, method, &opts, &a.output, &bar))?;
    println!("{:>10} {:>9} {:>14} {:>14} {:>14}", "photons", "time s", "beauty relMSE", "caustic", "indirect");
    for r in rows {
        println!("{:>10} {:>9.2} {:>14.5} {:>14.5} {:>14.5}", r.photons, r.time_s, r.beauty, r.caustic, r.indirect);
    }
    println!("wrote {}/converge.md, converge.json, converge.png", a.output.display());
    Ok(())
}

pub fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) if e.use_stderr() => {
            // One line, like every other input error.
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments").trim_start_matches("error: ");
            eprintln!("pmrender: {first} (see pmrender --help)");
            return 2;
        }
        Err(e) => {
            let _ = e.print();
            return 0;
        }
    };
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let c = cancel.clone();
        let _ = ctrlc::set_handler(move || c.store(true, Ordering::Relaxed));
    }
    let result = match cli.command {
        Command::Render(a) => render_command(a, &cancel),
        Command::Converge(a) => converge_command(a),
        Command::ExportMitsuba(a) => scene::load(&a.scene).and_then(|s| pmrender::export::export_mitsuba(&s, &a.dir, a.spp.max(1))),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("pmrender: {e}");
            match e {
                Error::Input(_) => 2,
                Error::Interrupted => 130,
                Error::Runtime(_) => 1,
            }
        }
    }
}
