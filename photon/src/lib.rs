//! Photon pass: emission and tracing of photons, global and caustic photon maps over FLANN kd-trees,
//! density estimates.
//!
//! `flann` is the only module with `unsafe` (FFI): the crate denies it, `flann` alone allows it, and
//! every other module forbids it.
#![deny(unsafe_code)]
#![warn(unreachable_pub)]
pub mod cells;
pub mod defaults;
mod error;
pub mod file;
mod flann;
pub mod map;
pub mod pathlog;
pub mod reach;
pub mod sampling;
pub mod trace;

pub use error::{Error, Result};
pub use file::{LoadedMaps, MapsInfo, Plausible};
pub use flann::{KdTree, Neighbor};
pub use map::{Coverage, Estimate, Filter, FullDisc, Photon, PhotonMap};
pub use pathlog::{PathLog, Reuse};
pub use trace::{
    retrace_photons, trace_photons_cancellable, EmittedRay, MapPaths, Over, PhotonMaps,
    PhotonScene, PhotonTargets, Propagation, Scatter, SurfaceHit, TraceStats,
};
