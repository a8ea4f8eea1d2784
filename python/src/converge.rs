//! `converge`: the photon-count convergence study of the `converge` command, its table returned as
//! rows (and its files written only when asked).

use std::path::PathBuf;

use pmrender::converge::{converge as study, Study};
use pmrender::scene::{self, Method, MAX_PHOTONS, MAX_TIME_S};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors::bad_arg;
use crate::options::{pool, Settings};
use crate::run::detached;
use crate::scene::Scene;

#[pyfunction]
#[pyo3(signature = (scene, *, photons, reference, method="photons", spp=None, seed=None,
                    threads=None, out=None, progress=None, time=None))]
#[allow(clippy::too_many_arguments)]
pub fn converge<'py>(
    py: Python<'py>,
    scene: &Scene,
    photons: Vec<f64>,
    reference: PathBuf,
    method: &str,
    spp: Option<i64>,
    seed: Option<u64>,
    threads: Option<i64>,
    out: Option<PathBuf>,
    progress: Option<Bound<'py, PyAny>>,
    time: Option<Vec<f64>>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    scene.still()?;
    let counts = photons
        .iter()
        .map(|&x| {
            if (1.0..=MAX_PHOTONS as f64).contains(&x) && x.fract() == 0.0 {
                Ok(x as usize)
            } else {
                Err(bad_arg(
                    "photons",
                    format!("{x} is not a whole photon count in 1..={MAX_PHOTONS}"),
                ))
            }
        })
        .collect::<PyResult<Vec<_>>>()?;
    let times = time.unwrap_or_default();
    if let Some(t) = times.iter().find(|&&t| !(t > 0.0 && t <= MAX_TIME_S)) {
        return Err(bad_arg(
            "time",
            format!("{t} is not a time in (0, {MAX_TIME_S:e}] seconds"),
        ));
    }
    match (counts.is_empty(), times.is_empty()) {
        (true, true) => return Err(bad_arg("photons", "give at least one count (or time)")),
        (false, false) => {
            return Err(bad_arg(
                "time",
                "a study is of photons or of time: not both",
            ))
        }
        _ => {}
    }
    let method = match Method::parse(method) {
        Some(m @ (Method::Photons | Method::Pm)) => m,
        _ => {
            return Err(bad_arg(
                "method",
                format!("'{method}' must be photons or pm"),
            ))
        }
    };
    if !reference.is_file() {
        return Err(bad_arg(
            "reference",
            format!("'{}' is not a file", reference.display()),
        ));
    }
    let opts = Settings {
        spp,
        seed,
        ..Default::default()
    }
    .options()?;
    let pool = pool(threads)?;
    let path = scene.path.clone();
    // Each count's render has the still's phases; the study as a whole is the fraction of renders done.
    let phases = vec!["photons", "cache", "shade"];
    let rows = detached(py, progress.as_ref(), phases, |watch| {
        // The study sets the photon counts on the scene: a copy of it, loaded again.
        let mut s = scene::load(&path)?;
        let plan = Study {
            counts: &counts,
            times: &times,
            reference: &reference,
            method,
            out_dir: out.as_deref(),
        };
        pool.install(|| study(&mut s, &plan, &opts, watch, &watch.cancel))
    })?;
    rows.into_iter()
        .map(|r| {
            let d = PyDict::new(py);
            d.set_item("photons", r.photons)?;
            d.set_item("budget_s", r.budget_s)?;
            d.set_item("passes", r.passes)?;
            d.set_item("time_s", r.time_s)?;
            d.set_item("beauty", r.beauty)?;
            d.set_item("caustic", r.caustic)?;
            d.set_item("indirect", r.indirect)?;
            d.set_item("terms_are_reference", r.terms_are_reference)?;
            Ok(d)
        })
        .collect()
}
