//! Irradiance cache (Ward 1988, Ward & Heckbert 1992) with Tabellion–Lamorlette weighting, Křivánek's
//! neighbor clamping, an octree index, a deterministic two-pass fill driver and cache files.
//!
//! The cache knows positions, normals, irradiance and gradients only; the caller supplies shading points
//! and final gathers as closures.
#![forbid(unsafe_code)]
#![warn(unreachable_pub)]

mod cache;
mod error;
pub mod file;
mod index;
mod insert;
pub mod media;
mod onepass;
pub mod order;
pub mod params;
mod point_grid;
pub mod record;
mod report;
pub mod stats;
mod twopass;
mod validation;
mod weight;

#[cfg(test)]
mod cache_tests;
#[cfg(test)]
mod file_tests;
#[cfg(test)]
mod twopass_tests;

pub use cache::IrradianceCache;
pub use error::{Error, Result};
pub use onepass::{fill_one_pass_cancellable, OnePassFill};
pub use params::{CacheParams, Pass, Weighting};
pub use record::{Lookup, NewRecord, Record};
pub use report::CacheStats;
pub use stats::{FillStats, InsertStats, LookupStats, RadiusHistogram};
pub use twopass::{
    fill_pass_a_cancellable, fill_pixels_cancellable, PassAPixels, ShadingPoint, VisibleFn,
};
pub use validation::Validation;
