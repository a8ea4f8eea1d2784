//! The render driver: a sequence of named phases chosen by the method, each returning its output and
//! its statistics, readable top-down from [`render`].

pub mod budget;
pub mod files;
pub mod outputs;
pub mod pm_phases;
pub mod tiles;
pub mod write;

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use glam::Vec3;

use crate::error::{option, Result};
use crate::integrator::{path, SampleCounters};
use crate::io::output::Image;
use crate::scene::{Method, Scene};
use crate::stats::{peak_rss_bytes, Report};
use tiles::{render_tiles, Sampling, Window};

/// Progress of long phases; the binary draws a bar, tests pass [`NoProgress`].
pub trait Progress: Sync {
    fn start(&self, phase: &str, total: u64);
    fn set(&self, done: u64);
    fn finish(&self);
}

pub struct NoProgress;

impl Progress for NoProgress {
    fn start(&self, _: &str, _: u64) {}
    fn set(&self, _: u64) {}
    fn finish(&self) {}
}

/// Command-line overrides of the scene's `[render]` and `[camera]` values.
#[derive(Clone, Debug, Default)]
pub struct Options {
    pub method: Option<Method>,
    pub spp: Option<u32>,
    /// Adaptive sampling's noise target (`--noise`); see [`tiles::Sampling`].
    pub noise: Option<f32>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub seed: Option<u64>,
    pub crop: Option<Window>,
    pub files: files::FileOptions,
    /// Memory budget in bytes (`--max-memory`); see [`budget`].
    pub max_memory: Option<u64>,
}

/// What a render produced: beauty and the per-term layers of Jensen's split (empty for `path`).
pub struct RenderOutput {
    pub beauty: Image,
    pub layers: Vec<(&'static str, Image)>,
    /// The irradiance cache `pm` filled (for `--save-cache` and `--cache-image`).
    pub cache: Option<icache::IrradianceCache>,
    /// Traced photon maps, kept when `--save-photons` or `--dump-photons` asks for them.
    pub photons: Option<files::PhotonOutput>,
}

/// Resolved settings of one render.
pub struct Plan {
    pub method: Method,
    pub spp: u32,
    /// Adaptive sampling's noise target (0: `spp` everywhere).
    pub noise: f32,
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub window: Window,
}

/// Default noise target of the photon-map methods (chosen from the speed×accuracy chart; README).
pub const DEFAULT_NOISE: f32 = 0.04;

impl Plan {
    pub fn sampling(&self) -> Sampling {
        Sampling { spp: self.spp, noise: self.noise }
    }
}

pub fn plan(scene: &Scene, opts: &Options) -> Result<Plan> {
    let method = opts.method.or(scene.settings.method).unwrap_or(Method::Pm);
    let spp = opts.spp.or(scene.settings.spp).unwrap_or(match method {
        // Chosen from measurements against the Mitsuba reference of the caustic scene (README).
        Method::Path => 64,
        Method::Pm | Method::Photons => 32,
        Method::PmFg => 4,
    });
    // Adaptive sampling by default for the photon-map methods, whose pixels mostly converge in a few
    // samples (point lights, diffuse walls, smooth cached irradiance); `path` keeps fixed sample counts
    // (it is the reference, and its charts are drawn per spp).
    let noise = opts.noise.or(scene.settings.noise).unwrap_or(match method {
        Method::Path => 0.0,
        Method::Pm | Method::Photons | Method::PmFg => DEFAULT_NOISE,
    });
    let width = opts.width.unwrap_or(scene.camera.width);
    let height = opts.height.unwrap_or(scene.camera.height);
    let window = match opts.crop {
        None => Window::full(width, height),
        Some(w) => {
            if w.x0 >= w.x1 || w.y0 >= w.y1 || w.x1 > width || w.y1 > height {
                return Err(option("--crop", format!("window {} {} {} {} is empty or outside the {width}×{height} image", w.x0, w.y0, w.x1, w.y1)));
            }
            w
        }
    };
    Ok(Plan { method, spp, noise, seed: opts.seed.unwrap_or(scene.settings.seed), width, height, window })
}

pub fn render(scene: &Scene, opts: &Options, progress: &dyn Progress, cancel: &AtomicBool) -> Result<(RenderOutput, Report)> {
    let t0 = Instant::now();
    let plan = plan(scene, opts)?;
    budget::check(scene, &plan, opts)?;
    let camera = scene.camera.with_resolution(plan.width, plan.height);
    let mut report = Report::default();
    report.text("Render", "Method", "render.method", plan.method.name());
    let (output, counters, samples, shade_s) = match plan.method {
        Method::Path => {
            let t = Instant::now();
            let max_depth = scene.settings.max_depth;
            let sample = |x: u32, y: u32, off: [f32; 2], _: &mut crate::integrator::PixelMemo, rng: &mut photon::sampling::Rng, c: &mut SampleCounters| -> Vec<Vec3> {
                let d = camera.ray(x as f32 + off[0], y as f32 + off[1]);
                vec![path::radiance(scene, camera.eye, d, max_depth, rng, c)]
            };
            progress.start("shade", plan.window.n_pixels());
            let (mut images, counters, count) = render_tiles(plan.width, plan.height, plan.window, plan.sampling(), plan.seed, 1, &sample, &|n| progress.set(n), cancel)?;
            progress.finish();
            let shade_s = t.elapsed().as_secs_f64();
            report.seconds("Time", "Shade", "time.shade_s", shade_s);
            (RenderOutput { beauty: images.remove(0), layers: Vec::new(), cache: None, photons: None }, counters, count, shade_s)
        }
        Method::Pm | Method::PmFg | Method::Photons => {
            let run = pm_phases::render_pm(scene, &plan, opts, &camera, progress, cancel)?;
            let shade_s = run.report.rows.iter().filter(|r| r.key.starts_with("time.")).filter_map(|r| r.value.as_f64()).sum();
            report.rows.extend(run.report.rows);
            (run.output, run.counters, run.samples, shade_s)
        }
    };
    let total_s = t0.elapsed().as_secs_f64();
    report.seconds("Time", "Total", "time.total_s", total_s);
    let rays = counters.rays + counters.shadow_rays;
    report.count("Rays", "Total", "rays.total", rays);
    report.count("Rays", "Camera and bounce rays", "rays.closest_hit", counters.rays);
    report.count("Rays", "Shadow rays", "rays.shadow", counters.shadow_rays);
    report.number("Rays", "Rays per second", "rays.per_s", rays as f64 / shade_s.max(1e-9));
    report.count("Image", "Width", "image.width", plan.width as u64);
    report.count("Image", "Height", "image.height", plan.height as u64);
    report.count("Image", "Samples per pixel (most)", "image.spp", plan.spp as u64);
    report.number("Image", "Noise target (0: fixed spp)", "image.noise", plan.noise as f64);
    report.number("Image", "Samples per pixel (mean)", "image.spp_mean", samples.samples as f64 / samples.pixels.max(1) as f64);
    report.count("Image", "Pixels at the sample limit", "image.pixels_at_limit", samples.at_limit);
    report.count("Image", "Samples", "image.samples", samples.samples);
    report.count("Rare events", "NaN or negative radiance", "rare.nan_or_negative", counters.nan_or_negative);
    report.count("Rare events", "Zero-pdf samples", "rare.zero_pdf", counters.zero_pdf);
    report.count("Scene", "Triangles", "scene.triangles", scene.geometry.triangles.len() as u64);
    report.count("Scene", "Degenerate triangles dropped", "scene.degenerate_triangles", scene.geometry.n_degenerate as u64);
    report.count("Scene", "Lights", "scene.lights", scene.lights.len() as u64);
    report.bytes("Memory", "Peak resident set", "memory.peak_rss_bytes", peak_rss_bytes());
    Ok((output, report))
}
