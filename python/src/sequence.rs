//! `render_sequence`: an animated scene's frames rendered on a worker thread (temporal caching as
//! the command line does it) and handed to Python one at a time as an iterator. The worker renders
//! a frame ahead at most: it waits until Python has taken the frame before.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{sync_channel, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use pmrender::error::{Error, Result};
use pmrender::render::{self, NoProgress, RenderOutput};
use pyo3::prelude::*;

use crate::errors::{bad_arg, to_py};
use crate::options::{pool, Settings};
use crate::result::RenderResult;
use crate::scene::{Kind, Scene};

/// How often a waiting `__next__` looks at signals.
const TICK: Duration = Duration::from_millis(50);

type Frame = (u32, RenderResult);

/// The frames of a sequence being rendered, in order.
#[pyclass(frozen, module = "pmrender")]
pub struct Frames {
    rx: Mutex<Option<Receiver<Frame>>>,
    cancel: Arc<AtomicBool>,
    worker: Mutex<Option<JoinHandle<Result<()>>>>,
    total: u32,
    handed: AtomicU32,
    progress: Option<Py<PyAny>>,
}

#[pymethods]
impl Frames {
    fn __iter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    /// The next (frame, result), rendered while Python worked on the one before.
    fn __next__(&self, py: Python<'_>) -> PyResult<Option<Frame>> {
        let Some(mut rx) = self.rx.lock().unwrap_or_else(|e| e.into_inner()).take() else {
            return Ok(None);
        };
        loop {
            let (back, got) = py.detach(move || {
                let got = rx.recv_timeout(TICK);
                (rx, got)
            });
            rx = back;
            match got {
                Ok(frame) => {
                    *self.rx.lock().unwrap_or_else(|e| e.into_inner()) = Some(rx);
                    let n = self.handed.fetch_add(1, Ordering::Relaxed) + 1;
                    if let Some(cb) = &self.progress {
                        if let Err(e) = cb.call1(py, (n as f64 / self.total as f64,)) {
                            self.stop();
                            return Err(e);
                        }
                    }
                    return Ok(Some(frame));
                }
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.stop();
                        return Err(e);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => return self.ended(py),
            }
        }
    }
}

impl Frames {
    /// Cancels the render; its thread ends at its next check, or when it finds no one taking frames.
    fn stop(&self) {
        self.cancel.store(true, Ordering::SeqCst);
        self.rx.lock().unwrap_or_else(|e| e.into_inner()).take();
    }

    /// The worker is done: its error, if any, else the end of the iteration.
    fn ended(&self, py: Python<'_>) -> PyResult<Option<Frame>> {
        let worker = self.worker.lock().unwrap_or_else(|e| e.into_inner()).take();
        let Some(worker) = worker else {
            return Ok(None);
        };
        match py.detach(|| worker.join()) {
            Ok(Ok(())) => Ok(None),
            Ok(Err(e)) => Err(to_py(e)),
            Err(_) => Err(pyo3::exceptions::PyRuntimeError::new_err(
                "the sequence's thread panicked",
            )),
        }
    }
}

impl Drop for Frames {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A frame's output without the cache and photons it shares with the frames after it.
fn frame_output(out: &RenderOutput) -> RenderOutput {
    RenderOutput {
        beauty: out.beauty.clone(),
        layers: out.layers.clone(),
        cache: None,
        photons: None,
        media_records: out.media_records.clone(),
        radiance_records: out.radiance_records.clone(),
        camera: out.camera.clone(),
    }
}

#[pyfunction]
#[pyo3(signature = (scene, *, frames=None, method=None, spp=None, width=None, height=None,
                    seed=None, threads=None, noise=None, aa_spp=None, max_memory=None,
                    chunk=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn render_sequence(
    scene: &Scene,
    frames: Option<(u32, u32)>,
    method: Option<String>,
    spp: Option<i64>,
    width: Option<i64>,
    height: Option<i64>,
    seed: Option<u64>,
    threads: Option<i64>,
    noise: Option<f64>,
    aa_spp: Option<i64>,
    max_memory: Option<String>,
    chunk: Option<u32>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Frames> {
    let Kind::Animated(anim) = &scene.kind else {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "'{}' has no [animation]: render it with render",
            scene.path.display()
        )));
    };
    let n = anim.frames();
    let (first, last) = frames.unwrap_or((0, n - 1));
    if first > last || last >= n {
        return Err(bad_arg(
            "frames",
            format!(
                "{first}..={last} is not within the sequence's frames 0..={}",
                n - 1
            ),
        ));
    }
    if chunk == Some(0) {
        return Err(bad_arg("chunk", "0 must be at least 1"));
    }
    let mut opts = scene
        .settings
        .over(&Settings {
            method,
            spp,
            noise,
            aa_spp,
            width,
            height,
            seed,
            crop: None,
            max_memory,
        })
        .options()?;
    opts.chunk = chunk;
    if scene.settings.crop.is_some() {
        return Err(bad_arg("crop", "is for still scenes"));
    }
    let pool = pool(threads)?;
    let (tx, rx) = sync_channel::<Frame>(0);
    let cancel = Arc::new(AtomicBool::new(false));
    let (anim, flag, path) = (anim.clone(), cancel.clone(), scene.path.clone());
    let worker = std::thread::Builder::new()
        .name("pmrender-sequence".into())
        .spawn(move || {
            pool.install(|| {
                let mut on_frame = |f: u32, s: &pmrender::scene::Scene, out: &_, stats: &_| {
                    let result = RenderResult {
                        out: frame_output(out),
                        stats: render::RenderStats::clone(stats),
                        fingerprint: s.fingerprint,
                        scene_path: path.clone(),
                    };
                    // No one takes frames any more: the iterator was dropped or stopped.
                    tx.send((f, result)).map_err(|_| Error::Interrupted)
                };
                render::sequence::render_sequence(
                    &anim,
                    first..=last,
                    &opts,
                    &NoProgress,
                    &flag,
                    &mut on_frame,
                )
            })
        })
        .map_err(|e| {
            pyo3::exceptions::PyRuntimeError::new_err(format!("cannot start the sequence: {e}"))
        })?;
    Ok(Frames {
        rx: Mutex::new(Some(rx)),
        cancel,
        worker: Mutex::new(Some(worker)),
        total: last - first + 1,
        handed: AtomicU32::new(0),
        progress,
    })
}
