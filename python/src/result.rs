//! `render` and what it returns: the beauty and its layers as float32 buffers, the statistics as
//! the `--stats` JSON, and `write` for the command line's outputs.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use pmrender::io::output::Image;
use pmrender::render::outputs::{check_distinct, check_output, scene_inputs, Output};
use pmrender::render::progressive::{Budget, MAX_PASSES};
use pmrender::render::write::{write_outputs, OutputPaths};
use pmrender::render::{RenderOutput, RenderStats};
use pmrender::scene::MAX_TIME_S;
use pyo3::prelude::*;
use pyo3::types::PyByteArray;

use crate::bake::Bake;
use crate::errors::{bad_arg, to_py};
use crate::options::{pool, Settings};
use crate::run::{detached, still_phases};
use crate::scene::Scene;

/// A finished render.
#[pyclass(frozen, module = "pmrender")]
pub struct RenderResult {
    pub out: RenderOutput,
    pub stats: RenderStats,
    /// The scene's fingerprint, marking a saved cache.
    pub fingerprint: u64,
    /// The scene file, which no output may replace.
    pub scene_path: PathBuf,
}

/// An image's pixels as float32 RGB, row by row from the top (numpy's H×W×3 in C order).
pub fn pixel_bytes<'py>(py: Python<'py>, img: &Image) -> Bound<'py, PyByteArray> {
    let mut bytes = Vec::with_capacity(img.pixels.len() * 12);
    for p in &img.pixels {
        for c in p.to_array() {
            bytes.extend(c.to_le_bytes());
        }
    }
    PyByteArray::new(py, &bytes)
}

#[pymethods]
impl RenderResult {
    #[getter]
    fn width(&self) -> u32 {
        self.out.beauty.width
    }

    #[getter]
    fn height(&self) -> u32 {
        self.out.beauty.height
    }

    /// The beauty's pixels (float32 RGB bytes).
    fn image_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, PyByteArray> {
        pixel_bytes(py, &self.out.beauty)
    }

    /// The layers' names, in the EXR's order.
    fn layer_names(&self) -> Vec<&'static str> {
        self.out.layers.iter().map(|(n, _)| *n).collect()
    }

    /// A layer's pixels (float32 RGB bytes).
    fn layer_bytes<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyByteArray>> {
        let (_, img) = self
            .out
            .layers
            .iter()
            .find(|(n, _)| *n == name)
            .ok_or_else(|| bad_arg("name", format!("no layer '{name}'")))?;
        Ok(pixel_bytes(py, img))
    }

    /// What the render would have the user hear (the CLI prints each as a warning).
    fn warnings(&self) -> Vec<String> {
        self.stats.warnings()
    }

    /// The statistics as the `--stats` JSON text.
    fn stats_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.stats.report().to_json())
            .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
    }

    /// Writes the command line's outputs: the layered EXR, and each of the others given.
    #[pyo3(signature = (path, *, png=None, stats=None, save_cache=None, cache_image=None))]
    fn write(
        &self,
        py: Python<'_>,
        path: PathBuf,
        png: Option<PathBuf>,
        stats: Option<PathBuf>,
        save_cache: Option<PathBuf>,
        cache_image: Option<PathBuf>,
    ) -> PyResult<()> {
        for (name, p, ext) in [
            ("path", Some(&path), "exr"),
            ("png", png.as_ref(), "png"),
            ("cache_image", cache_image.as_ref(), "png"),
        ] {
            if let Some(p) = p {
                if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
                    return Err(bad_arg(
                        name,
                        format!("'{}' must end in .{ext}", p.display()),
                    ));
                }
            }
        }
        if (save_cache.is_some() || cache_image.is_some()) && self.out.cache.is_none() {
            return Err(bad_arg(
                "save_cache",
                "this render has no irradiance cache (methods pm and ao have one)",
            ));
        }
        let mut outputs: Vec<Output> = vec![("path", path.as_path())];
        for (name, p) in [
            ("png", &png),
            ("stats", &stats),
            ("save_cache", &save_cache),
            ("cache_image", &cache_image),
        ] {
            if let Some(p) = p {
                outputs.push((name, p.as_path()));
            }
        }
        for (name, p) in &outputs {
            check_output(name, p).map_err(to_py)?;
        }
        check_distinct(&outputs, &scene_inputs(&self.scene_path)).map_err(to_py)?;
        let paths = OutputPaths {
            exr: path.clone(),
            png: png.clone(),
            stats: stats.clone(),
            save_photons: None,
            dump_photons: None,
            save_cache: save_cache.clone(),
            cache_image: cache_image.clone(),
        };
        let never = AtomicBool::new(false);
        py.detach(|| {
            write_outputs(
                &paths,
                self.fingerprint,
                &self.out,
                self.stats.clone(),
                &never,
            )
        })
        .map_err(to_py)?;
        Ok(())
    }
}

#[pyfunction]
#[pyo3(signature = (scene, *, method=None, spp=None, width=None, height=None, seed=None,
                    threads=None, noise=None, aa_spp=None, crop=None, max_memory=None,
                    progress=None, bake=None, tiles=None, passes=None, time=None, frame=None))]
#[allow(clippy::too_many_arguments)]
pub fn render(
    py: Python<'_>,
    scene: &Scene,
    method: Option<String>,
    spp: Option<i64>,
    width: Option<i64>,
    height: Option<i64>,
    seed: Option<u64>,
    threads: Option<i64>,
    noise: Option<f64>,
    aa_spp: Option<i64>,
    crop: Option<(u32, u32, u32, u32)>,
    max_memory: Option<String>,
    progress: Option<Bound<'_, PyAny>>,
    bake: Option<&Bake>,
    tiles: Option<u32>,
    passes: Option<i64>,
    time: Option<f64>,
    frame: Option<u32>,
) -> PyResult<RenderResult> {
    if let Some(f) = frame {
        if passes.is_some() || time.is_some() {
            let name = if passes.is_some() { "passes" } else { "time" };
            return Err(bad_arg(
                name,
                "a walk's frame is one pass from its bake: leave it out",
            ));
        }
        let s = Settings {
            method,
            spp,
            noise,
            aa_spp,
            width,
            height,
            seed,
            crop,
            max_memory,
        };
        let shading = WalkFrame {
            bake,
            tiles,
            threads,
        };
        return walk_frame(py, scene, f, s, shading, progress.as_ref());
    }
    let still = scene.still()?.clone();
    let mut settings = scene.settings.over(&Settings {
        method,
        spp,
        noise,
        aa_spp,
        width,
        height,
        seed,
        crop,
        max_memory,
    });
    if let (Some(b), None) = (bake, &settings.method) {
        settings.method = Some(b.baked.method.name().to_string());
    }
    let mut opts = settings.options()?;
    opts.budget = budget(passes, time)?;
    if opts.budget.is_set() && bake.is_some() {
        let name = if passes.is_some() { "passes" } else { "time" };
        return Err(bad_arg(
            name,
            "makes every pass's photon maps and caches afresh: leave out bake",
        ));
    }
    let pool = pool(threads)?;
    let method = pmrender::render::method(&still, &opts);
    let phases = still_phases(method, bake.is_some());
    let baked = bake.map(|b| &b.baked);
    if tiles == Some(0) {
        return Err(bad_arg("tiles", "0 must be at least 1"));
    }
    if tiles.is_some() && baked.is_some() {
        return Err(bad_arg("tiles", "makes its own bake: leave out bake"));
    }
    let (out, stats) = detached(py, progress.as_ref(), phases, |watch| {
        pool.install(|| match (baked, tiles) {
            (Some(b), _) => {
                pmrender::render::baked::render_baked(&still, &opts, b, watch, &watch.cancel)
            }
            (None, Some(n)) => {
                pmrender::render::tiled::render_tiled(&still, &opts, n, watch, &watch.cancel)
            }
            (None, None) => pmrender::render::render(&still, &opts, watch, &watch.cancel),
        })
    })?;
    Ok(RenderResult {
        out,
        stats,
        fingerprint: still.fingerprint,
        scene_path: scene.path.clone(),
    })
}

/// How a walk's frame is shaded: from which bake, in how many tiles, with how many threads.
struct WalkFrame<'a> {
    bake: Option<&'a Bake>,
    tiles: Option<u32>,
    threads: Option<i64>,
}

/// Frame `f` of an animated scene's walk, shaded from the walk's bake (`bake(scene)`).
fn walk_frame(
    py: Python<'_>,
    scene: &Scene,
    f: u32,
    overrides: Settings,
    shading: WalkFrame,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<RenderResult> {
    let anim = scene.animation()?.clone();
    let Some(bake) = shading.bake else {
        return Err(bad_arg(
            "frame",
            "shades a walk's frame from the walk's bake: pass bake=bake(scene)",
        ));
    };
    if f >= anim.frames() {
        return Err(bad_arg(
            "frame",
            format!(
                "{f} is not within the sequence's frames 0..={}",
                anim.frames() - 1
            ),
        ));
    }
    if shading.tiles == Some(0) {
        return Err(bad_arg("tiles", "0 must be at least 1"));
    }
    let mut settings = scene.settings.over(&overrides);
    if settings.method.is_none() {
        settings.method = Some(bake.baked.method.name().to_string());
    }
    let opts = settings.options()?;
    let pool = pool(shading.threads)?;
    let walk = py.detach(|| scene.walk_scene(&anim)).map_err(to_py)?;
    let phases = still_phases(bake.baked.method, true);
    let (out, stats) = detached(py, progress, phases, |watch| {
        pool.install(|| {
            pmrender::render::shared_bake::render_walk_frame(
                &anim,
                &walk,
                &bake.baked,
                f,
                shading.tiles,
                &opts,
                watch,
                &watch.cancel,
            )
        })
    })?;
    Ok(RenderResult {
        out,
        stats,
        fingerprint: walk.fingerprint,
        scene_path: scene.path.clone(),
    })
}

/// An image file's pixels (an EXR's beauty, or its layer `layer`) as (width, height, float32 RGB
/// bytes).
#[pyfunction]
#[pyo3(signature = (path, layer=None))]
pub fn read_image<'py>(
    py: Python<'py>,
    path: PathBuf,
    layer: Option<String>,
) -> PyResult<(u32, u32, Bound<'py, PyByteArray>)> {
    let img = py
        .detach(|| pmrender::io::output::read_layer(&path, layer.as_deref()))
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("{}: {e}", path.display())))?;
    Ok((img.width, img.height, pixel_bytes(py, &img)))
}

/// Pixels given as float32 RGB bytes, checked against the image's size.
fn image_of(name: &str, width: u32, height: u32, bytes: &[u8]) -> PyResult<Image> {
    let n = width as usize * height as usize;
    if bytes.len() != n * 12 {
        return Err(bad_arg(
            name,
            format!(
                "{} bytes are not {width}×{height} float32 RGB pixels",
                bytes.len()
            ),
        ));
    }
    let pixels = bytes
        .chunks_exact(12)
        .map(|p| {
            let c = |i: usize| f32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
            glam::Vec3::new(c(0), c(4), c(8))
        })
        .collect();
    Ok(Image {
        width,
        height,
        pixels,
    })
}

/// Writes an image made elsewhere (tiles pasted together) as a render's EXR (beauty and named
/// layers) and PNG: both or neither.
#[pyfunction]
#[pyo3(signature = (path, width, height, beauty, layers, png=None))]
pub fn write_exr(
    py: Python<'_>,
    path: PathBuf,
    width: u32,
    height: u32,
    beauty: Vec<u8>,
    layers: Vec<(String, Vec<u8>)>,
    png: Option<PathBuf>,
) -> PyResult<()> {
    let beauty = image_of("beauty", width, height, &beauty)?;
    let named = layers
        .iter()
        .map(|(n, b)| Ok((n.as_str(), image_of(n, width, height, b)?)))
        .collect::<PyResult<Vec<_>>>()?;
    check_output("path", &path).map_err(to_py)?;
    if let Some(p) = &png {
        check_output("png", p).map_err(to_py)?;
    }
    let refs: Vec<(&str, &Image)> = named.iter().map(|(n, i)| (*n, i)).collect();
    py.detach(|| pmrender::render::write::write_images(&path, png.as_deref(), &beauty, &refs))
        .map_err(to_py)
}

/// The tiles `render(tiles=n)` and a farm split a width × height image into: (x0, y0, x1, y1) each.
#[pyfunction]
pub fn tile_windows(width: u32, height: u32, n: u32) -> Vec<(u32, u32, u32, u32)> {
    pmrender::render::tiled::tile_windows(width, height, n)
        .into_iter()
        .map(|w| (w.x0, w.y0, w.x1, w.y1))
        .collect()
}

/// `passes` and `time` checked as `--passes` and `--time` are.
fn budget(passes: Option<i64>, time: Option<f64>) -> PyResult<Budget> {
    let passes = match passes {
        Some(n) if !(1..=i64::from(MAX_PASSES)).contains(&n) => {
            return Err(bad_arg(
                "passes",
                format!("{n} must be in 1..={MAX_PASSES}"),
            ))
        }
        n => n.map(|n| n as u32),
    };
    let seconds = match time {
        Some(t) if !(t > 0.0 && t <= MAX_TIME_S) => {
            return Err(bad_arg(
                "time",
                format!("{t} must be in (0, {MAX_TIME_S:e}] seconds"),
            ))
        }
        t => t,
    };
    Ok(Budget { passes, seconds })
}
