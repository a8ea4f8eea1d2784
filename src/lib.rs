//! pmrender: a two-pass photon-mapping renderer whose final gather is cached in an irradiance cache.
//!
//! The root crate loads scenes, wraps Embree, holds materials, lights and the camera, combines the terms
//! of Jensen's split, and writes images and statistics. `photon`, `gather` and `icache` are its passes.
//!
//! `unsafe` lives only in the FFI modules — `accel` (Embree), `io::oiio` (OpenImageIO), `signal`
//! (`sigaction`) and `memory` (`getrlimit`) — each behind a safe interface; every other module forbids it.

pub(crate) mod accel;
#[forbid(unsafe_code)]
pub(crate) mod bump;
#[forbid(unsafe_code)]
pub(crate) mod camera;
#[forbid(unsafe_code)]
pub mod chart;
#[forbid(unsafe_code)]
mod chi2;
#[forbid(unsafe_code)]
pub mod converge;
#[forbid(unsafe_code)]
pub mod counters;
#[forbid(unsafe_code)]
pub(crate) mod cutout;
#[forbid(unsafe_code)]
pub(crate) mod distribution;
#[forbid(unsafe_code)]
pub mod error;
#[forbid(unsafe_code)]
pub mod export;
#[forbid(unsafe_code)]
pub mod geometry;
#[forbid(unsafe_code)]
pub(crate) mod gloss_map;
#[forbid(unsafe_code)]
pub mod integrator;
pub mod io;
#[forbid(unsafe_code)]
pub(crate) mod light;
#[forbid(unsafe_code)]
pub(crate) mod material;
#[forbid(unsafe_code)]
pub mod medium;
pub mod memory;
#[forbid(unsafe_code)]
pub mod photons;
#[forbid(unsafe_code)]
pub mod progress;
#[forbid(unsafe_code)]
pub mod render;
#[forbid(unsafe_code)]
pub mod scene;
#[forbid(unsafe_code)]
pub(crate) mod sh;
pub mod signal;
#[forbid(unsafe_code)]
pub(crate) mod stats;
#[forbid(unsafe_code)]
pub(crate) mod tangents;
#[forbid(unsafe_code)]
pub(crate) mod texture;
#[forbid(unsafe_code)]
pub mod warp;
