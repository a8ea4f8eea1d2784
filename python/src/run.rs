//! A render on a worker thread while the calling thread, the GIL released, waits for it: every
//! [`TICK`] it takes the GIL back to run Python's signal handlers (Ctrl-C cancels the render, which
//! stops within a second) and to hand the progress callback the fraction done. Progress is thus
//! delivered on the thread that called, which holds the GIL, never from the render's threads.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Condvar, Mutex};
use std::time::Duration;

use pmrender::error::Error;
use pmrender::render::Progress;
use pyo3::prelude::*;

use crate::errors::to_py;

/// How often the waiting thread looks at signals and progress.
const TICK: Duration = Duration::from_millis(50);

/// What the waiting thread and the render share: the cancellation flag, the phase and how far it
/// got, and whether the render is done.
pub struct Watch {
    pub cancel: AtomicBool,
    /// The phases whose progress counts, in the order they run; others are not shown.
    phases: Vec<&'static str>,
    /// The current phase's index in `phases` and its length.
    phase: Mutex<Option<(usize, u64)>>,
    at: AtomicU64,
    done: Mutex<bool>,
    woken: Condvar,
}

impl Watch {
    fn new(phases: Vec<&'static str>) -> Watch {
        Watch {
            cancel: AtomicBool::new(false),
            phases,
            phase: Mutex::new(None),
            at: AtomicU64::new(0),
            done: Mutex::new(false),
            woken: Condvar::new(),
        }
    }

    /// The fraction of the counted phases done.
    fn fraction(&self) -> f64 {
        let phase = *self.phase.lock().unwrap_or_else(|e| e.into_inner());
        match phase {
            None => 0.0,
            Some((i, total)) => {
                let within = match total {
                    0 => 0.0,
                    t => (self.at.load(Ordering::Relaxed) as f64 / t as f64).min(1.0),
                };
                (i as f64 + within) / self.phases.len() as f64
            }
        }
    }

    /// Waits up to [`TICK`] for the render to end; whether it has.
    fn wait(&self) -> bool {
        let done = self.done.lock().unwrap_or_else(|e| e.into_inner());
        let (done, _) = self
            .woken
            .wait_timeout_while(done, TICK, |d| !*d)
            .unwrap_or_else(|e| e.into_inner());
        *done
    }

    fn end(&self) {
        *self.done.lock().unwrap_or_else(|e| e.into_inner()) = true;
        self.woken.notify_all();
    }
}

impl Progress for Watch {
    fn start(&self, phase: &str, total: u64) {
        if let Some(i) = self.phases.iter().position(|p| *p == phase) {
            *self.phase.lock().unwrap_or_else(|e| e.into_inner()) = Some((i, total));
            self.at.store(0, Ordering::Relaxed);
        }
    }
    fn set(&self, done: u64) {
        self.at.store(done, Ordering::Relaxed);
    }
    fn finish(&self) {}
}

/// The phases a still's progress counts for `method`, given whether it is shaded from a bake.
pub fn still_phases(method: pmrender::scene::Method, baked: bool) -> Vec<&'static str> {
    let mut phases = Vec::new();
    if method.uses_photon_maps() && !baked {
        phases.push("photons");
    }
    if method == pmrender::scene::Method::Pm {
        phases.push("media cache");
    }
    if method.uses_cache() && !baked {
        phases.push("cache");
    }
    phases.push("shade");
    phases
}

/// Runs `work` on a worker thread with the GIL released, reporting the fraction of `phases` done to
/// `progress` (a callable taking a float in [0, 1]) and cancelling on a Python exception (Ctrl-C's
/// `KeyboardInterrupt`, or one the callback raised), which is then raised here.
pub fn detached<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    phases: Vec<&'static str>,
    work: impl FnOnce(&Watch) -> pmrender::error::Result<T> + Send,
) -> PyResult<T> {
    let watch = Watch::new(phases);
    let mut raised: Option<PyErr> = None;
    let result = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = work(&watch);
            watch.end();
            r
        });
        let mut shown = -1.0;
        loop {
            let done = py.detach(|| watch.wait());
            if raised.is_none() {
                if let Err(e) = py.check_signals() {
                    raised = Some(e);
                } else if let Some(cb) = progress {
                    let f = watch.fraction();
                    if f > shown && !done {
                        shown = f;
                        if let Err(e) = cb.call1((f,)) {
                            raised = Some(e);
                        }
                    }
                }
                if raised.is_some() {
                    watch.cancel.store(true, Ordering::SeqCst);
                }
            }
            if done {
                break;
            }
        }
        py.detach(|| worker.join())
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let result = result
        .map_err(|_| pyo3::exceptions::PyRuntimeError::new_err("the render's thread panicked"))?;
    match result {
        Ok(v) => {
            if let Some(cb) = progress {
                cb.call1((1.0,))?;
            }
            Ok(v)
        }
        Err(Error::Interrupted) => py
            .check_signals()
            .and_then(|_| Err(to_py(Error::Interrupted))),
        Err(e) => Err(to_py(e)),
    }
}
