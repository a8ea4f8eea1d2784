//! `bake` and `load_bake`: the photon maps and caches of a render, made once and shaded from many
//! times (`render(scene, bake=...)`), saved and loaded as one file.

use std::path::PathBuf;

use pmrender::render::baked::{bake_apart, Baked};
use pmrender::render::outputs::check_output;
use pmrender::render::RenderStats;
use pyo3::prelude::*;

use crate::errors::to_py;
use crate::options::{pool, Settings};
use crate::run::{detached, still_phases};
use crate::scene::{Kind, Scene};
use pmrender::render::shared_bake::bake_walk;

/// The photon maps and caches a render shades from.
#[pyclass(frozen, module = "pmrender")]
pub struct Bake {
    pub baked: Baked,
    /// What making it did (None once loaded from a file).
    stats: Option<RenderStats>,
}

#[pymethods]
impl Bake {
    /// The method the bake was made for.
    #[getter]
    fn method(&self) -> &'static str {
        self.baked.method.name()
    }

    /// The bake's statistics as `--stats` JSON text (None for a bake loaded from a file).
    fn stats_json(&self) -> PyResult<Option<String>> {
        self.stats
            .as_ref()
            .map(|s| {
                serde_json::to_string(&s.report().to_json())
                    .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(e.to_string()))
            })
            .transpose()
    }

    /// The bake's file as bytes (to ship it to another process).
    fn to_bytes<'py>(&self, py: Python<'py>) -> Bound<'py, pyo3::types::PyBytes> {
        pyo3::types::PyBytes::new(py, &self.baked.to_bytes())
    }

    /// Writes the bake to `path` (all or nothing).
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        check_output("path", &path).map_err(to_py)?;
        py.detach(|| self.baked.save(&path)).map_err(to_py)
    }
}

#[pyfunction]
#[pyo3(signature = (scene, *, method=None, spp=None, width=None, height=None, seed=None,
                    threads=None, noise=None, aa_spp=None, crop=None, max_memory=None,
                    progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn bake(
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
) -> PyResult<Bake> {
    let settings = scene.settings.over(&Settings {
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
    let opts = settings.options()?;
    let pool = pool(threads)?;
    // An animated scene's bake is its walk's: one for every frame (render(frame=...) shades them).
    if let Kind::Animated(anim) = &scene.kind {
        if opts.crop.is_some() {
            return Err(pyo3::exceptions::PyValueError::new_err(
                "crop: a walk's bake covers every frame's whole view: leave out crop",
            ));
        }
        let phases = vec![
            "photons",
            "media cache",
            "filling the cache over the frames' views",
        ];
        let (baked, stats) = detached(py, progress.as_ref(), phases, |watch| {
            pool.install(|| bake_walk(anim, &opts, watch, &watch.cancel))
        })?;
        return Ok(Bake {
            baked,
            stats: Some(stats),
        });
    }
    let still = scene.still()?.clone();
    let method = pmrender::render::method(&still, &opts);
    let mut phases = still_phases(method, false);
    phases.retain(|p| *p != "shade");
    let (baked, stats) = detached(py, progress.as_ref(), phases, |watch| {
        pool.install(|| bake_apart(&still, &opts, watch, &watch.cancel))
    })?;
    Ok(Bake {
        baked,
        stats: Some(stats),
    })
}

#[pyfunction]
pub fn load_bake(py: Python<'_>, path: PathBuf) -> PyResult<Bake> {
    let baked = py.detach(|| Baked::load(&path)).map_err(to_py)?;
    Ok(Bake { baked, stats: None })
}

/// A bake from the bytes `Bake.to_bytes` gave.
#[pyfunction]
pub fn bake_from_bytes(data: &[u8]) -> PyResult<Bake> {
    let baked = Baked::from_bytes(data).map_err(pyo3::exceptions::PyValueError::new_err)?;
    Ok(Bake { baked, stats: None })
}
