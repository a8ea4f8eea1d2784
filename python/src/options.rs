//! Keyword arguments checked as the command line checks its options, each refusal a `ValueError`
//! naming the keyword: the render settings ([`Settings`]) and the worker pool ([`pool`]).

use pmrender::render::budget::{env_max_memory, parse_size};
use pmrender::render::tiles::Window;
use pmrender::render::Options;
use pmrender::scene::{Method, MAX_SIDE, MAX_SPP, METHODS};
use pyo3::prelude::*;

use crate::errors::{bad_arg, to_py};

/// Overrides of a scene's `[render]` and `[camera]` values, as `load_file` and `render` take them.
#[derive(Clone, Debug, Default)]
pub struct Settings {
    pub method: Option<String>,
    pub spp: Option<i64>,
    pub noise: Option<f64>,
    pub aa_spp: Option<i64>,
    pub width: Option<i64>,
    pub height: Option<i64>,
    pub seed: Option<u64>,
    pub crop: Option<(u32, u32, u32, u32)>,
    pub max_memory: Option<String>,
}

impl Settings {
    /// `self` with every value `over` gives replacing it.
    pub fn over(&self, over: &Settings) -> Settings {
        Settings {
            method: over.method.clone().or_else(|| self.method.clone()),
            spp: over.spp.or(self.spp),
            noise: over.noise.or(self.noise),
            aa_spp: over.aa_spp.or(self.aa_spp),
            width: over.width.or(self.width),
            height: over.height.or(self.height),
            seed: over.seed.or(self.seed),
            crop: over.crop.or(self.crop),
            max_memory: over.max_memory.clone().or_else(|| self.max_memory.clone()),
        }
    }

    /// The render options these settings make, checked.
    pub fn options(&self) -> PyResult<Options> {
        let method =
            match &self.method {
                Some(m) => Some(Method::parse(m).ok_or_else(|| {
                    bad_arg("method", format!("unknown method '{m}' ({METHODS})"))
                })?),
                None => None,
            };
        let noise = match self.noise {
            Some(t) if !(0.0..=1.0).contains(&t) => {
                return Err(bad_arg("noise", format!("{t} must be in 0..=1")))
            }
            t => t.map(|t| t as f32),
        };
        let max_memory = match &self.max_memory {
            Some(t) => Some(parse_size(t).ok_or_else(|| {
                bad_arg("max_memory", format!("'{t}' is not a size (e.g. 8G, 512M)"))
            })?),
            None => None,
        };
        env_max_memory().map_err(to_py)?;
        Ok(Options {
            method,
            spp: in_range("spp", self.spp, MAX_SPP)?,
            aa_spp: in_range("aa_spp", self.aa_spp, MAX_SPP)?,
            noise,
            width: in_range("width", self.width, MAX_SIDE)?,
            height: in_range("height", self.height, MAX_SIDE)?,
            seed: self.seed,
            crop: self.crop.map(|(x0, y0, x1, y1)| Window { x0, y0, x1, y1 }),
            max_memory,
            ..Default::default()
        })
    }
}

fn in_range(name: &str, v: Option<i64>, max: u32) -> PyResult<Option<u32>> {
    match v {
        Some(x) if !(1..=max as i64).contains(&x) => {
            Err(bad_arg(name, format!("{x} must be in 1..={max}")))
        }
        x => Ok(x.map(|x| x as u32)),
    }
}

/// The worker pool: `threads` (at most 4 per core, at least 16 allowed), else one per core.
pub fn pool(threads: Option<i64>) -> PyResult<rayon::ThreadPool> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let max = (4 * cores).max(16);
    let n = match threads {
        Some(t) if !(1..=max as i64).contains(&t) => {
            return Err(bad_arg(
                "threads",
                format!("{t} must be in 1..={max} (4 per core of this machine's {cores})"),
            ))
        }
        t => t.unwrap_or(0) as usize,
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!(
                "cannot start the worker threads: {e}"
            ))
        })
}
